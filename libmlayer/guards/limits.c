/* Joint limits: ranges per joint learned from clips (or given), applied with a soft saturation
 * (mlr_limits.h). The human table and the anatomical classes are in limits_human.c. */
#include "guards/limits_internal.h"

#include <float.h>
#include <string.h>

#include "common/mlr_internal.h"
#include "common/options_internal.h"
#include "math/quat_internal.h"

#define PI 3.14159265358979323846
#define DEG (PI / 180.0)
#define MIN_INPUT_BOUND (5.0 * DEG)

/* ---------------------------------------------------------------------------------------- */
/* Small vector helpers                                                                     */

static double dot3(mlr_vec3 a, mlr_vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static double norm3(mlr_vec3 a) { return sqrt(dot3(a, a)); }
static mlr_vec3 scale3(mlr_vec3 a, double s)
{
    mlr_vec3 c = {a.x * s, a.y * s, a.z * s};
    return c;
}
static mlr_vec3 vec3_at(const double *p)
{
    mlr_vec3 v = {p[0], p[1], p[2]};
    return v;
}
static mlr_quat qconj(mlr_quat q)
{
    mlr_quat c = {q.w, -q.x, -q.y, -q.z};
    return c;
}
static mlr_quat qmul(mlr_quat a, mlr_quat b)
{
    mlr_quat c;
    common__quat_mul_inline(&a, &b, &c);
    return c;
}
static mlr_vec3 qrot(mlr_quat q, mlr_vec3 v)
{
    const double vv[3] = {v.x, v.y, v.z};
    double o[3];
    common__quat_rotate_inline(&q, vv, o);
    return (mlr_vec3){o[0], o[1], o[2]};
}
/* Rotation by angle about the unit axis n. */
static mlr_quat axis_angle(mlr_vec3 n, double angle)
{
    const double s = sin(0.5 * angle);
    mlr_quat q = {cos(0.5 * angle), n.x * s, n.y * s, n.z * s};
    return q;
}

/* The signed angle about the unit axis n from a to q v, both projected on the plane normal to n,
 * as the (y, x) of its atan2, for the unit quaternion (w, ux, uy, uz); an = a.n. Scalars in and
 * out, so that the vectorized loops take it as it is (the same operations: the same bits). */
static inline void hinge_pair(double w, double ux, double uy, double uz, mlr_vec3 v, mlr_vec3 a,
                              mlr_vec3 n, double an, double *y, double *x)
{
    const mlr_quat q = {w, ux, uy, uz};
    const double vv[3] = {v.x, v.y, v.z};
    double s[3];
    common__quat_rotate_inline(&q, vv, s);
    const double cx = a.y * s[2] - a.z * s[1], cy = a.z * s[0] - a.x * s[2],
                 cz = a.x * s[1] - a.y * s[0];
    *y = n.x * cx + n.y * cy + n.z * cz;
    *x = (a.x * s[0] + a.y * s[1] + a.z * s[2]) - an * (s[0] * n.x + s[1] * n.y + s[2] * n.z);
}

/* The swing-twist decomposition of r = (w, x, y, z), w >= 0, about unit t = (tx, ty, tz), in
 * the closed forms every path of this file takes (scalar and vectorized blocks: the same
 * operations, the same bits). With p = v.t (v the vector part), the twist is 2 atan2(|p|, w)
 * and the swing 2 atan2(|v - p t|, |(w, p)|): st_pairs gives p, the swing's sine-like |v - p t|
 * in *s and its cosine-like |(w, p)| (the twist's norm) in *c. Branch-free: vectorizes. */
static inline void st_pairs(double w, double x, double y, double z, double tx, double ty,
                            double tz, double *p, double *s, double *c)
{
    const double pp = x * tx + y * ty + z * tz;
    const double vx = x - pp * tx, vy = y - pp * ty, vz = z - pp * tz;
    *p = pp;
    *s = sqrt(vx * vx + vy * vy + vz * vz);
    *c = sqrt(w * w + pp * pp);
}

/* The swing s = r conj(tw) of r (as st_pairs'; p and tn = |(w, p)| from it), tw the unit twist
 * (w, p t) / tn, or the identity when tn <= 1e-300; s.w >= 0 (its vector part is the swing
 * axis' direction, unnormalized). Branch-free: vectorizes. */
static inline mlr_quat st_swing(double w, double x, double y, double z, double tx, double ty,
                                double tz, double p, double tn)
{
    const int ok = tn > 1e-300;
    const double d = common__select_bits(ok, tn, 1.0);
    const double tww = common__select_bits(ok, w / d, 1.0),
                 twx = common__select_bits(ok, p * tx / d, 0.0),
                 twy = common__select_bits(ok, p * ty / d, 0.0),
                 twz = common__select_bits(ok, p * tz / d, 0.0);
    mlr_quat sq = common__qmul_wxyz(w, x, y, z, tww, -twx, -twy, -twz);
    if (sq.w < 0)
        sq.w = -sq.w, sq.x = -sq.x, sq.y = -sq.y, sq.z = -sq.z;
    return sq;
}

/* The twist angle of r (r.w >= 0) about unit t, in [-pi, pi]. */
static double twist_angle(mlr_quat r, mlr_vec3 t)
{
    double p, s, tw_n;
    st_pairs(r.w, r.x, r.y, r.z, t.x, t.y, t.z, &p, &s, &tw_n);
    const double c = tw_n > 1e-300 ? r.w / tw_n : 1.0;
    double twist = 2.0 * atan2(p / (tw_n > 1e-300 ? tw_n : 1.0), c);
    if (twist > PI)
        twist -= 2.0 * PI;
    else if (twist < -PI)
        twist += 2.0 * PI;
    return twist;
}

/* The swing angle of an st_swing s. */
static double swing_angle(mlr_quat s)
{
    return 2.0 * atan2(sqrt(s.x * s.x + s.y * s.y + s.z * s.z), s.w);
}

/* Quaternion with the vector part of q (any length > 0) as axis and the given angle. */
static mlr_quat with_angle(mlr_quat q, double angle)
{
    const double vn = sqrt(q.x * q.x + q.y * q.y + q.z * q.z);
    if (!(vn > 0))
        return q;
    const double s = sin(0.5 * angle) / vn;
    mlr_quat o = {cos(0.5 * angle), q.x * s, q.y * s, q.z * s};
    return o;
}

/* The largest eigenvalue and its vector of a symmetric PSD 3 x 3 matrix (power iteration
 * from the largest column; enough for a concentration ratio). */
static double top_eigen(const double *m, mlr_vec3 *e)
{
    int best = 0;
    for (int i = 1; i < 3; i++)
        if (m[4 * i] > m[4 * best])
            best = i;
    mlr_vec3 v = vec3_at(m + 3 * best);
    double lam = 0.0;
    for (int it = 0; it < 200; it++) {
        mlr_vec3 w = {m[0] * v.x + m[1] * v.y + m[2] * v.z, m[3] * v.x + m[4] * v.y + m[5] * v.z,
                      m[6] * v.x + m[7] * v.y + m[8] * v.z};
        const double n = norm3(w);
        if (!(n > 0))
            break;
        lam = n / (norm3(v) > 0 ? norm3(v) : 1.0);
        v = scale3(w, 1.0 / n);
    }
    *e = v;
    return lam;
}

/* Are the squared norms of the m <= 64 quaternions at p (4 doubles each) all finite and
 * nonzero? Branch-free, vectorized. */
MLR_CLONES("avx2")
static int quat_block_ok(const double *p, size_t m)
{
    long ok = 1;
    for (size_t i = 0; i < m; i++) {
        const double *e = p + 4 * i;
        const double n2 = e[0] * e[0] + e[1] * e[1] + e[2] * e[2] + e[3] * e[3];
        ok &= (n2 > 0.0) & (n2 <= DBL_MAX);
    }
    return ok != 0;
}

/* The index of the first of the n quaternions (4 doubles each) whose squared norm is not
 * finite or is zero, or n when there is none. */
static size_t first_bad_quat(const double *q, size_t n)
{
    for (size_t i0 = 0; i0 < n; i0 += 64) {
        const size_t m = n - i0 < 64 ? n - i0 : 64;
        const double *p = q + 4 * i0;
        if (quat_block_ok(p, m))
            continue;
        for (size_t i = 0; i < m; i++) {
            const double *e = p + 4 * i;
            const double n2 = e[0] * e[0] + e[1] * e[1] + e[2] * e[2] + e[3] * e[3];
            if (!(n2 > 0.0 && n2 <= DBL_MAX))
                return i0 + i;
        }
    }
    return n;
}

/* Is the squared norm of quaternion q (4 doubles) finite (else zero)? For the messages. */
static int quat_finite(const double *q)
{
    return isfinite(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
}

/* ---------------------------------------------------------------------------------------- */
/* Create                                                                                   */

/* quats_unit: the clips' rotations are unit quaternions the caller made (not checked again). */
static mlr_status check_clips(const mlr_rig *rig, const mlr_limits_clip *clips, size_t n_clips,
                              int quats_unit, mlr_diag *diag)
{
    const size_t J = rig->n_joints, P = rig->n_trans;
    if (!clips || n_clips == 0)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "limits: no clips");
    for (size_t k = 0; k < n_clips; k++) {
        const mlr_limits_clip *c = &clips[k];
        if (c->n_frames == 0 || !c->rot)
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "limits: clip %zu has %s", k,
                                    c->rot ? "no frames" : "rot NULL");
        size_t nq;
        if (common__mul_size(c->n_frames, J, &nq) != MLR_OK || nq > SIZE_MAX / 4)
            return common__diag_set(diag, MLR_E_OVERFLOW, 0, 0, "limits: clip %zu too large", k);
        const size_t i = quats_unit ? nq : first_bad_quat(c->rot, nq);
        if (i < nq)
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    "limits: clip %zu rot[%zu][%zu] is %s", k, i / J, i % J,
                                    quat_finite(c->rot + 4 * i) ? "zero" : "not finite");
        if (c->trans && P > 0)
            for (size_t i = 0; i < c->n_frames * P * 3; i++)
                if (!isfinite(c->trans[i]))
                    return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                            "limits: clip %zu trans[%zu][%zu] is not finite", k,
                                            i / (3 * P), (i / 3) % P);
    }
    return MLR_OK;
}

typedef struct create_opts {
    int human;
    double fold, soft, rev_soft;
} create_opts;

static const mlr_opt_spec limits_opts[] = {
    {MLR_LIMITS_OPT_HUMAN, "human", MLR_OPT_INT, -1.0, 1.0, 0, 0, -1.0,
     "-1 (decide), 0 (not human) or 1 (human)"},
    {MLR_LIMITS_OPT_FOLD, "fold", MLR_OPT_DOUBLE, 0.0, PI, 1, 0, 150.0 * DEG, "in (0, pi]"},
    {MLR_LIMITS_OPT_SOFT, "soft", MLR_OPT_DOUBLE, 0.0, 1.0, 1, 1, 0.15, NULL},
    {MLR_LIMITS_OPT_REVERSAL_SOFT, "reversal_soft", MLR_OPT_DOUBLE, 0.0, 0.5 * PI, 1, 0,
     10.0 * DEG, "in (0, pi/2]"},
};

static mlr_status read_opts(const mlr_limits_option *opts, size_t n_opts, create_opts *o,
                            mlr_diag *diag)
{
    mlr_opt_values v;
    mlr_status st = MLR_OPTIONS_READ("limits", limits_opts, opts, n_opts, &v, diag);
    o->human = (int)v.v[MLR_LIMITS_OPT_HUMAN];
    o->fold = v.v[MLR_LIMITS_OPT_FOLD];
    o->soft = v.v[MLR_LIMITS_OPT_SOFT];
    o->rev_soft = v.v[MLR_LIMITS_OPT_REVERSAL_SOFT];
    return st;
}

static int name_contains(const mlr_rig *rig, const char *word)
{
    if (!rig->names)
        return 0;
    const size_t n = strlen(word);
    for (size_t j = 0; j < rig->n_joints; j++) {
        const char *s = rig->names[j];
        for (; s && *s; s++) {
            size_t i = 0;
            while (i < n && s[i] && (s[i] | 0x20) == word[i])
                i++;
            if (i == n)
                return 1;
        }
    }
    return 0;
}

/* Per-joint accumulators during create (scratch). */
typedef struct acc {
    mlr_quat qsum;
    mlr_vec3 xsum;
    double m[9];
    /* the largest swing and |twist| so far as (sine-like, cosine-like) pairs: the angle is
       2 atan2(s, c), monotonic in s / c, so the atan2 is taken once at the end */
    double sw_s, sw_c, tw_s, tw_c;
    double ms[9]; /* moments of the swings' vector parts (the twist about the bone removed) */
    /* the smallest and largest hinge angle so far as (y, x) pairs of atan2 (hinge_pair) */
    double lo_y, lo_x, hi_y, hi_x;
    /* the largest whole angle of a joint with no bone out, as a (sine-like, cosine-like) pair */
    double an_s, an_c;
    mlr_vec3 t;   /* bone_out / |bone_out|, or zero */
    int need_x;   /* pass 1: the axis sum (|bone_in| |bone_out| > 0: the axis can be learned) */
    int need_m;   /* hinge candidate: moments of the logs, hinge angle extremes */
    int need_ms;  /* named hinge candidate: moments of the swings */
    int has_out;  /* |bone_out| > 0 */
} acc;

/* Is atan2(y1, x1) < atan2(y2, x2)? By the half planes and the cross product where that
   decides it beyond rounding, else by the atan2s themselves (so the extreme pair's atan2 is
   the extreme of the atan2s). */
static inline int angle_less(double y1, double x1, double y2, double x2)
{
    if (y1 == y2 && x1 == x2 && signbit(y1) == signbit(y2) && signbit(x1) == signbit(x2))
        return 0; /* the same pair (a static joint's frames) */
    if (y1 != 0.0 && y2 != 0.0) {
        if ((y1 < 0.0) != (y2 < 0.0))
            return y1 < 0.0;
        const double c = x1 * y2 - y1 * x2;
        if (fabs(c) > 1e-9 * (fabs(x1) + fabs(y1)) * (fabs(x2) + fabs(y2)))
            return c > 0.0;
    }
    return atan2(y1, x1) < atan2(y2, x2);
}

/* Is the angle of (s, c) larger than that of (bs, bc)? (s, bs >= 0, c, bc >= 0) */
static int wider(double s, double c, double bs, double bc) { return s * bc > bs * c; }

/* Is any of the m pairs (s[i], c[i]) wider than (bs, bc)? Branch-free, vectorized. */
MLR_CLONES("avx2")
static int any_wider(const double *s, const double *c, size_t m, double bs, double bc)
{
    long any = 0;
    for (size_t i = 0; i < m; i++)
        any |= s[i] * bc > bs * c[i];
    return any != 0;
}

/* (*bs, *bc) replaced in turn by each of the m pairs (s[i], c[i]) wider than it (most blocks
   have none: any_wider finds them first). */
static void widen(const double *s, const double *c, size_t m, double *bs, double *bc)
{
    if (!any_wider(s, c, m, *bs, *bc))
        return;
    double ws = *bs, wc = *bc;
    for (size_t i = 0; i < m; i++)
        if (wider(s[i], c[i], ws, wc))
            ws = s[i], wc = c[i];
    *bs = ws, *bc = wc;
}

/* The scratch and inputs of learning a rig's limits, shared by the steps of
   mlr_limits_create. */
typedef struct learner {
    const mlr_rig *rig;
    const mlr_limits_clip *clips;
    size_t n_clips;
    mlr_limits_joint *jt;
    acc *ac;
    int32_t *main_child;
    int *is_hinge, *cls;
    int unit; /* the clips' rotations are unit quaternions (not normalized again) */
} learner;

/* Bones: offsets, or the mean translation of a trans joint over the clips; each joint's main
   child (the longest bone) and bone_out. */
static void measure_bones(const learner *L)
{
    const mlr_rig *rig = L->rig;
    const mlr_limits_clip *clips = L->clips;
    const size_t n_clips = L->n_clips, J = rig->n_joints;
    mlr_limits_joint *jt = L->jt;
    const size_t P = rig->n_trans;
    int32_t *main_child = L->main_child;
    for (size_t j = 0; j < J; j++)
        jt[j].bone_in = vec3_at(rig->offsets + 3 * j);
    if (P > 0) {
        size_t n_tot = 0;
        for (size_t k = 0; k < n_clips; k++)
            if (clips[k].trans)
                n_tot += clips[k].n_frames;
        if (n_tot > 0)
            for (size_t p = 0; p < P; p++) {
                mlr_vec3 s = {0, 0, 0};
                for (size_t k = 0; k < n_clips; k++)
                    for (size_t f = 0; clips[k].trans && f < clips[k].n_frames; f++) {
                        const double *t = clips[k].trans + 3 * (f * P + p);
                        s.x += t[0], s.y += t[1], s.z += t[2];
                    }
                jt[rig->trans_joints[p]].bone_in = scale3(s, 1.0 / (double)n_tot);
            }
    }
    for (size_t j = 0; j < J; j++)
        main_child[j] = -1;
    for (size_t c = 1; c < J; c++) {
        const int32_t p = rig->parents[c];
        const double lc = norm3(jt[c].bone_in);
        if (lc > 0 && (main_child[p] < 0 || lc > norm3(jt[p].bone_out))) {
            main_child[p] = (int32_t)c;
            jt[p].bone_out = jt[c].bone_in;
        }
    }
    for (size_t e = 0; e < rig->n_end_sites; e++) {
        const int32_t p = rig->end_site_parents[e];
        const mlr_vec3 v = vec3_at(rig->end_site_offsets + 3 * e);
        if (main_child[p] < 0 && norm3(v) > norm3(jt[p].bone_out))
            jt[p].bone_out = v;
    }
}

/* The frames of a block of learn_centres and measure_extents. */
#define EXT_FB 64

/* The m <= EXT_FB quaternions p + stride i (doubles) into w, x, y, z, normalized unless unit
 * (the caller's are unit quaternions: taken as they are). */
#if defined(__GNUC__)
__attribute__((always_inline))
#endif
static inline void load_unit(const double *restrict p, size_t stride, size_t m, int unit,
                             double *restrict w, double *restrict x, double *restrict y,
                             double *restrict z)
{
    if (unit) {
        for (size_t i = 0; i < m; i++) {
            const double *e = p + stride * i;
            w[i] = e[0], x[i] = e[1], y[i] = e[2], z[i] = e[3];
        }
        return;
    }
    for (size_t i = 0; i < m; i++) {
        const double *e = p + stride * i;
        const double n = sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2] + e[3] * e[3]);
        w[i] = e[0] / n, x[i] = e[1] / n, y[i] = e[2] / n, z[i] = e[3] / n;
    }
}

/* The m <= EXT_FB quaternions p + stride i (doubles) of a joint, normalized (q), added to
 * *qsum sign-aligned (q, or -q when its dot product with qsum is negative) and, unless a is
 * NULL, a x q b added to *xsum, in order, as learn_centres takes them. Vectorized but for the
 * sums. */
MLR_CLONES("avx2")
static void centres_block(const double *p, size_t stride, size_t m, int unit, const mlr_vec3 *a,
                          const mlr_vec3 *b, mlr_quat *qsum, mlr_vec3 *xsum)
{
    double qw[EXT_FB], qx[EXT_FB], qy[EXT_FB], qz[EXT_FB], xs[3 * EXT_FB];
    load_unit(p, stride, m, unit, qw, qx, qy, qz);
    double sw = qsum->w, sx = qsum->x, sy = qsum->y, sz = qsum->z;
    for (size_t i = 0; i < m; i++) { /* q + sum, or sum - q: the bits of sum + sign * q */
        if (sw * qw[i] + sx * qx[i] + sy * qy[i] + sz * qz[i] < 0)
            sw -= qw[i], sx -= qx[i], sy -= qy[i], sz -= qz[i];
        else
            sw += qw[i], sx += qx[i], sy += qy[i], sz += qz[i];
    }
    *qsum = (mlr_quat){sw, sx, sy, sz};
    if (!a)
        return;
    const double v[3] = {b->x, b->y, b->z}, ax = a->x, ay = a->y, az = a->z;
    for (size_t i = 0; i < m; i++) {
        const mlr_quat q = {qw[i], qx[i], qy[i], qz[i]};
        double o[3];
        common__quat_rotate_inline(&q, v, o);
        xs[i] = ay * o[2] - az * o[1];
        xs[EXT_FB + i] = az * o[0] - ax * o[2];
        xs[2 * EXT_FB + i] = ax * o[1] - ay * o[0];
    }
    mlr_vec3 x = *xsum;
    for (size_t i = 0; i < m; i++)
        x.x += xs[i], x.y += xs[EXT_FB + i], x.z += xs[2 * EXT_FB + i];
    *xsum = x;
}

/* Pass 1: centres (sign-aligned sums) and hinge axes (sum of a x q b), by blocks of EXT_FB
   frames, joint by joint within them. */
static void learn_centres(const learner *L)
{
    const mlr_rig *rig = L->rig;
    const mlr_limits_clip *clips = L->clips;
    const size_t n_clips = L->n_clips, J = rig->n_joints;
    mlr_limits_joint *jt = L->jt;
    acc *ac = L->ac;
    for (size_t j = 0; j < J; j++)
        ac[j].need_x = norm3(jt[j].bone_in) * norm3(jt[j].bone_out) > 0;
    for (size_t k = 0; k < n_clips; k++)
        for (size_t f0 = 0; f0 < clips[k].n_frames; f0 += EXT_FB) {
            const size_t nf = clips[k].n_frames - f0 < EXT_FB ? clips[k].n_frames - f0 : EXT_FB;
            for (size_t j = 0; j < J; j++) {
                acc *c = &ac[j];
                /* no axis without both bones: the axis sum is not read */
                centres_block(clips[k].rot + 4 * (f0 * J + j), 4 * J, nf, L->unit,
                              c->need_x ? &jt[j].bone_in : NULL, &jt[j].bone_out, &c->qsum,
                              &c->xsum);
            }
        }
    for (size_t j = 0; j < J; j++) {
        mlr_quat s = ac[j].qsum;
        const double n = sqrt(s.w * s.w + s.x * s.x + s.y * s.y + s.z * s.z);
        if (n > 0)
            jt[j].centre = (mlr_quat){s.w / n, s.x / n, s.y / n, s.z / n};
        else
            jt[j].centre = (mlr_quat){1, 0, 0, 0};
        if (jt[j].centre.w < 0)
            jt[j].centre =
                (mlr_quat){-jt[j].centre.w, -jt[j].centre.x, -jt[j].centre.y, -jt[j].centre.z};
        const double xn = norm3(ac[j].xsum);
        const double scale = norm3(jt[j].bone_in) * norm3(jt[j].bone_out);
        if (scale > 0 && xn > 1e-9 * scale)
            jt[j].axis = scale3(ac[j].xsum, 1.0 / xn);
        jt[j].stats[0] = jt[j].stats[1] = 0.0; /* measure_extents: hinge candidates' */
    }
}

/* The centred rotations r = conj(centre) q / |q| (cc = conj(centre); r.w >= 0) of the m <= EXT_FB
 * quaternions p + stride i (doubles) of a joint, as measure_extents' other joints take them
 * (the same operations: the same bits), reduced to the pairs of their maxima: with a bone out
 * (unit t), the swing's (|v - p t|, |(w, p)|) in s1, c1 and the twist's (|p|, w) in s2, c2
 * (p = v.t); without one (t NULL), the whole angle's (|v|, w) in s1, c1. Vectorized. */
MLR_CLONES("avx2")
static void extents_block(const double *p, size_t stride, size_t m, int unit, mlr_quat cc,
                          const mlr_vec3 *t, double *s1, double *c1, double *s2, double *c2)
{
    const double aw = cc.w, ax = cc.x, ay = cc.y, az = cc.z;
    double rw[EXT_FB], rx[EXT_FB], ry[EXT_FB], rz[EXT_FB];
    double qw[EXT_FB], qx[EXT_FB], qy[EXT_FB], qz[EXT_FB];
    load_unit(p, stride, m, unit, qw, qx, qy, qz);
    for (size_t i = 0; i < m; i++) {
        const mlr_quat r = common__qmul_wxyz(aw, ax, ay, az, qw[i], qx[i], qy[i], qz[i]);
        const double w = r.w, x = r.x, y = r.y, z = r.z;
        const int neg = w < 0;
        rw[i] = neg ? -w : w, rx[i] = neg ? -x : x, ry[i] = neg ? -y : y, rz[i] = neg ? -z : z;
    }
    if (!t) {
        for (size_t i = 0; i < m; i++) {
            s1[i] = sqrt(rx[i] * rx[i] + ry[i] * ry[i] + rz[i] * rz[i]);
            c1[i] = rw[i];
        }
        return;
    }
    const double tx = t->x, ty = t->y, tz = t->z;
    for (size_t i = 0; i < m; i++) {
        double pp;
        st_pairs(rw[i], rx[i], ry[i], rz[i], tx, ty, tz, &pp, &s1[i], &c1[i]);
        s2[i] = fabs(pp);
        c2[i] = rw[i];
    }
}

/* What measure_extents takes of the m <= EXT_FB quaternions p + stride i (doubles) of hinge
 * candidate g (unit bone out t): the centred rotations r (r.w >= 0) in lq, the hinge angle's
 * (y, x) pairs (hinge_pair of q b) in hy, hx, the swing's and the twist's pairs as
 * extents_block's in s1, c1, s2, c2, and the vector parts of the swings s = r conj(twist)
 * (s.w >= 0) in sv (x, y, z by blocks of EXT_FB); the same operations as the scalar helpers
 * (hinge_pair, st_pairs, st_swing): the same bits. Vectorized. */
MLR_CLONES("avx2")
static void cand_block(const double *restrict p, size_t stride, size_t m, int unit,
                       const mlr_limits_joint *restrict g, const mlr_vec3 *restrict t,
                       mlr_quat *restrict lq, double *restrict hy, double *restrict hx,
                       double *restrict s1, double *restrict c1, double *restrict s2,
                       double *restrict c2, double *restrict sv)
{
    const double aw = g->centre.w, ax = -g->centre.x, ay = -g->centre.y, az = -g->centre.z;
    const mlr_vec3 v = g->bone_out, n = g->axis, a = g->bone_in;
    const double an = dot3(a, n), tx = t->x, ty = t->y, tz = t->z;
    double qw[EXT_FB], qx[EXT_FB], qy[EXT_FB], qz[EXT_FB];
    load_unit(p, stride, m, unit, qw, qx, qy, qz);
    for (size_t i = 0; i < m; i++) {
        const double bw = qw[i], bx = qx[i], by = qy[i], bz = qz[i];
        hinge_pair(bw, bx, by, bz, v, a, n, an, &hy[i], &hx[i]);
        /* r = conj(centre) q, r.w >= 0 */
        const mlr_quat r = common__qmul_wxyz(aw, ax, ay, az, bw, bx, by, bz);
        double w = r.w, x = r.x, y = r.y, z = r.z;
        const int neg = w < 0;
        w = neg ? -w : w, x = neg ? -x : x, y = neg ? -y : y, z = neg ? -z : z;
        lq[i].w = w, lq[i].x = x, lq[i].y = y, lq[i].z = z;
        /* the swing's and the twist's pairs */
        double pp, tn;
        st_pairs(w, x, y, z, tx, ty, tz, &pp, &s1[i], &tn);
        c1[i] = tn;
        s2[i] = fabs(pp);
        c2[i] = w;
        /* s = r conj(tw), tw the unit twist */
        const mlr_quat sq = st_swing(w, x, y, z, tx, ty, tz, pp, tn);
        sv[i] = sq.x, sv[EXT_FB + i] = sq.y, sv[2 * EXT_FB + i] = sq.z;
    }
}

/* The smallest and largest hinge angle so far (c->lo_y .. c->hi_x) with the m pairs (hy, hx)
 * (angle_less), in order; first: they are the first pairs (the first one sets both). In the
 * AVX2 clone: three-operand code, fewer register copies. */
MLR_CLONES("avx2")
static void hinge_extremes(const double *hy, const double *hx, size_t m, int first, acc *c)
{
    double lo_y = c->lo_y, lo_x = c->lo_x, hi_y = c->hi_y, hi_x = c->hi_x;
    for (size_t i = 0; i < m; i++) {
        const double y = hy[i], x = hx[i];
        if ((first && i == 0) || angle_less(y, x, lo_y, lo_x))
            lo_y = y, lo_x = x;
        if ((first && i == 0) || angle_less(hi_y, hi_x, y, x))
            hi_y = y, hi_x = x;
    }
    c->lo_y = lo_y, c->lo_x = lo_x, c->hi_y = hi_y, c->hi_x = hi_x;
}

/* The upper triangle of the second moments of the m vectors (x, y, z)[stride i] added to mom
 * (3 x 3), in order. In the AVX2 clone: three-operand code, fewer register copies. */
MLR_CLONES("avx2")
static void add_moments(const double *x, const double *y, const double *z, size_t stride, size_t m,
                        double *mom)
{
    double m00 = mom[0], m01 = mom[1], m02 = mom[2], m11 = mom[4], m12 = mom[5], m22 = mom[8];
    for (size_t i = 0; i < m; i++) {
        const double a = x[stride * i], b = y[stride * i], c = z[stride * i];
        m00 += a * a, m01 += a * b, m02 += a * c, m11 += b * b, m12 += b * c, m22 += c * c;
    }
    mom[0] = m00, mom[1] = m01, mom[2] = m02, mom[4] = m11, mom[5] = m12, mom[8] = m22;
}

/* Pass 2: moments of the centred rotation vectors, hinge angle, swing and twist maxima, by
   blocks of EXT_FB frames, joint by joint within them. The hinge angle extremes and the
   moments are taken for find_hinges' candidates only (named hinges, or every joint with an
   axis when the rig has no names): no other joint can be a hinge, and the others'
   stats[0..1] are 0; the other joints' maxima are reduced by extents_block. */
static void measure_extents(const learner *L)
{
    const mlr_rig *rig = L->rig;
    const mlr_limits_clip *clips = L->clips;
    const size_t n_clips = L->n_clips, J = rig->n_joints;
    mlr_limits_joint *jt = L->jt;
    acc *ac = L->ac;
    mlr_quat lq[EXT_FB];
    mlr_vec3 rv[EXT_FB];
    double s1[EXT_FB], c1[EXT_FB], s2[EXT_FB], c2[EXT_FB], hy[EXT_FB], hx[EXT_FB], sv[3 * EXT_FB];
    size_t n_seen = 0;
    for (size_t j = 0; j < J; j++) {
        acc *c = &ac[j];
        c->sw_s = c->tw_s = c->an_s = 0.0, c->sw_c = c->tw_c = c->an_c = 1.0;
        /* the moments of the rotation vectors and the hinge angle extremes: for find_hinges'
           candidates; the swings': for named hinges */
        const int named = rig->names ? limits__hinge_name(rig->names[j]) : 0;
        const int cand = j > 0 && norm3(jt[j].axis) > 0 && (!rig->names || named);
        c->need_m = cand;
        c->need_ms = cand && named;
        const double bl = norm3(jt[j].bone_out);
        c->t = bl > 0 ? scale3(jt[j].bone_out, 1.0 / bl) : (mlr_vec3){0, 0, 0};
        c->has_out = bl > 0;
    }
    for (size_t k = 0; k < n_clips; k++)
        for (size_t f0 = 0; f0 < clips[k].n_frames; f0 += EXT_FB) {
            const size_t nf = clips[k].n_frames - f0 < EXT_FB ? clips[k].n_frames - f0 : EXT_FB;
            for (size_t j = 0; j < J; j++) {
                mlr_limits_joint *g = &jt[j];
                acc *c = &ac[j];
                const double *p0 = clips[k].rot + 4 * (f0 * J + j);
                if (!c->need_m) {
                    extents_block(p0, 4 * J, nf, L->unit, qconj(g->centre),
                                  c->has_out ? &c->t : NULL, s1, c1, s2, c2);
                    if (!c->has_out) {
                        widen(s1, c1, nf, &c->an_s, &c->an_c);
                        continue;
                    }
                    widen(s1, c1, nf, &c->sw_s, &c->sw_c);
                    widen(s2, c2, nf, &c->tw_s, &c->tw_c);
                    continue;
                }
                /* a hinge candidate (it has both bones, as its axis) */
                cand_block(p0, 4 * J, nf, L->unit, g, &c->t, lq, hy, hx, s1, c1, s2, c2, sv);
                hinge_extremes(hy, hx, nf, n_seen == 0, c);
                widen(s1, c1, nf, &c->sw_s, &c->sw_c);
                widen(s2, c2, nf, &c->tw_s, &c->tw_c);
                if (c->need_ms)
                    add_moments(sv, sv + EXT_FB, sv + 2 * EXT_FB, 1, nf, c->ms);
                (void)mlr_quat_log_array(lq, nf, rv, NULL);
                add_moments(&rv[0].x, &rv[0].y, &rv[0].z, 3, nf, c->m);
            }
            n_seen += nf;
        }
    for (size_t j = 0; j < J; j++) {
        acc *c = &ac[j];
        for (int a3 = 0; a3 < 3; a3++) /* the moments' lower triangles */
            for (int b3 = 0; b3 < a3; b3++)
                c->m[3 * a3 + b3] = c->m[3 * b3 + a3], c->ms[3 * a3 + b3] = c->ms[3 * b3 + a3];
        if (norm3(jt[j].bone_out) > 0) {
            jt[j].stats[2] = 2.0 * atan2(c->sw_s, c->sw_c);
            jt[j].stats[3] = 2.0 * atan2(c->tw_s, c->tw_c);
        } else {
            jt[j].stats[2] = 2.0 * atan2(c->an_s, c->an_c);
        }
        if (c->need_m && n_seen > 0) {
            jt[j].stats[0] = atan2(c->lo_y, c->lo_x);
            jt[j].stats[1] = atan2(c->hi_y, c->hi_x);
        }
    }
}

/* Hinges (is_hinge: by name and concentration about the learned axis, or without names by
   concentration and range); 1 when the rig is human (or as opts say). */
static int find_hinges(const learner *L, int human_opt)
{
    const mlr_rig *rig = L->rig;
    const size_t J = rig->n_joints;
    mlr_limits_joint *jt = L->jt;
    const acc *ac = L->ac;
    int *is_hinge = L->is_hinge;
    const double cos35 = cos(35.0 * DEG);
    double arm_len = 0, leg_len = 0;
    int n_arm = 0, n_leg = 0;
    for (size_t j = 1; j < J; j++) {
        mlr_limits_joint *g = &jt[j];
        if (!(norm3(g->axis) > 0)) {
            g->stats[0] = g->stats[1] = 0.0;
            continue;
        }
        const double *m = ac[j].m;
        const double tr = m[0] + m[4] + m[8];
        mlr_vec3 e = {0, 0, 0};
        const double l1 = tr > 0 ? top_eigen(m, &e) : 0.0;
        const double conc = tr > 0 ? l1 / tr : 0.0;
        /* e is an axis of the centred rotations conj(centre) q; the hinge axis lives in the
           parent's frame, where the rotations about e turn about centre e */
        const double along = fabs(dot3(qrot(g->centre, e), g->axis));
        const int named = rig->names ? limits__hinge_name(rig->names[j]) : 0;
        if (named && conc >= 0.5 && along >= cos35) {
            is_hinge[j] = named;
        } else if (named) {
            /* a hinge that also twists about its bone (a forearm's pronation, a capture's
               twist noise) turns about another axis as a whole; its swing (the bone's
               direction) still turns about the hinge axis */
            const double *ms = ac[j].ms;
            const double trs = ms[0] + ms[4] + ms[8];
            mlr_vec3 es = {0, 0, 0};
            const double ls = trs > 0 ? top_eigen(ms, &es) : 0.0;
            if (trs > 0 && ls / trs >= 0.5 && fabs(dot3(qrot(g->centre, es), g->axis)) >= cos35)
                is_hinge[j] = named;
        } else if (!rig->names && conc >= 0.9 && along >= cos35 &&
                   g->stats[1] - g->stats[0] >= 30.0 * DEG && rig->parents[j] > 0)
            is_hinge[j] = 1;
        if (named && is_hinge[j]) {
            const double len = norm3(g->bone_in) + norm3(g->bone_out);
            if (named == 1)
                leg_len += len, n_leg++;
            else
                arm_len += len, n_arm++;
        }
    }
    if (human_opt >= 0)
        return human_opt;
    return rig->names && !name_contains(rig, "tail") && n_leg > 0 && n_arm > 0 &&
           (arm_len / n_arm) < 0.85 * (leg_len / n_leg);
}

/* Classes and ranges of every joint. */
static void set_ranges(const learner *L, const mlr_limits *lim, const create_opts *o)
{
    const mlr_rig *rig = L->rig;
    const size_t J = rig->n_joints;
    mlr_limits_joint *jt = L->jt;
    int *cls = L->cls;
    const int *is_hinge = L->is_hinge;
    const int32_t *main_child = L->main_child;
    limits__classify(rig, is_hinge, main_child, cls);
    size_t count[MLR_LIMITS_CLASS_COUNT] = {0};
    for (size_t j = 0; j < J; j++)
        count[cls[j]]++;
    for (size_t j = 0; j < J; j++) {
        mlr_limits_joint *g = &jt[j];
        g->cls = cls[j];
        mlr_limits_range *r = &g->range;
        if (cls[j] == MLR_LIMITS_CLASS_FREE) {
            r->kind = MLR_LIMITS_FREE, r->source = MLR_LIMITS_SOURCE_NONE;
            continue;
        }
        if (is_hinge[j]) {
            r->kind = MLR_LIMITS_HINGE;
            r->lo = fmin(0.0, g->stats[0]);
            r->hi = fmax(o->fold, g->stats[1]);
            r->source = lim->human ? MLR_LIMITS_SOURCE_TABLE : MLR_LIMITS_SOURCE_INPUT;
            continue;
        }
        r->kind = MLR_LIMITS_SWING_TWIST;
        /* the input's own extent sits at the knee point (a relative 1e-12 above it, so that
         * rounding never moves an input frame) */
        const double grow = (1.0 + 1e-12) / (1.0 - o->soft);
        const double in_sw = fmin(PI, fmax(MIN_INPUT_BOUND, g->stats[2] * grow));
        const double in_tw = fmin(PI, fmax(MIN_INPUT_BOUND, g->stats[3] * grow));
        double t_sw, t_tw;
        if (lim->human && limits__table(cls[j], count[cls[j]], &t_sw, &t_tw)) {
            r->swing = fmin(PI, fmax(t_sw, g->stats[2] * grow));
            r->twist = fmin(PI, fmax(t_tw, g->stats[3] * grow));
            r->widen = 0, r->source = MLR_LIMITS_SOURCE_TABLE;
        } else {
            r->swing = in_sw, r->twist = in_tw;
            r->widen = 1, r->source = MLR_LIMITS_SOURCE_INPUT;
        }
    }
}

static mlr_status create_limits(const mlr_rig *rig, const mlr_limits_clip *clips, size_t n_clips,
                                const mlr_limits_option *opts, size_t n_opts,
                                const mlr_allocator *alloc, int quats_unit, mlr_limits **out,
                                mlr_diag *diag)
{
    if (out)
        *out = NULL;
    if (!out)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "limits: out is NULL");
    mlr_status st = mlr_rig_check(rig, diag);
    if (st != MLR_OK)
        return st;
    create_opts o;
    if ((st = read_opts(opts, n_opts, &o, diag)) != MLR_OK)
        return st;
    if ((st = check_clips(rig, clips, n_clips, quats_unit, diag)) != MLR_OK)
        return st;
    const size_t J = rig->n_joints;
    mlr_allocator a;
    common__allocator_resolve(alloc, &a);
    size_t jbytes, sbytes;
    if (common__mul_size(J, sizeof(mlr_limits_joint), &jbytes) != MLR_OK ||
        common__mul_size(J, sizeof(acc) + 3 * sizeof(int32_t), &sbytes) != MLR_OK)
        return common__diag_set(diag, MLR_E_OVERFLOW, 0, 0, "limits: too many joints");
    mlr_limits *lim = common__alloc(&a, sizeof *lim);
    if (!lim)
        return common__diag_set(diag, MLR_E_NO_MEMORY, 0, 0, "limits: out of memory");
    memset(lim, 0, sizeof *lim);
    lim->alloc = a;
    lim->n_joints = J;
    lim->soft = o.soft;
    lim->rev_soft = o.rev_soft;
    lim->joints = common__alloc(&a, jbytes);
    void *scratch = common__alloc(&a, sbytes);
    if (!lim->joints || !scratch) {
        common__free(&a, scratch, sbytes);
        mlr_limits_destroy(lim);
        return common__diag_set(diag, MLR_E_NO_MEMORY, 0, 0, "limits: out of memory");
    }
    memset(lim->joints, 0, jbytes);
    memset(scratch, 0, sbytes);
    learner L = {rig, clips, n_clips, lim->joints, scratch, NULL, NULL, NULL, quats_unit};
    L.main_child = (int32_t *)(L.ac + J);
    L.is_hinge = (int *)(L.main_child + J), L.cls = L.is_hinge + J;

    measure_bones(&L);
    learn_centres(&L);
    measure_extents(&L);
    lim->human = find_hinges(&L, o.human);
    set_ranges(&L, lim, &o);
    common__free(&a, scratch, sbytes);
    *out = lim;
    return MLR_OK;
}

mlr_status mlr_limits_create(const mlr_rig *rig, const mlr_limits_clip *clips, size_t n_clips,
                             const mlr_limits_option *opts, size_t n_opts,
                             const mlr_allocator *alloc, mlr_limits **out, mlr_diag *diag)
{
    return create_limits(rig, clips, n_clips, opts, n_opts, alloc, 0, out, diag);
}

mlr_status limits__create_unit(const mlr_rig *rig, const mlr_limits_clip *clips, size_t n_clips,
                               const mlr_allocator *alloc, mlr_limits **out, mlr_diag *diag)
{
    return create_limits(rig, clips, n_clips, NULL, 0, alloc, 1, out, diag);
}

/* ---------------------------------------------------------------------------------------- */
/* Access                                                                                   */

size_t mlr_limits_n_joints(const mlr_limits *lim) { return lim ? lim->n_joints : 0; }
int mlr_limits_is_human(const mlr_limits *lim) { return lim ? lim->human : 0; }

mlr_status mlr_limits_get_range(const mlr_limits *lim, size_t joint, mlr_limits_range *out)
{
    if (!lim || !out || joint >= lim->n_joints)
        return MLR_E_INVALID_ARG;
    *out = lim->joints[joint].range;
    return MLR_OK;
}

mlr_status mlr_limits_set_range(mlr_limits *lim, size_t joint, const mlr_limits_range *range,
                                mlr_diag *diag)
{
    if (!lim || !range)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "limits: %s is NULL",
                                lim ? "range" : "limits");
    if (joint >= lim->n_joints)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "limits: joint %zu out of range (J = %zu)", joint, lim->n_joints);
    mlr_limits_joint *g = &lim->joints[joint];
    mlr_limits_range r = *range;
    switch (r.kind) {
    case MLR_LIMITS_FREE:
        break;
    case MLR_LIMITS_HINGE:
        if (!(norm3(g->axis) > 0) || !(norm3(g->bone_out) > 0))
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    "limits: joint %zu has no thigh and shin vectors for a hinge",
                                    joint);
        if (!isfinite(r.lo) || !isfinite(r.hi) || !(r.lo > -PI) || !(r.hi <= PI) || !(r.lo < r.hi))
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    "limits: joint %zu hinge range [%g, %g] must satisfy "
                                    "-pi < lo < hi <= pi",
                                    joint, r.lo, r.hi);
        break;
    case MLR_LIMITS_SWING_TWIST:
        if (!isfinite(r.swing) || !isfinite(r.twist) || !(r.swing > 0) || !(r.swing <= PI) ||
            !(r.twist > 0) || !(r.twist <= PI))
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    "limits: joint %zu swing %g and twist %g must be in (0, pi]",
                                    joint, r.swing, r.twist);
        break;
    default:
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "limits: joint %zu unknown kind %d",
                                joint, r.kind);
    }
    r.widen = r.widen != 0;
    r.source = MLR_LIMITS_SOURCE_USER;
    g->range = r;
    return MLR_OK;
}

mlr_status mlr_limits_get_geometry(const mlr_limits *lim, size_t joint, double *centre,
                                   double *axis, double *bone_in, double *bone_out, double *stats)
{
    if (!lim || joint >= lim->n_joints)
        return MLR_E_INVALID_ARG;
    const mlr_limits_joint *g = &lim->joints[joint];
    if (centre)
        centre[0] = g->centre.w, centre[1] = g->centre.x, centre[2] = g->centre.y,
        centre[3] = g->centre.z;
    if (axis)
        axis[0] = g->axis.x, axis[1] = g->axis.y, axis[2] = g->axis.z;
    if (bone_in)
        bone_in[0] = g->bone_in.x, bone_in[1] = g->bone_in.y, bone_in[2] = g->bone_in.z;
    if (bone_out)
        bone_out[0] = g->bone_out.x, bone_out[1] = g->bone_out.y, bone_out[2] = g->bone_out.z;
    if (stats)
        memcpy(stats, g->stats, sizeof g->stats);
    return MLR_OK;
}

void mlr_limits_destroy(mlr_limits *lim)
{
    if (!lim)
        return;
    mlr_allocator a = lim->alloc;
    if (lim->joints)
        common__free(&a, lim->joints, lim->n_joints * sizeof(mlr_limits_joint));
    common__free(&a, lim, sizeof *lim);
}

/* ---------------------------------------------------------------------------------------- */
/* Apply                                                                                    */

/* x + 2 pi k nearest prev, when that is within a quarter turn of prev; else x. */
static double unwrap_near(double x, double prev)
{
    const double y = x + 2.0 * PI * round((prev - x) / (2.0 * PI));
    return fabs(y - prev) <= 0.5 * PI ? y : x;
}

/* sin^2 of half the smallest knee point (where the soft saturation begins) of a swing-twist
 * joint at alpha: a centred rotation whose whole angle is below it has swing and |twist|
 * below their knee points (both are at most the whole angle), so the limits leave it as it
 * is. A relative margin covers the rounding of the angles' computation. */
static double fast_bound(const mlr_limits *lim, const mlr_limits_joint *g, double alpha)
{
    const mlr_limits_range *r = &g->range;
    const double wide = r->widen ? fmax(1.0, fabs(alpha)) : 1.0;
    const double smax = fmin(PI, r->swing * wide), tmax = fmin(PI, r->twist * wide);
    const double k = norm3(g->bone_out) > 0
                         ? fmin(smax - lim->soft * smax, tmax - lim->soft * tmax)
                         : smax - lim->soft * smax;
    if (!(k > 0))
        return -1.0;
    const double sh = sin(0.5 * k);
    return sh * sh * (1.0 - 1e-9);
}

/* What limit_joint reads of a joint at one alpha, the same for every frame: worked out once
 * per joint and alpha (bounds_of) instead of at every frame. */
typedef struct joint_bounds {
    double w_hi, w_lo, mid;          /* hinge: the soft widths, the excluded arc's middle */
    double smax, tmax, ws, wt, fast; /* swing-twist: the bounds at alpha, their soft widths,
                                        fast_bound */
    double bl;                       /* |bone_out| */
    double an;                       /* hinge: bone_in . axis (hinge_pair's) */
    mlr_vec3 t;                      /* bone_out / bl (bl > 0) */
    int hard;                        /* hinge: only angles outside [lo, hi], to the bound */
    /* the fast paths without atan2 (in_arc): a hinge angle within the arc where the limits
       leave it, of middle (hc_x, hc_y) (unit) and half width of cosine h_cos (h_fast: the
       arc is not empty); the halves of the swing's and the twist's knee points as (cos, sin) */
    double hc_x, hc_y, h_cos, sk_c, sk_s, tk_c, tk_s;
    int h_fast;
    mlr_quat cc; /* conj(centre) */
} joint_bounds;

/* The fast paths' margin: an angle decided without its atan2 is this far (radians) inside its
   bound, far beyond the rounding of the atan2 path (1e-15), so both paths agree on every
   frame; the frames nearer the bound take the atan2 path. */
#define FAST_MARGIN 1e-10

/* Is atan2(y, x) in [h - a, h + a] + 2 pi k by FAST_MARGIN, a in [0, pi], given
   (hx, hy) = (cos h, sin h) and ca = cos a? cos(angle - h) >= cos a + margin implies that
   (|cos u - cos v| <= |u - v|); |x| + |y| >= |(x, y)| makes the margin relative. */
static int in_arc(double y, double x, double hx, double hy, double ca)
{
    return x * hx + y * hy > ca * sqrt(x * x + y * y) + FAST_MARGIN * (fabs(x) + fabs(y));
}

/* Is 2 atan2(s, c) (s, c >= 0) below the angle 2 h, given (hc, hs) = (cos h, sin h), h in
   [0, pi / 2], by FAST_MARGIN? sin(h - atan2(s, c)) >= margin implies that. */
static int below_half(double s, double c, double hc, double hs)
{
    return hs * c - hc * s > FAST_MARGIN * (s + c);
}

/* The angle a joint read at the frame before, for unwrapping in time: v (NAN for none), or,
 * when that frame took a fast path of limit_joint (inside the range, so its angle was not
 * needed there), what the angle is read from only if a later frame needs it: pending 1, the
 * frame's centred rotation rr (its twist); pending 2, the hinge's (y, x) of its atan2 in
 * (rr.x, rr.y). */
typedef struct prev_angle {
    double v;
    int pending; /* 3: the twist of conj(centre) *qp, qp a quaternion left as it was */
    mlr_quat rr;
    const mlr_quat *qp;
} prev_angle;

/* The hinge angle atan2(y, x) in [mid - 2 pi, mid). */
static double hinge_angle(double y, double x, double mid)
{
    double phi = atan2(y, x);
    if (phi >= mid)
        phi -= 2.0 * PI;
    else if (phi < mid - 2.0 * PI)
        phi += 2.0 * PI;
    return phi;
}

/* The value of *pv, reading a pending angle. */
static double prev_value(prev_angle *pv, const joint_bounds *b)
{
    if (pv->pending == 3) {
        pv->rr = qmul(b->cc, *pv->qp);
        if (pv->rr.w < 0)
            pv->rr = (mlr_quat){-pv->rr.w, -pv->rr.x, -pv->rr.y, -pv->rr.z};
        pv->pending = 1;
    }
    if (pv->pending == 1)
        pv->v = twist_angle(pv->rr, b->t);
    else if (pv->pending == 2)
        pv->v = hinge_angle(pv->rr.x, pv->rr.y, b->mid);
    pv->pending = 0;
    return pv->v;
}

static joint_bounds bounds_of(const mlr_limits *lim, const mlr_limits_joint *g, double alpha,
                              int hard)
{
    const mlr_limits_range *r = &g->range;
    joint_bounds b;
    memset(&b, 0, sizeof b);
    b.fast = -1.0;
    b.bl = norm3(g->bone_out);
    if (b.bl > 0)
        b.t = scale3(g->bone_out, 1.0 / b.bl);
    b.hard = hard && r->kind == MLR_LIMITS_HINGE;
    b.cc = qconj(g->centre);
    if (r->kind == MLR_LIMITS_HINGE) {
        b.an = dot3(g->bone_in, g->axis);
        const double span = r->hi - r->lo;
        b.w_hi = lim->soft * span, b.w_lo = fmin(lim->rev_soft, 0.5 * span);
        if (b.w_hi + b.w_lo > span)
            b.w_hi = span - b.w_lo;
        b.mid = 0.5 * (r->hi + r->lo) + PI; /* middle of the excluded arc */
        /* the angles limit_joint leaves as they are: [lo, hi] (hard), else
           [lo + w_lo, hi - w_hi] (below both soft zones) */
        const double lo = b.hard ? r->lo : r->lo + b.w_lo, hi = b.hard ? r->hi : r->hi - b.w_hi;
        b.h_fast = hi > lo;
        b.hc_x = cos(0.5 * (hi + lo)), b.hc_y = sin(0.5 * (hi + lo)),
        b.h_cos = cos(0.5 * (hi - lo));
    } else if (r->kind == MLR_LIMITS_SWING_TWIST) {
        const double wide = r->widen ? fmax(1.0, fabs(alpha)) : 1.0;
        b.smax = fmin(PI, r->swing * wide), b.tmax = fmin(PI, r->twist * wide);
        b.ws = lim->soft * b.smax, b.wt = lim->soft * b.tmax;
        b.fast = fast_bound(lim, g, alpha);
        const double hs = fmax(0.0, 0.5 * (b.smax - b.ws)), ht = fmax(0.0, 0.5 * (b.tmax - b.wt));
        b.sk_c = cos(hs), b.sk_s = sin(hs), b.tk_c = cos(ht), b.tk_s = sin(ht);
    }
    return b;
}

/* How far inside its range (a fraction of it) the hard mode sets a hinge angle that left it:
   1e-9 of 150 degrees is 2.6e-9 radians, far above the rounding of the angle (1e-15) and far
   below anything a body shows. */
#define HARD_INSIDE 1e-9

/* Limit one unit quaternion of joint g; returns 1 when changed. prev: for a hinge in a run of
 * frames, the angle read at the frame before (NAN for none; updated). The angle is read in
 * [m - 2 pi, m), m the middle of the excluded arc; outside [lo, hi] and with a frame before,
 * in the branch nearest that frame's (unwrapped in time), so a trajectory that crosses the
 * middle of the excluded arc stays on its side instead of snapping to the other bound. A swing-twist joint's
 * twist is unwrapped the same way (it would snap from +twist to -twist at a half turn). */
static inline int limit_joint(const mlr_limits_joint *g, const joint_bounds *b, mlr_quat *q,
                              prev_angle *prev)
{
    const mlr_limits_range *r = &g->range;
    const mlr_quat q0 = *q;
    if (r->kind == MLR_LIMITS_HINGE) {
        const double w_hi = b->w_hi, w_lo = b->w_lo;
        double y, x;
        hinge_pair(q->w, q->x, q->y, q->z, g->bone_out, g->bone_in, g->axis, b->an, &y, &x);
        if (b->h_fast && in_arc(y, x, b->hc_x, b->hc_y, b->h_cos)) { /* left as it is */
            if (prev)
                prev->pending = 2, prev->rr = (mlr_quat){0, y, x, 0};
            return 0;
        }
        double phi = hinge_angle(y, x, b->mid);
        /* outside the range, on the side the frame before was on (no drift inside it), unless
           the step from there is a jump (over a quarter turn: a glitch frame, a T-pose) */
        if (prev && (phi < r->lo || phi > r->hi)) {
            const double pv = prev_value(prev, b);
            if (isfinite(pv))
                phi = unwrap_near(phi, pv);
        }
        if (prev)
            prev->v = phi, prev->pending = 0;
        double phi2 = phi;
        if (b->hard) /* just inside the bound it passed, so that rounding keeps it inside */
            phi2 = phi > r->hi   ? r->hi - HARD_INSIDE * (r->hi - r->lo)
                   : phi < r->lo ? r->lo + HARD_INSIDE * (r->hi - r->lo)
                                 : phi;
        else if (phi > r->hi - w_hi)
            phi2 = limits__soft(phi, r->hi, w_hi);
        else if (phi < r->lo + w_lo)
            phi2 = -limits__soft(-phi, -r->lo, w_lo);
        if (phi2 == phi)
            return 0;
        *q = qmul(axis_angle(g->axis, phi2 - phi), *q);
    } else if (r->kind == MLR_LIMITS_SWING_TWIST) {
        const double smax = b->smax, tmax = b->tmax, ws = b->ws, wt = b->wt;
        mlr_quat rr = qmul(b->cc, *q);
        if (rr.w < 0)
            rr = (mlr_quat){-rr.w, -rr.x, -rr.y, -rr.z};
        const double bl = b->bl;
        const double vv = rr.x * rr.x + rr.y * rr.y + rr.z * rr.z;
        if (vv < b->fast) { /* well inside: unchanged */
            if (prev && bl > 0)
                prev->pending = 1, prev->rr = rr;
            return 0;
        }
        if (bl > 0) {
            const mlr_vec3 t = b->t;
            /* swing and twist below their knee points, decided without the atan2s: the twist
               2 atan2(|p|, w), p = v.t, and the swing 2 atan2(|v - p t|, |(w, p)|) (the
               closed forms of twist_angle's and swing_angle's); one below its knee point is
               left as it is, so its angle is not needed */
            double pp, ss, tn;
            st_pairs(rr.w, rr.x, rr.y, rr.z, t.x, t.y, t.z, &pp, &ss, &tn);
            const int twist_in = below_half(fabs(pp), rr.w, b->tk_c, b->tk_s);
            const int swing_in = below_half(ss, tn, b->sk_c, b->sk_s);
            mlr_quat sq = rr;
            double sw = 0.0, sw2 = 0.0;
            if (!(twist_in && swing_in)) {
                sq = st_swing(rr.w, rr.x, rr.y, rr.z, t.x, t.y, t.z, pp, tn);
                if (!swing_in) {
                    sw = swing_angle(sq);
                    sw2 = sw > smax - ws ? limits__soft(sw, smax, ws) : sw;
                }
            }
            if (twist_in && sw2 == sw) { /* unchanged; its twist read if a later frame needs it */
                if (prev)
                    prev->pending = 1, prev->rr = rr;
                return 0;
            }
            double tw = twist_angle(rr, t);
            if (prev) { /* beyond its bound, the twist unwrapped in time as a hinge's angle */
                if (fabs(tw) > tmax) {
                    const double pv = prev_value(prev, b);
                    if (isfinite(pv))
                        tw = unwrap_near(tw, pv);
                }
                prev->v = tw, prev->pending = 0;
            }
            const double atw = fabs(tw);
            const double tw2 = atw > tmax - wt ? copysign(limits__soft(atw, tmax, wt), tw) : tw;
            if (sw2 == sw && tw2 == tw)
                return 0;
            const mlr_quat s2 = sw2 == sw ? sq : with_angle(sq, sw2);
            *q = qmul(g->centre, qmul(s2, axis_angle(t, tw2)));
        } else {
            const double vs = sqrt(vv);
            if (below_half(vs, rr.w, b->sk_c, b->sk_s)) /* the whole angle below the knee */
                return 0;
            const double ang = 2.0 * atan2(vs, rr.w);
            if (!(ang > smax - ws))
                return 0;
            *q = qmul(g->centre, with_angle(rr, limits__soft(ang, smax, ws)));
        }
    } else {
        return 0;
    }
    if (q->w * q0.w + q->x * q0.x + q->y * q0.y + q->z * q0.z < 0)
        *q = (mlr_quat){-q->w, -q->x, -q->y, -q->z};
    return 1;
}

void limits__apply_frame(const mlr_limits *lim, mlr_quat *q, const double *alpha, size_t stride,
                         size_t *counts)
{
    for (size_t j = 0; j < lim->n_joints; j++) {
        const double a = alpha ? alpha[stride * j] : 1.0;
        const mlr_limits_joint *g = &lim->joints[j];
        const joint_bounds b = bounds_of(lim, g, a, 0);
        if (limit_joint(g, &b, &q[j], NULL) && counts)
            counts[j]++;
    }
}

void limits__apply_kind(const mlr_limits *lim, size_t n_frames, mlr_quat *rot, const double *alpha,
                        size_t n_alpha, size_t *counts, int kind)
{
    limits__apply_kind_masked(lim, n_frames, rot, alpha, n_alpha, counts, kind, NULL, NULL, 0, 0);
}

/* Which of the m quaternions q[stride i] of joint g limit_joint leaves as they are by its first
 * fast path (a hinge angle in the arc b->hc_x .. b->h_cos with b->h_fast, or a swing-twist
 * rotation of squared vector part below b->fast > 0), in inside[i], and a hinge's (y, x)
 * pairs in hy, hx: found for a block of frames at once, as limit_joint decides them (the same
 * operations: the same bits). Vectorized. */
MLR_CLONES("avx2")
static void inside_block(const mlr_quat *restrict q, size_t stride, size_t m,
                         const mlr_limits_joint *restrict g, const joint_bounds *restrict b,
                         double *restrict hy, double *restrict hx, int *restrict inside)
{
    if (g->range.kind == MLR_LIMITS_HINGE) {
        const mlr_vec3 v = g->bone_out, a = g->bone_in, n = g->axis;
        const double an = b->an, cx = b->hc_x, cy = b->hc_y, ca = b->h_cos;
        for (size_t i = 0; i < m; i++) {
            const mlr_quat *p = q + stride * i;
            hinge_pair(p->w, p->x, p->y, p->z, v, a, n, an, &hy[i], &hx[i]);
            inside[i] = in_arc(hy[i], hx[i], cx, cy, ca);
        }
        return;
    }
    const double aw = b->cc.w, ax = b->cc.x, ay = b->cc.y, az = b->cc.z, fast = b->fast;
    for (size_t i = 0; i < m; i++) {
        const mlr_quat *p = q + stride * i;
        const mlr_quat r = common__qmul_wxyz(aw, ax, ay, az, p->w, p->x, p->y, p->z);
        inside[i] = r.x * r.x + r.y * r.y + r.z * r.z < fast;
    }
}

/* Is any of the n bytes mask[stride f] nonzero? By fours, then one by one. */
static int any_limited(const uint8_t *mask, size_t stride, size_t n)
{
    size_t f = 0;
    for (; f + 4 <= n; f += 4)
        if (mask[stride * f] | mask[stride * (f + 1)] | mask[stride * (f + 2)] |
            mask[stride * (f + 3)])
            return 1;
    for (; f < n; f++)
        if (mask[stride * f])
            return 1;
    return 0;
}

/* The frames of a block of limits__apply_kind_masked. */
#define APPLY_FB 64

/* limit_joint on the nf <= APPLY_FB frames from f0 of joint j of rot (n_frames x J), in order
 * (b, prev: its bounds and unwrapping state; mask and counts as limits__apply_kind_masked's).
 * The rotations limit_joint's first fast path leaves as they are are found for the block at once
 * (inside_block), a run of them passed over at once, its last one's angle read only if a later
 * frame needs it. In the AVX2 clone: three-operand code, fewer register copies. */
MLR_CLONES("avx2")
static void limit_block(const mlr_limits *lim, size_t j, const joint_bounds *b, prev_angle *prev,
                        mlr_quat *rot, size_t f0, size_t nf, const uint8_t *mask, size_t *counts)
{
    const size_t J = lim->n_joints;
    const mlr_limits_joint *g = &lim->joints[j];
    const int hinge = g->range.kind == MLR_LIMITS_HINGE;
    double hy[APPLY_FB], hx[APPLY_FB];
    int inside[APPLY_FB + 1];
    const int pre = hinge ? b->h_fast : b->fast > 0;
    if (mask && !any_limited(mask + f0 * J + j, J, nf)) { /* nothing limited in the block: what
                                                             its frames' loop leaves */
        *prev = (prev_angle){NAN, 0, {1, 0, 0, 0}, NULL};
        return;
    }
    if (pre) { /* a run of frames inside ends at one not limited, or at the end */
        inside_block(rot + f0 * J + j, J, nf, g, b, hy, hx, inside);
        for (size_t f = f0; mask && f < f0 + nf; f++)
            inside[f - f0] &= mask[f * J + j] != 0;
        inside[nf] = 0;
    }
    for (size_t f = f0; f < f0 + nf; f++) {
        if (mask && !mask[f * J + j]) { /* not limited here: the unwrapping starts again at the
                                           next frame that is */
            *prev = (prev_angle){NAN, 0, {1, 0, 0, 0}, NULL};
            continue;
        }
        if (pre && inside[f - f0]) { /* unchanged, and so are the frames after it up to the
                                        next one not inside */
            while (inside[f + 1 - f0])
                f++;
            if (hinge)
                prev->pending = 2, prev->rr = (mlr_quat){0, hy[f - f0], hx[f - f0], 0};
            else if (b->bl > 0)
                prev->pending = 3, prev->qp = &rot[f * J + j];
            continue;
        }
        if (limit_joint(g, b, &rot[f * J + j], prev) && counts)
            counts[j]++;
    }
}

void limits__apply_kind_masked(const mlr_limits *lim, size_t n_frames, mlr_quat *rot,
                               const double *alpha, size_t n_alpha, size_t *counts, int kind,
                               const uint8_t *mask, const int32_t *joints, size_t n_joints,
                               int hard)
{
    const size_t J = lim->n_joints, n_look = joints ? n_joints : J;
    const double *aj = alpha ? (n_alpha == 1 ? alpha : alpha + 1) : NULL;
    const size_t stride = n_alpha == 1 ? 0 : 1;
    /* each joint along the frames with its own unwrapping state, as if joint by joint; by
       blocks of APPLY_FB frames, the joints of a block one after the other within them (so the
       frames are read in order) */
    enum { BLOCK = 32 };
    size_t js[BLOCK];
    prev_angle prev[BLOCK];
    joint_bounds b[BLOCK];
    for (size_t l0 = 0; l0 < n_look;) {
        size_t m = 0;
        for (; l0 < n_look && m < BLOCK; l0++) {
            const size_t j0 = joints ? (size_t)joints[l0] : l0;
            const mlr_limits_joint *lj = &lim->joints[j0];
            if (lj->range.kind != kind)
                continue;
            if (mask && !any_limited(mask + j0, J, n_frames)) /* nothing to limit: left out */
                continue;
            const double a = aj ? aj[stride * j0] : 1.0;
            js[m] = j0;
            prev[m] = (prev_angle){NAN, 0, {1, 0, 0, 0}, NULL};
            b[m] = bounds_of(lim, lj, a, hard);
            m++;
        }
        for (size_t f0 = 0; f0 < n_frames; f0 += APPLY_FB) {
            const size_t nf = n_frames - f0 < APPLY_FB ? n_frames - f0 : APPLY_FB;
            for (size_t i = 0; i < m; i++)
                limit_block(lim, js[i], &b[i], &prev[i], rot, f0, nf, mask, counts);
        }
    }
}

/* The joints that limits__apply_normalized limits in one go (more: kind by kind). */
#define FUSED_JOINTS 64

mlr_status limits__apply_normalized(const mlr_limits *lim, size_t n_frames, const double *rot_in,
                                    double *rot_out, const double *alpha, size_t n_alpha,
                                    size_t *counts)
{
    const size_t J = lim->n_joints;
    mlr_quat *q = (mlr_quat *)rot_out;
    if (J > FUSED_JOINTS) {
        if (quat__unit_array((const mlr_quat *)rot_in, J * n_frames, q) != MLR_OK)
            return MLR_E_INVALID_ARG;
        for (int kind = MLR_LIMITS_HINGE; kind <= MLR_LIMITS_SWING_TWIST; kind++)
            limits__apply_kind(lim, n_frames, q, alpha, n_alpha, counts, kind);
        return MLR_OK;
    }
    /* by blocks of APPLY_FB frames: the block normalized, then each limited joint along it
       with its own state (the hinges, then the swing-twist joints: what the kinds one after
       the other give, each joint's frames in order), while the block is in cache */
    const double *aj = alpha ? (n_alpha == 1 ? alpha : alpha + 1) : NULL;
    const size_t stride = n_alpha == 1 ? 0 : 1;
    size_t js[FUSED_JOINTS], m = 0;
    prev_angle prev[FUSED_JOINTS];
    joint_bounds b[FUSED_JOINTS];
    for (int kind = MLR_LIMITS_HINGE; kind <= MLR_LIMITS_SWING_TWIST; kind++)
        for (size_t j = 0; j < J; j++) {
            const mlr_limits_joint *lj = &lim->joints[j];
            if (lj->range.kind != kind)
                continue;
            js[m] = j;
            prev[m] = (prev_angle){NAN, 0, {1, 0, 0, 0}, NULL};
            b[m] = bounds_of(lim, lj, aj ? aj[stride * j] : 1.0, 0);
            m++;
        }
    for (size_t f0 = 0; f0 < n_frames; f0 += APPLY_FB) {
        const size_t nf = n_frames - f0 < APPLY_FB ? n_frames - f0 : APPLY_FB;
        if (quat__unit_array((const mlr_quat *)rot_in + J * f0, J * nf, q + J * f0) != MLR_OK)
            return MLR_E_INVALID_ARG;
        for (size_t i = 0; i < m; i++)
            limit_block(lim, js[i], &b[i], &prev[i], q, f0, nf, NULL, counts);
    }
    return MLR_OK;
}

mlr_status limits__rot_error(const mlr_limits *lim, size_t n_frames, const double *rot,
                             mlr_diag *diag)
{
    const size_t J = lim->n_joints, nq = J * n_frames, bad = first_bad_quat(rot, nq);
    if (bad == nq)
        return MLR_OK;
    return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "limits: rot_in[%zu][%zu] is %s",
                            bad / J, bad % J, quat_finite(rot + 4 * bad) ? "zero" : "not finite");
}

mlr_status mlr_limits_apply(const mlr_limits *lim, size_t n_frames, const double *rot_in,
                            double *rot_out, const double *alpha, size_t n_alpha, size_t *counts,
                            size_t n_counts, mlr_diag *diag)
{
    if (!lim)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "limits: limits is NULL");
    const size_t J = lim->n_joints;
    if (n_frames > 0 && (!rot_in || !rot_out))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "limits: rot_%s is NULL",
                                rot_in ? "out" : "in");
    if (!(n_alpha == 0 && !alpha) && !(alpha && (n_alpha == 1 || n_alpha == 1 + J)))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "limits: alpha must have 1 or 1 + J = %zu values, got %zu", 1 + J,
                                alpha ? n_alpha : 0);
    for (size_t i = 0; i < n_alpha; i++)
        if (!isfinite(alpha[i]))
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    "limits: alpha[%zu] is not finite", i);
    if (counts && n_counts != J)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "limits: counts must have J = %zu values, got %zu", J, n_counts);
    if (counts)
        memset(counts, 0, J * sizeof *counts);
    mlr_status st = limits__rot_error(lim, n_frames, rot_in, diag);
    if (st != MLR_OK)
        return st;
    const size_t nq = J * n_frames;
    mlr_quat *q = (mlr_quat *)rot_out;
    const uintptr_t in_at = (uintptr_t)rot_in, out_at = (uintptr_t)rot_out,
                    bytes = 4 * nq * sizeof(double);
    const int apart = out_at + bytes <= in_at || in_at + bytes <= out_at;
    if (rot_out != rot_in && !apart) /* overlapping arrays: in place */
        memmove(rot_out, rot_in, 4 * nq * sizeof(double));
    (void)quat__unit_array(apart ? (const mlr_quat *)rot_in : q, nq, q);
    /* joint by joint, so that hinge angles are unwrapped along the frames */
    for (int kind = MLR_LIMITS_HINGE; kind <= MLR_LIMITS_SWING_TWIST; kind++)
        limits__apply_kind(lim, n_frames, q, alpha, n_alpha, counts, kind);
    return MLR_OK;
}
