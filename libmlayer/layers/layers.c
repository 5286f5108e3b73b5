/*
 * Motion layers (paper 1, section 4): the handle, the decomposition's stages in order, the
 * getters, synthesis and reconstruction. The base layer is in layers_base.c, the control
 * layer in layers_control.c, the batched solves in layers_batch.c.
 */
#include "layers/layers_internal.h"
#include "common/options_internal.h"
#include "math/quat_internal.h"

#include <math.h>

#define MLR_PI 3.14159265358979323846

/* The base s whose LGS (second-difference prior, identity observations) halves the power at
 * cutoff Hz for a clip at fps: 1 / (1 + s (2 sin(pi f / fps))^4) = 1/2 at f = cutoff. */
static double floor_s_max(double fps, double cutoff)
{
    return pow(2.0 * sin(MLR_PI * cutoff / fps), -4.0);
}

#define MLR_LAYERS_DEFAULT_CUTOFF 0.25 /* Hz */
#define MLR_LAYERS_ROBUST_CUTOFF 2.0        /* Hz: the detection smoother's half-power point */
#define MLR_LAYERS_ROBUST_FPS 30.0          /* the frame rate assumed for it without FPS */
#define MLR_LAYERS_ROBUST_HEIGHT_GATE 0.2   /* translation gate, in body heights */

#define S "layers"
#define INF INFINITY
static const mlr_opt_spec layers_opts[] = {
    {MLR_LAYERS_OPT_GAMMA, "gamma", MLR_OPT_DOUBLE, 0.5 * MLR_PI, MLR_PI, 0, 1, 0.5 * MLR_PI,
     "in [pi/2, pi)"},
    {MLR_LAYERS_OPT_LAM_B, "lam_b", MLR_OPT_DOUBLE, 0.0, INF, 1, 0, 1.0, NULL},
    {MLR_LAYERS_OPT_SIGMA_B, "sigma_b", MLR_OPT_DOUBLE, 0.0, INF, 1, 0, 0.1, NULL},
    {MLR_LAYERS_OPT_LAM_C, "lam_c", MLR_OPT_DOUBLE, 0.0, INF, 1, 0, 1.0, NULL},
    {MLR_LAYERS_OPT_SIGMA_C, "sigma_c", MLR_OPT_DOUBLE, 0.0, INF, 1, 0, 1.0, NULL},
    {MLR_LAYERS_OPT_BASE_S_MIN, "base_s_min", MLR_OPT_DOUBLE, 0.0, INF, 1, 0, 1e-2, NULL},
    {MLR_LAYERS_OPT_BASE_S_MAX, "base_s_max", MLR_OPT_DOUBLE, 0.0, INF, 1, 0, 1e10, NULL},
    {MLR_LAYERS_OPT_CONTROL_S_MIN, "control_s_min", MLR_OPT_DOUBLE, 0.0, INF, 1, 0, 1e-2, NULL},
    {MLR_LAYERS_OPT_CONTROL_S_MAX, "control_s_max", MLR_OPT_DOUBLE, 0.0, INF, 1, 0, 1e8, NULL},
    {MLR_LAYERS_OPT_FPS, "fps", MLR_OPT_DOUBLE, 0.0, INF, 1, 0, MLR_LAYERS_ROBUST_FPS, NULL},
    {MLR_LAYERS_OPT_BASE_CUTOFF, "base_cutoff", MLR_OPT_DOUBLE, 0.0, INF, 1, 0,
     MLR_LAYERS_DEFAULT_CUTOFF, NULL},
    {MLR_LAYERS_OPT_BODY_JOINT, "body_joint", MLR_OPT_INT, 0.0, INF, 0, 0, 0.0, "a joint index"},
    {MLR_LAYERS_OPT_ROBUST, "robust", MLR_OPT_BOOL, 0.0, 1.0, 0, 0, 1.0, NULL},
    {MLR_LAYERS_OPT_BODY_HEIGHT, "body_height", MLR_OPT_DOUBLE, 0.0, INF, 1, 0, 0.0, NULL},
    {MLR_LAYERS_OPT_ROBUST_ANGLE, "robust_angle", MLR_OPT_DOUBLE, 0.0, MLR_PI, 1, 0, 0.5 * MLR_PI,
     "in (0, pi]"},
};
#undef INF

static mlr_status parse_options(const mlr_layers_option *opts, size_t n_opts, size_t n_joints,
                                mlr_layers_cfg *cfg, mlr_diag *diag)
{
    mlr_opt_values o;
    mlr_status st = MLR_OPTIONS_READ(S, layers_opts, opts, n_opts, &o, diag);
    if (st != MLR_OK)
        return st;
    const double *val = o.v;
    const unsigned char *seen = o.given;
    cfg->gamma = val[MLR_LAYERS_OPT_GAMMA];
    cfg->base_s = cfg->control_s = 0.0;
    if (seen[MLR_LAYERS_OPT_LAM_B] || seen[MLR_LAYERS_OPT_SIGMA_B]) {
        const double lam = val[MLR_LAYERS_OPT_LAM_B], sig = val[MLR_LAYERS_OPT_SIGMA_B];
        cfg->base_s = lam * lam * sig * sig;
        if (!(cfg->base_s > 0.0) || !isfinite(cfg->base_s))
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    S ": lam_b^2 sigma_b^2 = %g is not finite and > 0",
                                    cfg->base_s);
    }
    if (seen[MLR_LAYERS_OPT_LAM_C] || seen[MLR_LAYERS_OPT_SIGMA_C]) {
        const double lam = val[MLR_LAYERS_OPT_LAM_C], sig = val[MLR_LAYERS_OPT_SIGMA_C];
        cfg->control_s = lam * lam * sig * sig;
        if (!(cfg->control_s > 0.0) || !isfinite(cfg->control_s))
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    S ": lam_c^2 sigma_c^2 = %g is not finite and > 0",
                                    cfg->control_s);
    }
    const double b = val[MLR_LAYERS_OPT_BODY_JOINT];
    if (!(b < (double)n_joints))
        return options__reject(diag, S, "body_joint", b, "a joint index in [0, %zu)", n_joints);
    cfg->body_joint = (size_t)b;
    cfg->robust = val[MLR_LAYERS_OPT_ROBUST] == 1.0;
    cfg->robust_angle = val[MLR_LAYERS_OPT_ROBUST_ANGLE];
    cfg->robust_length = seen[MLR_LAYERS_OPT_BODY_HEIGHT]
                             ? MLR_LAYERS_ROBUST_HEIGHT_GATE * val[MLR_LAYERS_OPT_BODY_HEIGHT]
                             : 0.0;
    {
        const double fps = val[MLR_LAYERS_OPT_FPS]; /* MLR_LAYERS_ROBUST_FPS when not given */
        /* at fps below twice the cutoff: the weakest smoother there is, s of fps / 4 */
        const double fc = fmin(MLR_LAYERS_ROBUST_CUTOFF, 0.25 * fps);
        cfg->robust_s = floor_s_max(fps, fc);
        cfg->robust_window = fps >= 32.0 ? (size_t)fmin(0.25 * fps + 0.5, 256.0) : 8;
    }
    cfg->base_s_min = val[MLR_LAYERS_OPT_BASE_S_MIN];
    cfg->base_s_max = val[MLR_LAYERS_OPT_BASE_S_MAX];
    if (seen[MLR_LAYERS_OPT_BASE_CUTOFF] && !seen[MLR_LAYERS_OPT_FPS])
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                S
                                ": option base_cutoff = %g (Hz) needs the frame rate (option fps)",
                                val[MLR_LAYERS_OPT_BASE_CUTOFF]);
    if (seen[MLR_LAYERS_OPT_FPS]) {
        const double fps = val[MLR_LAYERS_OPT_FPS];
        const double fc = val[MLR_LAYERS_OPT_BASE_CUTOFF];
        if (!(fc < 0.5 * fps))
            return options__reject(diag, S, "base_cutoff", fc, "in (0, fps/2) = (0, %g) Hz",
                                   0.5 * fps);
        if (seen[MLR_LAYERS_OPT_BASE_CUTOFF] && seen[MLR_LAYERS_OPT_BASE_S_MAX])
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    S
                                    ": options base_cutoff and base_s_max both set the upper end "
                                    "of the base search: give one");
        if (!seen[MLR_LAYERS_OPT_BASE_S_MAX]) {
            cfg->base_s_max = floor_s_max(fps, fc); /* >= 1/16 > the default BASE_S_MIN */
            if (!(cfg->base_s_min < cfg->base_s_max))
                return options__reject(diag, S, "base_s_min", cfg->base_s_min,
                                       "below the base floor's s %g (cutoff %g Hz at %g fps)",
                                       cfg->base_s_max, fc, fps);
        }
    }
    cfg->control_s_min = val[MLR_LAYERS_OPT_CONTROL_S_MIN];
    cfg->control_s_max = val[MLR_LAYERS_OPT_CONTROL_S_MAX];
    if (!(cfg->base_s_min < cfg->base_s_max))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                S ": options base_s_min %g and base_s_max %g are not ordered",
                                cfg->base_s_min, cfg->base_s_max);
    if (!(cfg->control_s_min < cfg->control_s_max))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                S
                                ": options control_s_min %g and control_s_max %g are not ordered",
                                cfg->control_s_min, cfg->control_s_max);
    return MLR_OK;
}
#undef S

/* Sizes (in doubles) of the handle's arrays and of the scratch, overflow-checked. */
typedef struct sizes {
    size_t pos, rot, grp, param, flags, handle_bytes;
    size_t q, fac, comp, work, col, rhs, weights, scratch_bytes;
} sizes;

/* robust: the scratch holds the weights and the right-hand sides of the outlier search */
static mlr_status compute_sizes(size_t n, size_t j, int robust, sizes *z)
{
    size_t ng = j + 1, t;
    if (ng == 0 || common__mul_size(n, 3, &z->pos) || common__mul_size(n, j, &t) ||
        common__mul_size(t, 4, &z->rot) || common__mul_size(n, ng, &t) ||
        common__mul_size(t, 3, &z->grp) || common__mul_size(ng, MLR_LAYERS_N_PARAM, &z->param) ||
        common__mul_size(ng, MLR_LAYERS_WORK, &z->work))
        return MLR_E_OVERFLOW;
    z->q = z->rot;
    z->fac = z->grp; /* three n x (1 + j) factor arrays */
    z->comp = z->rot > z->grp ? z->rot : z->grp; /* compacted channels of the searches */
    z->col = ng;
    z->rhs = 0;
    if (robust && (common__mul_size(n, j, &t) || t > SIZE_MAX - z->comp))
        return MLR_E_OVERFLOW;
    if (robust)
        z->rhs = z->comp + t; /* right-hand sides (4 n j) and leverages (n j) */
    if (common__mul_size(n, ng, &z->flags) ||
        common__mul_size(z->flags, robust ? 2 : 0, &z->weights))
        return MLR_E_OVERFLOW;
    size_t total = z->pos;
    const size_t parts[] = {z->rot, z->grp, z->grp, z->param};
    for (size_t i = 0; i < MLR_COUNTOF(parts); i++) {
        if (total > SIZE_MAX - parts[i])
            return MLR_E_OVERFLOW;
        total += parts[i];
    }
    if (common__mul_size(total, sizeof(double), &t) ||
        t > SIZE_MAX - sizeof(mlr_layers) - 64 - z->flags)
        return MLR_E_OVERFLOW;
    z->handle_bytes = t + sizeof(mlr_layers) + 64 + z->flags;
    total = z->q;
    const size_t sparts[] = {z->fac, z->comp, z->work, z->col, z->rhs, z->weights};
    for (size_t i = 0; i < MLR_COUNTOF(sparts); i++) {
        if (total > SIZE_MAX - sparts[i])
            return MLR_E_OVERFLOW;
        total += sparts[i];
    }
    if (common__mul_size(total, sizeof(double), &z->scratch_bytes))
        return MLR_E_OVERFLOW;
    return MLR_OK;
}

/* Displacements: root u0 = p - pb; joints v = log(conj(qb) q). On return q holds the products
 * conj(qb) q (needed again by the residual) and the largest |u0|, |v_j| are in the params
 * (over the frames that are not outliers of the group when robust). tmp: 1 + j doubles. */
static void displacements(mlr_layers *L, const double *root_pos, int robust, double *q,
                          double *delta, double *tmp)
{
    const size_t n = L->n, j = L->j, ld = 3 * (1 + j);
    double *amax = layers__param_slot(L, MLR_LAYERS_PARAM_BASE_MAX_ANGLE, 0);
    double *a2 = tmp; /* largest squared norms */
    for (size_t g = 0; g <= j; g++)
        a2[g] = 0.0;
    for (size_t i = 0; i < n; i++) {
        double *di = delta + i * ld;
        const double *pb = L->base_pos + 3 * i;
        for (size_t c = 0; c < 3; c++)
            di[c] = root_pos ? root_pos[3 * i + c] - pb[c] : 0.0;
        mlr_quat *qi = (mlr_quat *)(void *)(q + 4 * j * i);
        common__quat_conj_mul_log((const mlr_quat *)(const void *)(L->base_rot + 4 * j * i), qi, j,
                                  0, qi, (mlr_vec3 *)(void *)(di + 3));
        const unsigned char *fl = L->outliers + i * (1 + j);
        for (size_t g = 0; g <= j; g++) {
            const double *v = di + 3 * g;
            const double r = robust && fl[g] ? 0.0 : v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
            a2[g] = r > a2[g] ? r : a2[g];
        }
    }
    for (size_t g = 0; g <= j; g++)
        amax[g] = sqrt(a2[g]);
}

/* Residual in place over delta: u0 - uc for the root, log(conj(exp(vc)) conj(qb) q) for the
 * joints (p = conj(qb) q from displacements()). tmp: 8 j doubles. */
static void residuals(mlr_layers *L, const double *p, double *delta, double *tmp)
{
    const size_t n = L->n, j = L->j, ld = 3 * (1 + j);
    mlr_quat *e = (mlr_quat *)(void *)tmp, *r = e + j;
    for (size_t i = 0; i < n; i++) {
        double *ri = delta + i * ld;
        const double *ci = L->control + i * ld;
        for (size_t c = 0; c < 3; c++)
            ri[c] -= ci[c];
        mlr_quat_exp_array((const mlr_vec3 *)(const void *)(ci + 3), j, e, NULL);
        common__quat_conj_mul_log(e, (const mlr_quat *)(const void *)(p + 4 * j * i), j, 0, r,
                                  (mlr_vec3 *)(void *)(ri + 3));
    }
}

/* The frames of a flip that the robust search undid (flag 2 in L->outliers) counted in the
 * fits with their repaired rotation; the residual layer keeps the input there (p = conj(qb)
 * q_in, in the hemisphere of the repaired product, so that the identity still holds) and the
 * flag becomes 1, an outlier like the others. */
static void restore_undone(mlr_layers *L, const double *rot, double *p)
{
    const size_t n = L->n, j = L->j;
    for (size_t i = 0; i < n; i++) {
        unsigned char *fl = L->outliers + i * (1 + j) + 1;
        for (size_t k = 0; k < j; k++) {
            if (fl[k] != 2)
                continue;
            fl[k] = 1;
            const double *r = rot + 4 * (i * j + k), *b = L->base_rot + 4 * (i * j + k);
            const double nr = sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2] + r[3] * r[3]);
            const mlr_quat o = common__qmul_wxyz(b[0], -b[1], -b[2], -b[3], r[0] / nr, r[1] / nr,
                                                 r[2] / nr, r[3] / nr);
            double *x = p + 4 * (i * j + k);
            const double sg = o.w * x[0] + o.x * x[1] + o.y * x[2] + o.z * x[3] < 0.0 ? -1.0 : 1.0;
            x[0] = sg * o.w, x[1] = sg * o.x, x[2] = sg * o.y, x[3] = sg * o.z;
        }
    }
}

static int all_finite(const double *x, size_t count, size_t *bad)
{
    for (size_t i = 0; i < count; i++) {
        if (!isfinite(x[i])) {
            *bad = i;
            return 0;
        }
    }
    return 1;
}

mlr_status mlr_layers_decompose(size_t n_frames, size_t n_joints, const double *root_pos,
                                const double *rot, const mlr_layers_option *opts, size_t n_opts,
                                const mlr_allocator *alloc, mlr_layers **out, mlr_diag *diag)
{
    if (!out)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "out is NULL");
    *out = NULL;
    if (n_frames < 3)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "the second-difference prior needs at least 3 frames, got %zu",
                                n_frames);
    if (n_joints == 0)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "no joints");
    if (!rot)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "rot is NULL");
    mlr_layers_cfg cfg;
    mlr_status st = parse_options(opts, n_opts, n_joints, &cfg, diag);
    if (st != MLR_OK)
        return st;
    sizes z;
    if (compute_sizes(n_frames, n_joints, cfg.robust, &z) != MLR_OK)
        return common__diag_set(diag, MLR_E_OVERFLOW, 0, 0,
                                "%zu frames x %zu joints overflow a size", n_frames, n_joints);
    size_t bad;
    if (root_pos && !all_finite(root_pos, z.pos, &bad))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "root translation of frame %zu is not finite", bad / 3);

    mlr_allocator a;
    common__allocator_resolve(alloc, &a);
    unsigned char *block = common__alloc(&a, z.handle_bytes);
    if (!block)
        return common__diag_set(diag, MLR_E_NO_MEMORY, 0, 0,
                                "decompose: out of memory (%zu bytes for the layers)",
                                z.handle_bytes);
    double *scratch = common__alloc(&a, z.scratch_bytes);
    if (!scratch) {
        common__free(&a, block, z.handle_bytes);
        return common__diag_set(diag, MLR_E_NO_MEMORY, 0, 0,
                                "decompose: out of memory (%zu bytes of scratch)",
                                z.scratch_bytes);
    }
    mlr_layers *L = (mlr_layers *)(void *)block;
    memset(L, 0, sizeof *L);
    L->alloc = a;
    L->n = n_frames;
    L->j = n_joints;
    L->bytes = z.handle_bytes;
    double *d = (double *)(void *)(block + ((sizeof *L + 63) & ~(size_t)63));
    L->base_pos = d, d += z.pos;
    L->base_rot = d, d += z.rot;
    L->control = d, d += z.grp;
    L->residual = d, d += z.grp;
    L->param = d, d += z.param;
    L->outliers = (unsigned char *)(void *)d;
    memset(L->outliers, 0, z.flags);
    L->end_runs[0] = L->end_runs[1] = 0;

    double *q = scratch, *fac = q + z.q, *comp = fac + z.fac, *work = comp + z.comp;
    size_t *col = (size_t *)(void *)(work + z.work);
    double *rhs = (double *)(void *)(col + z.col);
    const mlr_lay_robust weights = {rhs + z.rhs, rhs + z.rhs + z.flags};
    const mlr_lay_robust *rb = NULL;

    st = layers__prepare_rot(n_frames, n_joints, rot, q, diag);
    if (st == MLR_OK && cfg.robust) {
        int any = 0;
        st = layers__robust_weights(L, &cfg, q, root_pos, &weights, fac, comp, rhs, work, &any,
                                    diag);
        rb = any ? &weights : NULL;
    }
    if (st == MLR_OK)
        st = layers__base(L, &cfg, q, root_pos, rb, fac, comp, work, col, diag);
    if (st == MLR_OK) {
        displacements(L, root_pos, rb != NULL, q, L->residual, fac);
        st = layers__control(L, &cfg, L->residual, rb, fac, comp, work, col, diag);
    }
    if (st == MLR_OK && cfg.robust)
        restore_undone(L, rot, q);
    if (st == MLR_OK)
        residuals(L, q, L->residual, fac);
    common__free(&a, scratch, z.scratch_bytes);
    if (st != MLR_OK) {
        common__free(&a, block, z.handle_bytes);
        return st;
    }
    *out = L;
    return MLR_OK;
}

void mlr_layers_destroy(mlr_layers *L)
{
    if (!L)
        return;
    mlr_allocator a = L->alloc;
    common__free(&a, L, L->bytes);
}

size_t mlr_layers_n_frames(const mlr_layers *L) { return L ? L->n : 0; }
size_t mlr_layers_n_joints(const mlr_layers *L) { return L ? L->j : 0; }

mlr_status mlr_layers_get_base(const mlr_layers *L, double *root_pos, size_t n_root_pos,
                               double *rot, size_t n_rot)
{
    if (!L || (root_pos && n_root_pos != 3 * L->n) || (rot && n_rot != 4 * L->n * L->j))
        return MLR_E_INVALID_ARG;
    if (root_pos)
        memcpy(root_pos, L->base_pos, n_root_pos * sizeof(double));
    if (rot)
        memcpy(rot, L->base_rot, n_rot * sizeof(double));
    return MLR_OK;
}

mlr_status mlr_layers_get_outliers(const mlr_layers *L, unsigned char *out, size_t count)
{
    if (!L || !out || count != L->n * (1 + L->j))
        return MLR_E_INVALID_ARG;
    memcpy(out, L->outliers, count);
    return MLR_OK;
}

mlr_status mlr_layers_get_end_runs(const mlr_layers *L, size_t *head, size_t *tail)
{
    if (!L || !head || !tail)
        return MLR_E_INVALID_ARG;
    *head = L->end_runs[0];
    *tail = L->end_runs[1];
    return MLR_OK;
}

static mlr_status copy_groups(const mlr_layers *L, const double *src, double *out, size_t count)
{
    if (!L || !out || count != 3 * L->n * (1 + L->j))
        return MLR_E_INVALID_ARG;
    memcpy(out, src, count * sizeof(double));
    return MLR_OK;
}

mlr_status mlr_layers_get_control(const mlr_layers *L, double *out, size_t count)
{
    return copy_groups(L, L ? L->control : NULL, out, count);
}

mlr_status mlr_layers_get_residual(const mlr_layers *L, double *out, size_t count)
{
    return copy_groups(L, L ? L->residual : NULL, out, count);
}

mlr_status mlr_layers_get_param(const mlr_layers *L, mlr_layers_param which, double *out,
                                size_t count)
{
    if (!L || !out || count != 1 + L->j || (int)which < 0 || (int)which >= MLR_LAYERS_N_PARAM)
        return MLR_E_INVALID_ARG;
    memcpy(out, layers__param_slot(L, (int)which, 0), count * sizeof(double));
    return MLR_OK;
}

static mlr_status check_range(const mlr_layers *L, size_t begin, size_t count, double *root_pos,
                              size_t n_root_pos, double *rot, size_t n_rot, const char *fn,
                              mlr_diag *diag)
{
    if (!L)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "layers %s: the handle is NULL",
                                fn);
    if (begin > L->n || count > L->n - begin)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "layers %s: frames [%zu, %zu + %zu) are not within the %zu frames",
                                fn, begin, begin, count, L->n);
    if (root_pos && n_root_pos != 3 * count)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "layers %s: n_root_pos is %zu, 3 count is %zu", fn, n_root_pos,
                                3 * count);
    if (rot && n_rot != 4 * L->j * count)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "layers %s: n_rot is %zu, 4 J count is %zu", fn, n_rot,
                                4 * L->j * count);
    return MLR_OK;
}

mlr_status mlr_layers_repair(const mlr_layers *L, size_t begin, size_t count, double *root_pos,
                             size_t n_root_pos, double *rot, size_t n_rot, size_t *n_repaired,
                             mlr_diag *diag)
{
    if (n_repaired)
        *n_repaired = 0;
    mlr_status st = check_range(L, begin, count, root_pos, n_root_pos, rot, n_rot, "repair", diag);
    if (st != MLR_OK)
        return st;
    const size_t g = 1 + L->j;
    const double one = 1.0;
    size_t n = 0;
    for (size_t f = 0; f < count; f++) {
        const unsigned char *o = L->outliers + (begin + f) * g;
        size_t k = 0;
        while (k < g && !o[k])
            k++;
        if (k == g)
            continue;
        /* one frame of the synthesis at alpha 1: the same arithmetic, so the same bits */
        (void)mlr_layers_synthesize(L, begin + f, 1, &one, 1, root_pos ? root_pos + 3 * f : NULL,
                                    3, rot ? rot + 4 * L->j * f : NULL, 4 * L->j, NULL);
        n++;
    }
    if (n_repaired)
        *n_repaired = n;
    return MLR_OK;
}

/* (frame, joint) pairs per exp kernel call in mlr_layers_synthesize */
#define SYNTH_BLOCK 256

/* out[t] = qb[t] * e[t] in the hemisphere of qb[t], for m quaternions (displace() without the
   residual, the same operations: the same bits; vectorized). */
MLR_CLONES("avx2")
static void displace_block(const double *restrict qb, const mlr_quat *restrict e, size_t m,
                           double *restrict out)
{
    for (size_t t = 0; t < m; t++) {
        const double *b = qb + 4 * t;
        mlr_quat o;
        common__quat_mul_inline((const mlr_quat *)(const void *)b, &e[t], &o);
        const double sgn = o.w * b[0] + o.x * b[1] + o.y * b[2] + o.z * b[3] < 0.0 ? -1.0 : 1.0;
        double *q = out + 4 * t;
        q[0] = sgn * o.w, q[1] = sgn * o.x, q[2] = sgn * o.y, q[3] = sgn * o.z;
    }
}

/* q = qb * exp(v) [* exp(r)], in the hemisphere of qb. */
static void displace(const double *qb, const double *v, double alpha, const double *r, double *out)
{
    const mlr_vec3 av = {alpha * v[0], alpha * v[1], alpha * v[2]};
    mlr_quat e, o;
    mlr_quat_exp_array(&av, 1, &e, NULL);
    mlr_quat_mul((const mlr_quat *)(const void *)qb, &e, &o);
    if (r) {
        mlr_quat_exp_array((const mlr_vec3 *)(const void *)r, 1, &e, NULL);
        mlr_quat_mul(&o, &e, &o);
    }
    const double sgn = o.w * qb[0] + o.x * qb[1] + o.y * qb[2] + o.z * qb[3] < 0.0 ? -1.0 : 1.0;
    out[0] = sgn * o.w, out[1] = sgn * o.x, out[2] = sgn * o.y, out[3] = sgn * o.z;
}

/* Synthesis with the alphas of frame f at alpha + f * fstride (fstride 0: one row for every
   frame), n_alpha per row; the arguments checked by the callers. The same arithmetic for
   every stride, so one row repeated gives the bits of the constant synthesis. */
static void synthesize_rows(const mlr_layers *L, size_t begin, size_t count, const double *alpha,
                            size_t n_alpha, size_t fstride, double *root_pos, double *rot)
{
    const size_t j = L->j, ld = 3 * (1 + j);
    if (root_pos)
        for (size_t f = 0; f < count; f++) {
            const size_t i = begin + f;
            const double *ci = L->control + i * ld, a0 = alpha[f * fstride];
            for (size_t c = 0; c < 3; c++)
                root_pos[3 * f + c] = L->base_pos[3 * i + c] + a0 * ci[c];
        }
    if (!rot)
        return;
    /* the exps and products by blocks of (frame, joint) pairs, in the order of rot (one kernel
       call per block; the same arithmetic per quaternion, so the same bits as displace()) */
    const size_t n = count * j;
    size_t f = 0, k = 0; /* the pair p0 + t */
    for (size_t p0 = 0; p0 < n; p0 += SYNTH_BLOCK) {
        const size_t m = n - p0 < SYNTH_BLOCK ? n - p0 : SYNTH_BLOCK;
        mlr_vec3 av[SYNTH_BLOCK];
        mlr_quat e[SYNTH_BLOCK];
        for (size_t t = 0; t < m; t++) {
            const double ak = alpha[f * fstride + (n_alpha == 1 ? 0 : 1 + k)];
            const double *v = L->control + (begin + f) * ld + 3 + 3 * k;
            av[t] = quat__scale_turn((mlr_vec3){v[0], v[1], v[2]}, ak);
            if (++k == j)
                k = 0, f++;
        }
        mlr_quat_exp_array(av, m, e, NULL);
        displace_block(L->base_rot + 4 * (begin * j + p0), e, m, rot + 4 * p0);
    }
}

mlr_status mlr_layers_synthesize(const mlr_layers *L, size_t begin, size_t count,
                                 const double *alpha, size_t n_alpha, double *root_pos,
                                 size_t n_root_pos, double *rot, size_t n_rot, mlr_diag *diag)
{
    mlr_status st =
        check_range(L, begin, count, root_pos, n_root_pos, rot, n_rot, "synthesize", diag);
    if (st != MLR_OK)
        return st;
    const size_t j = L->j;
    if (!alpha || (n_alpha != 1 && n_alpha != 1 + j))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "layers synthesize: %zu alphas (NULL: %d), not 1 or 1 + J = %zu",
                                n_alpha, !alpha, 1 + j);
    for (size_t g = 0; g < n_alpha; g++)
        if (!isfinite(alpha[g]))
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    "layers synthesize: alpha[%zu] is NaN or infinite", g);
    synthesize_rows(L, begin, count, alpha, n_alpha, 0, root_pos, rot);
    return MLR_OK;
}

mlr_status mlr_layers_synthesize_frames(const mlr_layers *L, size_t begin, size_t count,
                                        const double *alpha, size_t n_alpha, double *root_pos,
                                        size_t n_root_pos, double *rot, size_t n_rot,
                                        mlr_diag *diag)
{
    mlr_status st =
        check_range(L, begin, count, root_pos, n_root_pos, rot, n_rot, "synthesize_frames", diag);
    if (st != MLR_OK)
        return st;
    const size_t g = 1 + L->j;
    if (!alpha && count)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "layers synthesize_frames: alpha is NULL");
    size_t per_frame = 0;
    if (n_alpha == count)
        per_frame = 1;
    else if (count && n_alpha / count == g && n_alpha % count == 0)
        per_frame = g;
    else
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "layers synthesize_frames: %zu alphas, not count = %zu or "
                                "count (1 + J) = %zu x %zu",
                                n_alpha, count, count, g);
    for (size_t k = 0; k < n_alpha; k++)
        if (!isfinite(alpha[k]))
            return common__diag_set(
                diag, MLR_E_INVALID_ARG, 0, 0,
                "layers synthesize_frames: the alpha of frame %zu, group %zu is "
                "NaN or infinite",
                begin + k / per_frame, k % per_frame);
    if (count)
        synthesize_rows(L, begin, count, alpha, per_frame, per_frame, root_pos, rot);
    return MLR_OK;
}

mlr_status mlr_layers_reconstruct(const mlr_layers *L, size_t begin, size_t count,
                                  double *root_pos, size_t n_root_pos, double *rot, size_t n_rot,
                                  mlr_diag *diag)
{
    mlr_status st =
        check_range(L, begin, count, root_pos, n_root_pos, rot, n_rot, "reconstruct", diag);
    if (st != MLR_OK)
        return st;
    const size_t j = L->j, ld = 3 * (1 + j);
    for (size_t f = 0; f < count; f++) {
        const size_t i = begin + f;
        const double *ci = L->control + i * ld, *ri = L->residual + i * ld;
        if (root_pos)
            for (size_t c = 0; c < 3; c++)
                root_pos[3 * f + c] = (L->base_pos[3 * i + c] + ci[c]) + ri[c];
        if (rot)
            for (size_t k = 0; k < j; k++)
                displace(L->base_rot + 4 * (i * j + k), ci + 3 + 3 * k, 1.0, ri + 3 + 3 * k,
                         rot + 4 * (f * j + k));
    }
    return MLR_OK;
}
