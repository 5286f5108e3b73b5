/*
 * Cleanup of a synthesized motion (paper 1, eq. 18, and the floor guard of issue 18): the feet
 * are pinned during the contacts detected on the original and kept above the original's floor,
 * with two-bone IK on the legs (mlr_ik.h) and the rotation corrections spread in time as an LGS
 * displacement map (mlr_lgs.h).
 *
 * Contact points are (joint, End Site or -1) pairs as mlr_rig_point_positions takes them;
 * contacts is N x C uint8 (nonzero: the point touches the ground in that frame), normally
 * detected on the original. Points are grouped into feet: a listed joint with no listed
 * ancestor is an ankle; the other points (toes, End Sites) are placed by turning the topmost
 * listed ankle above them (or, without one, their own joint's parent for a joint point and the
 * joint itself for an End Site).
 *
 * Targets, per foot on the frames U where any of its points is in contact: with a reference,
 * each run of U gets one horizontal offset o (the mean of motion minus reference over the run's
 * contact samples) and the ankle and the first placed point follow the reference's own
 * trajectories (smoothed over REF_SMOOTH seconds) shifted by o, at the reference's heights;
 * without one, each point is pinned to its mean position over its contact interval.
 *
 * Floor: a flat floor at height h along the up axis. Unless given (FLOOR_HEIGHT), h is the
 * FLOOR_QUANTILE (default 0.05, linear interpolation between order statistics) quantile of the
 * heights of the contact points on their contact frames, in the reference (the motion itself
 * without one): the level the feet stand on, robust to a few low outliers. A foot point may not
 * go below min(h, the reference's own height of that point in that frame) (h without a
 * reference); on frames where one does (and the foot is not in contact) the foot's ankle target
 * is its current position raised by the largest shortfall, and the ankle keeps its world
 * rotation, so every point of the foot rises by that amount.
 *
 * Correction: the root moves only where a leg would have to stretch beyond REACH of its length
 * (or beyond its current extension where it is straighter already) to reach a contact target:
 * the need, widened over +-0.1 s (the largest need there) and averaged over the same window
 * with a raised cosine (a smooth shift that still covers each need at its frame, zero farther
 * than 0.2 s from every need), repeated on what is left (5 times). Per frame,
 * two-bone IK on each leg (hip, knee, ankle from mlr_ik_leg_chain) reaches the ankle target,
 * and a turn of the ankle the placed point's target. The changes of the local rotations of hip,
 * knee and ankle (rotation vectors of new * inv(old)), known on the constrained frames, make a
 * displacement map: on the frames between two constrained frames less than BLEND seconds apart
 * it goes from one value to the other along a smoothstep; elsewhere it fades from the nearest
 * constrained frame's value to zero along a smoothstep over BLEND seconds; then a smoothing
 * with the constrained frames held (min sum over the other frames of (x - y)^2 + lam^2 |D2 x|^2,
 * lam = (PIN_SMOOTH fps)^2, x = y on the constrained frames up to ~1e-10 relative) rounds the
 * blend's corners on the free side only, so the constrained frames get the IK's values. The map
 * stays close to the range of its values at the two nearest constrained frames and zero, so a
 * foot out of contact moves no further than the blend requires, and frames farther than BLEND
 * from every constrained frame keep the synthesized motion (up to the smoothing's tails,
 * ~exp(-d / PIN_SMOOTH)). PASSES passes repeat IK and spread on what the floor check of the
 * previous pass found. Bone lengths never change;
 * translations of non-root joints (trans) are kept as they are.
 */
#ifndef MLR_CLEANUP_H
#define MLR_CLEANUP_H

#include <stdint.h>

#include "mlr_common.h"
#include "mlr_rig.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Option keys of mlr_cleanup_contacts. Values pinned; new options get new values. */
typedef enum mlr_cleanup_key {
    MLR_CLEANUP_OPT_BLEND = 1,          /* seconds, > 0: the map's fade outside constrained
                                           frames; default 0.2 */
    MLR_CLEANUP_OPT_REACH = 2,          /* (0, 1]: the root moves where a leg needs more than
                                           this of its length; default 0.98 */
    MLR_CLEANUP_OPT_PASSES = 3,         /* integer in [1, 10]: IK + spread passes; default 2 */
    MLR_CLEANUP_OPT_FLOOR = 4,          /* 1: the floor guard on (default), 0: off */
    MLR_CLEANUP_OPT_FLOOR_HEIGHT = 5,   /* finite: the floor height along the up axis (replaces
                                           the estimate) */
    MLR_CLEANUP_OPT_FLOOR_QUANTILE = 6, /* [0, 1]: quantile of contact heights; default 0.05 */
    MLR_CLEANUP_OPT_REF_SMOOTH = 7,     /* seconds, >= 0: LGS smoothing of the reference's
                                           contact trajectories; default 0.02; 0: none */
    MLR_CLEANUP_OPT_PIN_SMOOTH = 8,     /* seconds, > 0: time scale of the map's smoothing
                                           outside the constrained frames; default 0.02 */
    MLR_CLEANUP_OPT_ROOT = 9,           /* 1: the root may move (default), 0: never */
    MLR_CLEANUP_OPT_MAX_FOLD = 10,      /* radians in (0, pi]: the largest knee flexion IK may
                                           use; a target nearer the hip moves the root away
                                           (on contact and floor frames); default pi (none) */
    MLR_CLEANUP_OPT_KEEP_STILLER = 11,  /* k >= 1: a foot's contact run whose own contact
                                           points slide (horizontal path length) at most k
                                           times the reference's keeps its own trajectory; 0
                                           (default): every run follows the reference */
    MLR_CLEANUP_OPT_KEEP_TOTAL = 12,    /* 1: with KEEP_STILLER, the feet slide in all (kept
                                           runs their own path, the others the reference's)
                                           at most as much as the reference's points before
                                           REF_SMOOTH: the kept runs that slide most beyond
                                           the reference follow it instead, largest excess
                                           first; 0 (default): off */
    MLR_CLEANUP_OPT_PIN_DETAIL = 13,    /* [0, 1]: how much of the synthesized foot's own fast
                                           motion (beyond a 0.03 s local linear fit) a pinned
                                           contact keeps; the slow part follows the reference.
                                           0 (default): planted on the reference's smoothed
                                           path; 1: the synthesis' detail kept, the reference's
                                           capture noise left out (the guards' denoise) */
    MLR_CLEANUP_OPT_RAMP_TRACK = 14,    /* 1 (default): the frames around a contact pinned to
                                           the reference cross-fade from the reference's
                                           motion (plus the contact's offset) to the
                                           synthesis's, so the foot meets its contact with
                                           the contact's velocity; 0: they carry the edge's
                                           offset alone (the synthesis's velocity at the
                                           edge: the guards' denoise, retiming). Since 0.3 */
    MLR_CLEANUP_OPT_ROOT_BOB = 15,      /* seconds, >= 0: the vertical part of the root's shift
                                           (up to 0.1 leg lengths, in the first round) is
                                           spread over +- this many seconds, no lower than the
                                           body's parts off the feet stand above the floor, so
                                           that a body whose bob was scaled keeps it; 0
                                           (default): off, every need within +-0.1 s. The
                                           guards pass 0.5 when the body translation's alpha
                                           is not 1. Since 0.3 */
    MLR_CLEANUP_OPT_STRAIGHT_SLACK = 16, /* leg lengths, >= 0: on a leg within about a degree
                                           of straight, the part of a contact target's
                                           correction along the hip-anchor line, l, becomes
                                           l x^2 / (1 + x^2), x = |l| / this, blended back into
                                           the whole correction by 6 degrees of bend, so that
                                           a straight leg asked to shorten by a hair does not
                                           bend its knee for it (what is left along the line is
                                           at most half of this); 0 (default): every
                                           correction whole. The guards pass 0.002. Since 0.3 */
    MLR_CLEANUP_OPT_SOFT_REACH = 17 /* leg lengths, in [0, 0.5]: a leg's target farther from
                                       its hip than b = L (1 - this), L its length, is drawn
                                       in to b + this L (1 - exp(-(d - b) / (this L))), but
                                       no nearer than the leg's extension now, so that the
                                       knee straightens smoothly as its target nears full
                                       reach instead of snapping straight and back; 0
                                       (default): off. The guards pass 0.02. Since 0.3 */
} mlr_cleanup_key;

/** One option: key (an mlr_cleanup_key) and its value. A frozen value type. */
typedef struct mlr_cleanup_option {
    int key;
    double value;
} mlr_cleanup_option;

/** What a cleanup did. A frozen value type: fields are never reordered or removed. */
typedef struct mlr_cleanup_report {
    double floor_height;   /* the floor used along the up axis; NaN when the floor was off */
    size_t contact_frames; /* frames where some foot was pinned */
    size_t floor_frames;   /* frames where some foot was raised to the floor (last pass) */
    double root_shift_max; /* largest root correction (length units) */
} mlr_cleanup_report;

/**
 * The floor height of a motion from its contacts (the long form of
 * mlr_cleanup_job_floor_height, kept for the ABI of 0.2): the `quantile` quantile (linear
 * interpolation between order statistics) of the up coordinates of the contact points on their
 * contact frames.
 * @param rig       [in] the skeleton (mlr_rig_check)
 * @param n_frames  [in] N >= 1
 * @param root_pos, rot, trans [in] N x 3, N x J x 4, N x P x 3 (P = rig->n_trans; trans may
 *                  be NULL when P is 0)
 * @param n_points, joints, end_sites [in] C points (end_sites NULL: all joints)
 * @param contacts  [in] N x C, nonzero where the point touches
 * @param up        [in] an mlr_axis
 * @param quantile  [in] in [0, 1]
 * @param height    [out] the floor; NaN when no point is in contact on any frame
 * @return MLR_OK; MLR_E_INVALID_ARG (bad rig, NULL array, points that name nothing, bad axis
 *         or quantile, non-finite motion; reason in diag); MLR_E_NO_MEMORY; MLR_E_OVERFLOW
 * Allocates: forward kinematics and the heights, about N (7 J + 4 C) doubles, released before
 * return. Threads: any; inputs only read.
 */
MLR_API mlr_status mlr_cleanup_floor_height(const mlr_rig *rig, size_t n_frames,
                                            const double *root_pos, const double *rot,
                                            const double *trans, size_t n_points,
                                            const int32_t *joints, const int32_t *end_sites,
                                            const uint8_t *contacts, int up, double quantile,
                                            double *height, const mlr_allocator *alloc,
                                            mlr_diag *diag);

/**
 * Pin the feet of a synthesized motion during contacts and keep them above the floor (see the
 * file comment). The long form of mlr_cleanup_job_run, kept for the ABI of 0.2: new code fills
 * an mlr_cleanup_job.
 * @param rig        [in] the skeleton of motion and reference (mlr_rig_check)
 * @param n_frames   [in] N >= 1 (N < 2 or nothing to do: the input is copied)
 * @param fps        [in] frames per second, finite, > 0
 * @param up         [in] the up axis, an mlr_axis
 * @param root_pos, rot, trans [in] the synthesized motion: N x 3, N x J x 4 unit quaternions,
 *                   N x P x 3 (P = rig->n_trans; NULL when P is 0), finite
 * @param ref_root_pos, ref_rot, ref_trans [in] the reference (normally the original) at the
 *                   same frames, or all NULL for none (ref_trans NULL when P is 0)
 * @param n_points, joints, end_sites [in] C contact points (end_sites NULL: all joints)
 * @param contacts   [in] N x C uint8, nonzero where a point touches
 * @param opts       [in] n_opts options (mlr_cleanup_key); NULL when n_opts is 0
 * @param out_root_pos [out] N x 3; may be root_pos itself
 * @param out_rot    [out] N x J x 4; may be rot itself
 * @param report     [out] optional
 * @param alloc      [in] NULL for malloc/free
 * @return MLR_OK; MLR_E_INVALID_ARG (bad rig, NULL array, fps or axis, points that name
 *         nothing, a contact foot without a two-bone chain, non-finite input, unknown or
 *         repeated option, option values out of range or not finite; reason in diag; outputs
 *         then unspecified); MLR_E_NO_MEMORY; MLR_E_OVERFLOW
 * Allocates: scratch of about N (11 J + 14 C + 10 F + 42) doubles (F feet), released before
 * return. Cost O(N J) per pass. Threads: any; inputs only read.
 */
MLR_API mlr_status mlr_cleanup_contacts(
    const mlr_rig *rig, size_t n_frames, double fps, int up, const double *root_pos,
    const double *rot, const double *trans, const double *ref_root_pos, const double *ref_rot,
    const double *ref_trans, size_t n_points, const int32_t *joints, const int32_t *end_sites,
    const uint8_t *contacts, const mlr_cleanup_option *opts, size_t n_opts, double *out_root_pos,
    double *out_rot, mlr_cleanup_report *report, const mlr_allocator *alloc, mlr_diag *diag);

/** Contact points: C joints (n_points), each with an End Site index or -1 (end_sites NULL:
 *  all joints), and their contacts, N x C uint8, nonzero where a point touches. Borrowed. A
 *  frozen value type. Since 0.3 */
typedef struct mlr_cleanup_points {
    size_t n_points;
    const int32_t *joints;
    const int32_t *end_sites;
    const uint8_t *contacts;
} mlr_cleanup_points;

/** A cleanup job, in the manner of ozz-animation's jobs: what mlr_cleanup_contacts takes, in
 *  one struct, so that no call takes more than a few arguments. Fill it (zero what you do not
 *  use: `mlr_cleanup_job job = {0};`), check it with mlr_cleanup_job_validate and run it with
 *  mlr_cleanup_job_run (which checks it too); mlr_cleanup_job_floor_height reads the same
 *  fields. Every pointer is borrowed for the call. A frozen value type. Since 0.3 */
typedef struct mlr_cleanup_job {
    const mlr_rig *rig;           /* the skeleton of motion and reference (mlr_rig_check) */
    double fps;                   /* frames per second, finite, > 0 (run only) */
    int up;                       /* the up axis, an mlr_axis */
    mlr_frames motion;            /* the synthesized motion, N = motion.n_frames >= 1 */
    mlr_frames reference;         /* the reference at the same frames, or all NULL (run only) */
    mlr_cleanup_points points;    /* the contact points and their contacts */
    const mlr_cleanup_option *opts; /* n_opts options (mlr_cleanup_key); NULL when n_opts is 0 */
    size_t n_opts;
    double *out_root_pos;         /* [out] N x 3; may be motion.root_pos itself (run only) */
    double *out_rot;              /* [out] N x J x 4; may be motion.rot itself (run only) */
    mlr_cleanup_report *report;   /* [out] optional (run only) */
} mlr_cleanup_job;

/**
 * Check a cleanup job's fields as mlr_cleanup_job_run would, without running it.
 * @return MLR_OK; MLR_E_INVALID_ARG (NULL job, or what mlr_cleanup_contacts refuses; the
 *         reason in diag names the field, e.g. "job.points.joints: NULL")
 * Allocates: never. Threads: any.
 */
MLR_API mlr_status mlr_cleanup_job_validate(const mlr_cleanup_job *job, mlr_diag *diag);

/**
 * Run a cleanup job: mlr_cleanup_contacts with the job's fields (the same bits).
 * @return as mlr_cleanup_contacts; MLR_E_INVALID_ARG for a NULL job
 * Allocates, cost, threads: as mlr_cleanup_contacts.
 */
MLR_API mlr_status mlr_cleanup_job_run(const mlr_cleanup_job *job, const mlr_allocator *alloc,
                                       mlr_diag *diag);

/**
 * The floor height of a job's motion from its contacts: mlr_cleanup_floor_height with the
 * job's rig, motion, points and up axis (fps, reference, options and outputs are not read).
 * @param quantile  [in] in [0, 1] (the guards take 0.05)
 * @param height    [out] the floor; NaN when no point is in contact on any frame
 * @return as mlr_cleanup_floor_height; MLR_E_INVALID_ARG for a NULL job
 * Allocates, threads: as mlr_cleanup_floor_height.
 */
MLR_API mlr_status mlr_cleanup_job_floor_height(const mlr_cleanup_job *job, double quantile,
                                                double *height, const mlr_allocator *alloc,
                                                mlr_diag *diag);

#ifdef __cplusplus
}
#endif

#endif /* MLR_CLEANUP_H */
