/*
 * Left/right mirroring: joint pairs by name, the mirror plane, the reflected motion. The rules
 * and formulas are in include/mlayer/mlr_mirror.h.
 */
#include "common/mlr_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "motion/mirror_internal.h"
#include "mlayer/mlr_mirror.h"

/* ---- names --------------------------------------------------------------------------------- */

static int is_sep(char c)
{
    return c == '_' || c == '.' || c == '-' || c == ':' || c == '|' || c == ' ';
}

static int is_upper(char c) { return c >= 'A' && c <= 'Z'; }
static int is_lower(char c) { return c >= 'a' && c <= 'z'; }
static char lower(char c) { return is_upper(c) ? (char)(c - 'A' + 'a') : c; }

/* "left" (4) or "right" (5) at s, ASCII case-insensitively: its length, or 0. */
static size_t side_word_at(const char *s, int *side)
{
    static const char *const words[2] = {"left", "right"};
    for (int w = 0; w < 2; w++) {
        size_t n = 0;
        while (words[w][n] && lower(s[n]) == words[w][n])
            n++;
        if (!words[w][n]) {
            *side = w == 0 ? 1 : -1;
            return n;
        }
    }
    return 0;
}

/* The other side's word in the case of the matched one (all upper, first upper, lower). */
static size_t put_other_word(const char *matched, size_t n, char *out)
{
    const char *other = n == 4 ? "right" : "left";
    const size_t m = n == 4 ? 5 : 4;
    int all_upper = 1;
    for (size_t i = 0; i < n; i++)
        all_upper &= is_upper(matched[i]);
    for (size_t i = 0; i < m; i++) {
        const int up = all_upper || (i == 0 && is_upper(matched[0]));
        out[i] = up ? (char)(other[i] - 'a' + 'A') : other[i];
    }
    return m;
}

/* Whether the letter at name[i] is an L/R token of rule 2, 3 or 4 (mlr_mirror.h). */
static int letter_token(const char *name, size_t i, int rule)
{
    const char c = name[i];
    if (c != 'L' && c != 'R' && c != 'l' && c != 'r')
        return 0;
    if (i > 0 && !is_sep(name[i - 1]))
        return 0;
    const char after = name[i + 1];
    if (rule == 2)
        return after == '\0' || is_sep(after);
    if (rule == 3)
        return is_upper(after);
    return (c == 'l' || c == 'r') && is_lower(after);
}

int mirror__next_candidate(const char *name, size_t len, mlr_mirror_cursor *cur, char *buf,
                           int *side)
{
    if (cur->rule == 0) {
        cur->rule = 2, cur->pos = 0;
        size_t o = 0;
        int found = 0, s = 0;
        for (size_t i = 0; i < len;) {
            int si;
            const size_t n = side_word_at(name + i, &si);
            if (n) {
                if (!found)
                    s = si;
                found = 1;
                o += put_other_word(name + i, n, buf + o);
                i += n;
            } else {
                buf[o++] = name[i++];
            }
        }
        buf[o] = '\0';
        if (found) {
            *side = s;
            return 1;
        }
    }
    while (cur->rule <= 4) {
        for (; cur->pos < len; cur->pos++) {
            const size_t i = cur->pos;
            if (!letter_token(name, i, cur->rule))
                continue;
            memcpy(buf, name, len + 1);
            const char c = name[i];
            buf[i] = c == 'L' ? 'R' : c == 'R' ? 'L' : c == 'l' ? 'r' : 'l';
            *side = (c == 'L' || c == 'l') ? 1 : -1;
            cur->pos++;
            return 1;
        }
        cur->rule++, cur->pos = 0;
    }
    return 0;
}

/* Joints sorted by name, for lookups (qsort has no user pointer: (name, index) records). */
typedef struct name_rec {
    const char *name;
    int32_t j;
} name_rec;

static int rec_cmp(const void *a, const void *b)
{
    const name_rec *x = a, *y = b;
    const int c = strcmp(x->name, y->name);
    return c ? c : (x->j > y->j) - (x->j < y->j);
}

/* The first joint named key, or -1. */
static int32_t find_name(const name_rec *recs, size_t n, const char *key)
{
    size_t lo = 0, hi = n;
    while (lo < hi) {
        const size_t mid = lo + (hi - lo) / 2;
        if (strcmp(recs[mid].name, key) < 0)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo < n && strcmp(recs[lo].name, key) == 0 ? recs[lo].j : -1;
}

/* ---- checks ------------------------------------------------------------------------------- */

static const char *jname(const mlr_rig *rig, size_t j, char *buf, size_t cap)
{
    if (rig->names && rig->names[j])
        return rig->names[j];
    snprintf(buf, cap, "joint %zu", j);
    return buf;
}

/* The End Site that mirrors End Site e: the same rank among the End Sites of the partner of
 * its joint as e among those of its joint; -1 when the partner has too few. */
static long mirror_end_site(const mlr_rig *rig, const int32_t *partner, size_t e)
{
    const int32_t j = rig->end_site_parents[e], k = partner[j];
    size_t rank = 0;
    for (size_t i = 0; i < e; i++)
        rank += rig->end_site_parents[i] == j;
    for (size_t i = 0; i < rig->n_end_sites; i++)
        if (rig->end_site_parents[i] == k && rank-- == 0)
            return (long)i;
    return -1;
}

mlr_status mirror__check_partner(const mlr_rig *rig, const int32_t *partner, mlr_diag *diag)
{
    const size_t J = rig->n_joints;
    char b1[32], b2[32], b3[32], b4[32];
    for (size_t j = 0; j < J; j++) {
        const int32_t k = partner[j];
        if (k < 0 || (size_t)k >= J || partner[k] != (int32_t)j)
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    "mirror: partner[%zu] = %d is "
                                    "not a joint whose partner is %zu",
                                    j, (int)k, j);
    }
    if (partner[0] != 0)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "mirror: the root %.40s cannot be "
                                "paired (with %.40s)",
                                jname(rig, 0, b1, sizeof b1),
                                jname(rig, (size_t)partner[0], b2, sizeof b2));
    for (size_t j = 1; j < J; j++) {
        const int32_t k = partner[j], p = rig->parents[j];
        if (k == (int32_t)j && partner[p] != p) /* a one-sided joint: a prop in one hand */
            return common__diag_set(
                diag, MLR_E_INVALID_ARG, 0, 0,
                "mirror: %.30s has no partner but hangs under %.30s, which has one "
                "(%.30s): a mirror needs a partner for it there",
                jname(rig, j, b1, sizeof b1), jname(rig, (size_t)p, b2, sizeof b2),
                jname(rig, (size_t)partner[p], b3, sizeof b3));
        if (rig->parents[k] != partner[p])
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    "mirror: %.30s pairs with %.30s, "
                                    "but their parents %.30s and %.30s are not partners",
                                    jname(rig, j, b1, sizeof b1),
                                    jname(rig, (size_t)k, b2, sizeof b2),
                                    jname(rig, (size_t)p, b3, sizeof b3),
                                    jname(rig, (size_t)rig->parents[k], b4, sizeof b4));
        if ((mirror__rig_trans_row(rig, (int32_t)j) < 0) != (mirror__rig_trans_row(rig, k) < 0))
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    "mirror: %.40s pairs with %.40s, "
                                    "but only one of them has position channels",
                                    jname(rig, j, b1, sizeof b1),
                                    jname(rig, (size_t)k, b2, sizeof b2));
    }
    for (size_t e = 0; e < rig->n_end_sites; e++)
        if (mirror_end_site(rig, partner, e) < 0) {
            const size_t j = (size_t)rig->end_site_parents[e];
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    "mirror: %.40s pairs with %.40s, "
                                    "but they have different numbers of End Sites",
                                    jname(rig, j, b1, sizeof b1),
                                    jname(rig, (size_t)partner[j], b2, sizeof b2));
        }
    return MLR_OK;
}

/* ---- pairs -------------------------------------------------------------------------------- */

/* The side of a in the pair (a, b) by the rule that turns a into b: +1, -1 or 0. */
static int pair_side(const char *a, const char *b, char *buf)
{
    mlr_mirror_cursor cur = {0, 0};
    int side;
    const size_t len = strlen(a);
    while (mirror__next_candidate(a, len, &cur, buf, &side))
        if (strcmp(buf, b) == 0)
            return side;
    return 0;
}

static mlr_status given_pairs(const mlr_rig *rig, const name_rec *recs, const char *const *given,
                              size_t n_given, int32_t *partner, size_t *n_pairs, mlr_diag *diag)
{
    const size_t J = rig->n_joints;
    for (size_t g = 0; g < n_given; g++) {
        int32_t jk[2];
        for (int i = 0; i < 2; i++) {
            const char *s = given[2 * g + (size_t)i];
            if (!s)
                return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                        "mirror: pairs[%zu] has a "
                                        "NULL name",
                                        g);
            jk[i] = find_name(recs, J, s);
            if (jk[i] < 0)
                return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                        "mirror: pairs: no joint "
                                        "named '%.80s'",
                                        s);
        }
        if (jk[0] == jk[1])
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    "mirror: pairs: '%.80s' is "
                                    "paired with itself",
                                    given[2 * g]);
        for (int i = 0; i < 2; i++)
            if (partner[jk[i]] != jk[i])
                return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                        "mirror: pairs: '%.80s' is "
                                        "in two pairs",
                                        rig->names[jk[i]]);
        partner[jk[0]] = jk[1];
        partner[jk[1]] = jk[0];
        ++*n_pairs;
    }
    return MLR_OK;
}

mlr_status mirror__find_pairs(const mlr_rig *rig, const char *const *given, size_t n_given,
                              unsigned flags, int32_t *partner, int8_t *side, size_t *n_pairs,
                              const mlr_allocator *alloc, mlr_diag *diag)
{
    mlr_status st;
    if (flags & ~(unsigned)MLR_MIRROR_GIVEN_ONLY)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "mirror: unknown flags 0x%x for "
                                "pairs",
                                flags);
    if (n_given && !given)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "mirror: pairs is NULL with %zu "
                                "pairs",
                                n_given);
    const size_t J = rig->n_joints;
    const int by_name = !(flags & MLR_MIRROR_GIVEN_ONLY);
    if (!rig->names && (by_name || n_given))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "mirror: the rig has no joint "
                                "names to pair joints by");
    size_t longest = 0;
    for (size_t j = 0; j < J && rig->names; j++) {
        if (!rig->names[j])
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    "mirror: joint %zu has no "
                                    "name",
                                    j);
        const size_t n = strlen(rig->names[j]);
        longest = n > longest ? n : longest;
    }
    for (size_t j = 0; j < J; j++)
        partner[j] = (int32_t)j;
    size_t pairs = 0;
    if (rig->names) {
        mlr_allocator a;
        common__allocator_resolve(alloc, &a);
        size_t rec_bytes, buf_bytes;
        /* rule 1 turns "left" (4) into "right" (5): at most 5/4 of the length, + NUL */
        if (common__mul_size(J, sizeof(name_rec), &rec_bytes) != MLR_OK ||
            longest > (SIZE_MAX - 2) / 2)
            return common__diag_set(diag, MLR_E_OVERFLOW, 0, 0,
                                    "mirror: %zu joint names overflow "
                                    "the size",
                                    J);
        buf_bytes = 2 * longest + 2;
        name_rec *recs = common__alloc(&a, rec_bytes);
        char *buf = recs ? common__alloc(&a, buf_bytes) : NULL;
        if (!buf) {
            common__free(&a, recs, rec_bytes);
            return common__diag_set(diag, MLR_E_NO_MEMORY, 0, 0,
                                    "mirror: out of memory for the "
                                    "name index of %zu joints",
                                    J);
        }
        for (size_t j = 0; j < J; j++)
            recs[j] = (name_rec){rig->names[j], (int32_t)j};
        qsort(recs, J, sizeof *recs, rec_cmp);
        st = given_pairs(rig, recs, given, n_given, partner, &pairs, diag);
        for (size_t j = 0; st == MLR_OK && by_name && j < J; j++) {
            if (partner[j] != (int32_t)j)
                continue;
            const char *name = rig->names[j];
            const size_t len = strlen(name);
            mlr_mirror_cursor cur = {0, 0};
            int s;
            while (mirror__next_candidate(name, len, &cur, buf, &s)) {
                const int32_t k = find_name(recs, J, buf);
                if (k < 0 || k == (int32_t)j || partner[k] != k)
                    continue;
                partner[j] = k, partner[k] = (int32_t)j;
                pairs++;
                break;
            }
        }
        if (side && st == MLR_OK)
            for (size_t j = 0; j < J; j++)
                side[j] = partner[j] == (int32_t)j
                              ? 0
                              : (int8_t)pair_side(rig->names[j], rig->names[partner[j]], buf);
        common__free(&a, buf, buf_bytes);
        common__free(&a, recs, rec_bytes);
        if (st != MLR_OK)
            return st;
    } else if (side) {
        memset(side, 0, J);
    }
    *n_pairs = pairs;
    return MLR_OK;
}

mlr_status mlr_mirror_pairs(const mlr_rig *rig, const char *const *given, size_t n_given,
                            unsigned flags, int32_t *partner, int8_t *side, size_t *n_pairs,
                            const mlr_allocator *alloc, mlr_diag *diag)
{
    if (!partner)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "mirror: partner is NULL");
    mlr_status st = mlr_rig_check(rig, diag);
    if (st != MLR_OK)
        return st;
    size_t pairs = 0;
    st = mirror__find_pairs(rig, given, n_given, flags, partner, side, &pairs, alloc, diag);
    if (st == MLR_OK)
        st = mirror__check_partner(rig, partner, diag);
    if (st != MLR_OK)
        return st;
    if (n_pairs)
        *n_pairs = pairs;
    return MLR_OK;
}

/* ---- plane -------------------------------------------------------------------------------- */

void mirror__rest_position(const mlr_rig *rig, size_t j, double *out)
{
    out[0] = out[1] = out[2] = 0.0;
    for (size_t i = j; i != 0; i = (size_t)rig->parents[i])
        for (int c = 0; c < 3; c++)
            out[c] += rig->offsets[3 * i + (size_t)c];
}

mlr_status mlr_mirror_plane(const mlr_rig *rig, const int32_t *partner, int plane, int *axis,
                            mlr_diag *diag)
{
    if (!axis)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "mirror: axis is NULL");
    mlr_status st = mlr_rig_check(rig, diag);
    if (st != MLR_OK)
        return st;
    if (plane != MLR_MIRROR_PLANE_AUTO && (plane < MLR_AXIS_X || plane > MLR_AXIS_Z))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "mirror: plane %d is not -1 (auto), "
                                "0 (x), 1 (y) or 2 (z)",
                                plane);
    if (plane != MLR_MIRROR_PLANE_AUTO) {
        *axis = plane;
        return MLR_OK;
    }
    if (!partner)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "mirror: partner is NULL for the "
                                "auto plane");
    const size_t J = rig->n_joints;
    for (size_t j = 0; j < J; j++)
        if (partner[j] < 0 || (size_t)partner[j] >= J || partner[partner[j]] != (int32_t)j)
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    "mirror: partner[%zu] = %d is "
                                    "not a joint whose partner is %zu",
                                    j, (int)partner[j], j);
    double sum[3] = {0.0, 0.0, 0.0};
    size_t pairs = 0;
    for (size_t j = 0; j < J; j++) {
        if ((size_t)partner[j] <= j)
            continue;
        double a[3], b[3];
        mirror__rest_position(rig, j, a);
        mirror__rest_position(rig, (size_t)partner[j], b);
        for (int c = 0; c < 3; c++)
            sum[c] += fabs(a[c] - b[c]);
        pairs++;
    }
    if (pairs == 0)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "mirror: no left/right joint pairs "
                                "to find the plane from; give the plane (x, y or z) or the pairs");
    int best = 0;
    for (int c = 1; c < 3; c++)
        if (sum[c] > sum[best])
            best = c;
    if (!(sum[best] > 0.0))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "mirror: the %zu joint pairs have "
                                "the same rest positions; give the plane (x, y or z)",
                                pairs);
    *axis = best;
    return MLR_OK;
}

/* ---- motion ------------------------------------------------------------------------------- */

/* A translation (3) reflected across the plane normal to axis a. */
static inline void reflect3(const double *v, int a, double *o)
{
    o[0] = v[0], o[1] = v[1], o[2] = v[2];
    o[a] = -o[a];
}

/* M q M for the reflection normal to axis a: keep w and the a-component, negate the others. */
static inline void reflect4(const double *q, int a, double *o)
{
    o[0] = q[0];
    for (int c = 0; c < 3; c++)
        o[1 + c] = c == a ? q[1 + c] : -q[1 + c];
}

/* Rows j and k = partner(j) of a table of width w (3 or 4): out[j] = f(in[k]), out[k] = f(in[j])
 * with f the reflection; in place when out == in. */
static inline void swap_rows(const double *in, double *out, size_t j, size_t k, int w, int a)
{
    double x[4], y[4];
    memcpy(x, in + (size_t)w * j, (size_t)w * sizeof *x);
    memcpy(y, in + (size_t)w * k, (size_t)w * sizeof *y);
    if (w == 3) {
        reflect3(y, a, out + 3 * j);
        reflect3(x, a, out + 3 * k);
    } else {
        reflect4(y, a, out + 4 * j);
        reflect4(x, a, out + 4 * k);
    }
}

mlr_status mlr_mirror_motion(const mlr_rig *rig, const int32_t *partner, int axis, unsigned flags,
                             size_t n_frames, const double *root_pos, const double *rot,
                             const double *trans, double *out_root_pos, double *out_rot,
                             double *out_trans, double *out_offsets, double *out_end_site_offsets,
                             mlr_diag *diag)
{
    mlr_status st = mlr_rig_check(rig, diag);
    if (st != MLR_OK)
        return st;
    if (!partner)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "mirror: partner is NULL");
    if (axis < MLR_AXIS_X || axis > MLR_AXIS_Z)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "mirror: axis %d is not 0 (x), "
                                "1 (y) or 2 (z)",
                                axis);
    if (flags & ~(unsigned)MLR_MIRROR_KEEP_SKELETON)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "mirror: unknown flags 0x%x for "
                                "motion",
                                flags);
    const size_t N = n_frames, J = rig->n_joints, P = rig->n_trans, E = rig->n_end_sites;
    if (N && (!root_pos || !rot || !out_root_pos || !out_rot))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "mirror: root_pos, rot or their "
                                "outputs are NULL with %zu frames",
                                N);
    if (N && P && (!trans || !out_trans))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "mirror: trans or out_trans is NULL "
                                "with %zu translated joints",
                                P);
    st = mirror__check_partner(rig, partner, diag);
    if (st != MLR_OK)
        return st;
    if (flags & MLR_MIRROR_KEEP_SKELETON) {
        if (out_offsets && out_offsets != rig->offsets)
            memcpy(out_offsets, rig->offsets, 3 * J * sizeof(double));
        if (out_end_site_offsets && E && out_end_site_offsets != rig->end_site_offsets)
            memcpy(out_end_site_offsets, rig->end_site_offsets, 3 * E * sizeof(double));
    } else {
        for (size_t j = 0; out_offsets && j < J; j++)
            if ((size_t)partner[j] >= j)
                swap_rows(rig->offsets, out_offsets, j, (size_t)partner[j], 3, axis);
        for (size_t e = 0; out_end_site_offsets && e < E; e++) {
            const size_t f = (size_t)mirror_end_site(rig, partner, e);
            if (f >= e)
                swap_rows(rig->end_site_offsets, out_end_site_offsets, e, f, 3, axis);
        }
    }
    for (size_t n = 0; n < N; n++) {
        reflect3(root_pos + 3 * n, axis, out_root_pos + 3 * n);
        const double *r = rot + 4 * J * n;
        double *o = out_rot + 4 * J * n;
        for (size_t j = 0; j < J; j++)
            if ((size_t)partner[j] >= j)
                swap_rows(r, o, j, (size_t)partner[j], 4, axis);
        for (size_t p = 0; p < P; p++) {
            const size_t q = (size_t)mirror__rig_trans_row(rig, partner[rig->trans_joints[p]]);
            if (q >= p)
                swap_rows(trans + 3 * P * n, out_trans + 3 * P * n, p, q, 3, axis);
        }
    }
    return MLR_OK;
}
