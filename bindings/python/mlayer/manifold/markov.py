"""Markov models over motion-primitive labels (paper 2, section 4.2, and its future work).

``P[j, k]`` is the probability that a frame of primitive j is followed by a frame of primitive
k, counted over consecutive frames of the training clips (rows sum to 1). The paper writes the
same matrix transposed (p_{k,j} = P(C_k at t+1 | C_j at t)); equation 5, the most likely next
primitive other than the current one, is :meth:`Markov.most_likely_next`.

**Jumps and higher orders.** Generation follows the chain of *distinct* primitives (each run of
equal labels collapsed to one symbol; the time spent in a primitive is its mean run length).
Order 1: the jump matrix (:meth:`Markov.jump_matrix`, P without its diagonal, rows
renormalized). Order n (1 .. 3): the next distinct primitive given the last n distinct ones,
counted on the collapsed sequences of the clips. Back-off (:meth:`Markov.next_distribution`):
the longest context of length L <= order that was followed at least ``min_count`` times in the
data is used, else L - 1, down to the jump matrix (L = 1). ``min_count=1`` is a fixed-order
model (backing off only from contexts never seen); a larger ``min_count`` is the
variable-length model: it uses long contexts only where the data hold them often enough.
The frame-to-frame matrix P (sampling with ``distinct=False``) stays first order.

**Noise** (:meth:`Markov.perturbed`, paper section 5.2). Every row r of P, of the jump matrix
and of each context is redrawn from a Dirichlet distribution centred on it:
``r' ~ Dirichlet(r / noise)`` over the entries of r that are > 0, the others stay 0. So
``E[r'] = r`` and ``Var[r'_k] = r_k (1 - r_k) noise / (1 + noise)``. The concentration
1 / noise is a number of transitions: at noise = 1 / N a row varies as much as it would if it
had been estimated from N transitions drawn from it (noise 0.01: a probability of 0.5 varies
by about +-0.05; noise 1: by +-0.35). Transitions never seen stay impossible. With
``allow_unseen=True`` the centre of each row first gives
:data:`UNSEEN_MASS` (0.02) of its mass, in equal parts, to the transitions the data never saw
(of the jump rows: to the other primitives), then the same draw.

**Held-out likelihood** (:func:`heldout_loglik`): 5-fold blocked cross-validation: each clip
cut into 5 consecutive blocks, the model of each order fitted on 4 of them and scored on the
jumps that arrive in the fifth, each predicted from its full history in the clip. (A split
at the last 20% of each clip would score nothing on clips that end standing still.)
"""
from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .. import _attrs
from .._args import integer
from .._native import ffi, lib
from ..errors import InvalidArgumentError, check

__all__ = ["Markov", "Rng", "heldout_loglik", "UNSEEN_MASS", "MAX_ORDER"]

UNSEEN_MASS = 0.02  # the prior mass per row that allow_unseen gives to transitions never seen
#: the perturbation of :meth:`Markov.walk` draws from ``Rng(seed ^ NOISE_SEED_XOR)``
#: (``MLR_GEN_NOISE_SEED_XOR``: the first 64 fractional bits of sqrt(2))
NOISE_SEED_XOR = 0x6A09E667F3BCC908
MAX_ORDER = 3
HELDOUT_FOLDS = 5      # the blocks of each clip in heldout_loglik's cross-validation
HELDOUT_FLOOR = 1e-3    # mixed into each held-out prediction: see heldout_loglik


def _labels(a: Any, name: str) -> NDArray[np.int64]:
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


def _runs(s: NDArray[np.int64]) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """The distinct symbols of a label sequence (runs collapsed) and the frame each run starts."""
    if s.size == 0:
        return s[:0], np.zeros(0, dtype=np.int64)
    starts = np.flatnonzero(np.r_[True, s[1:] != s[:-1]])
    return s[starts], starts


def _order(order: int, name: str = "order") -> int:
    return integer(order, name, 1, MAX_ORDER)


def _noise(noise: float, name: str) -> float:
    try:
        f = float(noise)
    except (TypeError, ValueError):
        f = float("nan")
    if isinstance(noise, (bool, np.bool_)) or not (math.isfinite(f) and f >= 0):
        raise InvalidArgumentError(f"{name} must be finite and >= 0, got {noise!r}")
    return f


def dirichlet_rows(R: ArrayLike, noise: float, rng: np.random.Generator, *,
                   allowed: NDArray[np.bool_] | None = None,
                   allow_unseen: bool = False) -> NDArray[np.float64]:
    """Rows of a stochastic matrix redrawn from Dirichlet distributions centred on them.

    Each row r of R (summing to 1) is redrawn from Dirichlet(r / noise) over its entries > 0
    (see the module's docstring).

    Parameters
    ----------
    R : array_like, shape (m, n)
        Rows summing to 1.
    noise : float
        The scale; 0 returns a copy of R (after allow_unseen).
    rng : numpy.random.Generator
        The generator.
    allowed : numpy.ndarray of bool, shape (m, n), optional
        The entries that allow_unseen may open (default all).
    allow_unseen : bool, optional
        Give the entries that are 0 some mass (UNSEEN_MASS).

    Returns
    -------
    numpy.ndarray, shape (m, n)
        The redrawn rows.
    """
    R = np.array(R, dtype=np.float64)
    out = np.zeros_like(R)
    allowed = np.ones(R.shape, bool) if allowed is None else allowed
    for i in range(R.shape[0]):
        c = R[i].copy()
        if allow_unseen:
            un = (c <= 0) & allowed[i]
            if un.any() and c.sum() > 0:
                c *= 1.0 - UNSEEN_MASS
                c[un] = UNSEEN_MASS / un.sum()
        s = c > 0
        if noise == 0 or s.sum() <= 1:
            out[i] = c
            continue
        q = rng.dirichlet(c[s] / noise)
        if not (np.isfinite(q).all() and q.sum() > 0):  # every gamma draw underflowed
            q = np.zeros(s.sum())
            q[int(np.argmax(c[s]))] = 1.0
        out[i, s] = q / q.sum()
    return out


class Rng(_attrs.ReadOnlyAttributes):
    """The C core's seeded generator (``mlr_rng``, ``mlr_markov.h``): xoshiro256** seeded by
    splitmix64. The same seed gives the same numbers here and in a C program, which is what
    makes :meth:`Markov.walk` and ``mlayer generate`` reproducible at run time.

    Parameters
    ----------
    seed : int
        0 .. 2^64 - 1; the read-only attribute ``seed``.
    """

    seed: int
    _readonly = ("seed",)

    def __init__(self, seed: int = 0) -> None:
        seed = integer(seed, "Rng: seed", 0, 2**64 - 1)
        self.seed = int(seed)
        self._state = ffi.new("mlr_rng *")
        lib.mlr_rng_seed(self._state, seed)

    def below(self, n: int) -> int:
        """A uniform integer in [0, n) (``mlr_rng_below``: unbiased, by rejection).

        Parameters
        ----------
        n : int
            >= 1.

        Returns
        -------
        int
            The integer; the generator advances.
        """
        n = integer(n, "Rng.below: n", 1)
        return int(lib.mlr_rng_below(self._state, n))

    def uniform(self) -> float:
        """A uniform float in [0, 1) (``mlr_rng_uniform``: the top 53 bits times 2^-53).

        Returns
        -------
        float
            The number; the generator advances.
        """
        return float(lib.mlr_rng_uniform(self._state))


def _state(j: Any, n: int, name: str = "state") -> int:
    j = integer(j, name)
    if not 0 <= j < n:
        raise InvalidArgumentError(f"{name} {j} out of range: the model has {n} states "
                                   f"(0 .. {n - 1})")
    return int(j)


class Markov(_attrs.ReadOnlyAttributes):
    """A Markov model of primitive labels.

    A transition matrix ``P`` (n, n), rows summing to 1, plus the transition counts and the
    mean run length (frames spent in a state before leaving it) of each state; and the jump
    model of the distinct primitives: ``order`` (1 .. 3), ``min_count`` (the back-off rule)
    and ``contexts``. These are attributes of the same names; ``min_count`` can be assigned
    (an integer >= 1, else InvalidArgumentError), the others are read-only (they were
    estimated together: make a new Markov, or :meth:`perturbed`).

    Parameters
    ----------
    P : array_like, shape (n, n)
        Finite, non-negative, rows summing to 1.
    counts : array_like, shape (n, n), optional
        Transition counts (default zeros).
    run_length : array_like, shape (n,), optional
        Mean run length per state (default ``1 / (1 - P[j, j])``).
    order : int, optional
        Order of the jump model, 1 .. 3.
    min_count : int, optional
        Times a context must have been followed to be used (the back-off rule).
    contexts : dict, optional
        Tuple of 2 .. order distinct states, the last the current one -> (times seen,
        probabilities (n,) of the next distinct state).
    jumps : array_like, shape (n, n), optional
        A jump matrix of its own (a perturbed model's); default from P.

    Raises
    ------
    mlayer.InvalidArgumentError
        For a P that is not a stochastic matrix or parameters out of range.
    """
    counts: NDArray[np.float64]
    run_length: NDArray[np.float64]
    order: int
    min_count: int
    contexts: dict[tuple[int, ...], tuple[float, NDArray[np.float64]]]

    _readonly = ("P", "counts", "run_length", "order", "contexts")
    _checked = {"min_count": _attrs.integer(1)}

    def __init__(self, P: ArrayLike, counts: ArrayLike | None = None,
                 run_length: ArrayLike | None = None, *, order: int = 1, min_count: int = 1,
                 contexts: Mapping[tuple[int, ...], tuple[float, NDArray[np.float64]]]
                 | None = None, jumps: ArrayLike | None = None) -> None:
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
        self.order = _order(order, "Markov: order")
        self.min_count = integer(min_count, "Markov: min_count", 1)
        self.contexts = dict(contexts or {})
        self._jumps = None if jumps is None else np.asarray(jumps, dtype=np.float64)

    @property
    def n_states(self) -> int:
        """The number of states n."""
        return self.P.shape[0]

    @classmethod
    def fit(cls, labels: ArrayLike | Sequence[ArrayLike], n_states: int | None = None, *,
            order: int = 1, min_count: int = 1) -> Markov:
        """Count transitions between consecutive labels.

        A state that is never left in the data (no outgoing transition) gets a uniform row.
        ``run_length[j]`` is the mean length of the runs of label j in the data (1 if j never
        occurs).

        Parameters
        ----------
        labels : array_like of int, or a list of them
            One sequence, or one per clip (no transition is counted across clips).
        n_states : int, optional
            Default max label + 1.
        order : int, optional
            1 .. 3: the jump model of the distinct primitives (see the module's docstring).
        min_count : int, optional
            >= 1: its back-off rule.

        Returns
        -------
        Markov
            The model.

        Raises
        ------
        mlayer.InvalidArgumentError
            For no labels or labels out of range.
        """
        order = _order(order)
        min_count = integer(min_count, "min_count", 1)
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
        ctx_counts: dict = {}
        for s in seqs:
            if s.size > 1:
                np.add.at(C, (s[:-1], s[1:]), 1.0)
            if s.size:
                starts = np.flatnonzero(np.r_[True, s[1:] != s[:-1]])
                lengths = np.diff(np.r_[starts, s.size])
                np.add.at(runs, s[starts], 1.0)
                np.add.at(run_frames, s[starts], lengths)
                d = s[starts].tolist()
                for L in range(2, order + 1):
                    for t in range(L, len(d)):
                        row = ctx_counts.setdefault(tuple(d[t - L:t]), np.zeros(n))
                        row[d[t]] += 1.0
        rows = C.sum(axis=1, keepdims=True)
        P = np.where(rows > 0, C / np.where(rows > 0, rows, 1.0), 1.0 / n)
        run_length = np.where(runs > 0, run_frames / np.maximum(runs, 1), 1.0)
        return cls(P, C, run_length, order=order, min_count=min_count,
                   contexts=_normalized(ctx_counts))

    # -- the jump model --------------------------------------------------------------------------

    def jump_matrix(self) -> NDArray[np.float64]:
        """Transitions between distinct states.

        Returns
        -------
        numpy.ndarray, shape (n, n)
            P with the diagonal removed, rows renormalized (a state that only stays goes
            uniformly to the others); a perturbed model's own.
        """
        if self._jumps is not None:
            return self._jumps.copy()
        n = self.n_states
        Q = self.P.copy()
        np.fill_diagonal(Q, 0.0)
        s = Q.sum(axis=1, keepdims=True)
        if n == 1:
            return np.ones((1, 1))
        uniform = (1.0 - np.eye(n)) / (n - 1)
        return np.where(s > 0, Q / np.where(s > 0, s, 1.0), uniform)

    def context_length(self, history: Sequence[int]) -> int:
        """The length of the context :meth:`next_distribution` uses after a history.

        Parameters
        ----------
        history : sequence of int
            The distinct states so far, the current one last.

        Returns
        -------
        int
            The longest L <= order whose context was followed at least min_count times in the
            data, else 1.
        """
        h = tuple(int(v) for v in history)
        for L in range(min(self.order, len(h)), 1, -1):
            got = self.contexts.get(h[-L:])
            if got is not None and got[0] >= self.min_count:
                return L
        return 1

    def next_distribution(self, history: int | Sequence[int] | NDArray[np.integer[Any]]
                          ) -> NDArray[np.float64]:
        """Probabilities of the next distinct state, by the back-off rule.

        Parameters
        ----------
        history : int or sequence of int
            Distinct states, the current one last (:meth:`context_length`).

        Returns
        -------
        numpy.ndarray, shape (n,)
            The probabilities.
        """
        h = [_state(v, self.n_states) for v in np.atleast_1d(history)]
        if not h:
            raise InvalidArgumentError("next_distribution: empty history")
        L = self.context_length(h)
        if L == 1:
            return self._jump_row(h[-1])
        return self.contexts[tuple(h[-L:])][1].copy()

    def _jump_row(self, j: int) -> NDArray[np.float64]:
        if self._jumps is None:
            self._jumps = self.jump_matrix()
        return self._jumps[j].copy()

    def ranked_next(self, history: int | Sequence[int] | NDArray[np.integer[Any]],
                    rank: int = 1) -> int:
        """The rank-th most likely next distinct state after a history.

        Rank 1: equation 5; rank 2: the second most likely, paper Figure 3 (c); lowest index
        on ties. When fewer than rank other states have a probability > 0, the least likely of
        those that have.

        Parameters
        ----------
        history : int or sequence of int
            Distinct states, the current one last.
        rank : int, optional
            >= 1.

        Returns
        -------
        int
            The state; -1 when the model has one state.
        """
        rank = integer(rank, "rank", 1)
        h = np.atleast_1d(history)
        if self.n_states == 1:
            _state(h[-1], 1)
            return -1
        p = self.next_distribution(h)
        p[int(h[-1])] = -1.0
        order = np.argsort(-p, kind="stable")
        possible = int((p > 0).sum())
        return int(order[min(rank, max(possible, 1)) - 1])

    def most_likely_next(self, j: int, history: Sequence[int] | None = None) -> int:
        """Equation 5: ``k* = argmax_{k != j} P[j, k]``, the most likely next distinct primitive.

        Parameters
        ----------
        j : int
            The current state.
        history : sequence of int, optional
            The distinct states before j (for order > 1).

        Returns
        -------
        int
            The state (lowest index on ties); -1 when the model has one state.
        """
        j = _state(j, self.n_states)
        h = [] if history is None else [int(v) for v in history]
        return self.ranked_next(h + [j], 1)

    def most_likely_path(self, start: int, n: int | None = None, *, rank: int = 1
                         ) -> NDArray[np.int64]:
        """Follow :meth:`ranked_next` from a state.

        Parameters
        ----------
        start : int
            The first state.
        n : int, optional
            States in the path; default: until a state repeats, the cycle of paper Figure 3
            (c), the repeated state included (for order > 1 until a context repeats).
        rank : int, optional
            1: equation 5; 2: the second most likely.

        Returns
        -------
        numpy.ndarray of int64
            The path.
        """
        s = _state(start, self.n_states, "start")
        rank = integer(rank, "rank", 1)
        path = [s]
        limit = n if n is not None else self.n_states ** min(self.order, 2) + 1
        seen = {tuple(path[-self.order:])}
        while len(path) < limit:
            s = self.ranked_next(path, rank)
            if s < 0:
                break
            path.append(s)
            if n is None:
                key = tuple(path[-self.order:])
                if (self.order == 1 and s in path[:-1]) or (self.order > 1 and key in seen):
                    break
                seen.add(key)
        return np.array(path, dtype=np.int64)

    # -- noise -----------------------------------------------------------------------------------

    def perturbed(self, scale: float, seed: int = 0, *, allow_unseen: bool = False) -> Markov:
        """A model with redrawn rows (paper section 5.2).

        The rows of P, of the jump matrix and of every context are redrawn from Dirichlet
        distributions centred on them with concentration 1 / scale (the module's docstring:
        the scale controls the deviation from the data).

        Parameters
        ----------
        scale : float
            >= 0; 0: the same probabilities (with allow_unseen: the centres that give
            UNSEEN_MASS to the unseen).
        seed : int, optional
            Seed.
        allow_unseen : bool, optional
            Transitions never seen stay impossible unless this is true.

        Returns
        -------
        Markov
            The new model.
        """
        scale = _noise(scale, "Markov: noise scale")
        seed = integer(seed, "Markov: seed", 0)
        if not isinstance(allow_unseen, (bool, np.bool_)):
            raise InvalidArgumentError(f"allow_unseen must be True or False, got "
                                       f"{allow_unseen!r}")
        rng = np.random.default_rng(seed)
        n = self.n_states
        P = dirichlet_rows(self.P, scale, rng, allow_unseen=allow_unseen)
        off = ~np.eye(n, dtype=bool) if n > 1 else np.ones((1, 1), bool)
        J = dirichlet_rows(self.jump_matrix(), scale, rng, allowed=off,
                           allow_unseen=allow_unseen)
        ctx = {}
        for key in sorted(self.contexts):
            cnt, row = self.contexts[key]
            allowed = np.ones((1, n), bool)
            allowed[0, key[-1]] = False
            ctx[key] = (cnt, dirichlet_rows(row[None], scale, rng, allowed=allowed,
                                            allow_unseen=allow_unseen)[0])
        return Markov(P, self.counts, self.run_length, order=self.order,
                      min_count=self.min_count, contexts=ctx, jumps=J)

    # -- sampling --------------------------------------------------------------------------------

    def sample(self, start: int, n: int, noise: float = 0.0, seed: int = 0, *,
               distinct: bool = False, history: Sequence[int] | None = None,
               allow_unseen: bool = False) -> NDArray[np.int64]:
        """A seeded sequence of states; the same arguments give the same sequence.

        Parameters
        ----------
        start : int
            The first state.
        n : int
            States in the sequence (>= 1).
        noise : float, optional
            Scale of the perturbation (:meth:`perturbed`, same seed, allow_unseen) before
            sampling.
        seed : int, optional
            Seed.
        distinct : bool, optional
            Sample the chain of distinct primitives (each step leaves the current state; of
            order ``order``, with the distinct states of history before start as the first
            context) rather than frame-to-frame transitions (first order, P).
        history : sequence of int, optional
            Distinct states before start.
        allow_unseen : bool, optional
            As for :meth:`perturbed`.

        Returns
        -------
        numpy.ndarray of int64, shape (n,)
            The states.
        """
        s = _state(start, self.n_states, "start")
        n = integer(n, "sample: n", 1)
        noise = _noise(noise, "sample: noise")
        model = self.perturbed(noise, seed, allow_unseen=allow_unseen) \
            if noise > 0 or allow_unseen else self
        u = np.random.default_rng([seed, 1]).random(n - 1)
        out = np.empty(n, dtype=np.int64)
        out[0] = s
        if distinct and model.order > 1:
            h = [] if history is None else [int(v) for v in history]
            h.append(s)
            for i in range(1, n):
                cum = np.cumsum(model.next_distribution(h[-model.order:]))
                cum[-1] = 1.0
                s = int(np.searchsorted(cum, u[i - 1], side="right"))
                out[i] = s
                h.append(s)
            return out
        T = model.jump_matrix() if distinct else model.P
        cum = np.cumsum(T, axis=1)
        cum[:, -1] = 1.0
        for i in range(1, n):
            s = int(np.searchsorted(cum[s], u[i - 1], side="right"))
            out[i] = s
        return out

    def c_arrays(self) -> dict[str, Any]:
        """The jump model as the C core takes it (``mlr_markov_create``).

        Returns
        -------
        dict
            ``jumps`` (n, n), ``run_length`` (n,), ``order``, ``min_count``,
            ``context_keys`` (m, order) int64 left-padded with -1, ``context_seen`` (m,) and
            ``context_probs`` (m, n), the contexts in sorted order.
        """
        keys = sorted(self.contexts)
        K = np.full((len(keys), self.order), -1, dtype=np.int64)
        seen = np.zeros(len(keys))
        probs = np.zeros((len(keys), self.n_states))
        for i, key in enumerate(keys):
            K[i, self.order - len(key):] = key
            seen[i], probs[i] = self.contexts[key]
        return {"jumps": np.ascontiguousarray(self.jump_matrix(), dtype=np.float64),
                "run_length": np.ascontiguousarray(self.run_length, dtype=np.float64),
                "order": int(self.order), "min_count": int(self.min_count),
                "context_keys": K, "context_seen": seen, "context_probs": probs}

    def _native(self) -> Any:
        """The C jump model (``mlr_markov``), freed with the returned handle (made for each
        call, so that a Markov stays picklable and a contexts dict edited in place is seen)."""
        a = self.c_arrays()
        out = ffi.new("mlr_markov **")
        diag = ffi.new("mlr_diag *")
        keys = a["context_keys"]
        m = keys.shape[0]
        check(lib.mlr_markov_create(
            self.n_states, ffi.cast("double *", ffi.from_buffer(a["jumps"])),
            ffi.cast("double *", ffi.from_buffer(a["run_length"])), a["order"], a["min_count"],
            m, ffi.cast("int64_t *", ffi.from_buffer(keys)) if m else ffi.NULL,
            ffi.cast("double *", ffi.from_buffer(a["context_seen"])) if m else ffi.NULL,
            ffi.cast("double *", ffi.from_buffer(a["context_probs"])) if m else ffi.NULL,
            ffi.NULL, out, diag), "mlayer.Markov", diag)
        return ffi.gc(out[0], lib.mlr_markov_destroy)

    def walk(self, start: int, n_frames: int, *, rank: int = 0, rng: Rng | None = None,
             seed: int = 0, history: Sequence[int] | None = None, noise: float = 0.0,
             allow_unseen: bool = False, noise_rng: Rng | None = None) -> NDArray[np.int64]:
        """Distinct primitives from a start, enough to fill n_frames at their mean run lengths,
        by the C core (``mlr_markov_path``: the same path a C program gets from the same model
        and generator).

        path[0] = start; each next state is sampled from the jump model after the path so far
        (one uniform from the generator per step), or with rank r >= 1 the r-th most likely
        (:meth:`ranked_next`); a step from j to k lasts (max(run_length[j], 1) +
        max(run_length[k], 1)) / 2 frames, and the walk stops once the steps last n_frames or
        more.

        Parameters
        ----------
        start : int
            The first state.
        n_frames : int
            Frames to fill, >= 1.
        rank : int, optional
            0 sampled, 1 most likely, 2 second most likely, ...
        rng : Rng, optional
            The generator (its state advances); default ``Rng(seed)``.
        seed : int, optional
            Seed of the default generator.
        history : sequence of int, optional
            Distinct states before start (the first context, order > 1).
        noise : float, optional
            > 0: walk the jump model with its rows redrawn first, by the C core
            (``mlr_markov_perturb``: Dirichlet(r / noise) per row, as :meth:`perturbed` draws
            them, from its own generator).
        allow_unseen : bool, optional
            As for :meth:`perturbed` (a perturbation even at noise 0).
        noise_rng : Rng, optional
            The perturbation's generator (default ``Rng(seed ^ 0x6A09E667F3BCC908)``, as the
            C generator seeds it: ``MLR_GEN_NOISE_SEED_XOR``).

        Returns
        -------
        numpy.ndarray of int64
            The states, at most n_frames + 1.
        """
        s = _state(start, self.n_states, "start")
        n_frames = integer(n_frames, "walk: n_frames", 1)
        rank = integer(rank, "walk: rank", 0, 2**31 - 1)
        if rng is None:
            rng = Rng(seed)
        h = np.array([_state(v, self.n_states, "history") for v in (history or [])],
                     dtype=np.int64)
        noise = _noise(noise, "walk: noise")
        if not isinstance(allow_unseen, (bool, np.bool_)):
            raise InvalidArgumentError(f"allow_unseen must be True or False, got "
                                       f"{allow_unseen!r}")
        out = np.empty(n_frames + 1, dtype=np.int64)
        got = ffi.new("size_t *")
        diag = ffi.new("mlr_diag *")
        model = self._native()
        if noise > 0 or allow_unseen:
            if noise_rng is None:
                noise_rng = Rng(integer(seed, "walk: seed", 0, 2**64 - 1) ^ NOISE_SEED_XOR)
            pert = ffi.new("mlr_markov **")
            check(lib.mlr_markov_perturb(model, noise, int(bool(allow_unseen)), noise_rng._state,
                                         ffi.NULL, pert, diag), "mlayer.Markov.walk", diag)
            model = ffi.gc(pert[0], lib.mlr_markov_destroy)
        check(lib.mlr_markov_path(model,
                                  ffi.cast("int64_t *", ffi.from_buffer(h)) if h.size
                                  else ffi.NULL, h.size, s, n_frames, rank, rng._state,
                                  ffi.cast("int64_t *", ffi.from_buffer(out)), out.size, got,
                                  diag), "mlayer.Markov.walk", diag)
        return out[:got[0]].copy()

    def stationary(self) -> NDArray[np.float64]:
        """Stationary distribution of P.

        Returns
        -------
        numpy.ndarray, shape (n,)
            The left eigenvector of P for eigenvalue 1, normalized.
        """
        w, v = np.linalg.eig(self.P.T)
        p = np.abs(np.real(v[:, np.argmin(np.abs(w - 1.0))]))
        return p / p.sum()

    # -- persistence helpers ---------------------------------------------------------------------

    def context_arrays(self) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
        """The contexts as arrays (for saving; :func:`contexts_from_arrays`).

        Returns
        -------
        keys : numpy.ndarray of int64, shape (m, order)
            Left-padded with -1.
        counts : numpy.ndarray, shape (m, n)
            Counts of the next distinct state.
        """
        keys = sorted(self.contexts)
        K = np.full((len(keys), self.order), -1, dtype=np.int64)
        R = np.zeros((len(keys), self.n_states))
        for i, key in enumerate(keys):
            K[i, self.order - len(key):] = key
            cnt, row = self.contexts[key]
            R[i] = cnt * row
        return K, R


def _normalized(ctx_counts: dict[tuple[int, ...], NDArray[np.float64]]
                ) -> dict[tuple[int, ...], tuple[float, NDArray[np.float64]]]:
    return {k: (float(v.sum()), v / v.sum()) for k, v in ctx_counts.items()}


def contexts_from_arrays(keys: ArrayLike, counts: ArrayLike
                         ) -> dict[tuple[int, ...], tuple[float, NDArray[np.float64]]]:
    """The contexts dict of :class:`Markov` from :meth:`Markov.context_arrays`.

    Parameters
    ----------
    keys : array_like of int, shape (m, order)
        Left-padded with -1.
    counts : array_like, shape (m, n)
        Counts of the next distinct state.

    Returns
    -------
    dict
        Context -> (times seen, probabilities).
    """
    keys = np.asarray(keys, dtype=np.int64)
    counts = np.asarray(counts, dtype=np.float64)
    return _normalized({tuple(int(v) for v in k if v >= 0): c.copy()
                        for k, c in zip(keys, counts)})


def heldout_loglik(labels: Sequence[ArrayLike], n_states: int,
                   orders: Iterable[int] = (1, 2, 3), *, min_count: int = 1,
                   folds: int = HELDOUT_FOLDS) -> dict[int, tuple[float, int]]:
    """The held-out log-likelihood of the jump model of each order, by blocked cross-validation.

    Each clip is cut into ``folds`` consecutive blocks of equal length; for fold f the models
    are fitted on the other blocks of every clip (each block a sequence of its own: no
    transition is counted across a removed block), and every jump (a change of label)
    arriving in block f is predicted from its full history in the clip (the distinct
    primitives before it). The probability p given to the jump scores
    ``log((1 - 1e-3) p + 1e-3 / (n_states - 1))``: the floor HELDOUT_FLOOR keeps a jump the
    other blocks never showed finite, at the same cost for every order.

    Parameters
    ----------
    labels : sequence of array_like of int
        One label sequence per clip.
    n_states : int
        States.
    orders : iterable of int, optional
        The orders to score.
    min_count : int, optional
        The back-off rule.
    folds : int, optional
        Blocks per clip (>= 2).

    Returns
    -------
    dict of int to (float, int)
        ``{order: (mean log-likelihood per held-out jump in nats, number of held-out
        jumps)}``; NaN when no clip has a jump.
    """
    seqs = [_labels(s, f"labels[{i}]") for i, s in enumerate(labels)]
    n = integer(n_states, "n_states", 1)
    min_count = integer(min_count, "min_count", 1)
    folds = integer(folds, "folds", 2)
    orders = [_order(o) for o in orders]
    edges = [np.linspace(0, s.size, folds + 1).round().astype(np.int64) for s in seqs]
    runs = [_runs(s) for s in seqs]
    ll = {o: 0.0 for o in orders}
    m = 0
    for f in range(folds):
        train = [s[e[b]:e[b + 1]] for s, e in zip(seqs, edges) for b in range(folds)
                 if b != f and e[b + 1] > e[b]]
        if not train:
            continue
        models = {o: Markov.fit(train, n, order=o, min_count=min_count) for o in orders}
        for (d, starts), e in zip(runs, edges):
            for t in range(1, d.size):
                if not e[f] <= starts[t] < e[f + 1]:
                    continue
                m += 1
                for o in orders:
                    p = models[o].next_distribution(d[max(0, t - o):t])[d[t]]
                    ll[o] += math.log((1.0 - HELDOUT_FLOOR) * p + HELDOUT_FLOOR / max(n - 1, 1))
    return {o: (ll[o] / m if m else float("nan"), m) for o in orders}


def best_order(scores: Mapping[int, tuple[float, int]]) -> int:
    """The order of highest held-out log-likelihood.

    Parameters
    ----------
    scores : dict
        :func:`heldout_loglik`'s scores.

    Returns
    -------
    int
        The order (the lowest on ties, 1 when none is finite).
    """
    best, val = 1, -math.inf
    for order in sorted(scores):
        v = scores[order][0]
        if math.isfinite(v) and v > val + 1e-12:
            best, val = order, v
    return best
