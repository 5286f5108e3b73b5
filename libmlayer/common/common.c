/* Status names, version, default allocator, diagnostics. */
#include "common/mlr_internal.h"

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>

static const struct {
    mlr_status code;
    const char *name;
    const char *text;
} status_table[] = {
    {MLR_OK, "MLR_OK", "success"},
    {MLR_E_INVALID_ARG, "MLR_E_INVALID_ARG", "invalid argument"},
    {MLR_E_NO_MEMORY, "MLR_E_NO_MEMORY", "out of memory"},
    {MLR_E_OVERFLOW, "MLR_E_OVERFLOW", "size computation overflows"},
    {MLR_E_SINGULAR, "MLR_E_SINGULAR", "the linear system is singular"},
    {MLR_E_BAD_STATE, "MLR_E_BAD_STATE", "the object is not in a state that allows this call"},
    {MLR_E_UNSUPPORTED, "MLR_E_UNSUPPORTED", "not supported by this build or this object"},
    {MLR_E_PARSE, "MLR_E_PARSE", "the input could not be parsed"},
    {MLR_E_IO, "MLR_E_IO", "input/output error"},
    {MLR_W_ILL_CONDITIONED, "MLR_W_ILL_CONDITIONED",
     "the system is ill-conditioned; the result may be inaccurate"},
    {MLR_W_MAX_ITER, "MLR_W_MAX_ITER", "the iteration limit was reached before convergence"},
};

const char *mlr_status_name(mlr_status s)
{
    for (size_t i = 0; i < MLR_COUNTOF(status_table); i++)
        if (status_table[i].code == s)
            return status_table[i].name;
    return "MLR_UNKNOWN";
}

const char *mlr_status_string(mlr_status s)
{
    for (size_t i = 0; i < MLR_COUNTOF(status_table); i++)
        if (status_table[i].code == s)
            return status_table[i].text;
    return "unknown status code";
}

const char *mlr_version_string(void) { return MLR_VERSION_STRING; }
int mlr_version_number(void) { return MLR_VERSION_NUMBER; }

static void *default_allocate(void *user, size_t size, size_t align)
{
    (void)user;
    (void)align; /* malloc's alignment (16 on the supported platforms) serves every caller */
    return malloc(size);
}

static void default_release(void *user, void *ptr, size_t size)
{
    (void)user;
    (void)size;
    free(ptr);
}

void common__allocator_resolve(const mlr_allocator *in, mlr_allocator *out)
{
    if (in && in->allocate && in->release) {
        *out = *in;
    } else {
        out->allocate = default_allocate;
        out->release = default_release;
        out->user = NULL;
    }
}

void *common__alloc(const mlr_allocator *a, size_t size) { return a->allocate(a->user, size, 16); }

void common__free(const mlr_allocator *a, void *ptr, size_t size)
{
    if (ptr)
        a->release(a->user, ptr, size);
}

mlr_status common__diag_prefix(mlr_diag *diag, mlr_status status, const char *who)
{
    const size_t n = strlen(who);
    if (!diag || (strncmp(diag->message, who, n) == 0 && diag->message[n] == ':'))
        return status;
    char m[sizeof diag->message];
    memcpy(m, diag->message, sizeof m);
    m[sizeof m - 1] = '\0';
    const size_t cap = sizeof diag->message - 1; /* characters before the NUL */
    size_t k = n < cap ? n : cap;
    memcpy(diag->message, who, k);
    if (k + 2 <= cap) {
        diag->message[k++] = ':';
        diag->message[k++] = ' ';
    }
    size_t rest = strlen(m);
    if (rest > cap - k)
        rest = cap - k;
    memcpy(diag->message + k, m, rest);
    diag->message[k + rest] = '\0';
    return status;
}

mlr_status common__diag_set(mlr_diag *diag, mlr_status status, size_t line, size_t column,
                            const char *fmt, ...)
{
    if (diag) {
        va_list ap;
        va_start(ap, fmt);
        diag->line = line;
        diag->column = column;
        vsnprintf(diag->message, sizeof diag->message, fmt, ap);
        va_end(ap);
    }
    return status;
}
