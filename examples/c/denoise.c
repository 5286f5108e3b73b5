/*
 * Denoise (or stylize) a BVH clip with the C library, as mlayer.denoise / mlayer.stylize do:
 * read the file, decompose the motion into layers, synthesize it with one alpha, make the
 * result plausible with the guards (joint limits, foot contacts, the floor), write it back.
 *
 *     denoise IN.bvh OUT.bvh [ALPHA]     (ALPHA 1, the default: denoised; 2: exaggerated)
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

int main(int argc, char **argv)
{
    if (argc < 3 || argc > 4) {
        fprintf(stderr, "usage: %s IN.bvh OUT.bvh [ALPHA]\n", argv[0]);
        return 2;
    }
    const double alpha = argc == 4 ? strtod(argv[3], NULL) : 1.0;
    mlr_diag diag = {0};
    mlr_motion *m = NULL;
    mlr_layers *layers = NULL;
    mlr_guards *guards = NULL;
    const char **names = NULL;
    int rc = 1;

    /* 1. Read the clip: a skeleton and N frames of root translation and joint quaternions. */
    mlr_status st = mlr_bvh_read_file(argv[1], NULL, &m, &diag);
    if (st < 0)
        return failed(argv[1], st, &diag);
    const size_t n = mlr_motion_n_frames(m), j = mlr_motion_n_joints(m);
    const double fps = 1.0 / mlr_motion_frame_time(m);
    double *root = mlr_motion_root_pos_mut(m); /* N x 3, synthesized in place below */
    double *rot = mlr_motion_rot_mut(m);       /* N x J x 4, scalar-first */

    /* 2. Decompose. With the frame rate given, the base layer keeps trends slower than 0.25 Hz
     *    (the base floor) and outlier frames are found and down-weighted (on by default). */
    const mlr_layers_option opts[] = {{MLR_LAYERS_OPT_FPS, fps}};
    st = mlr_layers_decompose(n, j, root, rot, opts, 1, NULL, &layers, &diag);
    if (st < 0) {
        failed("decompose", st, &diag);
        goto done;
    }

    /* 3. The guards learn from the input: the rig (names find the feet and the hinges), its
     *    contacts, its floor and its joint limits. Repair the input's outlier frames first, so
     *    that a glitch is not taken for a contact or a joint's range. */
    names = malloc(j * sizeof *names);
    if (!names)
        goto done;
    for (size_t k = 0; k < j; k++)
        names[k] = mlr_motion_joint_name(m, k);
    const mlr_rig rig = {j,
                         mlr_motion_parents(m),
                         mlr_motion_offsets(m),
                         names,
                         mlr_motion_n_trans(m),
                         mlr_motion_trans_joints(m),
                         mlr_motion_n_end_sites(m),
                         mlr_motion_end_site_parents(m),
                         mlr_motion_end_site_offsets(m)};
    st = mlr_layers_repair(layers, 0, n, root, 3 * n, rot, 4 * n * j, NULL, &diag);
    if (st >= 0)
        st = mlr_guards_create(&rig, fps, n, root, rot, mlr_motion_trans(m), NULL, 0, NULL,
                               &guards, &diag);
    if (st < 0) {
        failed("guards", st, &diag);
        goto done;
    }

    /* 4. Synthesize Mb (+) alpha delta_c over the whole clip (one alpha for every joint and the
     *    root), into the motion's own arrays, then apply the guards in place, with the input
     *    as their reference (NULL). */
    st = mlr_layers_synthesize(layers, 0, n, &alpha, 1, root, 3 * n, rot, 4 * n * j, &diag);
    mlr_guards_report report;
    if (st >= 0)
        st = mlr_guards_apply_trans(guards, &alpha, 1, NULL, NULL, NULL, root, rot,
                                    mlr_motion_trans_mut(m), NULL, 0, &report, &diag);
    if (st < 0) {
        failed("synthesize", st, &diag);
        goto done;
    }

    /* 5. Write the result (through a temporary file renamed into place). */
    st = mlr_bvh_write_file(m, argv[2], &diag);
    if (st < 0) {
        failed(argv[2], st, &diag);
        goto done;
    }
    printf("%s: %zu frames x %zu joints at %.0f fps, alpha %g -> %s\n", argv[1], n, j, fps, alpha,
           argv[2]);
    printf("guards: limits %s (%zu joints), feet pinned on %zu frames, raised to the floor on "
           "%zu\n",
           report.limits_applied ? "on" : "off", report.limited_joints, report.contact_frames,
           report.floor_frames);
    rc = 0;
done:
    free(names);
    mlr_guards_destroy(guards);
    mlr_layers_destroy(layers);
    mlr_motion_destroy(m);
    return rc;
}
