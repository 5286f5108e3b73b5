/* The one reader of key/value options (options_internal.h). */
#include "common/options_internal.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>

/* The wording of spec's valid values into buf: "0 or 1", "an integer in [1, 10]", "> 0",
 * "in (0, 1]". */
static const char *range_text(const mlr_opt_spec *s, char *buf, size_t size)
{
    if (s->range)
        return s->range;
    if (s->kind == MLR_OPT_BOOL)
        return "0 or 1";
    const int lo = isfinite(s->min), hi = isfinite(s->max);
    if (s->kind == MLR_OPT_INT) {
        if (lo && hi)
            snprintf(buf, size, "an integer in [%g, %g]", s->min, s->max);
        else if (lo)
            snprintf(buf, size, "an integer >= %g", s->min);
        else
            snprintf(buf, size, "an integer");
    } else if (lo && hi) {
        snprintf(buf, size, "in %c%.6g, %.6g%c", s->lo_open ? '(' : '[', s->min, s->max,
                 s->hi_open ? ')' : ']');
    } else if (lo) {
        snprintf(buf, size, "%s %.6g", s->lo_open ? ">" : ">=", s->min);
    } else if (hi) {
        snprintf(buf, size, "%s %.6g", s->hi_open ? "<" : "<=", s->max);
    } else {
        snprintf(buf, size, "finite");
    }
    return buf;
}

static int in_range(const mlr_opt_spec *s, double v)
{
    switch (s->kind) {
    case MLR_OPT_BOOL:
        return v == 0.0 || v == 1.0;
    case MLR_OPT_INT:
        if (v != floor(v))
            return 0;
        /* fall through */
    default:
        if (s->lo_open ? !(v > s->min) : !(v >= s->min))
            return 0;
        if (s->hi_open ? !(v < s->max) : !(v <= s->max))
            return 0;
        return 1;
    }
}

mlr_status options__reject(mlr_diag *diag, const char *subject, const char *name, double value,
                           const char *why, ...)
{
    if (diag) {
        char text[120];
        va_list ap;
        va_start(ap, why);
        vsnprintf(text, sizeof text, why, ap);
        va_end(ap);
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "%s: option %s = %g is not %s",
                                subject, name, value, text);
    }
    return MLR_E_INVALID_ARG;
}

mlr_status options__read(const char *subject, const mlr_opt_spec *spec, size_t n_spec,
                         const int *key0, const double *value0, size_t stride, size_t n_opts,
                         mlr_opt_values *out, mlr_diag *diag)
{
    const mlr_opt_spec *by_key[MLR_OPT_MAX_KEYS] = {0};
    for (size_t i = 0; i < n_spec; i++) {
        by_key[spec[i].key] = &spec[i];
        out->v[spec[i].key] = spec[i].def;
    }
    memset(out->given, 0, sizeof out->given);
    if (n_opts > 0 && (!key0 || !value0))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "%s: opts is NULL but n_opts is %zu", subject, n_opts);
    for (size_t i = 0; i < n_opts; i++) {
        const int key = *(const int *)(const void *)((const char *)key0 + i * stride);
        const double v = *(const double *)(const void *)((const char *)value0 + i * stride);
        const mlr_opt_spec *s = key > 0 && key < MLR_OPT_MAX_KEYS ? by_key[key] : NULL;
        if (!s)
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "%s: unknown option key %d",
                                    subject, key);
        if (out->given[key])
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "%s: option %s given twice",
                                    subject, s->name);
        if (!isfinite(v))
            return options__reject(diag, subject, s->name, v, "finite");
        if (!in_range(s, v)) {
            char buf[64];
            return options__reject(diag, subject, s->name, v, "%s",
                                   range_text(s, buf, sizeof buf));
        }
        out->given[key] = 1;
        out->v[key] = v;
    }
    return MLR_OK;
}
