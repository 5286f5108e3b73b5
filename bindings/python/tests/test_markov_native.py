"""The C core's Markov sampler (mlr_markov.h) against a pure-Python reference: the generator
(xoshiro256** seeded by splitmix64, written out here from its published definition) and the
walk, whose next-state distributions come from mlayer.Markov.next_distribution (the numpy
back-off) and whose ranked steps from mlayer.Markov.ranked_next."""
from __future__ import annotations

import numpy as np
import pytest

import mlayer
from mlayer.markov import Markov, Rng

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
