/*
 * Markov sampling of motion primitives (paper 2, section 4.2) and the library's seeded
 * generator: what a runtime needs to walk the chain of primitives without Python.
 *
 * Generator (mlr_rng): xoshiro256** (Blackman and Vigna), its 256-bit state seeded by four
 * outputs of splitmix64 started at the seed. The state lives in the caller's mlr_rng: no
 * globals, two generators never share anything. The same seed gives the same numbers on every
 * platform (integer arithmetic only; the uniform is the top 53 bits times 2^-53).
 * k-means++ seeding and the SOM's initialization draw from the same generator.
 *
 * The jump model (mlr_markov): the chain of *distinct* primitives (each run of equal labels
 * collapsed to one state) of order 1 .. 3, as mlayer.Markov holds it:
 *  - the jump matrix J (n x n, rows summing to 1, J[j][j] = 0 when n > 1): the next distinct
 *    state after j;
 *  - contexts: a key of L = 2 .. order distinct states (the current one last) with the times
 *    it was followed in the data and the probabilities (n) of the next distinct state;
 *  - back-off: after a history h (the current state last) the longest context h[-L:], L <=
 *    order, followed at least min_count times is used, else L - 1, down to J[h[-1]] (L = 1);
 *  - the mean run length of each state (frames spent in it); a step from j to k lasts
 *    (max(run_length[j], 1) + max(run_length[k], 1)) / 2 frames.
 * Sampling a next state draws one uniform u from the generator and returns the first state k
 * whose cumulative probability p_0 + ... + p_k (summed in index order) exceeds u, the last
 * state of probability > 0 taking the rest of the mass (so rounding in the sum never picks a
 * state of probability 0). Rank r >= 1 draws nothing: the r-th most likely next state other
 * than the current one (rank 1 is the paper's equation 5), lowest index on ties; when fewer
 * than r states have a probability > 0, the least likely of those that have.
 *
 * Threads: an mlr_markov is read only after creation (share it between threads); an mlr_rng
 * is the caller's, one per thread.
 */
#ifndef MLR_MARKOV_H
#define MLR_MARKOV_H

#include "mlr_common.h"

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/** xoshiro256** state. Seed it with mlr_rng_seed; copy it to fork the stream. */
typedef struct mlr_rng {
    uint64_t s[4];
} mlr_rng;

/** Seed: s[i] = the i-th output of splitmix64 started at seed (i = 0 .. 3). */
MLR_API void mlr_rng_seed(mlr_rng *rng, uint64_t seed);
/** The next 64 random bits. */
MLR_API uint64_t mlr_rng_u64(mlr_rng *rng);
/** A uniform double in [0, 1): (mlr_rng_u64 >> 11) * 2^-53. */
MLR_API double mlr_rng_uniform(mlr_rng *rng);
/** A uniform integer in [0, n), n >= 1, unbiased (draws above the largest multiple of n are
 *  rejected and drawn again). n == 0 returns 0 and draws nothing. */
MLR_API size_t mlr_rng_below(mlr_rng *rng, size_t n);

/** A gamma variate of the given shape (scale 1): Marsaglia and Tsang's method (2000) for
 *  shape >= 1, normals by Marsaglia's polar method; for shape < 1 a variate of shape + 1 times
 *  U^(1/shape). NaN (drawing nothing) for a shape that is not finite and > 0. */
MLR_API double mlr_rng_gamma(mlr_rng *rng, double shape);

/** The largest order of the jump model. */
#define MLR_MARKOV_MAX_ORDER 3

/** The jump model of the distinct primitives (mlr_markov_create): read only once made. Opaque. */
typedef struct mlr_markov mlr_markov;

/**
 * A jump model from its arrays (copied).
 * @param n_states     n >= 1
 * @param jumps        [in] n x n, row j at jumps + j * n: finite, >= 0, each row summing to 1
 *                     within 1e-9
 * @param run_length   [in] n mean run lengths, finite and >= 0
 * @param order        1 .. MLR_MARKOV_MAX_ORDER
 * @param min_count    >= 1: times a context must have been followed to be used
 * @param n_contexts   m (0 with order 1)
 * @param context_keys [in] m x order states, left-padded with -1 (a key of L states has
 *                     order - L entries -1 first, then L states in 0 .. n-1), 2 <= L <= order;
 *                     on a key listed twice the first is used
 * @param context_seen [in] m times each context was followed (finite, >= 0)
 * @param context_probs [in] m x n probabilities of the next distinct state, rows as jumps
 * @param alloc        allocator (NULL: malloc/free), kept by the model
 * @param out          [out] the model; NULL on failure
 * @return MLR_OK; MLR_E_INVALID_ARG naming the argument (and the row or key) that is out of
 *         range; MLR_E_OVERFLOW; MLR_E_NO_MEMORY. Nothing is allocated on failure.
 * Allocates: one block of about (n + 2) n + m (order + n + 1) values.
 */
MLR_API mlr_status mlr_markov_create(size_t n_states, const double *jumps,
                                     const double *run_length, unsigned order, size_t min_count,
                                     size_t n_contexts, const int64_t *context_keys,
                                     const double *context_seen, const double *context_probs,
                                     const mlr_allocator *alloc, mlr_markov **out, mlr_diag *diag);

/** States n. */
MLR_API size_t mlr_markov_n_states(const mlr_markov *mk);
/** Order 1 .. 3. */
MLR_API unsigned mlr_markov_order(const mlr_markov *mk);

/**
 * The next distinct state after a history.
 * @param history  [in] len >= 1 states in 0 .. n-1, the current one last (only the last
 *                 order are read)
 * @param rank     0: sampled (one uniform drawn from rng); r >= 1: the r-th most likely
 * @param rng      the generator (may be NULL when rank >= 1)
 * @param next     [out] the state; -1 for rank >= 1 on a model of one state
 * @return MLR_OK; MLR_E_INVALID_ARG (NULL pointers, len 0, a state out of range, rank < 0).
 * Allocates: never.
 */
MLR_API mlr_status mlr_markov_next(const mlr_markov *mk, const int64_t *history, size_t len,
                                   int rank, mlr_rng *rng, int64_t *next, mlr_diag *diag);

/** The frames a step from state a to state b lasts: (max(run_length[a], 1) +
 *  max(run_length[b], 1)) / 2 (NaN for states out of range). */
MLR_API double mlr_markov_step_frames(const mlr_markov *mk, int64_t a, int64_t b);

/**
 * A path of distinct states from a start, long enough to fill n_frames at the mean run
 * lengths: path[0] = start, then mlr_markov_next (history: the path so far, after the states
 * of history) until the steps' frames (mlr_markov_step_frames) sum to n_frames or more; with
 * rank >= 1 the path also ends on a model of one state. Each step lasts at least one frame, so
 * the path holds at most n_frames + 1 states.
 * @param history    [in] n_history distinct states before start (NULL when 0)
 * @param start      the first state
 * @param n_frames   frames to fill (>= 1)
 * @param rank       as for mlr_markov_next
 * @param rng        the generator (one uniform per sampled step)
 * @param path       [out] cap >= n_frames + 1 states
 * @param len        [out] states written
 * @return MLR_OK; MLR_E_INVALID_ARG (NULL pointers, states out of range, cap too small).
 * Allocates: never.
 */
MLR_API mlr_status mlr_markov_path(const mlr_markov *mk, const int64_t *history, size_t n_history,
                                   int64_t start, size_t n_frames, int rank, mlr_rng *rng,
                                   int64_t *path, size_t cap, size_t *len, mlr_diag *diag);

/** The share of each row that allow_unseen gives to the transitions never seen. */
#define MLR_MARKOV_UNSEEN_MASS 0.02

/**
 * A model with redrawn rows (paper 2 section 5.2; mlayer.Markov.perturbed's rule for the jump
 * model): every row r of the jump matrix (in order), then of each context (in the order given
 * at creation), is redrawn from Dirichlet(r / noise) over its entries > 0, the others staying
 * 0: E[r'] = r, Var[r'_k] = r_k (1 - r_k) noise / (1 + noise). Each draw is one mlr_rng_gamma
 * per entry > 0, in index order, divided by their sum (a row whose gammas all underflow puts
 * all its mass on its largest entry, the first on ties); a row with one entry > 0, or noise 0,
 * is kept. With allow_unseen the centre of each row first gives MLR_MARKOV_UNSEEN_MASS of its
 * mass, in equal parts, to the entries that are 0 and may be opened (a jump row: not its own
 * state; a context row: not the context's current state).
 * @param noise        finite, >= 0
 * @param allow_unseen 0 or 1
 * @param rng          the generator of the draws
 * @param out          [out] the new model (the steps' frames, order, min_count, context keys
 *                     and times seen as mk's); NULL on failure
 * @return MLR_OK; MLR_E_INVALID_ARG; MLR_E_NO_MEMORY (nothing allocated).
 * Allocates: the new model and a workspace of its rows, released before returning.
 */
MLR_API mlr_status mlr_markov_perturb(const mlr_markov *mk, double noise, int allow_unseen,
                                      mlr_rng *rng, const mlr_allocator *alloc, mlr_markov **out,
                                      mlr_diag *diag);

/** Free the model. NULL is a no-op. */
MLR_API void mlr_markov_destroy(mlr_markov *mk);

#ifdef __cplusplus
}
#endif

#endif /* MLR_MARKOV_H */
