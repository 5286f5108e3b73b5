/*
 * The feet of a rig found by joint name: ankles, toes (or End Sites), and hands that stay low;
 * where no name says foot, the leaf joints that stay on the ground.
 */
#include "guards/contacts_internal.h"
#include "common/mlr_internal.h"

#include <math.h>
#include <stdlib.h>

static const char *const foot_patterns[] = {"foot", "ankle", "paw", "hoof", NULL};
static const char *const toe_patterns[] = {"toe", "ball", NULL};
static const char *const hand_patterns[] = {"hand", "wrist", NULL};

int contacts__is_foot_name(const char *name)
{
    return name && common__name_matches(name, foot_patterns);
}

#define HAND_LOW 0.2       /* hands within this (body heights) of the feet's height are feet */
#define ZERO_LENGTH 1e-9   /* a joint this short is passed through on the way to a toe */

static double offset_length(const mlr_rig *rig, size_t j)
{
    const double *o = rig->offsets + 3 * j;
    return sqrt(o[0] * o[0] + o[1] * o[1] + o[2] * o[2]);
}

/* The toe of ankle a: (joint, -1), (a, End Site) or (-1, -1). */
static void find_toe(const mlr_rig *rig, int32_t a, int32_t *joint, int32_t *end_site)
{
    const size_t J = rig->n_joints;
    int32_t best = -1;
    double best_len = 0.0;
    for (int pass = 0; pass < 2 && best < 0; pass++)
        for (size_t k = (size_t)a + 1; k < J; k++) {
            if (!common__name_matches(rig->names[k], toe_patterns))
                continue;
            int32_t p = rig->parents[k];
            if (pass == 0 && p != a)
                continue;
            /* pass 1: a descendant reached only through zero-length joints */
            while (pass == 1 && p > a && offset_length(rig, (size_t)p) <= ZERO_LENGTH)
                p = rig->parents[p];
            if (p != a)
                continue;
            const double len = offset_length(rig, k);
            if (best < 0 || len > best_len)
                best = (int32_t)k, best_len = len;
        }
    *joint = best;
    *end_site = -1;
    if (best >= 0)
        return;
    for (size_t e = 0; e < rig->n_end_sites; e++)
        if (rig->end_site_parents[e] == a) {
            *joint = a;
            *end_site = (int32_t)e;
            return;
        }
}

/* Flags: 1 foot (ankle), 2 hand candidate, 4 a foot joint matched (for the topmost rule),
 * 8 a hand joint matched. */
enum { IS_ANKLE = 1, IS_HAND = 2, FOOT_NAME = 4, HAND_NAME = 8, FOOT_BELOW = 16, HAND_BELOW = 32 };

/* Adds the hands that stay low to the ankles (flags). */
static mlr_status low_hands(const mlr_rig *rig, size_t N, const double *world_pos, int up,
                            unsigned char *flags, size_t n_ankles, const mlr_allocator *a,
                            const double *height, mlr_diag *diag)
{
    const size_t J = rig->n_joints;
    double H = height ? *height : 0.0;
    mlr_status st = height ? MLR_OK : mlr_rig_body_height(N, J, world_pos, up, &H, a, diag);
    if (st != MLR_OK)
        return common__diag_prefix(diag, st, "find_feet");
    if (H == 0.0)
        H = 1.0;
    size_t count, bytes;
    if (common__mul_size(N, n_ankles + 2, &count) != MLR_OK ||
        common__mul_size(count, sizeof(double), &bytes) != MLR_OK)
        return common__diag_set(diag, MLR_E_OVERFLOW, 0, 0, "find_feet: too many frames");
    double *ground = common__alloc(a, bytes);
    if (!ground)
        return common__diag_set(diag, MLR_E_NO_MEMORY, 0, 0, "find_feet: out of memory");
    double *rel = ground + N, *tmp = rel + N * n_ankles;
    (void)common__rig_up_range(N, J, world_pos, up, ground, NULL); /* the ground of each frame */
    size_t i = 0;
    for (size_t f = 0; f < N; f++)
        for (size_t j = 0; j < J; j++)
            if (flags[j] & IS_ANKLE)
                rel[i++] = world_pos[3 * (f * J + j) + (size_t)up] - ground[f];
    const double foot_h = common__median(rel, i);
    for (size_t j = 0; j < J; j++) {
        if (!(flags[j] & IS_HAND))
            continue;
        for (size_t f = 0; f < N; f++)
            tmp[f] = world_pos[3 * (f * J + j) + (size_t)up] - ground[f];
        if (common__median(tmp, N) <= foot_h + HAND_LOW * H)
            flags[j] |= IS_ANKLE;
    }
    common__free(a, ground, bytes);
    return MLR_OK;
}

#define GEOM_LOW 0.1 /* a leaf within this (body heights) of the ground, in the median: a foot */

/* Feet by geometry, where no name says foot: the leaf joints (no child joint) whose median
   height above the ground of their frame (the lowest joint) is within GEOM_LOW body heights,
   at least three joints below the root; the ankle is the leaf's parent when that is low too
   (the leaf then its toe), else the leaf. Flags the ankles; returns how many. */
static size_t ground_leaves(const mlr_rig *rig, size_t N, const double *world_pos, int up,
                            unsigned char *flags, const mlr_allocator *a, const double *height,
                            mlr_status *st, mlr_diag *diag)
{
    const size_t J = rig->n_joints;
    double H = height ? *height : 0.0;
    *st = height ? MLR_OK : mlr_rig_body_height(N, J, world_pos, up, &H, a, diag);
    if (*st != MLR_OK || !(H > 0.0))
        return 0;
    size_t bytes;
    if (common__mul_size(2 * N + J, sizeof(double), &bytes) != MLR_OK) {
        *st = common__diag_set(diag, MLR_E_OVERFLOW, 0, 0, "find_feet: too many frames");
        return 0;
    }
    double *ground = common__alloc(a, bytes);
    if (!ground) {
        *st = common__diag_set(diag, MLR_E_NO_MEMORY, 0, 0, "find_feet: out of memory");
        return 0;
    }
    double *tmp = ground + N, *med = tmp + N;
    (void)common__rig_up_range(N, J, world_pos, up, ground, NULL);
    for (size_t j = 0; j < J; j++) {
        for (size_t f = 0; f < N; f++)
            tmp[f] = world_pos[3 * (f * J + j) + (size_t)up] - ground[f];
        med[j] = common__median(tmp, N);
    }
    size_t n = 0;
    for (size_t j = 0; j < J; j++) {
        int has_child = 0;
        for (size_t k = j + 1; k < J && !has_child; k++)
            has_child = rig->parents[k] == (int32_t)j;
        if (has_child || !(med[j] <= GEOM_LOW * H))
            continue;
        size_t depth = 0;
        for (int32_t u = rig->parents[j]; u >= 0; u = rig->parents[u])
            depth++;
        if (depth < 3)
            continue;
        const int32_t p = rig->parents[j];
        const size_t ankle = depth >= 4 && med[p] <= GEOM_LOW * H ? (size_t)p : j;
        if (!(flags[ankle] & IS_ANKLE))
            flags[ankle] |= IS_ANKLE, n++;
    }
    common__free(a, ground, bytes);
    return n;
}

mlr_status mlr_contacts_find_feet(const mlr_rig *rig, size_t n_frames, const double *world_pos,
                                  int up, size_t capacity, int32_t *joints, int32_t *end_sites,
                                  size_t *n_feet, const mlr_allocator *alloc, mlr_diag *diag)
{
    return contacts__find_feet(rig, n_frames, world_pos, up, capacity, joints, end_sites, n_feet,
                               alloc, NULL, diag);
}

mlr_status contacts__find_feet(const mlr_rig *rig, size_t n_frames, const double *world_pos,
                               int up, size_t capacity, int32_t *joints, int32_t *end_sites,
                               size_t *n_feet, const mlr_allocator *alloc, const double *height,
                               mlr_diag *diag)
{
    mlr_status st = mlr_rig_check(rig, diag);
    if (st != MLR_OK)
        return st;
    if (!n_feet || (capacity && (!joints || !end_sites)) || (n_frames && !world_pos))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "find_feet: NULL argument");
    *n_feet = 0;
    if (!rig->names)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "find_feet: the rig has no joint names");
    if (up < MLR_AXIS_X || up > MLR_AXIS_Z)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "find_feet: up axis %d is not 0 (X), 1 (Y) or 2 (Z)", up);
    const size_t J = rig->n_joints;
    mlr_allocator a;
    common__allocator_resolve(alloc, &a);
    unsigned char *flags = common__alloc(&a, J);
    if (!flags)
        return common__diag_set(diag, MLR_E_NO_MEMORY, 0, 0, "find_feet: out of memory");
    size_t n_ankles = 0, n_hands = 0;
    for (size_t j = 0; j < J; j++) {
        const int32_t p = rig->parents[j];
        unsigned char f = 0;
        if (p >= 0) {
            f |= (flags[p] & (FOOT_NAME | FOOT_BELOW)) ? FOOT_BELOW : 0;
            f |= (flags[p] & (HAND_NAME | HAND_BELOW)) ? HAND_BELOW : 0;
        }
        if (common__name_matches(rig->names[j], foot_patterns)) {
            f |= FOOT_NAME;
            if (!(f & FOOT_BELOW))
                f |= IS_ANKLE, n_ankles++;
        }
        if (common__name_matches(rig->names[j], hand_patterns)) {
            f |= HAND_NAME;
            if (!(f & HAND_BELOW) && !(f & IS_ANKLE))
                f |= IS_HAND, n_hands++;
        }
        flags[j] = f;
    }
    if (n_ankles == 0 && n_frames) { /* no name says foot: the leaves on the ground */
        n_ankles = ground_leaves(rig, n_frames, world_pos, up, flags, &a, height, &st, diag);
        if (st != MLR_OK) {
            common__free(&a, flags, J);
            return st;
        }
        n_hands = 0; /* (the low leaves are every foot there is) */
    }
    if (n_ankles == 0) {
        common__free(&a, flags, J);
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "no feet found: no joint name contains foot, ankle, paw or hoof "
                                "(case-insensitive; toes: toe or ball below a foot), and no leaf "
                                "joint stays on the ground; name the "
                                "contact points yourself ('Joint/End' names a joint's End Site)");
    }
    if (n_hands && n_frames) {
        st = low_hands(rig, n_frames, world_pos, up, flags, n_ankles, &a, height, diag);
        if (st != MLR_OK) {
            common__free(&a, flags, J);
            return st;
        }
    }
    size_t F = 0;
    for (size_t j = 0; j < J; j++)
        F += (flags[j] & IS_ANKLE) != 0;
    if (F > capacity) {
        common__free(&a, flags, J);
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "find_feet: %zu feet found, room for %zu", F, capacity);
    }
    size_t f = 0;
    for (size_t j = 0; j < J; j++) {
        if (!(flags[j] & IS_ANKLE))
            continue;
        joints[2 * f] = (int32_t)j;
        end_sites[2 * f] = -1;
        find_toe(rig, (int32_t)j, joints + 2 * f + 1, end_sites + 2 * f + 1);
        f++;
    }
    *n_feet = F;
    common__free(&a, flags, J);
    return MLR_OK;
}
