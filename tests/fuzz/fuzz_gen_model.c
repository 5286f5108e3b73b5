/* libFuzzer target for the runtime model loader (mlr_gen_model_load) and the generator over
 * what loads (built only with clang; see run_gen_model.sh). Built with
 * FUZZING_BUILD_MODE_UNSAFE_FOR_PRODUCTION, under which the loader skips its CRC-32 and
 * skeleton-hash checks, so that mutations reach the fields. Oracles beyond "no crash, no leak,
 * no UB": the status is OK, PARSE or NO_MEMORY (a capped allocator), a failure carries a
 * message and leaves no allocation behind, and the frames of what loads are finite with unit
 * quaternions. MLR_FUZZ_WRITE_SEED=PATH writes the seed (tests/gen_model_file.h) and exits. */
#include <mlayer/mlayer.h>

#include "../gen_model_file.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

typedef struct capped {
    size_t live, blocks;
} capped;

static void *cap_alloc(void *user, size_t size, size_t align)
{
    capped *c = user;
    (void)align;
    if (size > ((size_t)64 << 20) || c->live + size > ((size_t)256 << 20))
        return NULL;
    void *p = malloc(size);
    if (p) {
        c->live += size;
        c->blocks++;
    }
    return p;
}

static void cap_release(void *user, void *ptr, size_t size)
{
    capped *c = user;
    c->live -= size;
    c->blocks--;
    free(ptr);
}

static void check(int ok)
{
    if (!ok)
        abort();
}

int LLVMFuzzerInitialize(int *argc, char ***argv);
int LLVMFuzzerInitialize(int *argc, char ***argv)
{
    (void)argc;
    (void)argv;
    const char *path = getenv("MLR_FUZZ_WRITE_SEED");
    if (path) {
        buf f = model_file(1, 0x01020304u, 0, 6);
        FILE *o = fopen(path, "wb");
        check(o && fwrite(f.b, 1, f.n, o) == f.n && fclose(o) == 0);
        free(f.b);
        exit(0);
    }
    return 0;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    capped c = {0, 0};
    mlr_allocator a = {cap_alloc, cap_release, &c};
    mlr_gen_model *m = NULL;
    mlr_diag d;
    d.message[0] = 0;
    mlr_status st = mlr_gen_model_load(&a, data, size, NULL, &m, &d);
    check(st == MLR_OK || st == MLR_E_PARSE || st == MLR_E_NO_MEMORY);
    if (st) {
        check(m == NULL && c.blocks == 0 && d.message[0] != 0);
        return 0;
    }
    mlr_generator *g = NULL;
    /* odd sizes walk a perturbed chain (mlr_markov_perturb), even ones the learned one */
    mlr_generate_option opts[] = {{MLR_GEN_OPT_FRAMES, 16},
                                  {MLR_GEN_OPT_NOISE, size % 2 ? 0.3 : 0.0}};
    if (mlr_generator_create(&a, m, 1, opts, 2, &g, &d) == MLR_OK) {
        size_t n = mlr_gen_model_frame_size(m), J = mlr_gen_model_n_joints(m);
        double *pose = malloc(n * sizeof *pose);
        for (int f = 0; pose && f < 40; f++) {
            st = mlr_generator_next(g, pose, &d);
            if (st)
                break;
            /* the body position may be huge for wild coefficients, never NaN */
            for (size_t i = 0; i < 3; i++)
                check(!isnan(pose[i]));
            for (size_t j = 0; j < J; j++) {
                const double *q = pose + 3 + 4 * j;
                double s = q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3];
                check(fabs(s - 1.0) < 1e-9);
            }
        }
        free(pose);
    }
    mlr_generator_destroy(g);
    mlr_gen_model_destroy(m);
    check(c.blocks == 0);
    return 0;
}
