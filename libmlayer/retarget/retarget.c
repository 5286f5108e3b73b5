/*
 * Retargeting between humanoid rigs: the roles of each rig's joints, the rest-pose frames of
 * their bones, and the motion moved across. The rules and formulas are in
 * include/mlayer/mlr_retarget.h.
 */
#include "common/mlr_internal.h"

#include <math.h>
#include <string.h>

#include "guards/cleanup_internal.h"
#include "guards/floor_lift_internal.h"
#include "motion/mirror_internal.h"
#include "mlayer/mlr_cleanup.h"
#include "mlayer/mlr_contacts.h"
#include "mlayer/mlr_fk.h"
#include "mlayer/mlr_retarget.h"

/* ---- role names --------------------------------------------------------------------------- */

static const char *const fixed_names[MLR_ROLE_COUNT] = {
    "Hips",          "Spine0",        "Spine1",        "Spine2",        "Spine3",
    "Spine4",        "Spine5",        "Spine6",        "Spine7",        "Neck0",
    "Neck1",         "Neck2",         "Neck3",         "Head",          "LeftShoulder",
    "LeftUpperArm",  "LeftLowerArm",  "LeftHand",      "RightShoulder", "RightUpperArm",
    "RightLowerArm", "RightHand",     "LeftUpperLeg",  "LeftLowerLeg",  "LeftFoot",
    "LeftToes",      "RightUpperLeg", "RightLowerLeg", "RightFoot",     "RightToes"};

const char *mlr_role_name(int role)
{
    return role >= 0 && role < MLR_ROLE_COUNT ? fixed_names[role] : NULL;
}

/* ---- the tree ----------------------------------------------------------------------------- */

static size_t depth_of(const mlr_rig *rig, int32_t j)
{
    size_t d = 0;
    while (j > 0)
        j = rig->parents[j], d++;
    return d;
}

/* Whether a is j or one of its ancestors. */
static int is_ancestor(const mlr_rig *rig, int32_t a, int32_t j)
{
    for (; j >= 0; j = rig->parents[j])
        if (j == a)
            return 1;
    return 0;
}

static int32_t lca(const mlr_rig *rig, int32_t a, int32_t b)
{
    size_t da = depth_of(rig, a), db = depth_of(rig, b);
    while (da > db)
        a = rig->parents[a], da--;
    while (db > da)
        b = rig->parents[b], db--;
    while (a != b)
        a = rig->parents[a], b = rig->parents[b];
    return a;
}

static const char *const twist_words[] = {"twist", "roll", NULL};

/* The parent of j, twist and roll joints passed over; -1 at the root. */
static int32_t limb_parent(const mlr_rig *rig, int32_t j)
{
    int32_t p = j > 0 ? rig->parents[j] : -1;
    while (p > 0 && common__name_matches(rig->names[p], twist_words))
        p = rig->parents[p];
    return p;
}

/* The topmost joint (fewest ancestors, first in joint order among equals) of a side whose name
 * contains one of words (and none of the excluded words); -1 when there is none. */
static int32_t topmost(const mlr_rig *rig, const int8_t *side, int want_side,
                       const char *const *words, const char *const *not_words)
{
    int32_t best = -1;
    size_t best_depth = 0;
    for (size_t j = 0; j < rig->n_joints; j++) {
        if (side[j] != want_side || !common__name_matches(rig->names[j], words))
            continue;
        if (not_words && common__name_matches(rig->names[j], not_words))
            continue;
        const size_t d = depth_of(rig, (int32_t)j);
        if (best < 0 || d < best_depth)
            best = (int32_t)j, best_depth = d;
    }
    return best;
}

/* Fill role_joint[first .. first + max) from the path from `from` (excluded) down to `to`
 * (included when include_to): all of it when it fits, else max joints spread evenly along it
 * (the last one always kept). */
static void fill_chain(const mlr_rig *rig, int32_t from, int32_t to, int include_to,
                       int32_t *role_joint, int first, int max)
{
    int32_t path[64];
    size_t n = 0;
    int32_t j = include_to ? to : rig->parents[to];
    if (!include_to && to <= 0)
        return;
    /* count first (the path may be long), then keep max of it */
    size_t len = 0;
    for (int32_t k = j; k >= 0 && k != from; k = rig->parents[k])
        len++;
    if (len == 0)
        return;
    size_t keep = len < (size_t)max ? len : (size_t)max;
    /* path positions (from the top of the chain, 0 = nearest `from`) to keep */
    for (size_t i = 0; i < keep && i < MLR_COUNTOF(path); i++)
        path[i] = -1;
    size_t pos = len;
    for (int32_t k = j; k >= 0 && k != from; k = rig->parents[k]) {
        pos--; /* position of k along the chain, 0 just below `from` */
        for (size_t i = 0; i < keep; i++)
            if ((i + 1) * len / keep - 1 == pos)
                path[i] = k;
    }
    for (size_t i = 0; i < keep; i++)
        role_joint[first + (int)i] = path[i];
    n = keep;
    (void)n;
}

static int first_child(const mlr_rig *rig, int32_t j);

/* The roles that follow from the tree (each only where it has no joint yet): the hips where the
 * upper legs meet, the toes, the head (a candidate below the hips), the shoulders, the spine
 * and neck chains. */
static void tree_roles(const mlr_rig *rig, int32_t *role, int32_t head)
{
    const int32_t ll = role[MLR_ROLE_LEFT_UPPER_LEG], rl = role[MLR_ROLE_RIGHT_UPPER_LEG];
    const int32_t la = role[MLR_ROLE_LEFT_UPPER_ARM], ra = role[MLR_ROLE_RIGHT_UPPER_ARM];
    int32_t hips = role[MLR_ROLE_HIPS];
    if (hips < 0 && ll > 0 && rl > 0) {
        hips = lca(rig, ll, rl);
        if (hips == ll || hips == rl)
            hips = -1;
        /* the hips carry the upper body too: where the legs hang from a pelvis joint beside
         * the spine (MakeHuman: Root -> Hips -> legs, Root -> Spine1 -> .. -> Head), the joint
         * where the legs and the upper body (the named head, else the arms) meet */
        const int32_t upper = head > 0 ? head : la > 0 && ra > 0 ? lca(rig, la, ra) : -1;
        if (hips >= 0 && upper > 0 && !is_ancestor(rig, hips, upper)) {
            const int32_t h = lca(rig, hips, upper);
            if (h >= 0 && h != upper)
                hips = h;
        }
    }
    role[MLR_ROLE_HIPS] = hips;
    for (int s = 0; s < 2; s++) { /* the toes: the foot's first child joint */
        const int toes = s == 0 ? MLR_ROLE_LEFT_TOES : MLR_ROLE_RIGHT_TOES;
        const int32_t foot = role[toes - 1];
        if (foot > 0 && role[toes] < 0)
            role[toes] = (int32_t)first_child(rig, foot);
    }
    if (role[MLR_ROLE_HEAD] < 0 && head >= 0 &&
        (hips < 0 || (head != hips && is_ancestor(rig, hips, head))))
        role[MLR_ROLE_HEAD] = head;
    head = role[MLR_ROLE_HEAD];
    /* the shoulders: the upper arm's parent, unless the other arm or the head hangs from it */
    for (int s = 0; s < 2; s++) {
        const int32_t upper = s == 0 ? la : ra, other = s == 0 ? ra : la;
        if (upper <= 0 || role[s == 0 ? MLR_ROLE_LEFT_SHOULDER : MLR_ROLE_RIGHT_SHOULDER] >= 0)
            continue;
        const int32_t p = limb_parent(rig, upper);
        if (p <= 0 || (other > 0 && is_ancestor(rig, p, other)) ||
            (head >= 0 && is_ancestor(rig, p, head)) ||
            (hips >= 0 && !is_ancestor(rig, hips, p)) || p == hips)
            continue;
        role[(s == 0 ? MLR_ROLE_LEFT_SHOULDER : MLR_ROLE_RIGHT_SHOULDER)] = p;
    }
    if (hips < 0)
        return;
    /* the chest: where the arms meet, or else the head's parent */
    int32_t chest = -1;
    if (la > 0 && ra > 0)
        chest = lca(rig, la, ra);
    else if (head > 0)
        chest = rig->parents[head];
    if (chest >= 0 && (chest == hips || !is_ancestor(rig, hips, chest)))
        chest = -1;
    if (chest >= 0 && role[MLR_ROLE_SPINE] < 0)
        fill_chain(rig, hips, chest, 1, role, MLR_ROLE_SPINE, MLR_RETARGET_MAX_SPINE);
    if (head < 0 && chest >= 0) {
        /* no joint named head: the end of the middle chain up from the chest (its child that
         * carries neither arm, then the only child of each joint while there is one) */
        int32_t j = -1;
        for (size_t c = (size_t)chest + 1; c < rig->n_joints && j < 0; c++)
            if (rig->parents[c] == chest && !(la > 0 && is_ancestor(rig, (int32_t)c, la)) &&
                !(ra > 0 && is_ancestor(rig, (int32_t)c, ra)))
                j = (int32_t)c;
        while (j >= 0) {
            int n = 0, only = -1;
            for (size_t c = (size_t)j + 1; c < rig->n_joints; c++)
                if (rig->parents[c] == j)
                    n++, only = (int)c;
            if (n != 1)
                break;
            j = only;
        }
        if (j > 0)
            role[MLR_ROLE_HEAD] = head = j;
    }
    if (head > 0) {
        const int32_t from = chest >= 0 ? chest : hips;
        if (is_ancestor(rig, from, head) && head != from && role[MLR_ROLE_NECK] < 0)
            fill_chain(rig, from, head, 0, role, MLR_ROLE_NECK, MLR_RETARGET_MAX_NECK);
    }
}

/* The roles found by the rules, without the minimum check. */
static mlr_status detect_roles(const mlr_rig *rig, int32_t *role, const mlr_allocator *alloc,
                               mlr_diag *diag)
{
    const size_t J = rig->n_joints;
    for (int r = 0; r < MLR_ROLE_COUNT; r++)
        role[r] = -1;
    size_t bytes;
    if (common__mul_size(J, sizeof(int32_t) + sizeof(int8_t), &bytes) != MLR_OK)
        return common__diag_set(diag, MLR_E_OVERFLOW, 0, 0, "retarget: too many joints");
    mlr_allocator a;
    common__allocator_resolve(alloc, &a);
    unsigned char *scratch = common__alloc(&a, bytes);
    if (!scratch)
        return common__diag_set(diag, MLR_E_NO_MEMORY, 0, 0, "retarget: out of memory");
    int32_t *partner = (int32_t *)(void *)scratch;
    int8_t *side = (int8_t *)(scratch + J * sizeof(int32_t));
    size_t n_pairs = 0;
    mlr_status st = mirror__find_pairs(rig, NULL, 0, 0, partner, side, &n_pairs, alloc, diag);
    if (st != MLR_OK) {
        common__free(&a, scratch, bytes);
        return st;
    }
    static const char *const foot_words[] = {"foot", "ankle", NULL};
    static const char *const hand_words[] = {"hand", "wrist", NULL};
    static const char *const head_words[] = {"head", NULL};
    static const char *const head_not[] = {"end", "top", NULL};
    const int sides[2] = {1, -1};
    for (int s = 0; s < 2; s++) {
        const int leg = s == 0 ? MLR_ROLE_LEFT_UPPER_LEG : MLR_ROLE_RIGHT_UPPER_LEG;
        const int arm = s == 0 ? MLR_ROLE_LEFT_SHOULDER : MLR_ROLE_RIGHT_SHOULDER;
        const int32_t foot = topmost(rig, side, sides[s], foot_words, NULL);
        if (foot > 0) {
            const int32_t lower = limb_parent(rig, foot);
            const int32_t upper = lower > 0 ? limb_parent(rig, lower) : -1;
            if (upper > 0) {
                role[leg + 2] = foot;
                role[leg + 1] = lower;
                role[leg] = upper;
            }
        }
        const int32_t hand = topmost(rig, side, sides[s], hand_words, NULL);
        if (hand > 0) {
            const int32_t lower = limb_parent(rig, hand);
            const int32_t upper = lower > 0 ? limb_parent(rig, lower) : -1;
            if (upper > 0) {
                role[arm + 3] = hand;
                role[arm + 2] = lower;
                role[arm + 1] = upper;
            }
        }
    }
    int32_t head = topmost(rig, side, 0, head_words, head_not);
    if (head < 0)
        head = topmost(rig, side, 0, head_words, NULL);
    common__free(&a, scratch, bytes);
    tree_roles(rig, role, head);
    return MLR_OK;
}

/* The rest position of joint j (the OFFSETs summed from the root, the root at the origin). */
static void rest_of(const mlr_rig *rig, int32_t j, double *out)
{
    out[0] = out[1] = out[2] = 0.0;
    for (; j > 0; j = rig->parents[j])
        for (int c = 0; c < 3; c++)
            out[c] += rig->offsets[3 * (size_t)j + (size_t)c];
}

static double rest_dist(const mlr_rig *rig, int32_t a, int32_t b)
{
    double pa[3], pb[3];
    rest_of(rig, a, pa), rest_of(rig, b, pb);
    const double d[3] = {pa[0] - pb[0], pa[1] - pb[1], pa[2] - pb[2]};
    return sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
}

/* A humanoid's arms are shorter than its legs and its torso shorter than its legs; a
 * quadruped's front legs (taken for arms) are about as long as its hind legs and its torso,
 * spanning from the hind legs to the front ones, is longer. Measured (bench_retarget.py
 * --proportions) over the 93 rigs it accepts among 103 BVH files: arms 0.22 to 0.80 of the
 * legs (one Kinect skeleton with glitched OFFSETs, 1.14), torsos 0.24 to 0.73; the
 * AI4Animation dog 0.97 and 1.38, the Truebones elephant 0.86 and 0.84. Both at or above these
 * are refused. */
#define HUMANOID_MAX_ARM 0.8
#define HUMANOID_MAX_TORSO 0.75

/* The humanoid minimum: both legs (upper leg, lower leg, foot), the hips above them, both arms
 * (upper arm, lower arm, hand), a head, and the proportions of a humanoid's limbs rather than a
 * quadruped's. A spine is not required: Kinect skeletons hang the arms, the legs and the neck
 * from one torso joint. */
static mlr_status check_minimum(const mlr_rig *rig, const int32_t *role, const char *who,
                                mlr_diag *diag)
{
    static const int need[] = {MLR_ROLE_LEFT_FOOT,
                               MLR_ROLE_RIGHT_FOOT,
                               MLR_ROLE_LEFT_LOWER_LEG,
                               MLR_ROLE_RIGHT_LOWER_LEG,
                               MLR_ROLE_LEFT_UPPER_LEG,
                               MLR_ROLE_RIGHT_UPPER_LEG,
                               MLR_ROLE_HIPS,
                               MLR_ROLE_LEFT_HAND,
                               MLR_ROLE_RIGHT_HAND,
                               MLR_ROLE_LEFT_LOWER_ARM,
                               MLR_ROLE_RIGHT_LOWER_ARM,
                               MLR_ROLE_LEFT_UPPER_ARM,
                               MLR_ROLE_RIGHT_UPPER_ARM,
                               MLR_ROLE_HEAD};
    for (size_t i = 0; i < MLR_COUNTOF(need); i++)
        if (role[need[i]] < 0) {
            const int r = need[i];
            const char *how =
                r == MLR_ROLE_LEFT_FOOT || r == MLR_ROLE_RIGHT_FOOT
                    ? "a joint of that side (Left/Right, _L/_R, l/r) named with foot or ankle, "
                      "two joints below the root"
                : r == MLR_ROLE_LEFT_HAND || r == MLR_ROLE_RIGHT_HAND
                    ? "a joint of that side named with hand or wrist, two joints below the "
                      "shoulder"
                : r == MLR_ROLE_HIPS ? "the common ancestor of the two upper legs"
                : r == MLR_ROLE_HEAD
                    ? "a joint named with head, or the end of the chain up from the chest"
                : r >= MLR_ROLE_LEFT_SHOULDER && r <= MLR_ROLE_RIGHT_HAND
                    ? "from the hand up the tree"
                    : "from the foot up the tree";
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    "retarget: %s: no humanoid %s (%s); name it with a map entry",
                                    who, fixed_names[r], how);
        }
    const int32_t *R = role;
    double leg = 0.0, arm = 0.0, mid_arms[3], hips[3], a[3], b[3];
    for (int s = 0; s < 2; s++) {
        const int ul = s ? MLR_ROLE_RIGHT_UPPER_LEG : MLR_ROLE_LEFT_UPPER_LEG;
        const int ua = s ? MLR_ROLE_RIGHT_UPPER_ARM : MLR_ROLE_LEFT_UPPER_ARM;
        leg += 0.5 * (rest_dist(rig, R[ul], R[ul + 1]) + rest_dist(rig, R[ul + 1], R[ul + 2]));
        arm += 0.5 * (rest_dist(rig, R[ua], R[ua + 1]) + rest_dist(rig, R[ua + 1], R[ua + 2]));
    }
    rest_of(rig, R[MLR_ROLE_LEFT_UPPER_ARM], a);
    rest_of(rig, R[MLR_ROLE_RIGHT_UPPER_ARM], b);
    rest_of(rig, R[MLR_ROLE_HIPS], hips);
    for (int c = 0; c < 3; c++)
        mid_arms[c] = 0.5 * (a[c] + b[c]) - hips[c];
    const double torso =
        sqrt(mid_arms[0] * mid_arms[0] + mid_arms[1] * mid_arms[1] + mid_arms[2] * mid_arms[2]);
    if (leg > 0 && arm >= HUMANOID_MAX_ARM * leg && torso >= HUMANOID_MAX_TORSO * leg)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "retarget: %s: not a humanoid: arms (%s, %s) %.2f and torso "
                                "(%s-arms) %.2f of the legs: a quadruped's (humanoid: arms < "
                                "%.2f or torso < %.2f)",
                                who, rig->names[R[MLR_ROLE_LEFT_UPPER_ARM]],
                                rig->names[R[MLR_ROLE_RIGHT_UPPER_ARM]], arm / leg,
                                rig->names[R[MLR_ROLE_HIPS]], torso / leg, HUMANOID_MAX_ARM,
                                HUMANOID_MAX_TORSO);
    return MLR_OK;
}

mlr_status mlr_retarget_roles(const mlr_rig *rig, int32_t *role_joint, const mlr_allocator *alloc,
                              mlr_diag *diag)
{
    mlr_status st = mlr_rig_check(rig, diag);
    if (st != MLR_OK)
        return common__diag_prefix(diag, st, "retarget");
    if (!role_joint)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "retarget: role_joint is NULL");
    if (!rig->names)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "retarget: the rig has no joint names to find roles by");
    st = detect_roles(rig, role_joint, alloc, diag);
    if (st != MLR_OK)
        return st;
    return check_minimum(rig, role_joint, "rig", diag);
}

/* ---- small linear algebra ----------------------------------------------------------------- */

static int normalize3(double *v)
{
    const double n = sqrt(common__dot3(v, v));
    if (!(n > 1e-12))
        return 0;
    v[0] /= n, v[1] /= n, v[2] /= n;
    return 1;
}

/* Rotation matrix (row-major, columns e1 e2 e3) from a primary and a secondary direction. */
static int frame_of(const double *primary, const double *secondary, double *m)
{
    double e1[3] = {primary[0], primary[1], primary[2]}, e2[3], e3[3];
    if (!normalize3(e1))
        return 0;
    const double d = common__dot3(secondary, e1);
    for (int c = 0; c < 3; c++)
        e2[c] = secondary[c] - d * e1[c];
    if (!normalize3(e2))
        return 0;
    common__cross3(e1, e2, e3);
    for (int r = 0; r < 3; r++)
        m[3 * r] = e1[r], m[3 * r + 1] = e2[r], m[3 * r + 2] = e3[r];
    return 1;
}

/* a b^T for rotation matrices (row-major). */
static void mul_abt(const double *a, const double *b, double *o)
{
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 3; c++)
            o[3 * r + c] =
                a[3 * r] * b[3 * c] + a[3 * r + 1] * b[3 * c + 1] + a[3 * r + 2] * b[3 * c + 2];
}

static void quat_of_matrix(const double *m, mlr_quat *q)
{
    const double tr = m[0] + m[4] + m[8];
    double w, x, y, z;
    if (tr > 0) {
        const double s = 2.0 * sqrt(tr + 1.0);
        w = 0.25 * s, x = (m[7] - m[5]) / s, y = (m[2] - m[6]) / s, z = (m[3] - m[1]) / s;
    } else if (m[0] > m[4] && m[0] > m[8]) {
        const double s = 2.0 * sqrt(1.0 + m[0] - m[4] - m[8]);
        w = (m[7] - m[5]) / s, x = 0.25 * s, y = (m[1] + m[3]) / s, z = (m[2] + m[6]) / s;
    } else if (m[4] > m[8]) {
        const double s = 2.0 * sqrt(1.0 + m[4] - m[0] - m[8]);
        w = (m[2] - m[6]) / s, x = (m[1] + m[3]) / s, y = 0.25 * s, z = (m[5] + m[7]) / s;
    } else {
        const double s = 2.0 * sqrt(1.0 + m[8] - m[0] - m[4]);
        w = (m[3] - m[1]) / s, x = (m[2] + m[6]) / s, y = (m[5] + m[7]) / s, z = 0.25 * s;
    }
    const double n = sqrt(w * w + x * x + y * y + z * z);
    q->w = w / n, q->x = x / n, q->y = y / n, q->z = z / n;
}

static mlr_quat qconj(mlr_quat q)
{
    q.x = -q.x, q.y = -q.y, q.z = -q.z;
    return q;
}

static mlr_quat qmul(mlr_quat a, mlr_quat b)
{
    mlr_quat o;
    common__quat_mul_inline(&a, &b, &o);
    return o;
}

/* ---- one rig's rest pose ------------------------------------------------------------------ */

typedef struct rig_rest {
    const mlr_rig *rig;
    int32_t role[MLR_ROLE_COUNT];
    int n_spine, n_neck;
    double *pos;       /* J x 3 rest positions, the root at the origin */
    double body[9];    /* columns left, up, forward of the rest pose (snapped to axes) */
    double world[9];   /* F: the same in the world: up the given axis where one is given */
    double leg;        /* L: mean leg length */
} rig_rest;

static void end_site_pos(const rig_rest *r, int32_t j, double *out, int *found)
{
    const mlr_rig *rig = r->rig;
    for (size_t e = 0; e < rig->n_end_sites; e++)
        if (rig->end_site_parents[e] == j) {
            for (int c = 0; c < 3; c++)
                out[c] =
                    r->pos[3 * (size_t)j + (size_t)c] + rig->end_site_offsets[3 * e + (size_t)c];
            *found = 1;
            return;
        }
    *found = 0;
}

static int first_child(const mlr_rig *rig, int32_t j)
{
    for (size_t c = (size_t)j + 1; c < rig->n_joints; c++)
        if (rig->parents[c] == j)
            return (int)c;
    return -1;
}

/* The rest position of the end of role r's bone; 0 when it has none. */
static int bone_end(const rig_rest *r, int role, double *out)
{
    const int32_t *R = r->role;
    const int32_t j = R[role];
    int32_t next = -1;
    int found = 0;
    if (role >= MLR_ROLE_SPINE && role < MLR_ROLE_SPINE + MLR_RETARGET_MAX_SPINE) {
        const int k = role - MLR_ROLE_SPINE;
        next = k + 1 < r->n_spine ? R[role + 1]
               : r->n_neck > 0    ? R[MLR_ROLE_NECK]
                                  : R[MLR_ROLE_HEAD];
    } else if (role >= MLR_ROLE_NECK && role < MLR_ROLE_NECK + MLR_RETARGET_MAX_NECK) {
        const int k = role - MLR_ROLE_NECK;
        next = k + 1 < r->n_neck ? R[role + 1] : R[MLR_ROLE_HEAD];
    } else if (role == MLR_ROLE_HEAD || role == MLR_ROLE_LEFT_TOES ||
               role == MLR_ROLE_RIGHT_TOES) {
        end_site_pos(r, j, out, &found);
        if (found)
            return 1;
        next = first_child(r->rig, j);
    } else if (role == MLR_ROLE_LEFT_HAND || role == MLR_ROLE_RIGHT_HAND) {
        const mlr_rig *rig = r->rig;
        double sum[3] = {0, 0, 0};
        size_t n = 0;
        for (size_t c = (size_t)j + 1; c < rig->n_joints; c++)
            if (rig->parents[c] == j) {
                for (int a = 0; a < 3; a++)
                    sum[a] += r->pos[3 * c + (size_t)a];
                n++;
            }
        for (size_t e = 0; e < rig->n_end_sites; e++)
            if (rig->end_site_parents[e] == j) {
                for (int a = 0; a < 3; a++)
                    sum[a] += r->pos[3 * (size_t)j + (size_t)a] +
                              rig->end_site_offsets[3 * e + (size_t)a];
                n++;
            }
        if (!n)
            return 0;
        for (int a = 0; a < 3; a++)
            out[a] = sum[a] / (double)n;
        return 1;
    } else if (role == MLR_ROLE_LEFT_FOOT || role == MLR_ROLE_RIGHT_FOOT) {
        next = R[role + 1];
        if (next < 0) {
            end_site_pos(r, j, out, &found);
            return found;
        }
    } else if (role != MLR_ROLE_HIPS) {
        next = R[role + 1]; /* shoulder, upper and lower arm, upper and lower leg */
    }
    if (next < 0)
        return 0;
    for (int c = 0; c < 3; c++)
        out[c] = r->pos[3 * (size_t)next + (size_t)c];
    return 1;
}

static void count_chains(rig_rest *r)
{
    r->n_spine = 0;
    while (r->n_spine < MLR_RETARGET_MAX_SPINE && r->role[MLR_ROLE_SPINE + r->n_spine] >= 0)
        r->n_spine++;
    r->n_neck = 0;
    while (r->n_neck < MLR_RETARGET_MAX_NECK && r->role[MLR_ROLE_NECK + r->n_neck] >= 0)
        r->n_neck++;
}

static double dist3(const double *a, const double *b)
{
    const double d[3] = {a[0] - b[0], a[1] - b[1], a[2] - b[2]};
    return sqrt(common__dot3(d, d));
}

/* Rest positions, the body frame and the leg length (roles already set). */
static mlr_status rest_setup(rig_rest *r, const char *who, int up_axis, mlr_diag *diag)
{
    const mlr_rig *rig = r->rig;
    const int32_t *R = r->role;
    r->pos[0] = r->pos[1] = r->pos[2] = 0.0;
    for (size_t j = 1; j < rig->n_joints; j++)
        for (int c = 0; c < 3; c++)
            r->pos[3 * j + (size_t)c] =
                r->pos[3 * (size_t)rig->parents[j] + (size_t)c] + rig->offsets[3 * j + (size_t)c];
    count_chains(r);
    const double *P = r->pos;
#define RP(role_) (P + 3 * (size_t)R[role_])
    r->leg = 0.5 * (dist3(RP(MLR_ROLE_LEFT_UPPER_LEG), RP(MLR_ROLE_LEFT_LOWER_LEG)) +
                    dist3(RP(MLR_ROLE_LEFT_LOWER_LEG), RP(MLR_ROLE_LEFT_FOOT)) +
                    dist3(RP(MLR_ROLE_RIGHT_UPPER_LEG), RP(MLR_ROLE_RIGHT_LOWER_LEG)) +
                    dist3(RP(MLR_ROLE_RIGHT_LOWER_LEG), RP(MLR_ROLE_RIGHT_FOOT)));
    if (!(r->leg > 0) || !isfinite(r->leg))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "retarget: %s: the legs have no length in the rest pose", who);
    /* up: the hips to the head, the neck, the chest or the arms */
    int32_t top = R[MLR_ROLE_HEAD];
    if (top < 0)
        top = r->n_neck ? R[MLR_ROLE_NECK] : r->n_spine ? R[MLR_ROLE_SPINE + r->n_spine - 1] : -1;
    double up[3], left[3];
    if (top >= 0) {
        for (int c = 0; c < 3; c++)
            up[c] = P[3 * (size_t)top + (size_t)c] - RP(MLR_ROLE_HIPS)[c];
    } else {
        /* no upper body: up is away from the feet */
        for (int c = 0; c < 3; c++)
            up[c] = RP(MLR_ROLE_HIPS)[c] -
                    0.5 * (RP(MLR_ROLE_LEFT_FOOT)[c] + RP(MLR_ROLE_RIGHT_FOOT)[c]);
    }
    for (int c = 0; c < 3; c++)
        left[c] = RP(MLR_ROLE_LEFT_UPPER_LEG)[c] - RP(MLR_ROLE_RIGHT_UPPER_LEG)[c];
#undef RP
    double m[9];
    if (!frame_of(up, left, m))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "retarget: %s: the rest pose has no body frame (the upper legs or "
                                "the hips and the head coincide, or are in line)",
                                who);
    /* m's columns: up, left' (left without its part along up). Each snapped to the world axis
     * it is nearest, with its sign (rigs stand and face along axes; a rest pose leaning a few
     * degrees must not tilt the floor), then F's columns: left, up, forward = left x up. */
    double su[3] = {0, 0, 0}, sl[3] = {0, 0, 0};
    int ku = 0, kl = -1;
    for (int c = 1; c < 3; c++)
        if (fabs(m[3 * c]) > fabs(m[3 * ku]))
            ku = c;
    for (int c = 0; c < 3; c++)
        if (c != ku && (kl < 0 || fabs(m[3 * c + 1]) > fabs(m[3 * kl + 1])))
            kl = c;
    su[ku] = m[3 * ku] > 0 ? 1.0 : -1.0;
    sl[kl] = m[3 * kl + 1] > 0 ? 1.0 : -1.0;
    double fw[3];
    common__cross3(sl, su, fw);
    for (int row = 0; row < 3; row++) {
        r->body[3 * row] = sl[row];
        r->body[3 * row + 1] = su[row];
        r->body[3 * row + 2] = fw[row];
    }
    memcpy(r->world, r->body, sizeof r->body);
    if (up_axis >= 0 && up_axis != ku) {
        /* the world's up is given and the rest pose lies along another axis (Bandai's bind
         * pose: the bones along x): left stays the rest's where it is level, else forward does */
        double wu[3] = {0, 0, 0}, wl[3], wf[3];
        wu[up_axis] = 1.0;
        if (kl != up_axis) {
            memcpy(wl, sl, sizeof wl);
            common__cross3(wl, wu, wf);
        } else {
            memcpy(wf, fw, sizeof wf);
            common__cross3(wu, wf, wl);
        }
        for (int row = 0; row < 3; row++) {
            r->world[3 * row] = wl[row];
            r->world[3 * row + 1] = wu[row];
            r->world[3 * row + 2] = wf[row];
        }
    }
    return MLR_OK;
}

/* ---- the map ------------------------------------------------------------------------------ */

static int32_t find_joint(const mlr_rig *rig, const char *name)
{
    for (size_t j = 0; j < rig->n_joints; j++)
        if (strcmp(rig->names[j], name) == 0)
            return (int32_t)j;
    return -1;
}

static mlr_status apply_map(const rig_rest *src, rig_rest *dst, const char *const *map,
                            size_t n_map, mlr_diag *diag)
{
    for (size_t k = 0; k < n_map; k++) {
        const char *sn = map[2 * k], *tn = map[2 * k + 1];
        if (!sn || !tn)
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    "retarget: map: pair %zu has a NULL name", k);
        const int32_t s = find_joint(src->rig, sn), t = find_joint(dst->rig, tn);
        if (s < 0)
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    "retarget: map: the source has no joint '%s'", sn);
        if (t < 0)
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    "retarget: map: the target has no joint '%s'", tn);
        for (size_t i = 0; i < k; i++)
            if (strcmp(map[2 * i + 1], tn) == 0)
                return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                        "retarget: map: the target joint '%s' is named twice", tn);
        int role = -1;
        for (int r = 0; r < MLR_ROLE_COUNT; r++)
            if (src->role[r] == s)
                role = r;
        if (role < 0)
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    "retarget: map: the source joint '%s' has no humanoid role "
                                    "(mlr_retarget_roles)",
                                    sn);
        for (int r = 0; r < MLR_ROLE_COUNT; r++)
            if (dst->role[r] == t)
                dst->role[r] = -1;
        dst->role[role] = t;
    }
    return MLR_OK;
}

/* After a map: the legs and arms up from the feet and hands it named, the hips where the legs
 * meet, for the roles still without a joint. */
static void complete_roles(const mlr_rig *rig, int32_t *role)
{
    static const int limbs[4] = {MLR_ROLE_LEFT_UPPER_LEG, MLR_ROLE_RIGHT_UPPER_LEG,
                                 MLR_ROLE_LEFT_UPPER_ARM, MLR_ROLE_RIGHT_UPPER_ARM};
    for (int i = 0; i < 4; i++) {
        const int up = limbs[i], end = up + 2;
        if (role[end] <= 0)
            continue;
        if (role[up + 1] < 0)
            role[up + 1] = limb_parent(rig, role[end]);
        if (role[up] < 0 && role[up + 1] > 0)
            role[up] = limb_parent(rig, role[up + 1]);
    }
    const int32_t ll = role[MLR_ROLE_LEFT_UPPER_LEG], rl = role[MLR_ROLE_RIGHT_UPPER_LEG];
    if (role[MLR_ROLE_HIPS] < 0 && ll > 0 && rl > 0) {
        const int32_t h = lca(rig, ll, rl);
        if (h != ll && h != rl)
            role[MLR_ROLE_HIPS] = h;
    }
    tree_roles(rig, role, role[MLR_ROLE_HEAD]);
}

/* The height along up of a rig's ankle (foot role) above the lowest of its foot's points (the
 * toes and the End Sites of the foot and the toes), posed by the world rotations wrot (J). */
static double foot_drop(const rig_rest *r, int side, const mlr_quat *wrot, const double *up)
{
    const mlr_rig *rig = r->rig;
    const int foot_role = side == 0 ? MLR_ROLE_LEFT_FOOT : MLR_ROLE_RIGHT_FOOT;
    const int32_t foot = r->role[foot_role], toes = r->role[foot_role + 1];
    double low = 0.0, toe_rel[3] = {0, 0, 0};
    if (toes >= 0 && rig->parents[toes] == foot) {
        common__quat_rotate_inline(&wrot[foot], rig->offsets + 3 * (size_t)toes, toe_rel);
        low = fmin(low, common__dot3(toe_rel, up));
    }
    for (size_t e = 0; e < rig->n_end_sites; e++) {
        const int32_t j = rig->end_site_parents[e];
        if (j != foot && (j != toes || toes < 0 || rig->parents[toes] != foot))
            continue;
        double v[3];
        common__quat_rotate_inline(&wrot[j], rig->end_site_offsets + 3 * e, v);
        if (j == toes)
            for (int c = 0; c < 3; c++)
                v[c] += toe_rel[c];
        low = fmin(low, common__dot3(v, up));
    }
    return -low;
}

/* ---- fingers ------------------------------------------------------------------------------ */

/* The finger a joint's name names: 0 thumb, 1 index, 2 middle, 3 ring, 4 little; -1 none. */
static int finger_kind(const char *name)
{
    static const char *const thumb[] = {"thumb", NULL}, *const index[] = {"index", NULL},
                             *const middle[] = {"middle", NULL}, *const ring[] = {"ring", NULL},
                             *const little[] = {"pinky", "pinkie", "little", NULL};
    static const char *const *const kinds[5] = {thumb, index, middle, ring, little};
    for (int k = 0; k < 5; k++)
        if (common__name_matches(name, kinds[k]))
            return k;
    return -1;
}

/* A finger joint of a rig: its side (0 left, 1 right: below that hand role), its finger, its
 * place k from the hand among the joints of that finger above it and the count n of that
 * finger's joints below the hand; 0 when j is none (no role hand above it, no finger name). */
static int finger_of(const rig_rest *r, int32_t j, int *side, int *kind, int *k, int *n)
{
    const mlr_rig *rig = r->rig;
    *kind = finger_kind(rig->names[j]);
    if (*kind < 0)
        return 0;
    int32_t hand = -1;
    for (int s = 0; s < 2 && hand < 0; s++) {
        const int32_t h = r->role[s ? MLR_ROLE_RIGHT_HAND : MLR_ROLE_LEFT_HAND];
        if (h >= 0 && h != j && is_ancestor(rig, h, j))
            hand = h, *side = s;
    }
    if (hand < 0)
        return 0;
    *k = 0;
    for (int32_t a = rig->parents[j]; a != hand; a = rig->parents[a])
        *k += finger_kind(rig->names[a]) == *kind;
    *n = 0;
    for (size_t c = (size_t)hand + 1; c < rig->n_joints; c++)
        *n += finger_kind(rig->names[c]) == *kind && is_ancestor(rig, hand, (int32_t)c);
    return 1;
}

/* The source joint that target finger joint j follows: the joint of the same hand and finger
 * at the same place counted from the finger's tip (a rig with a metacarpal joint more, as
 * MakeHuman's and Axis Neuron's, lines up at the tips); -1 when none, or when it has a role. */
static int32_t finger_source(const rig_rest *src, const rig_rest *dst, int32_t j)
{
    int ts, tk, tpos, tn;
    if (!finger_of(dst, j, &ts, &tk, &tpos, &tn))
        return -1;
    for (size_t c = 1; c < src->rig->n_joints; c++) {
        int ss, sk, spos, sn;
        if (!finger_of(src, (int32_t)c, &ss, &sk, &spos, &sn) || ss != ts || sk != tk)
            continue;
        if (spos - (sn - tn) != tpos)
            continue;
        for (int r = 0; r < MLR_ROLE_COUNT; r++)
            if (src->role[r] == (int32_t)c)
                return -1;
        return (int32_t)c;
    }
    return -1;
}

/* ---- the retarget ------------------------------------------------------------------------- */

/* A spine or neck chain: its joints, then the joint it ends at, with the fraction of the
 * chain's rest length at each. */
typedef struct chain {
    int n;                               /* joints of the chain */
    int ok;                              /* an end joint and a length: fractions known */
    int32_t j[MLR_RETARGET_MAX_SPINE + 1]; /* n joints, then the end */
    double u[MLR_RETARGET_MAX_SPINE + 1];  /* u[0] = 0 .. u[n] = 1 */
} chain;

static void chain_of(const rig_rest *r, int first, int n, int32_t end, chain *c)
{
    c->n = n;
    c->ok = 0;
    if (n == 0 || end < 0)
        return;
    for (int k = 0; k < n; k++)
        c->j[k] = r->role[first + k];
    c->j[n] = end;
    c->u[0] = 0.0;
    for (int k = 0; k < n; k++)
        c->u[k + 1] =
            c->u[k] + dist3(r->pos + 3 * (size_t)c->j[k], r->pos + 3 * (size_t)c->j[k + 1]);
    const double L = c->u[n];
    if (!(L > 0))
        return;
    for (int k = 1; k <= n; k++)
        c->u[k] /= L;
    c->u[n] = 1.0;
    c->ok = 1;
}

static void chains_of(const rig_rest *r, chain *spine, chain *neck)
{
    const int32_t head = r->role[MLR_ROLE_HEAD];
    chain_of(r, MLR_ROLE_SPINE, r->n_spine, r->n_neck ? r->role[MLR_ROLE_NECK] : head, spine);
    chain_of(r, MLR_ROLE_NECK, r->n_neck, head, neck);
}

/* The segment of chain c at fraction u. */
static int segment_at(const chain *c, double u)
{
    int i = 0;
    while (i + 1 < c->n && c->u[i + 1] <= u)
        i++;
    return i;
}

/* The source role that target role r follows; -1 when none. Chain joints follow the source
 * joint whose segment holds the middle of theirs (by the fractions of the rest lengths), or,
 * without fractions, joint ceil((k + 1) m / n) - 1. */
static int source_role(const rig_rest *src, const chain *ss, const chain *sn, const chain *ts,
                       const chain *tn, int r)
{
    const int is_spine = r >= MLR_ROLE_SPINE && r < MLR_ROLE_SPINE + MLR_RETARGET_MAX_SPINE;
    const int is_neck = r >= MLR_ROLE_NECK && r < MLR_ROLE_NECK + MLR_RETARGET_MAX_NECK;
    if (is_spine || is_neck) {
        const chain *sc = is_spine ? ss : sn, *tc = is_spine ? ts : tn;
        const int base = is_spine ? MLR_ROLE_SPINE : MLR_ROLE_NECK;
        const int k = r - base, n = tc->n, m = sc->n;
        if (k >= n || m == 0)
            return -1;
        if (sc->ok && tc->ok)
            return base + segment_at(sc, 0.5 * (tc->u[k] + tc->u[k + 1]));
        return base + ((k + 1) * m + n - 1) / n - 1;
    }
    return src->role[r] >= 0 ? r : -1;
}

/* The direction from fraction u0 to u1 along source chain c at one frame: the chain's rest
 * segments turned by the world rotations of their joints (so that position channels that only
 * repeat an OFFSET with noise do not move it), or the world positions where a segment's end is
 * not its joint's child. */
static void chain_span(const chain *c, const rig_rest *r, const double *wpos, const mlr_quat *wrot,
                       double u0, double u1, double *out)
{
    out[0] = out[1] = out[2] = 0.0;
    for (int i = 0; i < c->n; i++) {
        const double lo = c->u[i], hi = c->u[i + 1], len = hi - lo;
        const double a = u0 > lo ? u0 : lo, b = u1 < hi ? u1 : hi;
        if (!(b > a) || !(len > 0))
            continue;
        const int32_t j = c->j[i], k = c->j[i + 1];
        double seg[3];
        if (r->rig->parents[k] == j) {
            common__quat_rotate_inline(&wrot[j], r->rig->offsets + 3 * (size_t)k, seg);
        } else {
            for (int x = 0; x < 3; x++)
                seg[x] = wpos[3 * (size_t)k + (size_t)x] - wpos[3 * (size_t)j + (size_t)x];
        }
        const double w = (b - a) / len;
        for (int x = 0; x < 3; x++)
            out[x] += w * seg[x];
    }
}

/* The shortest rotation taking direction a onto direction b (both nonzero). */
static mlr_quat swing(const double *a_, const double *b_)
{
    double a[3] = {a_[0], a_[1], a_[2]}, b[3] = {b_[0], b_[1], b_[2]}, x[3];
    mlr_quat q = {1.0, 0.0, 0.0, 0.0};
    if (!normalize3(a) || !normalize3(b))
        return q;
    const double d = common__dot3(a, b);
    common__cross3(a, b, x);
    if (d < -1.0 + 1e-12) {
        /* opposite: half a turn about any axis normal to a */
        const double e[3] = {fabs(a[0]) < 0.9 ? 1.0 : 0.0, fabs(a[0]) < 0.9 ? 0.0 : 1.0, 0.0};
        common__cross3(a, e, x);
        normalize3(x);
        return (mlr_quat){0.0, x[0], x[1], x[2]};
    }
    q.w = 1.0 + d, q.x = x[0], q.y = x[1], q.z = x[2];
    const double n = sqrt(q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z);
    q.w /= n, q.x /= n, q.y /= n, q.z /= n;
    return q;
}

/* The end of the bone of a joint without a role: its first child joint, else its first End
 * Site; 0 when it has neither. */
static int plain_bone_end(const rig_rest *r, int32_t j, double *out)
{
    const int c = first_child(r->rig, j);
    if (c >= 0) {
        for (int a = 0; a < 3; a++)
            out[a] = r->pos[3 * (size_t)c + (size_t)a];
        return 1;
    }
    int found;
    end_site_pos(r, j, out, &found);
    return found;
}

/* C = P_s P_t^T for bones (pos - joint rest positions) ps and pt; G when either is missing. */
static mlr_quat correction(const rig_rest *src, const rig_rest *dst, int have, const double *ps,
                           const double *pt, mlr_quat g)
{
    if (!have)
        return g;
    /* the body axis least along either bone (the largest of the two cosines smallest), the
     * same axis on both */
    int axis = 0;
    double best = 2.0, u[3] = {ps[0], ps[1], ps[2]}, v[3] = {pt[0], pt[1], pt[2]};
    if (!normalize3(u) || !normalize3(v))
        return g;
    for (int a = 0; a < 3; a++) {
        const double cs[3] = {src->body[a], src->body[3 + a], src->body[6 + a]};
        const double ct[3] = {dst->body[a], dst->body[3 + a], dst->body[6 + a]};
        const double d = fmax(fabs(common__dot3(u, cs)), fabs(common__dot3(v, ct)));
        if (d < best)
            best = d, axis = a;
    }
    const double sa[3] = {src->body[axis], src->body[3 + axis], src->body[6 + axis]};
    const double ta[3] = {dst->body[axis], dst->body[3 + axis], dst->body[6 + axis]};
    double Ps[9], Pt[9], C[9];
    if (!frame_of(ps, sa, Ps) || !frame_of(pt, ta, Pt))
        return g;
    mul_abt(Ps, Pt, C);
    mlr_quat q;
    quat_of_matrix(C, &q);
    return q;
}

static mlr_status check_finite(const double *x, size_t n, const char *what, size_t per_frame,
                               mlr_diag *diag)
{
    const size_t i = common__first_nonfinite(x, n);
    if (i < n)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "retarget: %s: a value of frame %zu is not finite", what,
                                i / per_frame);
    return MLR_OK;
}

/* The roles of both rigs, the map applied, the humanoid minimum checked. */
static mlr_status pair_roles(rig_rest *src, rig_rest *dst, const char *const *map, size_t n_map,
                             const mlr_allocator *alloc, mlr_diag *diag)
{
    mlr_status st;
    if ((st = detect_roles(src->rig, src->role, alloc, diag)) != MLR_OK ||
        (st = detect_roles(dst->rig, dst->role, alloc, diag)) != MLR_OK)
        return st;
    if ((st = check_minimum(src->rig, src->role, "source", diag)) != MLR_OK)
        return st;
    if ((st = apply_map(src, dst, map, n_map, diag)) != MLR_OK)
        return st;
    complete_roles(dst->rig, dst->role);
    return check_minimum(dst->rig, dst->role, "target", diag);
}

/* What one target joint does: follow a source joint (with a correction), and for a chain
 * joint, point its bone along the source chain between two fractions. */
typedef struct follow_rec {
    int32_t src;     /* source joint, or -1: at rest */
    int8_t chain;    /* 0 none, 1 spine, 2 neck */
    double u0, u1;   /* fractions of the chain */
    double bone[3];  /* the target's rest bone (local = world at rest) */
    mlr_quat corr;
} follow_rec;

/* Both rigs valid (mlr_rig_check) and named: the checks that open mlr_retarget and
   mlr_retarget_feet. */
static mlr_status check_rigs(const mlr_rig *source, const mlr_rig *target, mlr_diag *diag)
{
    mlr_status st = mlr_rig_check(source, diag);
    if (st != MLR_OK)
        return common__diag_prefix(diag, st, "retarget: source");
    st = mlr_rig_check(target, diag);
    if (st != MLR_OK)
        return common__diag_prefix(diag, st, "retarget: target");
    if (!source->names || !target->names)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "retarget: the %s rig has no joint names to find roles by",
                                source->names ? "target" : "source");
    return MLR_OK;
}

mlr_status mlr_retarget(const mlr_rig *source, size_t n_frames, const double *root_pos,
                        const double *rot, const double *trans, const mlr_rig *target,
                        int source_up, int target_up, const char *const *map, size_t n_map,
                        double *out_root_pos, double *out_rot, double *out_trans,
                        mlr_retarget_info *info, const mlr_allocator *alloc, mlr_diag *diag)
{
    mlr_status st = check_rigs(source, target, diag);
    if (st != MLR_OK)
        return st;
    const size_t Js = source->n_joints, Jt = target->n_joints;
    const size_t Ps = source->n_trans, Pt = target->n_trans;
    if (n_frames &&
        (!root_pos || !rot || (Ps && !trans) || !out_root_pos || !out_rot || (Pt && !out_trans)))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "retarget: a frame array is NULL with %zu frames", n_frames);
    if (n_map && !map)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "retarget: map is NULL with %zu pairs", n_map);
    if (source_up < -1 || source_up > 2 || target_up < -1 || target_up > 2)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "retarget: up %d is not an axis or MLR_RETARGET_UP_REST",
                                source_up < -1 || source_up > 2 ? source_up : target_up);
    size_t nr, nq, nt;
    if (common__mul_size(n_frames, 3, &nr) || common__mul_size(n_frames, 4 * Js, &nq) ||
        common__mul_size(n_frames, 3 * Ps, &nt))
        return common__diag_set(diag, MLR_E_OVERFLOW, 0, 0, "retarget: the frames are too many");
    if ((st = check_finite(root_pos, nr, "root_pos", 3, diag)) != MLR_OK ||
        (st = check_finite(rot, nq, "rot", 4 * Js, diag)) != MLR_OK ||
        (Ps && (st = check_finite(trans, nt, "trans", 3 * Ps, diag)) != MLR_OK))
        return st;

    rig_rest src = {.rig = source}, dst = {.rig = target};
    if ((st = pair_roles(&src, &dst, map, n_map, alloc, diag)) != MLR_OK)
        return st;

    /* scratch: rest positions of both, the source frame's world pose, the target's */
    const size_t doubles = 3 * Js + 3 * Jt + 7 * Js + 7 * Jt;
    size_t bytes, rbytes;
    if (common__mul_size(doubles, sizeof(double), &bytes) != MLR_OK ||
        common__mul_size(Jt, sizeof(follow_rec), &rbytes) != MLR_OK || bytes + rbytes < bytes)
        return common__diag_set(diag, MLR_E_OVERFLOW, 0, 0, "retarget: too many joints");
    mlr_allocator a;
    common__allocator_resolve(alloc, &a);
    double *buf = common__alloc(&a, bytes + rbytes);
    if (!buf)
        return common__diag_set(diag, MLR_E_NO_MEMORY, 0, 0, "retarget: out of memory");
    src.pos = buf;
    dst.pos = src.pos + 3 * Js;
    double *s_wpos = dst.pos + 3 * Jt;
    double *s_wrot = s_wpos + 3 * Js;
    double *t_wpos = s_wrot + 4 * Js;
    double *t_wrot = t_wpos + 3 * Jt;
    follow_rec *fr = (follow_rec *)(void *)(t_wrot + 4 * Jt);
    size_t matched = 0;
    double G[9], scale = 0.0;
    double *drop = NULL, *hipq = NULL; /* N drops, N x 4 hips' parents, N of scratch */
    size_t dbytes = 0;

    if ((st = rest_setup(&src, "source", source_up, diag)) != MLR_OK ||
        (st = rest_setup(&dst, "target", target_up, diag)) != MLR_OK)
        goto done;
    mul_abt(src.world, dst.world, G); /* F_s F_t^T */
    mlr_quat g;
    quat_of_matrix(G, &g);
    const mlr_quat gc = qconj(g);
    double B[9]; /* the rest poses' body frames: the correction of a joint without a bone */
    mul_abt(src.body, dst.body, B);
    mlr_quat rb;
    quat_of_matrix(B, &rb);
    chain ss, sn, ts, tn;
    chains_of(&src, &ss, &sn);
    chains_of(&dst, &ts, &tn);
    for (size_t j = 0; j < Jt; j++)
        fr[j] = (follow_rec){.src = -1};
    for (int r = 0; r < MLR_ROLE_COUNT; r++) {
        const int32_t t = dst.role[r];
        const int sr = t >= 0 ? source_role(&src, &ss, &sn, &ts, &tn, r) : -1;
        if (sr < 0 || fr[t].src >= 0)
            continue;
        follow_rec *f = &fr[t];
        f->src = src.role[sr];
        matched++;
        double ps[3], pt[3];
        const int have = r != MLR_ROLE_HIPS && bone_end(&src, sr, ps) && bone_end(&dst, r, pt);
        if (have)
            for (int c = 0; c < 3; c++) {
                ps[c] -= src.pos[3 * (size_t)f->src + (size_t)c];
                pt[c] -= dst.pos[3 * (size_t)t + (size_t)c];
            }
        f->corr = correction(&src, &dst, have, ps, pt, rb);
        const int is_spine = r >= MLR_ROLE_SPINE && r < MLR_ROLE_SPINE + MLR_RETARGET_MAX_SPINE;
        const int is_neck = r >= MLR_ROLE_NECK && r < MLR_ROLE_NECK + MLR_RETARGET_MAX_NECK;
        const chain *sc = is_spine ? &ss : &sn, *tc = is_spine ? &ts : &tn;
        if ((is_spine || is_neck) && have && sc->ok && tc->ok) {
            const int k = r - (is_spine ? MLR_ROLE_SPINE : MLR_ROLE_NECK);
            f->chain = (int8_t)(is_spine ? 1 : 2);
            f->u0 = tc->u[k], f->u1 = tc->u[k + 1];
            memcpy(f->bone, pt, sizeof pt);
        }
    }
    /* joints without a role on either rig follow the source joint of their name, or, for the
     * fingers, the joint of the same finger of the same hand at the same place from its tip */
    for (size_t j = 0; j < Jt; j++) {
        int roled = 0;
        for (int r = 0; r < MLR_ROLE_COUNT; r++)
            roled |= dst.role[r] == (int32_t)j;
        int32_t s = roled || fr[j].src >= 0 ? -1 : find_joint(source, target->names[j]);
        for (int r = 0; s >= 0 && r < MLR_ROLE_COUNT; r++)
            if (src.role[r] == s)
                s = -1;
        if (s < 0 && !roled && fr[j].src < 0)
            s = finger_source(&src, &dst, (int32_t)j); /* the same finger of the same hand */
        if (s < 0)
            continue;
        double ps[3], pt[3];
        const int have = plain_bone_end(&src, s, ps) && plain_bone_end(&dst, (int32_t)j, pt);
        if (have)
            for (int c = 0; c < 3; c++) {
                ps[c] -= src.pos[3 * (size_t)s + (size_t)c];
                pt[c] -= dst.pos[3 * j + (size_t)c];
            }
        fr[j].src = s;
        fr[j].corr = correction(&src, &dst, have, ps, pt, rb);
        matched++;
    }

    const int32_t hips_t = dst.role[MLR_ROLE_HIPS];
    scale = dst.leg / src.leg;
    const long hips_row = hips_t > 0 ? mirror__rig_trans_row(target, hips_t) : -1;
    const int32_t tl = dst.role[MLR_ROLE_LEFT_UPPER_LEG], tr = dst.role[MLR_ROLE_RIGHT_UPPER_LEG];
    const size_t last_leg = (size_t)(tl > tr ? tl : tr);
    /* the soles: per frame, the ankles above their feet's lowest points, target less scaled
     * source, the mean of both sides; their median raises the whole motion (A -> B -> A: the
     * way back's is minus this one over s, so the round trip cancels it) */
    if (n_frames) {
        if (common__mul_size(n_frames, 6 * sizeof(double), &dbytes) != MLR_OK) {
            st = common__diag_set(diag, MLR_E_OVERFLOW, 0, 0, "retarget: the frames are too many");
            goto done;
        }
        drop = common__alloc(&a, dbytes);
        if (!drop) {
            st = common__diag_set(diag, MLR_E_NO_MEMORY, 0, 0, "retarget: out of memory");
            goto done;
        }
        hipq = drop + n_frames;
    }
    const double up_s[3] = {src.world[1], src.world[4], src.world[7]};
    const double up_t[3] = {dst.world[1], dst.world[4], dst.world[7]};
    for (size_t f = 0; f < n_frames; f++) {
        st = mlr_fk_arrays(1, Js, source->parents, source->offsets, root_pos + 3 * f,
                           rot + 4 * Js * f, Ps, source->trans_joints,
                           Ps ? trans + 3 * Ps * f : NULL, s_wpos, s_wrot, alloc, diag);
        if (st != MLR_OK)
            goto done;
        const mlr_quat *sw = (const mlr_quat *)(const void *)s_wrot;
        mlr_quat *tw = (mlr_quat *)(void *)t_wrot;
        double *orot = out_rot + 4 * Jt * f;
        for (size_t j = 0; j < Jt; j++) {
            const int32_t p = target->parents[j];
            const follow_rec *rec = &fr[j];
            mlr_quat w;
            if (rec->src >= 0) {
                w = qmul(qmul(gc, sw[rec->src]), rec->corr);
                if (rec->chain) {
                    /* the bone along the source chain between the same fractions */
                    const chain *c = rec->chain == 1 ? &ss : &sn;
                    double d[3], want[3], cur[3];
                    chain_span(c, &src, s_wpos, sw, rec->u0, rec->u1, d);
                    common__quat_rotate_inline(&gc, d, want);
                    common__quat_rotate_inline(&w, rec->bone, cur);
                    w = qmul(swing(cur, want), w);
                }
            } else {
                w = p >= 0 ? tw[p] : (mlr_quat){1.0, 0.0, 0.0, 0.0};
            }
            tw[j] = w;
            const mlr_quat local = p >= 0 ? qmul(qconj(tw[p]), w) : w;
            orot[4 * j] = local.w, orot[4 * j + 1] = local.x, orot[4 * j + 2] = local.y,
                     orot[4 * j + 3] = local.z;
        }
        /* the target's translations at rest, then the hips moved so that the middle of the
         * upper legs is where the scaled source's is, raised by the difference of the soles */
        const double *sl = s_wpos + 3 * (size_t)src.role[MLR_ROLE_LEFT_UPPER_LEG];
        const double *sr = s_wpos + 3 * (size_t)src.role[MLR_ROLE_RIGHT_UPPER_LEG];
        double want[3], hs[3];
        for (int c = 0; c < 3; c++)
            hs[c] = 0.5 * (sl[c] + sr[c]) * scale;
        common__quat_rotate_inline(&gc, hs, want);
        double *oroot = out_root_pos + 3 * f;
        double *otr = Pt ? out_trans + 3 * Pt * f : NULL;
        for (int c = 0; c < 3; c++)
            oroot[c] = target->offsets[c];
        for (size_t i = 0; i < Pt; i++)
            for (int c = 0; c < 3; c++)
                otr[3 * i + (size_t)c] =
                    target->offsets[3 * (size_t)target->trans_joints[i] + (size_t)c];
        /* world positions down to the upper legs, the root translation at its OFFSET */
        for (int c = 0; c < 3; c++)
            t_wpos[c] = oroot[c];
        for (size_t j = 1; j <= last_leg; j++) {
            const int32_t p = target->parents[j];
            double v[3];
            common__quat_rotate_inline(&tw[p], target->offsets + 3 * j, v);
            for (int c = 0; c < 3; c++)
                t_wpos[3 * j + (size_t)c] = t_wpos[3 * (size_t)p + (size_t)c] + v[c];
        }
        double shift[3];
        for (int c = 0; c < 3; c++)
            shift[c] = want[c] - 0.5 * (t_wpos[3 * (size_t)tl + (size_t)c] +
                                        t_wpos[3 * (size_t)tr + (size_t)c]);
        if (hips_row >= 0) {
            const mlr_quat pc = qconj(tw[target->parents[hips_t]]);
            double v[3];
            common__quat_rotate_inline(&pc, shift, v);
            for (int c = 0; c < 3; c++)
                otr[3 * (size_t)hips_row + (size_t)c] += v[c];
            memcpy(hipq + 4 * f, &pc, sizeof pc);
        } else {
            for (int c = 0; c < 3; c++)
                oroot[c] += shift[c];
        }
        drop[f] = 0.0;
        for (int k = 0; k < 2; k++)
            drop[f] += 0.5 * (foot_drop(&dst, k, tw, up_t) - scale * foot_drop(&src, k, sw, up_s));
    }
    if (n_frames) {
        double *tmp = hipq + 4 * n_frames; /* the median reorders: a copy */
        memcpy(tmp, drop, n_frames * sizeof(double));
        const double lift = common__median(tmp, n_frames);
        for (size_t f = 0; f < n_frames; f++) {
            const double v[3] = {lift * up_t[0], lift * up_t[1], lift * up_t[2]};
            if (hips_row >= 0) {
                double w[3];
                mlr_quat q;
                memcpy(&q, hipq + 4 * f, sizeof q);
                common__quat_rotate_inline(&q, v, w);
                for (int c = 0; c < 3; c++)
                    out_trans[3 * (Pt * f + (size_t)hips_row) + (size_t)c] += w[c];
            } else {
                for (int c = 0; c < 3; c++)
                    out_root_pos[3 * f + (size_t)c] += v[c];
            }
        }
    }
    if (info) {
        info->scale = scale;
        info->n_matched = matched;
        memcpy(info->to_source, G, sizeof G);
    }
done:
    if (drop)
        common__free(&a, drop, dbytes);
    common__free(&a, buf, bytes + rbytes);
    return st;
}

/* ---- the feet ----------------------------------------------------------------------------- */

/* The contact points of a rig's feet: per side the ankle, then the toes or else the ankle's
 * first End Site; their count. */
static size_t foot_points(const rig_rest *r, int32_t *joints, int32_t *ends, int *kind)
{
    const mlr_rig *rig = r->rig;
    size_t n = 0;
    for (int side = 0; side < 2; side++) {
        const int foot = side == 0 ? MLR_ROLE_LEFT_FOOT : MLR_ROLE_RIGHT_FOOT;
        joints[n] = r->role[foot], ends[n] = -1, kind[n] = 2 * side, n++;
        if (r->role[foot + 1] >= 0) {
            joints[n] = r->role[foot + 1], ends[n] = -1, kind[n] = 2 * side + 1, n++;
            continue;
        }
        for (size_t e = 0; e < rig->n_end_sites; e++)
            if (rig->end_site_parents[e] == r->role[foot]) {
                joints[n] = r->role[foot], ends[n] = (int32_t)e, kind[n] = 2 * side + 1, n++;
                break;
            }
    }
    return n;
}

/* The lowest foot point of each frame along up (axis up, positive): the ankles, the toes and
 * the End Sites below them. wpos and wrot are scratch of N x J x 3 and N x J x 4 (the frames'
 * forward kinematics); out (N) may be wpos itself. */
static void lowest_foot(const rig_rest *r, size_t n_frames, const double *root_pos,
                        const double *rot, const double *trans, int up, double *wpos, double *wrot,
                        double *out)
{
    const mlr_rig *rig = r->rig;
    const size_t J = rig->n_joints;
    (void)mlr_fk_arrays(n_frames, J, rig->parents, rig->offsets, root_pos, rot, rig->n_trans,
                        rig->trans_joints, trans, wpos, wrot, NULL, NULL);
    int32_t pts[4];
    size_t np = 0;
    for (int side = 0; side < 2; side++) {
        const int foot = side == 0 ? MLR_ROLE_LEFT_FOOT : MLR_ROLE_RIGHT_FOOT;
        pts[np++] = r->role[foot];
        if (r->role[foot + 1] >= 0)
            pts[np++] = r->role[foot + 1];
    }
    for (size_t f = 0; f < n_frames; f++) {
        double lo = INFINITY;
        for (size_t i = 0; i < np; i++)
            lo = fmin(lo, wpos[3 * (f * J + (size_t)pts[i]) + (size_t)up]);
        for (size_t e = 0; e < rig->n_end_sites; e++) {
            const int32_t j = rig->end_site_parents[e];
            int mine = 0;
            for (size_t i = 0; i < np; i++)
                mine |= j == pts[i];
            if (!mine)
                continue;
            double v[3];
            const mlr_quat *q = (const mlr_quat *)(const void *)(wrot + 4 * (f * J + (size_t)j));
            common__quat_rotate_inline(q, rig->end_site_offsets + 3 * e, v);
            lo = fmin(lo, wpos[3 * (f * J + (size_t)j) + (size_t)up] + v[up]);
        }
        out[f] = lo; /* f <= 3 f J: out may overlay wpos */
    }
}

/* A target toe joint that no source joint drives (the source has no toe role on that side)
 * stays at rest on its foot, and where the foot pitches down on the ground (the heel up) its
 * tip would go into the ground, which the source's toes, bending, did not: on the frames where
 * its foot is planted, the toe keeps the pitch against the ground that its bone has at rest
 * (flat; its tip never lower against the toe joint than at rest). The shortfall of the toe
 * bone's elevation below its rest elevation (radians) is made up by a turn of the toe about the
 * level axis across it, eased in by a C1 ramp of TOE_LEVEL_EASE radians (no turn where the toe
 * is higher than at rest by more than that, the shortfall and a little more within it, the
 * shortfall itself beyond), times a weight that is 1 on the foot's contact frames and eases to
 * 0 within 0.2 s of them (raise_feet's envelope): the toe hangs from its foot in the air. */
#define TOE_LEVEL_EASE 0.0873 /* radians (5 degrees) */

typedef struct toe_level {
    int32_t j;      /* the toe joint, or -1 */
    double bone[3]; /* its rest bone (rest world = its local frame) */
    double elev;    /* the bone's rest elevation along up, radians */
} toe_level;

/* The toes of the target whose side has no toe role in the source, whose parent is the foot,
 * with a bone; tl[k] for side k. */
static void toe_levels(const rig_rest *src, const rig_rest *dst, const double *up, toe_level *tl)
{
    for (int k = 0; k < 2; k++) {
        const int role = k == 0 ? MLR_ROLE_LEFT_TOES : MLR_ROLE_RIGHT_TOES;
        const int32_t t = dst->role[role];
        double end[3];
        tl[k].j = -1;
        if (t <= 0 || src->role[role] >= 0 || dst->rig->parents[t] != dst->role[role - 1] ||
            !bone_end(dst, role, end))
            continue;
        for (int c = 0; c < 3; c++)
            tl[k].bone[c] = end[c] - dst->pos[3 * (size_t)t + (size_t)c];
        const double n = sqrt(common__dot3(tl[k].bone, tl[k].bone));
        if (!(n > 0.0))
            continue;
        tl[k].j = t;
        tl[k].elev = asin(fmax(-1.0, fmin(1.0, common__dot3(tl[k].bone, up) / n)));
    }
}

/* The turn (a unit quaternion, applied on the left of the toe's world rotation w) that brings a
 * toe of toe_levels up to its rest elevation (see above), scaled by weight. */
static mlr_quat toe_level_turn(const toe_level *tl, mlr_quat w, const double *up, double weight)
{
    double cur[3], axis[3];
    const mlr_quat one = {1.0, 0.0, 0.0, 0.0};
    common__quat_rotate_inline(&w, tl->bone, cur);
    const double n = sqrt(common__dot3(cur, cur));
    const double e = asin(fmax(-1.0, fmin(1.0, common__dot3(cur, up) / n)));
    const double d = tl->elev - e, h = TOE_LEVEL_EASE;
    double turn = d >= h ? d : d <= -h ? 0.0 : (d + h) * (d + h) / (4.0 * h);
    turn = weight * fmin(turn, 0.5 * 3.14159265358979323846 - e); /* never past the vertical */
    common__cross3(cur, up, axis);
    if (!(turn > 0.0) || !normalize3(axis))
        return one;
    const double sh = sin(0.5 * turn);
    return (mlr_quat){cos(0.5 * turn), sh * axis[0], sh * axis[1], sh * axis[2]};
}

/* The toes of toe_levels turned up on their feet's contact frames (ct: N x nt flags of the
 * target's points of kinds tk), eased in time; out_rot rewritten. */
static mlr_status level_toes(const rig_rest *src, const rig_rest *dst, size_t n_frames, double fps,
                             const double *up, const double *root_pos, double *rot,
                             const double *trans, size_t nt, const int *tk, const uint8_t *ct,
                             const mlr_allocator *a, mlr_diag *diag)
{
    toe_level tl[2];
    toe_levels(src, dst, up, tl);
    if (tl[0].j < 0 && tl[1].j < 0)
        return MLR_OK;
    const mlr_rig *rig = dst->rig;
    const size_t J = rig->n_joints;
    size_t nd, bytes;
    if (common__mul_size(n_frames, 7 * J + 2, &nd) != MLR_OK ||
        common__mul_size(nd, sizeof(double), &bytes) != MLR_OK)
        return common__diag_set(diag, MLR_E_OVERFLOW, 0, 0, "retarget: the frames are too many");
    double *wpos = common__alloc(a, bytes);
    if (!wpos)
        return common__diag_set(diag, MLR_E_NO_MEMORY, 0, 0, "retarget: out of memory");
    double *wrot = wpos + 3 * n_frames * J, *on = wrot + 4 * n_frames * J, *weight = on + n_frames;
    mlr_status st = mlr_fk_arrays(n_frames, J, rig->parents, rig->offsets, root_pos, rot,
                                  rig->n_trans, rig->trans_joints, trans, wpos, wrot, a, diag);
    for (int k = 0; k < 2 && st == MLR_OK; k++) {
        if (tl[k].j < 0)
            continue;
        for (size_t f = 0; f < n_frames; f++) {
            on[f] = 0.0;
            for (size_t i = 0; i < nt; i++)
                if ((tk[i] >> 1) == k && ct[f * nt + i])
                    on[f] = 1.0;
        }
        /* eased over 0.1 s (floor_lift.c's envelope, its ramps fixed) */
        memset(weight, 0, n_frames * sizeof(double));
        if ((st = floor_lift__envelope(n_frames, fps, on, INFINITY, weight, 1, a)) != MLR_OK) {
            common__diag_set(diag, st, 0, 0, "retarget: out of memory");
            break;
        }
        const size_t t = (size_t)tl[k].j;
        for (size_t f = 0; f < n_frames; f++) {
            mlr_quat w, pw;
            memcpy(&w, wrot + 4 * (f * J + t), sizeof w);
            memcpy(&pw, wrot + 4 * (f * J + (size_t)rig->parents[t]), sizeof pw);
            const mlr_quat q = toe_level_turn(&tl[k], w, up, weight[f]);
            const mlr_quat local = qmul(qconj(pw), qmul(q, w));
            double *o = rot + 4 * (f * J + t);
            o[0] = local.w, o[1] = local.x, o[2] = local.y, o[3] = local.z;
        }
    }
    common__free(a, wpos, bytes);
    return st;
}

/* Raise the target's whole body along up (its root translation) where its lowest foot point is
 * below ground: by a smooth envelope of the shortfall (floor_lift__envelope with its ramps fixed
 * at 0.1 s: the largest within +-0.1 s, averaged with a raised-cosine window of the same width,
 * so it covers every frame's shortfall and is zero farther than 0.2 s from any). */
static mlr_status raise_feet(const rig_rest *r, size_t n_frames, double fps, int up, double ground,
                             double *root_pos, const double *rot, const double *trans,
                             const mlr_allocator *a, mlr_diag *diag)
{
    const size_t J = r->rig->n_joints;
    size_t nd, bytes;
    if (common__mul_size(n_frames, 7 * J + 1, &nd) != MLR_OK ||
        common__mul_size(nd, sizeof(double), &bytes) != MLR_OK)
        return common__diag_set(diag, MLR_E_OVERFLOW, 0, 0, "retarget: the frames are too many");
    double *wpos = common__alloc(a, bytes);
    if (!wpos)
        return common__diag_set(diag, MLR_E_NO_MEMORY, 0, 0, "retarget: out of memory");
    double *wrot = wpos + 3 * n_frames * J, *need = wrot + 4 * n_frames * J;
    lowest_foot(r, n_frames, root_pos, rot, trans, up, wpos, wrot, need);
    for (size_t f = 0; f < n_frames; f++)
        need[f] = fmax(0.0, ground - need[f]);
    const mlr_status st =
        floor_lift__envelope(n_frames, fps, need, INFINITY, root_pos + (size_t)up, 3, a);
    common__free(a, wpos, bytes);
    return st == MLR_OK ? MLR_OK : common__diag_set(diag, st, 0, 0, "retarget: out of memory");
}

mlr_status mlr_retarget_feet(const mlr_rig *source, size_t n_frames, double fps, int up,
                             const double *root_pos, const double *rot, const double *trans,
                             const mlr_rig *target, int target_up, const char *const *map,
                             size_t n_map, double *out_root_pos, double *out_rot,
                             const double *out_trans, mlr_cleanup_report *report,
                             const mlr_allocator *alloc, mlr_diag *diag)
{
    mlr_status st = check_rigs(source, target, diag);
    if (st != MLR_OK)
        return st;
    if (up < 0 || up > 2)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "retarget: up %d is not an axis",
                                up);
    if (target_up < -1 || target_up > 2)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "retarget: up %d is not an axis or MLR_RETARGET_UP_REST",
                                target_up);
    if (!(fps > 0) || !isfinite(fps))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "retarget: fps must be > 0");
    const size_t Js = source->n_joints, Jt = target->n_joints;
    if (n_frames < 3)
        return MLR_OK; /* too short for contacts */
    if (!root_pos || !rot || (source->n_trans && !trans) || !out_root_pos || !out_rot ||
        (target->n_trans && !out_trans))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "retarget: a frame array is NULL with %zu frames", n_frames);
    rig_rest src = {.rig = source}, dst = {.rig = target};
    if ((st = pair_roles(&src, &dst, map, n_map, alloc, diag)) != MLR_OK)
        return st;
    /* scratch: both rest poses; the source's forward kinematics (N x Js x 7); its contact
     * points (N x 4 x 3); the target's reference points (N x 4 x 3), whose place first holds N
     * doubles and the target's forward kinematics (N x Jt x 7); then the contacts */
    size_t nw, bytes;
    if (common__mul_size(n_frames, 7 * (Js + Jt) + 24, &nw) != MLR_OK ||
        nw > SIZE_MAX - 3 * (Js + Jt) ||
        common__mul_size(nw + 3 * (Js + Jt), sizeof(double), &bytes) != MLR_OK ||
        bytes > SIZE_MAX - 2 * 4 * n_frames)
        return common__diag_set(diag, MLR_E_OVERFLOW, 0, 0, "retarget: the frames are too many");
    const size_t cbytes = 2 * 4 * n_frames; /* the source's and the target's contacts */
    mlr_allocator a;
    common__allocator_resolve(alloc, &a);
    double *buf = common__alloc(&a, bytes + cbytes);
    if (!buf)
        return common__diag_set(diag, MLR_E_NO_MEMORY, 0, 0, "retarget: out of memory");
    src.pos = buf;
    dst.pos = src.pos + 3 * Js;
    double *wpos = dst.pos + 3 * Jt, *wrot = wpos + 3 * n_frames * Js;
    uint8_t *cs = (uint8_t *)(void *)(buf + 3 * (Js + Jt) + nw), *ct = cs + 4 * n_frames;
    if ((st = rest_setup(&src, "source", up, diag)) != MLR_OK ||
        (st = rest_setup(&dst, "target", target_up, diag)) != MLR_OK)
        goto done;
    int32_t sj[4], se[4], tj[4], te[4];
    int sk[4], tk[4];
    const size_t ns = foot_points(&src, sj, se, sk);
    size_t nt = foot_points(&dst, tj, te, tk);
    {
        /* a toe point of the target stays when the source has one of the same nature (a toe
         * joint for a toe joint, an End Site for an End Site): a toe joint pinned where the
         * source's toe tip is would tip the foot over (Axis Neuron's feet end in an End Site
         * on the ground, CMU's toe joints stand above theirs) */
        size_t n = 0;
        for (size_t i = 0; i < nt; i++) {
            int keep = !(tk[i] & 1);
            for (size_t k = 0; k < ns && !keep; k++)
                keep = sk[k] == tk[i] && (se[k] >= 0) == (te[i] >= 0);
            if (keep)
                tj[n] = tj[i], te[n] = te[i], tk[n] = tk[i], n++;
        }
        nt = n;
    }
    if ((st = mlr_fk_arrays(n_frames, Js, source->parents, source->offsets, root_pos, rot,
                            source->n_trans, source->trans_joints, trans, wpos, wrot, alloc,
                            diag)) != MLR_OK ||
        (st = mlr_contacts_detect(source, fps, up, n_frames, wpos, wrot, ns, sj, se, NULL, 0, cs,
                                  alloc, diag)) != MLR_OK)
        goto done;
    /* each target point takes the contacts of the source point of its kind (ankle or toe), or
     * of that side's ankle */
    for (size_t i = 0; i < nt; i++) {
        size_t from = ns;
        for (size_t k = 0; k < ns; k++)
            if (sk[k] == tk[i])
                from = k;
        for (size_t k = 0; k < ns && from == ns; k++)
            if (sk[k] == (tk[i] & ~1))
                from = k; /* the ankle is always there */
        for (size_t f = 0; f < n_frames; f++)
            ct[f * nt + i] = cs[f * ns + from];
        /* an ankle without a toe point of its own takes the source's toe contacts too: its
         * foot stands on the toes there (the heel up), and the ankle follows the source's */
        int own_toe = 0;
        for (size_t k = 0; k < nt; k++)
            own_toe |= tk[k] == (tk[i] | 1);
        for (size_t k = 0; k < ns && !(tk[i] & 1) && !own_toe; k++)
            if (sk[k] == (tk[i] | 1))
                for (size_t f = 0; f < n_frames; f++)
                    ct[f * nt + i] |= cs[f * ns + k];
    }
    /* the target's up: where G^T takes the source's (the body frames are signed axes) */
    double G[9];
    mul_abt(src.world, dst.world, G);
    int tup = 0;
    for (int c = 1; c < 3; c++)
        if (fabs(G[3 * up + c]) > fabs(G[3 * up + tup]))
            tup = c;
    const double sign = G[3 * up + tup];
    const double scale = dst.leg / src.leg;
    /* the reference of the target's contact points: the source's points of their kind, mapped
     * by G^T and scaled by s, raised by the placement's lift (the median over frames of the
     * target's upper legs' middle above the scaled source's, along the target's up: the soles'
     * difference of mlr_retarget) */
    double *sp = wpos + 7 * n_frames * Js; /* N x ns x 3 source points, then N x nt x 3 */
    double *rp = sp + 12 * n_frames;
    if ((st = mlr_rig_point_positions(source, n_frames, wpos, wrot, ns, sj, se, sp, diag)) !=
        MLR_OK)
        goto done;
    const double up_t[3] = {dst.world[1], dst.world[4], dst.world[7]};
    double lift;
    {
        /* the source's upper legs' middle of each frame, then the target's (its forward
         * kinematics over the source's, no longer needed) */
        const int32_t sl = src.role[MLR_ROLE_LEFT_UPPER_LEG],
                      sr = src.role[MLR_ROLE_RIGHT_UPPER_LEG];
        const int32_t tl = dst.role[MLR_ROLE_LEFT_UPPER_LEG],
                      tr = dst.role[MLR_ROLE_RIGHT_UPPER_LEG];
        double *mid = rp; /* N of scratch (rp is written later) */
        for (size_t f = 0; f < n_frames; f++) {
            double m[3], y[3];
            for (int c = 0; c < 3; c++)
                m[c] = 0.5 * scale *
                       (wpos[3 * (f * Js + (size_t)sl) + (size_t)c] +
                        wpos[3 * (f * Js + (size_t)sr) + (size_t)c]);
            for (int r = 0; r < 3; r++)
                y[r] = G[r] * m[0] + G[3 + r] * m[1] + G[6 + r] * m[2];
            mid[f] = -common__dot3(y, up_t);
        }
        double *tpos = mid + n_frames, *trot = tpos + 3 * n_frames * Jt;
        if ((st = mlr_fk_arrays(n_frames, Jt, target->parents, target->offsets, out_root_pos,
                                out_rot, target->n_trans, target->trans_joints, out_trans, tpos,
                                trot, alloc, diag)) != MLR_OK)
            goto done;
        for (size_t f = 0; f < n_frames; f++) {
            double m[3];
            for (int c = 0; c < 3; c++)
                m[c] = 0.5 * (tpos[3 * (f * Jt + (size_t)tl) + (size_t)c] +
                              tpos[3 * (f * Jt + (size_t)tr) + (size_t)c]);
            mid[f] += common__dot3(m, up_t);
        }
        lift = common__median(mid, n_frames);
    }
    for (size_t f = 0; f < n_frames; f++)
        for (size_t i = 0; i < nt; i++) {
            size_t from = ns;
            for (size_t k = 0; k < ns; k++)
                if (sk[k] == tk[i])
                    from = k;
            for (size_t k = 0; k < ns && from == ns; k++)
                if (sk[k] == (tk[i] & ~1))
                    from = k;
            const double *x = sp + 3 * (f * ns + from);
            double *y = rp + 3 * (f * nt + i);
            for (int r = 0; r < 3; r++)
                y[r] = scale * (G[r] * x[0] + G[3 + r] * x[1] + G[6 + r] * x[2]) + lift * up_t[r];
        }
    /* the cleanup: each contact run of the target follows the reference's trajectory, shifted
     * horizontally by the run's mean offset, at its heights; the floor is the reference's (the
     * scaled source's); off when up does not map onto a positive axis of the target */
    mlr_cleanup_option opts[2];
    size_t n_opts = 0;
    opts[n_opts++] = (mlr_cleanup_option){MLR_CLEANUP_OPT_REF_SMOOTH, 0.0};
    if (!(sign > 0.5))
        opts[n_opts++] = (mlr_cleanup_option){MLR_CLEANUP_OPT_FLOOR, 0.0};
    mlr_cleanup_ref *ref = NULL;
    if ((st = cleanup__ref_of_points(target, n_frames, fps, tup, nt, tj, te, rp, opts, n_opts,
                                     alloc, &ref, diag)) != MLR_OK)
        goto done;
    st = cleanup__contacts_ref(target, n_frames, fps, tup, out_root_pos, out_rot, out_trans, ref,
                               0, NULL, nt, tj, te, ct, opts, n_opts, out_root_pos, out_rot,
                               report, alloc, diag);
    cleanup__ref_destroy(ref);
    if (st == MLR_OK)
        st = level_toes(&src, &dst, n_frames, fps, up_t, out_root_pos, out_rot, out_trans, nt, tk,
                        ct, &a, diag);
    /* the soles on the contact frames: mlr_retarget raised the target by the median over all
     * frames of the ankles' heights above their feet's lowest points (target less scaled
     * source), and the cleanup put the ankles at the reference's heights; where the feet
     * pitch otherwise in the air than on the ground, or the source's feet are shaped by
     * position channels the target does not carry, the soles of the contact frames are left
     * apart. The rest of their difference, the median over the source's contact frames of the
     * scaled source's lowest foot point less the target's, raises the whole target (a round trip
     * undoes it, as it undoes the lift: the way back's median is minus this one over s). Only
     * where up maps onto a positive axis of the target. */
    double src_ground = -INFINITY;
    if (st == MLR_OK && sign > 0.5) {
        double *alow = wpos, *blow = rp; /* over the frames no longer needed */
        lowest_foot(&src, n_frames, root_pos, rot, trans, up, wpos, wrot, alow);
        lowest_foot(&dst, n_frames, out_root_pos, out_rot, out_trans, tup, blow,
                    blow + 3 * n_frames * Jt, blow);
        size_t m = 0;
        for (size_t f = 0; f < n_frames; f++) {
            int any = 0;
            for (size_t i = 0; i < ns; i++)
                any |= cs[f * ns + i] != 0;
            if (any)
                blow[m++] = scale * alow[f] - blow[f];
        }
        const double sole = m ? common__median(blow, m) : 0.0;
        for (size_t f = 0; f < n_frames; f++)
            out_root_pos[3 * f + (size_t)tup] += sole;
        /* the scaled source's ground: the 0.05 quantile of its lowest foot point over its
         * contact frames */
        double *v = wpos + n_frames;
        m = 0;
        for (size_t f = 0; f < n_frames; f++) {
            int any = 0;
            for (size_t i = 0; i < ns; i++)
                any |= cs[f * ns + i] != 0;
            if (any)
                v[m++] = alow[f];
        }
        if (m)
            src_ground = scale * cleanup__quantile_of(v, m, 0.05);
    }
    if (st == MLR_OK && sign > 0.5) {
        /* the last word, as the guards' (guards.c, raise_to_floor): the ground the target's
         * feet stand on (the 0.05 quantile over its contact frames of its lowest foot point,
         * End Sites included) or the scaled source's, the higher, and the whole body raised
         * smoothly wherever a foot point of the result is below it, also where the source's
         * own foot went below its floor (the target's feet stay on the ground it is placed
         * on; a round trip gives back the source raised there). */
        double *low = sp; /* N lows, then the target's forward kinematics */
        lowest_foot(&dst, n_frames, out_root_pos, out_rot, out_trans, tup, sp + n_frames,
                    sp + n_frames + 3 * n_frames * Jt, low);
        size_t m = 0;
        for (size_t f = 0; f < n_frames; f++) {
            int any = 0;
            for (size_t i = 0; i < nt; i++)
                any |= ct[f * nt + i] != 0;
            if (any)
                low[m++] = low[f];
        }
        if (m) {
            const double ground = fmax(cleanup__quantile_of(low, m, 0.05), src_ground);
            st = raise_feet(&dst, n_frames, fps, tup, ground, out_root_pos, out_rot, out_trans, &a,
                            diag);
        }
    }
done:
    common__free(&a, buf, bytes + cbytes);
    return st;
}
