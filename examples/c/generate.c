/*
 * Generate an endless walk (or idle) from a trained primitives model, without Python: the
 * model file PrimitiveModel.save_runtime writes (docs/model-format.md) is loaded against the
 * game's rig, and a generator produces one frame per call (mlr_generate.h); here FRAMES frames
 * go into a BVH file of the rig.
 *
 *     generate RIG.bvh MODEL.mlrgen OUT.bvh FRAMES [SEED [SEGMENT]]
 *
 * RIG.bvh gives the skeleton (its joint names and tree must be the model's, else the loader
 * names the first joint that differs) and, for a rig whose body joint is below a static root,
 * the root's position (its first frame). GUARDS 1 turns on the per-frame guards
 * (mlr_generator_set_guards): the joint limits learned from RIG.bvh's frames (give a training
 * clip) and the model's floor. SEGMENT (default 300) is the generator's
 * option frames (MLR_GEN_OPT_FRAMES): the first SEGMENT frames are those of `mlayer generate --frames SEGMENT
 * --seed SEED --no-guards`; the frames after them continue the walk. It prints the time of the
 * first mlr_generator_next call (it computes the first segment) and the median, mean, 99th and
 * 99.9th percentiles and largest time of the others, in wall time and in the thread's processor
 * time (the wall time includes the time the machine gave to other jobs during a call).
 *
 * Build: cc generate.c $(pkg-config --cflags --libs mlayer) -o generate
 */
#define _POSIX_C_SOURCE 200809L /* clock_gettime, CLOCK_THREAD_CPUTIME_ID */
#include <mlayer/mlayer.h>

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static double now(void)
{
    struct timespec t;
    timespec_get(&t, TIME_UTC);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

/* The processor time of this thread: a call's own work, without the time the machine gave
 * to other jobs meanwhile (the wall time includes it). 0 where there is no such clock. */
static double cpu_now(void)
{
#ifdef CLOCK_THREAD_CPUTIME_ID
    struct timespec t;
    if (clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t) == 0)
        return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
#endif
    return 0.0;
}

static int by_value(const void *a, const void *b)
{
    const double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* Median, mean, 99th and 99.9th percentiles (nearest rank) and largest of n > 0 times (sorted
 * here), in microseconds. */
static void summary(const char *what, double *t, size_t n)
{
    double total = 0;
    for (size_t i = 0; i < n; i++)
        total += t[i];
    qsort(t, n, sizeof *t, by_value);
    printf("  %s: median %.2f us, mean %.2f us, 99th percentile %.1f us, 99.9th %.1f us, "
           "slowest %.1f us\n",
           what, 1e6 * t[(n - 1) / 2], 1e6 * total / (double)n, 1e6 * t[(n * 99 + 99) / 100 - 1],
           1e6 * t[(n * 999 + 999) / 1000 - 1], 1e6 * t[n - 1]);
}

static int failed(const char *what, mlr_status st, const mlr_diag *diag)
{
    fprintf(stderr, "generate: %s: %s (%s)\n", what, diag->message, mlr_status_name(st));
    return 1;
}

/* A motion of the rig's skeleton with n frames (the rest pose). */
static mlr_status rig_motion(const mlr_motion *rig, size_t n, mlr_motion **out, mlr_diag *diag)
{
    size_t J = mlr_motion_n_joints(rig);
    const char **names = malloc(J * sizeof *names), **chans = malloc(J * sizeof *chans);
    if (!names || !chans) {
        free(names);
        free(chans);
        return MLR_E_NO_MEMORY;
    }
    for (size_t j = 0; j < J; j++) {
        names[j] = mlr_motion_joint_name(rig, j);
        chans[j] = mlr_motion_joint_channels(rig, j);
    }
    mlr_status st = mlr_motion_create(
        J, names, mlr_motion_parents(rig), mlr_motion_offsets(rig), chans,
        mlr_motion_n_end_sites(rig), mlr_motion_end_site_parents(rig),
        mlr_motion_end_site_offsets(rig), n, mlr_motion_frame_time(rig), NULL, out, diag);
    free(names);
    free(chans);
    return st;
}

int main(int argc, char **argv)
{
    if (argc < 5 || argc > 8) {
        fprintf(stderr, "usage: generate RIG.bvh MODEL.mlrgen OUT.bvh FRAMES [SEED [SEGMENT "
                        "[GUARDS]]]\n");
        return 2;
    }
    const int guards = argc > 7 && atoi(argv[7]) != 0;
    long frames = atol(argv[4]);
    unsigned long long seed = argc > 5 ? strtoull(argv[5], NULL, 10) : 0;
    double segment = argc > 6 ? atof(argv[6]) : 300;
    if (frames < 1) {
        fprintf(stderr, "generate: FRAMES must be >= 1, got %s\n", argv[4]);
        return 2;
    }
    mlr_diag diag = {0};
    mlr_motion *rig = NULL, *out = NULL;
    mlr_gen_model *model = NULL;
    mlr_generator *gen = NULL;
    double *pose = NULL, *took = NULL, *rest = NULL;
    const char **names = NULL;
    mlr_limits *limits = NULL;
    int rc = 1;
    mlr_status st = mlr_bvh_read_file(argv[1], NULL, &rig, &diag);
    if (st) {
        rc = failed(argv[1], st, &diag);
        goto done;
    }
    st = mlr_gen_model_load_file(NULL, argv[2], rig, &model, &diag);
    if (st) {
        rc = failed(argv[2], st, &diag);
        goto done;
    }
    mlr_generate_option opts[] = {{MLR_GEN_OPT_FRAMES, segment}};
    st = mlr_generator_create(NULL, model, seed, opts, 1, &gen, &diag);
    if (!st)
        st = rig_motion(rig, (size_t)frames, &out, &diag);
    if (st) {
        rc = failed("generator", st, &diag);
        goto done;
    }
    size_t J = mlr_gen_model_n_joints(model), body = mlr_gen_model_body_joint(model);
    size_t P = mlr_motion_n_trans(out), slot = P;
    /* The guards: the joint limits learned from RIG.bvh's frames, the model's floor; the root
     * and the other position channels at RIG.bvh's first frame. rig_view, names and limits
     * must outlive the generator. */
    mlr_rig rig_view = {0};
    if (guards) {
        names = malloc(J * sizeof *names);
        rest = malloc((3 + 3 * P) * sizeof *rest);
        if (!names || !rest || mlr_motion_n_frames(rig) == 0) {
            fprintf(stderr, "generate: GUARDS needs the frames of %s\n", argv[1]);
            goto done;
        }
        for (size_t j = 0; j < J; j++)
            names[j] = mlr_motion_joint_name(rig, j);
        mlr_rig r = {J,
                     mlr_motion_parents(rig),
                     mlr_motion_offsets(rig),
                     names,
                     P,
                     mlr_motion_trans_joints(rig),
                     mlr_motion_n_end_sites(rig),
                     mlr_motion_end_site_parents(rig),
                     mlr_motion_end_site_offsets(rig)};
        rig_view = r;
        memcpy(rest, mlr_motion_root_pos(rig), 3 * sizeof *rest);
        if (P)
            memcpy(rest + 3, mlr_motion_trans(rig), 3 * P * sizeof *rest);
        const mlr_limits_clip clip = {mlr_motion_n_frames(rig), mlr_motion_rot(rig),
                                      mlr_motion_trans(rig)};
        st = mlr_limits_create(&rig_view, &clip, 1, NULL, 0, NULL, &limits, &diag);
        if (!st)
            st = mlr_generator_set_guards(gen, &rig_view, rest, limits, &diag);
        if (st) {
            rc = failed("guards", st, &diag);
            goto done;
        }
    }
    const int32_t *tj = mlr_motion_trans_joints(out);
    for (size_t i = 0; i < P; i++)
        if ((size_t)tj[i] == body)
            slot = i;
    if (body != 0 && slot == P) {
        fprintf(stderr, "generate: the body joint %s has no position channels in %s\n",
                mlr_gen_model_joint_name(model, body), argv[1]);
        goto done;
    }
    pose = malloc(mlr_gen_model_frame_size(model) * sizeof *pose);
    took = malloc(2 * (size_t)frames * sizeof *took); /* wall, then processor times */
    if (!pose || !took)
        goto done;
    double *root = mlr_motion_root_pos_mut(out), *rot = mlr_motion_rot_mut(out);
    double *trans = mlr_motion_trans_mut(out);
    const double *rig_root = mlr_motion_n_frames(rig) ? mlr_motion_root_pos(rig) : NULL;
    for (long f = 0; f < frames; f++) {
        double t0 = now(), c0 = cpu_now();
        st = mlr_generator_next(gen, pose, &diag);
        took[f] = now() - t0;
        took[frames + f] = cpu_now() - c0;
        if (st) {
            rc = failed("frame", st, &diag);
            goto done;
        }
        memcpy(rot + (size_t)f * J * 4, pose + 3, J * 4 * sizeof(double));
        if (body == 0) {
            memcpy(root + (size_t)f * 3, pose, 3 * sizeof(double));
        } else {
            memcpy(trans + ((size_t)f * P + slot) * 3, pose, 3 * sizeof(double));
            if (rig_root)
                memcpy(root + (size_t)f * 3, rig_root, 3 * sizeof(double));
        }
    }
    st = mlr_bvh_write_file(out, argv[3], &diag);
    if (st) {
        rc = failed(argv[3], st, &diag);
        goto done;
    }
    printf("generate: wrote %s (%ld frames, start frame %lld, seed %llu); the first call "
           "took %.0f us (%.0f us of processor time); the other calls:\n",
           argv[3], frames, (long long)mlr_generator_start_frame(gen), seed, 1e6 * took[0],
           1e6 * took[frames]);
    if (frames > 1) {
        summary("wall time", took + 1, (size_t)frames - 1);
        summary("processor time", took + frames + 1, (size_t)frames - 1);
    }
    rc = 0;
done:
    free(took);
    free(pose);
    mlr_generator_destroy(gen);
    mlr_limits_destroy(limits);
    free(rest);
    free(names);
    mlr_gen_model_destroy(model);
    mlr_motion_destroy(out);
    mlr_motion_destroy(rig);
    return rc;
}
