"""Markov dynamics of issue 23: Dirichlet noise with a meaning (items 3), jump models of order
1 to 3 with back-off and their held-out log-likelihood (item 5)."""
from collections import Counter

import numpy as np
import pytest

import mlayer
from mlayer import InvalidArgumentError, Markov
from mlayer.manifold.markov import UNSEEN_MASS, best_order, heldout_loglik


@pytest.fixture(scope="module")
def dog_labels(mocap):
    from mlayer.manifold.primitives import PrimitiveModel
    path = mocap / "ai4a_dog_D1_008_KAN01_002.bvh"
    if not path.exists():
        pytest.skip("dog clip not found")
    model = PrimitiveModel.fit(mlayer.read_bvh(path), som=(10, 10), epochs=5, lattice=(6, 6),
                               k=8)
    return model.labels, 8


def _tv(A, B):
    return 0.5 * np.abs(A - B).sum(axis=1).mean()


def test_noise_zero_is_the_learned_chain(dog_labels):
    lab, k = dog_labels
    mk = Markov.fit(lab, k)
    np.testing.assert_array_equal(mk.perturbed(0.0, seed=3).P, mk.P)
    np.testing.assert_array_equal(mk.perturbed(0.0, seed=3).jump_matrix(), mk.jump_matrix())
    q = mk.perturbed(1e-9, seed=3)
    np.testing.assert_allclose(q.P, mk.P, atol=1e-3)
    np.testing.assert_allclose(q.jump_matrix(), mk.jump_matrix(), atol=1e-3)
    # the most likely chain (equation 5) of a barely perturbed matrix is the learned one's
    for s in range(k):
        np.testing.assert_array_equal(q.most_likely_path(s, 20), mk.most_likely_path(s, 20))
        np.testing.assert_array_equal(mk.sample(s, 200, noise=1e-12, seed=5, distinct=True),
                                      mk.sample(s, 200, seed=5, distinct=True))


def test_divergence_grows_with_noise(dog_labels):
    lab, k = dog_labels
    mk = Markov.fit(lab, k)
    noises = [0.003, 0.01, 0.03, 0.1, 0.3, 1.0, 3.0]
    tv = [np.mean([_tv(mk.perturbed(s, seed=i).P, mk.P) for i in range(60)]) for s in noises]
    tvj = [np.mean([_tv(mk.perturbed(s, seed=i).jump_matrix(), mk.jump_matrix())
                    for i in range(60)]) for s in noises]
    assert np.all(np.diff(tv) > 0), tv
    assert np.all(np.diff(tvj) > 0), tvj
    # (measured on the dog, k = 8: TV of P 0.015 at noise 0.003, 0.17 at 3; the jump rows,
    # less certain than the sticky frame-to-frame rows, move more)
    assert tv[-1] > 10 * tv[0] and tvj[-1] > tv[-1]


def test_dirichlet_mean_and_variance_formula():
    # Var[r'_k] = r_k (1 - r_k) noise / (1 + noise) and E[r'] = r (the documented formula)
    P = np.array([[0.5, 0.3, 0.2, 0.0], [0.1, 0.6, 0.0, 0.3], [0.25, 0.25, 0.25, 0.25],
                  [0.0, 0.0, 0.1, 0.9]])
    mk = Markov(P)
    for noise in (0.05, 0.5):
        draws = np.array([mk.perturbed(noise, seed=i).P for i in range(3000)])
        np.testing.assert_allclose(draws.mean(0), P, atol=0.015)
        want = P * (1 - P) * noise / (1 + noise)
        np.testing.assert_allclose(draws.var(0), want, rtol=0.12, atol=1e-12)


def test_unseen_transitions_stay_zero_unless_asked(dog_labels):
    lab, k = dog_labels
    mk = Markov.fit(lab, k)
    zero = mk.P == 0
    J = mk.jump_matrix()
    assert zero.any()
    for s in (0.05, 0.5, 5.0):
        for seed in range(10):
            q = mk.perturbed(s, seed=seed)
            assert (q.P[zero] == 0).all() and (q.jump_matrix()[J == 0] == 0).all()
            np.testing.assert_allclose(q.P.sum(1), 1.0)
    # allow_unseen: the centres give UNSEEN_MASS of each row to its unseen transitions
    draws = [mk.perturbed(0.05, seed=i, allow_unseen=True).P for i in range(400)]
    rows = zero.any(axis=1) & (mk.counts.sum(1) > 0)
    mass = np.mean([(d * zero).sum(1)[rows] for d in draws], axis=0)
    np.testing.assert_allclose(mass, UNSEEN_MASS, rtol=0.3)
    c = mk.perturbed(0.0, allow_unseen=True).P
    np.testing.assert_allclose((c * zero).sum(1)[rows], UNSEEN_MASS)
    np.testing.assert_allclose(c[~zero & rows[:, None]],
                               ((1 - UNSEEN_MASS) * mk.P)[~zero & rows[:, None]])


def test_noise_bad_input():
    mk = Markov(np.eye(2)[[1, 0]])
    for bad in (-0.1, float("nan"), float("inf"), "x"):
        with pytest.raises(InvalidArgumentError, match="noise"):
            mk.perturbed(bad)
    with pytest.raises(InvalidArgumentError, match="allow_unseen"):
        mk.perturbed(0.1, allow_unseen="yes")


# ---- orders ------------------------------------------------------------------------------------

def _second_order_labels(reps=40, run=3):
    """Distinct sequence 0 1 2 1 0 1 2 1 ...: after 1 comes 2 when 0 came before, else 0."""
    d = [0, 1, 2, 1] * reps
    return np.repeat(d, run)


def test_contexts_count_like_a_direct_count():
    rng = np.random.default_rng(4)
    seqs = [rng.integers(4, size=300), rng.integers(4, size=120)]
    mk = Markov.fit(seqs, 4, order=3)
    ref = Counter()
    for s in seqs:
        d = [int(v) for i, v in enumerate(s) if i == 0 or v != s[i - 1]]
        for L in (2, 3):
            for t in range(L, len(d)):
                ref[(tuple(d[t - L:t]), d[t])] += 1
    got = Counter()
    for ctx, (cnt, row) in mk.contexts.items():
        assert cnt == pytest.approx(sum(v for (c, _), v in ref.items() if c == ctx))
        for nxt in range(4):
            if row[nxt] > 0:
                got[(ctx, nxt)] = round(row[nxt] * cnt)
    assert got == ref
    # order 1: the jump matrix (the off-diagonal counts)
    C = mk.counts.copy()
    np.fill_diagonal(C, 0)
    np.testing.assert_allclose(mk.jump_matrix(), C / C.sum(1, keepdims=True))


def test_second_order_structure_is_learned_and_preferred():
    lab = _second_order_labels()
    m1, m2 = Markov.fit(lab, 3, order=1), Markov.fit(lab, 3, order=2)
    np.testing.assert_allclose(m1.next_distribution([0, 1]), [0.5, 0, 0.5], atol=0.02)
    np.testing.assert_allclose(m2.next_distribution([0, 1]), [0, 0, 1])
    np.testing.assert_allclose(m2.next_distribution([2, 1]), [1, 0, 0])
    np.testing.assert_array_equal(m2.most_likely_path(0, 9), [0, 1, 2, 1, 0, 1, 2, 1, 0])
    np.testing.assert_array_equal(m2.sample(1, 8, seed=2, distinct=True, history=[2]),
                                  [1, 0, 1, 2, 1, 0, 1, 2])
    ll = heldout_loglik([lab], 3)
    # order 1: the jumps after 1 (half of them) are a coin toss, the others certain
    assert ll[1][0] == pytest.approx(-np.log(2) / 2, abs=0.005) and ll[2][1] > 20
    assert ll[2][0] > ll[1][0] + 0.3
    assert abs(ll[2][0]) < 0.01 and ll[3][0] == pytest.approx(ll[2][0])
    assert best_order(ll) == 2


def test_backoff_uses_long_contexts_only_where_seen_often():
    lab = np.r_[_second_order_labels(reps=10), np.repeat([3, 1, 3, 0], 3)]
    fixed = Markov.fit(lab, 4, order=2, min_count=1)
    var = Markov.fit(lab, 4, order=2, min_count=3)
    assert fixed.contexts[(3, 1)][0] == 1
    assert fixed.context_length([3, 1]) == 2 and var.context_length([3, 1]) == 1
    assert var.context_length([0, 1]) == 2
    np.testing.assert_allclose(var.next_distribution([3, 1]), var.jump_matrix()[1])
    # a context never seen backs off too
    assert fixed.context_length([2, 3]) == 1


def test_held_out_log_likelihood_on_the_shared_clips(mocap):
    from mlayer.manifold.primitives import PrimitiveModel
    for name, frames in (("cmu_131_01_mj_style_walk.bvh", None), ("lafan1_clip_a.bvh", 1200),
                         ("bandai1_walk_happy_001.bvh", None),
                         ("ai4a_dog_D1_008_KAN01_002.bvh", None)):
        path = mocap / name
        if not path.exists():
            continue
        m = mlayer.read_bvh(path)
        m = m[:frames] if frames else m
        model = PrimitiveModel.fit(m, som=(10, 10), epochs=5, lattice=(6, 6), k=8,
                                   order="auto")
        ll = model.order_loglik
        assert set(ll) == {1, 2, 3} and ll[1][1] > 10
        assert all(np.isfinite(v) and v <= 0 for v, _ in ll.values())
        assert model.markov.order == best_order(ll)
        # the same figures from the function itself
        assert heldout_loglik(model.clip_labels(), 8) == ll


def test_order_bad_input():
    lab = _second_order_labels(reps=3)
    for bad in (0, 4, -1, 1.5, "2"):
        with pytest.raises(InvalidArgumentError, match="order"):
            Markov.fit(lab, 3, order=bad)
    with pytest.raises(InvalidArgumentError, match="min_count"):
        Markov.fit(lab, 3, order=2, min_count=0)
    with pytest.raises(InvalidArgumentError, match="out of range"):
        Markov.fit(lab, 3, order=2).next_distribution([0, 7])
    with pytest.raises(InvalidArgumentError, match="rank"):
        Markov.fit(lab, 3).ranked_next([0], 0)
