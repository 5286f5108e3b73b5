/*
 * The contact cleanup's options and argument checks (mlr_cleanup.h).
 */
#include "guards/cleanup_internal.h"
#include "common/options_internal.h"

#include <math.h>

#define PI 3.14159265358979323846
static const mlr_opt_spec cleanup_opts[] = {
    {MLR_CLEANUP_OPT_BLEND, "blend", MLR_OPT_DOUBLE, 0.0, INFINITY, 1, 0, 0.2, NULL},
    {MLR_CLEANUP_OPT_REACH, "reach", MLR_OPT_DOUBLE, 0.0, 1.0, 1, 0, 0.98, NULL},
    {MLR_CLEANUP_OPT_PASSES, "passes", MLR_OPT_INT, 1.0, 10.0, 0, 0, 2.0, NULL},
    {MLR_CLEANUP_OPT_FLOOR, "floor", MLR_OPT_BOOL, 0.0, 1.0, 0, 0, 1.0, NULL},
    {MLR_CLEANUP_OPT_FLOOR_HEIGHT, "floor_height", MLR_OPT_DOUBLE, -INFINITY, INFINITY, 0, 0, NAN,
     NULL},
    {MLR_CLEANUP_OPT_FLOOR_QUANTILE, "floor_quantile", MLR_OPT_DOUBLE, 0.0, 1.0, 0, 0, 0.05, NULL},
    {MLR_CLEANUP_OPT_REF_SMOOTH, "ref_smooth", MLR_OPT_DOUBLE, 0.0, INFINITY, 0, 0, 0.02, NULL},
    {MLR_CLEANUP_OPT_PIN_SMOOTH, "pin_smooth", MLR_OPT_DOUBLE, 0.0, INFINITY, 1, 0, 0.02, NULL},
    {MLR_CLEANUP_OPT_ROOT, "root", MLR_OPT_BOOL, 0.0, 1.0, 0, 0, 1.0, NULL},
    {MLR_CLEANUP_OPT_MAX_FOLD, "max_fold", MLR_OPT_DOUBLE, 0.0, PI, 1, 0, PI, "in (0, pi]"},
    {MLR_CLEANUP_OPT_KEEP_STILLER, "keep_stiller", MLR_OPT_DOUBLE, 0.0, INFINITY, 0, 0, 0.0,
     "0 (off) or >= 1"},
    {MLR_CLEANUP_OPT_KEEP_TOTAL, "keep_total", MLR_OPT_BOOL, 0.0, 1.0, 0, 0, 0.0, NULL},
    {MLR_CLEANUP_OPT_PIN_DETAIL, "pin_detail", MLR_OPT_DOUBLE, 0.0, 1.0, 0, 0, 0.0, NULL},
    {MLR_CLEANUP_OPT_RAMP_TRACK, "ramp_track", MLR_OPT_BOOL, 0.0, 1.0, 0, 0, 1.0, NULL},
    {MLR_CLEANUP_OPT_ROOT_BOB, "root_bob", MLR_OPT_DOUBLE, 0.0, INFINITY, 0, 0, 0.0, NULL},
    {MLR_CLEANUP_OPT_STRAIGHT_SLACK, "straight_slack", MLR_OPT_DOUBLE, 0.0, INFINITY, 0, 0, 0.0,
     NULL},
    {MLR_CLEANUP_OPT_SOFT_REACH, "soft_reach", MLR_OPT_DOUBLE, 0.0, 0.5, 0, 0, 0.0, NULL},
};
#undef PI

mlr_status cleanup__parse_options(const mlr_cleanup_option *opts, size_t n_opts,
                                  cleanup_config *cfg, mlr_diag *diag)
{
    mlr_opt_values o;
    mlr_status st = MLR_OPTIONS_READ("cleanup", cleanup_opts, opts, n_opts, &o, diag);
    if (st != MLR_OK)
        return st;
    const double ks = o.v[MLR_CLEANUP_OPT_KEEP_STILLER];
    if (ks > 0.0 && ks < 1.0)
        return options__reject(diag, "cleanup", "keep_stiller", ks, "0 (off) or >= 1");
    cfg->blend = o.v[MLR_CLEANUP_OPT_BLEND];
    cfg->reach = o.v[MLR_CLEANUP_OPT_REACH];
    cfg->passes = (int)o.v[MLR_CLEANUP_OPT_PASSES];
    cfg->floor_on = o.v[MLR_CLEANUP_OPT_FLOOR] != 0.0;
    cfg->floor_given = o.given[MLR_CLEANUP_OPT_FLOOR_HEIGHT];
    cfg->floor_height = o.v[MLR_CLEANUP_OPT_FLOOR_HEIGHT];
    cfg->floor_q = o.v[MLR_CLEANUP_OPT_FLOOR_QUANTILE];
    cfg->ref_smooth = o.v[MLR_CLEANUP_OPT_REF_SMOOTH];
    cfg->pin_smooth = o.v[MLR_CLEANUP_OPT_PIN_SMOOTH];
    cfg->root_on = o.v[MLR_CLEANUP_OPT_ROOT] != 0.0;
    cfg->max_fold = o.v[MLR_CLEANUP_OPT_MAX_FOLD];
    cfg->keep_stiller = ks;
    cfg->keep_total = o.v[MLR_CLEANUP_OPT_KEEP_TOTAL] != 0.0;
    cfg->pin_detail = o.v[MLR_CLEANUP_OPT_PIN_DETAIL];
    cfg->ramp_track = o.v[MLR_CLEANUP_OPT_RAMP_TRACK] != 0.0;
    cfg->root_bob = o.v[MLR_CLEANUP_OPT_ROOT_BOB];
    cfg->straight_slack = o.v[MLR_CLEANUP_OPT_STRAIGHT_SLACK];
    cfg->soft_reach = o.v[MLR_CLEANUP_OPT_SOFT_REACH];
    return MLR_OK;
}

static int finite_all(const double *x, size_t count)
{
    return common__first_nonfinite(x, count) == count;
}

mlr_status cleanup__check_motion(const mlr_rig *rig, size_t N, const double *root_pos,
                                 const double *rot, const double *trans, const char *what,
                                 mlr_diag *diag)
{
    const size_t J = rig->n_joints, P = rig->n_trans;
    if (!root_pos || !rot || (P && !trans))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "%s: root_pos, rot%s is NULL", what,
                                P ? " or trans" : "");
    if (!finite_all(root_pos, 3 * N) || !finite_all(rot, 4 * N * J) ||
        (P && !finite_all(trans, 3 * N * P)))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "%s contains NaN or infinite values", what);
    return MLR_OK;
}

mlr_status cleanup__check_points(const mlr_rig *rig, size_t C, const int32_t *joints,
                                 const int32_t *end_sites, mlr_diag *diag)
{
    if (C && !joints)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "contact points: joints is NULL");
    for (size_t c = 0; c < C; c++) {
        const int32_t j = joints[c], e = end_sites ? end_sites[c] : -1;
        if (j < 0 || (size_t)j >= rig->n_joints)
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    "contact point %zu: joint %d names nothing (the rig has %zu "
                                    "joints)",
                                    c, (int)j, rig->n_joints);
        if (e < -1 || (e >= 0 && ((size_t)e >= rig->n_end_sites || rig->end_site_parents[e] != j)))
            return common__diag_set(
                diag, MLR_E_INVALID_ARG, 0, 0,
                "contact point %zu: End Site %d is not an End Site of joint %d", c, (int)e,
                (int)j);
        for (size_t d = 0; d < c; d++)
            if (joints[d] == j && (end_sites ? end_sites[d] : -1) == e)
                return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                        "contact points %zu and %zu are the same point", d, c);
    }
    return MLR_OK;
}
