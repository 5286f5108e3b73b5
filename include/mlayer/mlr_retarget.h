/*
 * Retargeting: a motion of one humanoid rig put onto another rig (other names, other
 * proportions, another rest pose, another up axis).
 *
 * Humanoid roles (mlr_retarget_roles). Each rig's joints get roles from their names and the
 * tree: the side of a joint is the one mlr_mirror_pairs tells by name (Left/Right, _L/_R, l/r
 * prefixes); the feet are the topmost joints of each side whose names contain "foot" or
 * "ankle", the hands those with "hand" or "wrist", the head the topmost mid-plane joint with
 * "head". The rest follows from the tree: the lower leg is the foot's parent, the upper leg
 * the lower leg's, the hips the upper legs' nearest common ancestor, or, where that joint does
 * not carry the upper body (the head, else the arms: MakeHuman's legs hang from a pelvis joint
 * beside the spine), the nearest common ancestor of it and the upper body; the lower arm is the
 * hand's parent, the upper arm the lower arm's, the shoulder (clavicle) the upper arm's parent
 * when that joint is an ancestor of neither the other arm nor the head; the spine chain is the
 * path from the hips (excluded) to the nearest common ancestor of the two upper arms
 * (included), the neck chain the path from there to the head (both excluded); without a joint
 * named head, the head is the end of the middle chain up from the chest (the chest's child
 * that carries neither arm, then the only child of each joint while there is one: video2bvh's
 * Neck1); the toes are the foot's first child joint. Joints on the way that get no role (CMU's
 * LHipJoint, a twist joint) stay unmatched. A spine chain longer than MLR_RETARGET_MAX_SPINE (a
 * neck chain longer than MLR_RETARGET_MAX_NECK) gives its roles to joints spread evenly along
 * it.
 *
 * A humanoid has both legs (upper leg, lower leg, foot), the hips, both arms (upper arm, lower
 * arm, hand) and a head (a spine is not required: Kinect skeletons hang the arms, the legs and
 * the neck from one torso joint), and a humanoid's proportions: a rig whose arms (upper + lower
 * arm, rest lengths) are at least 0.8 of its legs (upper + lower leg) and whose torso (the hips
 * to the middle of the upper arms) is at least 0.75 of them is a quadruped named as a humanoid
 * (its front legs taken for arms) and is refused. Over the 93 rigs accepted among 103 BVH
 * files (a corpus of 95 and the 8 shared clips) the arms are 0.22 to 0.80 of the legs (one
 * Kinect skeleton with glitched OFFSETs, 1.14) and the torsos 0.24 to 0.73; the AI4Animation
 * dog is 0.97 and 1.38, a Truebones elephant 0.86 and 0.84 (bench/python/bench_retarget.py
 * --proportions).
 *
 * The retarget (mlr_retarget). Both rest poses are the OFFSETs with identity rotations. Each
 * rig has a rest body frame B (columns: left, up, forward; up from the hips to the head, left
 * from the right upper leg to the left one without its part along up, each snapped to the
 * nearest world axis with its sign, so that a rest pose leaning a few degrees does not tilt the
 * floor; forward = left x up) and a world frame F: B, or, where the rig's world up is given and
 * is another axis than B's up (a bind pose lying along x, as Bandai's), that up with B's left
 * where it is level (else B's forward), forward = left x up. Every role joint j with a bone has
 * a rest frame P_j: its first column along the bone (to the next joint of its role chain:
 * upper leg to lower leg, lower arm to hand, spine to spine, neck or head, the foot to the toes
 * or its End Site, the hand to the mean of its children, the head to its End Site), its second
 * the axis of B least aligned with both bones (Gram-Schmidt). With G = F_s F_t^T (target world
 * to source world) and, per matched role, C = P_s P_t^T (C = B_s B_t^T for the hips and for a
 * role without a bone on either rig), the target joint's world rotation at each frame is
 *     W_t = G^T W_s C,
 * so that the direction of every matched bone in the target's world is the source's (mapped by
 * G) and its roll follows the source's. Unmatched target joints keep their rest (identity)
 * local rotations; the local rotation of a matched joint is W_parent^-1 W_t. Chains of other
 * lengths are distributed by the fractions of their rest lengths: target chain joint k, whose
 * bone spans fractions u_k .. u_k+1 of its chain (spine: up to the first neck joint or the head;
 * neck: up to the head), takes the roll of the source chain joint whose segment holds the
 * middle of that span, and its bone is turned (the shortest way) to point along the source
 * chain from fraction u_k to u_k+1 (the source's rest segments turned by their joints' world
 * rotations). Joints without a role on either rig follow the source joint of the same name
 * when there is one that has no role either, or else, for a finger (a joint below a hand role
 * whose name holds thumb, index, middle, ring, pinky, pinkie or little), the source joint of
 * the same finger below the same hand at the same place counted from the finger's tip
 * (MakeHuman's Index1_L follows Mixamo's LeftHandIndex1 or Daz's lIndex1; a metacarpal joint
 * more at the base is left at rest), with C from their bones to their first
 * child (or End Site).
 *
 * Placement. s = L_t / L_s, L being the mean over both sides of the rest lengths upper leg ->
 * lower leg -> foot. The middle of the target's upper legs goes where the source's is, mapped
 * by G^T and scaled by s (about the origin: the floor is taken at height 0), raised along the
 * target's world up by a_t - s a_s, a being the rest height of the ankles above the lowest joint or
 * End Site of their feet (so that soles on the floor stay on it). The shift that puts it there
 * goes into the root translation (the hips are the root, or the root carries them: its
 * rotation stays at rest) or into the hips' position channels (a static root above them:
 * Bandai). Other position channels of the target keep their OFFSETs. Retargeting a rig onto
 * itself gives the input back (G = C = I, s = 1) up to rounding; A -> B -> A gives back A's
 * joints whose roles B has, up to the chains' distribution.
 *
 * An override map pairs source joints with target joints by name: target joint t takes the
 * role of source joint s (any joint that had that role on the target loses it).
 */
#ifndef MLR_RETARGET_H
#define MLR_RETARGET_H

#include <stdint.h>

#include "mlr_cleanup.h"
#include "mlr_common.h"
#include "mlr_rig.h"

#ifdef __cplusplus
extern "C" {
#endif

/** The up argument that takes a rig's up from its rest pose (the hips to the head). */
#define MLR_RETARGET_UP_REST (-1)

/** Longest spine and neck chains given roles. */
#define MLR_RETARGET_MAX_SPINE 8
#define MLR_RETARGET_MAX_NECK 4

/** Humanoid roles. Values pinned. */
typedef enum mlr_role {
    MLR_ROLE_HIPS = 0,
    MLR_ROLE_SPINE = 1, /**< SPINE + k, k < MLR_RETARGET_MAX_SPINE, from the hips up */
    MLR_ROLE_NECK = 9,  /**< NECK + k, k < MLR_RETARGET_MAX_NECK, from the chest up */
    MLR_ROLE_HEAD = 13,
    MLR_ROLE_LEFT_SHOULDER = 14,
    MLR_ROLE_LEFT_UPPER_ARM = 15,
    MLR_ROLE_LEFT_LOWER_ARM = 16,
    MLR_ROLE_LEFT_HAND = 17,
    MLR_ROLE_RIGHT_SHOULDER = 18,
    MLR_ROLE_RIGHT_UPPER_ARM = 19,
    MLR_ROLE_RIGHT_LOWER_ARM = 20,
    MLR_ROLE_RIGHT_HAND = 21,
    MLR_ROLE_LEFT_UPPER_LEG = 22,
    MLR_ROLE_LEFT_LOWER_LEG = 23,
    MLR_ROLE_LEFT_FOOT = 24,
    MLR_ROLE_LEFT_TOES = 25,
    MLR_ROLE_RIGHT_UPPER_LEG = 26,
    MLR_ROLE_RIGHT_LOWER_LEG = 27,
    MLR_ROLE_RIGHT_FOOT = 28,
    MLR_ROLE_RIGHT_TOES = 29,
    MLR_ROLE_COUNT = 30
} mlr_role;

/** The name of a role ("Hips", "Spine0", "LeftUpperArm"), or NULL outside 0..MLR_ROLE_COUNT-1.
 *  Allocates: never. Threads: any. */
MLR_API const char *mlr_role_name(int role);

/**
 * The joint of every humanoid role of a rig (the rules of the file comment).
 * @param rig        [in] a valid rig with names
 * @param role_joint [out] MLR_ROLE_COUNT joint indices, -1 for a role no joint has
 * @param alloc      [in] for scratch; NULL for malloc/free
 * @param diag       [out] optional: the reason of an error
 * @return MLR_OK; MLR_E_INVALID_ARG (NULL arguments, an invalid rig, no names, and a rig
 *         that is not a humanoid (the file comment): the message names the missing role, or
 *         the arms and the torso with their proportions); MLR_E_NO_MEMORY
 * Allocates: scratch only, released before return. Cost O(J log J) string work. Threads: any.
 */
MLR_API mlr_status mlr_retarget_roles(const mlr_rig *rig, int32_t *role_joint,
                                      const mlr_allocator *alloc, mlr_diag *diag);

/** Figures of a retarget. A frozen value type: fields are never reordered or removed. */
typedef struct mlr_retarget_info {
    double scale;         /**< s = L_t / L_s, the target's leg length over the source's */
    size_t n_matched;     /**< target joints that follow a source joint */
    double to_source[9];  /**< G, row-major: target world to source world */
} mlr_retarget_info;

/**
 * Retarget a motion of the source rig onto the target rig (the formulas of the file comment).
 * @param source       [in] a valid rig with names
 * @param n_frames     [in] N (0 allowed)
 * @param root_pos     [in] N x 3 source root translations
 * @param rot          [in] N x J_s x 4 source local rotations (unit, scalar first)
 * @param trans        [in] N x P_s x 3 translations of source->trans_joints; NULL when P_s is 0
 * @param target       [in] a valid rig with names
 * @param source_up    [in] the source's world up, an mlr_axis, or MLR_RETARGET_UP_REST
 * @param target_up    [in] the target's likewise (the world frames of the file comment)
 * @param map          [in] 2 n_map names, pair k = (source joint map[2k], target joint
 *                     map[2k+1]); NULL when n_map is 0
 * @param n_map        [in] number of pairs
 * @param out_root_pos [out] N x 3 target root translations
 * @param out_rot      [out] N x J_t x 4 target local rotations
 * @param out_trans    [out] N x P_t x 3 translations of target->trans_joints; NULL when P_t
 *                     is 0
 * @param info         [out] optional: the scale, the matched joints, G
 * @param alloc        [in] for scratch; NULL for malloc/free
 * @param diag         [out] optional: the reason of an error
 * @return MLR_OK; MLR_E_INVALID_ARG (NULL arguments, an invalid rig, a rig that is not a
 *         humanoid, a map name that is no joint of its rig or a source joint of the
 *         map without a role, a target joint named twice, non-finite input: the message names
 *         the rig and the joint; nothing is written to the outputs then); MLR_E_NO_MEMORY;
 *         MLR_E_OVERFLOW
 * Allocates: scratch of O(J_s + J_t) per frame, released before return. Cost O(N (J_s + J_t)).
 * Threads: any; inputs only read; outputs must not alias inputs.
 */
MLR_API mlr_status mlr_retarget(const mlr_rig *source, size_t n_frames, const double *root_pos,
                                const double *rot, const double *trans, const mlr_rig *target,
                                int source_up, int target_up, const char *const *map, size_t n_map,
                                double *out_root_pos, double *out_rot, double *out_trans,
                                mlr_retarget_info *info, const mlr_allocator *alloc,
                                mlr_diag *diag);

/**
 * The feet of a retargeted motion (the output of mlr_retarget, changed in place): the source's
 * contacts become the target's and the contact cleanup (mlr_cleanup_contacts with a reference,
 * two-bone IK with the corrections spread in time) plants the target's feet where the scaled
 * source planted its own. The contact points of each rig are, per side, the ankle (foot role)
 * and the toes or else the ankle's first End Site; the source's are detected by
 * mlr_contacts_detect (default options); a target's toe point is kept where the source has one
 * of the same nature (a toe joint for a toe joint, an End Site for an End Site), and each
 * target point takes the contacts of the source point of its kind (the ankle's for the ankle;
 * an ankle without a toe point of its own also the source's toe contacts: the heel up, the
 * foot on its toes).
 * The reference of each target point is the source's point of its kind mapped into the
 * target's world (G^T), scaled by s about the origin and raised by mlr_retarget's lift (the
 * median over frames of the target's upper legs' middle above the scaled source's), not
 * smoothed (MLR_CLEANUP_OPT_REF_SMOOTH 0): each contact run of the target follows that
 * trajectory shifted horizontally by the run's mean offset, at its heights, so the target's
 * feet slide as the source's do (in leg lengths) and a round trip A -> B -> A puts A's feet
 * back where they were. The cleanup's floor is the reference's (the 0.05 quantile of its
 * contact heights; off when the source's up does not map onto a positive world axis of the
 * target). A target toe joint whose side has no toe joint in the source (Axis Neuron's feet
 * end in an End Site) has no motion of its own: on its foot's contact frames it keeps the
 * pitch against the ground that its bone has at rest (where the foot pitches down, heel up,
 * it turns up about the level axis across it by the shortfall, entering by a C1 ramp of 5
 * degrees), with a weight that is 1 on the contact frames and eases to 0 within 0.2 s of them
 * (in the air it hangs from its foot, at rest). Then, where up maps onto a positive axis: the
 * whole target is raised by the median over the source's contact frames of the scaled source's
 * lowest foot point (ankles, toes and their End Sites) less the target's, a constant that puts
 * the soles of the contact frames together where the two feet pitch or are shaped otherwise
 * (a round trip undoes it, as it undoes the lift); last, as the guards' last step, the ground
 * is kept: the higher of the target's own (the 0.05 quantile over its contact frames of its
 * lowest foot point) and the scaled source's (the same of the source, times s); the body is
 * raised along up by a smooth envelope of the shortfall (the largest within +-0.1 s, averaged
 * with a raised-cosine window as wide) wherever its lowest foot point is below that, also
 * where the source's own foot went below its ground (no foot point of the target ends below
 * the ground it is placed on).
 * @param source     [in] the source rig (as given to mlr_retarget)
 * @param n_frames   [in] N; fewer than 3: nothing is done
 * @param fps        [in] frames per second, finite, > 0
 * @param up         [in] the source's up axis, an mlr_axis
 * @param root_pos, rot, trans [in] the source motion (as given to mlr_retarget)
 * @param target, target_up, map, n_map [in] as given to mlr_retarget
 * @param out_root_pos, out_rot [in, out] the retargeted motion, N x 3 and N x J_t x 4
 * @param out_trans  [in] its N x P_t x 3 translations (kept), NULL when P_t is 0
 * @param report     [out] optional: what the cleanup did
 * @param alloc      [in] for scratch; NULL for malloc/free
 * @param diag       [out] optional: the reason of an error
 * @return MLR_OK; MLR_E_INVALID_ARG (as mlr_retarget; bad up or fps; the cleanup's reasons);
 *         MLR_E_NO_MEMORY; MLR_E_OVERFLOW
 * Allocates: N (7 J_s + 7 J_t + 24) doubles, the reference's N (5 C + 3 F), N (7 J_t + 3) for
 * the toes and N (7 J_t + 2) doubles and the cleanup's scratch, released before return.
 * Threads: any; the source is only read.
 */
MLR_API mlr_status mlr_retarget_feet(const mlr_rig *source, size_t n_frames, double fps, int up,
                                     const double *root_pos, const double *rot,
                                     const double *trans, const mlr_rig *target, int target_up,
                                     const char *const *map, size_t n_map, double *out_root_pos,
                                     double *out_rot, const double *out_trans,
                                     mlr_cleanup_report *report, const mlr_allocator *alloc,
                                     mlr_diag *diag);

#ifdef __cplusplus
}
#endif

#endif /* MLR_RETARGET_H */
