/*
 * Left/right mirroring of a motion: the joint pairs of a rig found by name, the body's
 * sagittal plane, and the motion reflected across it with the sides swapped.
 *
 * The mirror is a reflection M = I - 2 e_a e_a^T across the plane through the origin normal
 * to a world axis a (the body's left-right axis), composed with the joint permutation s that
 * swaps each left joint with its right partner (s(j) = j for joints on the mid-plane). For
 * world positions x_j and world rotations W_j of the input, the exact mirror image has
 *     x'_j = M x_{s(j)},   W'_j = M W_{s(j)} M,
 * which holds frame by frame when
 *     R'_j = M R_{s(j)} M  (local rotations),  t'_j = M t_{s(j)}  (local translations:
 *     root_pos, the position channels and the OFFSETs; End Sites likewise),
 * provided s maps the hierarchy onto itself (parent(s(j)) = s(parent(j))). In quaternions
 * (w, x, y, z), M q M keeps w and the a-component and negates the other two; a translation
 * has its a-component negated. Mirroring twice gives the input back (M M = I, s s = id):
 * bit for bit, since only signs change.
 *
 * Real skeletons are not symmetric (one CMU bone pair differs by 7%), so the exact mirror
 * image needs the mirrored OFFSETs too (mlr_mirror_motion's out_offsets). With
 * MLR_MIRROR_KEEP_SKELETON the OFFSETs (and End Sites) stay the input's and only the motion
 * is mirrored: the rotations of the swapped joints drive the other side's bones.
 *
 * Joint pairs by name (mlr_mirror_pairs). For each joint, in joint order, the first of these
 * rules that turns its name into the name of another joint not yet paired pairs the two:
 *  1. every "left" <-> "right", ASCII case-insensitive, the case kept (Left/Right, left/right,
 *     LEFT/RIGHT): LeftUpLeg, leftEye, mixamorig:LeftArm, CMU's LeftHip;
 *  2. a one-letter token L/R or l/r between separators (_ . - : | space) or the ends of the
 *     name, at least one of them a separator: Hand_L, upperarm_l, Hand.L, eye.l, L_Hand,
 *     Bip01 L Thigh;
 *  3. L/R or l/r starting the name (or a token after a separator) before an upper-case
 *     letter: lHip, rShldr, LHipJoint, LThumb;
 *  4. l/r starting the name (or a token after a separator) before a lower-case letter:
 *     MakeHuman's lcollar, rhip, __lthumb (last, as it fits many words; the other name must
 *     exist all the same).
 * The rules are involutions, so the partner's rule finds the joint back. Joints without a
 * partner are on the mid-plane. The letter or word that was swapped also tells the side
 * (+1 left, -1 right).
 */
#ifndef MLR_MIRROR_H
#define MLR_MIRROR_H

#include <stdint.h>

#include "mlr_common.h"
#include "mlr_rig.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Flags of the mirror functions (an unsigned bitmask). Values pinned. */
typedef enum mlr_mirror_flag {
    MLR_MIRROR_GIVEN_ONLY = 1u,   /**< mlr_mirror_pairs: only the given pairs, none by name */
    MLR_MIRROR_KEEP_SKELETON = 2u /**< mlr_mirror_motion: keep the OFFSETs and End Sites */
} mlr_mirror_flag;

/** The plane argument of mlr_mirror_plane that asks for the left-right axis of the rig. */
enum { MLR_MIRROR_PLANE_AUTO = -1 };

/**
 * The left/right partner of every joint: the given pairs, then (unless MLR_MIRROR_GIVEN_ONLY)
 * the rules of the file comment for the joints no given pair names. Then the permutation is
 * checked: it must map the hierarchy onto itself (the parent of a joint's partner is the
 * partner of its parent), pair joints with position channels only with joints that have them,
 * and pair joints with the same number of End Sites.
 * @param rig      [in] a valid rig (mlr_rig_check); names required unless GIVEN_ONLY with no
 *                 given pair
 * @param given    [in] 2 n_given joint names, pair k = (given[2k], given[2k+1]); NULL when
 *                 n_given is 0
 * @param n_given  [in] number of given pairs
 * @param flags    [in] 0 or MLR_MIRROR_GIVEN_ONLY
 * @param partner  [out] J entries: the joint's partner, or the joint itself (mid-plane)
 * @param side     [out] J entries or NULL: +1 left, -1 right (by the rule that paired them;
 *                 for a given pair, by the rule that turns one name into the other when there
 *                 is one), 0 mid-plane or unknown
 * @param n_pairs  [out] or NULL: the number of pairs
 * @param alloc    [in] for scratch; NULL for malloc/free
 * @return MLR_OK; MLR_E_INVALID_ARG (NULL arguments, an invalid rig, no names, unknown flag,
 *         a given name that is no joint, a pair naming one joint twice, a joint in two pairs,
 *         the root in a pair, a permutation that breaks the hierarchy, the position channels
 *         or the End Sites: the message names the joints); MLR_E_NO_MEMORY; MLR_E_OVERFLOW
 * Allocates: J indices and the longest name of scratch, released before return.
 * Cost O(J log J) string comparisons. Threads: any; inputs only read.
 */
MLR_API mlr_status mlr_mirror_pairs(const mlr_rig *rig, const char *const *given, size_t n_given,
                                    unsigned flags, int32_t *partner, int8_t *side,
                                    size_t *n_pairs, const mlr_allocator *alloc, mlr_diag *diag);

/**
 * The mirror plane's normal axis. With plane MLR_MIRROR_PLANE_AUTO: the left-right axis of the
 * rig, the axis along which the paired joints' rest positions (OFFSETs summed from the root,
 * all rotations identity) differ most: the largest of sum over pairs |rest_j - rest_partner|
 * per axis. With 0, 1 or 2 that axis, checked.
 * @param rig      [in] a valid rig
 * @param partner  [in] J partners (mlr_mirror_pairs); may be NULL for a given plane
 * @param plane    [in] MLR_MIRROR_PLANE_AUTO, or an mlr_axis
 * @param axis     [out] an mlr_axis
 * @return MLR_OK; MLR_E_INVALID_ARG (NULL arguments, an invalid rig, a plane not -1, 0, 1, 2,
 *         partner not an involution, and for auto: no pairs, or pairs whose rest positions
 *         coincide)
 * Allocates: never. Cost O(J). Threads: any.
 */
MLR_API mlr_status mlr_mirror_plane(const mlr_rig *rig, const int32_t *partner, int plane,
                                    int *axis, mlr_diag *diag);

/**
 * Mirror a motion across the plane normal to axis, the sides swapped by partner (the formulas
 * of the file comment). Joint j of the output takes the mirrored data of partner[j]; joint
 * names, parents and channel layouts are unchanged. Values are not checked for finiteness
 * (the reflection only changes signs and order).
 * @param rig          [in] a valid rig
 * @param partner      [in] J partners (mlr_mirror_pairs), checked as there
 * @param axis         [in] the plane's normal, an mlr_axis (mlr_mirror_plane)
 * @param flags        [in] 0 or MLR_MIRROR_KEEP_SKELETON
 * @param n_frames     [in] N (0 allowed: then only the skeleton)
 * @param root_pos     [in] N x 3
 * @param rot          [in] N x J x 4 local rotations
 * @param trans        [in] N x P x 3 translations of rig->trans_joints; NULL when P is 0
 * @param out_root_pos [out] N x 3; may be root_pos itself (in place)
 * @param out_rot      [out] N x J x 4; may be rot itself
 * @param out_trans    [out] N x P x 3; may be trans itself; NULL when P is 0
 * @param out_offsets  [out] J x 3 OFFSETs of the output (mirrored and swapped; the input's
 *                     with KEEP_SKELETON), or NULL; may be rig->offsets only with KEEP_SKELETON
 * @param out_end_site_offsets [out] E x 3 End Site OFFSETs likewise, or NULL
 * @return MLR_OK; MLR_E_INVALID_ARG (NULL arguments, an invalid rig, bad axis, unknown flag,
 *         partner not valid for the rig: reason in diag)
 * Allocates: never. Cost O(N J). Threads: any. Outputs may equal their inputs (same pointer);
 * other overlaps are not allowed.
 */
MLR_API mlr_status mlr_mirror_motion(const mlr_rig *rig, const int32_t *partner, int axis,
                                     unsigned flags, size_t n_frames, const double *root_pos,
                                     const double *rot, const double *trans, double *out_root_pos,
                                     double *out_rot, double *out_trans, double *out_offsets,
                                     double *out_end_site_offsets, mlr_diag *diag);

#ifdef __cplusplus
}
#endif

#endif /* MLR_MIRROR_H */
