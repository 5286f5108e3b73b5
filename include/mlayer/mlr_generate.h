/*
 * Generation at run time (paper 2, section 5): a trained primitives model, written by Python
 * (mlayer.PrimitiveModel.save_runtime, `mlayer primitives --runtime`) in the binary format of
 * docs/model-format.md, loaded here, and a generator that produces the frames of a generated
 * motion one at a time, without Python.
 *
 * What a generator computes is what PrimitiveModel.generate(frames, start_frame=, start=,
 * most_likely= / second_likely=, noise=, allow_unseen=, seed=, smooth=, guards=False)
 * computes, step for step:
 *  1. the seeded generator (mlr_rng, mlr_markov.h) seeded with the seed; the start frame (the
 *     option, or mlr_rng_below(n_points) when it is -1) and its primitive (the option, or the
 *     frame's label);
 *  2. the walk of distinct primitives (mlr_markov_path: sampled, or ranked) filling the frames,
 *     on the chain perturbed once at the first frame when the option noise > 0 or
 *     allow_unseen (mlr_markov_perturb, its own generator: MLR_GEN_NOISE_SEED_XOR);
 *  3. the knots: the start frame's manifold point, then the primitives' centres, at times
 *     spaced by the steps' frames; the knot past the last frame cut to it by linear
 *     interpolation;
 *  4. the LGS smoothing spline through the knots (order 2, lam = sqrt(1e-3), sigma 1, the
 *     banded solver: mlr_lgs.h) sampled at the frames and clipped to the model's bounds;
 *  5. the GRBF mapping (mlr_grbf_eval) of those points to outputs: body height, velocity and
 *     turning rate in the heading frame, joint rotations, joint positions;
 *  6. the LGS smoothing of the outputs (order 2, lam = the smooth option, sigma 1) when smooth
 *     > 0 and there are more than 2 frames;
 *  7. rotations renormalized, the heading integrated from the turning rate (yaw of frame f the
 *     sum of the rates of frames 0 .. f-1), the body position from the velocities rotated by
 *     the heading, the body joint's rotation turned by the heading.
 * Frames 0 .. frames-1 of a generator therefore equal those of generate (the walk by the same
 * C code; the rest by the same C solvers in the same order, measured equal within 1e-12 by
 * the tests). The guards are off by default; mlr_generator_set_guards applies the joint
 * limits and the floor to each frame (the contacts pinned by IK are not applied at run time:
 * see docs/primitives.md, "Runtime generation").
 *
 * Endless generation: after `frames` frames the generator starts the next segment of `frames`
 * frames, continuing the walk (the transition in progress first, from the last manifold point)
 * and the heading and body position; only the first segment is what generate returns.
 *
 * Work per call: the first mlr_generator_next computes the first segment whole. Each later
 * segment is computed ahead, in equal parts over the calls of the segment before it (its walk
 * and spline, then its GRBF rows four at a time, then its smoothing 16 outputs at a time), so no
 * later call does a whole segment's work; the parts are the same sums in the same order, so the
 * frames are those computed whole, bit for bit.
 *
 * Memory: mlr_gen_model_load allocates the model (two blocks) and its Markov model (two
 * blocks; a temporary copy of its arrays is released before returning); mlr_generator_create
 * the generator; its first mlr_generator_next the buffers of two segments (about
 * 2 frames * (n_out + 6) doubles, n_out = 4 + 7 J) and the GRBF's packed coefficients (about
 * 24 ceil(n_out / 24) (N + 3) doubles, N the GRBF centres) in one block, the smoothing's
 * factorization and, with noise or allow_unseen, the perturbed chain; the call that computes
 * the walk of a segment ahead (the first of each segment) allocates and releases the spline's
 * factorization; the other calls of mlr_generator_next allocate nothing.
 *
 * Threads: a model is read only after loading (generators on several threads may share it);
 * a generator serves one thread at a time.
 */
#ifndef MLR_GENERATE_H
#define MLR_GENERATE_H

#include "mlr_common.h"
#include "mlr_limits.h"
#include "mlr_motion.h"
#include "mlr_rig.h"

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/** The format version of model files this library reads and Python writes. */
#define MLR_GEN_FORMAT_VERSION 1

/** A loaded runtime model (mlr_gen_model_load): read only after loading, so one model may be
 *  shared by generators on several threads. Opaque. */
typedef struct mlr_gen_model mlr_gen_model;

/**
 * Load a model from the bytes of a model file (docs/model-format.md).
 * Everything is checked before it is used: the magic, the format version (another one is
 * refused naming both versions and the writer's library version), the byte order, the size,
 * the payload hash, every field's name (an unknown one is refused), type and dimensions
 * against the bytes that remain and against the other fields, the values (finite, states and
 * joints in range, probability rows). With skeleton != NULL the model's joints (names and
 * parents) must be the skeleton's, else the diag names the first joint that differs.
 * @param alloc     allocator (NULL: malloc/free), kept by the model
 * @param bytes     [in] the file's bytes; only read, not kept
 * @param size      their count
 * @param skeleton  [in] optional: the rig the frames are meant for
 * @param out       [out] the model; NULL on failure
 * @return MLR_OK; MLR_E_PARSE (not a model file, truncated, another format version or byte
 *         order, a bad field; the diag names it); MLR_E_INVALID_ARG (NULL pointers, another
 *         skeleton); MLR_E_NO_MEMORY. Nothing is allocated on failure.
 */
MLR_API mlr_status mlr_gen_model_load(const mlr_allocator *alloc, const void *bytes, size_t size,
                                      const mlr_motion *skeleton, mlr_gen_model **out,
                                      mlr_diag *diag);

/**
 * mlr_gen_model_load on a file's contents (read whole, at most 1 GiB).
 * @return as mlr_gen_model_load; MLR_E_IO (cannot open or read the file).
 */
MLR_API mlr_status mlr_gen_model_load_file(const mlr_allocator *alloc, const char *path,
                                           const mlr_motion *skeleton, mlr_gen_model **out,
                                           mlr_diag *diag);

/** Joints J of the model's skeleton. */
MLR_API size_t mlr_gen_model_n_joints(const mlr_gen_model *model);
/** The model's joint names, each NUL-terminated, in joint order (valid while the model is). */
MLR_API const char *mlr_gen_model_joint_name(const mlr_gen_model *model, size_t joint);
/** The joint the body position drives (the root on most rigs). */
MLR_API size_t mlr_gen_model_body_joint(const mlr_gen_model *model);
/** Training frames n (the start frames 0 .. n-1). */
MLR_API size_t mlr_gen_model_n_points(const mlr_gen_model *model);
/** Primitives k. */
MLR_API size_t mlr_gen_model_n_primitives(const mlr_gen_model *model);
/** Seconds per frame of the training clips. */
MLR_API double mlr_gen_model_frame_time(const mlr_gen_model *model);
/** Values per generated frame: 3 + 4 J (mlr_generator_next). */
MLR_API size_t mlr_gen_model_frame_size(const mlr_gen_model *model);
/** Free the model (after its generators). NULL is a no-op. */
MLR_API void mlr_gen_model_destroy(mlr_gen_model *model);

/** Keys of the options of a generator (docs/OPTIONS.md: the name of an option is the
 *  lower-case suffix of its key, the keyword of PrimitiveModel.generate where it has one). */
typedef enum mlr_generate_key {
    MLR_GEN_OPT_FRAMES = 1,      /* frames per segment, an integer in 2 .. 10,000,000 (300:
                                    `mlayer generate --frames`) */
    MLR_GEN_OPT_START_FRAME = 2, /* the training frame to start from, -1 (default): drawn */
    MLR_GEN_OPT_START = 3,       /* the first primitive, -1 (default): the start frame's label */
    MLR_GEN_OPT_RANK = 4,        /* 0 (default): sampled transitions; 1 most likely (equation
                                    5, most_likely), 2 second most likely (second_likely) */
    MLR_GEN_OPT_SMOOTH = 5,      /* lam of the LGS that smooths the outputs, >= 0 (2) */
    MLR_GEN_OPT_NOISE = 6,       /* the chain perturbed first (mlr_markov_perturb), >= 0
                                    (default 0: the learned chain) */
    MLR_GEN_OPT_ALLOW_UNSEEN = 7, /* 0 (default) or 1: the perturbation may open transitions the
                                    data never showed */
    MLR_GEN_OPT_PIN_FEET = 8     /* 1 (default) or 0: with the guards set
                                    (mlr_generator_set_guards), each foot found by name on the rig
                                    is pinned where it touches down (its lowest point within 0.08
                                    leg lengths of the model's floor, its ankle slower than 0.6
                                    leg lengths a second) by two-bone IK, and let go over 0.2 s
                                    when it lifts or leaves; 0: the guards do the limits and the
                                    floor only. Since 0.3 */
} mlr_generate_key;

/** One option: key (an mlr_generate_key) and its value. A frozen value type. */
typedef struct mlr_generate_option {
    int key;
    double value;
} mlr_generate_option;

/** The perturbation's generator is seeded with seed ^ MLR_GEN_NOISE_SEED_XOR (the first 64
 *  fractional bits of sqrt(2)), apart from the stream of the start frame and the walk. */
#define MLR_GEN_NOISE_SEED_XOR 0x6A09E667F3BCC908ull

/** A frame-by-frame generator over a model (mlr_generator_create): its own random state and
 *  buffers; one thread at a time. Opaque. */
typedef struct mlr_generator mlr_generator;

/**
 * A generator of frames from a model. The model must outlive it.
 * @param seed    seed of its mlr_rng (the start frame and the sampled transitions)
 * @param opts    [in] n_opts options (NULL when n_opts is 0); the others at their defaults
 * @return MLR_OK; MLR_E_INVALID_ARG (NULL pointers; an unknown key, a key given twice, a value
 *         out of range: "generate: option start_frame = 900 is not in -1 .. 799 (the model's
 *         training frames)"); MLR_E_NO_MEMORY (nothing allocated).
 * Allocates: the generator (the segment's buffers come at the first mlr_generator_next).
 */
MLR_API mlr_status mlr_generator_create(const mlr_allocator *alloc, const mlr_gen_model *model,
                                        uint64_t seed, const mlr_generate_option *opts,
                                        size_t n_opts, mlr_generator **out, mlr_diag *diag);

/**
 * Turn on the per-frame guards of generated frames, before the first mlr_generator_next. Each
 * frame is then finished, after step 7 above, as a stream's output is (mlr_stream_set_limits,
 * and the floor of examples/c/game_loop/character.c), on that frame alone:
 *  1. the joint limits (mlr_limits_apply's map at alpha 1) on its rotations, when limits is
 *     given (normally mlr_limits_create on the training clips: PrimitiveModel.joint_limits);
 *  2. the floor, when the model file holds its contact points and floor (the optional fields
 *     contact_names and floor_height, a finite floor): forward kinematics of the frame on the
 *     rig, and the body position raised by how far the lowest contact point is below the
 *     floor (y up, as the generated frames); a frame with every point above it is unchanged.
 *     The lift depends on the frame alone (no state), so it is as continuous as the frames;
 *  3. between the two, with MLR_GEN_OPT_PIN_FEET (the default) and the contact points: the feet
 *     (the contact joints with no contact joint above them, each with the points below it)
 *     pinned causally: a foot whose lowest point is within 0.08 leg lengths of the floor and
 *     whose ankle moved slower than 0.6 leg lengths a second since the frame before is held
 *     where it touched down, by two-bone IK on its leg (mlr_ik_apply_leg), the limits applied
 *     again to what the IK turned; when it lifts or moves on it is let go over 0.2 s.
 * The generator's walk, heading and body position are those of the unguarded frames: with the
 * guards off (the default) the frames are the ones described above, bit for bit. The guarded
 * frames are not PrimitiveModel.generate's guarded ones: that cleanup sees the whole clip and
 * pins each contact at its mean; this one sees the frames so far.
 * @param rig    [in] the model's skeleton (its joint names and parents; offsets, trans joints
 *               and End Sites for the kinematics); borrowed: it must outlive the generator
 * @param rest   [in] 3 + 3 P doubles (P = rig->n_trans): the root translation, then the trans
 *               joints' translations, that the frames keep where the generator does not drive
 *               them (Python's rest_root_pos, rest_trans; only the body joint's channels are
 *               generated); NULL: the root at 0, the trans joints at their offsets
 * @param limits [in] limits of the rig's joints, or NULL (no limits); borrowed, as rig, and
 *               not changed (mlr_limits_set_range) while the generator runs
 * @return MLR_OK; MLR_E_INVALID_ARG (NULL gen or rig, a bad rig, another skeleton than the
 *         model's: the diag names the first joint that differs, a body joint without position
 *         channels, limits of another count of joints, a non-finite rest value, a contact
 *         point of the model the rig does not have); MLR_E_BAD_STATE (set already, or frames
 *         generated already); MLR_E_NO_MEMORY. Nothing changes on failure.
 * Allocates: the guards' buffers (3 + 3 P + 7 J + 3 C doubles and 2 C int32, C the contact
 * points); mlr_generator_next allocates nothing more for them. Threads: as the generator.
 */
MLR_API mlr_status mlr_generator_set_guards(mlr_generator *gen, const mlr_rig *rig,
                                            const double *rest, const mlr_limits *limits,
                                            mlr_diag *diag);

/**
 * The next frame: pose[0 .. 2] the body position (x, height, z; the body joint's position
 * channels), then J quaternions (w, x, y, z; joint j at pose + 3 + 4 j), the body joint's with
 * the heading.
 * @param pose  [out] mlr_gen_model_frame_size(model) doubles
 * @return MLR_OK; MLR_E_INVALID_ARG (NULL); MLR_E_NO_MEMORY, MLR_E_SINGULAR (at a segment's
 *         start, also when computing it ahead failed: the failure is kept until its first
 *         frame is asked for; the generator is then unusable, MLR_E_BAD_STATE after).
 */
MLR_API mlr_status mlr_generator_next(mlr_generator *gen, double *pose, mlr_diag *diag);

/** Frames produced so far. */
MLR_API uint64_t mlr_generator_frame(const mlr_generator *gen);
/** The manifold point (row, column) of the last frame produced (both NaN before the first). */
MLR_API void mlr_generator_point(const mlr_generator *gen, double point[2]);
/** The primitive the last frame moves toward (-1 before the first frame). */
MLR_API int64_t mlr_generator_primitive(const mlr_generator *gen);
/** The start frame (drawn at the first mlr_generator_next when the option is -1; -1 before). */
MLR_API int64_t mlr_generator_start_frame(const mlr_generator *gen);

/** Free the generator. NULL is a no-op. */
MLR_API void mlr_generator_destroy(mlr_generator *gen);

#ifdef __cplusplus
}
#endif

#endif /* MLR_GENERATE_H */
