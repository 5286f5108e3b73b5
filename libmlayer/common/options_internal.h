/* The one reader of key/value options (options.c). Private; not installed.
 *
 * Every subject with several tunables takes an array of {int key; double value;} (the public
 * mlr_layers_option, mlr_guards_option, mlr_limits_option, mlr_contacts_option,
 * mlr_cleanup_option and mlr_bvh_read_option all have that layout) and reads it with
 * MLR_OPTIONS_READ against a table of its keys. The reader rejects a NULL array with n_opts > 0,
 * an unknown key, a key given twice, a non-finite value and a value outside the key's range,
 * each with one message format that names the option by its name (the lower-case suffix of
 * its key, e.g. "lam_c" for MLR_LAYERS_OPT_LAM_C; the Python keyword and the CLI flag
 * --lam-c are the same name, docs/OPTIONS.md):
 *
 *     SUBJECT: unknown option key K
 *     SUBJECT: option NAME given twice
 *     SUBJECT: option NAME = V is not RANGE
 *
 * Checks that depend on other options or on the data (a joint index below J, a cutoff below
 * fps / 2) stay with the subject and report through options__reject in the same format.
 * Booleans of functions without several tunables are flags (unsigned bitmasks such as
 * MLR_RESAMPLE_ALLOW_EXTREME); their messages name the flag the same way ("allow_extreme").
 */
#ifndef MLR_OPTIONS_INTERNAL_H
#define MLR_OPTIONS_INTERNAL_H

#include "common/mlr_internal.h"

#include <math.h> /* INFINITY and NAN for the tables */

/** The largest key + 1 a table may use. */
#define MLR_OPT_MAX_KEYS 32

typedef enum mlr_opt_kind {
    MLR_OPT_BOOL,   /* 0 or 1 */
    MLR_OPT_INT,    /* an integer in [min, max] (enumerations too: give range a wording) */
    MLR_OPT_DOUBLE  /* finite, in [min, max], a bound excluded where lo_open / hi_open */
} mlr_opt_kind;

/** One key of a subject. */
typedef struct mlr_opt_spec {
    int key;            /* 1 .. MLR_OPT_MAX_KEYS - 1 */
    const char *name;   /* the key's lower-case suffix: the Python keyword */
    mlr_opt_kind kind;
    double min, max;    /* -INFINITY / INFINITY for no bound */
    int lo_open, hi_open;
    double def;         /* the value when the key is not given */
    const char *range;  /* the valid values in words for messages ("in (0, pi]"); NULL: from
                           the bounds */
} mlr_opt_spec;

/** The options read: v[key] the given value or the default; given[key] 1 when given. */
typedef struct mlr_opt_values {
    double v[MLR_OPT_MAX_KEYS];
    unsigned char given[MLR_OPT_MAX_KEYS];
} mlr_opt_values;

/* Read n_opts options (their keys at key0, values at value0, stride bytes apart; NULL when
 * n_opts is 0) against spec[0 .. n_spec). MLR_OK or MLR_E_INVALID_ARG with the message above. */
mlr_status options__read(const char *subject, const mlr_opt_spec *spec, size_t n_spec,
                         const int *key0, const double *value0, size_t stride, size_t n_opts,
                         mlr_opt_values *out, mlr_diag *diag);

#define MLR_OPTIONS_READ(subject, spec, opts, n_opts, out, diag)                      \
    options__read((subject), (spec), MLR_COUNTOF(spec), (opts) ? &(opts)->key : NULL, \
                  (opts) ? &(opts)->value : NULL, sizeof *(opts), (n_opts), (out), (diag))

/* "SUBJECT: option NAME = V is not WHY..." (WHY a printf format); MLR_E_INVALID_ARG. */
mlr_status options__reject(mlr_diag *diag, const char *subject, const char *name, double value,
                           const char *why, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 5, 6)))
#endif
    ;

#endif
