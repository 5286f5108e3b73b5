/* The loaded model of generation at run time (mlr_generate.h). Not installed. */
#ifndef MLR_GEN_INTERNAL_H
#define MLR_GEN_INTERNAL_H

#include "common/mlr_internal.h"

struct mlr_gen_model {
    mlr_allocator alloc;
    size_t bytes;          /* of block */
    void *block;           /* every array below, one allocation */
    size_t n_joints, body_joint, n_points, k, n_out, n_centers;
    double frame_time;
    char *names;           /* J names, each NUL-terminated */
    const char **name_at;  /* J pointers into names */
    int32_t *parents;      /* J */
    double *points;        /* n x 2 */
    int64_t *labels;       /* n */
    double *centers;       /* k x 2 */
    double bounds[4];      /* row lo, row hi, column lo, column hi */
    int kernel;
    double width;
    double *grbf_centers;  /* n_centers x 2 */
    double *grbf_coef;     /* (n_centers + 3) x n_out */
    mlr_markov *markov;
    size_t n_contacts;     /* contact points (0: none in the file) */
    char *contact_names;   /* n_contacts names, each NUL-terminated ("Joint" or "Joint/End") */
    double floor_height;   /* the training clips' floor along y, NaN: none */
};

#endif
