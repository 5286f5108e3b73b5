/* Internals of the motion layers (layers.c, layers_base.c, layers_control.c, layers_batch.c).
 * Not installed. */
#ifndef MLR_LAYERS_INTERNAL_H
#define MLR_LAYERS_INTERNAL_H

#include "math/lgs_internal.h"

/* Number of values per group in the parameter table (mlr_layers_param). */
#define MLR_LAYERS_N_PARAM 9

/* Work doubles per group of the stages (see layers__base, layers__control). */
#define MLR_LAYERS_WORK 56

struct mlr_layers {
    mlr_allocator alloc;
    size_t n, j;         /* frames, joints */
    size_t bytes;        /* of the single allocation holding the struct and its arrays */
    double *base_pos;    /* n x 3 */
    double *base_rot;    /* n x j x 4, unit */
    double *control;     /* n x (1 + j) x 3 */
    double *residual;    /* n x (1 + j) x 3 */
    double *param;       /* MLR_LAYERS_N_PARAM x (1 + j), param[which * (1 + j) + g] */
    unsigned char *outliers; /* n x (1 + j): 1 where a frame of a group was down-weighted */
    size_t end_runs[2]; /* layers__end_runs' runs, made outliers (0 when none or not robust) */
};

/* Settings of one decomposition, validated. */
typedef struct mlr_layers_cfg {
    double gamma;
    double base_s; /* > 0: fixed base s for every group; 0: heuristic */
    double control_s; /* > 0: fixed control s; 0: GCV */
    double base_s_min, base_s_max;
    double control_s_min, control_s_max;
    size_t body_joint; /* the joint whose base s the translation group takes */
    int robust; /* find and down-weight outlier frames (layers_robust.c) */
    double robust_s; /* s of the detection smoother */
    double robust_angle; /* gate of the joints' residual angle, radians */
    double robust_length; /* gate of the translation residual; 0: relative to its median */
    size_t robust_window; /* frames a realignment looks back over */
} mlr_layers_cfg;

/* Observation weights of a robust decomposition: w (n x (1 + j), group g of frame i at
 * i (1 + j) + g, in (0, 1]) and the scratch wpk (n x (1 + j)) for the weights of the systems
 * of one batch, packed. */
typedef struct mlr_lay_robust {
    double *w, *wpk;
} mlr_lay_robust;

/* The weights of groups g0 + col[k] / cw (k < ns) packed into rb->wpk (n x ns), and the
 * weighted observations w y (the m channels col[k] .. col[k] + m - 1 of the rows of y, stride
 * ldy) packed into comp (stride m ns). ng = 1 + j. */
void layers__pack_weighted(size_t n, size_t ng, const mlr_lay_robust *rb, size_t g0, size_t cw,
                           const size_t *col, size_t ns, size_t m, const double *y, size_t ldy,
                           double *comp);

/* Find the outlier frames of every group (layers_robust.c): iteratively reweighted LGS at
 * cfg->robust_s, per joint on the quaternions q (n x j x 4, unit, sign-continuous; realigned
 * here so that a frame takes the hemisphere of the most similar of its last robust_window
 * frames that are not outliers) and on
 * the translation root_pos (NULL: none). Weights into rb->w, flags into L->outliers; *any is 1
 * when some weight is below 1. fac: 3 n j doubles; fit: 4 n j doubles; rhs: 5 n j doubles;
 * work: 14 j doubles. */
mlr_status layers__robust_weights(mlr_layers *L, const mlr_layers_cfg *cfg, double *q,
                                  const double *root_pos, const mlr_lay_robust *rb, double *fac,
                                  double *fit, double *rhs, double *work, int *any,
                                  mlr_diag *diag);

/* The body translation's runs at the clip's ends, p n x 3: ends[0] frames at the start and
 * ends[1] at the end (0: none), each the shortest run of 1 to 10 frames that the translation
 * leaves (or enters) by a step more than 10 times every step inside the run and in the 3 steps
 * beyond it, with at least 8 frames left outside the runs: a converter's T-pose frame before
 * the capture. The robust decomposition makes these frames outliers for the translation and for
 * every joint that jumps there too (layers_robust.c; mlr_layers_get_end_runs reports them); the
 * pipeline passes them through. */
void layers__end_runs(size_t n, const double *p, size_t ends[2]);
/* The same runs found from the pose where the translation gave none (ends[e] == 0 on entry):
 * the shortest run of 1 to 10 frames that at least 3 joints (q: n x j x 4 unit quaternions)
 * leave (or enter) by a turn of more than 20 degrees and more than 10 times each of their turns
 * inside the run and in the 3 beyond it: CMU's rest frame before a capture, the root already
 * where the capture starts (a pybvh export of 12_01: arms 82 degrees, a knee 52, against
 * 2.5 a frame after it). */
void layers__pose_end_runs(size_t n, size_t j, const double *q, size_t ends[2]);

/*
 * Batched LDL^T of ns pentadiagonal systems A_k = I + s_k L^T L (L the n-row second
 * difference, n >= 3), factored and swept together: the recurrences of one system are
 * latency-bound, those of different systems are independent, so the loops run over systems
 * innermost. Factor arrays hold up to n rows of ns values, entry [r * ns + k]: dinv = 1 / D,
 * l1 = L(i, i-1), l2 = L(i, i-2) of system k. When the factor reaches a fixed point of its
 * recurrence at row k - 1 (k < n), rows k .. n-3 equal row k - 1 and are not stored; rows
 * n-2 and n-1 are stored at k and k + 1 (see layers__row). k == n: every row stored.
 */
typedef struct mlr_lay_batch {
    size_t n, ns, k;
    double *dinv, *l1, *l2;
    const double *w; /* NULL: A_k = I + s_k L^T L; else observation weights, n rows of ns
                        values [i * ns + k], A_k = W_k + s_k L^T L (every row stored: k == n),
                        and the caller passes W_k y as the right-hand side */
} mlr_lay_batch;

/* Storage row of factor row i. */
static inline size_t layers__row(const mlr_lay_batch *b, size_t i)
{
    if (i < b->k)
        return i;
    return i + 2 >= b->n ? b->k + (i + 2 - b->n) : b->k - 1;
}

/* Factor every system; 0 on success, or 1 + k for the first system k with a non-positive or
 * non-finite pivot (s far too large for n). */
size_t layers__batch_factor(mlr_lay_batch *b, const double *s);

/* x = A_k^-1 y for every system: system k owns the m contiguous channels [k m, (k+1) m) of
 * the rows of y (stride ldy) and of x (stride ldx); x and y do not overlap. buf is scratch of
 * 3 m ns doubles. */
void layers__batch_solve(const mlr_lay_batch *b, size_t m, const double *y, size_t ldy, double *x,
                         size_t ldx, double *buf);

/* acc[c] = sum_i (y_i[c] - x_i[c])^2 over the mm = m ns channels for x = A^-1 y (systems and
 * channels as for layers__batch_solve), without keeping x: z (stride ldz, not overlapping y)
 * receives the forward sweep only. buf is scratch of 6 m ns doubles. */
void layers__batch_rss(const mlr_lay_batch *b, size_t m, const double *y, size_t ldy, double *z,
                       size_t ldz, double *buf, double *acc);

/* acc[c] = sum_i (y[i mm + c] - x[i mm + c])^2 over n rows of mm channels. */
void layers__sum_sq_diff(size_t n, size_t mm, const double *y, const double *x, double *acc);

/* tr(A_k^-1 W_k) for every system (W_k = I without weights) by selected inversion over the
 * factor (rolling, O(n ns) at most); work holds 3 ns doubles. */
void layers__batch_trace(const mlr_lay_batch *b, double *trace, double *work);

/* layers__batch_trace that also writes the leverages, the diagonal of A_k^-1 W_k, into lev
 * (n rows of ns values, [i * ns + k]; every row visited, O(n ns)). */
void layers__batch_leverage(const mlr_lay_batch *b, double *trace, double *lev, double *work);

/* The stages of mlr_layers_decompose; work areas are owned by the caller. */

/* rot_in (n x j x 4) normalized and made sign-continuous into q; MLR_E_INVALID_ARG with the
 * frame and joint of a zero or non-finite quaternion. */
mlr_status layers__prepare_rot(size_t n, size_t j, const double *rot_in, double *q,
                               mlr_diag *diag);

/* With weights rb (NULL: none), every LGS of the stages below weights its observations by
 * rb->w and the base heuristic's angle bound and the largest displacements skip the outlier
 * frames. */

/* Base layer: per-joint s (heuristic or cfg->base_s) into L->param, L->base_rot filled with
 * the unit base quaternions; root translation smoothed with joint cfg->body_joint's s into
 * L->base_pos.
 * fac: 3 n j doubles; comp: 4 n j doubles; work: MLR_LAYERS_WORK j doubles; col: j entries. */
mlr_status layers__base(mlr_layers *L, const mlr_layers_cfg *cfg, const double *q,
                        const double *root_pos, const mlr_lay_robust *rb, double *fac,
                        double *comp, double *work, size_t *col, mlr_diag *diag);

/* Control layer: delta (n x (1+j) x 3) smoothed into L->control with s per group by GCV
 * (or cfg->control_s); parameters into L->param. fac: 3 n (1+j) doubles; comp: 3 n (1+j)
 * doubles; work: MLR_LAYERS_WORK (1+j) doubles; col: 1+j entries. */
mlr_status layers__control(mlr_layers *L, const mlr_layers_cfg *cfg, const double *delta,
                           const mlr_lay_robust *rb, double *fac, double *comp, double *work,
                           size_t *col, mlr_diag *diag);

/* Parameter slot of group g. */
static inline double *layers__param_slot(const mlr_layers *L, int which, size_t g)
{
    return L->param + (size_t)which * (1 + L->j) + g;
}

#endif
