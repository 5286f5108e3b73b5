"""First-order Markov model over motion-primitive labels (paper 2, section 4.2).

``P[j, k]`` is the probability that a frame of primitive j is followed by a frame of primitive
k, counted over consecutive frames of the training clips (rows sum to 1). The paper writes the
same matrix transposed (p_{k,j} = P(C_k at t+1 | C_j at t)); equation 5, the most likely next
primitive other than the current one, is :meth:`Markov.most_likely_next`.
"""
from __future__ import annotations

import math

import numpy as np

from .errors import InvalidArgumentError
from ._args import integer

__all__ = ["Markov"]


def _labels(a, name: str) -> np.ndarray:
    arr = np.asarray(a)
    if arr.ndim != 1:
        raise InvalidArgumentError(f"{name}: labels must be 1-D, got shape {arr.shape}")
    if arr.size and not np.issubdtype(arr.dtype, np.integer):
        if np.issubdtype(arr.dtype, np.floating) and np.isfinite(arr).all() \
                and (arr == np.round(arr)).all():
            arr = arr.astype(np.int64)
        else:
            raise InvalidArgumentError(f"{name}: labels must be integers, got {arr.dtype}")
    return arr.astype(np.int64, copy=False)


def _state(j, n: int, name: str = "state") -> int:
    j = integer(j, name)
    if not 0 <= j < n:
        raise InvalidArgumentError(f"{name} {j} out of range: the model has {n} states "
                                   f"(0 .. {n - 1})")
    return int(j)


class Markov:
    """A transition matrix ``P`` (n, n), rows summing to 1, plus the transition counts and the
    mean run length (frames spent in a state before leaving it) of each state."""

    def __init__(self, P, counts=None, run_length=None):
        P = np.array(P, dtype=np.float64)
        if P.ndim != 2 or P.shape[0] != P.shape[1] or P.shape[0] == 0:
            raise InvalidArgumentError(f"Markov: P must be a non-empty square matrix, got "
                                       f"shape {P.shape}")
        if not np.isfinite(P).all() or (P < 0).any() \
                or not np.allclose(P.sum(axis=1), 1.0, rtol=0, atol=1e-9):
            raise InvalidArgumentError("Markov: P must be finite, non-negative, rows summing "
                                       "to 1")
        self.P = P
        n = P.shape[0]
        self.counts = np.zeros((n, n)) if counts is None else np.asarray(counts, np.float64)
        if run_length is None:
            stay = np.diag(P)
            with np.errstate(divide="ignore"):
                run_length = np.where(stay < 1.0, 1.0 / (1.0 - stay), np.inf)
        self.run_length = np.asarray(run_length, dtype=np.float64)

    @property
    def n_states(self) -> int:
        return self.P.shape[0]

    @classmethod
    def fit(cls, labels, n_states: int | None = None) -> "Markov":
        """Count transitions between consecutive labels.

        labels: a 1-D integer array, or a list of them (one per clip: no transition is counted
        across clips). n_states: default max label + 1. A state that is never left in the data
        (no outgoing transition) gets a uniform row. ``run_length[j]`` is the mean length of
        the runs of label j in the data (1 if j never occurs).
        """
        if isinstance(labels, (list, tuple)) and labels and not np.isscalar(labels[0]):
            seqs = [_labels(s, f"labels[{i}]") for i, s in enumerate(labels)]
        else:
            seqs = [_labels(labels, "labels")]
        total = sum(s.size for s in seqs)
        if total == 0:
            raise InvalidArgumentError("Markov.fit: no labels")
        lo = min(int(s.min()) for s in seqs if s.size)
        hi = max(int(s.max()) for s in seqs if s.size)
        if n_states is None:
            n_states = hi + 1
        n = integer(n_states, "Markov.fit: n_states", 1)
        if lo < 0 or hi >= n:
            raise InvalidArgumentError(f"Markov.fit: labels out of range: found {lo} .. {hi} "
                                       f"for {n} states (0 .. {n - 1})")
        C = np.zeros((n, n))
        runs = np.zeros(n)
        run_frames = np.zeros(n)
        for s in seqs:
            if s.size > 1:
                np.add.at(C, (s[:-1], s[1:]), 1.0)
            if s.size:
                starts = np.flatnonzero(np.r_[True, s[1:] != s[:-1]])
                lengths = np.diff(np.r_[starts, s.size])
                np.add.at(runs, s[starts], 1.0)
                np.add.at(run_frames, s[starts], lengths)
        rows = C.sum(axis=1, keepdims=True)
        P = np.where(rows > 0, C / np.where(rows > 0, rows, 1.0), 1.0 / n)
        run_length = np.where(runs > 0, run_frames / np.maximum(runs, 1), 1.0)
        return cls(P, C, run_length)

    def most_likely_next(self, j: int) -> int:
        """Equation 5: k* = argmax_{k != j} P[j, k], the most likely next distinct primitive
        (lowest index on ties). Returns -1 when the model has one state."""
        j = _state(j, self.n_states)
        if self.n_states == 1:
            return -1
        row = self.P[j].copy()
        row[j] = -1.0
        return int(np.argmax(row))

    def most_likely_path(self, start: int, n: int | None = None) -> np.ndarray:
        """Follow :meth:`most_likely_next` from start: n states (default: until a state repeats,
        the cycle of paper Figure 3 (c), the repeated state included)."""
        s = _state(start, self.n_states, "start")
        path = [s]
        limit = n if n is not None else self.n_states + 1
        while len(path) < limit:
            s = self.most_likely_next(s)
            if s < 0:
                break
            path.append(s)
            if n is None and s in path[:-1]:
                break
        return np.array(path, dtype=np.int64)

    def perturbed(self, scale: float, seed: int = 0) -> "Markov":
        """A model whose matrix is P + scale * U(0, 1) noise on every element, rows
        renormalized (paper section 5.2: the scale controls the deviation from the data)."""
        if not (math.isfinite(scale) and scale >= 0):
            raise InvalidArgumentError(f"Markov: noise scale must be finite and >= 0, got "
                                       f"{scale!r}")
        seed = integer(seed, "Markov: seed", 0)
        rng = np.random.default_rng(seed)
        Q = self.P + scale * rng.random(self.P.shape)
        Q /= Q.sum(axis=1, keepdims=True)
        return Markov(Q, self.counts, self.run_length)

    def jump_matrix(self) -> np.ndarray:
        """Transitions between distinct states: P with the diagonal removed, rows renormalized
        (a state that only stays goes uniformly to the others)."""
        n = self.n_states
        Q = self.P.copy()
        np.fill_diagonal(Q, 0.0)
        s = Q.sum(axis=1, keepdims=True)
        if n == 1:
            return np.ones((1, 1))
        uniform = (1.0 - np.eye(n)) / (n - 1)
        return np.where(s > 0, Q / np.where(s > 0, s, 1.0), uniform)

    def sample(self, start: int, n: int, noise: float = 0.0, seed: int = 0, *,
               distinct: bool = False) -> np.ndarray:
        """A seeded sequence of n states beginning with start.

        noise: scale of the perturbation of P (:meth:`perturbed`, same seed) before sampling.
        distinct: sample the chain of distinct primitives (each step leaves the current state,
        :meth:`jump_matrix`) rather than frame-to-frame transitions. The same arguments give
        the same sequence.
        """
        s = _state(start, self.n_states, "start")
        n = integer(n, "sample: n", 1)
        if not (math.isfinite(noise) and noise >= 0):
            raise InvalidArgumentError(f"sample: noise must be finite and >= 0, got {noise!r}")
        model = self.perturbed(noise, seed) if noise > 0 else self
        T = model.jump_matrix() if distinct else model.P
        cum = np.cumsum(T, axis=1)
        cum[:, -1] = 1.0
        u = np.random.default_rng([seed, 1]).random(n - 1)
        out = np.empty(n, dtype=np.int64)
        out[0] = s
        for i in range(1, n):
            s = int(np.searchsorted(cum[s], u[i - 1], side="right"))
            out[i] = s
        return out

    def stationary(self) -> np.ndarray:
        """Stationary distribution (left eigenvector of P for eigenvalue 1, normalized)."""
        w, v = np.linalg.eig(self.P.T)
        p = np.abs(np.real(v[:, np.argmin(np.abs(w - 1.0))]))
        return p / p.sum()
