/*
 * Fixed-lag LGS smoother (see include/mlayer/mlr_stream.h for the derivation).
 *
 * Notation for a prefix of n frames (rows 0 .. n-1) of the order-2 system (s D^T D + I):
 *  - continuing rows i <= n-3: the LDL^T rows of any clip longer than i + 2 frames, computed
 *    once per pushed frame into a ring (l1 = L(i,i-1), l2 = L(i,i-2), dinv = 1/D(i)), with
 *    the forward-swept values z_i of every channel;
 *  - end rows n-2, n-1: factored for each prefix from the prefix matrix's own last two rows
 *    ("hat" rows), and their forward values zhat written in terms of y_{n-2}, y_{n-1} and
 *    z_{n-3}, z_{n-4}.
 * Ring slots: row i lives in slot i % ring, ring = max(lag + 1, 4) (the output needs rows
 * min(j, n-4) .. n-3 of z, j = n-1-lag). The aligned inputs keep 3 rows (y_{n-2}, y_{n-1}
 * for the end rows, one spare); the sign rule keeps its own 3 earlier quaternion rows.
 */
#include "common/cpu.h"
#include "math/lgs_internal.h"
#include "math/quat_internal.h"
#include "math/sincosd.h"
#include "guards/limits_internal.h"

#include <math.h>

typedef struct smoother {
    double s;                   /* lam^2 sigma^2 */
    double *z;                  /* ring x m forward-swept values (continuing rows) */
    double *l1, *l2, *dinv;     /* ring continuing factor rows */
} smoother;

/* The prefix's two end rows, index 0 for row n-2, 1 for row n-1 (rows < 0 unused). */
typedef struct end_rows {
    double l1[2], l2[2], dinv[2];
} end_rows;

struct mlr_stream {
    mlr_allocator alloc;
    size_t block_bytes;
    size_t n_joints, n_trans, m, q_off; /* q_off: first quaternion value in a frame */
    int root, layered, finished;
    size_t lag, ring;
    size_t n;                   /* frames pushed */
    size_t n_out;               /* frames output */
    smoother sm[2];             /* main, base (layered only) */
    double *y;                  /* 3 x m aligned inputs, row i at slot i % 3 */
    double *coef;               /* ring + 4 scratch weights */
    const double **src;         /* ring + 4 scratch row pointers */
    double *raw_base;           /* m: base layer output row */
    double *zh;                 /* m: scratch row of the flush */
    double *qhist;              /* 4 x n_joints aligned quaternions: frames n-3 .. n-1, new */
    double *flush_base;         /* lag x m: base layer rows of a flush (layered only) */
    double *alpha;              /* n_joints layer scales */
    double alpha_trans;
    int alpha_one; /* every joint's alpha is 1: the rotations are the main layer's */
    mlr_quat *lq, *le; /* n_joints scratch quaternions of compose_layers */
    mlr_vec3 *lv; /* n_joints scratch rotation vectors of compose_layers */
    const mlr_limits *limits; /* borrowed (mlr_stream_set_limits), or NULL */
};

/* ---------------------------------------------------------------------------------------- */
/* Factor rows                                                                              */

/* Entry A(i, i-k) of the system for a clip of n frames (k = 0, 1, 2; 0 when i < k). */
static double sys_entry(double s, size_t n, size_t i, size_t k)
{
    if (k > i)
        return 0.0;
    double v = s == 0.0 ? 0.0 : s * lgs__ltl_entry(n, 2, i, i - k);
    return k == 0 ? v + 1.0 : v;
}

/* Continuing factor row i into the ring (rows i-1, i-2 already there). */
static void continuing_row(const mlr_stream *st, smoother *sm, size_t i)
{
    const size_t R = st->ring, c = i % R, p1 = (i + R - 1) % R, p2 = (i + R - 2) % R;
    const size_t n = i + 3; /* any clip in which row i is not an end row */
    double d = band__ldl2_row(i, sys_entry(sm->s, n, i, 0), sys_entry(sm->s, n, i, 1),
                              sys_entry(sm->s, n, i, 2), i >= 2 ? sm->l1[p1] : 0.0,
                              i >= 1 ? sm->dinv[p1] : 0.0, i >= 2 ? sm->dinv[p2] : 0.0, &sm->l1[c],
                              &sm->l2[c]);
    sm->dinv[c] = 1.0 / d; /* d >= 1: every Schur complement of s D^T D + I is */
}

/* End rows of the n-frame prefix (n >= 1). */
static void end_rows_of(const mlr_stream *st, const smoother *sm, size_t n, end_rows *e)
{
    const size_t R = st->ring;
    e->l1[0] = e->l2[0] = 0.0;
    e->dinv[0] = 1.0;
    if (n >= 2) { /* row n-2 after continuing rows n-3, n-4 */
        const size_t i = n - 2, p1 = (i + R - 1) % R, p2 = (i + R - 2) % R;
        double d = band__ldl2_row(i, sys_entry(sm->s, n, i, 0), sys_entry(sm->s, n, i, 1),
                                  sys_entry(sm->s, n, i, 2), i >= 2 ? sm->l1[p1] : 0.0,
                                  i >= 1 ? sm->dinv[p1] : 0.0, i >= 2 ? sm->dinv[p2] : 0.0,
                                  &e->l1[0], &e->l2[0]);
        e->dinv[0] = 1.0 / d;
    }
    /* row n-1 after the end row n-2 and the continuing row n-3 */
    const size_t i = n - 1, p2 = (i + R - 2) % R;
    double d = band__ldl2_row(i, sys_entry(sm->s, n, i, 0), sys_entry(sm->s, n, i, 1),
                              sys_entry(sm->s, n, i, 2), i >= 2 ? e->l1[0] : 0.0,
                              i >= 1 ? e->dinv[0] : 0.0, i >= 2 ? sm->dinv[p2] : 0.0, &e->l1[1],
                              &e->l2[1]);
    e->dinv[1] = 1.0 / d;
}

/* Factor entries of row k of the n-frame prefix: continuing or end row. */
static void hat_row(const mlr_stream *st, const smoother *sm, const end_rows *e, size_t n,
                    size_t k, double *l1, double *l2, double *dinv)
{
    if (k + 2 >= n) {
        size_t t = k + 2 - n; /* 0: row n-2, 1: row n-1 */
        *l1 = e->l1[t], *l2 = e->l2[t], *dinv = e->dinv[t];
    } else {
        size_t c = k % st->ring;
        *l1 = sm->l1[c], *l2 = sm->l2[c], *dinv = sm->dinv[c];
    }
}

/* ---------------------------------------------------------------------------------------- */
/* Channel kernels (rows distinct: restrict lets the compiler vectorize over channels)       */

/* The two kernels over every channel get an AVX2 clone (common/cpu.h): the same operations in
 * the same order (no contraction), so the same bits, in fewer instructions. */
MLR_CLONES("avx2")
static void row_forward(double *restrict z, const double *restrict y, const double *restrict z1,
                        const double *restrict z2, double l1, double l2, size_t m)
{
    for (size_t c = 0; c < m; c++)
        z[c] = y[c] - (l1 * z1[c] + l2 * z2[c]);
}

/* x_i = x_i / D_i - (a1 x_{i+1} + a2 x_{i+2}) */
static void row_scale_sub2(double *restrict xi, const double *x1, const double *x2, double dinv,
                           double a1, double a2, size_t m)
{
    for (size_t c = 0; c < m; c++)
        xi[c] = xi[c] * dinv - (a1 * x1[c] + a2 * x2[c]);
}

/* out = sum_r coef[r] * src[r][.], r < count (count >= 1). */
MLR_CLONES("avx2")
static void weighted_sum(double *restrict out, const double *const *src, const double *coef,
                         size_t count, size_t m)
{
    size_t r = 0;
    {
        const double *restrict a = src[0];
        const double ca = coef[0];
        for (size_t c = 0; c < m; c++)
            out[c] = ca * a[c];
        r = 1;
    }
    for (; r + 4 <= count; r += 4) {
        const double *restrict a = src[r], *restrict b = src[r + 1];
        const double *restrict d = src[r + 2], *restrict f = src[r + 3];
        const double ca = coef[r], cb = coef[r + 1], cd = coef[r + 2], cf = coef[r + 3];
        for (size_t c = 0; c < m; c++)
            out[c] += (ca * a[c] + cb * b[c]) + (cd * d[c] + cf * f[c]);
    }
    for (; r < count; r++) {
        const double *restrict a = src[r];
        const double ca = coef[r];
        for (size_t c = 0; c < m; c++)
            out[c] += ca * a[c];
    }
}

static int values_finite(const double *x, size_t m)
{
    double acc = 0.0;
    for (size_t c = 0; c < m; c++)
        acc += x[c] * 0.0; /* NaN for any NaN or inf */
    return acc == 0.0;
}

/* ---------------------------------------------------------------------------------------- */
/* One output row and the flush                                                             */

/* x_j of the n-frame prefix (n >= 1, j <= n-1) into out: the backward sweep of that single row
 * written as weights over z_{lo..n-3} and y_{n-2}, y_{n-1}. */
static void smoother_point(mlr_stream *st, const smoother *sm, size_t n, size_t j, double *out)
{
    end_rows e;
    end_rows_of(st, sm, n, &e);
    /* w_k = dinvhat_k v_k, v = column j of Lhat^{-1}: v_j = 1, v_k = -l1 v_{k-1} - l2 v_{k-2} */
    const size_t lo_ = n < 4 ? 0 : (n - 4 < j ? n - 4 : j); /* min(j, n-4), >= 0 */
    double *w = st->coef; /* w[k - lo_] for k = lo_ .. n-1 */
    for (size_t k = lo_; k < j; k++)
        w[k - lo_] = 0.0;
    double v1 = 0.0, v2 = 0.0; /* v_{k-1}, v_{k-2} */
    for (size_t k = j; k < n; k++) {
        double l1, l2, dinv;
        hat_row(st, sm, &e, n, k, &l1, &l2, &dinv);
        double v = k == j ? 1.0 : -(l1 * v1 + l2 * v2);
        w[k - lo_] = v * dinv;
        v2 = v1, v1 = v;
    }
    /* fold zhat_{n-1} = y_{n-1} - l1 zhat_{n-2} - l2 z_{n-3} and
     *      zhat_{n-2} = y_{n-2} - l1 z_{n-3} - l2 z_{n-4} into the weights */
    size_t count = 0;
    const double **src = st->src;
    double *coef = st->coef + (n - lo_); /* after w */
    {
        const double cy1 = w[n - 1 - lo_];
        if (n >= 2)
            w[n - 2 - lo_] -= cy1 * e.l1[1];
        if (n >= 3)
            w[n - 3 - lo_] -= cy1 * e.l2[1];
        src[count] = st->y + ((n - 1) % 3) * st->m;
        coef[count++] = cy1;
    }
    if (n >= 2) {
        const double cy2 = w[n - 2 - lo_];
        if (n >= 3)
            w[n - 3 - lo_] -= cy2 * e.l1[0];
        if (n >= 4)
            w[n - 4 - lo_] -= cy2 * e.l2[0];
        src[count] = st->y + ((n - 2) % 3) * st->m;
        coef[count++] = cy2;
    }
    for (size_t k = lo_; k + 2 < n; k++) {
        src[count] = sm->z + (k % st->ring) * st->m;
        coef[count++] = w[k - lo_];
    }
    weighted_sum(out, src, coef, count, st->m);
}

/* Rows first .. n-1 of the n-frame prefix solution (n = frames pushed) into x, row r at
 * x + (r - first) * m: the forward values of those rows, then the backward sweep over them
 * (exact: the sweep never needs rows past n-1). */
static void smoother_tail(mlr_stream *st, const smoother *sm, size_t first, double *x)
{
    const size_t n = st->n, m = st->m, R = st->ring;
    end_rows e;
    end_rows_of(st, sm, n, &e);
    double *zh = st->zh; /* zhat_{n-2} */
    if (n >= 2) {
        const size_t i = n - 2;
        const double *yi = st->y + (i % 3) * m;
        for (size_t c = 0; c < m; c++) {
            double v = yi[c];
            if (i >= 1)
                v -= e.l1[0] * sm->z[((i - 1) % R) * m + c];
            if (i >= 2)
                v -= e.l2[0] * sm->z[((i - 2) % R) * m + c];
            zh[c] = v;
        }
    }
    for (size_t i = first; i < n; i++) {
        double *xi = x + (i - first) * m;
        if (i + 2 < n) {
            memcpy(xi, sm->z + (i % R) * m, m * sizeof(double));
        } else if (i + 2 == n) {
            memcpy(xi, zh, m * sizeof(double));
        } else { /* zhat_{n-1} = y_{n-1} - l1 zhat_{n-2} - l2 z_{n-3} */
            const double *yi = st->y + (i % 3) * m;
            const double *z3 = n >= 3 ? sm->z + ((n - 3) % R) * m : NULL;
            for (size_t c = 0; c < m; c++) {
                double v = yi[c];
                if (n >= 2)
                    v -= e.l1[1] * zh[c];
                if (z3)
                    v -= e.l2[1] * z3[c];
                xi[c] = v;
            }
        }
    }
    for (size_t i = n; i-- > first;) {
        double *xi = x + (i - first) * m;
        double l1, l2, dinv, a1 = 0.0, a2 = 0.0;
        hat_row(st, sm, &e, n, i, &l1, &l2, &dinv);
        if (i + 1 < n)
            hat_row(st, sm, &e, n, i + 1, &a1, &l2, &l1); /* a1 = L(i+1, i) */
        if (i + 2 < n)
            hat_row(st, sm, &e, n, i + 2, &l1, &a2, &l2); /* a2 = L(i+2, i) */
        if (i + 2 < n)
            row_scale_sub2(xi, xi + m, xi + 2 * m, dinv, a1, a2, m);
        else if (i + 1 < n)
            row_scale_sub2(xi, xi + m, xi + m, dinv, a1, 0.0, m);
        else
            for (size_t c = 0; c < m; c++)
                xi[c] *= dinv;
    }
}

/* ---------------------------------------------------------------------------------------- */
/* Quaternions and layers                                                                   */

/*
 * Online sign continuity of the new frame's quaternions (frame i), placed in st->qhist row 3,
 * against the aligned frames i-3 .. i-1 (rows 0 .. 2; only the last min(i, 3) exist): the
 * second-order predictive rule of mlr_quat_continue_sign, through the very per-frame step the
 * batch mlr_quat_make_continuous_predictive takes (common__quat_continue_frame), so the aligned
 * input equals the offline clip's bit for bit.
 */
static void align_signs(mlr_stream *st, size_t i, double *yi)
{
    const size_t J = st->n_joints, qb = 4 * J * sizeof(double);
    if (J == 0)
        return;
    mlr_quat *h = (mlr_quat *)st->qhist;
    const size_t n_prev = i < 3 ? i : 3;
    memcpy(h + 3 * J, yi + st->q_off, qb);
    common__quat_continue_frame(h + (3 - n_prev) * J, n_prev, J);
    memcpy(yi + st->q_off, h + 3 * J, qb);
    memmove(h, h + J, 3 * qb); /* rows 1 .. 3 become rows 0 .. 2 */
}

static void compose_layers(const mlr_stream *st, double *x, double *xb, mlr_quat *q);

/* Whether an output row needs the base layer's row: some alpha is not 1. */
static int needs_base(const mlr_stream *st)
{
    return st->layered && !(st->alpha_one && st->alpha_trans == 1.0);
}

/* Renormalize the quaternions of an output row x; with layers, compose it with the base row
 * xb (raw, normalized here; not read when every alpha is 1): x = xb (+) alpha (x (-) xb); then
 * the joint limits, if any. */
static void finish_row(const mlr_stream *st, double *x, double *xb)
{
    const size_t J = st->n_joints;
    mlr_quat *q = (mlr_quat *)(x + st->q_off);
    (void)mlr_quat_normalize_array(q, J, q, NULL); /* a zero mean gives the identity */
    if (needs_base(st))
        compose_layers(st, x, xb, q);
    if (st->limits)
        limits__apply_frame(st->limits, q, st->layered ? st->alpha : NULL, 1, NULL);
}

/* x = xb (+) alpha (x (-) xb) of a layered stream (q: the normalized quaternions of x). Per
 * joint with alpha a != 1: q = b exp(a log(conj(b) q)), b the normalized base. The products
 * and logs of all joints go through one call and the exps of the joints with a != 1 through
 * another: those kernels compute each element on its own (no sums across elements), so the
 * bits are those of one call per joint. An exp whose vectors leave the kernels' fast range
 * (|a| in the tens of thousands) is taken one joint at a time, as it always was. */
static void compose_layers(const mlr_stream *st, double *x, double *xb, mlr_quat *q)
{
    const size_t J = st->n_joints;
    if (st->alpha_trans != 1.0)
        for (size_t c = 0; c < st->q_off; c++)
            x[c] = xb[c] + st->alpha_trans * (x[c] - xb[c]);
    if (st->alpha_one)
        return;
    mlr_quat *b = (mlr_quat *)(xb + st->q_off);
    (void)mlr_quat_normalize_array(b, J, b, NULL);
    common__quat_conj_mul_log(b, q, J, 0, st->lq, st->lv); /* the angle in [0, pi]: shorter way */
    mlr_vec3 *v = st->lv;
    size_t n = 0;
    int fast = 1;
    for (size_t j = 0; j < J; j++) {
        const double a = st->alpha[j];
        if (a == 1.0)
            continue;
        const mlr_vec3 w = quat__scale_turn(v[j], a);
        const double lim = 0.5 * MLR_SINCOS_LIMIT; /* false for a NaN or an infinity too */
        fast &= (fabs(w.x) <= lim) & (fabs(w.y) <= lim) & (fabs(w.z) <= lim);
        v[n++] = w;
    }
    if (fast) {
        (void)mlr_quat_exp_array(v, n, st->le, NULL);
    } else {
        for (size_t k = 0; k < n; k++)
            (void)mlr_quat_exp_array(&v[k], 1, &st->le[k], NULL);
    }
    n = 0;
    for (size_t j = 0; j < J; j++)
        if (st->alpha[j] != 1.0)
            common__quat_mul_inline(&b[j], &st->le[n++], &q[j]);
}

/* ---------------------------------------------------------------------------------------- */
/* Public API                                                                               */

/* *acc += a * b with overflow check. */
static int add_size(size_t *acc, size_t a, size_t b)
{
    size_t p;
    if (common__mul_size(a, b, &p) || *acc > SIZE_MAX - p)
        return 1;
    *acc += p;
    return 0;
}

static mlr_status check_lam_sigma(double lam, double sigma, const char *which, mlr_diag *diag)
{
    if (!isfinite(lam) || lam < 0.0)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "lam%s must be finite and >= 0, got %g", which, lam);
    if (!isfinite(sigma) || !(sigma > 0.0))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "sigma%s must be finite and > 0, got %g", which, sigma);
    if (!isfinite(lam * lam * sigma * sigma))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "lam%s^2 sigma%s^2 overflows",
                                which, which);
    return MLR_OK;
}

static mlr_status stream_create(size_t n_joints, int root, size_t n_trans, double lam,
                                double sigma, int layered, double lam_b, double sigma_b,
                                size_t lag, const mlr_allocator *alloc, mlr_stream **out,
                                mlr_diag *diag)
{
    if (!out)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "out is NULL");
    *out = NULL;
    mlr_status st = check_lam_sigma(lam, sigma, "", diag);
    if (st == MLR_OK && layered)
        st = check_lam_sigma(lam_b, sigma_b, "_base", diag);
    if (st != MLR_OK)
        return st;
    size_t m = root ? 3 : 0;
    if (add_size(&m, n_trans, 3) || add_size(&m, n_joints, 4))
        return common__diag_set(diag, MLR_E_OVERFLOW, 0, 0, "stream: the state's size overflows");
    if (m == 0)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "a frame needs at least one channel");
    if (lag == SIZE_MAX)
        return common__diag_set(diag, MLR_E_OVERFLOW, 0, 0, "stream: the state's size overflows");
    const size_t ring = lag + 1 > 4 ? lag + 1 : 4, n_sm = layered ? 2 : 1;
    /* doubles: per smoother ring x m + 3 ring; y 3m; coef 2 (ring + 4); raw_base, zh m each;
     * qhist 16 J; flush_base lag m; alpha J; lq, le, lv 11 J. Then ring + 4 pointers. */
    size_t nd = 0, per_sm = 0;
    if (add_size(&per_sm, ring, m) || add_size(&per_sm, ring, 3) || add_size(&nd, per_sm, n_sm) ||
        add_size(&nd, m, 5) || add_size(&nd, ring + 4, 2) || add_size(&nd, n_joints, 28) ||
        (layered && add_size(&nd, lag, m)))
        return common__diag_set(diag, MLR_E_OVERFLOW, 0, 0, "stream: the state's size overflows");
    size_t bytes = 0;
    if (add_size(&bytes, nd, sizeof(double)) || add_size(&bytes, ring + 4, sizeof(double *)))
        return common__diag_set(diag, MLR_E_OVERFLOW, 0, 0, "stream: the state's size overflows");

    mlr_allocator a;
    common__allocator_resolve(alloc, &a);
    mlr_stream *s = common__alloc(&a, sizeof *s);
    if (!s)
        return common__diag_set(diag, MLR_E_NO_MEMORY, 0, 0, "stream: out of memory");
    memset(s, 0, sizeof *s);
    double *p = common__alloc(&a, bytes);
    if (!p) {
        common__free(&a, s, sizeof *s);
        return common__diag_set(diag, MLR_E_NO_MEMORY, 0, 0,
                                "stream: out of memory (%zu bytes for the state)", bytes);
    }
    memset(p, 0, bytes);
    s->alloc = a;
    s->block_bytes = bytes;
    s->n_joints = n_joints, s->n_trans = n_trans, s->m = m, s->root = root ? 1 : 0;
    s->q_off = m - 4 * n_joints;
    s->layered = layered, s->lag = lag, s->ring = ring;
    for (size_t k = 0; k < n_sm; k++) {
        smoother *sm = &s->sm[k];
        sm->s = k == 0 ? lam * lam * sigma * sigma : lam_b * lam_b * sigma_b * sigma_b;
        sm->z = p, p += ring * m;
        sm->l1 = p, p += ring;
        sm->l2 = p, p += ring;
        sm->dinv = p, p += ring;
    }
    s->y = p, p += 3 * m;
    s->raw_base = p, p += m;
    s->zh = p, p += m;
    s->coef = p, p += 2 * (ring + 4);
    s->qhist = p, p += 16 * n_joints;
    s->alpha = p, p += n_joints;
    s->lq = (mlr_quat *)(void *)p, p += 4 * n_joints;
    s->le = (mlr_quat *)(void *)p, p += 4 * n_joints;
    s->lv = (mlr_vec3 *)(void *)p, p += 3 * n_joints;
    if (layered)
        s->flush_base = p, p += lag * m;
    s->src = (const double **)(void *)p;
    for (size_t j = 0; j < n_joints; j++)
        s->alpha[j] = 1.0;
    s->alpha_trans = 1.0;
    s->alpha_one = 1;
    *out = s;
    return MLR_OK;
}

mlr_status mlr_stream_create(size_t n_joints, int root, size_t n_trans, double lam, double sigma,
                             size_t lag, const mlr_allocator *alloc, mlr_stream **out,
                             mlr_diag *diag)
{
    return stream_create(n_joints, root, n_trans, lam, sigma, 0, 0.0, 1.0, lag, alloc, out, diag);
}

mlr_status mlr_stream_create_layered(size_t n_joints, int root, size_t n_trans, double lam,
                                     double sigma, double lam_base, double sigma_base, size_t lag,
                                     const mlr_allocator *alloc, mlr_stream **out, mlr_diag *diag)
{
    return stream_create(n_joints, root, n_trans, lam, sigma, 1, lam_base, sigma_base, lag, alloc,
                         out, diag);
}

void mlr_stream_destroy(mlr_stream *st)
{
    if (!st)
        return;
    mlr_allocator a = st->alloc;
    common__free(&a, st->sm[0].z, st->block_bytes); /* start of the single block */
    common__free(&a, st, sizeof *st);
}

static mlr_status flushed(mlr_diag *diag, const char *fn)
{
    return common__diag_set(diag, MLR_E_BAD_STATE, 0, 0,
                            "stream %s: the stream was flushed; reset it before pushing again",
                            fn);
}

/* The first non-finite value of v[0 .. n): the message of a rejected frame or alpha. */
static mlr_status not_finite(mlr_diag *diag, const char *fn, const char *what, const double *v,
                             size_t n)
{
    size_t i = 0;
    while (i < n && isfinite(v[i]))
        i++;
    return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                            "stream %s: %s[%zu] is NaN or infinite (rejected; the stream is "
                            "unchanged)",
                            fn, what, i);
}

mlr_status mlr_stream_push(mlr_stream *st, const double *frame, size_t n_values, double *out,
                           size_t out_len, size_t *n_ready, mlr_diag *diag)
{
    if (n_ready)
        *n_ready = 0;
    if (!st || !frame || !out || !n_ready)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "stream push: st, frame, out or n_ready is NULL");
    if (st->finished)
        return flushed(diag, "push");
    const size_t m = st->m, R = st->ring, i = st->n;
    if (n_values != m)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "stream push: n_values is %zu, a frame has %zu", n_values, m);
    if (out_len < m)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "stream push: out_len %zu is below the frame size %zu", out_len,
                                m);
    if (!values_finite(frame, m))
        return not_finite(diag, "push", "frame", frame, m);
    double *yi = st->y + (i % 3) * m;
    memcpy(yi, frame, m * sizeof(double));
    align_signs(st, i, yi);
    const size_t n_sm = st->layered ? 2 : 1;
    for (size_t k = 0; k < n_sm; k++) {
        smoother *sm = &st->sm[k];
        continuing_row(st, sm, i);
        const size_t c = i % R;
        /* rows before 0 have zero factor entries: any finite row stands in for them */
        const double *z1 = i >= 1 ? sm->z + ((i - 1) % R) * m : yi;
        const double *z2 = i >= 2 ? sm->z + ((i - 2) % R) * m : yi;
        row_forward(sm->z + c * m, yi, z1, z2, sm->l1[c], sm->l2[c], m);
    }
    st->n = i + 1;
    if (st->n <= st->lag)
        return MLR_OK;
    const size_t j = st->n - 1 - st->lag;
    smoother_point(st, &st->sm[0], st->n, j, out);
    if (needs_base(st))
        smoother_point(st, &st->sm[1], st->n, j, st->raw_base);
    finish_row(st, out, st->raw_base);
    st->n_out = j + 1;
    *n_ready = 1;
    return MLR_OK;
}

mlr_status mlr_stream_flush(mlr_stream *st, double *out, size_t out_len, size_t *n_written,
                            mlr_diag *diag)
{
    if (n_written)
        *n_written = 0;
    if (!st || !n_written)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "stream flush: st or n_written is NULL");
    if (st->finished)
        return common__diag_set(diag, MLR_E_BAD_STATE, 0, 0,
                                "stream flush: the stream was flushed already; reset it first");
    const size_t pending = st->n - st->n_out, m = st->m; /* pending <= lag: fits (create) */
    if (pending > 0) {
        if (!out)
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    "stream flush: out is NULL with %zu frames pending", pending);
        if (out_len / m < pending)
            return common__diag_set(diag, MLR_E_OVERFLOW, 0, 0,
                                    "stream flush: out_len %zu is below %zu pending frames of %zu",
                                    out_len, pending, m);
        smoother_tail(st, &st->sm[0], st->n_out, out);
        if (st->layered)
            smoother_tail(st, &st->sm[1], st->n_out, st->flush_base);
        for (size_t r = 0; r < pending; r++)
            finish_row(st, out + r * m, st->layered ? st->flush_base + r * m : NULL);
    }
    st->n_out = st->n;
    st->finished = 1;
    *n_written = pending;
    return MLR_OK;
}

void mlr_stream_reset(mlr_stream *st)
{
    if (!st)
        return;
    st->n = st->n_out = 0;
    st->finished = 0;
}

mlr_status mlr_stream_set_alpha(mlr_stream *st, double alpha_trans, const double *alpha,
                                size_t n_joints, mlr_diag *diag)
{
    if (!st || (n_joints > 0 && !alpha))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "stream set_alpha: st or alpha is NULL");
    if (n_joints != st->n_joints)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "stream set_alpha: %zu alphas for a stream of %zu joints",
                                n_joints, st->n_joints);
    if (!isfinite(alpha_trans))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "stream set_alpha: alpha_trans = %g is NaN or infinite",
                                alpha_trans);
    if (!st->layered)
        return common__diag_set(diag, MLR_E_BAD_STATE, 0, 0,
                                "stream set_alpha: the stream has no base layer (create it with "
                                "mlr_stream_create_layered)");
    if (n_joints > 0 && !values_finite(alpha, n_joints))
        return not_finite(diag, "set_alpha", "alpha", alpha, n_joints);
    st->alpha_trans = alpha_trans;
    if (n_joints > 0)
        memcpy(st->alpha, alpha, n_joints * sizeof(double));
    st->alpha_one = 1;
    for (size_t j = 0; j < n_joints; j++)
        st->alpha_one &= alpha[j] == 1.0;
    return MLR_OK;
}

mlr_status mlr_stream_set_limits(mlr_stream *st, const mlr_limits *limits, mlr_diag *diag)
{
    if (!st)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "stream set_limits: st is NULL");
    if (limits && mlr_limits_n_joints(limits) != st->n_joints)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "stream set_limits: limits of %zu joints for a stream of %zu",
                                mlr_limits_n_joints(limits), st->n_joints);
    st->limits = limits;
    return MLR_OK;
}

size_t mlr_stream_frame_size(const mlr_stream *st) { return st ? st->m : 0; }
size_t mlr_stream_lag(const mlr_stream *st) { return st ? st->lag : 0; }
size_t mlr_stream_n_pushed(const mlr_stream *st) { return st ? st->n : 0; }
size_t mlr_stream_pending(const mlr_stream *st)
{
    return st && !st->finished ? st->n - st->n_out : 0;
}

double mlr_stream_decay_rate(double lam, double sigma)
{
    if (check_lam_sigma(lam, sigma, "", NULL) != MLR_OK)
        return -1.0;
    const double s = lam * lam * sigma * sigma;
    if (s == 0.0)
        return 0.0;
    /* roots of z + 1/z = w, w = 2 - i b, b = 1/sqrt(s): z = (w +- sqrt(w^2 - 4)) / 2, with
     * w^2 - 4 = -b^2 - 4 i b; the pair multiplies to 1, rho is the smaller modulus */
    const double b = 1.0 / sqrt(s);
    const double pr = -b * b, pi = -4.0 * b, r = hypot(pr, pi);
    const double sr = sqrt(0.5 * (r + pr)), si = -sqrt(0.5 * (r - pr)); /* sign of pi */
    const double z1 = hypot(0.5 * (2.0 + sr), 0.5 * (-b + si));
    const double z2 = hypot(0.5 * (2.0 - sr), 0.5 * (-b - si));
    return z1 < z2 ? z1 : z2;
}
