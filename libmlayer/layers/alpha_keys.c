/*
 * Alpha over time (mlr_layers.h, "Alpha over time"): keyframed alphas evaluated at any times,
 * each segment eased by the quintic smoothstep s(u) = u^3 (10 - 15 u + 6 u^2).
 */
#include "layers/layers_internal.h"

#include <math.h>

mlr_status mlr_alpha_keys_check(const double *times, const double *values, size_t n_keys,
                                mlr_diag *diag)
{
    if (n_keys == 0 || !times || !values)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "alpha keys: %s",
                                n_keys == 0 ? "no keys (give at least one)"
                                            : "times or values is NULL");
    for (size_t k = 0; k < n_keys; k++) {
        if (!isfinite(times[k]))
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    "alpha keys: the time of key %zu is not finite (%g)", k,
                                    times[k]);
        if (!isfinite(values[k]))
            return common__diag_set(
                diag, MLR_E_INVALID_ARG, 0, 0,
                "alpha keys: the alpha of key %zu (at %g s) is not finite (%g)", k, times[k],
                values[k]);
        if (k && !(times[k] > times[k - 1]))
            return common__diag_set(
                diag, MLR_E_INVALID_ARG, 0, 0,
                "alpha keys: times must increase: key %zu at %g s is not after "
                "key %zu at %g s",
                k, times[k], k - 1, times[k - 1]);
    }
    return MLR_OK;
}

/* The curve at t (keys checked, t finite). */
static double eval1(const double *times, const double *values, size_t n, double t)
{
    if (t <= times[0])
        return values[0];
    if (t >= times[n - 1])
        return values[n - 1];
    size_t lo = 0, hi = n - 1; /* times[lo] <= t < times[hi] */
    while (hi - lo > 1) {
        const size_t mid = lo + (hi - lo) / 2;
        if (times[mid] <= t)
            lo = mid;
        else
            hi = mid;
    }
    const double a = values[lo], b = values[hi];
    if (a == b) /* a flat segment is its value, bit for bit */
        return a;
    const double u = (t - times[lo]) / (times[hi] - times[lo]);
    const double s = u * u * u * (10.0 + u * (6.0 * u - 15.0));
    return a + (b - a) * s;
}

mlr_status mlr_alpha_keys_eval(const double *times, const double *values, size_t n_keys,
                               const double *t, size_t count, double *out, mlr_diag *diag)
{
    mlr_status st = mlr_alpha_keys_check(times, values, n_keys, diag);
    if (st != MLR_OK)
        return st;
    if (count && (!t || !out))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "alpha keys: t or out is NULL");
    for (size_t i = 0; i < count; i++)
        if (!isfinite(t[i]))
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    "alpha keys: time %zu is not finite (%g)", i, t[i]);
    for (size_t i = 0; i < count; i++)
        out[i] = eval1(times, values, n_keys, t[i]);
    return MLR_OK;
}
