/*
 * Analytic two-bone IK (mlr_ik.h): the solver per frame, leg chains, local rotations.
 */
#include "guards/ik_internal.h"

#include <float.h>
#include <math.h>

#define IK_EPS 1e-12

static double norm3(const double a[3]) { return sqrt(common__dot3(a, a)); }

static void unit3(double a[3])
{
    const double n = norm3(a);
    if (n > IK_EPS)
        a[0] /= n, a[1] /= n, a[2] /= n;
}

/* The shortest arc from unit u to unit v, (1 + u.v, u x v) normalized; antiparallel: a half
   turn about an axis perpendicular to u. */
static void from_to_unit(double u[3], double v[3], double q[4])
{
    unit3(u);
    unit3(v);
    const double c = common__dot3(u, v);
    double axis[3];
    common__cross3(u, v, axis);
    q[0] = 1.0 + c, q[1] = axis[0], q[2] = axis[1], q[3] = axis[2];
    if (c < -1.0 + 1e-12) {
        const double ex[3] = {1.0, 0.0, 0.0}, ey[3] = {0.0, 1.0, 0.0};
        double perp[3];
        common__cross3(u, ex, perp);
        if (norm3(perp) < 1e-6)
            common__cross3(u, ey, perp);
        unit3(perp);
        q[0] = 0.0, q[1] = perp[0], q[2] = perp[1], q[3] = perp[2];
    }
    const double n = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    if (n < IK_EPS) {
        q[0] = 1.0, q[1] = q[2] = q[3] = 0.0;
        return;
    }
    q[0] /= n, q[1] /= n, q[2] /= n, q[3] /= n;
}

void ik__from_to_1(const double u_in[3], const double v_in[3], double q[4])
{
    double u[3] = {u_in[0], u_in[1], u_in[2]}, v[3] = {v_in[0], v_in[1], v_in[2]};
    const double nu = norm3(u), nv = norm3(v), p = nu * nv, d = common__dot3(u, v);
    if (!(nu > IK_EPS && nv > IK_EPS && p <= DBL_MAX) || !(d >= (-1.0 + 1e-12) * p)) {
        from_to_unit(u, v, q); /* a zero vector, antiparallel, too long, or not finite */
        return;
    }
    /* (1 + c, u' x v') for the unit u', v' is (|u| |v| + u.v, u x v) / (|u| |v|): normalized
       as it is, without the unit vectors' divisions */
    double axis[3];
    common__cross3(u, v, axis);
    q[0] = p + d, q[1] = axis[0], q[2] = axis[1], q[3] = axis[2];
    const double n = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    q[0] /= n, q[1] /= n, q[2] /= n, q[3] /= n;
}

void ik__two_bone_1(const double a[3], const double b[3], const double c[3], const double t[3],
                    const double *axis, double max_ext, double r_hip[4], double r_knee[4])
{
    double ab[3], bc[3], ac[3], at[3], mab[3];
    for (int k = 0; k < 3; k++) {
        ab[k] = b[k] - a[k], bc[k] = c[k] - b[k], ac[k] = c[k] - a[k], at[k] = t[k] - a[k];
        mab[k] = -ab[k];
    }
    const double l1 = norm3(ab), l2 = norm3(bc), d_now = norm3(ac);
    double d = norm3(at);
    const double hi = common__fmax(max_ext * (l1 + l2), d_now);
    d = common__fmin(d, hi);
    double n[3], bcu[3] = {bc[0], bc[1], bc[2]};
    if (axis)
        n[0] = axis[0], n[1] = axis[1], n[2] = axis[2];
    else
        common__cross3(bc, mab, n);
    if (l2 > IK_EPS) /* unit3(bcu), with the norm l2 already is */
        bcu[0] /= l2, bcu[1] /= l2, bcu[2] /= l2;
    const double p = common__dot3(n, bcu);
    for (int k = 0; k < 3; k++)
        n[k] -= p * bcu[k];
    const double small = 1e-9 * common__fmax(l1 * l2, IK_EPS);
    double nn = norm3(n);
    if (nn <= small) { /* hinge along the shin: the leg's own plane, or any axis */
        common__cross3(bc, mab, n);
        if ((nn = norm3(n)) <= small) {
            const double ex[3] = {1.0, 0.0, 0.0};
            common__cross3(bc, ex, n);
            nn = norm3(n);
        }
    }
    if (nn > IK_EPS) /* unit3(n), with its norm nn */
        n[0] /= nn, n[1] /= nn, n[2] /= nn;
    /* |ab + R(n, phi) bc|^2 = K + 2 (P cos phi + Q sin phi) = K + 2 A cos(phi - phi0) */
    double w[3];
    common__cross3(n, bc, w);
    const double K = l1 * l1 + l2 * l2, P = common__dot3(ab, bc), Q = common__dot3(ab, w);
    const double A = sqrt(P * P + Q * Q);
    double cosb = (d * d - K) / common__fmax(2.0 * A, IK_EPS);
    cosb = cosb < -1.0 ? -1.0 : cosb > 1.0 ? 1.0 : cosb;
    /* the forward-bent solution phi = phi0 + acos(cosb), phi0 = atan2(Q, P), as its cosine
       and sine (the angle sum) and the knee's half angle in [-pi/2, pi/2] from them (the
       half-angle formulas, each where it is well conditioned): no atan2, acos, sin or cos */
    const double c0 = A > 0.0 ? P / A : 1.0, s0 = A > 0.0 ? Q / A : 0.0;
    const double sb = sqrt((1.0 - cosb) * (1.0 + cosb));
    const double cp = c0 * cosb - s0 * sb, sp = s0 * cosb + c0 * sb;
    double ch, sh;
    if (cp >= 0.0) {
        ch = sqrt(0.5 * (1.0 + cp));
        sh = sp / (2.0 * ch);
    } else {
        sh = copysign(sqrt(0.5 * (1.0 - cp)), sp);
        ch = sp / (2.0 * sh);
    }
    r_knee[0] = ch, r_knee[1] = sh * n[0], r_knee[2] = sh * n[1], r_knee[3] = sh * n[2];
    double c1a[3];
    for (int k = 0; k < 3; k++)
        c1a[k] = b[k] + cp * bc[k] + sp * w[k] - a[k];
    ik__from_to_1(c1a, at, r_hip);
}

/* common__fmax and common__fmin (the same values) without control flow, for the vectorized loop. */
static inline double lane_max(double a, double b)
{
    return common__select_bits((a > b) | (b != b), a, b);
}
static inline double lane_min(double a, double b)
{
    return common__select_bits((a < b) | (b != b), a, b);
}

MLR_CLONES("avx2")
void ik__two_bone_lanes(mlr_ik_lanes *L, size_t m, int have_axis, double max_ext)
{
    if (!have_axis) /* the leg's own plane: bc x (a - b) */
        for (size_t i = 0; i < m; i++) {
            const double bc[3] = {L->c[0][i] - L->b[0][i], L->c[1][i] - L->b[1][i],
                                  L->c[2][i] - L->b[2][i]};
            const double mab[3] = {-(L->b[0][i] - L->a[0][i]), -(L->b[1][i] - L->a[1][i]),
                                   -(L->b[2][i] - L->a[2][i])};
            double n[3];
            common__cross3(bc, mab, n);
            L->axis[0][i] = n[0], L->axis[1][i] = n[1], L->axis[2][i] = n[2];
        }
    for (size_t i = 0; i < m; i++) {
        double ab[3], bc[3], ac[3], at[3];
        for (int k = 0; k < 3; k++) {
            ab[k] = L->b[k][i] - L->a[k][i], bc[k] = L->c[k][i] - L->b[k][i];
            ac[k] = L->c[k][i] - L->a[k][i], at[k] = L->t[k][i] - L->a[k][i];
        }
        const double l1 = norm3(ab), l2 = norm3(bc), d_now = norm3(ac);
        const double d = lane_min(norm3(at), lane_max(max_ext * (l1 + l2), d_now));
        double n[3] = {L->axis[0][i], L->axis[1][i], L->axis[2][i]}, bcu[3];
        const int by_l2 = l2 > IK_EPS;
        for (int k = 0; k < 3; k++)
            bcu[k] = common__select_bits(by_l2, bc[k] / l2, bc[k]);
        const double p = common__dot3(n, bcu);
        for (int k = 0; k < 3; k++)
            n[k] -= p * bcu[k];
        const double small = 1e-9 * lane_max(l1 * l2, IK_EPS);
        const double nn = norm3(n);
        const int by_nn = nn > IK_EPS;
        for (int k = 0; k < 3; k++)
            n[k] = common__select_bits(by_nn, n[k] / nn, n[k]);
        double w[3];
        common__cross3(n, bc, w);
        const double K = l1 * l1 + l2 * l2, P = common__dot3(ab, bc), Q = common__dot3(ab, w);
        const double A = sqrt(P * P + Q * Q);
        const double cosr = (d * d - K) / lane_max(2.0 * A, IK_EPS);
        const double cosb =
            common__select_bits(cosr < -1.0, -1.0, common__select_bits(cosr > 1.0, 1.0, cosr));
        const int pos_a = A > 0.0;
        const double c0 = common__select_bits(pos_a, P / A, 1.0),
                     s0 = common__select_bits(pos_a, Q / A, 0.0);
        const double sb = sqrt((1.0 - cosb) * (1.0 + cosb));
        const double cp = c0 * cosb - s0 * sb, sp = s0 * cosb + c0 * sb;
        const double ch1 = sqrt(0.5 * (1.0 + cp)), sh1 = sp / (2.0 * ch1);
        const double sh2 = copysign(sqrt(0.5 * (1.0 - cp)), sp), ch2 = sp / (2.0 * sh2);
        const int front = cp >= 0.0;
        const double ch = common__select_bits(front, ch1, ch2),
                     sh = common__select_bits(front, sh1, sh2);
        L->r_knee[0][i] = ch, L->r_knee[1][i] = sh * n[0], L->r_knee[2][i] = sh * n[1],
        L->r_knee[3][i] = sh * n[2];
        /* ik__from_to_1(b + cp bc + sp w - a, at) on its fast path */
        double u[3];
        for (int k = 0; k < 3; k++)
            u[k] = L->b[k][i] + cp * bc[k] + sp * w[k] - L->a[k][i];
        const double nu = norm3(u), nv = norm3(at), pq = nu * nv, du = common__dot3(u, at);
        double axis[3];
        common__cross3(u, at, axis);
        const double q0 = pq + du;
        const double qn =
            sqrt(q0 * q0 + axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]);
        L->r_hip[0][i] = q0 / qn, L->r_hip[1][i] = axis[0] / qn, L->r_hip[2][i] = axis[1] / qn,
        L->r_hip[3][i] = axis[2] / qn;
        L->slow[i] = (nn <= small) | !((nu > IK_EPS) & (nv > IK_EPS) & (pq <= DBL_MAX)) |
                     !(du >= (-1.0 + 1e-12) * pq);
    }
}

static int all_finite(const double *x, size_t count)
{
    for (size_t i = 0; i < count; i++)
        if (!isfinite(x[i]))
            return 0;
    return 1;
}

mlr_status mlr_ik_two_bone(size_t n, const double *hip, const double *knee, const double *end,
                           const double *target, const double *bend_axis, double max_extension,
                           double *r_hip, double *r_knee, mlr_diag *diag)
{
    if (n && (!hip || !knee || !end || !target || !r_hip || !r_knee))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "two_bone: NULL array");
    if (!(max_extension > 0.0 && max_extension <= 1.0))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "two_bone: max_extension %g outside (0, 1]", max_extension);
    const double *arrs[5] = {hip, knee, end, target, bend_axis};
    const char *names[5] = {"hip", "knee", "end", "target", "bend_axis"};
    for (int i = 0; i < 5; i++)
        if (arrs[i] && !all_finite(arrs[i], 3 * n))
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    "two_bone: %s contains NaN or infinite values", names[i]);
    /* by batches of MLR_IK_LANES frames (the same bits as frame by frame) */
    mlr_ik_lanes L;
    for (size_t f0 = 0; f0 < n; f0 += MLR_IK_LANES) {
        const size_t m = n - f0 < MLR_IK_LANES ? n - f0 : MLR_IK_LANES;
        for (size_t i = 0; i < m; i++)
            for (int k = 0; k < 3; k++) {
                const size_t q = 3 * (f0 + i) + (size_t)k;
                L.a[k][i] = hip[q], L.b[k][i] = knee[q], L.c[k][i] = end[q], L.t[k][i] = target[q];
                L.axis[k][i] = bend_axis ? bend_axis[q] : 0.0;
            }
        ik__two_bone_lanes(&L, m, bend_axis != NULL, max_extension);
        for (size_t i = 0; i < m; i++) {
            const size_t f = f0 + i;
            if (L.slow[i]) {
                ik__two_bone_1(hip + 3 * f, knee + 3 * f, end + 3 * f, target + 3 * f,
                               bend_axis ? bend_axis + 3 * f : NULL, max_extension, r_hip + 4 * f,
                               r_knee + 4 * f);
                continue;
            }
            for (int k = 0; k < 4; k++)
                r_hip[4 * f + (size_t)k] = L.r_hip[k][i],
                              r_knee[4 * f + (size_t)k] = L.r_knee[k][i];
        }
    }
    return MLR_OK;
}

mlr_status mlr_ik_from_to(size_t n, const double *u, const double *v, double *out)
{
    if (n && (!u || !v || !out))
        return MLR_E_INVALID_ARG;
    for (size_t f = 0; f < n; f++)
        ik__from_to_1(u + 3 * f, v + 3 * f, out + 4 * f);
    return MLR_OK;
}

static int32_t bone_parent(const mlr_rig *rig, int32_t j)
{
    int32_t c = j;
    while (c > 0 && norm3(rig->offsets + 3 * (size_t)c) <= 1e-9)
        c = rig->parents[c];
    return c > 0 ? rig->parents[c] : -1;
}

mlr_status mlr_ik_leg_chain(const mlr_rig *rig, int32_t end, int32_t *hip, int32_t *knee,
                            mlr_diag *diag)
{
    mlr_status st = mlr_rig_check(rig, diag);
    if (st != MLR_OK)
        return st;
    if (!hip || !knee)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "leg_chain: NULL output");
    if (end < 0 || (size_t)end >= rig->n_joints)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "leg_chain: joint %d outside [0, %zu)", (int)end, rig->n_joints);
    const int32_t k = bone_parent(rig, end);
    const int32_t h = k >= 0 ? bone_parent(rig, k) : -1;
    if (k < 0 || h < 0) {
        if (rig->names && rig->names[end])
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    "joint '%.60s' has no two-bone chain above it (needs two "
                                    "ancestors at non-zero distances: a hip and a knee)",
                                    rig->names[end]);
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "joint %d has no two-bone chain above it (needs two ancestors at "
                                "non-zero distances: a hip and a knee)",
                                (int)end);
    }
    *hip = h, *knee = k;
    return MLR_OK;
}

/* The frames of a block of bend_terms. */
#define BEND_BLOCK 64

/* The hip-local bend normals conj(G_hip) ((end - knee) x (hip - knee)) of m <= BEND_BLOCK
   frames (J joints each) into l (x, y, z by blocks of BEND_BLOCK). Vectorized. */
MLR_CLONES("avx2")
static void bend_terms(const double *restrict pos, const double *restrict wrot, size_t J,
                       size_t hip, size_t knee, size_t end, size_t m, double *restrict l)
{
    for (size_t i = 0; i < m; i++) {
        const double *ph = pos + 3 * (i * J + hip), *pk = pos + 3 * (i * J + knee),
                     *pe = pos + 3 * (i * J + end), *g = wrot + 4 * (i * J + hip);
        double ek[3], hk[3], c[3], o[3];
        for (int k = 0; k < 3; k++)
            ek[k] = pe[k] - pk[k], hk[k] = ph[k] - pk[k];
        common__cross3(ek, hk, c);
        const double cg[4] = {g[0], -g[1], -g[2], -g[3]};
        ik__qrot(cg, c, o);
        l[i] = o[0], l[BEND_BLOCK + i] = o[1], l[2 * BEND_BLOCK + i] = o[2];
    }
}

mlr_status mlr_ik_bend_axis_local(size_t n, size_t J, const double *pos, const double *wrot,
                                  int32_t hip, int32_t knee, int32_t end, double axis[3],
                                  mlr_diag *diag)
{
    if (!axis || (n && (!pos || !wrot)))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "bend_axis_local: %s is NULL",
                                !axis  ? "axis"
                                : !pos ? "world_pos"
                                       : "world_rot");
    const int32_t joint[3] = {hip, knee, end};
    static const char *const role[3] = {"hip", "knee", "end"};
    for (int r = 0; r < 3; r++)
        if (joint[r] < 0 || (size_t)joint[r] >= J)
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    "bend_axis_local: %s joint %d outside [0, %zu)", role[r],
                                    (int)joint[r], J);
    /* each frame's term by blocks (vectorized), summed in frame order */
    double s[3] = {0.0, 0.0, 0.0}, l[3 * BEND_BLOCK];
    for (size_t f0 = 0; f0 < n; f0 += BEND_BLOCK) {
        const size_t m = n - f0 < BEND_BLOCK ? n - f0 : BEND_BLOCK;
        bend_terms(pos + 3 * f0 * J, wrot + 4 * f0 * J, J, (size_t)hip, (size_t)knee, (size_t)end,
                   m, l);
        for (size_t i = 0; i < m; i++)
            s[0] += l[i], s[1] += l[BEND_BLOCK + i], s[2] += l[2 * BEND_BLOCK + i];
    }
    const double ns = norm3(s);
    for (int k = 0; k < 3; k++)
        axis[k] = ns > IK_EPS ? s[k] / ns : 0.0;
    return MLR_OK;
}

static mlr_status check_joint(size_t J, const int32_t *parents, int32_t j, mlr_diag *diag)
{
    if (j < 0 || (size_t)j >= J)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "joint %d outside [0, %zu)", (int)j,
                                J);
    if ((j == 0 && parents[0] != -1) || (j > 0 && (parents[j] < 0 || parents[j] >= j)))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "joint %d: bad parent %d", (int)j,
                                (int)parents[j]);
    return MLR_OK;
}

mlr_status mlr_ik_rotate_to(size_t n, size_t J, const int32_t *parents, double *rot,
                            const double *wrot, int32_t joint, const double *r_world,
                            mlr_diag *diag)
{
    if (!parents || (n && (!rot || !wrot || !r_world)))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "rotate_to: NULL array");
    mlr_status st = check_joint(J, parents, joint, diag);
    if (st != MLR_OK)
        return st;
    const int32_t p = parents[joint];
    for (size_t f = 0; f < n; f++)
        ik__rotate_to_1(rot + 4 * (f * J + (size_t)joint),
                        p >= 0 ? wrot + 4 * (f * J + (size_t)p) : NULL,
                        wrot + 4 * (f * J + (size_t)joint), r_world + 4 * f);
    return MLR_OK;
}

mlr_status mlr_ik_apply_leg(size_t n, size_t J, const int32_t *parents, double *rot,
                            const double *pos, const double *wrot, int32_t hip, int32_t knee,
                            int32_t end, const double *target, const double *bend_axis,
                            mlr_diag *diag)
{
    if (!parents || (n && (!rot || !pos || !wrot || !target)))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "apply_leg: NULL array");
    mlr_status st;
    if ((st = check_joint(J, parents, hip, diag)) != MLR_OK ||
        (st = check_joint(J, parents, knee, diag)) != MLR_OK ||
        (st = check_joint(J, parents, end, diag)) != MLR_OK)
        return st;
    if (!(hip < knee && knee < end))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "apply_leg: (%d, %d, %d) is not a hip, knee, end chain", (int)hip,
                                (int)knee, (int)end);
    if (!all_finite(target, 3 * n) || (bend_axis && !all_finite(bend_axis, 3 * n)))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "apply_leg: target or bend_axis contains NaN or infinite values");
    double local[3] = {0.0, 0.0, 0.0};
    int have_local = 0;
    if (!bend_axis) {
        mlr_ik_bend_axis_local(n, J, pos, wrot, hip, knee, end, local, NULL);
        have_local = local[0] != 0.0 || local[1] != 0.0 || local[2] != 0.0;
    }
    const size_t h = (size_t)hip, k = (size_t)knee, e = (size_t)end;
    const int32_t pk = parents[knee], ph = parents[hip];
    for (size_t f = 0; f < n; f++) {
        const double *P = pos + 3 * f * J, *G = wrot + 4 * f * J;
        double ax[3], rh[4], rk[4];
        const double *axp = bend_axis ? bend_axis + 3 * f : NULL;
        if (have_local) {
            ik__qrot(G + 4 * h, local, ax);
            axp = ax;
        }
        ik__two_bone_1(P + 3 * h, P + 3 * k, P + 3 * e, target + 3 * f, axp, MLR_IK_MAX_EXTENSION,
                       rh, rk);
        /* the knee's parent keeps its old world rotation here: the hip's delta turns knee and
           parent alike */
        ik__rotate_to_1(rot + 4 * (f * J + k), pk >= 0 ? G + 4 * (size_t)pk : NULL, G + 4 * k, rk);
        ik__rotate_to_1(rot + 4 * (f * J + h), ph >= 0 ? G + 4 * (size_t)ph : NULL, G + 4 * h, rh);
    }
    return MLR_OK;
}
