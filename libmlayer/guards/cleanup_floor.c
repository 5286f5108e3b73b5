/*
 * The floor height of the contact cleanup: a quantile of the contact points' heights on
 * their contact frames (mlr_cleanup.h).
 */
#include "guards/cleanup_internal.h"

#include <math.h>

double cleanup__quantile_of(double *v, size_t n, double q)
{
    /* the order statistics i and i + 1 of a sort, by selection: v[i], then the smallest of
       the values after it (all no smaller) */
    const double pos = q * (double)(n - 1);
    const size_t i = (size_t)floor(pos);
    if (i + 1 >= n) {
        common__select_kth(v, n, n - 1);
        return v[n - 1];
    }
    common__select_kth(v, n, i);
    double next = v[i + 1];
    for (size_t k = i + 2; k < n; k++)
        next = v[k] < next ? v[k] : next;
    const double f = pos - (double)i;
    return v[i] + f * (next - v[i]);
}

mlr_status mlr_cleanup_floor_height(const mlr_rig *rig, size_t N, const double *root_pos,
                                    const double *rot, const double *trans, size_t C,
                                    const int32_t *joints, const int32_t *end_sites,
                                    const uint8_t *contacts, int up, double quantile,
                                    double *height, const mlr_allocator *alloc, mlr_diag *diag)
{
    mlr_status st = mlr_rig_check(rig, diag);
    if (st != MLR_OK)
        return st;
    if (!height || N == 0 || (C && !contacts))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "floor_height: NULL output or contacts, or no frames");
    if (up < 0 || up > 2)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "floor_height: up axis %d is not "
                                "0 (X), 1 (Y) or 2 (Z)",
                                up);
    if (!(quantile >= 0.0 && quantile <= 1.0))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "floor_height: quantile %g outside [0, 1]", quantile);
    if ((st = cleanup__check_points(rig, C, joints, end_sites, diag)) != MLR_OK ||
        (st = cleanup__check_motion(rig, N, root_pos, rot, trans, "motion", diag)) != MLR_OK)
        return st;
    mlr_allocator A;
    common__allocator_resolve(alloc, &A);
    cleanup_arena ar = {.a = &A, .st = MLR_OK};
    const size_t J = rig->n_joints;
    double *pos = cleanup__take(&ar, N * J * 3, sizeof(double));
    double *wrot = cleanup__take(&ar, N * J * 4, sizeof(double));
    double *pts = cleanup__take(&ar, N * C * 3, sizeof(double));
    if (ar.st != MLR_OK) {
        cleanup__release(&ar);
        return common__diag_set(diag, ar.st, 0, 0, "floor_height: out of memory");
    }
    st = cleanup__fk_points(rig, N, root_pos, rot, trans, C, joints, end_sites, pos, wrot, pts, &A,
                            NULL, 0, NULL);
    if (st == MLR_OK)
        st = cleanup__floor_of_points(N, C, pts, contacts, up, quantile, height, &A);
    cleanup__release(&ar);
    if (st == MLR_OK)
        return MLR_OK;
    return common__diag_set(diag, st, 0, 0,
                            st == MLR_E_NO_MEMORY ? "floor_height: out of memory"
                                                  : "floor_height: FK failed");
}

mlr_status cleanup__floor_of_points(size_t n_frames, size_t n_points, const double *pts,
                                    const uint8_t *contacts, int up, double quantile,
                                    double *height, const mlr_allocator *a)
{
    size_t k = 0;
    for (size_t i = 0; i < n_frames * n_points; i++)
        k += contacts[i] != 0;
    *height = NAN;
    if (k == 0)
        return MLR_OK;
    double *v = common__alloc(a, k * sizeof(double));
    if (!v)
        return MLR_E_NO_MEMORY;
    k = 0;
    for (size_t i = 0; i < n_frames * n_points; i++)
        if (contacts[i])
            v[k++] = pts[3 * i + (size_t)up];
    *height = cleanup__quantile_of(v, k, quantile);
    common__free(a, v, k * sizeof(double));
    return MLR_OK;
}
