/*
 * The streaming filter in a fixed-timestep game loop: capture frames arrive one at a time at
 * the capture rate, the game renders at its own rate, and each simulation step pushes the
 * newest frame into a fixed-lag LGS smoother (mlr_stream) and poses the character with the
 * smoothed frame from `lag` steps ago. Nothing allocates inside the loop.
 *
 *     stream IN.bvh OUT.bvh [LAG]     (the capture is replayed from IN; OUT is what was shown)
 *
 * Build: cc stream.c $(pkg-config --cflags --libs mlayer) -lm -o stream
 */
#include <mlayer/mlayer.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Pose frame k of `shown` with one frame of the stream's layout (root, translations, rotations). */
static void pose(mlr_motion *shown, size_t k, const double *o, size_t p, size_t j)
{
    memcpy(mlr_motion_root_pos_mut(shown) + 3 * k, o, 3 * sizeof(double));
    if (p)
        memcpy(mlr_motion_trans_mut(shown) + 3 * p * k, o + 3, 3 * p * sizeof(double));
    memcpy(mlr_motion_rot_mut(shown) + 4 * j * k, o + 3 + 3 * p, 4 * j * sizeof(double));
}

int main(int argc, char **argv)
{
    if (argc < 3 || argc > 4) {
        fprintf(stderr, "usage: %s IN.bvh OUT.bvh [LAG]\n", argv[0]);
        return 2;
    }
    const size_t lag = argc == 4 ? (size_t)strtoul(argv[3], NULL, 10) : 10;
    mlr_diag diag = {0};
    mlr_motion *capture = NULL, *shown = NULL;
    mlr_stream *st = NULL;
    double *frame = NULL, *out = NULL;
    int rc = 1;

    mlr_status s = mlr_bvh_read_file(argv[1], NULL, &capture, &diag);
    if (s >= 0) /* the poses the character is given, on the same skeleton */
        s = mlr_motion_copy_frames(capture, 0, mlr_motion_n_frames(capture), &shown, &diag);
    if (s < 0) {
        fprintf(stderr, "stream: %s: %s\n", argv[1], diag.message);
        goto done;
    }
    const size_t n = mlr_motion_n_frames(capture), j = mlr_motion_n_joints(capture);
    const size_t p = mlr_motion_n_trans(capture);
    const double dt = mlr_motion_frame_time(capture); /* the fixed simulation step */

    /* Created once, before the loop: everything the stream will use is allocated here.
     * lam 1, sigma 1: a light smoothing; the gap to the offline solve shrinks as rho^lag. */
    s = mlr_stream_create(j, 1, p, 1.0, 1.0, lag, NULL, &st, &diag);
    if (s < 0) {
        fprintf(stderr, "stream: %s\n", diag.message);
        goto done;
    }
    const size_t width = mlr_stream_frame_size(st); /* 3 + 3 P + 4 J */
    frame = malloc(width * sizeof *frame);
    out = malloc((lag + 1) * width * sizeof *out);
    if (!frame || !out)
        goto done;

    size_t pushed = 0, posed = 0;
    double accumulator = 0.0;
    for (int tick = 0; pushed < n; tick++) {
        /* The render loop's elapsed time: about 60 Hz with some jitter. */
        accumulator += 1.0 / 60.0 * (1.0 + 0.2 * sin(0.7 * tick));
        while (accumulator >= dt && pushed < n) { /* fixed-timestep simulation steps */
            accumulator -= dt;
            /* The newest capture frame, in the stream's layout: root, translations, rotations. */
            memcpy(frame, mlr_motion_root_pos(capture) + 3 * pushed, 3 * sizeof(double));
            if (p)
                memcpy(frame + 3, mlr_motion_trans(capture) + 3 * p * pushed,
                       3 * p * sizeof(double));
            memcpy(frame + 3 + 3 * p, mlr_motion_rot(capture) + 4 * j * pushed,
                   4 * j * sizeof(double));
            size_t ready = 0;
            s = mlr_stream_push(st, frame, width, out, width, &ready, &diag);
            pushed++;
            if (s < 0) {
                fprintf(stderr, "stream: frame %zu: %s\n", pushed - 1, diag.message);
                goto done;
            }
            if (ready) /* the smoothed frame pushed - 1 - lag: pose the character with it */
                pose(shown, posed++, out, p, j);
        }
    }
    /* The capture ended: the last `lag` frames, exactly as the offline solve gives them. */
    size_t written = 0;
    s = mlr_stream_flush(st, out, (lag + 1) * width, &written, &diag);
    for (size_t k = 0; s >= 0 && k < written; k++)
        pose(shown, posed++, out + k * width, p, j);
    if (s >= 0)
        s = mlr_bvh_write_file(shown, argv[2], &diag);
    if (s < 0) {
        fprintf(stderr, "stream: %s\n", diag.message);
        goto done;
    }
    printf("%s: %zu frames streamed with lag %zu (%.1f ms behind), rho %.3f -> %s\n", argv[1],
           posed, lag, 1000.0 * (double)lag * dt, mlr_stream_decay_rate(1.0, 1.0), argv[2]);
    rc = posed == n ? 0 : 1;
done:
    free(frame);
    free(out);
    mlr_stream_destroy(st);
    mlr_motion_destroy(shown);
    mlr_motion_destroy(capture);
    return rc;
}
