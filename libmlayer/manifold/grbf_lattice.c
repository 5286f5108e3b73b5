/* GRBF interpolation on a symmetric lattice (mlr_grbf_fit_lattice): the kernel matrix splits
 * into four symmetry classes, each solved by Cholesky (with a Householder reflection that
 * removes the polynomial term). See mlr_grbf.h. */
#include "manifold/grbf_internal.h"

#include <math.h>

/* ---- interpolation on a symmetric lattice ------------------------------------------------------
 * Notation of mlr_grbf.h: representatives i = (r, c) with r < Rh = ceil(R/2), c < Ch = ceil(C/2)
 * (index r * Ch + c), the four reflections g, class (sx, sy) with characters chi(g) = 1, sx, sy,
 * sx sy. Each class is solved by one thread, so the result does not depend on the count. */

/* sum_t a[t] b[t] in 32 interleaved sums (four vectors of independent chains), reduced in a
 * fixed order. Inlined into the cloned callers, which vectorize it. */
static inline double dot32(const double *a, const double *b, size_t n)
{
    double s[32] = {0};
    size_t t = 0;
    for (; t + 32 <= n; t += 32)
        for (size_t l = 0; l < 32; l++)
            s[l] += a[t + l] * b[t + l];
    for (size_t l = 0; t + l < n; l++)
        s[l] += a[t + l] * b[t + l];
    for (size_t w = 16; w >= 1; w /= 2)
        for (size_t l = 0; l < w; l++)
            s[l] += s[l + w];
    return s[0];
}

/* y[t] -= f x[t] */
static inline void axpy_sub(double *restrict y, double f, const double *restrict x, size_t n)
{
    for (size_t t = 0; t < n; t++)
        y[t] -= f * x[t];
}

/* In-place Cholesky A = L L^T of the n x n matrix at a (row stride lda; the lower triangle is
 * read and overwritten by L), left-looking by blocks of PANEL columns: the block's columns of
 * every row below get the products with the columns before the block from the product kernel
 * (the block's rows packed transposed into pk, n x PANEL), then the block is finished column by
 * column. Returns 0, or -1 at a pivot that is not positive and finite. */
static int cholesky_lower(double *a, size_t n, size_t lda, double *pk, int wide)
{
    double acc[8 * PANEL];
    for (size_t j0 = 0; j0 < n; j0 += PANEL) {
        const size_t jb = n - j0 < PANEL ? n - j0 : PANEL;
        for (size_t q = 0; q < j0; q++) /* pk[q][c] = L[j0 + c][q] */
            for (size_t c = 0; c < PANEL; c++)
                pk[q * PANEL + c] = c < jb ? a[(j0 + c) * lda + q] : 0.0;
        for (size_t i0 = j0; i0 < n && j0 > 0; i0 += 8) {
            const size_t rb = n - i0 < 8 ? n - i0 : 8;
            memset(acc, 0, sizeof acc);
            panel(wide, a + i0 * lda, lda, 1, rb, j0, pk, PANEL, acc, PANEL);
            for (size_t p = 0; p < rb; p++) {
                double *ai = a + (i0 + p) * lda + j0;
                const size_t cmax = i0 + p - j0 + 1 < jb ? i0 + p - j0 + 1 : jb;
                for (size_t c = 0; c < cmax; c++)
                    ai[c] -= acc[p * PANEL + c];
            }
        }
        for (size_t c = 0; c < jb; c++) { /* the block itself, then its column below */
            double *aj = a + (j0 + c) * lda + j0;
            double d = aj[c];
            for (size_t t = 0; t < c; t++)
                d -= aj[t] * aj[t];
            if (!(d > 0.0) || !(d < INFINITY))
                return -1;
            d = sqrt(d);
            aj[c] = d;
            const double inv = 1.0 / d;
            for (size_t i = j0 + c + 1; i < n; i++) {
                double *ai = a + i * lda + j0, v = ai[c];
                for (size_t t = 0; t < c; t++)
                    v -= ai[t] * aj[t];
                ai[c] = v * inv;
            }
        }
    }
    return 0;
}

/* X = (L L^T)^-1 X for the factor of cholesky_lower; X n x (np PANEL) (padded), row stride ldx.
 * By blocks of 8 rows: the product kernel takes the rows already solved, the 8 x 8 diagonal
 * block is solved by substitution. */
static void cholesky_solve(const double *l, size_t n, size_t ldl, double *x, size_t ldx, size_t np,
                           int wide, double *acc)
{
    const size_t w = np * PANEL;
    for (size_t i0 = 0; i0 < n; i0 += 8) { /* L y = x */
        const size_t rb = n - i0 < 8 ? n - i0 : 8;
        memset(acc, 0, rb * w * sizeof(double));
        for (size_t q = 0; q < np && i0 > 0; q++)
            panel(wide, l + i0 * ldl, ldl, 1, rb, i0, x + q * PANEL, ldx, acc + q * PANEL, w);
        for (size_t p = 0; p < rb; p++) {
            double *xi = x + (i0 + p) * ldx;
            const double *li = l + (i0 + p) * ldl;
            for (size_t t = 0; t < w; t++)
                xi[t] -= acc[p * w + t];
            for (size_t p2 = 0; p2 < p; p2++)
                axpy_sub(xi, li[i0 + p2], x + (i0 + p2) * ldx, w);
            const double inv = 1.0 / li[i0 + p];
            for (size_t t = 0; t < w; t++)
                xi[t] *= inv;
        }
    }
    for (size_t e = n; e > 0;) { /* L^T x = y, blocks from the bottom */
        const size_t rb = e % 8 ? e % 8 : 8, i0 = e - rb, done = n - e;
        memset(acc, 0, rb * w * sizeof(double));
        for (size_t q = 0; q < np && done > 0; q++) /* sum_{k >= e} L[k][i] x_k */
            panel(wide, l + e * ldl + i0, 1, ldl, rb, done, x + e * ldx + q * PANEL, ldx,
                  acc + q * PANEL, w);
        for (size_t p = rb; p-- > 0;) {
            double *xi = x + (i0 + p) * ldx;
            for (size_t t = 0; t < w; t++)
                xi[t] -= acc[p * w + t];
            for (size_t p2 = p + 1; p2 < rb; p2++)
                axpy_sub(xi, l[(i0 + p2) * ldl + i0 + p], x + (i0 + p2) * ldx, w);
            const double inv = 1.0 / l[(i0 + p) * ldl + i0 + p];
            for (size_t t = 0; t < w; t++)
                xi[t] *= inv;
        }
        e = i0;
    }
}

/* X = (I - beta v v^T) X for X k x m (row-major), t: m values of scratch. */
MLR_CLONES("avx512f", "avx2")
static void householder_rows(double *x, size_t k, size_t m, const double *v, double beta,
                             double *t)
{
    for (size_t o = 0; o < m; o++)
        t[o] = 0.0;
    for (size_t i = 0; i < k; i++)
        axpy_sub(t, -v[i], x + i * m, m);
    for (size_t i = 0; i < k; i++)
        axpy_sub(x + i * m, beta * v[i], t, m);
}

typedef struct lattice_ctx {
    size_t R, C, Rh, Ch, n_out, mp, ldy; /* mp: n_out rounded up to PANEL */
    const double *xs, *ys, *y, *krow;   /* krow: Rh Ch rows of the R C kernel values */
    double xm, ym;
    int wide;
    /* per class: matrix (k x k), right-hand sides then solution (k x mp, zero padded), work
     * (LATTICE_WORK); the polynomial coefficient of classes 0, 1, 2 (n_out each) */
    double *a[4], *x[4], *v[4], *poly_a[3];
    int failed[4];
} lattice_ctx;

/* Work doubles of a class of at most nr unknowns: v and z (2 nr), t (mp), the packed block of
 * the Cholesky (nr PANEL) and the accumulators of the solves (8 mp). */
#define LATTICE_WORK(nr, mp) ((2 + PANEL) * (nr) + 9 * (mp))

static double lattice_scale(const lattice_ctx *c, size_t r, size_t col)
{
    double s = 1.0; /* sqrt of the stabilizer size */
    if (c->R % 2 && r == c->Rh - 1)
        s *= 1.4142135623730950488;
    if (c->C % 2 && col == c->Ch - 1)
        s *= 1.4142135623730950488;
    return s;
}

static void lattice_class_task(void *ctx, size_t cls)
{
    lattice_ctx *c = ctx;
    const double sx = cls & 1 ? -1.0 : 1.0, sy = cls & 2 ? -1.0 : 1.0;
    const size_t R = c->R, C = c->C, Ch = c->Ch, m = c->n_out, mp = c->mp, np = mp / PANEL;
    const size_t rv = sx > 0 ? c->Rh : R / 2, cv = sy > 0 ? Ch : C / 2, k = rv * cv;
    double *A = c->a[cls], *X = c->x[cls], *v = c->v[cls], *z = v + k, *t = z + k;
    double *pk = t + mp, *acc = pk + k * PANEL;
    /* lower triangle of sum_g chi(g) K[i, g j] / sqrt(s_i s_j), mirrored */
    for (size_t i = 0; i < k; i++) {
        const size_t ri = i / cv, ci = i % cv;
        const double *kr = c->krow + (ri * Ch + ci) * (R * C), si = lattice_scale(c, ri, ci);
        for (size_t j = 0; j <= i; j++) {
            const size_t rj = j / cv, cj = j % cv, rr = R - 1 - rj, cr = C - 1 - cj;
            double sum = kr[rj * C + cj] + sx * kr[rr * C + cj] + sy * kr[rj * C + cr] +
                         sx * sy * kr[rr * C + cr];
            A[i * k + j] = A[j * k + i] = sum / (si * lattice_scale(c, rj, cj));
        }
        const double *y0 = c->y + (ri * C + ci) * c->ldy,
                     *y1 = c->y + ((R - 1 - ri) * C + ci) * c->ldy;
        const double *y2 = c->y + (ri * C + C - 1 - ci) * c->ldy;
        const double *y3 = c->y + ((R - 1 - ri) * C + C - 1 - ci) * c->ldy;
        for (size_t o = 0; o < m; o++)
            X[i * mp + o] = (y0[o] + sx * y1[o] + sy * y2[o] + sx * sy * y3[o]) / (2.0 * si);
        for (size_t o = m; o < mp; o++)
            X[i * mp + o] = 0.0;
        /* the class's polynomial, 2 p(i) / sqrt(s_i): 1, x - xm, y - ym */
        v[i] = cls == 0   ? 2.0 / si
               : cls == 1 ? 2.0 * (c->xs[ri] - c->xm) / si
               : cls == 2 ? 2.0 * (c->ys[ci] - c->ym) / si
                          : 0.0;
    }
    if (cls == 3) { /* no polynomial term: K is positive definite on the whole class */
        if (cholesky_lower(A, k, k, pk, c->wide)) {
            c->failed[cls] = 1;
            return;
        }
        cholesky_solve(A, k, k, X, mp, np, c->wide, acc);
        return;
    }
    /* Householder H = I - beta v v^T with H p = alpha e_0; w = H [0; w'] satisfies p^T w = 0,
     * and (H A H)[1:, 1:] w' = (H y)[1:] is positive definite */
    double pn = sqrt(dot32(v, v, k));
    if (!(pn > 0.0)) {
        c->failed[cls] = 1;
        return;
    }
    const double alpha = v[0] >= 0 ? -pn : pn;
    v[0] -= alpha;
    const double beta = 2.0 / dot32(v, v, k);
    for (size_t i = 0; i < k; i++)
        z[i] = beta * dot32(A + i * k, v, k); /* beta A v */
    const double g = 0.5 * beta * dot32(v, z, k);
    for (size_t i = 0; i < k; i++)
        z[i] -= g * v[i]; /* z = beta A v - (beta^2 v^T A v / 2) v: H A H = A - v z^T - z v^T */
    for (size_t i = 0; i < k; i++)
        for (size_t j = 0; j < k; j++)
            A[i * k + j] -= v[i] * z[j] + z[i] * v[j];
    householder_rows(X, k, mp, v, beta, t); /* X = H X */
    if (cholesky_lower(A + k + 1, k - 1, k, pk, c->wide)) {
        c->failed[cls] = 1;
        return;
    }
    cholesky_solve(A + k + 1, k - 1, k, X + mp, mp, np, c->wide, acc);
    double *pa = c->poly_a[cls];
    for (size_t o = 0; o < m; o++) /* alpha a = (H y)_0 - (H A H)[0, 1:] w' */
        pa[o] = X[o];
    for (size_t j = 1; j < k; j++)
        axpy_sub(pa, A[j], X + j * mp, m);
    for (size_t o = 0; o < mp; o++)
        X[o] = 0.0;
    for (size_t o = 0; o < m; o++)
        pa[o] /= alpha;
    householder_rows(X, k, mp, v, beta, t); /* w = H [0; w'] */
}

/* The workspace of a rows x cols lattice with n_out outputs, in doubles, one part per array:
 * transposed centres (2 N), representatives (2 nr), kernel rows (nr N), and per class a matrix
 * (<= nr^2), the right-hand sides (nr mp), work (LATTICE_WORK); the three polynomial
 * coefficients (n_out each). MLR_E_OVERFLOW when it does not fit a size_t of bytes. */
#define LATTICE_PARTS 16
static mlr_status lattice_workspace(size_t rows, size_t cols, size_t ldy, size_t n_out,
                                    size_t ldcoef, size_t parts[LATTICE_PARTS], size_t *total,
                                    mlr_diag *diag)
{
    const size_t Rh = (rows + 1) / 2, Ch = (cols + 1) / 2;
    size_t N, nr, nkrow, kk;
    *total = 0;
    if (common__mul_size(rows, cols, &N) || N > SIZE_MAX / 4 - 3 ||
        common__mul_size(Rh, Ch, &nr) || common__mul_size(nr, N, &nkrow) ||
        common__mul_size(nr, nr, &kk) || grbf__rows_overflow(N, ldy) ||
        grbf__rows_overflow(N + 3, ldcoef))
        return common__diag_set(diag, MLR_E_OVERFLOW, 0, 0, "lattice workspace overflows");
    if (n_out > SIZE_MAX / 16 - PANEL || nr > SIZE_MAX / (4 * (PANEL + 2)))
        return common__diag_set(diag, MLR_E_OVERFLOW, 0, 0, "lattice workspace overflows");
    const size_t mp = (n_out + PANEL - 1) / PANEL * PANEL;
    const size_t fixed[LATTICE_PARTS] = {2 * N, 2 * nr, nkrow, kk, kk, kk, kk, 0,
                                         0,     0,      0,     0,  0,  0,  0,  3 * n_out};
    memcpy(parts, fixed, sizeof fixed);
    for (size_t q = 7; q < 11; q++)
        if (common__mul_size(nr, mp, &parts[q]))
            return common__diag_set(diag, MLR_E_OVERFLOW, 0, 0, "lattice workspace overflows");
    for (size_t q = 11; q < 15; q++)
        parts[q] = LATTICE_WORK(nr, mp);
    for (size_t q = 0; q < LATTICE_PARTS; q++) {
        if (parts[q] > SIZE_MAX / sizeof(double) - *total)
            return common__diag_set(diag, MLR_E_OVERFLOW, 0, 0, "lattice workspace overflows");
        *total += parts[q];
    }
    return MLR_OK;
}

/* The coordinates are finite and symmetric about their middle (xm, ym), y is finite. */
static mlr_status check_lattice_data(const double *xs, size_t rows, const double *ys, size_t cols,
                                     const double *y, size_t ldy, size_t n_out, mlr_diag *diag)
{
    size_t bad = grbf__first_bad_row(xs, 1, rows, rows);
    if (bad == 0 || grbf__first_bad_row(ys, 1, cols, cols) == 0)
        return common__diag_set(
            diag, MLR_E_INVALID_ARG, 0, 0,
            "lattice coordinates hold a NaN, an infinity or a value beyond 1e150");
    /* the reflections must map the lattice onto itself */
    double xm = 0.5 * (xs[0] + xs[rows - 1]), ym = 0.5 * (ys[0] + ys[cols - 1]);
    double xe = fabs(xs[rows - 1] - xs[0]), ye = fabs(ys[cols - 1] - ys[0]);
    for (size_t r = 0; r < rows; r++)
        if (!(fabs(xs[r] + xs[rows - 1 - r] - 2.0 * xm) <= 1e-12 * xe))
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    "xs is not symmetric about its middle (xs[%zu] + xs[%zu])", r,
                                    rows - 1 - r);
    for (size_t c = 0; c < cols; c++)
        if (!(fabs(ys[c] + ys[cols - 1 - c] - 2.0 * ym) <= 1e-12 * ye))
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    "ys is not symmetric about its middle (ys[%zu] + ys[%zu])", c,
                                    cols - 1 - c);
    const size_t N = rows * cols;
    bad = cluster__first_nonfinite_row(y, N, n_out, ldy);
    if (bad < N)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "y row %zu holds a NaN or an infinity", bad);
    return MLR_OK;
}

/* coef from the solved classes: each representative's weights spread to its four reflections
 * with the class characters, then the polynomial terms. */
static void lattice_coefficients(const lattice_ctx *lc, double *coef, size_t ldcoef)
{
    const size_t rows = lc->R, cols = lc->C, N = rows * cols, n_out = lc->n_out, mp = lc->mp;
    for (size_t u = 0; u < N + 3; u++)
        memset(coef + u * ldcoef, 0, n_out * sizeof(double));
    for (size_t cls = 0; cls < 4; cls++) {
        const double sx = cls & 1 ? -1.0 : 1.0, sy = cls & 2 ? -1.0 : 1.0;
        const size_t rv = sx > 0 ? lc->Rh : rows / 2, cv = sy > 0 ? lc->Ch : cols / 2;
        for (size_t i = 0; i < rv * cv; i++) {
            const size_t ri = i / cv, ci = i % cv, rr = rows - 1 - ri, cr = cols - 1 - ci;
            const double f = 1.0 / (2.0 * lattice_scale(lc, ri, ci));
            const double *w = lc->x[cls] + i * mp;
            /* w[g i] += chi(g) w_i / (2 sqrt(s_i)); a fixed centre gets its share twice */
            axpy_sub(coef + (ri * cols + ci) * ldcoef, -f, w, n_out);
            axpy_sub(coef + (rr * cols + ci) * ldcoef, -sx * f, w, n_out);
            axpy_sub(coef + (ri * cols + cr) * ldcoef, -sy * f, w, n_out);
            axpy_sub(coef + (rr * cols + cr) * ldcoef, -sx * sy * f, w, n_out);
        }
    }
    double *c0 = coef + N * ldcoef, *c1 = c0 + ldcoef, *c2 = c1 + ldcoef;
    for (size_t o = 0; o < n_out; o++) { /* a0 + ax (x - xm) + ay (y - ym) */
        c1[o] = lc->poly_a[1][o];
        c2[o] = lc->poly_a[2][o];
        c0[o] = lc->poly_a[0][o] - (c1[o] * lc->xm + c2[o] * lc->ym);
    }
}

mlr_status mlr_grbf_fit_lattice(int kernel, double width, const double *xs, size_t rows,
                                const double *ys, size_t cols, const double *y, size_t ldy,
                                size_t n_out, size_t n_threads, double *coef, size_t ldcoef,
                                const mlr_allocator *alloc, mlr_diag *diag)
{
    mlr_status st = grbf__check_kernel(kernel, width, diag);
    if (st != MLR_OK)
        return st;
    if (rows < 2 || cols < 2)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "lattice %zu x %zu: needs at least 2 x 2 (the linear terms)", rows,
                                cols);
    if (!xs || !ys || !y || !coef || n_out == 0)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "xs, ys, y or coef NULL, or no outputs (n_out %zu)", n_out);
    if (ldy < n_out || ldcoef < n_out)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "dimension mismatch: strides ldy %zu, ldcoef %zu < n_out %zu", ldy,
                                ldcoef, n_out);
    if (n_threads < 1 || n_threads > MLR_MAX_THREADS)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "n_threads %zu not in 1 .. %d",
                                n_threads, MLR_MAX_THREADS);
    size_t parts[LATTICE_PARTS], total;
    if ((st = lattice_workspace(rows, cols, ldy, n_out, ldcoef, parts, &total, diag)) ||
        (st = check_lattice_data(xs, rows, ys, cols, y, ldy, n_out, diag)))
        return st;
    const size_t Rh = (rows + 1) / 2, Ch = (cols + 1) / 2, N = rows * cols, nr = Rh * Ch;
    const size_t mp = (n_out + PANEL - 1) / PANEL * PANEL;
    const double xm = 0.5 * (xs[0] + xs[rows - 1]), ym = 0.5 * (ys[0] + ys[cols - 1]);
    mlr_allocator a;
    common__allocator_resolve(alloc, &a);
    double *ws = common__alloc(&a, total * sizeof(double));
    if (!ws)
        return common__diag_set(diag, MLR_E_NO_MEMORY, 0, 0,
                                "grbf fit_lattice: out of memory for the workspace (%zu doubles)",
                                total);
    double *ptr[LATTICE_PARTS];
    for (size_t q = 0, off = 0; q < LATTICE_PARTS; off += parts[q], q++)
        ptr[q] = ws + off;
    /* the kernel values of the representatives against every centre, then the four classes */
    double *ct = ptr[0], *rep = ptr[1], *krow = ptr[2];
    for (size_t u = 0; u < N; u++) {
        ct[u] = xs[u / cols];
        ct[N + u] = ys[u % cols];
    }
    for (size_t i = 0; i < nr; i++) {
        rep[2 * i] = xs[i / Ch];
        rep[2 * i + 1] = ys[i % Ch];
    }
    basis_ctx bc = {kernel, 0,   kernel == MLR_GRBF_GAUSSIAN ? 1.0 / (width * width) : 0.0,
                    ct,     rep, N,
                    2,      nr,  2,
                    N,      krow};
    parallel__run(n_threads, (nr + GRBF_TASK_ROWS - 1) / GRBF_TASK_ROWS, grbf__basis_task, &bc);
    lattice_ctx lc = {rows,
                      cols,
                      Rh,
                      Ch,
                      n_out,
                      mp,
                      ldy,
                      xs,
                      ys,
                      y,
                      krow,
                      xm,
                      ym,
                      grbf__cpu_wide(),
                      {ptr[3], ptr[4], ptr[5], ptr[6]},
                      {ptr[7], ptr[8], ptr[9], ptr[10]},
                      {ptr[11], ptr[12], ptr[13], ptr[14]},
                      {ptr[15], ptr[15] + n_out, ptr[15] + 2 * n_out},
                      {0, 0, 0, 0}};
    parallel__run(n_threads, 4, lattice_class_task, &lc);
    st = MLR_OK;
    for (size_t cls = 0; cls < 4; cls++)
        if (lc.failed[cls] && !st)
            st = common__diag_set(diag, MLR_E_SINGULAR, 0, 0,
                                  "symmetry class %zu of the kernel matrix is not numerically "
                                  "positive definite (coincident centres or a too wide Gaussian)",
                                  cls);
    if (!st)
        lattice_coefficients(&lc, coef, ldcoef);
    common__free(&a, ws, total * sizeof(double));
    return st;
}
