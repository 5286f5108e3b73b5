/* The cleanup's private parts: shared with the guards, and between the cleanup's files
 * (cleanup_options.c, cleanup_fk.c, cleanup_floor.c, cleanup_feet.c, cleanup_spread.c,
 * cleanup_ref.c, cleanup_root.c, cleanup_pass.c and contacts_fix.c, the run). Not installed;
 * none of it is exported. */
#ifndef MLR_CLEANUP_INTERNAL_H
#define MLR_CLEANUP_INTERNAL_H

#include "motion/fk_internal.h"
#include "common/mlr_internal.h"

#include <math.h>

/* The floor of mlr_cleanup_floor_height from the contact points' world positions pts
 * (N x C x 3, as mlr_rig_point_positions gives them) instead of the frames: the quantile of
 * their up coordinates on their contact frames, NaN when nothing touches. Arguments checked
 * by the caller; N C doubles of scratch from a. */
mlr_status cleanup__floor_of_points(size_t n_frames, size_t n_points, const double *pts,
                                    const uint8_t *contacts, int up, double quantile,
                                    double *height, const mlr_allocator *a);

/* Heights along up of the contact points (N x C into h) of frames (root_pos, rot, trans), by
 * forward kinematics of the points' chains only, bit for bit what mlr_fk_arrays and
 * mlr_rig_point_positions give, 32 frames at a time (fk__list_block). Arguments checked by
 * the caller; one allocation of scratch from a: about 280 J + 96 C doubles (for N >= 32:
 * those frames' J x 7 and C x 3, and the blocks' 56 J). */
mlr_status cleanup__point_heights(const mlr_rig *rig, size_t N, const double *root_pos,
                                  const double *rot, const double *trans, size_t C,
                                  const int32_t *joints, const int32_t *end_sites, int up,
                                  double *h, const mlr_allocator *a);

/* A reference's trajectories, as mlr_cleanup_contacts derives them from the reference frames:
 * what depends on the reference alone, made once and then read by any number of cleanups of
 * motions on the same frames (the guards' rounds, and every apply when the reference is the
 * input). Read only once made: threads may share it. */
typedef struct mlr_cleanup_ref {
    mlr_allocator alloc;
    size_t n_frames, n_points, n_feet;
    int up;
    double smooth;   /* the MLR_CLEANUP_OPT_REF_SMOOTH it was made with */
    double *h;       /* N x C: the points' up coordinates (unsmoothed) */
    double *pts;     /* N x C x 3: the points, smoothed over `smooth` seconds */
    double *step;    /* N x C: the unsmoothed points' horizontal step to the next frame (0 at
                        the last) */
    double *anchors; /* N x F x 3: the feet's anchors (ankles), smoothed */
} mlr_cleanup_ref;

/* Make the trajectories of reference frames (root_pos, rot, trans) for the contact points
 * and the frames (both checked by the caller: finite); world_pos / world_rot: the reference's full
 * forward kinematics (N x J x 3 and N x J x 4) when at hand, else NULL (computed here). opts:
 * the cleanup's options (only REF_SMOOTH is read; the others are checked). *out NULL on
 * failure. Allocates about N (5 C + 3 F) doubles. */
mlr_status cleanup__ref_create(const mlr_rig *rig, size_t N, double fps, int up,
                               const double *root_pos, const double *rot, const double *trans,
                               const double *world_pos, const double *world_rot, size_t C,
                               const int32_t *joints, const int32_t *end_sites,
                               const mlr_cleanup_option *opts, size_t n_opts,
                               const mlr_allocator *alloc, mlr_cleanup_ref **out, mlr_diag *diag);
void cleanup__ref_destroy(mlr_cleanup_ref *ref);
/* A reference made from the contact points' trajectories themselves (pts: N x C x 3, finite,
 * as mlr_rig_point_positions would give them), not from frames: each foot's anchor is the
 * point of its ankle joint (an error when the ankle is not a point). The same smoothing,
 * heights and steps as cleanup__ref_create. Allocates about N (5 C + 3 F) doubles. */
mlr_status cleanup__ref_of_points(const mlr_rig *rig, size_t N, double fps, int up, size_t C,
                                  const int32_t *joints, const int32_t *end_sites,
                                  const double *pts, const mlr_cleanup_option *opts, size_t n_opts,
                                  const mlr_allocator *alloc, mlr_cleanup_ref **out,
                                  mlr_diag *diag);

/* What a caller does to the legs' rotations a pass set (the guards: the joint limits). fn
 * changes rot (N x J x 4) where mask (N x J) is set, only ever at the n_joints joints
 * (distinct). Called by the first ik_passes passes on the IK's new
 * rotations of the constrained frames before they are spread, and by the first blend_passes
 * on the frames of the spread's blends after it (see cleanup_pass.c). */
typedef struct mlr_cleanup_hook {
    void (*fn)(void *ctx, size_t N, size_t J, double *rot, const uint8_t *mask,
               const int32_t *joints, size_t n_joints, int count);
    void *ctx;
    int ik_passes, blend_passes; /* the passes that call it before / after the spread */
    /* per joint: 1 where the hook's correction is cut to the pass's excess (run_hook), 0
       where it stays whole; NULL: whole everywhere */
    const uint8_t *excess;
} mlr_cleanup_hook;

/* The argument checks of mlr_cleanup_contacts alone (mlr_cleanup_job_validate). */
mlr_status cleanup__validate(const mlr_rig *rig, size_t N, double fps, int up,
                             const double *root_pos, const double *rot, const double *trans,
                             const double *ref_root_pos, const double *ref_rot,
                             const double *ref_trans, size_t C, const int32_t *joints,
                             const int32_t *end_sites, const uint8_t *contacts,
                             const mlr_cleanup_option *opts, size_t n_opts,
                             const double *out_root_pos, const double *out_rot, mlr_diag *diag);

/* mlr_cleanup_contacts with the reference's trajectories made (ref, or NULL for no reference:
 * then ref_root_pos and the others of the public call are NULL). trusted: the rig, the points
 * and the motion were checked by the caller, so they are not checked again. hook: NULL, or
 * what to do to the IK's rotations before the spread. */
mlr_status cleanup__contacts_ref(const mlr_rig *rig, size_t N, double fps, int up,
                                 const double *root_pos, const double *rot, const double *trans,
                                 const mlr_cleanup_ref *ref, int trusted,
                                 const mlr_cleanup_hook *hook, size_t C, const int32_t *joints,
                                 const int32_t *end_sites, const uint8_t *contacts,
                                 const mlr_cleanup_option *opts, size_t n_opts,
                                 double *out_root_pos, double *out_rot, mlr_cleanup_report *report,
                                 const mlr_allocator *alloc, mlr_diag *diag);

/* ---- between the cleanup's files ---- */

/* How far below its floor limit a point may go before the floor guard lifts it, in leg lengths
   (0.5% of the leg, about 0.25% of the body's height): a dead zone, so that the rounding-level
   dips of a denoised foot under the input's own height are not chased by IK on a straight leg
   (the knee of CMU 60_10's salsa swung by 1.9% of body height for a dip of 0.1%). The lift
   grows from 0 at the zone's edge, so it is as smooth as the depth. */
#ifndef CLEANUP_FLOOR_SLACK
#define CLEANUP_FLOOR_SLACK 0.005
#endif

enum { CLEANUP_MAX_BLOCKS = 64 };

/* The scratch of one call: up to CLEANUP_MAX_BLOCKS blocks, released together; the first
   failure kept in st (later takes then return NULL). */
typedef struct cleanup_arena {
    const mlr_allocator *a;
    void *p[CLEANUP_MAX_BLOCKS];
    size_t n[CLEANUP_MAX_BLOCKS];
    int count;
    mlr_status st;
} cleanup_arena;

/* A block of count elements, zeroed (take) or not (take_raw: for the big arrays that are
   written before they are read). */
static inline void *cleanup__take_block(cleanup_arena *ar, size_t count, size_t elem, int zero)
{
    size_t bytes;
    if (ar->st != MLR_OK)
        return NULL;
    if (common__mul_size(count ? count : 1, elem, &bytes) != MLR_OK) {
        ar->st = MLR_E_OVERFLOW;
        return NULL;
    }
    void *p = ar->count < CLEANUP_MAX_BLOCKS ? common__alloc(ar->a, bytes) : NULL;
    if (!p) {
        ar->st = MLR_E_NO_MEMORY;
        return NULL;
    }
    if (zero)
        memset(p, 0, bytes);
    ar->p[ar->count] = p, ar->n[ar->count] = bytes, ar->count++;
    return p;
}

static inline void *cleanup__take(cleanup_arena *ar, size_t count, size_t elem)
{
    return cleanup__take_block(ar, count, elem, 1);
}

static inline void *cleanup__take_raw(cleanup_arena *ar, size_t count, size_t elem)
{
    return cleanup__take_block(ar, count, elem, 0);
}

static inline void cleanup__release(cleanup_arena *ar)
{
    for (int i = ar->count - 1; i >= 0; i--)
        common__free(ar->a, ar->p[i], ar->n[i]);
    ar->count = 0;
}

/* The cleanup's options, read (cleanup__parse_options). */
typedef struct cleanup_config {
    double blend, reach, floor_height, floor_q, ref_smooth, pin_smooth, max_fold;
    int passes, floor_on, floor_given, root_on;
    double keep_stiller;
    int keep_total;
    double pin_detail;
    int ramp_track; /* MLR_CLEANUP_OPT_RAMP_TRACK */
    double root_bob; /* MLR_CLEANUP_OPT_ROOT_BOB, seconds; 0: off */
    double straight_slack; /* MLR_CLEANUP_OPT_STRAIGHT_SLACK, leg lengths; 0: off */
    double soft_reach;     /* MLR_CLEANUP_OPT_SOFT_REACH, leg lengths; 0: off */
} cleanup_config;

/* A foot: anchor joint, its leg, the columns of its points, the targets. */
typedef struct cleanup_foot {
    int32_t anchor, hip, knee;
    size_t n_cols, n_own;
    size_t cols[16]; /* own first, then the placed points */
    uint8_t *U, *F, *K; /* in contact, a floor frame, in a kept contact (no IK there) */
    uint8_t *R;         /* a ramp frame (also U): a pinned run's offset enters or leaves */
    uint8_t *S;         /* this pass: the leg already reaches its target (no IK there) */
    double *at, *tt, *lift;
    double *rw; /* a ramp frame's weight of its run's offset (1 at the run's edge), else 0 */
    double leg; /* the leg's length (hip to knee to anchor) at the first frame */
    int active;
} cleanup_foot;

/* The spread's state: the map's arrays and its windows' band solves
   (cleanup__spread_rotations). */
typedef struct cleanup_work {
    const mlr_rig *rig;
    size_t N, J, C;
    double fps;
    int up;
    const cleanup_config *cfg;
    double *ab;             /* N x 3: a window's lower band (2 sub-diagonals) */
    double *fac;            /* N x 3: its LDL^T (N values 1 / D, then N x 2 of L) */
    double *map_val, *map_y; /* N x 9 */
    uint8_t *cls;           /* N: each frame's part in the map (free, held, held and moved) */
    uint8_t *dirty;         /* N: what changed in each frame since its forward kinematics: bit
                               k the rotations of foot k's leg, CLEANUP_DIRTY_ALL anything */
    uint8_t dirty_bit;      /* the bit the spread sets (its leg's) */
} cleanup_work;

/* dirty: the whole frame (the root shift, or the leg of a foot past the 7th). */
#define CLEANUP_DIRTY_ALL 0x80u

/* Read the cleanup's options into cfg (the MLR_OPTIONS_READ rules, keep_stiller 0 or >= 1). */
mlr_status cleanup__parse_options(const mlr_cleanup_option *opts, size_t n_opts,
                                  cleanup_config *cfg, mlr_diag *diag);

/* motion (root_pos, rot, trans: N frames) not NULL and finite; what names it in the message. */
mlr_status cleanup__check_motion(const mlr_rig *rig, size_t N, const double *root_pos,
                                 const double *rot, const double *trans, const char *what,
                                 mlr_diag *diag);

/* The contact points name joints (and End Sites of them) of the rig, each once. */
mlr_status cleanup__check_points(const mlr_rig *rig, size_t C, const int32_t *joints,
                                 const int32_t *end_sites, mlr_diag *diag);

/* The quantile q of v's n >= 1 finite values by linear interpolation, as of the sorted values
   (v is reordered). */
double cleanup__quantile_of(double *v, size_t n, double q);

/* Forward kinematics of the root and the n joints of list (in increasing order, closed under
   parents, the root not in it) of frame f, with the arithmetic of mlr_fk_arrays (mlr_fk.h:
   mlr_quat_mul / mlr_quat_rotate, inlined), so each computed value is bit for bit what the
   full FK gives; the other joints are not written. tidx[j]: j's index among the rig's trans
   joints, or -1. wp, wrot_f: J x 3 and J x 4, the frame's (fk__list_frame). */
void cleanup__fk_masked_frame(const mlr_rig *rig, size_t f, const int32_t *list, size_t n,
                              const int32_t *tidx, const double *root_pos, const double *rot,
                              const double *trans, double *wp, double *wrot_f);

/* The same on the joints of list alone (in increasing order, e.g. those below a leg's hip when
   only the leg's rotations changed): their parents' values in wp / wrot_f are read as they
   are, so the values are the same as the whole frame's. */
void cleanup__fk_list_frame(const mlr_rig *rig, size_t f, const int32_t *list, size_t n,
                            const int32_t *tidx, const double *rot, const double *trans,
                            double *wp, double *wrot_f);

/* cleanup__fk_masked_frame on the joints of a chain only (top-down: chain[0] and then each a
   child of the one before), the world values of chain[0]'s parent read from pos_f / wrot_f
   (the frame's forward kinematics, J x 3 and J x 4): the same arithmetic, so the same values
   at the chain's joints when the joints above it have the same rotations. wp / wrot_out:
   J x 3 and J x 4, written at the chain's joints (and chain[0]'s parent). */
void cleanup__fk_chain_frame(const mlr_rig *rig, size_t f, const int32_t *chain, size_t n,
                             const int32_t *tidx, const double *rot, const double *trans,
                             const double *pos_f, const double *wrot_f, double *wp,
                             double *wrot_out);

/* FK + points of one motion into caller arrays; with list (n joints, and tidx), only the root
   and those joints (cleanup__fk_list_points, with the blocks' scratch from alloc: MLR_E_NO_MEMORY
   without it). */
mlr_status cleanup__fk_points(const mlr_rig *rig, size_t N, const double *root_pos,
                              const double *rot, const double *trans, size_t C,
                              const int32_t *joints, const int32_t *end_sites, double *pos,
                              double *wrot, double *pts, const mlr_allocator *alloc,
                              const int32_t *list, size_t n, const int32_t *tidx);

/* The joints of cleanup__fk_masked_frame (list, n, tidx) for the blocks of fk_internal.h (keep
   NULL: all of them written). */
mlr_fk_list cleanup__fk_list_of(const mlr_rig *rig, const int32_t *list, size_t n,
                                const int32_t *tidx);

/* The values of cleanup__fk_masked_frame on each of N frames at fl's joints (pos, wrot:
   N x J x 3 and N x J x 4), 8 frames at a time (fk__list_arrays; s: MLR_FK_BLOCK_SCRATCH(J)
   doubles of scratch, or NULL: frame by frame), then the points into pts (N x C x 3) unless
   NULL (their joints must be among those fl writes). */
mlr_status cleanup__fk_list_points(const mlr_rig *rig, const mlr_fk_list *fl, size_t N,
                                   const double *root_pos, const double *rot, const double *trans,
                                   size_t C, const int32_t *joints, const int32_t *end_sites,
                                   double *pos, double *wrot, double *pts, double *s);

/* The joints the cleanup's forward kinematics computes (need, J, zeroed by the caller): the
   contact points, the feet's anchors and their ancestors; list (J): the same joints but the
   root, in increasing order (returns how many); tidx (J): each joint's index among the rig's
   trans joints, or -1. */
size_t cleanup__fk_need(const mlr_rig *rig, size_t C, const int32_t *joints,
                        const cleanup_foot *feet, size_t nf, uint8_t *need, int32_t *list,
                        int32_t *tidx);

/* The feet of the contact points: each listed joint with no listed ancestor is an ankle (an
   anchor) with its own points; the other points (toes, End Sites) are placed on the foot of
   their nearest anchor ancestor. listed (J) and assigned (C): zeroed scratch. */
mlr_status cleanup__assign_feet(const mlr_rig *rig, size_t C, const int32_t *joints,
                                const int32_t *end_sites, cleanup_foot *feet, size_t *nf_out,
                                uint8_t *listed, uint8_t *assigned, mlr_diag *diag);

/* Spread the corrections new * inv(rot) of the listed joints, known on the frames of mask
   (nonzero): CLEANUP_HELD_SAME where the pass left the leg as it was (its correction 0,
   newr not read there), any other nonzero value where newr is read. */
#define CLEANUP_HELD_SAME 2
mlr_status cleanup__spread_rotations(cleanup_work *w, double *rot, const double *newr,
                                     const int32_t *js, size_t nj, const uint8_t *mask);

/* |a - b| of two 3-vectors. */
static inline double cleanup__dist3(const double *a, const double *b)
{
    const double x = a[0] - b[0], y = a[1] - b[1], z = a[2] - b[2];
    return sqrt(x * x + y * y + z * z);
}

/* The state of one cleanup run, shared by its steps. */
typedef struct cleanup_state {
    const mlr_rig *rig;
    size_t N, J, C;
    double fps;
    int up;
    const cleanup_config *cfg;
    const int32_t *joints, *end_sites;
    const uint8_t *contacts;
    const double *trans;
    double *out_root_pos, *out_rot;
    cleanup_foot *feet;
    size_t nf;
    int have_ref;
    const double *Pr, *pos_ref;     /* the reference's points and anchors, or NULL */
    const double *step_ref;         /* the reference's unsmoothed steps (mlr_cleanup_ref) */
    double *pos, *wrot, *P;         /* forward kinematics of (out_root_pos, out_rot), points */
    double *lim, *newr, *shift;
    double floor_h;
    int floor_active;
    uint8_t *anyU, *anyF;
    uint8_t *need;   /* joints whose forward kinematics the cleanup reads */
    int32_t *need_list; /* the same but the root, in order (n_need) */
    size_t n_need;
    int32_t *tidx;
    uint8_t *fk_frames;
    double *pos2, *wrot2;           /* one frame's forward kinematics */
    double *fk_s;                   /* MLR_FK_BLOCK_SCRATCH(J): the blocks' scratch */
    double *blk_pos, *blk_rot;      /* MLR_FK_BLOCK frames' forward kinematics (x J x 3, 4) */
    int32_t *chains;                /* nf x J: the toes' chains, top-down */
    size_t *chain_len;
    int chained;
    uint8_t *mask;
    int32_t *sub;     /* nf x J: need's joints at or below each foot's hip, in order */
    size_t *n_sub;
    cleanup_work *w;
    const mlr_cleanup_hook *hook; /* or NULL */
    uint8_t *hook_mask;           /* N x J: the rotations the hook changes */
    double *hook_prev;            /* N x J x 4: the rotations the hook is given */
    double *hook_pre;             /* N x J x 4: the rotations before the pass, hooked */
    double *hook_snap;            /* N x J x 4: the rotations before the spread */
    int hook_on;     /* the hook's stages in this pass: 1 before the spread, 2 after it, 4 on
                        the ramps' frames before the spread (a pass past ik_passes) */
} cleanup_state;

/* The root shift (up to 5 rounds of needs, widened and smoothed), added to out_root_pos;
   MLR_E_NO_MEMORY in ar->st. */
mlr_status cleanup__shift_root(cleanup_state *cu, cleanup_arena *ar, mlr_cleanup_report *report);

/* The toes' chains (the hip down to the placed point's joint), top-down; cu->chained is 1 when
   every active foot has one and no other foot's leg joint lies on it or above it: the turn of
   the ankle then needs the forward kinematics of the chain only, and newr is read at the
   legs' joints only. */
void cleanup__find_chains(cleanup_state *cu);

/* One pass: forward kinematics again on the frames that changed since the last (the root
   shift before the first pass, the spread of the pass before), the floor frames, IK on the
   constrained frames, the hook when it is on, then the spread per leg (and the hook again). */
mlr_status cleanup__pass(cleanup_state *cu);

#endif
