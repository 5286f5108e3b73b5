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
by about +-0.05; noise 1: by +-0.35). Transitions never seen stay impossible. With ``allow_unseen=True`` the centre of each row first gives
:data:`UNSEEN_MASS` (0.02) of its mass, in equal parts, to the transitions the data never saw
(of the jump rows: to the other primitives), then the same draw.

**Held-out likelihood** (:func:`heldout_loglik`): 5-fold blocked cross-validation: each clip
cut into 5 consecutive blocks, the model of each order fitted on 4 of them and scored on the
jumps that arrive in the fifth, each predicted from its full history in the clip. (A split
at the last 20% of each clip would score nothing on clips that end standing still.)
"""
from __future__ import annotations

import math

import numpy as np

from .errors import InvalidArgumentError
from ._args import integer

__all__ = ["Markov", "heldout_loglik", "UNSEEN_MASS", "MAX_ORDER"]

UNSEEN_MASS = 0.02  # the prior mass per row that allow_unseen gives to transitions never seen
MAX_ORDER = 3
HELDOUT_FOLDS = 5      # the blocks of each clip in heldout_loglik's cross-validation
HELDOUT_FLOOR = 1e-3    # mixed into each held-out prediction: see heldout_loglik


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


def _runs(s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The distinct symbols of a label sequence (runs collapsed) and the frame each run starts."""
    if s.size == 0:
        return s[:0], np.zeros(0, dtype=np.int64)
    starts = np.flatnonzero(np.r_[True, s[1:] != s[:-1]])
    return s[starts], starts


def _order(order, name: str = "order") -> int:
    return integer(order, name, 1, MAX_ORDER)


def _noise(noise, name: str) -> float:
    try:
        f = float(noise)
    except (TypeError, ValueError):
        f = float("nan")
    if isinstance(noise, (bool, np.bool_)) or not (math.isfinite(f) and f >= 0):
        raise InvalidArgumentError(f"{name} must be finite and >= 0, got {noise!r}")
    return f


def dirichlet_rows(R, noise: float, rng, *, allowed=None, allow_unseen: bool = False):
    """Each row r of R (m, n) (summing to 1) redrawn from Dirichlet(r / noise) over its
    entries > 0 (see the module's docstring). allowed (m, n) bool: the entries that
    allow_unseen may open (default all). noise 0 returns a copy of R (after allow_unseen)."""
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


def _state(j, n: int, name: str = "state") -> int:
    j = integer(j, name)
    if not 0 <= j < n:
        raise InvalidArgumentError(f"{name} {j} out of range: the model has {n} states "
                                   f"(0 .. {n - 1})")
    return int(j)


class Markov:
    """A transition matrix ``P`` (n, n), rows summing to 1, plus the transition counts and the
    mean run length (frames spent in a state before leaving it) of each state; and the jump
    model of the distinct primitives: ``order`` (1 .. 3), ``min_count`` (the back-off rule)
    and ``contexts`` (a dict: tuple of 2 .. order distinct states, the last the current one ->
    (times seen, probabilities (n,) of the next distinct state))."""

    def __init__(self, P, counts=None, run_length=None, *, order: int = 1, min_count: int = 1,
                 contexts=None, jumps=None):
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
        return self.P.shape[0]

    @classmethod
    def fit(cls, labels, n_states: int | None = None, *, order: int = 1,
            min_count: int = 1) -> "Markov":
        """Count transitions between consecutive labels.

        labels: a 1-D integer array, or a list of them (one per clip: no transition is counted
        across clips). n_states: default max label + 1. A state that is never left in the data
        (no outgoing transition) gets a uniform row. ``run_length[j]`` is the mean length of
        the runs of label j in the data (1 if j never occurs). order (1 .. 3) and min_count
        (>= 1): the jump model of the distinct primitives and its back-off rule (see the
        module's docstring).
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

    def jump_matrix(self) -> np.ndarray:
        """Transitions between distinct states: P with the diagonal removed, rows renormalized
        (a state that only stays goes uniformly to the others); a perturbed model's own."""
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

    def context_length(self, history) -> int:
        """The length of the context :meth:`next_distribution` uses after history (the
        distinct states so far, the current one last): the longest L <= order whose context
        was followed at least min_count times in the data, else 1."""
        h = tuple(int(v) for v in history)
        for L in range(min(self.order, len(h)), 1, -1):
            got = self.contexts.get(h[-L:])
            if got is not None and got[0] >= self.min_count:
                return L
        return 1

    def next_distribution(self, history) -> np.ndarray:
        """Probabilities (n,) of the next distinct state after history (a sequence of distinct
        states, the current one last), by the back-off rule (:meth:`context_length`)."""
        h = [_state(v, self.n_states) for v in np.atleast_1d(history)]
        if not h:
            raise InvalidArgumentError("next_distribution: empty history")
        L = self.context_length(h)
        if L == 1:
            return self._jump_row(h[-1])
        return self.contexts[tuple(h[-L:])][1].copy()

    def _jump_row(self, j: int) -> np.ndarray:
        if self._jumps is None:
            self._jumps = self.jump_matrix()
        return self._jumps[j].copy()

    def ranked_next(self, history, rank: int = 1) -> int:
        """The rank-th most likely next distinct state after history (rank 1: equation 5;
        rank 2: the second most likely, paper Figure 3 (c)); lowest index on ties. When fewer
        than rank other states have a probability > 0, the least likely of those that have.
        Returns -1 when the model has one state."""
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

    def most_likely_next(self, j: int, history=None) -> int:
        """Equation 5: k* = argmax_{k != j} P[j, k], the most likely next distinct primitive
        (lowest index on ties), given the distinct states before j (history, for order > 1).
        Returns -1 when the model has one state."""
        j = _state(j, self.n_states)
        h = [] if history is None else [int(v) for v in history]
        return self.ranked_next(h + [j], 1)

    def most_likely_path(self, start: int, n: int | None = None, *, rank: int = 1) -> np.ndarray:
        """Follow :meth:`ranked_next` (rank 1: equation 5; 2: the second most likely) from
        start: n states (default: until a state repeats, the cycle of paper Figure 3 (c), the
        repeated state included; for order > 1 until a context repeats)."""
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

    def perturbed(self, scale: float, seed: int = 0, *, allow_unseen: bool = False) -> "Markov":
        """A model whose rows (of P, of the jump matrix and of every context) are redrawn from
        Dirichlet distributions centred on them with concentration 1 / scale (the module's
        docstring; paper section 5.2: the scale controls the deviation from the data).
        Transitions never seen stay impossible unless allow_unseen. scale 0: the same
        probabilities (with allow_unseen: the centres that give UNSEEN_MASS to the unseen)."""
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
               distinct: bool = False, history=None, allow_unseen: bool = False) -> np.ndarray:
        """A seeded sequence of n states beginning with start.

        noise: scale of the perturbation (:meth:`perturbed`, same seed, allow_unseen) before
        sampling. distinct: sample the chain of distinct primitives (each step leaves the
        current state; of order ``order``, with the distinct states of history before start
        as the first context) rather than frame-to-frame transitions (first order, P). The
        same arguments give the same sequence.
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

    def stationary(self) -> np.ndarray:
        """Stationary distribution (left eigenvector of P for eigenvalue 1, normalized)."""
        w, v = np.linalg.eig(self.P.T)
        p = np.abs(np.real(v[:, np.argmin(np.abs(w - 1.0))]))
        return p / p.sum()

    # -- persistence helpers ---------------------------------------------------------------------

    def context_arrays(self) -> tuple[np.ndarray, np.ndarray]:
        """The contexts as arrays: keys (m, order) (left-padded with -1) and the counts
        (m, n) of the next distinct state (for saving; :func:`contexts_from_arrays`)."""
        keys = sorted(self.contexts)
        K = np.full((len(keys), self.order), -1, dtype=np.int64)
        R = np.zeros((len(keys), self.n_states))
        for i, key in enumerate(keys):
            K[i, self.order - len(key):] = key
            cnt, row = self.contexts[key]
            R[i] = cnt * row
        return K, R


def _normalized(ctx_counts: dict) -> dict:
    return {k: (float(v.sum()), v / v.sum()) for k, v in ctx_counts.items()}


def contexts_from_arrays(keys, counts) -> dict:
    """The contexts dict of :class:`Markov` from :meth:`Markov.context_arrays`."""
    keys = np.asarray(keys, dtype=np.int64)
    counts = np.asarray(counts, dtype=np.float64)
    return _normalized({tuple(int(v) for v in k if v >= 0): c.copy()
                        for k, c in zip(keys, counts)})


def heldout_loglik(labels, n_states: int, orders=(1, 2, 3), *, min_count: int = 1,
                   folds: int = HELDOUT_FOLDS) -> dict:
    """The held-out log-likelihood of the jump model of each order, by blocked
    cross-validation.

    labels: one label sequence per clip. Each clip is cut into ``folds`` (5) consecutive blocks
    of equal length; for fold f the models are fitted on the other blocks of every clip (each
    block a sequence of its own: no transition is counted across a removed block), and every
    jump (a change of label) arriving in block f is predicted from its full history in the
    clip (the distinct primitives before it). The probability p given to the jump scores
    log((1 - 1e-3) p + 1e-3 / (n_states - 1)): the floor HELDOUT_FLOOR keeps a jump the other
    blocks never showed finite, at the same cost for every order. Returns {order: (mean
    log-likelihood per held-out jump in nats, number of held-out jumps)}; nan when no clip
    has a jump.
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


def best_order(scores: dict) -> int:
    """The order of highest held-out log-likelihood in :func:`heldout_loglik`'s scores (the
    lowest on ties, 1 when none is finite)."""
    best, val = 1, -math.inf
    for order in sorted(scores):
        v = scores[order][0]
        if math.isfinite(v) and v > val + 1e-12:
            best, val = order, v
    return best
