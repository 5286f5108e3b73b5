/*
 * What a game runtime writes over the C core to play a clip on many characters, one frame at a
 * time, with live style modulation and the guards. Shared by the game loop (game_loop.c), the
 * crowd check (crowd.c) and the crowd benchmark (bench/bench_crowd.c).
 *
 * Load time, once per clip (char_clip_load; allocates, may take milliseconds): read the BVH,
 * resample it to the simulation rate (60 Hz) so one step pushes one frame, forward kinematics
 * of the whole clip, the up axis, the guards' contacts (mlr_guards_create), the floor
 * (mlr_cleanup_floor_height), the joint limits learned from the clip (mlr_limits_create, the
 * guards' defaults), the legs' IK chains and hinge axes. The result is read-only afterwards:
 * every character playing the clip, on any thread, shares it.
 *
 * Per character (char_init; allocates everything the character will use): a layered stream
 * (mlr_stream_create_layered) with the clip's limits attached, and its scratch buffers.
 *
 * Per frame (char_step; never allocates): push the clip's next frame (looped, the root carried
 * on by one loop's displacement per loop), take the stream's smoothed, style-modulated,
 * limited frame from `lag` steps ago, then the per-frame guards: the feet pinned by two-bone IK
 * (mlr_ik_apply_leg) while the clip's contacts say they touch, released over 0.2 s, and the
 * body lifted where a foot point would go below min(floor, the clip's own height of it),
 * that lift let down at most 1 body height per second. mlr_guards_apply itself works on a
 * whole clip (it blends corrections in time, forward and backward); these per-frame guards
 * are the causal counterpart built from the same pieces, and are not bit-equal to it.
 */
#ifndef MLR_EXAMPLE_CHARACTER_H
#define MLR_EXAMPLE_CHARACTER_H

#include <mlayer/mlayer.h>

#include <stddef.h>
#include <stdint.h>

#define CHAR_MAX_FEET 4
#define CHAR_STEP_HZ 60.0

/* One clip, prepared at load time; read-only while characters play it. */
typedef struct char_clip {
    mlr_allocator alloc;
    mlr_motion *motion;  /* as read (names, parents, offsets, End Sites) */
    const char **names;  /* J joint names (the rig points at them) */
    mlr_rig rig;         /* the skeleton, pointing into motion */
    size_t n_frames;     /* N, at CHAR_STEP_HZ */
    size_t n_joints;     /* J */
    size_t n_trans;      /* P */
    size_t width;        /* values per frame: 3 + 3 P + 4 J */
    double *root_pos;    /* N x 3, resampled */
    double *rot;         /* N x J x 4 */
    double *trans;       /* N x P x 3, NULL when P is 0 */
    double loop_shift[3];/* the root's ground displacement per loop (zero along up) */
    int up;              /* an mlr_axis */
    double body_height;  /* mlr_rig_body_height */
    double floor_height; /* NaN: no floor guard (no contacts found) */
    mlr_limits *limits;  /* learned from the clip */
    size_t n_points;     /* C foot points of the guards */
    int32_t *pt_joint, *pt_end;
    double *pt_height;   /* N x C: the clip's own height of each point (up component) */
    size_t n_feet;
    int32_t hip[CHAR_MAX_FEET], knee[CHAR_MAX_FEET], ankle[CHAR_MAX_FEET];
    double bend[CHAR_MAX_FEET][3]; /* each knee's hinge axis, in its hip's frame */
    uint8_t *contact;    /* N x n_feet: the foot touches in the clip */
    int32_t *end_index;  /* E: 0, 1, ..., E - 1 (the End Sites as points) */
    void *blk[12];        /* the arrays above, allocated with alloc */
    size_t blk_size[12];
    size_t n_blk;
} char_clip;

/* Read and prepare a clip. alloc NULL: malloc/free. On failure diag says why. */
mlr_status char_clip_load(const char *path, const mlr_allocator *alloc, char_clip *clip,
                          mlr_diag *diag);
void char_clip_free(char_clip *clip);

/* One character playing a clip. */
typedef struct character {
    const char_clip *clip;
    mlr_allocator alloc;
    mlr_stream *stream;
    size_t lag;
    size_t pushed;   /* frames pushed since char_init (the clip's frame pushed % N, looped) */
    size_t phase;    /* the clip frame the character started on */
    double alpha;
    int filter; /* 1: show the stream's output; 0: the raw clip (the stream keeps running) */
    int guards; /* 1: limits (in the stream), feet and floor; 0: none */
    double *in; /* width: the frame pushed */
    double *out; /* width: the stream's output */
    double *pose; /* width: the frame shown (root, translations, rotations) */
    double *alpha_j; /* J */
    double *world_pos, *world_rot; /* J x 3, J x 4 of pose */
    double *points; /* max(C, E) x 3 */
    double *ends; /* E x 3: the End Sites' world positions (for drawing) */
    int pinned[CHAR_MAX_FEET];
    double held[CHAR_MAX_FEET][3];
    double released[CHAR_MAX_FEET]; /* seconds since the contact ended */
    double lift; /* the body's lift by the floor guard */
    size_t bytes;
    void *block;
} character;

/* Create a character on clip, starting at clip frame `phase`, with the given stream lag.
 * lam, sigma: light smoothing (1, 1); the base layer: lam 20, sigma 1. */
mlr_status char_init(character *c, const char_clip *clip, size_t phase, size_t lag,
                     const mlr_allocator *alloc, mlr_diag *diag);
void char_free(character *c);

/* Switches; they take effect from the next step. Never allocate. */
mlr_status char_set_alpha(character *c, double alpha, mlr_diag *diag);
mlr_status char_set_guards(character *c, int on, mlr_diag *diag);
void char_set_filter(character *c, int on);

/* One simulation step: push the next frame, pose the character (c->pose, c->world_pos,
 * c->ends). Never allocates. */
mlr_status char_step(character *c, mlr_diag *diag);

/* The clip frame (0..N-1) the shown pose belongs to. */
size_t char_shown_frame(const character *c);

#endif
