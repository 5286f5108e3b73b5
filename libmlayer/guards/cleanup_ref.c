/*
 * The contact cleanup's reference trajectories (cleanup_internal.h): the reference's contact
 * points and ankles, smoothed, made once and read by many cleanups.
 */
#include "guards/cleanup_internal.h"

#include <math.h>

void cleanup__ref_destroy(mlr_cleanup_ref *ref)
{
    if (!ref)
        return;
    const size_t N = ref->n_frames, C = ref->n_points, F = ref->n_feet;
    mlr_allocator a = ref->alloc;
    if (ref->h)
        common__free(&a, ref->h, N * C * sizeof(double));
    if (ref->pts)
        common__free(&a, ref->pts, 3 * N * C * sizeof(double));
    if (ref->step)
        common__free(&a, ref->step, N * C * sizeof(double));
    if (ref->anchors)
        common__free(&a, ref->anchors, 3 * N * F * sizeof(double));
    common__free(&a, ref, sizeof *ref);
}

/* The options and the counts of a reference: at most 64 points, at least one, and frames. */
static mlr_status ref_check(size_t N, size_t C, const mlr_cleanup_option *opts, size_t n_opts,
                            cleanup_config *cfg, mlr_diag *diag)
{
    memset(cfg, 0, sizeof *cfg);
    mlr_status st = cleanup__parse_options(opts, n_opts, cfg, diag);
    if (st != MLR_OK)
        return st;
    if (C > 64)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "cleanup: at most 64 contact "
                                "points, got %zu",
                                C);
    if (C == 0 || N == 0)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "cleanup reference: %zu points, %zu "
                                "frames",
                                C, N);
    return MLR_OK;
}

/* A new reference of N frames, C points and nf feet; its arrays NULL where they could not be
   allocated (NULL when the handle itself could not). */
static mlr_cleanup_ref *ref_new(const mlr_allocator *A, size_t N, size_t C, size_t nf, int up,
                                double smooth)
{
    mlr_cleanup_ref *r = common__alloc(A, sizeof *r);
    if (r) {
        memset(r, 0, sizeof *r);
        r->alloc = *A, r->n_frames = N, r->n_points = C, r->n_feet = nf, r->up = up;
        r->smooth = smooth;
        r->h = common__alloc(A, N * C * sizeof(double));
        r->pts = common__alloc(A, 3 * N * C * sizeof(double));
        r->step = common__alloc(A, N * C * sizeof(double));
        r->anchors = nf ? common__alloc(A, 3 * N * nf * sizeof(double)) : NULL;
    }
    return r;
}

/* The scratch of cleanup__ref_create. */
typedef struct ref_scratch {
    uint8_t *listed, *assigned, *need;
    int32_t *tidx, *list;
    double *pos2, *wrot2; /* one frame's FK */
    double *tmp;          /* N x 3 max(C, nf): the smoothing's output */
} ref_scratch;

/* The heights and the horizontal steps of the points r->pts (unsmoothed yet). */
static void ref_heights_steps(mlr_cleanup_ref *r)
{
    const size_t N = r->n_frames, C = r->n_points;
    const double *Pr = r->pts;
    for (size_t i = 0; i < N * C; i++)
        r->h[i] = Pr[3 * i + (size_t)r->up];
    for (size_t f = 0; f < N; f++)
        for (size_t c = 0; c < C; c++) {
            double d2 = 0.0;
            for (int d = 0; f + 1 < N && d < 3; d++)
                if (d != r->up) {
                    const double x =
                        Pr[3 * ((f + 1) * C + c) + (size_t)d] - Pr[3 * (f * C + c) + (size_t)d];
                    d2 += x * x;
                }
            r->step[f * C + c] = sqrt(d2);
        }
}

/* The reference's points and anchors (unsmoothed) and the points' heights: from its world
   positions and rotations when given, else by forward kinematics of the contact points, the
   anchors and their ancestors only. */
static mlr_status ref_points(const mlr_rig *rig, const double *root_pos, const double *rot,
                             const double *trans, const double *world_pos, const double *world_rot,
                             const int32_t *joints, const int32_t *end_sites,
                             const cleanup_foot *feet, const ref_scratch *s, mlr_cleanup_ref *r)
{
    const size_t N = r->n_frames, C = r->n_points, nf = r->n_feet, J = rig->n_joints;
    double *Pr = r->pts, *pos_ref = r->anchors;
    mlr_status st = MLR_OK;
    if (world_pos) {
        st = mlr_rig_point_positions(rig, N, world_pos, world_rot, C, joints, end_sites, Pr, NULL);
        for (size_t f = 0; st == MLR_OK && f < N; f++)
            for (size_t k = 0; k < nf; k++)
                memcpy(pos_ref + 3 * (f * nf + k),
                       world_pos + 3 * (f * J + (size_t)feet[k].anchor), 3 * sizeof(double));
    } else {
        const size_t n = cleanup__fk_need(rig, C, joints, feet, nf, s->need, s->list, s->tidx);
        for (size_t f = 0; st == MLR_OK && f < N; f++) { /* the points and the anchors */
            cleanup__fk_masked_frame(rig, f, s->list, n, s->tidx, root_pos, rot, trans, s->pos2,
                                     s->wrot2);
            st = mlr_rig_point_positions(rig, 1, s->pos2, s->wrot2, C, joints, end_sites,
                                         Pr + 3 * C * f, NULL);
            for (size_t k = 0; k < nf; k++)
                memcpy(pos_ref + 3 * (f * nf + k), s->pos2 + 3 * (size_t)feet[k].anchor,
                       3 * sizeof(double));
        }
    }
    if (st != MLR_OK)
        return st;
    ref_heights_steps(r);
    return MLR_OK;
}

/* The points' and the anchors' trajectories smoothed by the LGS of r->smooth seconds. */
static mlr_status ref_smooth(mlr_cleanup_ref *r, double fps, double *tmp, const mlr_allocator *A,
                             mlr_diag *diag)
{
    const size_t N = r->n_frames, C = r->n_points, nf = r->n_feet;
    double *Pr = r->pts, *pos_ref = r->anchors;
    mlr_lgs *ref_lgs = NULL;
    const double lam = (r->smooth * fps) * (r->smooth * fps);
    mlr_status st = mlr_lgs_create(N, 2, lam, 1.0, NULL, N, MLR_LGS_BANDED, A, &ref_lgs, diag);
    if (st < 0)
        return common__diag_prefix(diag, st, "cleanup");
    mlr_lgs_solve(ref_lgs, Pr, 3 * C, 3 * C, tmp, 3 * C, NULL);
    memcpy(Pr, tmp, N * C * 3 * sizeof(double));
    for (size_t k = 0; k < nf; k++) { /* the ankles' trajectories */
        mlr_lgs_solve(ref_lgs, pos_ref + 3 * k, 3 * nf, 3, tmp, 3, NULL);
        for (size_t f = 0; f < N; f++)
            memcpy(pos_ref + 3 * (f * nf + k), tmp + 3 * f, 3 * sizeof(double));
    }
    mlr_lgs_destroy(ref_lgs);
    return MLR_OK;
}

mlr_status cleanup__ref_create(const mlr_rig *rig, size_t N, double fps, int up,
                               const double *root_pos, const double *rot, const double *trans,
                               const double *world_pos, const double *world_rot, size_t C,
                               const int32_t *joints, const int32_t *end_sites,
                               const mlr_cleanup_option *opts, size_t n_opts,
                               const mlr_allocator *alloc, mlr_cleanup_ref **out, mlr_diag *diag)
{
    *out = NULL;
    cleanup_config cfg;
    mlr_status st = ref_check(N, C, opts, n_opts, &cfg, diag);
    if (st != MLR_OK)
        return st;
    mlr_allocator A;
    common__allocator_resolve(alloc, &A);
    const size_t J = rig->n_joints;
    cleanup_foot feet[64];
    size_t nf = 0;
    cleanup_arena ar = {.a = &A, .st = MLR_OK};
    ref_scratch s;
    s.listed = cleanup__take(&ar, J, 1);
    s.assigned = cleanup__take(&ar, C, 1);
    s.need = cleanup__take(&ar, J, 1);
    s.tidx = cleanup__take(&ar, J, sizeof(int32_t));
    s.list = cleanup__take(&ar, J, sizeof(int32_t));
    s.pos2 = cleanup__take(&ar, J * 3, sizeof(double));
    s.wrot2 = cleanup__take(&ar, J * 4, sizeof(double));
    if (ar.st != MLR_OK) {
        cleanup__release(&ar);
        return common__diag_set(diag, ar.st, 0, 0, "cleanup: out of memory");
    }
    if ((st = cleanup__assign_feet(rig, C, joints, end_sites, feet, &nf, s.listed, s.assigned,
                                   diag)) != MLR_OK) {
        cleanup__release(&ar);
        return st;
    }
    mlr_cleanup_ref *r = ref_new(&A, N, C, nf, up, cfg.ref_smooth);
    s.tmp = cleanup__take(&ar, N * 3 * (C > nf ? C : nf), sizeof(double));
    if (!r || !r->h || !r->pts || !r->step || (nf && !r->anchors) || ar.st != MLR_OK) {
        st = common__diag_set(diag, MLR_E_NO_MEMORY, 0, 0, "cleanup: out of memory");
    } else if ((st = ref_points(rig, root_pos, rot, trans, world_pos, world_rot, joints, end_sites,
                                feet, &s, r)) != MLR_OK) {
        common__diag_set(diag, st, 0, 0, "cleanup: the reference's points failed");
    } else if (cfg.ref_smooth > 0.0) {
        st = ref_smooth(r, fps, s.tmp, &A, diag);
    }
    cleanup__release(&ar);
    if (st != MLR_OK) {
        cleanup__ref_destroy(r);
        return st;
    }
    *out = r;
    return MLR_OK;
}

mlr_status cleanup__ref_of_points(const mlr_rig *rig, size_t N, double fps, int up, size_t C,
                                  const int32_t *joints, const int32_t *end_sites,
                                  const double *pts, const mlr_cleanup_option *opts, size_t n_opts,
                                  const mlr_allocator *alloc, mlr_cleanup_ref **out,
                                  mlr_diag *diag)
{
    *out = NULL;
    cleanup_config cfg;
    mlr_status st = ref_check(N, C, opts, n_opts, &cfg, diag);
    if (st != MLR_OK)
        return st;
    mlr_allocator A;
    common__allocator_resolve(alloc, &A);
    const size_t J = rig->n_joints;
    cleanup_foot feet[64];
    size_t nf = 0;
    cleanup_arena ar = {.a = &A, .st = MLR_OK};
    uint8_t *listed = cleanup__take(&ar, J, 1), *assigned = cleanup__take(&ar, C, 1);
    if (ar.st != MLR_OK) {
        cleanup__release(&ar);
        return common__diag_set(diag, ar.st, 0, 0, "cleanup: out of memory");
    }
    if ((st = cleanup__assign_feet(rig, C, joints, end_sites, feet, &nf, listed, assigned,
                                   diag)) != MLR_OK) {
        cleanup__release(&ar);
        return st;
    }
    /* each foot's anchor is one of the points (a listed joint, not an End Site of it) */
    size_t anchor_col[64];
    for (size_t k = 0; k < nf; k++) {
        anchor_col[k] = C;
        for (size_t c = 0; c < C && anchor_col[k] == C; c++)
            if (joints[c] == feet[k].anchor && (!end_sites || end_sites[c] < 0))
                anchor_col[k] = c;
        if (anchor_col[k] == C) {
            cleanup__release(&ar);
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    "cleanup reference: the ankle joint %d is not a point",
                                    (int)feet[k].anchor);
        }
    }
    mlr_cleanup_ref *r = ref_new(&A, N, C, nf, up, cfg.ref_smooth);
    double *tmp = cleanup__take(&ar, N * 3 * (C > nf ? C : nf), sizeof(double));
    if (!r || !r->h || !r->pts || !r->step || (nf && !r->anchors) || ar.st != MLR_OK) {
        st = common__diag_set(diag, MLR_E_NO_MEMORY, 0, 0, "cleanup: out of memory");
    } else {
        memcpy(r->pts, pts, 3 * N * C * sizeof(double));
        for (size_t f = 0; f < N; f++)
            for (size_t k = 0; k < nf; k++)
                memcpy(r->anchors + 3 * (f * nf + k), pts + 3 * (f * C + anchor_col[k]),
                       3 * sizeof(double));
        ref_heights_steps(r);
        if (cfg.ref_smooth > 0.0)
            st = ref_smooth(r, fps, tmp, &A, diag);
    }
    cleanup__release(&ar);
    if (st != MLR_OK) {
        cleanup__ref_destroy(r);
        return st;
    }
    *out = r;
    return MLR_OK;
}
