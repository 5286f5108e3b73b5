/* Shared building blocks of k-means and the SOM: parallel loop, generator, packed centres and
 * the nearest/second-nearest search, blobs. See cluster_internal.h. */
#include "cluster_internal.h"

#include <math.h>
#include <pthread.h>
#include <stdatomic.h>

#if (defined(__x86_64__) || defined(__i386__)) && (defined(__GNUC__) || defined(__clang__))
#  define MLR_X86_DISPATCH 1
#  include <immintrin.h>
#endif

/* ---- parallel loop ---------------------------------------------------------------------- */

typedef struct par_ctx {
    atomic_size_t next;
    size_t n_tasks;
    mlr_task_fn fn;
    void *ctx;
} par_ctx;

static void *par_worker(void *arg)
{
    par_ctx *pc = arg;
    for (;;) {
        size_t t = atomic_fetch_add(&pc->next, 1);
        if (t >= pc->n_tasks)
            break;
        pc->fn(pc->ctx, t);
    }
    return NULL;
}

void mlr_parallel_run(size_t n_threads, size_t n_tasks, mlr_task_fn fn, void *ctx)
{
    if (n_threads > MLR_MAX_THREADS)
        n_threads = MLR_MAX_THREADS;
    if (n_threads > n_tasks)
        n_threads = n_tasks;
    if (n_threads <= 1) {
        for (size_t t = 0; t < n_tasks; t++)
            fn(ctx, t);
        return;
    }
    par_ctx pc;
    atomic_init(&pc.next, 0);
    pc.n_tasks = n_tasks;
    pc.fn = fn;
    pc.ctx = ctx;
    pthread_t th[MLR_MAX_THREADS];
    size_t started = 0;
    for (size_t i = 0; i + 1 < n_threads; i++) {
        if (pthread_create(&th[started], NULL, par_worker, &pc) != 0)
            break; /* the others take its share */
        started++;
    }
    par_worker(&pc);
    for (size_t i = 0; i < started; i++)
        pthread_join(th[i], NULL);
}

/* ---- generator ---------------------------------------------------------------------------- */

static uint64_t splitmix64(uint64_t *x)
{
    uint64_t z = (*x += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

void mlr_rng_seed(mlr_rng *r, uint64_t seed)
{
    for (int i = 0; i < 4; i++)
        r->s[i] = splitmix64(&seed);
}

static uint64_t rotl(uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }

uint64_t mlr_rng_u64(mlr_rng *r)
{
    uint64_t *s = r->s;
    uint64_t out = rotl(s[1] * 5, 7) * 9, t = s[1] << 17;
    s[2] ^= s[0];
    s[3] ^= s[1];
    s[1] ^= s[2];
    s[0] ^= s[3];
    s[2] ^= t;
    s[3] = rotl(s[3], 45);
    return out;
}

double mlr_rng_uniform(mlr_rng *r) { return (double)(mlr_rng_u64(r) >> 11) * 0x1.0p-53; }

size_t mlr_rng_below(mlr_rng *r, size_t n)
{
    uint64_t lim = UINT64_MAX - UINT64_MAX % (uint64_t)n, v;
    do
        v = mlr_rng_u64(r);
    while (v >= lim);
    return (size_t)(v % (uint64_t)n);
}

/* ---- packed centres ----------------------------------------------------------------------- */

size_t mlr_packed_kpad(size_t k) { return (k + MLR_PACK - 1) / MLR_PACK * MLR_PACK; }

double mlr_norm2(const double *a, size_t dim)
{
    double s = 0;
    for (size_t t = 0; t < dim; t++)
        s += a[t] * a[t];
    return s;
}

double mlr_dist2(const double *a, const double *b, size_t dim)
{
    double s = 0;
    for (size_t t = 0; t < dim; t++) {
        double e = a[t] - b[t];
        s += e * e;
    }
    return s;
}

void mlr_packed_set(mlr_packed *p, size_t j, const double *c)
{
    double *blk = p->pc + (j / MLR_PACK) * p->dim * MLR_PACK + j % MLR_PACK;
    for (size_t t = 0; t < p->dim; t++)
        blk[t * MLR_PACK] = c[t];
    p->cn[j] = mlr_norm2(c, p->dim);
}

void mlr_packed_get(const mlr_packed *p, size_t j, double *c)
{
    const double *blk = p->pc + (j / MLR_PACK) * p->dim * MLR_PACK + j % MLR_PACK;
    for (size_t t = 0; t < p->dim; t++)
        c[t] = blk[t * MLR_PACK];
}

void mlr_packed_fill(mlr_packed *p, const double *c, size_t ldc)
{
    for (size_t j = 0; j < p->k; j++)
        mlr_packed_set(p, j, c + j * ldc);
    for (size_t j = p->k; j < p->kpad; j++) {
        double *blk = p->pc + (j / MLR_PACK) * p->dim * MLR_PACK + j % MLR_PACK;
        for (size_t t = 0; t < p->dim; t++)
            blk[t * MLR_PACK] = 0.0;
        p->cn[j] = INFINITY;
    }
}

/* ---- the search ----------------------------------------------------------------------------
 * Dot products of G rows with one block of 16 centres: out[r * 16 + l] = x_r . c_l, summed
 * over t in increasing order, one accumulator per (r, l): the result of a row does not depend
 * on the other rows of the group. One kernel is chosen per CPU (AVX-512, AVX2 + FMA or plain
 * C), so results are reproducible on a machine, not across instruction sets. */
#define MAX_G 8

static void dot_generic(const double *const *xr, const double *blk, size_t dim, double *out)
{
    double acc[4 * MLR_PACK] = {0};
    for (size_t t = 0; t < dim; t++) {
        const double *b = blk + t * MLR_PACK;
        for (int r = 0; r < 4; r++) {
            double xv = xr[r][t];
            for (int l = 0; l < MLR_PACK; l++)
                acc[r * MLR_PACK + l] += xv * b[l];
        }
    }
    memcpy(out, acc, sizeof acc);
}

#ifdef MLR_X86_DISPATCH
__attribute__((target("avx2,fma"))) static void dot_avx2_half(const double *const *xr,
                                                               const double *blk, size_t dim,
                                                               double *out)
{
    __m256d a00 = _mm256_setzero_pd(), a01 = a00, a10 = a00, a11 = a00, a20 = a00, a21 = a00,
            a30 = a00, a31 = a00;
    const double *x0 = xr[0], *x1 = xr[1], *x2 = xr[2], *x3 = xr[3];
    for (size_t t = 0; t < dim; t++) {
        __m256d b0 = _mm256_loadu_pd(blk + t * MLR_PACK), b1 = _mm256_loadu_pd(blk + t * MLR_PACK + 4);
        __m256d v = _mm256_broadcast_sd(x0 + t);
        a00 = _mm256_fmadd_pd(v, b0, a00);
        a01 = _mm256_fmadd_pd(v, b1, a01);
        v = _mm256_broadcast_sd(x1 + t);
        a10 = _mm256_fmadd_pd(v, b0, a10);
        a11 = _mm256_fmadd_pd(v, b1, a11);
        v = _mm256_broadcast_sd(x2 + t);
        a20 = _mm256_fmadd_pd(v, b0, a20);
        a21 = _mm256_fmadd_pd(v, b1, a21);
        v = _mm256_broadcast_sd(x3 + t);
        a30 = _mm256_fmadd_pd(v, b0, a30);
        a31 = _mm256_fmadd_pd(v, b1, a31);
    }
    _mm256_storeu_pd(out + 0 * MLR_PACK, a00);
    _mm256_storeu_pd(out + 0 * MLR_PACK + 4, a01);
    _mm256_storeu_pd(out + 1 * MLR_PACK, a10);
    _mm256_storeu_pd(out + 1 * MLR_PACK + 4, a11);
    _mm256_storeu_pd(out + 2 * MLR_PACK, a20);
    _mm256_storeu_pd(out + 2 * MLR_PACK + 4, a21);
    _mm256_storeu_pd(out + 3 * MLR_PACK, a30);
    _mm256_storeu_pd(out + 3 * MLR_PACK + 4, a31);
}

__attribute__((target("avx2,fma"))) static void dot_avx2(const double *const *xr,
                                                          const double *blk, size_t dim,
                                                          double *out)
{
    dot_avx2_half(xr, blk, dim, out);
    dot_avx2_half(xr, blk + 8, dim, out + 8);
}

__attribute__((target("avx512f"))) static void dot_avx512(const double *const *xr,
                                                           const double *blk, size_t dim,
                                                           double *out)
{
    __m512d a00 = _mm512_setzero_pd(), a01 = a00, a10 = a00, a11 = a00, a20 = a00, a21 = a00,
            a30 = a00, a31 = a00, a40 = a00, a41 = a00, a50 = a00, a51 = a00;
    const double *x0 = xr[0], *x1 = xr[1], *x2 = xr[2], *x3 = xr[3], *x4 = xr[4], *x5 = xr[5];
    for (size_t t = 0; t < dim; t++) {
        __m512d b0 = _mm512_loadu_pd(blk + t * MLR_PACK), b1 = _mm512_loadu_pd(blk + t * MLR_PACK + 8);
        __m512d v = _mm512_set1_pd(x0[t]);
        a00 = _mm512_fmadd_pd(v, b0, a00);
        a01 = _mm512_fmadd_pd(v, b1, a01);
        v = _mm512_set1_pd(x1[t]);
        a10 = _mm512_fmadd_pd(v, b0, a10);
        a11 = _mm512_fmadd_pd(v, b1, a11);
        v = _mm512_set1_pd(x2[t]);
        a20 = _mm512_fmadd_pd(v, b0, a20);
        a21 = _mm512_fmadd_pd(v, b1, a21);
        v = _mm512_set1_pd(x3[t]);
        a30 = _mm512_fmadd_pd(v, b0, a30);
        a31 = _mm512_fmadd_pd(v, b1, a31);
        v = _mm512_set1_pd(x4[t]);
        a40 = _mm512_fmadd_pd(v, b0, a40);
        a41 = _mm512_fmadd_pd(v, b1, a41);
        v = _mm512_set1_pd(x5[t]);
        a50 = _mm512_fmadd_pd(v, b0, a50);
        a51 = _mm512_fmadd_pd(v, b1, a51);
    }
    _mm512_storeu_pd(out + 0 * MLR_PACK, a00);
    _mm512_storeu_pd(out + 0 * MLR_PACK + 8, a01);
    _mm512_storeu_pd(out + 1 * MLR_PACK, a10);
    _mm512_storeu_pd(out + 1 * MLR_PACK + 8, a11);
    _mm512_storeu_pd(out + 2 * MLR_PACK, a20);
    _mm512_storeu_pd(out + 2 * MLR_PACK + 8, a21);
    _mm512_storeu_pd(out + 3 * MLR_PACK, a30);
    _mm512_storeu_pd(out + 3 * MLR_PACK + 8, a31);
    _mm512_storeu_pd(out + 4 * MLR_PACK, a40);
    _mm512_storeu_pd(out + 4 * MLR_PACK + 8, a41);
    _mm512_storeu_pd(out + 5 * MLR_PACK, a50);
    _mm512_storeu_pd(out + 5 * MLR_PACK + 8, a51);
}

/* One row against 4 consecutive blocks (64 centres): the same fma sequence per (row, centre)
 * as dot_avx512, so a row gets bit-identical values whichever kernel served it. */
__attribute__((target("avx512f"))) static void dot1x4_avx512(const double *x, const double *blk,
                                                             size_t dim, double *out)
{
    const size_t bs = dim * MLR_PACK;
    const double *b0 = blk, *b1 = blk + bs, *b2 = blk + 2 * bs, *b3 = blk + 3 * bs;
    __m512d a0 = _mm512_setzero_pd(), a1 = a0, a2 = a0, a3 = a0, a4 = a0, a5 = a0, a6 = a0,
            a7 = a0;
    for (size_t t = 0; t < dim; t++) {
        __m512d v = _mm512_set1_pd(x[t]);
        size_t o = t * MLR_PACK;
        a0 = _mm512_fmadd_pd(v, _mm512_loadu_pd(b0 + o), a0);
        a1 = _mm512_fmadd_pd(v, _mm512_loadu_pd(b0 + o + 8), a1);
        a2 = _mm512_fmadd_pd(v, _mm512_loadu_pd(b1 + o), a2);
        a3 = _mm512_fmadd_pd(v, _mm512_loadu_pd(b1 + o + 8), a3);
        a4 = _mm512_fmadd_pd(v, _mm512_loadu_pd(b2 + o), a4);
        a5 = _mm512_fmadd_pd(v, _mm512_loadu_pd(b2 + o + 8), a5);
        a6 = _mm512_fmadd_pd(v, _mm512_loadu_pd(b3 + o), a6);
        a7 = _mm512_fmadd_pd(v, _mm512_loadu_pd(b3 + o + 8), a7);
    }
    _mm512_storeu_pd(out, a0);
    _mm512_storeu_pd(out + 8, a1);
    _mm512_storeu_pd(out + 16, a2);
    _mm512_storeu_pd(out + 24, a3);
    _mm512_storeu_pd(out + 32, a4);
    _mm512_storeu_pd(out + 40, a5);
    _mm512_storeu_pd(out + 48, a6);
    _mm512_storeu_pd(out + 56, a7);
}
#endif

typedef void (*dot_fn)(const double *const *xr, const double *blk, size_t dim, double *out);

#ifdef MLR_X86_DISPATCH
/* Single row (online SOM step), AVX-512 only: 64 centres per pass; returns 0 when the CPU lacks it. */
static int nearest1_avx512(const mlr_packed *p, const double *x, int32_t *best, double *d2best)
{
    if (!__builtin_cpu_supports("avx512f"))
        return 0;
    const size_t dim = p->dim, nb = p->kpad / MLR_PACK;
    double out[4 * MLR_PACK], bv = INFINITY;
    int32_t bi = 0;
    size_t jb = 0;
    while (jb < nb) {
        size_t take = nb - jb >= 4 ? 4 : 1;
        if (take == 4) {
            dot1x4_avx512(x, p->pc + jb * dim * MLR_PACK, dim, out);
        } else {
            const double *xr[MAX_G] = {x, x, x, x, x, x};
            double o6[6 * MLR_PACK];
            dot_avx512(xr, p->pc + jb * dim * MLR_PACK, dim, o6);
            memcpy(out, o6, MLR_PACK * sizeof(double));
        }
        for (size_t q = 0; q < take * MLR_PACK; q++) {
            double v = p->cn[jb * MLR_PACK + q] - 2.0 * out[q];
            if (v < bv) {
                bv = v;
                bi = (int32_t)(jb * MLR_PACK + q);
            }
        }
        jb += take;
    }
    double b = bv + mlr_norm2(x, dim);
    *best = bi;
    *d2best = b > 0 ? b : 0;
    return 1;
}
#endif

static dot_fn pick_dot(size_t *group)
{
#ifdef MLR_X86_DISPATCH
    if (__builtin_cpu_supports("avx512f")) {
        *group = 6;
        return dot_avx512;
    }
    if (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma")) {
        *group = 4;
        return dot_avx2;
    }
#endif
    *group = 4;
    return dot_generic;
}

void mlr_nearest2(const mlr_packed *p, const double *x, size_t ldx, const size_t *rows, size_t m,
                  const double *xn, int32_t *best, double *d2best, double *d2second,
                  int32_t *second)
{
#ifdef MLR_X86_DISPATCH
    if (m == 1 && !d2second && !second && nearest1_avx512(p, x + (rows ? rows[0] : 0) * ldx,
                                                          best, d2best))
        return;
#endif
    size_t G;
    dot_fn dot = pick_dot(&G);
    const size_t dim = p->dim, nb = p->kpad / MLR_PACK;
    double out[MAX_G * MLR_PACK];
    for (size_t r0 = 0; r0 < m; r0 += G) {
        const double *xr[MAX_G];
        size_t cnt = m - r0 < G ? m - r0 : G;
        for (size_t r = 0; r < G; r++) {
            size_t rr = r0 + (r < cnt ? r : cnt - 1);
            xr[r] = x + (rows ? rows[rr] : rr) * ldx;
        }
        double bv[MAX_G], sv[MAX_G];
        int32_t bi[MAX_G], si[MAX_G];
        for (size_t r = 0; r < G; r++) {
            bv[r] = sv[r] = INFINITY;
            bi[r] = 0;
            si[r] = -1;
        }
        for (size_t jb = 0; jb < nb; jb++) {
            dot(xr, p->pc + jb * dim * MLR_PACK, dim, out);
            const double *cn = p->cn + jb * MLR_PACK;
            for (size_t r = 0; r < cnt; r++) {
                const double *o = out + r * MLR_PACK;
                double val[MLR_PACK], mn = INFINITY;
                for (int l = 0; l < MLR_PACK; l++) { /* branch-free filter of the block */
                    val[l] = cn[l] - 2.0 * o[l];
                    mn = val[l] < mn ? val[l] : mn;
                }
                if (!(mn < sv[r]))
                    continue;
                for (int l = 0; l < MLR_PACK; l++) {
                    double v = val[l];
                    if (v < sv[r]) {
                        int32_t j = (int32_t)(jb * MLR_PACK + (size_t)l);
                        if (v < bv[r]) {
                            sv[r] = bv[r];
                            si[r] = bi[r];
                            bv[r] = v;
                            bi[r] = j;
                        } else {
                            sv[r] = v;
                            si[r] = j;
                        }
                    }
                }
            }
        }
        for (size_t r = 0; r < cnt; r++) {
            double xx = xn ? xn[r0 + r] : mlr_norm2(xr[r], dim);
            double b = bv[r] + xx, s = sv[r] + xx;
            best[r0 + r] = bi[r];
            d2best[r0 + r] = b > 0 ? b : 0;
            if (d2second)
                d2second[r0 + r] = s > 0 ? s : 0;
            if (second)
                second[r0 + r] = si[r] >= 0 ? si[r] : bi[r];
        }
    }
}

size_t mlr_first_nonfinite_row(const double *x, size_t n, size_t dim, size_t ldx)
{
    for (size_t i = 0; i < n; i++) {
        const double *r = x + i * ldx;
        double s = 0;
        for (size_t t = 0; t < dim; t++)
            s += r[t] * 0.0; /* NaN for a NaN or an infinity, 0 otherwise */
        if (s != 0.0 || s != s)
            return i;
    }
    return n;
}

/* ---- blobs ------------------------------------------------------------------------------------ */

static uint64_t fnv1a(const unsigned char *b, size_t n)
{
    uint64_t h = 0xcbf29ce484222325ull;
    for (size_t i = 0; i < n; i++) {
        h ^= b[i];
        h *= 0x100000001b3ull;
    }
    return h;
}

void mlr_blob_write(void *buf, const char tag[8], uint32_t version, const uint64_t dims[3],
                    const double *payload, size_t n_payload)
{
    unsigned char *b = buf;
    uint32_t bom = 0x01020304u;
    uint64_t total = MLR_BLOB_HEADER + (uint64_t)n_payload * 8, np = n_payload;
    memset(b, 0, MLR_BLOB_HEADER);
    memcpy(b, tag, 8);
    memcpy(b + 8, &version, 4);
    memcpy(b + 12, &bom, 4);
    memcpy(b + 16, &total, 8);
    memcpy(b + 24, &np, 8);
    memcpy(b + 32, dims, 24);
    if (n_payload)
        memcpy(b + MLR_BLOB_HEADER, payload, n_payload * 8);
    uint64_t h = fnv1a(b + MLR_BLOB_HEADER, n_payload * 8);
    memcpy(b + 56, &h, 8);
}

mlr_status mlr_blob_check(const void *buf, size_t size, const char tag[8], uint32_t version,
                          uint64_t dims[3], const unsigned char **payload, size_t *n_payload,
                          mlr_diag *diag)
{
    const unsigned char *b = buf;
    if (!buf)
        return mlr_diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "blob is NULL");
    if (size < MLR_BLOB_HEADER)
        return mlr_diag_set(diag, MLR_E_PARSE, 0, 0, "blob of %zu bytes is shorter than its header",
                            size);
    if (memcmp(b, tag, 8) != 0)
        return mlr_diag_set(diag, MLR_E_PARSE, 0, 0, "blob tag is not %.6s", tag);
    uint32_t ver, bom;
    uint64_t total, np, h;
    memcpy(&ver, b + 8, 4);
    memcpy(&bom, b + 12, 4);
    memcpy(&total, b + 16, 8);
    memcpy(&np, b + 24, 8);
    memcpy(dims, b + 32, 24);
    memcpy(&h, b + 56, 8);
    if (bom != 0x01020304u)
        return mlr_diag_set(diag, MLR_E_PARSE, 0, 0, "blob written with another byte order");
    if (ver != version)
        return mlr_diag_set(diag, MLR_E_PARSE, 0, 0, "blob version %u, this library reads %u",
                            (unsigned)ver, (unsigned)version);
    if (total != size || np > (size - MLR_BLOB_HEADER) / 8 || MLR_BLOB_HEADER + np * 8 != total)
        return mlr_diag_set(diag, MLR_E_PARSE, 0, 0,
                            "blob size %zu does not match its header (%llu bytes, %llu values)",
                            size, (unsigned long long)total, (unsigned long long)np);
    if (fnv1a(b + MLR_BLOB_HEADER, (size_t)np * 8) != h)
        return mlr_diag_set(diag, MLR_E_PARSE, 0, 0, "blob hash mismatch: the data is corrupt");
    *payload = b + MLR_BLOB_HEADER;
    *n_payload = (size_t)np;
    return MLR_OK;
}
