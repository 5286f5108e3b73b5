/* Motion layers: the layer identity on every real clip; synthesis at alpha 0 and 1 against
 * the layers; the gamma bound of the base heuristic checked with an independent LGS solve; GCV
 * against a brute-force scan with dense inverses; explicit lam_c / sigma_c; denoising of a
 * synthetic motion at 24-120 fps; bad arguments; allocation failures; threads. */
#include "mlr_test.h"

#include <dirent.h>
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define PI 3.14159265358979323846

/* ---- small helpers ---------------------------------------------------------------------- */

static double qdot(const double *a, const double *b)
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3];
}

/* Rotation angle between unit quaternions a and b (sign-insensitive, accurate near 0). */
static double qangle(const double *a, const double *b)
{
    mlr_quat ca = {a[0], -a[1], -a[2], -a[3]}, r;
    mlr_quat_mul(&ca, (const mlr_quat *)(const void *)b, &r);
    double s = sqrt(r.x * r.x + r.y * r.y + r.z * r.z);
    return 2.0 * atan2(s, fabs(r.w));
}

/* Max over components of min(|a - b|, |a + b|) for quaternion arrays. */
static double qdiff_sign(const double *a, const double *b, size_t count)
{
    double e = 0.0;
    for (size_t i = 0; i < count; i++) {
        double dp = 0.0, dm = 0.0;
        for (int c = 0; c < 4; c++) {
            dp = fmax(dp, fabs(a[4 * i + c] - b[4 * i + c]));
            dm = fmax(dm, fabs(a[4 * i + c] + b[4 * i + c]));
        }
        e = fmax(e, fmin(dp, dm));
    }
    return e;
}

static void normalize_copy(const double *in, double *out, size_t count)
{
    for (size_t i = 0; i < count; i++) {
        double n = sqrt(qdot(in + 4 * i, in + 4 * i));
        for (int c = 0; c < 4; c++)
            out[4 * i + c] = in[4 * i + c] / n;
    }
}

/* Dense (I + s L^T L)^-1 (order 2) by Gauss-Jordan; caller frees. */
static double *dense_h(size_t n, double s)
{
    double *M = calloc(n * n, sizeof *M), *H = calloc(n * n, sizeof *H);
    const double c[3] = {1, -2, 1};
    for (size_t r = 0; r + 2 < n; r++)
        for (size_t a = 0; a < 3; a++)
            for (size_t b = 0; b < 3; b++)
                M[(r + a) * n + r + b] += s * c[a] * c[b];
    for (size_t i = 0; i < n; i++) {
        M[i * n + i] += 1.0;
        H[i * n + i] = 1.0;
    }
    for (size_t p = 0; p < n; p++) {
        double d = M[p * n + p];
        for (size_t k = 0; k < n; k++) {
            M[p * n + k] /= d;
            H[p * n + k] /= d;
        }
        for (size_t r = 0; r < n; r++) {
            if (r == p)
                continue;
            double f = M[r * n + p];
            for (size_t k = 0; k < n; k++) {
                M[r * n + k] -= f * M[p * n + k];
                H[r * n + k] -= f * H[p * n + k];
            }
        }
    }
    free(M);
    return H;
}

/* Dense GCV of n x 3 data y at s; tr(H) into *dof. */
static double dense_gcv(size_t n, const double *y, size_t ldy, double s, double *dof)
{
    double *H = dense_h(n, s), rss = 0.0, tr = 0.0;
    for (size_t i = 0; i < n; i++) {
        tr += H[i * n + i];
        for (size_t c = 0; c < 3; c++) {
            double hy = 0.0;
            for (size_t k = 0; k < n; k++)
                hy += H[i * n + k] * y[k * ldy + c];
            rss += (y[i * ldy + c] - hy) * (y[i * ldy + c] - hy);
        }
    }
    free(H);
    if (dof)
        *dof = tr;
    double den = 1.0 - tr / (double)n;
    return rss / (3.0 * (double)n) / (den * den);
}

/* Largest angle of the displacement of joint k after an independent base solve at s:
 * mlr_lgs on the sign-continuous quaternion channels, renormalized. */
static double base_max_angle(size_t n, size_t j, const double *rot, size_t k, double s)
{
    double *y = malloc(n * 4 * sizeof *y), *x = malloc(n * 4 * sizeof *x);
    for (size_t i = 0; i < n; i++) {
        double nn = sqrt(qdot(rot + 4 * (i * j + k), rot + 4 * (i * j + k)));
        for (int c = 0; c < 4; c++)
            y[4 * i + c] = rot[4 * (i * j + k) + c] / nn;
    }
    mlr_quat_make_continuous((mlr_quat *)(void *)y, n, 1);
    mlr_lgs *g = NULL;
    ck_assert_int_ge(mlr_lgs_create(n, 2, sqrt(s), 1.0, NULL, n, MLR_LGS_BANDED, NULL, &g, NULL),
                     0);
    ck_assert_int_eq(mlr_lgs_solve(g, y, 4, 4, x, 4, NULL), MLR_OK);
    mlr_lgs_destroy(g);
    double amax = 0.0;
    for (size_t i = 0; i < n; i++) {
        double nb = sqrt(qdot(x + 4 * i, x + 4 * i));
        for (int c = 0; c < 4; c++)
            x[4 * i + c] /= nb;
        amax = fmax(amax, qangle(x + 4 * i, y + 4 * i));
    }
    free(y), free(x);
    return amax;
}

/* ---- clips -------------------------------------------------------------------------------- */

typedef struct clip {
    char name[256];
    mlr_motion *m;
    size_t n, j;
    const double *pos, *rot;
} clip;

static void load_one(clip *c, const char *name, const char *path)
{
    snprintf(c->name, sizeof c->name, "%s", name);
    mlr_diag dg;
    ck_assert_msg(mlr_bvh_read_file(path, NULL, &c->m, &dg) == MLR_OK, "%s: %s", path, dg.message);
    c->n = mlr_motion_n_frames(c->m);
    c->j = mlr_motion_n_joints(c->m);
    c->pos = mlr_motion_root_pos(c->m);
    c->rot = mlr_motion_rot(c->m);
}

/* Every clip of the shared folder; when it is absent, the clips of this repository: the
 * bundled walk, then the first five wild clips. (Not the two MakeHuman cycles: on the zombie
 * walk, whose root x is -0 throughout, the alpha-0 synthesis gives +0 where the base layer
 * holds -0, and alpha_zero_is_base_and_one_is_denoised compares bits.) */
static size_t load_clips(clip *out, size_t cap)
{
    size_t n = 0;
    char path[4096];
    if (!mlr_test_have_clips()) {
        for (size_t k = 0; k <= 5 && n < cap; k++) {
            const char *file = k ? mlr_test_wild_clips[k - 1] : MLR_TEST_BUNDLED_CLIP;
            ck_assert_ptr_nonnull(mlr_test_clip_path(file, path, sizeof path));
            load_one(&out[n++], file, path);
        }
        return n;
    }
    const char *dir = mlr_test_mocap_dir();
    DIR *d = opendir(dir);
    ck_assert_ptr_nonnull(d);
    struct dirent *e;
    while ((e = readdir(d)) && n < cap) {
        size_t len = strlen(e->d_name);
        if (len < 5 || strcmp(e->d_name + len - 4, ".bvh"))
            continue;
        snprintf(path, sizeof path, "%s/%s", dir, e->d_name);
        load_one(&out[n++], e->d_name, path);
    }
    closedir(d);
    ck_assert_uint_ge(n, 1);
    return n;
}

static void free_clips(clip *c, size_t n)
{
    for (size_t i = 0; i < n; i++)
        mlr_motion_destroy(c[i].m);
}

/* ---- tests --------------------------------------------------------------------------------- */

START_TEST(identity_on_every_clip)
{
    clip clips[16];
    size_t nc = load_clips(clips, 16);
    for (size_t ci = 0; ci < nc; ci++) {
        const clip *c = &clips[ci];
        mlr_layers *L = NULL;
        mlr_diag dg;
        ck_assert_msg(mlr_layers_decompose(c->n, c->j, c->pos, c->rot, NULL, 0, NULL, &L, &dg) ==
                          MLR_OK,
                      "%s: %s", c->name, dg.message);
        ck_assert_uint_eq(mlr_layers_n_frames(L), c->n);
        ck_assert_uint_eq(mlr_layers_n_joints(L), c->j);
        const size_t n = c->n, j = c->j, nr = 4 * n * j;
        double *pos = malloc(3 * n * sizeof *pos), *rot = malloc(nr * sizeof *rot);
        double *unit = malloc(nr * sizeof *unit);
        normalize_copy(c->rot, unit, n * j);
        ck_assert_int_eq(mlr_layers_reconstruct(L, 0, n, pos, 3 * n, rot, nr, NULL), MLR_OK);
        double ep = 0.0, scale = 1.0;
        for (size_t i = 0; i < 3 * n; i++) {
            ep = fmax(ep, fabs(pos[i] - c->pos[i]));
            scale = fmax(scale, fabs(c->pos[i]));
        }
        double eq = qdiff_sign(rot, unit, n * j);
        ck_assert_msg(ep <= 1e-12 * scale && eq <= 1e-12,
                      "%s: identity error pos %.3g (scale %g), rot %.3g", c->name, ep, scale, eq);
        /* a sub-range reproduces the same frames */
        size_t b0 = n / 3, cnt = n / 4;
        double *pos2 = malloc(3 * cnt * sizeof *pos2), *rot2 = malloc(4 * cnt * j * sizeof *rot2);
        ck_assert_int_eq(
            mlr_layers_reconstruct(L, b0, cnt, pos2, 3 * cnt, rot2, 4 * cnt * j, NULL), MLR_OK);
        ck_assert(memcmp(pos2, pos + 3 * b0, 3 * cnt * sizeof *pos2) == 0);
        ck_assert(memcmp(rot2, rot + 4 * j * b0, 4 * cnt * j * sizeof *rot2) == 0);
        free(pos2), free(rot2);
        free(pos), free(rot), free(unit);
        mlr_layers_destroy(L);
    }
    free_clips(clips, nc);
}
END_TEST

START_TEST(alpha_zero_is_base_and_one_is_denoised)
{
    clip clips[16];
    size_t nc = load_clips(clips, 16);
    for (size_t ci = 0; ci < nc; ci++) {
        const clip *c = &clips[ci];
        const size_t n = c->n, j = c->j, nr = 4 * n * j, ng = 3 * n * (1 + j);
        mlr_layers *L = NULL;
        ck_assert_int_eq(mlr_layers_decompose(n, j, c->pos, c->rot, NULL, 0, NULL, &L, NULL),
                         MLR_OK);
        double *bp = malloc(3 * n * sizeof *bp), *br = malloc(nr * sizeof *br);
        double *sp = malloc(3 * n * sizeof *sp), *sr = malloc(nr * sizeof *sr);
        double *ctl = malloc(ng * sizeof *ctl), *res = malloc(ng * sizeof *res);
        double *unit = malloc(nr * sizeof *unit);
        normalize_copy(c->rot, unit, n * j);
        ck_assert_int_eq(mlr_layers_get_base(L, bp, 3 * n, br, nr), MLR_OK);
        ck_assert_int_eq(mlr_layers_get_control(L, ctl, ng), MLR_OK);
        ck_assert_int_eq(mlr_layers_get_residual(L, res, ng), MLR_OK);
        for (size_t i = 0; i < n * j; i++)  /* base quaternions are unit */
            ck_assert_close(qdot(br + 4 * i, br + 4 * i), 1.0, 1e-14);
        const double zero = 0.0, one = 1.0;
        ck_assert_int_eq(mlr_layers_synthesize(L, 0, n, &zero, 1, sp, 3 * n, sr, nr, NULL),
                         MLR_OK);
        ck_assert_msg(memcmp(sp, bp, 3 * n * sizeof *sp) == 0, "%s", c->name);
        ck_assert_double_le(qdiff_sign(sr, br, n * j), 1e-15);
        ck_assert_int_eq(mlr_layers_synthesize(L, 0, n, &one, 1, sp, 3 * n, sr, nr, NULL), MLR_OK);
        /* alpha = 1: the input minus exactly the residual */
        double ep = 0.0, ea = 0.0, scale = 1.0;
        for (size_t i = 0; i < n; i++) {
            const double *ri = res + 3 * (1 + j) * i;
            for (size_t k = 0; k < 3; k++) {
                ep = fmax(ep, fabs(sp[3 * i + k] + ri[k] - c->pos[3 * i + k]));
                scale = fmax(scale, fabs(c->pos[3 * i + k]));
            }
            for (size_t k = 0; k < j; k++) {
                const double *r = ri + 3 + 3 * k;
                double rn = sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
                ea = fmax(ea, fabs(qangle(sr + 4 * (i * j + k), unit + 4 * (i * j + k)) - rn));
            }
        }
        ck_assert_msg(ep <= 1e-12 * scale && ea <= 1e-9, "%s: alpha=1 pos %.3g rot angle %.3g",
                      c->name, ep, ea);
        /* an alpha per group: only the scaled joint moves away from the base */
        double *alpha = calloc(1 + j, sizeof *alpha);
        const size_t pick = j / 2;
        alpha[1 + pick] = 2.0;
        ck_assert_int_eq(mlr_layers_synthesize(L, 0, n, alpha, 1 + j, sp, 3 * n, sr, nr, NULL),
                         MLR_OK);
        ck_assert_msg(memcmp(sp, bp, 3 * n * sizeof *sp) == 0, "%s", c->name);
        for (size_t i = 0; i < n; i++) {
            for (size_t k = 0; k < j; k++) {
                const double *v = ctl + 3 * (1 + j) * i + 3 + 3 * k;
                const double own = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
                double want = k == pick ? 2.0 * own : 0.0;
                if (want > 0.5 * PI) /* saturated below a half turn (quat__scale_turn) */
                    want = fmax(own, 0.5 * PI + 0.4 * PI * tanh((want - 0.5 * PI) / (0.4 * PI)));
                double got = qangle(sr + 4 * (i * j + k), br + 4 * (i * j + k));
                ck_assert_double_le(fabs(got - want), 1e-9);
            }
        }
        free(alpha);
        free(bp), free(br), free(sp), free(sr), free(ctl), free(res), free(unit);
        mlr_layers_destroy(L);
    }
    free_clips(clips, nc);
}
END_TEST

/* The base of the root translation is the LGS of joint 0's s; the control layer of the root
 * is the LGS of u0 = control + residual at the reported control s. (Without the robust search:
 * a frame it leaves out, such as CMU 10_01's lead-in, weighs 0 in those LGS.) */
START_TEST(root_layers_match_lgs)
{
    clip clips[16];
    size_t nc = load_clips(clips, 16);
    const mlr_layers_option plain[] = {{MLR_LAYERS_OPT_ROBUST, 0}};
    for (size_t ci = 0; ci < nc; ci++) {
        const clip *c = &clips[ci];
        const size_t n = c->n, j = c->j, ng = 3 * n * (1 + j), ld = 3 * (1 + j);
        mlr_layers *L = NULL;
        ck_assert_int_eq(mlr_layers_decompose(n, j, c->pos, c->rot, plain, 1, NULL, &L, NULL),
                         MLR_OK);
        double *bs = malloc((1 + j) * sizeof *bs), *cs = malloc((1 + j) * sizeof *cs);
        double *bp = malloc(3 * n * sizeof *bp), *x = malloc(3 * n * sizeof *x);
        double *u = malloc(3 * n * sizeof *u);
        double *ctl = malloc(ng * sizeof *ctl), *res = malloc(ng * sizeof *res);
        ck_assert_int_eq(mlr_layers_get_param(L, MLR_LAYERS_PARAM_BASE_S, bs, 1 + j), MLR_OK);
        ck_assert_int_eq(mlr_layers_get_param(L, MLR_LAYERS_PARAM_CONTROL_S, cs, 1 + j), MLR_OK);
        ck_assert_double_eq(bs[0], bs[1]);
        ck_assert_int_eq(mlr_layers_get_base(L, bp, 3 * n, NULL, 0), MLR_OK);
        ck_assert_int_eq(mlr_layers_get_control(L, ctl, ng), MLR_OK);
        ck_assert_int_eq(mlr_layers_get_residual(L, res, ng), MLR_OK);
        mlr_lgs *g = NULL;
        ck_assert_int_ge(
            mlr_lgs_create(n, 2, sqrt(bs[0]), 1.0, NULL, n, MLR_LGS_BANDED, NULL, &g, NULL), 0);
        ck_assert_int_eq(mlr_lgs_solve(g, c->pos, 3, 3, x, 3, NULL), MLR_OK);
        mlr_lgs_destroy(g);
        double e = 0.0, scale = 1.0;
        for (size_t i = 0; i < 3 * n; i++) {
            e = fmax(e, fabs(x[i] - bp[i]));
            scale = fmax(scale, fabs(c->pos[i]));
        }
        /* two solvers of I + s L^T L agree to about eps * cond = eps (1 + 16 s) */
        ck_assert_msg(e <= 1e-14 * (1.0 + 16.0 * bs[0]) * scale, "%s: root base vs mlr_lgs %.3g",
                      c->name, e);
        for (size_t i = 0; i < n; i++)
            for (size_t k = 0; k < 3; k++)
                u[3 * i + k] = ctl[i * ld + k] + res[i * ld + k];
        ck_assert_int_ge(
            mlr_lgs_create(n, 2, sqrt(cs[0]), 1.0, NULL, n, MLR_LGS_BANDED, NULL, &g, NULL), 0);
        ck_assert_int_eq(mlr_lgs_solve(g, u, 3, 3, x, 3, NULL), MLR_OK);
        mlr_lgs_destroy(g);
        e = 0.0;
        for (size_t i = 0; i < n; i++)
            for (size_t k = 0; k < 3; k++)
                e = fmax(e, fabs(x[3 * i + k] - ctl[i * ld + k]));
        ck_assert_msg(e <= 1e-14 * (1.0 + 16.0 * cs[0]) * scale,
                      "%s: root control vs mlr_lgs %.3g", c->name, e);
        free(bs), free(cs), free(bp), free(x), free(u), free(ctl), free(res);
        mlr_layers_destroy(L);
    }
    free_clips(clips, nc);
}
END_TEST

/* Check the bound of every joint's s with an independent solve; an interior s is the
 * strongest within 5%. */
static size_t check_gamma_bound(const char *name, size_t n, size_t j, const double *pos,
                                const double *rot, double gamma, double s_max)
{
    /* the plain heuristic (the robust one skips outlier frames in the bound: see below) */
    mlr_layers_option opt[3] = {{MLR_LAYERS_OPT_GAMMA, gamma},
                                {MLR_LAYERS_OPT_BASE_S_MAX, s_max},
                                {MLR_LAYERS_OPT_ROBUST, 0.0}};
    mlr_layers *L = NULL;
    mlr_diag dg;
    ck_assert_msg(mlr_layers_decompose(n, j, pos, rot, opt, 3, NULL, &L, &dg) == MLR_OK, "%s: %s",
                  name, dg.message);
    double *s = malloc((1 + j) * sizeof *s), *amax = malloc((1 + j) * sizeof *amax);
    ck_assert_int_eq(mlr_layers_get_param(L, MLR_LAYERS_PARAM_BASE_S, s, 1 + j), MLR_OK);
    ck_assert_int_eq(mlr_layers_get_param(L, MLR_LAYERS_PARAM_BASE_MAX_ANGLE, amax, 1 + j),
                     MLR_OK);
    size_t interior = 0;
    for (size_t k = 0; k < j; k++) {
        const double sk = s[1 + k];
        ck_assert(sk >= 1e-2 && sk <= s_max);
        /* two solvers of I + s L^T L agree to about eps * cond = eps (1 + 16 s) */
        const double tol = 1e-12 + 1e-15 * (1.0 + 16.0 * 1.05 * sk);
        double a = base_max_angle(n, j, rot, k, sk);
        ck_assert_msg(fabs(a - amax[1 + k]) <= tol,
                      "%s joint %zu: max angle %.17g, reported %.17g", name, k, a, amax[1 + k]);
        if (sk == 1e-2)
            continue; /* even the weakest setting may break the bound */
        ck_assert_msg(amax[1 + k] <= gamma, "%s joint %zu: s %g gives %.6f > gamma %.6f", name, k,
                      sk, amax[1 + k], gamma);
        ck_assert(a <= gamma + tol);
        if (sk < s_max) {
            interior++;
            double a5 = base_max_angle(n, j, rot, k, 1.05 * sk);
            ck_assert_msg(a5 > gamma - tol,
                          "%s joint %zu: s %g is not the strongest: 1.05 s gives %.6f <= %.6f",
                          name, k, sk, a5, gamma);
        }
    }
    free(s), free(amax);
    mlr_layers_destroy(L);
    return interior;
}

/* A synthetic motion with large rotations: joint 0 spins about y (several turns), joint 1
 * swings +-150 degrees, joint 2 moves little; seeded noise on top. */
static void synthetic_big(size_t n, double fps, double *pos, double *rot, uint64_t seed)
{
    mlr_test_rng rng;
    mlr_test_rng_seed(&rng, seed);
    for (size_t i = 0; i < n; i++) {
        double t = (double)i / fps;
        double ang[3][3] = {{0.2 * sin(1.3 * t), 2.0 * t + 0.8 * sin(0.7 * t), 0.1 * cos(2.1 * t)},
                            {2.6 * sin(1.1 * t), 0.3 * sin(0.4 * t), 0.5 * cos(0.9 * t)},
                            {0.2 * sin(3.0 * t), 0.1 * cos(2.0 * t), 0.15 * sin(1.7 * t)}};
        for (size_t k = 0; k < 3; k++) {
            for (size_t a = 0; a < 3; a++)
                ang[k][a] += 0.01 * mlr_test_rng_normal(&rng);
            mlr_quat_from_euler_array(ang[k], 1, MLR_EULER_ZYX,
                                      (mlr_quat *)(void *)(rot + 4 * (3 * i + k)), NULL);
        }
        pos[3 * i] = 10.0 * sin(0.3 * t);
        pos[3 * i + 1] = 90.0 + 3.0 * sin(4.0 * t);
        pos[3 * i + 2] = 50.0 * t;
    }
}

START_TEST(gamma_bound_synthetic)
{
    const double fps[] = {30.0, 120.0};
    const double gammas[] = {PI / 2, 2.0, 3.0};
    for (size_t f = 0; f < 2; f++) {
        size_t n = (size_t)(12.0 * fps[f]);
        double *pos = malloc(3 * n * sizeof *pos), *rot = malloc(12 * n * sizeof *rot);
        synthetic_big(n, fps[f], pos, rot, 7 + f);
        for (size_t g = 0; g < 3; g++) /* the spinning joint binds */
            ck_assert_uint_ge(check_gamma_bound("synthetic", n, 3, pos, rot, gammas[g], 1e10), 1);
        free(pos), free(rot);
    }
}
END_TEST

START_TEST(gamma_bound_real_clips)
{
    clip clips[16];
    size_t nc = load_clips(clips, 16);
    for (size_t ci = 0; ci < nc; ci++) {
        const clip *c = &clips[ci];
        if (c->j > 50)
            continue; /* the 165-joint clip adds time, not coverage */
        check_gamma_bound(c->name, c->n, c->j, c->pos, c->rot, PI / 2, 1e10);
        check_gamma_bound(c->name, c->n, c->j, c->pos, c->rot, 2.5, 1e10);
    }
    free_clips(clips, nc);
}
END_TEST

/* GCV on a small problem: the chosen s is the minimum of a dense brute-force scan, and the
 * reported GCV and tr(H) match dense values. */
START_TEST(gcv_matches_dense_scan)
{
    const size_t n = 60;
    for (uint64_t seed = 1; seed <= 4; seed++) {
        double pos[3 * 60], rot[4 * 60];
        mlr_test_rng rng;
        mlr_test_rng_seed(&rng, seed);
        const double noise = seed == 4 ? 1e-4 : 0.05 * (double)seed;
        for (size_t i = 0; i < n; i++) {
            double t = (double)i / 30.0;
            double ang[3] = {0.8 * sin(2.0 * t) + noise * mlr_test_rng_normal(&rng),
                             0.3 * t + noise * mlr_test_rng_normal(&rng),
                             0.2 * cos(3.0 * t) + noise * mlr_test_rng_normal(&rng)};
            mlr_quat_from_euler_array(ang, 1, MLR_EULER_XYZ, (mlr_quat *)(void *)(rot + 4 * i),
                                      NULL);
            for (size_t k = 0; k < 3; k++)
                pos[3 * i + k] =
                    sin(1.5 * t + (double)k) + 10.0 * noise * mlr_test_rng_normal(&rng);
        }
        mlr_layers *L = NULL;
        ck_assert_int_eq(mlr_layers_decompose(n, 1, pos, rot, NULL, 0, NULL, &L, NULL), MLR_OK);
        double cs[2], gcv[2], dof[2], ctl[6 * 60], res[6 * 60], br[4 * 60];
        ck_assert_int_eq(mlr_layers_get_param(L, MLR_LAYERS_PARAM_CONTROL_S, cs, 2), MLR_OK);
        ck_assert_int_eq(mlr_layers_get_param(L, MLR_LAYERS_PARAM_CONTROL_GCV, gcv, 2), MLR_OK);
        ck_assert_int_eq(mlr_layers_get_param(L, MLR_LAYERS_PARAM_CONTROL_DOF, dof, 2), MLR_OK);
        ck_assert_int_eq(mlr_layers_get_control(L, ctl, 6 * n), MLR_OK);
        ck_assert_int_eq(mlr_layers_get_residual(L, res, 6 * n), MLR_OK);
        ck_assert_int_eq(mlr_layers_get_base(L, NULL, 0, br, 4 * n), MLR_OK);
        /* the displacement of each group, rebuilt independently */
        double y[2][3 * 60];
        double unit[4 * 60];
        normalize_copy(rot, unit, n);
        mlr_quat_make_continuous((mlr_quat *)(void *)unit, n, 1);
        for (size_t i = 0; i < n; i++) {
            for (size_t k = 0; k < 3; k++)
                y[0][3 * i + k] = ctl[6 * i + k] + res[6 * i + k];
            mlr_quat cb = {br[4 * i], -br[4 * i + 1], -br[4 * i + 2], -br[4 * i + 3]}, p;
            mlr_quat_mul(&cb, (const mlr_quat *)(const void *)(unit + 4 * i), &p);
            mlr_quat_log_array(&p, 1, (mlr_vec3 *)(void *)(y[1] + 3 * i), NULL);
        }
        for (size_t g = 0; g < 2; g++) {
            double d_dof, d_gcv = dense_gcv(n, y[g], 3, cs[g], &d_dof);
            ck_assert_msg(fabs(d_dof - dof[g]) <= 1e-10 * n, "tr(H) %.17g vs dense %.17g", dof[g],
                          d_dof);
            ck_assert_msg(fabs(d_gcv - gcv[g]) <= 1e-8 * d_gcv, "GCV %.17g vs dense %.17g", gcv[g],
                          d_gcv);
            /* brute-force scan over [1e-2, 1e8], 20 points per decade */
            double best = INFINITY, s_best = 0.0;
            for (int p = 0; p <= 200; p++) {
                double s = pow(10.0, -2.0 + 0.05 * p), v = dense_gcv(n, y[g], 3, s, NULL);
                if (v < best)
                    best = v, s_best = s;
            }
            ck_assert_msg(gcv[g] <= best * (1.0 + 1e-6),
                          "seed %d group %zu: GCV %.10g at s %g above the scan's %.10g at s %g",
                          (int)seed, g, gcv[g], cs[g], best, s_best);
            if (s_best > 1e-2 && s_best < 1e8)
                ck_assert_msg(fabs(log(cs[g] / s_best)) < log(1.2), "s %g vs scan %g", cs[g],
                              s_best);
        }
        mlr_layers_destroy(L);
    }
}
END_TEST

/* GCV of n x 3 data y at s through the banded LGS (an implementation apart from the layers'
 * batched one): RSS from mlr_lgs_solve, tr(H) from its posterior variance (sigma = 1). */
static double banded_gcv(size_t n, const double *y, double s)
{
    mlr_lgs *g = NULL;
    double *x = malloc(n * 3 * sizeof *x), *var = malloc(n * sizeof *var), rss = 0.0, tr = 0.0;
    ck_assert_int_ge(mlr_lgs_create(n, 2, sqrt(s), 1.0, NULL, n, MLR_LGS_BANDED, NULL, &g, NULL),
                     0);
    ck_assert_int_eq(mlr_lgs_solve(g, y, 3, 3, x, 3, NULL), MLR_OK);
    ck_assert_int_eq(mlr_lgs_variance(g, var, n, NULL), MLR_OK);
    for (size_t i = 0; i < n; i++) {
        tr += var[i];
        for (size_t c = 0; c < 3; c++)
            rss += (y[3 * i + c] - x[3 * i + c]) * (y[3 * i + c] - x[3 * i + c]);
    }
    mlr_lgs_destroy(g);
    free(x), free(var);
    const double den = 1.0 - tr / (double)n;
    return rss / (3.0 * (double)n) / (den * den);
}

/* The longest real clip (LaFAN1, 7184 frames) with seeded noise (1.5 degrees per rotation
 * axis, 0.5 units on the root) takes the single-pass (chunked) residual sums of the GCV search:
 * every group's reported GCV matches the banded one, and no point of a scan of the banded GCV
 * beats it. */
START_TEST(gcv_long_clip_matches_banded_scan)
{
    MLR_TEST_NEED_CLIPS(); /* LaFAN1: 7184 frames, the chunked sums */
    clip clips[16];
    size_t nc = load_clips(clips, 16), li = 0;
    for (size_t i = 1; i < nc; i++)
        if (clips[i].n > clips[li].n)
            li = i;
    const clip *c = &clips[li];
    const size_t n = c->n, J = c->j, ng = J + 1;
    ck_assert_uint_ge(n, 6000);
    double *unit = malloc(n * J * 4 * sizeof *unit), *ctl = malloc(n * 3 * ng * sizeof *ctl);
    double *res = malloc(n * 3 * ng * sizeof *res), *br = malloc(n * J * 4 * sizeof *br);
    double *y = malloc(n * 3 * sizeof *y), *cs = malloc(ng * sizeof *cs);
    double *gcv = malloc(ng * sizeof *gcv), *pos = malloc(n * 3 * sizeof *pos);
    double *rot = malloc(n * J * 4 * sizeof *rot);
    mlr_test_rng rng;
    mlr_test_rng_seed(&rng, 1515);
    for (size_t i = 0; i < n * J; i++) {
        double v[3];
        for (int k = 0; k < 3; k++)
            v[k] = 1.5 * PI / 180.0 * mlr_test_rng_normal(&rng);
        mlr_quat dq;
        ck_assert_int_eq(mlr_quat_exp_array((const mlr_vec3 *)(const void *)v, 1, &dq, NULL),
                         MLR_OK);
        mlr_quat_mul((const mlr_quat *)(const void *)(c->rot + 4 * i), &dq,
                     (mlr_quat *)(void *)(rot + 4 * i));
    }
    for (size_t i = 0; i < n * 3; i++)
        pos[i] = c->pos[i] + 0.5 * mlr_test_rng_normal(&rng);
    mlr_layers *L = NULL;
    ck_assert_int_eq(mlr_layers_decompose(n, J, pos, rot, NULL, 0, NULL, &L, NULL), MLR_OK);
    ck_assert_int_eq(mlr_layers_get_param(L, MLR_LAYERS_PARAM_CONTROL_S, cs, ng), MLR_OK);
    ck_assert_int_eq(mlr_layers_get_param(L, MLR_LAYERS_PARAM_CONTROL_GCV, gcv, ng), MLR_OK);
    ck_assert_int_eq(mlr_layers_get_control(L, ctl, 3 * ng * n), MLR_OK);
    ck_assert_int_eq(mlr_layers_get_residual(L, res, 3 * ng * n), MLR_OK);
    ck_assert_int_eq(mlr_layers_get_base(L, NULL, 0, br, 4 * J * n), MLR_OK);
    normalize_copy(rot, unit, n * J);
    mlr_quat_make_continuous((mlr_quat *)(void *)unit, n, J);
    size_t interior = 0;
    for (size_t g = 0; g < ng; g++) {
        if (isnan(gcv[g])) /* an identically zero displacement (an unanimated joint) */
            continue;
        for (size_t i = 0; i < n; i++) { /* the displacement of group g, rebuilt */
            if (g == 0) {
                for (size_t k = 0; k < 3; k++)
                    y[3 * i + k] = ctl[3 * ng * i + k] + res[3 * ng * i + k];
            } else {
                const double *b = br + 4 * (i * J + g - 1);
                mlr_quat cb = {b[0], -b[1], -b[2], -b[3]}, p;
                mlr_quat_mul(&cb, (const mlr_quat *)(const void *)(unit + 4 * (i * J + g - 1)),
                             &p);
                mlr_quat_log_array(&p, 1, (mlr_vec3 *)(void *)(y + 3 * i), NULL);
            }
        }
        const double at = banded_gcv(n, y, cs[g]);
        ck_assert_msg(fabs(at - gcv[g]) <= 1e-8 * at, "group %zu: GCV %.17g vs banded %.17g", g,
                      gcv[g], at);
        double best = INFINITY, s_best = 0.0;
        for (int p = 0; p <= 100; p++) { /* [1e-2, 1e8], 10 points per decade */
            const double sp = pow(10.0, -2.0 + 0.1 * p), v = banded_gcv(n, y, sp);
            if (v < best)
                best = v, s_best = sp;
        }
        ck_assert_msg(gcv[g] <= best * (1.0 + 1e-6),
                      "group %zu: GCV %.10g at s %g above the "
                      "scan's %.10g at s %g",
                      g, gcv[g], cs[g], best, s_best);
        interior += s_best > 1e-2 && s_best < 1e8;
    }
    ck_assert_uint_ge(interior, J / 2); /* most groups have a real minimum to find */
    mlr_layers_destroy(L);
    free(unit), free(ctl), free(res), free(br), free(y), free(cs), free(gcv), free(pos), free(rot);
    free_clips(clips, nc);
}
END_TEST

START_TEST(explicit_control_parameters)
{
    clip clips[16];
    size_t nc = load_clips(clips, 16);
    const clip *c = &clips[0];
    const size_t n = c->n, j = c->j, ld = 3 * (1 + j), ng = ld * n;
    mlr_layers_option opt[2] = {{MLR_LAYERS_OPT_LAM_C, 2.0}, {MLR_LAYERS_OPT_SIGMA_C, 0.25}};
    mlr_layers *L = NULL;
    ck_assert_int_eq(mlr_layers_decompose(n, j, c->pos, c->rot, opt, 2, NULL, &L, NULL), MLR_OK);
    double *p = malloc((1 + j) * sizeof *p), *ctl = malloc(ng * sizeof *ctl),
           *res = malloc(ng * sizeof *res);
    ck_assert_int_eq(mlr_layers_get_param(L, MLR_LAYERS_PARAM_CONTROL_S, p, 1 + j), MLR_OK);
    for (size_t g = 0; g <= j; g++)
        ck_assert_double_eq_tol(p[g], 0.25, 1e-15);
    ck_assert_int_eq(mlr_layers_get_param(L, MLR_LAYERS_PARAM_CONTROL_GCV, p, 1 + j), MLR_OK);
    for (size_t g = 0; g <= j; g++)
        ck_assert(isnan(p[g]));
    ck_assert_int_eq(mlr_layers_get_param(L, MLR_LAYERS_PARAM_CONTROL_LAM, p, 1 + j), MLR_OK);
    ck_assert_double_eq_tol(p[0], sqrt(0.5), 1e-15);
    /* the root control is the LGS with lam = 2, sigma = 0.25 */
    ck_assert_int_eq(mlr_layers_get_control(L, ctl, ng), MLR_OK);
    ck_assert_int_eq(mlr_layers_get_residual(L, res, ng), MLR_OK);
    double *u = malloc(3 * n * sizeof *u), *x = malloc(3 * n * sizeof *x);
    for (size_t i = 0; i < n; i++)
        for (size_t k = 0; k < 3; k++)
            u[3 * i + k] = ctl[ld * i + k] + res[ld * i + k];
    mlr_lgs *g = NULL;
    ck_assert_int_ge(mlr_lgs_create(n, 2, 2.0, 0.25, NULL, n, MLR_LGS_BANDED, NULL, &g, NULL), 0);
    ck_assert_int_eq(mlr_lgs_solve(g, u, 3, 3, x, 3, NULL), MLR_OK);
    mlr_lgs_destroy(g);
    for (size_t i = 0; i < n; i++)
        for (size_t k = 0; k < 3; k++)
            ck_assert_double_le(fabs(x[3 * i + k] - ctl[ld * i + k]), 1e-9);
    mlr_layers_destroy(L);
    /* one of the pair alone: the other defaults to 1 */
    opt[0].key = MLR_LAYERS_OPT_SIGMA_C;
    opt[0].value = 3.0;
    ck_assert_int_eq(mlr_layers_decompose(n, j, c->pos, c->rot, opt, 1, NULL, &L, NULL), MLR_OK);
    ck_assert_int_eq(mlr_layers_get_param(L, MLR_LAYERS_PARAM_CONTROL_S, p, 1 + j), MLR_OK);
    ck_assert_double_eq_tol(p[3], 9.0, 1e-14);
    mlr_layers_destroy(L);
    /* explicit base parameters */
    mlr_layers_option ob[2] = {{MLR_LAYERS_OPT_LAM_B, 10.0}, {MLR_LAYERS_OPT_SIGMA_B, 2.0}};
    ck_assert_int_eq(mlr_layers_decompose(n, j, c->pos, c->rot, ob, 2, NULL, &L, NULL), MLR_OK);
    ck_assert_int_eq(mlr_layers_get_param(L, MLR_LAYERS_PARAM_BASE_S, p, 1 + j), MLR_OK);
    for (size_t k = 0; k <= j; k++)
        ck_assert_double_eq_tol(p[k], 400.0, 1e-12);
    mlr_layers_destroy(L);
    free(p), free(ctl), free(res), free(u), free(x);
    free_clips(clips, nc);
}
END_TEST

/* Clean smooth motion plus ~1.5 degrees of noise per axis: alpha = 1 is closer to the clean
 * motion than the noisy input, at 24, 30, 60 and 120 fps. */
START_TEST(denoises_synthetic_motion)
{
    const double fps[] = {24.0, 30.0, 60.0, 120.0};
    const size_t j = 5;
    const double sigma = 1.5 * PI / 180.0;
    for (size_t f = 0; f < 4; f++) {
        const size_t n = (size_t)(10.0 * fps[f]);
        double *clean = malloc(4 * n * j * sizeof *clean),
               *noisy = malloc(4 * n * j * sizeof *noisy);
        double *pos = malloc(3 * n * sizeof *pos), *out = malloc(4 * n * j * sizeof *out);
        mlr_test_rng rng;
        mlr_test_rng_seed(&rng, 100 + f);
        for (size_t i = 0; i < n; i++) {
            double t = (double)i / fps[f];
            for (size_t k = 0; k < j; k++) {
                double fk = 0.4 + 0.3 * (double)k;
                double ang[3] = {0.6 * sin(2 * PI * fk * t),
                                 0.4 * cos(2 * PI * 0.7 * fk * t + 1.0),
                                 0.3 * sin(2 * PI * 1.3 * fk * t + 2.0)};
                mlr_quat *qc = (mlr_quat *)(void *)(clean + 4 * (i * j + k));
                mlr_quat_from_euler_array(ang, 1, MLR_EULER_ZYX, qc, NULL);
                mlr_vec3 e = {sigma * mlr_test_rng_normal(&rng), sigma * mlr_test_rng_normal(&rng),
                              sigma * mlr_test_rng_normal(&rng)};
                mlr_quat qe;
                mlr_quat_exp_array(&e, 1, &qe, NULL);
                mlr_quat_mul(qc, &qe, (mlr_quat *)(void *)(noisy + 4 * (i * j + k)));
            }
            pos[3 * i] = pos[3 * i + 1] = pos[3 * i + 2] = 0.0;
        }
        mlr_layers *L = NULL;
        ck_assert_int_eq(mlr_layers_decompose(n, j, pos, noisy, NULL, 0, NULL, &L, NULL), MLR_OK);
        const double one = 1.0;
        ck_assert_int_eq(mlr_layers_synthesize(L, 0, n, &one, 1, NULL, 0, out, 4 * n * j, NULL),
                         MLR_OK);
        double e_noisy = 0.0, e_out = 0.0;
        for (size_t i = 0; i < n * j; i++) {
            e_noisy += qangle(noisy + 4 * i, clean + 4 * i);
            e_out += qangle(out + 4 * i, clean + 4 * i);
        }
        ck_assert_msg(e_out < 0.7 * e_noisy, "%g fps: denoised error %.4g deg vs noisy %.4g deg",
                      fps[f], e_out / (double)(n * j) * 180 / PI,
                      e_noisy / (double)(n * j) * 180 / PI);
        mlr_layers_destroy(L);
        free(clean), free(noisy), free(pos), free(out);
    }
}
END_TEST

/* A kick whose displacement from the base layer is 100 degrees, exaggerated 3x: its angle
   saturates below a half turn (at most 0.9 pi) and never falls below alpha 1's, frame to
   frame continuous. Scaled as it is (300 degrees), exp(3 v) turns back the other way: a
   rotation of 300 degrees is one of -60, less than alpha 1's, and the joint limits then
   found it on the far side of its range. */
START_TEST(exaggeration_stays_below_a_half_turn)
{
    const size_t n = 240, j = 1;
    double *rot = malloc(4 * n * sizeof *rot), *pos = calloc(3 * n, sizeof *pos);
    double *r0 = malloc(4 * n * sizeof *r0), *r1 = malloc(4 * n * sizeof *r1),
           *r3 = malloc(4 * n * sizeof *r3);
    for (size_t i = 0; i < n; i++) { /* 100 degrees about z, a bump of 0.08 s at 120 fps */
        const double t = ((double)i - 120.0) / 10.0, a = 100.0 * PI / 180.0 * exp(-0.5 * t * t);
        rot[4 * i] = cos(0.5 * a), rot[4 * i + 1] = rot[4 * i + 2] = 0.0;
        rot[4 * i + 3] = sin(0.5 * a);
    }
    mlr_layers *L = NULL;
    ck_assert_int_eq(mlr_layers_decompose(n, j, pos, rot, NULL, 0, NULL, &L, NULL), MLR_OK);
    const double a0 = 0.0, a1 = 1.0, a3 = 3.0;
    ck_assert_int_eq(mlr_layers_synthesize(L, 0, n, &a0, 1, NULL, 0, r0, 4 * n, NULL), MLR_OK);
    ck_assert_int_eq(mlr_layers_synthesize(L, 0, n, &a1, 1, NULL, 0, r1, 4 * n, NULL), MLR_OK);
    ck_assert_int_eq(mlr_layers_synthesize(L, 0, n, &a3, 1, NULL, 0, r3, 4 * n, NULL), MLR_OK);
    double peak1 = 0.0, peak3 = 0.0, step = 0.0;
    for (size_t i = 0; i < n; i++) {
        const double d1 = qangle(r0 + 4 * i, r1 + 4 * i), d3 = qangle(r0 + 4 * i, r3 + 4 * i);
        ck_assert_msg(d3 >= d1 - 1e-9, "frame %zu: alpha 3 displaced %.1f deg, alpha 1 %.1f", i,
                      d3 * 180 / PI, d1 * 180 / PI);
        ck_assert_msg(d3 <= 0.9 * PI + 1e-9, "frame %zu: alpha 3 displaced %.1f deg", i,
                      d3 * 180 / PI);
        peak1 = fmax(peak1, d1), peak3 = fmax(peak3, d3);
        if (i)
            step = fmax(step, qangle(r3 + 4 * (i - 1), r3 + 4 * i));
    }
    ck_assert_msg(peak1 > 1.2 && peak3 > 2.5, "peaks %.1f, %.1f deg", peak1 * 180 / PI,
                  peak3 * 180 / PI); /* the case is there: alpha 1 near 100, alpha 3 near 160 */
    ck_assert_msg(step < 3.0 * 0.25, "largest step %.1f deg", step * 180 / PI);
    mlr_layers_destroy(L);
    free(rot), free(pos), free(r0), free(r1), free(r3);
}
END_TEST

START_TEST(bad_arguments)
{
    double pos[3 * 8] = {0}, rot[4 * 8 * 2];
    for (size_t i = 0; i < 16; i++)
        rot[4 * i] = 1.0, rot[4 * i + 1] = rot[4 * i + 2] = rot[4 * i + 3] = 0.0;
    mlr_layers *L = (mlr_layers *)(void *)rot;
    mlr_diag dg;
#define EXPECT_BAD(call)                                                 \
    do {                                                                 \
        dg.message[0] = '\0';                                            \
        L = (mlr_layers *)(void *)rot;                                   \
        ck_assert_int_eq((call), MLR_E_INVALID_ARG);                     \
        ck_assert_ptr_null(L);                                           \
        ck_assert_msg(dg.message[0] != '\0', "no reason for %s", #call); \
    } while (0)
    EXPECT_BAD(mlr_layers_decompose(2, 2, pos, rot, NULL, 0, NULL, &L, &dg));
    EXPECT_BAD(mlr_layers_decompose(8, 0, pos, rot, NULL, 0, NULL, &L, &dg));
    EXPECT_BAD(mlr_layers_decompose(8, 2, pos, NULL, NULL, 0, NULL, &L, &dg));
    EXPECT_BAD(mlr_layers_decompose(8, 2, pos, rot, NULL, 1, NULL, &L, &dg));
    ck_assert_int_eq(mlr_layers_decompose(8, 2, pos, rot, NULL, 0, NULL, NULL, &dg),
                     MLR_E_INVALID_ARG);
    rot[4 * 5 + 2] = NAN;
    EXPECT_BAD(mlr_layers_decompose(8, 2, pos, rot, NULL, 0, NULL, &L, &dg));
    ck_assert_ptr_nonnull(strstr(dg.message, "frame 2, joint 1"));
    rot[4 * 5 + 2] = 0.0;
    rot[4 * 6] = 0.0;
    EXPECT_BAD(mlr_layers_decompose(8, 2, pos, rot, NULL, 0, NULL, &L, &dg));
    ck_assert_ptr_nonnull(strstr(dg.message, "zero"));
    rot[4 * 6] = 1.0;
    pos[7] = INFINITY;
    EXPECT_BAD(mlr_layers_decompose(8, 2, pos, rot, NULL, 0, NULL, &L, &dg));
    pos[7] = 0.0;
    const mlr_layers_option bad_opts[][2] = {
        {{MLR_LAYERS_OPT_GAMMA, 1.5}, {0, 0}},
        {{MLR_LAYERS_OPT_GAMMA, PI}, {0, 0}},
        {{MLR_LAYERS_OPT_GAMMA, NAN}, {0, 0}},
        {{99, 1.0}, {0, 0}},
        {{0, 1.0}, {0, 0}},
        {{MLR_LAYERS_OPT_LAM_C, 1.0}, {MLR_LAYERS_OPT_LAM_C, 2.0}},
        {{MLR_LAYERS_OPT_LAM_C, -1.0}, {0, 0}},
        {{MLR_LAYERS_OPT_SIGMA_B, 0.0}, {0, 0}},
        {{MLR_LAYERS_OPT_LAM_B, 1e200}, {MLR_LAYERS_OPT_SIGMA_B, 1e200}},
        {{MLR_LAYERS_OPT_BASE_S_MIN, 10.0}, {MLR_LAYERS_OPT_BASE_S_MAX, 1.0}},
        {{MLR_LAYERS_OPT_CONTROL_S_MAX, INFINITY}, {0, 0}},
    };
    const size_t n_bad[] = {1, 1, 1, 1, 1, 2, 1, 1, 2, 2, 1};
    for (size_t i = 0; i < MLR_COUNTOF(bad_opts); i++)
        EXPECT_BAD(mlr_layers_decompose(8, 2, pos, rot, bad_opts[i], n_bad[i], NULL, &L, &dg));
    const mlr_layers_option ok_gamma = {MLR_LAYERS_OPT_GAMMA, PI / 2};
    ck_assert_int_eq(mlr_layers_decompose(8, 2, pos, rot, &ok_gamma, 1, NULL, &L, &dg), MLR_OK);
    /* getters, synthesis, reconstruction */
    double buf[4 * 8 * 3], alpha[3] = {1, 1, 1};
    ck_assert_int_eq(mlr_layers_get_base(L, buf, 23, NULL, 0), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_layers_get_base(L, NULL, 0, buf, 63), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_layers_get_base(NULL, buf, 24, NULL, 0), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_layers_get_control(L, buf, 71), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_layers_get_control(L, NULL, 72), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_layers_get_residual(L, buf, 73), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_layers_get_param(L, MLR_LAYERS_PARAM_BASE_S, buf, 2), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_layers_get_param(L, (mlr_layers_param)9, buf, 3), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_layers_get_param(L, (mlr_layers_param)-1, buf, 3), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_layers_synthesize(L, 0, 8, alpha, 2, buf, 24, NULL, 0, NULL),
                     MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_layers_synthesize(L, 0, 8, NULL, 1, buf, 24, NULL, 0, NULL),
                     MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_layers_synthesize(L, 4, 5, alpha, 3, NULL, 0, NULL, 0, NULL),
                     MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_layers_synthesize(L, 9, 0, alpha, 3, NULL, 0, NULL, 0, NULL),
                     MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_layers_synthesize(L, 0, 8, alpha, 3, buf, 23, NULL, 0, NULL),
                     MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_layers_synthesize(L, 0, 8, alpha, 3, NULL, 0, buf, 60, NULL),
                     MLR_E_INVALID_ARG);
    for (int v = 0; v < 3; v++) {
        alpha[1] = v == 0 ? NAN : v == 1 ? INFINITY : -INFINITY;
        buf[0] = 42.0;
        ck_assert_int_eq(mlr_layers_synthesize(L, 0, 8, alpha, 3, buf, 24, NULL, 0, NULL),
                         MLR_E_INVALID_ARG);
        ck_assert_double_eq(buf[0], 42.0); /* nothing written */
    }
    alpha[1] = -3.0; /* any finite value works */
    ck_assert_int_eq(mlr_layers_synthesize(L, 0, 8, alpha, 3, buf, 24, buf + 24, 64, NULL),
                     MLR_OK);
    ck_assert_int_eq(mlr_layers_reconstruct(L, 7, 2, buf, 6, NULL, 0, NULL), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_layers_reconstruct(NULL, 0, 1, buf, 3, NULL, 0, NULL), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_layers_reconstruct(L, 8, 0, NULL, 0, NULL, 0, NULL), MLR_OK);
    ck_assert_uint_eq(mlr_layers_n_frames(NULL), 0);
    ck_assert_uint_eq(mlr_layers_n_joints(NULL), 0);
    mlr_layers_destroy(L);
    mlr_layers_destroy(NULL);
#undef EXPECT_BAD
}
END_TEST

START_TEST(constant_motion_and_no_root)
{
    /* a motion that does not move: every layer but the base is zero; no root translation */
    const size_t n = 20, j = 2;
    double rot[4 * 20 * 2];
    for (size_t i = 0; i < n * j; i++) {
        rot[4 * i] = 0.5, rot[4 * i + 1] = -0.5, rot[4 * i + 2] = 0.5, rot[4 * i + 3] = 0.5;
        if (i % 3 == 0)
            for (int c = 0; c < 4; c++)
                rot[4 * i + c] *= -2.0; /* sign flips and scale are normalized away */
    }
    mlr_layers *L = NULL;
    ck_assert_int_eq(mlr_layers_decompose(n, j, NULL, rot, NULL, 0, NULL, &L, NULL), MLR_OK);
    double pos[60], r[160], unit[160];
    normalize_copy(rot, unit, n * j);
    ck_assert_int_eq(mlr_layers_reconstruct(L, 0, n, pos, 60, r, 160, NULL), MLR_OK);
    for (size_t i = 0; i < 60; i++)
        ck_assert_double_le(fabs(pos[i]), 1e-300);
    ck_assert_double_le(qdiff_sign(r, unit, n * j), 1e-14);
    double s[3];
    ck_assert_int_eq(mlr_layers_get_param(L, MLR_LAYERS_PARAM_CONTROL_S, s, 3), MLR_OK);
    ck_assert_double_eq(s[0], 1.0); /* zero root displacement: s = 1 */
    mlr_layers_destroy(L);
}
END_TEST

START_TEST(every_allocation_failure_is_clean)
{
    double pos[3 * 30], rot[4 * 30 * 3];
    synthetic_big(30, 30.0, pos, rot, 3);
    for (size_t fail_at = 0;; fail_at++) {
        mlr_test_allocator ta;
        mlr_test_allocator_init(&ta, fail_at);
        mlr_layers *L = NULL;
        mlr_status s = mlr_layers_decompose(30, 3, pos, rot, NULL, 0, &ta.base, &L, NULL);
        if (s == MLR_OK) {
            ck_assert_uint_eq(ta.live_blocks, 1); /* the handle is one block */
            mlr_layers_destroy(L);
        }
        ck_assert_uint_eq(ta.live_blocks, 0);
        if (s == MLR_OK)
            break;
        ck_assert_int_eq(s, MLR_E_NO_MEMORY);
        ck_assert_ptr_null(L);
    }
}
END_TEST

typedef struct thread_job {
    const mlr_layers *L;
    size_t n, j;
    double alpha;
    double *rot, *pos;
    int status;
} thread_job;

static void *synth_thread(void *p)
{
    thread_job *t = p;
    t->status = 0;
    for (int rep = 0; rep < 5 && t->status == 0; rep++)
        t->status = mlr_layers_synthesize(t->L, 0, t->n, &t->alpha, 1, t->pos, 3 * t->n, t->rot,
                                          4 * t->n * t->j, NULL);
    return NULL;
}

START_TEST(threads_synthesize_identically)
{
    const size_t n = 600, j = 3;
    double *pos = malloc(3 * n * sizeof *pos), *rot = malloc(4 * n * j * sizeof *rot);
    synthetic_big(n, 60.0, pos, rot, 11);
    mlr_layers *L = NULL;
    ck_assert_int_eq(mlr_layers_decompose(n, j, pos, rot, NULL, 0, NULL, &L, NULL), MLR_OK);
    enum { NT = 4 };
    thread_job jobs[NT];
    pthread_t th[NT];
    double *ref_r = malloc(4 * n * j * sizeof *ref_r), *ref_p = malloc(3 * n * sizeof *ref_p);
    for (int t = 0; t < NT; t++) {
        jobs[t] = (thread_job){L,
                               n,
                               j,
                               0.5 * (double)(t % 2 + 1),
                               malloc(4 * n * j * sizeof(double)),
                               malloc(3 * n * sizeof(double)),
                               -1};
        ck_assert_int_eq(pthread_create(&th[t], NULL, synth_thread, &jobs[t]), 0);
    }
    for (int t = 0; t < NT; t++)
        ck_assert_int_eq(pthread_join(th[t], NULL), 0);
    for (int t = 0; t < NT; t++) {
        ck_assert_int_eq(jobs[t].status, MLR_OK);
        ck_assert_int_eq(mlr_layers_synthesize(L, 0, n, &jobs[t].alpha, 1, ref_p, 3 * n, ref_r,
                                               4 * n * j, NULL),
                         MLR_OK);
        ck_assert(memcmp(ref_r, jobs[t].rot, 4 * n * j * sizeof *ref_r) == 0);
        ck_assert(memcmp(ref_p, jobs[t].pos, 3 * n * sizeof *ref_p) == 0);
        free(jobs[t].rot), free(jobs[t].pos);
    }
    free(ref_r), free(ref_p), free(pos), free(rot);
    mlr_layers_destroy(L);
}
END_TEST

/* ---- the base floor (MLR_LAYERS_OPT_FPS, BASE_CUTOFF) and the body joint --------------- */

/* Every array and parameter of two decompositions, bit for bit. */
static int same_layers(const mlr_layers *a, const mlr_layers *b)
{
    const size_t n = mlr_layers_n_frames(a), j = mlr_layers_n_joints(a);
    if (n != mlr_layers_n_frames(b) || j != mlr_layers_n_joints(b))
        return 0;
    const size_t np = 3 * n, nr = 4 * n * j, ng = 3 * n * (1 + j);
    double *x = malloc((np + nr + 2 * ng) * sizeof *x),
           *y = malloc((np + nr + 2 * ng) * sizeof *y);
    int same = 1;
    ck_assert_int_eq(mlr_layers_get_base(a, x, np, x + np, nr), MLR_OK);
    ck_assert_int_eq(mlr_layers_get_base(b, y, np, y + np, nr), MLR_OK);
    ck_assert_int_eq(mlr_layers_get_control(a, x + np + nr, ng), MLR_OK);
    ck_assert_int_eq(mlr_layers_get_control(b, y + np + nr, ng), MLR_OK);
    ck_assert_int_eq(mlr_layers_get_residual(a, x + np + nr + ng, ng), MLR_OK);
    ck_assert_int_eq(mlr_layers_get_residual(b, y + np + nr + ng, ng), MLR_OK);
    same = memcmp(x, y, (np + nr + 2 * ng) * sizeof *x) == 0;
    for (int w = 0; w < 9 && same; w++) {
        ck_assert_int_eq(mlr_layers_get_param(a, (mlr_layers_param)w, x, 1 + j), MLR_OK);
        ck_assert_int_eq(mlr_layers_get_param(b, (mlr_layers_param)w, y, 1 + j), MLR_OK);
        for (size_t g = 0; g <= j; g++) /* NaN GCV scores compare equal here */
            same &= x[g] == y[g] || (isnan(x[g]) && isnan(y[g]));
    }
    free(x), free(y);
    return same;
}

static mlr_layers *decompose_ok(const clip *c, const mlr_layers_option *opt, size_t n_opt)
{
    mlr_layers *L = NULL;
    mlr_diag dg;
    ck_assert_msg(mlr_layers_decompose(c->n, c->j, c->pos, c->rot, opt, n_opt, NULL, &L, &dg) ==
                      MLR_OK,
                  "%s: %s", c->name, dg.message);
    return L;
}

/* decompose_ok with the outlier search off (FPS also sets the search's smoother, so layers
 * with and without FPS differ on clips with outliers). */
static mlr_layers *decompose_plain(const clip *c, const mlr_layers_option *opt, size_t n_opt)
{
    mlr_layers_option o[8];
    ck_assert_uint_lt(n_opt, 8);
    for (size_t i = 0; i < n_opt; i++)
        o[i] = opt[i];
    o[n_opt] = (mlr_layers_option){MLR_LAYERS_OPT_ROBUST, 0.0};
    return decompose_ok(c, o, n_opt + 1);
}

/* The gain of the mean of the LGS (I + s L^T L)^-1 on a sinusoid of frequency f at fps, measured
 * with mlr_lgs in the middle of a long clip (the ends are left out). */
static double lgs_gain(double s, double f, double fps)
{
    const size_t n = (size_t)(40.0 * fps / f);
    double *y = malloc(n * sizeof *y), *x = malloc(n * sizeof *x);
    for (size_t i = 0; i < n; i++)
        y[i] = sin(2.0 * PI * f * (double)i / fps);
    mlr_lgs *g = NULL;
    ck_assert_int_ge(mlr_lgs_create(n, 2, sqrt(s), 1.0, NULL, n, MLR_LGS_BANDED, NULL, &g, NULL),
                     0);
    ck_assert_int_eq(mlr_lgs_solve(g, y, 1, 1, x, 1, NULL), MLR_OK);
    mlr_lgs_destroy(g);
    double xy = 0.0, yy = 0.0;
    for (size_t i = n / 4; i < 3 * n / 4; i++)
        xy += x[i] * y[i], yy += y[i] * y[i];
    free(y), free(x);
    return xy / yy;
}

/* FPS alone gives the 0.25 Hz floor: the same layers as the upper end (2 sin(pi fc/fps))^-4
 * given explicitly (the formula Python used before the floor moved into C), and that s
 * halves a 0.25 Hz sinusoid; BASE_CUTOFF moves it; every joint's s stays within it. */
START_TEST(fps_gives_the_base_floor)
{
    clip clips[16];
    size_t nc = load_clips(clips, 16);
    for (size_t ci = 0; ci < nc; ci++) {
        const clip *c = &clips[ci];
        if (c->j > 50)
            continue; /* the 165-joint clip adds time, not coverage */
        const double fps = 1.0 / mlr_motion_frame_time(c->m);
        const double fcs[2] = {0.25, 1.0};
        for (int k = 0; k < 2; k++) {
            const double smax = pow(2.0 * sin(PI * fcs[k] / fps), -4.0);
            mlr_layers_option o_fps[2] = {{MLR_LAYERS_OPT_FPS, fps},
                                          {MLR_LAYERS_OPT_BASE_CUTOFF, fcs[k]}};
            mlr_layers_option o_s = {MLR_LAYERS_OPT_BASE_S_MAX, smax};
            mlr_layers *A = decompose_plain(c, o_fps, k == 0 ? 1 : 2),
                       *B = decompose_plain(c, &o_s, 1);
            ck_assert_msg(same_layers(A, B), "%s: FPS %g, cutoff %g differs from BASE_S_MAX %g",
                          c->name, fps, fcs[k], smax);
            double *s = malloc((1 + c->j) * sizeof *s);
            ck_assert_int_eq(mlr_layers_get_param(A, MLR_LAYERS_PARAM_BASE_S, s, 1 + c->j),
                             MLR_OK);
            for (size_t g = 0; g <= c->j; g++)
                ck_assert_double_le(s[g], smax);
            free(s);
            mlr_layers_destroy(A), mlr_layers_destroy(B);
        }
        if (ci == 0) { /* the floor's meaning, measured apart from the formula */
            const double smax = pow(2.0 * sin(PI * 0.25 / fps), -4.0);
            ck_assert_double_eq_tol(lgs_gain(smax, 0.25, fps), 0.5, 2e-3);
            ck_assert_double_gt(lgs_gain(smax, 0.125, fps), 0.9);
            ck_assert_double_lt(lgs_gain(smax, 0.5, fps), 0.1);
        }
    }
    free_clips(clips, nc);
}
END_TEST

/* Precedence: LAM_B / SIGMA_B win over the floor; an explicit BASE_S_MAX replaces it (1e10
 * with FPS is the C default range again); an explicit BASE_S_MIN is kept. */
START_TEST(base_floor_precedence)
{
    clip clips[16];
    size_t nc = load_clips(clips, 16);
    const clip *c = NULL;
    for (size_t ci = 0; ci < nc; ci++)
        if (strstr(clips[ci].name, "131_01"))
            c = &clips[ci];
    if (!c)
        c = &clips[0];
    const double fps = 1.0 / mlr_motion_frame_time(c->m);
    mlr_layers *A, *B;
    mlr_layers_option o1[3] = {
        {MLR_LAYERS_OPT_FPS, fps}, {MLR_LAYERS_OPT_LAM_B, 3.0}, {MLR_LAYERS_OPT_BASE_CUTOFF, 0.5}};
    A = decompose_plain(c, o1, 3), B = decompose_plain(c, o1 + 1, 1);
    ck_assert(same_layers(A, B));
    mlr_layers_destroy(A), mlr_layers_destroy(B);
    mlr_layers_option o2[2] = {{MLR_LAYERS_OPT_BASE_S_MAX, 1e10}, {MLR_LAYERS_OPT_FPS, fps}};
    A = decompose_plain(c, o2, 2), B = decompose_plain(c, NULL, 0);
    ck_assert(same_layers(A, B));
    mlr_layers_destroy(A), mlr_layers_destroy(B);
    const double smax = pow(2.0 * sin(PI * 0.25 / fps), -4.0);
    mlr_layers_option o3[2] = {{MLR_LAYERS_OPT_FPS, fps}, {MLR_LAYERS_OPT_BASE_S_MIN, 3.0}};
    mlr_layers_option o4[2] = {{MLR_LAYERS_OPT_BASE_S_MAX, smax},
                               {MLR_LAYERS_OPT_BASE_S_MIN, 3.0}};
    A = decompose_plain(c, o3, 2), B = decompose_plain(c, o4, 2);
    ck_assert(same_layers(A, B));
    double *s = malloc((1 + c->j) * sizeof *s);
    ck_assert_int_eq(mlr_layers_get_param(A, MLR_LAYERS_PARAM_BASE_S, s, 1 + c->j), MLR_OK);
    for (size_t g = 0; g <= c->j; g++)
        ck_assert(s[g] >= 3.0 && s[g] <= smax);
    free(s);
    mlr_layers_destroy(A), mlr_layers_destroy(B);
    free_clips(clips, nc);
}
END_TEST

/* BODY_JOINT k: the translation group takes joint k's base s, and its base is the LGS of the
 * translation at that s; the rest of the decomposition is unchanged. */
START_TEST(body_joint_sets_the_translation_s)
{
    const size_t n = 360, j = 3;
    double *pos = malloc(3 * n * sizeof *pos), *rot = malloc(4 * n * j * sizeof *rot);
    double *bp = malloc(3 * n * sizeof *bp), *x = malloc(3 * n * sizeof *x);
    synthetic_big(n, 30.0, pos, rot, 5);
    for (size_t k = 0; k < j; k++) {
        mlr_layers_option o = {MLR_LAYERS_OPT_BODY_JOINT, (double)k};
        mlr_layers *L = NULL, *R = NULL;
        ck_assert_int_eq(mlr_layers_decompose(n, j, pos, rot, &o, 1, NULL, &L, NULL), MLR_OK);
        ck_assert_int_eq(mlr_layers_decompose(n, j, pos, rot, NULL, 0, NULL, &R, NULL), MLR_OK);
        double bs[4], br[4];
        ck_assert_int_eq(mlr_layers_get_param(L, MLR_LAYERS_PARAM_BASE_S, bs, 1 + j), MLR_OK);
        ck_assert_int_eq(mlr_layers_get_param(R, MLR_LAYERS_PARAM_BASE_S, br, 1 + j), MLR_OK);
        ck_assert_double_eq(bs[0], bs[1 + k]);
        for (size_t g = 1; g <= j; g++)
            ck_assert_double_eq(bs[g], br[g]);
        if (k == 0)
            ck_assert(same_layers(L, R));
        ck_assert_int_eq(mlr_layers_get_base(L, bp, 3 * n, NULL, 0), MLR_OK);
        mlr_lgs *g = NULL;
        ck_assert_int_ge(
            mlr_lgs_create(n, 2, sqrt(bs[0]), 1.0, NULL, n, MLR_LGS_BANDED, NULL, &g, NULL), 0);
        ck_assert_int_eq(mlr_lgs_solve(g, pos, 3, 3, x, 3, NULL), MLR_OK);
        mlr_lgs_destroy(g);
        for (size_t i = 0; i < 3 * n; i++)
            ck_assert_double_le(fabs(x[i] - bp[i]), 1e-14 * (1.0 + 16.0 * bs[0]) * 200.0);
        mlr_layers_destroy(L), mlr_layers_destroy(R);
    }
    /* joint 1's s differs from joint 0's here, so the option is not a no-op */
    mlr_layers *L = NULL;
    ck_assert_int_eq(mlr_layers_decompose(n, j, pos, rot, NULL, 0, NULL, &L, NULL), MLR_OK);
    double bs[4];
    ck_assert_int_eq(mlr_layers_get_param(L, MLR_LAYERS_PARAM_BASE_S, bs, 1 + j), MLR_OK);
    ck_assert_double_ne(bs[1], bs[2]);
    ck_assert_double_ne(bs[1], bs[3]);
    mlr_layers_destroy(L);
    free(pos), free(rot), free(bp), free(x);
}
END_TEST

START_TEST(base_floor_bad_options)
{
    double pos[3 * 8] = {0}, rot[4 * 8 * 2];
    for (size_t i = 0; i < 16; i++)
        rot[4 * i] = 1.0, rot[4 * i + 1] = rot[4 * i + 2] = rot[4 * i + 3] = 0.0;
    const struct {
        mlr_layers_option o[2];
        size_t n;
        const char *why;
    } bad[] = {
        {{{MLR_LAYERS_OPT_FPS, 0.0}, {0, 0}}, 1, "not > 0"},
        {{{MLR_LAYERS_OPT_FPS, -30.0}, {0, 0}}, 1, "not > 0"},
        {{{MLR_LAYERS_OPT_FPS, NAN}, {0, 0}}, 1, "not finite"},
        {{{MLR_LAYERS_OPT_FPS, INFINITY}, {0, 0}}, 1, "not finite"},
        {{{MLR_LAYERS_OPT_FPS, 0.4}, {0, 0}}, 1, "(0, fps/2)"}, /* default 0.25 Hz >= fps/2 */
        {{{MLR_LAYERS_OPT_BASE_CUTOFF, 0.25}, {0, 0}}, 1, "frame rate"},
        {{{MLR_LAYERS_OPT_FPS, 30.0}, {MLR_LAYERS_OPT_BASE_CUTOFF, 15.0}}, 2, "(0, fps/2)"},
        {{{MLR_LAYERS_OPT_FPS, 30.0}, {MLR_LAYERS_OPT_BASE_CUTOFF, 20.0}}, 2, "(0, fps/2)"},
        {{{MLR_LAYERS_OPT_FPS, 30.0}, {MLR_LAYERS_OPT_BASE_CUTOFF, 0.0}}, 2, "not > 0"},
        {{{MLR_LAYERS_OPT_FPS, 30.0}, {MLR_LAYERS_OPT_BASE_CUTOFF, -1.0}}, 2, "not > 0"},
        {{{MLR_LAYERS_OPT_BASE_CUTOFF, 0.5}, {MLR_LAYERS_OPT_BASE_S_MAX, 1e6}}, 2, "frame rate"},
        {{{MLR_LAYERS_OPT_FPS, 30.0}, {MLR_LAYERS_OPT_FPS, 60.0}}, 2, "twice"},
        {{{MLR_LAYERS_OPT_BODY_JOINT, -1.0}, {0, 0}}, 1, "joint index"},
        {{{MLR_LAYERS_OPT_BODY_JOINT, 2.0}, {0, 0}}, 1, "joint index"},
        {{{MLR_LAYERS_OPT_BODY_JOINT, 0.5}, {0, 0}}, 1, "joint index"},
        {{{MLR_LAYERS_OPT_BODY_JOINT, NAN}, {0, 0}}, 1, "not finite"},
        {{{MLR_LAYERS_OPT_BODY_JOINT, 13.0}, {MLR_LAYERS_OPT_FPS, 30.0}}, 2, "joint index"},
        {{{16, 1.0}, {0, 0}}, 1, "unknown"},
        {{{MLR_LAYERS_OPT_ROBUST, 0.5}, {0, 0}}, 1, "not 0 or 1"},
        {{{MLR_LAYERS_OPT_ROBUST, -1.0}, {0, 0}}, 1, "not 0 or 1"},
        {{{MLR_LAYERS_OPT_ROBUST, NAN}, {0, 0}}, 1, "not finite"},
        {{{MLR_LAYERS_OPT_BODY_HEIGHT, 0.0}, {0, 0}}, 1, "not > 0"},
        {{{MLR_LAYERS_OPT_BODY_HEIGHT, INFINITY}, {0, 0}}, 1, "not finite"},
        {{{MLR_LAYERS_OPT_ROBUST_ANGLE, 0.0}, {0, 0}}, 1, "not in (0, pi]"},
        {{{MLR_LAYERS_OPT_ROBUST_ANGLE, 3.5}, {0, 0}}, 1, "(0, pi]"},
    };
    for (size_t i = 0; i < MLR_COUNTOF(bad); i++) {
        mlr_layers *L = (mlr_layers *)(void *)rot;
        mlr_diag dg;
        dg.message[0] = '\0';
        ck_assert_int_eq(mlr_layers_decompose(8, 2, pos, rot, bad[i].o, bad[i].n, NULL, &L, &dg),
                         MLR_E_INVALID_ARG);
        ck_assert_ptr_null(L);
        ck_assert_msg(strstr(dg.message, bad[i].why), "case %zu: '%s' lacks '%s'", i, dg.message,
                      bad[i].why);
    }
    /* the conflicts: cutoff with an explicit upper end; an explicit lower end above the floor */
    const mlr_layers_option both[3] = {{MLR_LAYERS_OPT_FPS, 30.0},
                                       {MLR_LAYERS_OPT_BASE_CUTOFF, 0.5},
                                       {MLR_LAYERS_OPT_BASE_S_MAX, 1e6}};
    const mlr_layers_option low[3] = {{MLR_LAYERS_OPT_FPS, 30.0},
                                      {MLR_LAYERS_OPT_BASE_CUTOFF, 14.0},
                                      {MLR_LAYERS_OPT_BASE_S_MIN, 1.0}};
    mlr_layers *L = NULL;
    mlr_diag dg;
    ck_assert_int_eq(mlr_layers_decompose(8, 2, pos, rot, both, 3, NULL, &L, &dg),
                     MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(dg.message, "give one"));
    ck_assert_int_eq(mlr_layers_decompose(8, 2, pos, rot, low, 3, NULL, &L, &dg),
                     MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(dg.message, "not below the base floor"));
    /* a cutoff close to fps/2 is valid: s = (2 sin(pi 14/30))^-4 = 0.064 (never below 1/16) */
    ck_assert_int_eq(mlr_layers_decompose(8, 2, pos, rot, low, 2, NULL, &L, &dg), MLR_OK);
    double s[3];
    ck_assert_int_eq(mlr_layers_get_param(L, MLR_LAYERS_PARAM_BASE_S, s, 3), MLR_OK);
    ck_assert_double_le(s[1], pow(2.0 * sin(PI * 14.0 / 30.0), -4.0));
    mlr_layers_destroy(L);
}
END_TEST

/* ---- robust decomposition ------------------------------------------------------------- */

/* A 5-frame glitch at frame `at` of the synthetic_big motion: the translation 1e5 units off
 * (1000 heights of a 100-unit body), alternating in sign, every joint turned by 180 degrees
 * about a seeded random axis. */
static void inject_glitch(size_t at, size_t j, double *pos, double *rot, uint64_t seed)
{
    mlr_test_rng rng;
    mlr_test_rng_seed(&rng, seed);
    for (size_t f = 0; f < 5; f++) {
        const double sg = f % 2 ? -1.0 : 1.0;
        pos[3 * (at + f)] += sg * 1e5, pos[3 * (at + f) + 1] += 0.3 * sg * 1e5;
        for (size_t k = 0; k < j; k++) {
            double a[3], nn = 0.0;
            for (int c = 0; c < 3; c++)
                a[c] = mlr_test_rng_normal(&rng), nn += a[c] * a[c];
            nn = sqrt(nn);
            const mlr_quat flip = {0.0, a[0] / nn, a[1] / nn, a[2] / nn}; /* 180 degrees */
            mlr_quat *q = (mlr_quat *)(void *)(rot + 4 * ((at + f) * j + k));
            mlr_quat_mul(q, &flip, q);
        }
    }
}

/* Dense reference of the weighted LGS step: (W + s L^T L) x = W y by Gaussian elimination,
 * m channels (row-major n x m). */
static void dense_weighted_lgs(size_t n, size_t m, double s, const double *w, const double *y,
                               double *x)
{
    double *M = calloc(n * n, sizeof *M), *B = malloc(n * m * sizeof *B);
    const double c[3] = {1, -2, 1};
    for (size_t r = 0; r + 2 < n; r++)
        for (size_t a = 0; a < 3; a++)
            for (size_t b = 0; b < 3; b++)
                M[(r + a) * n + r + b] += s * c[a] * c[b];
    for (size_t i = 0; i < n; i++) {
        M[i * n + i] += w[i];
        for (size_t k = 0; k < m; k++)
            B[i * m + k] = w[i] * y[i * m + k];
    }
    for (size_t p = 0; p < n; p++) { /* SPD: no pivoting */
        for (size_t r = p + 1; r < n && r <= p + 2; r++) {
            const double f = M[r * n + p] / M[p * n + p];
            for (size_t k = p; k < n && k <= p + 2; k++)
                M[r * n + k] -= f * M[p * n + k];
            for (size_t k = 0; k < m; k++)
                B[r * m + k] -= f * B[p * m + k];
        }
    }
    for (size_t p = n; p-- > 0;) {
        for (size_t k = 0; k < m; k++) {
            double v = B[p * m + k];
            for (size_t q = p + 1; q < n && q <= p + 2; q++)
                v -= M[p * n + q] * x[q * m + k];
            x[p * m + k] = v / M[p * n + p];
        }
    }
    free(M), free(B);
}

/* Weights 1 everywhere is the plain decomposition: a clip without outliers decomposes bit for
 * bit as with the search off, and reports none. */
START_TEST(robust_without_outliers_is_plain)
{
    const size_t n = 360, j = 3;
    double *pos = malloc(3 * n * sizeof *pos), *rot = malloc(4 * n * j * sizeof *rot);
    synthetic_big(n, 30.0, pos, rot, 11);
    const mlr_layers_option on[2] = {{MLR_LAYERS_OPT_ROBUST, 1.0},
                                     {MLR_LAYERS_OPT_BODY_HEIGHT, 100.0}};
    const mlr_layers_option off = {MLR_LAYERS_OPT_ROBUST, 0.0};
    mlr_layers *A = NULL, *B = NULL, *C = NULL;
    ck_assert_int_eq(mlr_layers_decompose(n, j, pos, rot, on, 2, NULL, &A, NULL), MLR_OK);
    ck_assert_int_eq(mlr_layers_decompose(n, j, pos, rot, &off, 1, NULL, &B, NULL), MLR_OK);
    ck_assert_int_eq(mlr_layers_decompose(n, j, pos, rot, NULL, 0, NULL, &C, NULL), MLR_OK);
    ck_assert(same_layers(A, B));
    ck_assert(same_layers(C, B));
    unsigned char *fl = malloc(n * (1 + j));
    ck_assert_int_eq(mlr_layers_get_outliers(A, fl, n * (1 + j)), MLR_OK);
    for (size_t i = 0; i < n * (1 + j); i++)
        ck_assert_uint_eq(fl[i], 0);
    /* bad arguments of the accessor */
    ck_assert_int_eq(mlr_layers_get_outliers(NULL, fl, n * (1 + j)), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_layers_get_outliers(A, NULL, n * (1 + j)), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_layers_get_outliers(A, fl, n * (1 + j) - 1), MLR_E_INVALID_ARG);
    free(fl), free(pos), free(rot);
    mlr_layers_destroy(A), mlr_layers_destroy(B), mlr_layers_destroy(C);
}
END_TEST

/* A converter's lead-in (the first frame a pose 90 degrees from the next, with the body 0.5 body heights away) is
 * a run at the start: an outlier of every group, reported by mlr_layers_get_end_runs; the clean
 * clip and the search switched off report none. */
START_TEST(robust_lead_in_is_an_end_run)
{
    const size_t n = 300, j = 3, ng = 1 + j;
    double *pos = malloc(3 * n * sizeof *pos), *rot = malloc(4 * n * j * sizeof *rot);
    unsigned char *fl = malloc(n * ng);
    synthetic_big(n, 30.0, pos, rot, 7);
    const mlr_layers_option on[2] = {{MLR_LAYERS_OPT_ROBUST, 1.0},
                                     {MLR_LAYERS_OPT_BODY_HEIGHT, 100.0}};
    const mlr_layers_option off = {MLR_LAYERS_OPT_ROBUST, 0.0};
    mlr_layers *C = NULL, *L = NULL, *P = NULL;
    ck_assert_int_eq(mlr_layers_decompose(n, j, pos, rot, on, 2, NULL, &C, NULL), MLR_OK);
    pos[0] += 50.0, pos[2] -= 30.0;
    for (size_t k = 0; k < j; k++) {
        double *q = rot + 4 * k; /* a rest pose 90 degrees away */
        const double *r = rot + 4 * (j + k);
        const double h = sqrt(0.5);
        q[0] = h * (r[0] - r[1]), q[1] = h * (r[1] + r[0]), q[2] = h * (r[2] + r[3]),
        q[3] = h * (r[3] - r[2]);
    }
    ck_assert_int_eq(mlr_layers_decompose(n, j, pos, rot, on, 2, NULL, &L, NULL), MLR_OK);
    ck_assert_int_eq(mlr_layers_decompose(n, j, pos, rot, &off, 1, NULL, &P, NULL), MLR_OK);
    size_t head = 9, tail = 9;
    ck_assert_int_eq(mlr_layers_get_end_runs(L, &head, &tail), MLR_OK);
    ck_assert_uint_eq(head, 1);
    ck_assert_uint_eq(tail, 0);
    ck_assert_int_eq(mlr_layers_get_outliers(L, fl, n * ng), MLR_OK);
    ck_assert_msg(fl[0] == 1, "the translation's lead-in frame is not an outlier");
    size_t jumped = 0; /* the joints whose step out of the lead-in is 10 times their next */
    for (size_t k = 0; k < j; k++) {
        double st[4];
        for (size_t i = 1; i <= 4; i++) {
            const double *a = rot + 4 * ((i - 1) * j + k), *b = rot + 4 * (i * j + k);
            const double c = fabs(a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3]);
            st[i - 1] = 2.0 * acos(fmin(c, 1.0));
        }
        if (st[0] > 10.0 * fmax(st[1], fmax(st[2], st[3]))) {
            ck_assert_msg(fl[1 + k] == 1, "joint %zu: the lead-in frame is not an outlier", k);
            jumped++;
        }
    }
    ck_assert_uint_ge(jumped, 1);
    ck_assert_int_eq(mlr_layers_get_end_runs(C, &head, &tail), MLR_OK);
    ck_assert_uint_eq(head + tail, 0);
    ck_assert_int_eq(mlr_layers_get_end_runs(P, &head, &tail), MLR_OK);
    ck_assert_uint_eq(head + tail, 0);
    ck_assert_int_eq(mlr_layers_get_end_runs(NULL, &head, &tail), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_layers_get_end_runs(L, NULL, &tail), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_layers_get_end_runs(L, &head, NULL), MLR_E_INVALID_ARG);
    free(fl), free(pos), free(rot);
    mlr_layers_destroy(C), mlr_layers_destroy(L), mlr_layers_destroy(P);
}
END_TEST

/* Frame f of joints [0, nk) turned 90 degrees from frame g's pose (a rest pose). */
static void rest_pose_at(double *rot, size_t j, size_t nk, size_t f, size_t g)
{
    const double h = sqrt(0.5);
    for (size_t k = 0; k < nk; k++) {
        double *q = rot + 4 * (f * j + k);
        const double *r = rot + 4 * (g * j + k);
        const double a = r[0], b = r[1], c = r[2], d = r[3];
        q[0] = h * (a - b), q[1] = h * (b + a), q[2] = h * (c + d), q[3] = h * (d - c);
    }
}

/* A rest pose before and after the capture with the root already where the capture starts and
 * ends (CMU's 12_01 as pybvh exports it): no step of the translation, so the pose's own steps
 * find the runs (layers__pose_end_runs), and the pipeline passes them through. A turn of two
 * joints alone is motion, not a rest pose. */
START_TEST(robust_rest_pose_with_the_root_in_place_is_an_end_run)
{
    const size_t n = 300, j = 3, ng = 1 + j;
    double *pos = malloc(3 * n * sizeof *pos), *rot = malloc(4 * n * j * sizeof *rot);
    unsigned char *fl = malloc(n * ng);
    const mlr_layers_option on[2] = {{MLR_LAYERS_OPT_ROBUST, 1.0},
                                     {MLR_LAYERS_OPT_BODY_HEIGHT, 100.0}};
    for (size_t nk = 2; nk <= 3; nk++) {
        synthetic_big(n, 30.0, pos, rot, 7);
        memcpy(pos, pos + 3, 3 * sizeof *pos); /* the root where the capture starts */
        memcpy(pos + 3 * (n - 1), pos + 3 * (n - 2), 3 * sizeof *pos);
        rest_pose_at(rot, j, nk, 0, 1);
        rest_pose_at(rot, j, nk, n - 1, n - 2);
        mlr_layers *L = NULL;
        ck_assert_int_eq(mlr_layers_decompose(n, j, pos, rot, on, 2, NULL, &L, NULL), MLR_OK);
        size_t head = 9, tail = 9;
        ck_assert_int_eq(mlr_layers_get_end_runs(L, &head, &tail), MLR_OK);
        ck_assert_uint_eq(head, (nk == 3 ? 1u : 0u));
        ck_assert_uint_eq(tail, (nk == 3 ? 1u : 0u));
        if (nk == 3) {
            ck_assert_int_eq(mlr_layers_get_outliers(L, fl, n * ng), MLR_OK);
            for (size_t g = 0; g < ng; g++) /* every group: the translation and each joint */
                ck_assert(fl[g] != 0 && fl[(n - 1) * ng + g] != 0);
        }
        mlr_layers_destroy(L);
    }
    free(fl), free(pos), free(rot);
}
END_TEST

/* A glitch (in the middle, then at the start) is found in every group, exactly its frames; the
 * base translation at a fixed s is the dense weighted LGS with those frames at weight 0 (a
 * 1000-height glitch weighs 0); the layers identity still holds; and the denoised motion more
 * than 0.5 s away from the glitch is that of the clean clip. */
START_TEST(robust_glitch_is_found_and_local)
{
    const size_t n = 600, j = 3, ng = 1 + j, ats[2] = {300, 0};
    const double fps = 30.0, s_b = 1e4;
    double *pos = malloc(3 * n * sizeof *pos), *rot = malloc(4 * n * j * sizeof *rot);
    double *gp = malloc(3 * n * sizeof *gp), *gr = malloc(4 * n * j * sizeof *gr);
    double *w = malloc(n * sizeof *w), *x = malloc(3 * n * sizeof *x),
           *bp = malloc(3 * n * sizeof *bp);
    double *p0 = malloc(3 * n * sizeof *p0), *q0 = malloc(4 * n * j * sizeof *q0);
    double *p1 = malloc(3 * n * sizeof *p1), *q1 = malloc(4 * n * j * sizeof *q1);
    unsigned char *fl = malloc(n * ng);
    synthetic_big(n, fps, pos, rot, 5);
    for (size_t t = 0; t < 2; t++) {
        const size_t at = ats[t];
        memcpy(gp, pos, 3 * n * sizeof *gp), memcpy(gr, rot, 4 * n * j * sizeof *gr);
        inject_glitch(at, j, gp, gr, 21 + t);
        const mlr_layers_option o[3] = {{MLR_LAYERS_OPT_FPS, fps},
                                        {MLR_LAYERS_OPT_BODY_HEIGHT, 100.0},
                                        {MLR_LAYERS_OPT_ROBUST, 1.0}};
        mlr_layers *G = NULL, *C = NULL;
        mlr_diag dg;
        ck_assert_msg(mlr_layers_decompose(n, j, gp, gr, o, 3, NULL, &G, &dg) == MLR_OK, "%s",
                      dg.message);
        ck_assert_int_eq(mlr_layers_decompose(n, j, pos, rot, o, 3, NULL, &C, NULL), MLR_OK);
        ck_assert_int_eq(mlr_layers_get_outliers(G, fl, n * ng), MLR_OK);
        for (size_t g = 0; g < ng; g++) {
            size_t hits = 0;
            for (size_t i = 0; i < n; i++) {
                const int in = i >= at && i < at + 5;
                ck_assert_msg(!fl[i * ng + g] || in, "glitch at %zu: frame %zu group %zu flagged",
                              at, i, g);
                hits += fl[i * ng + g];
            }
            /* every glitch frame, except at the clip's start for a joint (see the report):
             * there the glitch frames have no frame before them to take a hemisphere from */
            ck_assert_msg(hits == 5 || (at == 0 && g > 0 && hits >= 3),
                          "glitch at %zu: group %zu: %zu of 5 frames flagged", at, g, hits);
        }
        ck_assert_int_eq(mlr_layers_get_outliers(C, fl, n * ng), MLR_OK);
        for (size_t i = 0; i < n * ng; i++)
            ck_assert_uint_eq(fl[i], 0);
        /* the identity */
        ck_assert_int_eq(mlr_layers_reconstruct(G, 0, n, p1, 3 * n, q1, 4 * n * j, NULL), MLR_OK);
        double e = 0.0;
        for (size_t i = 0; i < 3 * n; i++)
            e = fmax(e, fabs(p1[i] - gp[i]));
        ck_assert_double_le(e, 1e-9 * 1e5);
        double *gn = malloc(4 * n * j * sizeof *gn);
        normalize_copy(gr, gn, n * j);
        ck_assert_double_le(qdiff_sign(q1, gn, n * j), 1e-9);
        free(gn);
        /* far from the glitch the denoised motion is the clean clip's */
        ck_assert_int_eq(
            mlr_layers_synthesize(C, 0, n, (double[]){1.0}, 1, p0, 3 * n, q0, 4 * n * j, NULL),
            MLR_OK);
        ck_assert_int_eq(
            mlr_layers_synthesize(G, 0, n, (double[]){1.0}, 1, p1, 3 * n, q1, 4 * n * j, NULL),
            MLR_OK);
        double ep = 0.0, eq = 0.0;
        const size_t half = (size_t)(0.5 * fps);
        for (size_t i = 0; i < n; i++) {
            if (i + half >= at && i < at + 5 + half)
                continue;
            for (size_t c = 0; c < 3; c++)
                ep = fmax(ep, fabs(p1[3 * i + c] - p0[3 * i + c]));
            for (size_t k = 0; k < j; k++)
                eq = fmax(eq, qangle(q0 + 4 * (i * j + k), q1 + 4 * (i * j + k)));
        }
        /* at the start, a glitch frame of the spinning joint 0 that is not found (see above)
         * leaves 0.041 rad on it (measured); elsewhere below 0.01 rad */
        ck_assert_msg(ep < 1.0 && eq < (at == 0 ? 0.05 : 0.01),
                      "glitch at %zu: far from it %g "
                      "units, %g rad",
                      at, ep, eq);
        mlr_layers_destroy(C);
        mlr_layers_destroy(G);

        /* the weighted LGS step at a fixed s against a dense solve */
        const mlr_layers_option of[4] = {{MLR_LAYERS_OPT_LAM_B, sqrt(s_b) / 0.1},
                                         {MLR_LAYERS_OPT_LAM_C, 1.0},
                                         {MLR_LAYERS_OPT_BODY_HEIGHT, 100.0},
                                         {MLR_LAYERS_OPT_FPS, fps}};
        ck_assert_int_eq(mlr_layers_decompose(n, j, gp, gr, of, 4, NULL, &G, NULL), MLR_OK);
        ck_assert_int_eq(mlr_layers_get_base(G, bp, 3 * n, NULL, 0), MLR_OK);
        for (size_t i = 0; i < n; i++)
            w[i] = i >= at && i < at + 5 ? 0.0 : 1.0;
        dense_weighted_lgs(n, 3, s_b, w, gp, x);
        e = 0.0;
        for (size_t i = 0; i < 3 * n; i++)
            e = fmax(e, fabs(x[i] - bp[i]));
        ck_assert_msg(e <= 1e-12 * (1.0 + 16.0 * s_b) * 100.0, "weighted base vs dense: %g", e);
        /* weights 1: the dense solve is the plain layers' base */
        for (size_t i = 0; i < n; i++)
            w[i] = 1.0;
        dense_weighted_lgs(n, 3, s_b, w, pos, x);
        mlr_layers_destroy(G);
        ck_assert_int_eq(mlr_layers_decompose(n, j, pos, rot, of, 4, NULL, &G, NULL), MLR_OK);
        ck_assert_int_eq(mlr_layers_get_base(G, bp, 3 * n, NULL, 0), MLR_OK);
        e = 0.0;
        for (size_t i = 0; i < 3 * n; i++)
            e = fmax(e, fabs(x[i] - bp[i]));
        ck_assert_double_le(e, 1e-12 * (1.0 + 16.0 * s_b) * 100.0);
        mlr_layers_destroy(G);
    }
    free(pos), free(rot), free(gp), free(gr), free(w), free(x), free(bp);
    free(p0), free(q0), free(p1), free(q1), free(fl);
}
END_TEST

/* The largest angle between q0 and q1 (n frames x j joints) on the frames [at, at + len) of a
   flip (*during) and on those more than half frames away from it (*far). */
static void flip_errors(const double *q0, const double *q1, size_t n, size_t j, size_t at,
                        size_t len, size_t half, double *during, double *far)
{
    *during = *far = 0.0;
    for (size_t i = 0; i < n; i++)
        for (size_t k = 0; k < j; k++) {
            const double e = qangle(q0 + 4 * (i * j + k), q1 + 4 * (i * j + k));
            if (i >= at && i < at + len)
                *during = fmax(*during, e);
            else if (i + half < at || i >= at + len + half)
                *far = fmax(*far, e);
        }
}

/* Flips of single joints found from their rotations at 30 and 240 fps (issue 38): joints 1
 * and 2 of synthetic_big turned by 180 degrees (and by 90) about a seeded axis for 5 frames,
 * the translation untouched. Exactly those frames of those joints are outliers, the denoised
 * rotations during the flip stay within 0.1 rad of the clean clip's and from 0.5 s after it
 * within 0.005 rad; q -> -q on the same frames is no flip: nothing found, the layers of the
 * clean clip. */
START_TEST(robust_joint_flips_any_fps)
{
    const double rates[2] = {30.0, 240.0}, angles[2] = {PI, 0.5 * PI};
    const size_t j = 3, ng = 1 + j, len = 5;
    for (size_t r = 0; r < 2; r++) {
        const double fps = rates[r];
        const size_t n = (size_t)(20.0 * fps), at = n / 2;
        double *pos = malloc(3 * n * sizeof *pos), *rot = malloc(4 * n * j * sizeof *rot);
        double *gr = malloc(4 * n * j * sizeof *gr);
        double *q0 = malloc(4 * n * j * sizeof *q0), *q1 = malloc(4 * n * j * sizeof *q1);
        unsigned char *fl = malloc(n * ng);
        synthetic_big(n, fps, pos, rot, 31 + r);
        const mlr_layers_option o[2] = {{MLR_LAYERS_OPT_FPS, fps},
                                        {MLR_LAYERS_OPT_BODY_HEIGHT, 100.0}};
        mlr_layers *C = NULL, *G = NULL;
        ck_assert_int_eq(mlr_layers_decompose(n, j, pos, rot, o, 2, NULL, &C, NULL), MLR_OK);
        ck_assert_int_eq(mlr_layers_get_outliers(C, fl, n * ng), MLR_OK);
        for (size_t i = 0; i < n * ng; i++)
            ck_assert_uint_eq(fl[i], 0);
        ck_assert_int_eq(
            mlr_layers_synthesize(C, 0, n, (double[]){1.0}, 1, NULL, 0, q0, 4 * n * j, NULL),
            MLR_OK);
        for (size_t v = 0; v < 3; v++) { /* 180 degrees, 90 degrees, a sign change */
            memcpy(gr, rot, 4 * n * j * sizeof *gr);
            mlr_test_rng rng;
            mlr_test_rng_seed(&rng, 77 + v + 10 * r);
            for (size_t k = 1; k < j; k++) {
                double a[3], nn = 0.0;
                for (int c = 0; c < 3; c++)
                    a[c] = mlr_test_rng_normal(&rng), nn += a[c] * a[c];
                nn = sqrt(nn);
                const double h = v < 2 ? 0.5 * angles[v] : 0.0, sh = sin(h) / nn;
                const mlr_quat turn = {cos(h), a[0] * sh, a[1] * sh, a[2] * sh};
                for (size_t i = at; i < at + len; i++) {
                    mlr_quat *q = (mlr_quat *)(void *)(gr + 4 * (i * j + k));
                    if (v < 2) {
                        mlr_quat_mul(q, &turn, q);
                    } else {
                        q->w = -q->w, q->x = -q->x, q->y = -q->y, q->z = -q->z;
                    }
                }
            }
            mlr_diag dg;
            ck_assert_msg(mlr_layers_decompose(n, j, pos, gr, o, 2, NULL, &G, &dg) == MLR_OK, "%s",
                          dg.message);
            ck_assert_int_eq(mlr_layers_get_outliers(G, fl, n * ng), MLR_OK);
            for (size_t i = 0; i < n; i++)
                for (size_t g = 0; g < ng; g++) {
                    const int want = v < 2 && g >= 2 && i >= at && i < at + len;
                    ck_assert_msg(fl[i * ng + g] == want,
                                  "%g fps, flip %zu: frame %zu group %zu flagged %d", fps, v, i, g,
                                  fl[i * ng + g]);
                }
            if (v == 2)
                ck_assert(same_layers(G, C));
            ck_assert_int_eq(
                mlr_layers_synthesize(G, 0, n, (double[]){1.0}, 1, NULL, 0, q1, 4 * n * j, NULL),
                MLR_OK);
            double during, far;
            flip_errors(q0, q1, n, j, at, len, (size_t)ceil(0.5 * fps), &during, &far);
            ck_assert_msg(during < 0.1 && far < 0.005, "%g fps, flip %zu: %g rad during, %g after",
                          fps, v, during, far);
            mlr_layers_destroy(G);
        }
        mlr_layers_destroy(C);
        free(pos), free(rot), free(gr), free(q0), free(q1), free(fl);
    }
}
END_TEST

/* A flip of constant turn is undone, not bridged (issue 38): at 30 fps joint 1 swings by
 * +-1.2 rad at 1.5 Hz (up to 0.4 rad a frame), and is turned by 180 degrees about a fixed axis
 * for 10 frames, as q R and as R q. Those frames of that joint, and no other, are reported as
 * outliers (value 1); the layers rebuild the input there (the identity); the synthesis at
 * alpha 1 follows the clean clip's during the flip within 0.05 rad (measured 0.018; the
 * prior's bridge over a third of a second, before the undo, missed it by 0.47 rad) and within
 * 0.005 rad from 0.5 s after. */
START_TEST(robust_flip_of_constant_turn_is_undone)
{
    const double fps = 30.0;
    const size_t j = 3, ng = 1 + j, len = 10, n = 600, at = 280;
    double *pos = malloc(3 * n * sizeof *pos), *rot = malloc(4 * n * j * sizeof *rot);
    double *gr = malloc(4 * n * j * sizeof *gr), *rr = malloc(4 * n * j * sizeof *rr);
    double *q0 = malloc(4 * n * j * sizeof *q0), *q1 = malloc(4 * n * j * sizeof *q1);
    unsigned char *fl = malloc(n * ng);
    for (size_t i = 0; i < n; i++) {
        const double t = (double)i / fps;
        double ang[3][3] = {{0.2 * sin(1.3 * t), 0.5 * t, 0.1 * cos(2.1 * t)},
                            {1.2 * sin(2.0 * PI * 1.5 * t) + 0.3 * sin(5.1 * t),
                             0.3 * sin(0.4 * t), 0.5 * cos(0.9 * t)},
                            {0.2 * sin(3.0 * t), 0.1 * cos(2.0 * t), 0.15 * sin(1.7 * t)}};
        for (size_t k = 0; k < 3; k++)
            mlr_quat_from_euler_array(ang[k], 1, MLR_EULER_ZYX,
                                      (mlr_quat *)(void *)(rot + 4 * (3 * i + k)), NULL);
        pos[3 * i] = 10.0 * sin(0.3 * t), pos[3 * i + 1] = 90.0, pos[3 * i + 2] = 50.0 * t;
    }
    const mlr_layers_option o[2] = {{MLR_LAYERS_OPT_FPS, fps},
                                    {MLR_LAYERS_OPT_BODY_HEIGHT, 100.0}};
    mlr_layers *C = NULL, *G = NULL;
    ck_assert_int_eq(mlr_layers_decompose(n, j, pos, rot, o, 2, NULL, &C, NULL), MLR_OK);
    ck_assert_int_eq(
        mlr_layers_synthesize(C, 0, n, (double[]){1.0}, 1, NULL, 0, q0, 4 * n * j, NULL), MLR_OK);
    for (int form = 0; form < 2; form++) { /* 0: q R, 1: R q */
        memcpy(gr, rot, 4 * n * j * sizeof *gr);
        const double a[3] = {form ? -0.7 : 0.3, -0.8, 0.5};
        const double nn = sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
        const mlr_quat turn = {0.0, a[0] / nn, a[1] / nn, a[2] / nn}; /* 180 degrees */
        for (size_t i = at; i < at + len; i++) {
            mlr_quat *q = (mlr_quat *)(void *)(gr + 4 * (i * j + 1));
            if (form == 0)
                mlr_quat_mul(q, &turn, q);
            else
                mlr_quat_mul(&turn, q, q);
        }
        mlr_diag dg;
        ck_assert_msg(mlr_layers_decompose(n, j, pos, gr, o, 2, NULL, &G, &dg) == MLR_OK, "%s",
                      dg.message);
        ck_assert_int_eq(mlr_layers_get_outliers(G, fl, n * ng), MLR_OK);
        for (size_t i = 0; i < n; i++)
            for (size_t g = 0; g < ng; g++)
                ck_assert_msg(fl[i * ng + g] == (g == 2 && i >= at && i < at + len),
                              "form %d: frame %zu group %zu flagged %d", form, i, g,
                              fl[i * ng + g]);
        ck_assert_int_eq(mlr_layers_reconstruct(G, 0, n, NULL, 0, rr, 4 * n * j, NULL), MLR_OK);
        for (size_t t = 0; t < n * j; t++)
            ck_assert_double_le(qangle(rr + 4 * t, gr + 4 * t), 1e-6);
        ck_assert_int_eq(
            mlr_layers_synthesize(G, 0, n, (double[]){1.0}, 1, NULL, 0, q1, 4 * n * j, NULL),
            MLR_OK);
        double during, far;
        flip_errors(q0, q1, n, j, at, len, 15, &during, &far);
        ck_assert_msg(during < 0.05 && far < 0.005, "form %d: %g rad during, %g after", form,
                      during, far);
        mlr_layers_destroy(G);
    }
    mlr_layers_destroy(C);
    free(pos), free(rot), free(gr), free(rr), free(q0), free(q1), free(fl);
}
END_TEST

/* The robust path under a failing allocator: every failure is MLR_E_NO_MEMORY, no leak. */
/* mlr_layers_repair against the straightforward composition: the whole synthesis at alpha 1
 * (every alpha given, 1 + J ones), written over the frames that get_outliers flags in some
 * group; the other frames bit for bit the input; on a sub-range and with one array skipped;
 * bad arguments write nothing. */
START_TEST(repair_replaces_the_outlier_frames)
{
    const size_t n = 600, j = 3, ng = 1 + j, at = 300;
    const double fps = 30.0;
    double *pos = malloc(3 * n * sizeof *pos), *rot = malloc(4 * n * j * sizeof *rot);
    double *dp = malloc(3 * n * sizeof *dp), *dq = malloc(4 * n * j * sizeof *dq);
    double *rp = malloc(3 * n * sizeof *rp), *rq = malloc(4 * n * j * sizeof *rq);
    unsigned char *fl = malloc(n * ng);
    synthetic_big(n, fps, pos, rot, 5);
    inject_glitch(at, j, pos, rot, 21);
    const mlr_layers_option o[2] = {{MLR_LAYERS_OPT_FPS, fps},
                                    {MLR_LAYERS_OPT_BODY_HEIGHT, 100.0}};
    mlr_layers *G = NULL;
    ck_assert_int_eq(mlr_layers_decompose(n, j, pos, rot, o, 2, NULL, &G, NULL), MLR_OK);
    ck_assert_int_eq(mlr_layers_get_outliers(G, fl, n * ng), MLR_OK);
    double ones[1 + 3] = {1.0, 1.0, 1.0, 1.0};
    ck_assert_int_eq(mlr_layers_synthesize(G, 0, n, ones, ng, dp, 3 * n, dq, 4 * n * j, NULL),
                     MLR_OK);
    memcpy(rp, pos, 3 * n * sizeof *rp), memcpy(rq, rot, 4 * n * j * sizeof *rq);
    size_t nr = 99;
    ck_assert_int_eq(mlr_layers_repair(G, 0, n, rp, 3 * n, rq, 4 * n * j, &nr, NULL), MLR_OK);
    size_t bad = 0;
    for (size_t i = 0; i < n; i++) {
        int b = 0;
        for (size_t g = 0; g < ng; g++)
            b |= fl[i * ng + g];
        bad += b != 0;
        const double *ep = b ? dp : pos, *eq = b ? dq : rot;
        ck_assert_mem_eq(rp + 3 * i, ep + 3 * i, 3 * sizeof *rp);
        ck_assert_mem_eq(rq + 4 * j * i, eq + 4 * j * i, 4 * j * sizeof *rq);
    }
    ck_assert_uint_eq(bad, 5);
    ck_assert_uint_eq(nr, bad);
    /* a sub-range over the glitch's end, rotations only */
    memcpy(rq, rot, 4 * n * j * sizeof *rq);
    ck_assert_int_eq(
        mlr_layers_repair(G, at + 2, 10, NULL, 0, rq + 4 * j * (at + 2), 40 * j, &nr, NULL),
        MLR_OK);
    ck_assert_uint_eq(nr, 3);
    for (size_t i = 0; i < n; i++) {
        const int b = i >= at + 2 && i < at + 5;
        ck_assert_mem_eq(rq + 4 * j * i, (b ? dq : rot) + 4 * j * i, 4 * j * sizeof *rq);
    }
    /* bad arguments: nothing written */
    memcpy(rp, pos, 3 * n * sizeof *rp);
    mlr_diag d;
    ck_assert_int_eq(mlr_layers_repair(NULL, 0, n, rp, 3 * n, NULL, 0, &nr, &d),
                     MLR_E_INVALID_ARG);
    ck_assert_uint_eq(nr, 0);
    ck_assert_str_eq(d.message, "layers repair: the handle is NULL");
    ck_assert_int_eq(mlr_layers_repair(G, 0, n, rp, 3 * n - 1, NULL, 0, NULL, &d),
                     MLR_E_INVALID_ARG);
    ck_assert_str_eq(d.message, "layers repair: n_root_pos is 1799, 3 count is 1800");
    ck_assert_int_eq(mlr_layers_repair(G, 0, n, rp, 3 * n, rq, 4 * n * j + 4, NULL, NULL),
                     MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_layers_repair(G, 1, n, rp, 3 * n, NULL, 0, NULL, &d), MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "are not within the 600 frames"));
    ck_assert_int_eq(mlr_layers_repair(G, n + 1, 0, NULL, 0, NULL, 0, NULL, NULL),
                     MLR_E_INVALID_ARG);
    ck_assert_mem_eq(rp, pos, 3 * n * sizeof *rp);
    /* a clip without outliers: nothing changes */
    mlr_layers *C = NULL;
    synthetic_big(n, fps, pos, rot, 5);
    ck_assert_int_eq(mlr_layers_decompose(n, j, pos, rot, o, 2, NULL, &C, NULL), MLR_OK);
    memcpy(rp, pos, 3 * n * sizeof *rp), memcpy(rq, rot, 4 * n * j * sizeof *rq);
    ck_assert_int_eq(mlr_layers_repair(C, 0, n, rp, 3 * n, rq, 4 * n * j, &nr, NULL), MLR_OK);
    ck_assert_uint_eq(nr, 0);
    ck_assert_mem_eq(rp, pos, 3 * n * sizeof *rp);
    ck_assert_mem_eq(rq, rot, 4 * n * j * sizeof *rq);
    mlr_layers_destroy(G), mlr_layers_destroy(C);
    free(pos), free(rot), free(dp), free(dq), free(rp), free(rq), free(fl);
}
END_TEST

START_TEST(robust_allocation_failures_are_clean)
{
    const size_t n = 60, j = 3;
    double pos[3 * 60], rot[4 * 60 * 3];
    synthetic_big(n, 30.0, pos, rot, 3);
    inject_glitch(20, j, pos, rot, 9);
    for (size_t fail_at = 0;; fail_at++) {
        mlr_test_allocator ta;
        mlr_test_allocator_init(&ta, fail_at);
        mlr_layers *L = NULL;
        mlr_status s = mlr_layers_decompose(n, j, pos, rot, NULL, 0, &ta.base, &L, NULL);
        if (s == MLR_OK) {
            unsigned char fl[60 * 4];
            ck_assert_int_eq(mlr_layers_get_outliers(L, fl, sizeof fl), MLR_OK);
            ck_assert_uint_eq(fl[20 * 4 + 1], 1);
            mlr_layers_destroy(L);
        }
        ck_assert_uint_eq(ta.live_blocks, 0);
        if (s == MLR_OK)
            break;
        ck_assert_int_eq(s, MLR_E_NO_MEMORY);
        ck_assert_ptr_null(L);
    }
}
END_TEST

static Suite *layers_suite(void)
{
    Suite *s = suite_create("layers");
    TCase *clips = tcase_create("clips");
    tcase_set_timeout(clips, 300);
    tcase_add_test(clips, identity_on_every_clip);
    tcase_add_test(clips, alpha_zero_is_base_and_one_is_denoised);
    tcase_add_test(clips, root_layers_match_lgs);
    tcase_add_test(clips, gamma_bound_real_clips);
    tcase_add_test(clips, explicit_control_parameters);
    tcase_add_test(clips, fps_gives_the_base_floor);
    tcase_add_test(clips, base_floor_precedence);
    suite_add_tcase(s, clips);
    TCase *num = tcase_create("numerics");
    tcase_set_timeout(num, 120);
    tcase_add_test(num, gamma_bound_synthetic);
    tcase_add_test(num, gcv_matches_dense_scan);
    tcase_add_test(num, gcv_long_clip_matches_banded_scan);
    tcase_add_test(num, denoises_synthetic_motion);
    tcase_add_test(num, exaggeration_stays_below_a_half_turn);
    tcase_add_test(num, constant_motion_and_no_root);
    tcase_add_test(num, body_joint_sets_the_translation_s);
    tcase_add_test(num, robust_without_outliers_is_plain);
    tcase_add_test(num, robust_glitch_is_found_and_local);
    tcase_add_test(num, robust_lead_in_is_an_end_run);
    tcase_add_test(num, robust_rest_pose_with_the_root_in_place_is_an_end_run);
    tcase_add_test(num, robust_joint_flips_any_fps);
    tcase_add_test(num, robust_flip_of_constant_turn_is_undone);
    tcase_add_test(num, repair_replaces_the_outlier_frames);
    suite_add_tcase(s, num);
    TCase *args = tcase_create("arguments");
    tcase_add_test(args, bad_arguments);
    tcase_add_test(args, base_floor_bad_options);
    tcase_add_test(args, every_allocation_failure_is_clean);
    tcase_add_test(args, robust_allocation_failures_are_clean);
    tcase_add_test(args, threads_synthesize_identically);
    suite_add_tcase(s, args);
    return s;
}

int main(void) { return mlr_test_run(layers_suite()); }
