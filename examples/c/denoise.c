/*
 * Denoise (or stylize) BVH clips with the C library, as mlayer.denoise / mlayer.stylize do:
 * one mlr_pipeline (the layers, the guards and their defaults composed in the library), reused
 * clip after clip.
 *
 *     denoise IN.bvh OUT.bvh [ALPHA [PATTERN=ALPHA ...]]
 *     denoise --batch ALPHA IN1.bvh OUT1.bvh [IN2.bvh OUT2.bvh ...]
 *
 * ALPHA 1 (the default) denoises, 2 exaggerates the style, 0.5 flattens it; PATTERN=ALPHA gives
 * the joints matching a name or glob their own alpha ("Left*=3"), later patterns winning.
 *
 * Build: cc denoise.c $(pkg-config --cflags --libs mlayer) -o denoise
 */
#include <mlayer/mlayer.h>

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Print the library's message for a failed call and say so. */
static int failed(const char *what, mlr_status st, const mlr_diag *diag)
{
    fprintf(stderr, "denoise: %s: %s (%s)\n", what, diag->message, mlr_status_name(st));
    return 1;
}

/* Read in, run the pipeline into *out (reused from clip to clip), write it to out_path. */
static int one_clip(mlr_pipeline *p, const char *in_path, const char *out_path, mlr_motion **out)
{
    mlr_diag diag = {0};
    mlr_motion *m = NULL;
    mlr_status st = mlr_bvh_read_file(in_path, NULL, &m, &diag);
    if (st < 0)
        return failed(in_path, st, &diag);

    /* trim, up axis, layers, repaired input, guards, synthesis, guards applied: one call */
    st = mlr_pipeline_run(p, m, out, &diag);
    if (st < 0) {
        mlr_motion_destroy(m);
        return failed(in_path, st, &diag);
    }
    if (diag.message[0]) /* a guard that cannot run (no feet found): a note, not an error */
        fprintf(stderr, "denoise: %s: %s\n", in_path, diag.message);
    mlr_motion_destroy(m);

    st = mlr_bvh_write_file(*out, out_path, &diag); /* a temporary renamed into place */
    if (st < 0)
        return failed(out_path, st, &diag);

    mlr_guards_report report;
    double up, alpha;
    mlr_pipeline_report(p, &report, NULL, 0);
    mlr_pipeline_get(p, MLR_PIPELINE_INFO_UP, &up);
    mlr_pipeline_get(p, MLR_PIPELINE_ALPHA, &alpha);
    printf("%s: %zu frames x %zu joints, %c-up, alpha %g -> %s\n", in_path,
           mlr_motion_n_frames(*out), mlr_motion_n_joints(*out), "XYZ"[(int)up], alpha, out_path);
    printf("guards: limits %s (%zu joints), feet pinned on %zu frames, raised to the floor on "
           "%zu\n",
           report.limits_applied ? "on" : "off", report.limited_joints, report.contact_frames,
           report.floor_frames);
    return 0;
}

int main(int argc, char **argv)
{
    const int batch = argc >= 2 && strcmp(argv[1], "--batch") == 0;
    if (batch ? argc < 5 || (argc - 3) % 2 != 0 : argc < 3) {
        fprintf(stderr,
                "usage: %s IN.bvh OUT.bvh [ALPHA [PATTERN=ALPHA ...]]\n"
                "       %s --batch ALPHA IN1.bvh OUT1.bvh [IN2.bvh OUT2.bvh ...]\n",
                argv[0], argv[0]);
        return 2;
    }
    mlr_diag diag = {0};
    mlr_pipeline *p = NULL;
    mlr_status st = mlr_pipeline_create(NULL, &p, &diag);
    if (st < 0)
        return failed("pipeline", st, &diag);

    /* the parameters: every one has mlayer.stylize's default until set */
    const char *alpha_arg = batch ? argv[2] : argc > 3 ? argv[3] : "1";
    st = mlr_pipeline_set(p, MLR_PIPELINE_ALPHA, strtod(alpha_arg, NULL), &diag);
    for (int k = 4; !batch && st >= 0 && k < argc; k++) {
        char pattern[128];
        const char *eq = strchr(argv[k], '=');
        const size_t len = eq ? (size_t)(eq - argv[k]) : 0;
        if (!eq || len == 0 || len >= sizeof pattern) {
            fprintf(stderr, "denoise: expected PATTERN=ALPHA, got '%s'\n", argv[k]);
            mlr_pipeline_destroy(p);
            return 2;
        }
        memcpy(pattern, argv[k], len);
        pattern[len] = '\0';
        st = mlr_pipeline_set_joint_alpha(p, pattern, strtod(eq + 1, NULL), &diag);
    }
    if (st < 0) {
        mlr_pipeline_destroy(p);
        return failed("parameters", st, &diag);
    }

    int rc = 0;
    mlr_motion *out = NULL; /* the result, overwritten in place clip after clip */
    for (int k = batch ? 3 : 1; rc == 0 && k + 1 < argc; k += 2) {
        rc = one_clip(p, argv[k], argv[k + 1], &out);
        if (!batch)
            break;
    }
    mlr_motion_destroy(out);
    mlr_pipeline_destroy(p);
    return rc;
}
