/*
 * Rigs by reference: checks, point lookup by name, End Site positions, body height, the joint
 * that carries the body translation.
 */
#include "common/mlr_internal.h"

#include <math.h>
#include <stdlib.h>

/* Bytes of s that match pattern character c (lower-case ASCII) at s, 0 when none: ASCII
 * case-insensitively, and the non-ASCII letters Python's re.IGNORECASE folds to i, s and k. */
static size_t match_char(const unsigned char *s, char c)
{
    unsigned char b = s[0];
    if (b >= 'A' && b <= 'Z')
        b = (unsigned char)(b - 'A' + 'a');
    if (b == (unsigned char)c)
        return 1;
    if (c == 'i' && s[0] == 0xC4 && (s[1] == 0xB0 || s[1] == 0xB1))  /* U+0130, U+0131 */
        return 2;
    if (c == 's' && s[0] == 0xC5 && s[1] == 0xBF)  /* U+017F long s */
        return 2;
    if (c == 'k' && s[0] == 0xE2 && s[1] == 0x84 && s[2] == 0xAA)  /* U+212A Kelvin sign */
        return 3;
    return 0;
}

/* mlr_internal.h */
int common__name_matches(const char *name, const char *const *patterns)
{
    if (!name)
        return 0;
    for (const unsigned char *start = (const unsigned char *)name; *start; start++)
        for (const char *const *p = patterns; *p; p++) {
            const unsigned char *s = start;
            const char *c = *p;
            size_t n;
            while (*c && (n = match_char(s, *c)) != 0)
                s += n, c++;
            if (!*c)
                return 1;
        }
    return 0;
}

mlr_status mlr_rig_check(const mlr_rig *rig, mlr_diag *diag)
{
    if (!rig)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "rig is NULL");
    const size_t J = rig->n_joints;
    if (J == 0 || !rig->parents || !rig->offsets)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "rig: needs at least one joint, parents and offsets");
    if (rig->parents[0] != -1)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "rig: parents[0] must be -1, got %d", (int)rig->parents[0]);
    for (size_t j = 1; j < J; j++)
        if (rig->parents[j] < 0 || (size_t)rig->parents[j] >= j)
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    "rig: parents[%zu] = %d is not a joint before it", j,
                                    (int)rig->parents[j]);
    for (size_t k = 0; k < 3 * J; k++)
        if (!isfinite(rig->offsets[k]))
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    "rig: offset of joint %zu is not finite", k / 3);
    if (rig->n_trans && !rig->trans_joints)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "rig: trans_joints is NULL");
    for (size_t p = 0; p < rig->n_trans; p++) {
        int32_t t = rig->trans_joints[p];
        if (t < 1 || (size_t)t >= J || (p > 0 && t <= rig->trans_joints[p - 1]))
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    "rig: trans_joints must be strictly increasing in [1, %zu)",
                                    J);
    }
    if (rig->n_end_sites && (!rig->end_site_parents || !rig->end_site_offsets))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "rig: End Site arrays are NULL for %zu End Sites",
                                rig->n_end_sites);
    for (size_t e = 0; e < rig->n_end_sites; e++) {
        int32_t p = rig->end_site_parents[e];
        if (p < 0 || (size_t)p >= J)
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    "rig: End Site %zu has parent %d outside [0, %zu)", e, (int)p,
                                    J);
        for (int k = 0; k < 3; k++)
            if (!isfinite(rig->end_site_offsets[3 * e + (size_t)k]))
                return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                        "rig: offset of End Site %zu is not finite", e);
    }
    return MLR_OK;
}

mlr_status mlr_rig_find_point(const mlr_rig *rig, const char *name, int32_t *joint,
                              int32_t *end_site, mlr_diag *diag)
{
    if (!rig || !name || !joint || !end_site)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "find_point: NULL argument");
    if (!rig->names)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "find_point: the rig has no joint names (looking for '%.80s')",
                                name);
    const size_t len = strlen(name), suffix = sizeof MLR_RIG_END_SUFFIX - 1;
    const int end = len > suffix && strcmp(name + len - suffix, MLR_RIG_END_SUFFIX) == 0;
    for (int pass = 0; pass < 2; pass++) {
        /* A joint whose own name ends in "/End" wins over the End Site reading. */
        const int want_end = pass == 1;
        if (want_end && !end)
            break;
        const size_t n = want_end ? len - suffix : len;
        for (size_t j = 0; j < rig->n_joints; j++) {
            const char *s = rig->names[j];
            if (!s || strlen(s) != n || strncmp(s, name, n) != 0)
                continue;
            if (!want_end) {
                *joint = (int32_t)j;
                *end_site = -1;
                return MLR_OK;
            }
            for (size_t e = 0; e < rig->n_end_sites; e++)
                if (rig->end_site_parents[e] == (int32_t)j) {
                    *joint = (int32_t)j;
                    *end_site = (int32_t)e;
                    return MLR_OK;
                }
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "joint '%.80s' has no End Site",
                                    s);
        }
    }
    return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                            "no joint named '%.80s' ('Joint/End' names a joint's End Site)", name);
}

mlr_status mlr_rig_point_positions(const mlr_rig *rig, size_t n_frames, const double *world_pos,
                                   const double *world_rot, size_t n_points, const int32_t *joints,
                                   const int32_t *end_sites, double *out, mlr_diag *diag)
{
    if (!rig || (n_frames && n_points && (!world_pos || !joints || !out)))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "point_positions: NULL argument");
    const size_t J = rig->n_joints;
    for (size_t c = 0; c < n_points; c++) {
        if (joints[c] < 0 || (size_t)joints[c] >= J)
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    "point %zu: joint %d outside [0, %zu)", c, (int)joints[c], J);
        int32_t e = end_sites ? end_sites[c] : -1;
        if (e < -1 ||
            (e >= 0 && ((size_t)e >= rig->n_end_sites || rig->end_site_parents[e] != joints[c])))
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    "point %zu: End Site %d is not below joint %d", c, (int)e,
                                    (int)joints[c]);
        if (e >= 0 && !world_rot)
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    "point %zu is an End Site: world_rot is needed", c);
    }
    for (size_t f = 0; f < n_frames; f++)
        for (size_t c = 0; c < n_points; c++) {
            const size_t j = (size_t)joints[c];
            const double *p = world_pos + 3 * (f * J + j);
            double *o = out + 3 * (f * n_points + c);
            int32_t e = end_sites ? end_sites[c] : -1;
            if (e < 0) {
                o[0] = p[0], o[1] = p[1], o[2] = p[2];
                continue;
            }
            const double *q = world_rot + 4 * (f * J + j);
            const mlr_quat qq = {q[0], q[1], q[2], q[3]};
            const double *v = rig->end_site_offsets + 3 * (size_t)e;
            double r[3];
            common__quat_rotate_inline(&qq, v, r);
            o[0] = p[0] + r[0], o[1] = p[1] + r[1], o[2] = p[2] + r[2];
        }
    return MLR_OK;
}

/* The frames of a block of up_range_block. */
#define RANGE_BLOCK 64

/* The lowest and highest of the m <= RANGE_BLOCK frames' J values p[3 (f J + j)] (frames by
 * lanes, joints one after the other: the same min and max as a scan); 0 when one is not
 * finite. Vectorized. */
MLR_CLONES("avx2")
static int up_range_block(const double *restrict p, size_t J, size_t m, double *restrict lo,
                          double *restrict hi)
{
    double chk[RANGE_BLOCK];
    for (size_t f = 0; f < m; f++)
        lo[f] = hi[f] = p[3 * f * J], chk[f] = 0.0;
    for (size_t j = 0; j < J; j++)
        for (size_t f = 0; f < m; f++) {
            const double y = p[3 * (f * J + j)];
            chk[f] += y * 0.0; /* NaN for a NaN or an infinity, 0 otherwise */
            lo[f] = y < lo[f] ? y : lo[f];
            hi[f] = y > hi[f] ? y : hi[f];
        }
    int ok = 1;
    for (size_t f = 0; f < m; f++)
        ok &= chk[f] == 0.0;
    return ok;
}

size_t common__rig_up_range(size_t n_frames, size_t n_joints, const double *world_pos, int up,
                            double *lo, double *hi)
{
    for (size_t f0 = 0; f0 < n_frames; f0 += RANGE_BLOCK) {
        const size_t m = n_frames - f0 < RANGE_BLOCK ? n_frames - f0 : RANGE_BLOCK;
        double l[RANGE_BLOCK], h[RANGE_BLOCK];
        const int ok =
            up_range_block(world_pos + 3 * f0 * n_joints + (size_t)up, n_joints, m, l, h);
        if (lo)
            memcpy(lo + f0, l, m * sizeof *lo);
        if (hi)
            memcpy(hi + f0, h, m * sizeof *hi);
        if (ok)
            continue;
        for (size_t f = f0; f < f0 + m; f++) /* the first value not finite */
            for (size_t j = 0; j < n_joints; j++)
                if (!isfinite(world_pos[3 * (f * n_joints + j) + (size_t)up]))
                    return f * n_joints + j;
    }
    return n_frames * n_joints;
}

mlr_status mlr_rig_body_height(size_t n_frames, size_t n_joints, const double *world_pos, int up,
                               double *height, const mlr_allocator *alloc, mlr_diag *diag)
{
    if (!world_pos || !height)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "body_height: world_pos or height is "
                                "NULL");
    if (n_frames == 0 || n_joints == 0)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "body_height: needs at least one frame and one joint");
    if (up < MLR_AXIS_X || up > MLR_AXIS_Z)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "body_height: up axis %d is not "
                                "0 (X), 1 (Y) or 2 (Z)",
                                up);
    size_t bytes;
    if (common__mul_size(n_frames, 2 * sizeof(double), &bytes) != MLR_OK)
        return common__diag_set(diag, MLR_E_OVERFLOW, 0, 0,
                                "body_height: %zu frames of scratch overflow a size", n_frames);
    mlr_allocator a;
    common__allocator_resolve(alloc, &a);
    double *ext = common__alloc(&a, bytes),
           *lo = ext + n_frames; /* the highest, then the lowest */
    if (!ext)
        return common__diag_set(diag, MLR_E_NO_MEMORY, 0, 0, "body_height: out of memory");
    const size_t bad = common__rig_up_range(n_frames, n_joints, world_pos, up, lo, ext);
    if (bad < n_frames * n_joints) {
        common__free(&a, ext, bytes);
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "body_height: position of joint %zu at frame %zu is not finite",
                                bad % n_joints, bad / n_joints);
    }
    for (size_t f = 0; f < n_frames; f++)
        ext[f] -= lo[f];
    /* numpy's median: the mean of the two middle values for an even count */
    *height = common__median(ext, n_frames);
    common__free(&a, ext, bytes);
    return MLR_OK;
}

/* Rest-pose position of joint j (OFFSETs summed up the chain, the root at the origin). */
static void rest_position(const mlr_rig *rig, size_t j, double *p)
{
    p[0] = p[1] = p[2] = 0.0;
    for (size_t k = j; k != 0; k = (size_t)rig->parents[k])
        for (int c = 0; c < 3; c++)
            p[c] += rig->offsets[3 * k + (size_t)c];
}

/* Largest extent along an axis of the rest pose, joints and End Sites. */
static double rest_size(const mlr_rig *rig)
{
    double lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0}, p[3];
    const size_t J = rig->n_joints;
    for (size_t i = 0; i < J + rig->n_end_sites; i++) {
        if (i < J) {
            rest_position(rig, i, p);
        } else {
            const size_t e = i - J;
            rest_position(rig, (size_t)rig->end_site_parents[e], p);
            for (int c = 0; c < 3; c++)
                p[c] += rig->end_site_offsets[3 * e + (size_t)c];
        }
        for (int c = 0; c < 3; c++) {
            lo[c] = p[c] < lo[c] ? p[c] : lo[c];
            hi[c] = p[c] > hi[c] ? p[c] : hi[c];
        }
    }
    double size = 0.0;
    for (int c = 0; c < 3; c++)
        size = hi[c] - lo[c] > size ? hi[c] - lo[c] : size;
    return size;
}

/* Largest span over the frames of one coordinate of a translation (rows of stride ld). */
static double span(size_t n, const double *x, size_t ld)
{
    double best = 0.0;
    for (int c = 0; c < 3; c++) {
        double lo = x[c], hi = x[c];
        for (size_t f = 1; f < n; f++) {
            const double v = x[f * ld + (size_t)c];
            lo = v < lo ? v : lo;
            hi = v > hi ? v : hi;
        }
        best = hi - lo > best ? hi - lo : best;
    }
    return best;
}

mlr_status mlr_rig_body_translation_joint(const mlr_rig *rig, size_t n_frames,
                                          const double *root_pos, const double *trans,
                                          int32_t *joint, mlr_diag *diag)
{
    if (!joint)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "body_translation_joint: joint is NULL");
    *joint = 0;
    mlr_status st = mlr_rig_check(rig, diag);
    if (st != MLR_OK)
        return st;
    const size_t P = rig->n_trans;
    if (n_frames == 0)
        return MLR_OK;
    if (P > 0 && !trans)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "body_translation_joint: trans is NULL for %zu trans joints", P);
    double amax = 0.0;
    for (size_t f = 0; f < n_frames; f++)
        for (size_t k = 0; k < 3 * (1 + P); k++) {
            const double v =
                k < 3 ? (root_pos ? root_pos[3 * f + k] : 0.0) : trans[3 * P * f + k - 3];
            if (!isfinite(v))
                return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                        "body_translation_joint: %s translation at frame %zu is "
                                        "not finite",
                                        k < 3 ? "root" : "a trans joint's", f);
            amax = fabs(v) > amax ? fabs(v) : amax;
        }
    double size = rest_size(rig);
    if (!(size > 0.0))
        size = amax;
    const double tol = MLR_RIG_TRANSLATION_ROUNDING * size;
    if (root_pos && span(n_frames, root_pos, 3) > tol)
        return MLR_OK;
    size_t best_depth = SIZE_MAX;
    for (size_t p = 0; p < P; p++) {
        const size_t j = (size_t)rig->trans_joints[p];
        size_t depth = 0;
        for (size_t k = j; k != 0; k = (size_t)rig->parents[k])
            depth++;
        if (depth < best_depth && span(n_frames, trans + 3 * p, 3 * P) > tol) {
            best_depth = depth;
            *joint = (int32_t)j;
        }
    }
    return MLR_OK;
}
