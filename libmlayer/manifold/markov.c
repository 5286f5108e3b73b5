/* The jump model of the distinct primitives and its sampling (mlr_markov.h). The generator
 * (mlr_rng_*) is in cluster.c, shared with k-means and the SOM. */
#include "manifold/cluster_internal.h"

#include <math.h>

struct mlr_markov {
    mlr_allocator alloc;
    size_t n, m, bytes;
    unsigned order;
    size_t min_count;
    double *jumps;  /* n x n */
    double *dur;    /* n: max(run_length, 1) */
    double *seen;   /* m */
    double *probs;  /* m x n */
    int64_t *keys;  /* m x order, left-padded with -1 */
};

/* Rows summing to 1 within 1e-9, finite, >= 0; the index of the first bad row or n_rows. */
static size_t bad_row(const double *p, size_t n_rows, size_t n)
{
    for (size_t r = 0; r < n_rows; r++) {
        double s = 0.0;
        for (size_t k = 0; k < n; k++) {
            double v = p[r * n + k];
            if (!(v >= 0.0) || v > 1.0 + 1e-9)
                return r;
            s += v;
        }
        if (!(fabs(s - 1.0) <= 1e-9))
            return r;
    }
    return n_rows;
}

mlr_status mlr_markov_create(size_t n_states, const double *jumps, const double *run_length,
                             unsigned order, size_t min_count, size_t n_contexts,
                             const int64_t *context_keys, const double *context_seen,
                             const double *context_probs, const mlr_allocator *alloc,
                             mlr_markov **out, mlr_diag *diag)
{
    if (!out)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "mlr_markov_create: out is NULL");
    *out = NULL;
    const char *who = "mlr_markov_create";
    size_t n = n_states, m = n_contexts;
    if (n == 0 || n > INT32_MAX)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "%s: n_states %zu out of range "
                                "(1 .. 2^31 - 1)",
                                who, n);
    if (!jumps || !run_length)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "%s: %s is NULL", who,
                                jumps ? "run_length" : "jumps");
    if (order < 1 || order > MLR_MARKOV_MAX_ORDER)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "%s: order %u out of range (1 .. %d)", who, order,
                                MLR_MARKOV_MAX_ORDER);
    if (min_count < 1)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "%s: min_count must be >= 1", who);
    if (m > 0 && (!context_keys || !context_seen || !context_probs))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "%s: %zu contexts but a context array "
                                "is NULL",
                                who, m);
    if (m > 0 && order == 1)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "%s: contexts need order >= 2",
                                who);
    size_t nn, mn, mo, total;
    if (common__mul_size(n, n, &nn) || common__mul_size(m, n, &mn) ||
        common__mul_size(m, order, &mo) || nn > SIZE_MAX / 16 || mn > SIZE_MAX / 16 ||
        mo > SIZE_MAX / 16 || m > SIZE_MAX / 16)
        return common__diag_set(diag, MLR_E_OVERFLOW, 0, 0, "%s: sizes overflow", who);
    total = (nn + n + m + mn + mo) * sizeof(double);
    size_t r = bad_row(jumps, n, n);
    if (r < n)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "%s: jumps row %zu is not finite, "
                                ">= 0 and summing to 1",
                                who, r);
    if (n > 1)
        for (size_t j = 0; j < n; j++)
            if (jumps[j * n + j] != 0.0)
                return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                        "%s: jumps[%zu][%zu] must be 0 "
                                        "(a jump leaves its state)",
                                        who, j, j);
    for (size_t j = 0; j < n; j++)
        if (!(run_length[j] >= 0.0 && run_length[j] < HUGE_VAL))
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    "%s: run_length[%zu] must be "
                                    "finite and >= 0",
                                    who, j);
    r = m ? bad_row(context_probs, m, n) : 0;
    if (r < m)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "%s: context_probs row %zu is not "
                                "finite, >= 0 and summing to 1",
                                who, r);
    for (size_t c = 0; c < m; c++) {
        if (!(context_seen[c] >= 0.0 && context_seen[c] < HUGE_VAL))
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    "%s: context_seen[%zu] must be "
                                    "finite and >= 0",
                                    who, c);
        const int64_t *k = context_keys + c * order;
        size_t pad = 0;
        while (pad < order && k[pad] == -1)
            pad++;
        if (order - pad < 2)
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    "%s: context key %zu has fewer "
                                    "than 2 states",
                                    who, c);
        for (size_t i = pad; i < order; i++)
            if (k[i] < 0 || (uint64_t)k[i] >= n)
                return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                        "%s: context key %zu holds "
                                        "state %lld, out of range (0 .. %zu, -1 only as left "
                                        "padding)",
                                        who, c, (long long)k[i], n - 1);
    }
    mlr_allocator a;
    common__allocator_resolve(alloc, &a);
    mlr_markov *mk = common__alloc(&a, sizeof *mk);
    if (!mk)
        return common__diag_set(diag, MLR_E_NO_MEMORY, 0, 0, "%s: out of memory", who);
    double *block = common__alloc(&a, total);
    if (!block) {
        common__free(&a, mk, sizeof *mk);
        return common__diag_set(diag, MLR_E_NO_MEMORY, 0, 0, "%s: out of memory (%zu bytes)", who,
                                total);
    }
    mk->alloc = a;
    mk->n = n;
    mk->m = m;
    mk->bytes = total;
    mk->order = order;
    mk->min_count = min_count;
    mk->jumps = block;
    mk->dur = block + nn;
    mk->seen = mk->dur + n;
    mk->probs = mk->seen + m;
    mk->keys = (int64_t *)(mk->probs + mn); /* int64_t and double are both 8 bytes */
    memcpy(mk->jumps, jumps, nn * sizeof(double));
    for (size_t j = 0; j < n; j++)
        mk->dur[j] = run_length[j] > 1.0 ? run_length[j] : 1.0;
    if (m) {
        memcpy(mk->seen, context_seen, m * sizeof(double));
        memcpy(mk->probs, context_probs, mn * sizeof(double));
        memcpy(mk->keys, context_keys, mo * sizeof(int64_t));
    }
    *out = mk;
    return MLR_OK;
}

size_t mlr_markov_n_states(const mlr_markov *mk) { return mk ? mk->n : 0; }
unsigned mlr_markov_order(const mlr_markov *mk) { return mk ? mk->order : 0; }

void mlr_markov_destroy(mlr_markov *mk)
{
    if (!mk)
        return;
    mlr_allocator a = mk->alloc;
    common__free(&a, mk->jumps, mk->bytes);
    common__free(&a, mk, sizeof *mk);
}

double mlr_markov_step_frames(const mlr_markov *mk, int64_t a, int64_t b)
{
    if (!mk || a < 0 || b < 0 || (uint64_t)a >= mk->n || (uint64_t)b >= mk->n)
        return NAN;
    return (mk->dur[a] + mk->dur[b]) / 2.0;
}

/* The probabilities of the next distinct state after h[0 .. len-1] (the back-off rule). */
static const double *next_row(const mlr_markov *mk, const int64_t *h, size_t len)
{
    size_t top = len < mk->order ? len : mk->order;
    for (size_t L = top; L >= 2; L--) {
        for (size_t c = 0; c < mk->m; c++) {
            const int64_t *k = mk->keys + c * mk->order;
            size_t pad = mk->order - L;
            if (pad > 0 && k[pad - 1] != -1)
                continue; /* a longer key */
            if (k[pad] == -1)
                continue; /* a shorter key */
            size_t i = 0;
            while (i < L && k[pad + i] == h[len - L + i])
                i++;
            if (i < L)
                continue;
            if (mk->seen[c] >= (double)mk->min_count)
                return mk->probs + c * mk->n;
            break; /* the first key listed decides */
        }
    }
    return mk->jumps + (size_t)h[len - 1] * mk->n;
}

static int64_t sample_row(const double *p, size_t n, double u)
{
    size_t last = n - 1;
    while (last > 0 && !(p[last] > 0.0))
        last--;
    double cum = 0.0;
    for (size_t k = 0; k < last; k++) {
        cum += p[k];
        if (cum > u)
            return (int64_t)k;
    }
    return (int64_t)last;
}

/* The rank-th state in the order of decreasing p (the current state cur excluded), lowest
 * index first on ties; fewer than rank states of p > 0: the last of those. */
static int64_t ranked(const double *p, size_t n, size_t cur, size_t rank)
{
    size_t possible = 0;
    for (size_t k = 0; k < n; k++)
        possible += k != cur && p[k] > 0.0;
    size_t want = rank < possible ? rank : possible;
    if (want < 1)
        want = 1;
    double pv = HUGE_VAL; /* the previous pick, (value, index) */
    size_t pi = 0;
    int64_t pick = -1;
    for (size_t r = 0; r < want; r++) {
        double best = -HUGE_VAL;
        int64_t bi = -1;
        for (size_t k = 0; k < n; k++) {
            double v = k == cur ? -1.0 : p[k];
            int after = r == 0 || v < pv || (v == pv && k > pi);
            if (after && (bi < 0 || v > best)) {
                best = v;
                bi = (int64_t)k;
            }
        }
        pv = best;
        pi = (size_t)bi;
        pick = bi;
    }
    return pick;
}

static mlr_status step(const mlr_markov *mk, const int64_t *h, size_t len, int rank, mlr_rng *rng,
                       int64_t *next)
{
    const double *p = next_row(mk, h, len);
    if (rank == 0) {
        *next = sample_row(p, mk->n, mlr_rng_uniform(rng));
        return MLR_OK;
    }
    *next = mk->n == 1 ? -1 : ranked(p, mk->n, (size_t)h[len - 1], (size_t)rank);
    return MLR_OK;
}

static mlr_status check_states(const mlr_markov *mk, const int64_t *h, size_t len, const char *who,
                               const char *what, mlr_diag *diag)
{
    for (size_t i = 0; i < len; i++)
        if (h[i] < 0 || (uint64_t)h[i] >= mk->n)
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    "%s: %s[%zu] = %lld out of range "
                                    "(the model has %zu states, 0 .. %zu)",
                                    who, what, i, (long long)h[i], mk->n, mk->n - 1);
    return MLR_OK;
}

mlr_status mlr_markov_next(const mlr_markov *mk, const int64_t *history, size_t len, int rank,
                           mlr_rng *rng, int64_t *next, mlr_diag *diag)
{
    const char *who = "mlr_markov_next";
    if (!mk || !history || !next || (rank == 0 && !rng))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "%s: %s is NULL", who,
                                !mk        ? "mk"
                                : !history ? "history"
                                : !next    ? "next"
                                           : "rng");
    if (len == 0)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "%s: empty history", who);
    if (rank < 0)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "%s: rank %d must be >= 0", who,
                                rank);
    size_t keep = len < mk->order ? len : mk->order;
    mlr_status st = check_states(mk, history + len - keep, keep, who, "history", diag);
    if (st)
        return st;
    return step(mk, history + len - keep, keep, rank, rng, next);
}

mlr_status mlr_markov_path(const mlr_markov *mk, const int64_t *history, size_t n_history,
                           int64_t start, size_t n_frames, int rank, mlr_rng *rng, int64_t *path,
                           size_t cap, size_t *len, mlr_diag *diag)
{
    const char *who = "mlr_markov_path";
    if (!mk || !path || !len || (n_history && !history) || (rank == 0 && !rng))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "%s: %s is NULL", who,
                                !mk     ? "mk"
                                : !path ? "path"
                                : !len  ? "len"
                                : !rng  ? "rng"
                                        : "history");
    *len = 0;
    if (rank < 0)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "%s: rank %d must be >= 0", who,
                                rank);
    if (n_frames < 1 || n_frames == SIZE_MAX || cap < n_frames + 1)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "%s: cap %zu < n_frames + 1 (n_frames "
                                "%zu >= 1)",
                                who, cap, n_frames);
    mlr_status st = check_states(mk, history, n_history, who, "history", diag);
    if (!st)
        st = check_states(mk, &start, 1, who, "start", diag);
    if (st)
        return st;
    /* h: the last order states (history, then the path) */
    int64_t h[MLR_MARKOV_MAX_ORDER];
    size_t hl = 0;
    size_t from = n_history > mk->order ? n_history - mk->order : 0;
    for (size_t i = from; i < n_history; i++)
        h[hl++] = history[i];
    if (hl == mk->order) {
        memmove(h, h + 1, (hl - 1) * sizeof *h);
        hl--;
    }
    h[hl++] = start;
    path[0] = start;
    size_t k = 1;
    double total = 0.0;
    while (total < (double)n_frames && k < cap) {
        int64_t nx;
        step(mk, h, hl, rank, rng, &nx);
        if (nx < 0)
            break;
        total += (mk->dur[path[k - 1]] + mk->dur[nx]) / 2.0;
        path[k++] = nx;
        if (hl == mk->order) {
            memmove(h, h + 1, (hl - 1) * sizeof *h);
            hl--;
        }
        h[hl++] = nx;
    }
    *len = k;
    return MLR_OK;
}

/* ---- noise -------------------------------------------------------------------------------- */

static double rng_normal(mlr_rng *r)
{
    double u, v, q;
    do {
        u = 2.0 * mlr_rng_uniform(r) - 1.0;
        v = 2.0 * mlr_rng_uniform(r) - 1.0;
        q = u * u + v * v;
    } while (q >= 1.0 || q == 0.0);
    return u * sqrt(-2.0 * log(q) / q);
}

double mlr_rng_gamma(mlr_rng *r, double a)
{
    if (!r || !(a > 0.0 && a < HUGE_VAL))
        return NAN;
    double boost = 1.0;
    if (a < 1.0) {
        boost = pow(mlr_rng_uniform(r), 1.0 / a);
        a += 1.0;
    }
    double d = a - 1.0 / 3.0, c = 1.0 / sqrt(9.0 * d);
    for (;;) {
        double x, v;
        do {
            x = rng_normal(r);
            v = 1.0 + c * x;
        } while (v <= 0.0);
        v = v * v * v;
        double u = mlr_rng_uniform(r);
        if (u < 1.0 - 0.0331 * (x * x) * (x * x) || log(u) < 0.5 * x * x + d * (1.0 - v + log(v)))
            return boost * d * v;
    }
}

/* Python's dirichlet_rows for one row: closed is the entry that may not be opened (or n). */
static void redraw(double *c, size_t n, size_t closed, double noise, int allow_unseen, mlr_rng *r)
{
    if (allow_unseen) {
        size_t un = 0;
        double sum = 0.0;
        for (size_t k = 0; k < n; k++) {
            un += !(c[k] > 0.0) && k != closed;
            sum += c[k];
        }
        if (un && sum > 0.0) {
            for (size_t k = 0; k < n; k++)
                c[k] = !(c[k] > 0.0) && k != closed ? MLR_MARKOV_UNSEEN_MASS / (double)un
                                                    : c[k] * (1.0 - MLR_MARKOV_UNSEEN_MASS);
        }
    }
    size_t pos = 0, top = n;
    for (size_t k = 0; k < n; k++)
        if (c[k] > 0.0) {
            pos++;
            if (top == n || c[k] > c[top])
                top = k;
        }
    if (noise == 0.0 || pos <= 1)
        return;
    double sum = 0.0;
    for (size_t k = 0; k < n; k++)
        if (c[k] > 0.0) {
            c[k] = mlr_rng_gamma(r, c[k] / noise);
            sum += c[k];
        }
    int ok = sum > 0.0 && sum < HUGE_VAL;
    for (size_t k = 0; k < n; k++)
        c[k] = ok ? c[k] / sum : (k == top ? 1.0 : 0.0);
}

mlr_status mlr_markov_perturb(const mlr_markov *mk, double noise, int allow_unseen, mlr_rng *rng,
                              const mlr_allocator *alloc, mlr_markov **out, mlr_diag *diag)
{
    const char *who = "mlr_markov_perturb";
    if (!out)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "%s: out is NULL", who);
    *out = NULL;
    if (!mk || !rng)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "%s: %s is NULL", who,
                                mk ? "rng" : "mk");
    if (!(noise >= 0.0 && noise < HUGE_VAL))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "%s: noise %g must be finite and >= 0", who, noise);
    if (allow_unseen != 0 && allow_unseen != 1)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "%s: allow_unseen must be 0 or 1",
                                who);
    size_t n = mk->n, m = mk->m, nn = n * n, mn = m * n, total = (nn + mn + n) * sizeof(double);
    mlr_allocator a;
    common__allocator_resolve(alloc, &a);
    double *w = common__alloc(&a, total);
    if (!w)
        return common__diag_set(diag, MLR_E_NO_MEMORY, 0, 0, "%s: out of memory", who);
    double *J = w, *P = w + nn, *run = P + mn;
    memcpy(J, mk->jumps, nn * sizeof(double));
    if (m)
        memcpy(P, mk->probs, mn * sizeof(double));
    for (size_t j = 0; j < n; j++) {
        run[j] = mk->dur[j]; /* max(run_length, 1): the same steps */
        redraw(J + j * n, n, n > 1 ? j : n, noise, allow_unseen, rng);
    }
    for (size_t c = 0; c < m; c++)
        redraw(P + c * n, n, (size_t)mk->keys[c * mk->order + mk->order - 1], noise, allow_unseen,
               rng);
    mlr_status st = mlr_markov_create(n, J, run, mk->order, mk->min_count, m, m ? mk->keys : NULL,
                                      m ? mk->seen : NULL, m ? P : NULL, &a, out, diag);
    common__free(&a, w, total);
    return st ? common__diag_prefix(diag, st, who) : MLR_OK;
}
