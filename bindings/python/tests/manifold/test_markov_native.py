"""The C core's Markov sampler (mlr_markov.h) against a pure-Python reference: the generator
(xoshiro256** seeded by splitmix64, written out here from its published definition) and the
walk, whose next-state distributions come from mlayer.Markov.next_distribution (the numpy
back-off) and whose ranked steps from mlayer.Markov.ranked_next."""
from __future__ import annotations

import math

import numpy as np
import pytest

import mlayer
from mlayer.manifold.markov import Markov, Rng

M64 = (1 << 64) - 1


class RefRng:
    def __init__(self, seed: int) -> None:
        x = seed
        self.s = []
        for _ in range(4):
            x = (x + 0x9E3779B97F4A7C15) & M64
            z = x
            z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & M64
            z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & M64
            self.s.append(z ^ (z >> 31))

    @staticmethod
    def _rotl(x: int, k: int) -> int:
        return ((x << k) | (x >> (64 - k))) & M64

    def u64(self) -> int:
        s = self.s
        out = (self._rotl((s[1] * 5) & M64, 7) * 9) & M64
        t = (s[1] << 17) & M64
        s[2] ^= s[0]
        s[3] ^= s[1]
        s[1] ^= s[2]
        s[0] ^= s[3]
        s[2] ^= t
        s[3] = self._rotl(s[3], 45)
        return out

    def uniform(self) -> float:
        return (self.u64() >> 11) * 2.0 ** -53

    def below(self, n: int) -> int:
        lim = M64 - M64 % n
        while True:
            v = self.u64()
            if v < lim:
                return v % n


def ref_walk(mk: Markov, start: int, n_frames: int, rank: int, rng: RefRng) -> list[int]:
    dur = np.maximum(mk.run_length, 1.0)
    path, total = [start], 0.0
    while total < n_frames:
        if rank:
            nxt = mk.ranked_next(path[-mk.order:], rank)
            if nxt < 0:
                break
        else:
            p = mk.next_distribution(path[-mk.order:])
            last = int(np.flatnonzero(p > 0)[-1])
            u, cum, nxt = rng.uniform(), 0.0, last
            for k in range(last):
                cum += p[k]
                if cum > u:
                    nxt = k
                    break
        total += (dur[path[-1]] + dur[nxt]) / 2.0
        path.append(int(nxt))
    return path


def _model(order: int, min_count: int, seed: int = 0, n: int = 6) -> Markov:
    rng = np.random.default_rng(seed)
    # runs of random lengths, so that run lengths and contexts are uneven
    clips = [np.repeat(rng.integers(0, n, 60), rng.integers(1, 6, 60)) for _ in range(3)]
    return Markov.fit(clips, n, order=order, min_count=min_count)


@pytest.mark.parametrize("seed", [0, 1, 12345, 2**64 - 1])
def test_rng_matches_the_reference(seed: int) -> None:
    a, b = Rng(seed), RefRng(seed)
    assert [a.uniform() for _ in range(50)] == [b.uniform() for _ in range(50)]
    assert [a.below(7) for _ in range(50)] == [b.below(7) for _ in range(50)]
    assert [a.below(2**63 + 5) for _ in range(20)] == [b.below(2**63 + 5) for _ in range(20)]


@pytest.mark.parametrize("order,min_count", [(1, 1), (2, 1), (3, 1), (3, 3), (2, 4)])
@pytest.mark.parametrize("seed", [0, 7])
def test_sampled_walk_matches_numpy_back_off(order: int, min_count: int, seed: int) -> None:
    mk = _model(order, min_count, seed)
    for start in range(mk.n_states):
        got = mk.walk(start, 200, seed=seed + start)
        want = ref_walk(mk, start, 200, 0, RefRng(seed + start))
        assert got.tolist() == want
        assert (np.diff(got) != 0).all()  # distinct primitives


@pytest.mark.parametrize("order", [1, 2, 3])
@pytest.mark.parametrize("rank", [1, 2, 3])
def test_ranked_walk_matches_ranked_next(order: int, rank: int) -> None:
    mk = _model(order, 1, 3)
    for start in range(mk.n_states):
        assert mk.walk(start, 120, rank=rank).tolist() == ref_walk(mk, start, 120, rank,
                                                                   RefRng(0))


def test_perturbed_model_walks_its_own_rows() -> None:
    mk = _model(2, 1, 5).perturbed(0.5, seed=2, allow_unseen=True)
    assert mk.walk(1, 150, seed=9).tolist() == ref_walk(mk, 1, 150, 0, RefRng(9))


def test_walk_length_and_one_state() -> None:
    mk = Markov(np.ones((1, 1)), run_length=np.array([3.0]))
    assert mk.walk(0, 10, rank=1).tolist() == [0]
    assert mk.walk(0, 10).tolist() == [0] * 5  # steps of 3 frames: the fourth reaches 12
    two = _model(1, 1, 1, n=2)
    assert len(two.walk(0, 1)) == 2


def test_walk_refuses_bad_arguments() -> None:
    mk = _model(2, 1)
    with pytest.raises(mlayer.InvalidArgumentError, match="start 6 out of range"):
        mk.walk(6, 10)
    with pytest.raises(mlayer.InvalidArgumentError, match="n_frames"):
        mk.walk(0, 0)
    with pytest.raises(mlayer.InvalidArgumentError, match="rank"):
        mk.walk(0, 10, rank=-1)


def test_c_model_refuses_rows_that_are_not_distributions() -> None:
    from mlayer._native import ffi, lib
    J = np.array([[0.0, 1.0], [0.7, 0.0]])  # row 1 sums to 0.7
    rl = np.ones(2)
    out = ffi.new("mlr_markov **")
    diag = ffi.new("mlr_diag *")
    st = lib.mlr_markov_create(2, ffi.cast("double *", ffi.from_buffer(J)),
                               ffi.cast("double *", ffi.from_buffer(rl)), 1, 1, 0, ffi.NULL,
                               ffi.NULL, ffi.NULL, ffi.NULL, out, diag)
    assert st == lib.MLR_E_INVALID_ARG and out[0] == ffi.NULL
    assert "jumps row 1" in ffi.string(diag.message).decode()
    J = np.array([[0.5, 0.5], [1.0, 0.0]])  # a jump that stays
    st = lib.mlr_markov_create(2, ffi.cast("double *", ffi.from_buffer(J)),
                               ffi.cast("double *", ffi.from_buffer(rl)), 1, 1, 0, ffi.NULL,
                               ffi.NULL, ffi.NULL, ffi.NULL, out, diag)
    assert st == lib.MLR_E_INVALID_ARG and "jumps[0][0]" in ffi.string(diag.message).decode()


# ---- noise: the gamma variates and the perturbed chain ----------------------------------------

def ref_normal(r: RefRng) -> float:
    while True:
        u = 2.0 * r.uniform() - 1.0
        v = 2.0 * r.uniform() - 1.0
        q = u * u + v * v
        if 0.0 < q < 1.0:
            return u * math.sqrt(-2.0 * math.log(q) / q)


def ref_gamma(r: RefRng, a: float) -> float:
    boost = 1.0
    if a < 1.0:
        boost = math.pow(r.uniform(), 1.0 / a)
        a += 1.0
    d = a - 1.0 / 3.0
    c = 1.0 / math.sqrt(9.0 * d)
    while True:
        while True:
            x = ref_normal(r)
            v = 1.0 + c * x
            if v > 0.0:
                break
        v = v * v * v
        u = r.uniform()
        if u < 1.0 - 0.0331 * (x * x) * (x * x) or \
                math.log(u) < 0.5 * x * x + d * (1.0 - v + math.log(v)):
            return boost * d * v


def ref_redraw(row: np.ndarray, closed: int | None, noise: float, allow_unseen: bool,
               r: RefRng) -> np.ndarray:
    c = row.copy()
    n = c.size
    if allow_unseen:
        un = [k for k in range(n) if not c[k] > 0 and k != closed]
        if un and c.sum() > 0:
            c = np.where([not c[k] > 0 and k != closed for k in range(n)],
                         0.02 / len(un), c * (1.0 - 0.02))
    pos = [k for k in range(n) if c[k] > 0]
    if noise == 0 or len(pos) <= 1:
        return c
    s = 0.0
    for k in pos:
        c[k] = ref_gamma(r, c[k] / noise)
        s += c[k]
    return c / s


def ref_perturbed(mk: Markov, noise: float, allow_unseen: bool, seed: int) -> Markov:
    r = RefRng(seed ^ 0x6A09E667F3BCC908)
    n = mk.n_states
    J = np.array([ref_redraw(row, j if n > 1 else None, noise, allow_unseen, r)
                  for j, row in enumerate(mk.jump_matrix())])
    ctx = {}
    for key in sorted(mk.contexts):
        cnt, row = mk.contexts[key]
        ctx[key] = (cnt, ref_redraw(row, key[-1], noise, allow_unseen, r))
    return Markov(mk.P, mk.counts, mk.run_length, order=mk.order, min_count=mk.min_count,
                  contexts=ctx, jumps=J)


@pytest.mark.parametrize("shape", [0.05, 0.3, 1.0, 4.5, 80.0])
def test_gamma_moments(shape: float) -> None:
    from mlayer._native import lib
    r = Rng(11)
    n = 100000
    x = np.array([lib.mlr_rng_gamma(r._state, shape) for _ in range(n)])
    assert (x >= 0).all()
    # mean shape, variance shape: within 5 standard errors
    assert abs(x.mean() - shape) < 5 * math.sqrt(shape / n)
    assert abs(x.var() - shape) < 5 * math.sqrt((2 * shape ** 2 + 6 * shape) / n)
    # the same variates as the reference written from the method's definition
    r2, ref = Rng(11), RefRng(11)
    assert [lib.mlr_rng_gamma(r2._state, shape) for _ in range(200)] == \
        [ref_gamma(ref, shape) for _ in range(200)]
    assert math.isnan(lib.mlr_rng_gamma(r2._state, 0.0))


@pytest.mark.parametrize("noise,allow_unseen", [(0.3, False), (2.0, True), (0.0, True)])
@pytest.mark.parametrize("order", [1, 3])
def test_perturbed_walk_matches_the_reference(noise: float, allow_unseen: bool,
                                              order: int) -> None:
    mk = _model(order, 1, 4)
    for seed in (0, 5, 2**64 - 1):
        got = mk.walk(2, 150, seed=seed, noise=noise, allow_unseen=allow_unseen)
        want = ref_walk(ref_perturbed(mk, noise, allow_unseen, seed), 2, 150, 0, RefRng(seed))
        assert got.tolist() == want
    if noise > 0:  # the noise changes the paths
        assert any(mk.walk(2, 150, seed=s, noise=noise).tolist() != mk.walk(2, 150, seed=s)
                   .tolist() for s in range(5))


def test_perturbed_rows_have_the_dirichlet_moments() -> None:
    """E[r'] = r and Var[r'_k] = r_k (1 - r_k) noise / (1 + noise) over many seeds."""
    mk = _model(1, 1, 6)
    row = mk.jump_matrix()[0]
    noise = 0.5
    draws = np.array([ref_perturbed(mk, noise, False, s).jump_matrix()[0] for s in range(3000)])
    var = row * (1 - row) * noise / (1 + noise)
    se = np.sqrt(var / draws.shape[0])
    assert (np.abs(draws.mean(axis=0) - row) <= 5 * se + 1e-15).all()
    ok = var > 0
    assert (np.abs(draws.var(axis=0)[ok] / var[ok] - 1) < 0.15).all()
