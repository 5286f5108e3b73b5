/* Loading a model file of generation at run time (mlr_generate.h, docs/model-format.md).
 * Every read is bounded by the bytes given; nothing is allocated before the whole file has been
 * checked, so a failure leaves nothing behind. */
#include "generate/gen_internal.h"
#include "io/file_read_internal.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>

#define HEADER 64
#define ENTRY 48
#define NAME_LEN 24
#define MAX_FIELDS 32
#define MAX_FILE ((size_t)1 << 30)

enum { T_F64 = 1, T_I64 = 2, T_U8 = 3 };

static const char magic[8] = {'M', 'L', 'R', 'G', 'E', 'N', 0, 0};

typedef struct field {
    const char *name;
    int type;
    int required;
    int ndim; /* 1 or 2 */
    /* filled by the scan */
    int found;
    uint64_t dim[2];
    const unsigned char *data;
} field;

enum {
    F_FRAME_TIME,
    F_NAMES,
    F_PARENTS,
    F_BODY,
    F_POINTS,
    F_LABELS,
    F_CENTERS,
    F_BOUNDS,
    F_JUMPS,
    F_RUN,
    F_MARKOV,
    F_KEYS,
    F_SEEN,
    F_PROBS,
    F_KERNEL,
    F_WIDTH,
    F_GCENTERS,
    F_COEF,
    F_SOM,
    F_SOM_LATTICE,
    F_CONTACT_NAMES,
    F_CONTACTS,
    F_FLOOR,
    F_COUNT
};

static const field field_table[F_COUNT] = {
    {"frame_time", T_F64, 1, 1, 0, {0, 0}, NULL},
    {"joint_names", T_U8, 1, 1, 0, {0, 0}, NULL},
    {"parents", T_I64, 1, 1, 0, {0, 0}, NULL},
    {"body_joint", T_I64, 1, 1, 0, {0, 0}, NULL},
    {"points", T_F64, 1, 2, 0, {0, 0}, NULL},
    {"labels", T_I64, 1, 1, 0, {0, 0}, NULL},
    {"centers", T_F64, 1, 2, 0, {0, 0}, NULL},
    {"bounds", T_F64, 1, 2, 0, {0, 0}, NULL},
    {"jumps", T_F64, 1, 2, 0, {0, 0}, NULL},
    {"run_length", T_F64, 1, 1, 0, {0, 0}, NULL},
    {"markov", T_I64, 1, 1, 0, {0, 0}, NULL},
    {"context_keys", T_I64, 1, 2, 0, {0, 0}, NULL},
    {"context_seen", T_F64, 1, 1, 0, {0, 0}, NULL},
    {"context_probs", T_F64, 1, 2, 0, {0, 0}, NULL},
    {"grbf_kernel", T_I64, 1, 1, 0, {0, 0}, NULL},
    {"grbf_width", T_F64, 1, 1, 0, {0, 0}, NULL},
    {"grbf_centers", T_F64, 1, 2, 0, {0, 0}, NULL},
    {"grbf_coef", T_F64, 1, 2, 0, {0, 0}, NULL},
    {"som_codebook", T_F64, 0, 2, 0, {0, 0}, NULL},
    {"som_lattice", T_I64, 0, 1, 0, {0, 0}, NULL},
    {"contact_names", T_U8, 0, 1, 0, {0, 0}, NULL},
    {"contacts", T_U8, 0, 2, 0, {0, 0}, NULL},
    {"floor_height", T_F64, 0, 1, 0, {0, 0}, NULL},
};

static uint32_t rd32(const unsigned char *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

static uint64_t rd64(const unsigned char *p) { return rd32(p) | (uint64_t)rd32(p + 4) << 32; }

static double rdf(const unsigned char *p)
{
    uint64_t u = rd64(p);
    double d;
    memcpy(&d, &u, sizeof d);
    return d;
}

static int64_t rdi(const unsigned char *p) { return (int64_t)rd64(p); }

static uint64_t fnv1a(uint64_t h, const unsigned char *b, size_t n)
{
    for (size_t i = 0; i < n; i++) {
        h ^= b[i];
        h *= 0x100000001b3ull;
    }
    return h;
}

/* CRC-32 of zlib (IEEE 802.3, reflected, polynomial 0xEDB88320). */
static uint32_t crc32_of(const unsigned char *b, size_t n)
{
    uint32_t table[256];
    for (uint32_t i = 0; i < 256; i++) {
        uint32_t c = i;
        for (int k = 0; k < 8; k++)
            c = c & 1 ? 0xEDB88320u ^ (c >> 1) : c >> 1;
        table[i] = c;
    }
    uint32_t c = 0xFFFFFFFFu;
    for (size_t i = 0; i < n; i++)
        c = table[(c ^ b[i]) & 0xFF] ^ (c >> 8);
    return c ^ 0xFFFFFFFFu;
}

static mlr_status bad(mlr_diag *diag, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;
static mlr_status bad(mlr_diag *diag, const char *fmt, ...)
{
    char msg[136];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    return common__diag_set(diag, MLR_E_PARSE, 0, 0, "mlr_gen_model_load: %s", msg);
}

/* The header and the field entries: every field's bytes within size. */
static mlr_status scan(const unsigned char *b, size_t size, field *f, mlr_diag *diag)
{
    if (size < HEADER || memcmp(b, magic, 8) != 0)
        return common__diag_set(diag, MLR_E_PARSE, 0, 0,
                                "mlr_gen_model_load: not a model file (%s)",
                                size < 8 ? "shorter than its magic" : "no MLRGEN magic");
    uint32_t version = rd32(b + 8), mark = rd32(b + 12), lib = rd32(b + 16);
    if (mark != 0x01020304u)
        return common__diag_set(diag, MLR_E_PARSE, 0, 0,
                                "mlr_gen_model_load: byte-order mark "
                                "0x%08x, expected 0x01020304 (little-endian)",
                                (unsigned)mark);
    if (version != MLR_GEN_FORMAT_VERSION)
        return common__diag_set(diag, MLR_E_PARSE, 0, 0,
                                "mlr_gen_model_load: model format version "
                                "%u (written by mlayer %u.%u.%u), this library reads version %d",
                                (unsigned)version, (unsigned)(lib / 10000),
                                (unsigned)(lib / 100 % 100), (unsigned)(lib % 100),
                                MLR_GEN_FORMAT_VERSION);
    uint32_t n_fields = rd32(b + 20);
    uint64_t total = rd64(b + 24);
    if (total != size)
        return bad(diag, "the header gives %llu bytes, the file has %zu (truncated?)",
                   (unsigned long long)total, size);
#ifndef FUZZING_BUILD_MODE_UNSAFE_FOR_PRODUCTION /* the fuzz target's mutations reach the fields */
    if ((uint64_t)crc32_of(b + HEADER, size - HEADER) != rd64(b + 40))
        return common__diag_set(diag, MLR_E_PARSE, 0, 0,
                                "mlr_gen_model_load: payload CRC-32 "
                                "mismatch (the file is damaged)");
#endif
    if (n_fields > MAX_FIELDS)
        return bad(diag, "%u fields, at most %d", (unsigned)n_fields, MAX_FIELDS);
    size_t at = HEADER;
    for (uint32_t i = 0; i < n_fields; i++) {
        if (size - at < ENTRY)
            return bad(diag, "field %u: entry past the end of the file", (unsigned)i);
        const unsigned char *e = b + at;
        char name[NAME_LEN + 1];
        memcpy(name, e, NAME_LEN);
        name[NAME_LEN] = 0;
        if (memchr(e, 0, NAME_LEN) == NULL)
            return bad(diag, "field %u: name not NUL-terminated", (unsigned)i);
        int which = -1;
        for (int k = 0; k < F_COUNT; k++)
            if (strcmp(name, f[k].name) == 0)
                which = k;
        for (const char *c = name; *c; c++)
            if (*c < 0x20 || *c > 0x7e)
                return bad(diag, "field %u: name holds byte 0x%02x", (unsigned)i,
                           (unsigned)(unsigned char)*c);
        if (which < 0)
            return bad(diag, "unknown field '%s' (entry %u)", name, (unsigned)i);
        field *d = &f[which];
        if (d->found)
            return bad(diag, "field '%s' given twice", name);
        uint32_t type = rd32(e + 24), ndim = rd32(e + 28);
        if ((int)type != d->type || (int)ndim != d->ndim)
            return bad(diag, "field '%s': type %u with %u dimensions, not the format's", name,
                       (unsigned)type, (unsigned)ndim);
        d->dim[0] = rd64(e + 32);
        d->dim[1] = rd64(e + 40);
        if (ndim == 1 && d->dim[1] != 1)
            return bad(diag, "field '%s': second dimension %llu of a vector", name,
                       (unsigned long long)d->dim[1]);
        size_t el = type == T_U8 ? 1 : 8;
        at += ENTRY;
        uint64_t room = (size - at) / el;
        if (d->dim[0] > room || (d->dim[1] != 0 && d->dim[0] > room / d->dim[1]))
            return bad(diag, "field '%s': %llu x %llu values run past the end of the file", name,
                       (unsigned long long)d->dim[0], (unsigned long long)d->dim[1]);
        size_t nb = (size_t)(d->dim[0] * d->dim[1]) * el, padded = (nb + 7) / 8 * 8;
        if (padded > size - at)
            return bad(diag, "field '%s': padding past the end of the file", name);
        d->data = b + at;
        d->found = 1;
        at += padded;
    }
    if (at != size)
        return bad(diag, "%zu bytes after the last field", size - at);
    for (int k = 0; k < F_COUNT; k++)
        if (f[k].required && !f[k].found)
            return bad(diag, "missing field '%s'", f[k].name);
    uint64_t h = fnv1a(0xcbf29ce484222325ull, f[F_NAMES].data, (size_t)f[F_NAMES].dim[0]);
    h = fnv1a(h, f[F_PARENTS].data, (size_t)f[F_PARENTS].dim[0] * 8);
#ifndef FUZZING_BUILD_MODE_UNSAFE_FOR_PRODUCTION
    if (h != rd64(b + 32))
        return bad(diag, "skeleton hash mismatch (joint_names and parents are not the header's)");
#else
    (void)h;
#endif
    return MLR_OK;
}

static int all_finite(const unsigned char *p, uint64_t n)
{
    for (uint64_t i = 0; i < n; i++)
        if (!isfinite(rdf(p + 8 * i)))
            return 0;
    return 1;
}

static mlr_status check_skeleton(const mlr_gen_model *m, const mlr_motion *sk, mlr_diag *diag)
{
    size_t J = mlr_motion_n_joints(sk);
    const int32_t *par = mlr_motion_parents(sk);
    for (size_t j = 0; j < J && j < m->n_joints; j++) {
        const char *a = m->name_at[j], *b = mlr_motion_joint_name(sk, j);
        if (!b || strcmp(a, b) != 0)
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    "mlr_gen_model_load: another "
                                    "skeleton: joint %zu is '%.40s' in the model, '%.40s' in the "
                                    "skeleton",
                                    j, a, b ? b : "");
        if (par[j] != m->parents[j])
            return common__diag_set(
                diag, MLR_E_INVALID_ARG, 0, 0,
                "mlr_gen_model_load: another "
                "skeleton: joint %zu '%.40s' has parent %d in the model, %d in "
                "the skeleton",
                j, a, (int)m->parents[j], (int)par[j]);
    }
    if (J != m->n_joints)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "mlr_gen_model_load: another "
                                "skeleton: %zu joints in the model, %zu in the skeleton",
                                m->n_joints, J);
    return MLR_OK;
}

mlr_status mlr_gen_model_load(const mlr_allocator *alloc, const void *bytes, size_t size,
                              const mlr_motion *skeleton, mlr_gen_model **out, mlr_diag *diag)
{
    if (!out)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "mlr_gen_model_load: out is NULL");
    *out = NULL;
    if (!bytes && size)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "mlr_gen_model_load: bytes is NULL");
    const unsigned char *b = bytes;
    field f[F_COUNT];
    memcpy(f, field_table, sizeof f);
    mlr_status st = scan(b, size, f, diag);
    if (st)
        return st;
    /* dimensions against each other */
    uint64_t J = f[F_PARENTS].dim[0], n = f[F_LABELS].dim[0], k = f[F_RUN].dim[0];
    uint64_t N = f[F_GCENTERS].dim[0], nout = f[F_COEF].dim[1], m = f[F_SEEN].dim[0];
    uint64_t nb = f[F_NAMES].dim[0];
#define NEED(cond, ...)                                                                           \
    do {                                                                                          \
        if (!(cond))                                                                              \
            return common__diag_set(diag, MLR_E_PARSE, 0, 0, "mlr_gen_model_load: " __VA_ARGS__); \
    } while (0)
    NEED(J >= 1 && J <= 100000, "field 'parents': %llu joints (1 .. 100000)",
         (unsigned long long)J);
    NEED(n >= 1 && k >= 1 && k <= 100000, "%llu points and %llu primitives (>= 1, k <= 100000)",
         (unsigned long long)n, (unsigned long long)k);
    NEED(f[F_FRAME_TIME].dim[0] == 1 && f[F_BODY].dim[0] == 1 && f[F_KERNEL].dim[0] == 1 &&
             f[F_WIDTH].dim[0] == 1 && f[F_MARKOV].dim[0] == 2,
         "frame_time, body_joint, grbf_kernel, grbf_width (1 value) or markov (2 values) of "
         "another size");
    NEED(f[F_POINTS].dim[0] == n && f[F_POINTS].dim[1] == 2,
         "field 'points' is %llu x %llu, "
         "expected %llu x 2 (labels)",
         (unsigned long long)f[F_POINTS].dim[0], (unsigned long long)f[F_POINTS].dim[1],
         (unsigned long long)n);
    NEED(f[F_CENTERS].dim[0] == k && f[F_CENTERS].dim[1] == 2, "field 'centers' is not %llu x 2",
         (unsigned long long)k);
    NEED(f[F_BOUNDS].dim[0] == 2 && f[F_BOUNDS].dim[1] == 2, "field 'bounds' is not 2 x 2");
    NEED(f[F_JUMPS].dim[0] == k && f[F_JUMPS].dim[1] == k, "field 'jumps' is not %llu x %llu",
         (unsigned long long)k, (unsigned long long)k);
    int64_t order = rdi(f[F_MARKOV].data), min_count = rdi(f[F_MARKOV].data + 8);
    NEED(order >= 1 && order <= MLR_MARKOV_MAX_ORDER && min_count >= 1,
         "field 'markov': order %lld (1 .. 3) or min_count %lld (>= 1) out of range",
         (long long)order, (long long)min_count);
    NEED(f[F_KEYS].dim[0] == m && f[F_KEYS].dim[1] == (uint64_t)order && f[F_PROBS].dim[0] == m &&
             f[F_PROBS].dim[1] == k,
         "context fields of other sizes than %llu contexts of order %lld over %llu primitives",
         (unsigned long long)m, (long long)order, (unsigned long long)k);
    NEED(N >= 1 && f[F_GCENTERS].dim[1] == 2 && f[F_COEF].dim[0] == N + 3,
         "fields 'grbf_centers' (%llu x %llu) and 'grbf_coef' (%llu rows) disagree",
         (unsigned long long)N, (unsigned long long)f[F_GCENTERS].dim[1],
         (unsigned long long)f[F_COEF].dim[0]);
    NEED(nout == 4 + 7 * J, "field 'grbf_coef' has %llu outputs, expected 4 + 7 J = %llu",
         (unsigned long long)nout, (unsigned long long)(4 + 7 * J));
    if (f[F_CONTACTS].found)
        NEED(f[F_CONTACTS].dim[0] == n && f[F_CONTACT_NAMES].found && f[F_FLOOR].found &&
                 f[F_FLOOR].dim[0] == 1,
             "contact fields of other sizes than %llu frames", (unsigned long long)n);
    if (f[F_SOM].found)
        NEED(f[F_SOM_LATTICE].found && f[F_SOM_LATTICE].dim[0] == 2 && f[F_SOM].dim[1] == 3 * J &&
                 rdi(f[F_SOM_LATTICE].data) > 0 && rdi(f[F_SOM_LATTICE].data + 8) > 0 &&
                 (uint64_t)rdi(f[F_SOM_LATTICE].data) * (uint64_t)rdi(f[F_SOM_LATTICE].data + 8) ==
                     f[F_SOM].dim[0],
             "fields 'som_codebook' and 'som_lattice' disagree");
    /* values */
    double frame_time = rdf(f[F_FRAME_TIME].data), width = rdf(f[F_WIDTH].data);
    int64_t body = rdi(f[F_BODY].data), kernel = rdi(f[F_KERNEL].data);
    NEED(isfinite(frame_time) && frame_time > 0, "field 'frame_time' must be finite and > 0");
    NEED(body >= 0 && (uint64_t)body < J, "field 'body_joint' %lld out of range (0 .. %llu)",
         (long long)body, (unsigned long long)(J - 1));
    NEED(kernel == 0 || kernel == 1, "field 'grbf_kernel' %lld (0 thin plate, 1 Gaussian)",
         (long long)kernel);
    NEED(kernel == 0 || (isfinite(width) && width >= 1e-150), "field 'grbf_width' out of range");
    NEED(all_finite(f[F_POINTS].data, 2 * n) && all_finite(f[F_CENTERS].data, 2 * k) &&
             all_finite(f[F_BOUNDS].data, 4) && all_finite(f[F_GCENTERS].data, 2 * N) &&
             all_finite(f[F_COEF].data, (N + 3) * nout),
         "points, centers, bounds or the GRBF hold a NaN or an infinity");
    for (int a = 0; a < 2; a++)
        NEED(rdf(f[F_BOUNDS].data + 16 * a) <= rdf(f[F_BOUNDS].data + 16 * a + 8),
             "field 'bounds': row %d has lo > hi", a);
    for (uint64_t i = 0; i < n; i++) {
        int64_t l = rdi(f[F_LABELS].data + 8 * i);
        NEED(l >= 0 && (uint64_t)l < k,
             "field 'labels': label %lld of frame %llu out of range "
             "(0 .. %llu)",
             (long long)l, (unsigned long long)i, (unsigned long long)(k - 1));
    }
    /* names: J NUL-terminated, not empty */
    const unsigned char *nm = f[F_NAMES].data;
    uint64_t count = 0, len = 0;
    for (uint64_t i = 0; i < nb; i++) {
        if (nm[i] == 0) {
            NEED(len > 0, "field 'joint_names': name %llu is empty", (unsigned long long)count);
            count++;
            len = 0;
        } else {
            len++;
        }
    }
    NEED(count == J && len == 0,
         "field 'joint_names' holds %llu names for %llu joints "
         "(each NUL-terminated)",
         (unsigned long long)count, (unsigned long long)J);
    for (uint64_t j = 0; j < J; j++) {
        int64_t p = rdi(f[F_PARENTS].data + 8 * j);
        NEED(j == 0 ? p == -1 : (p >= 0 && (uint64_t)p < j),
             "field 'parents': joint %llu has "
             "parent %lld (the root -1, the others an earlier joint)",
             (unsigned long long)j, (long long)p);
    }
    /* the contact points' names and the floor (optional): mlr_generator_set_guards */
    uint64_t nc = 0, cnb = 0;
    double floor_height = NAN;
    if (f[F_CONTACTS].found) {
        const unsigned char *cn = f[F_CONTACT_NAMES].data;
        uint64_t cc = 0, cl = 0;
        nc = f[F_CONTACTS].dim[1];
        cnb = f[F_CONTACT_NAMES].dim[0];
        for (uint64_t i = 0; i < cnb; i++) {
            if (cn[i] == 0) {
                NEED(cl > 0, "field 'contact_names': name %llu is empty", (unsigned long long)cc);
                cc++;
                cl = 0;
            } else {
                cl++;
            }
        }
        NEED(cc == nc && cl == 0,
             "field 'contact_names' holds %llu names for %llu contact columns "
             "(each NUL-terminated)",
             (unsigned long long)cc, (unsigned long long)nc);
        floor_height = rdf(f[F_FLOOR].data);
        NEED(!isinf(floor_height), "field 'floor_height' is infinite (NaN: no floor)");
    }
    /* sizes, then one block */
    size_t off_names = 0, off_ptr, off_par, off_pts, off_lab, off_cen, off_gc, off_coef, off_cn;
    size_t total;
    size_t sz = (size_t)nb;
    off_ptr = (sz + 7) / 8 * 8;
    off_par = off_ptr + (size_t)J * sizeof(char *);
    off_par = (off_par + 7) / 8 * 8;
    off_pts = off_par + ((size_t)J * 4 + 7) / 8 * 8;
    off_lab = off_pts + (size_t)n * 16;
    off_cen = off_lab + (size_t)n * 8;
    off_gc = off_cen + (size_t)k * 16;
    off_coef = off_gc + (size_t)N * 16;
    off_cn = off_coef + (size_t)((N + 3) * nout) * 8;
    total = off_cn + (size_t)cnb; /* all bounded by size: no overflow */
    mlr_allocator a;
    common__allocator_resolve(alloc, &a);
    mlr_gen_model *g = common__alloc(&a, sizeof *g);
    unsigned char *blk = g ? common__alloc(&a, total) : NULL;
    if (!blk) {
        if (g)
            common__free(&a, g, sizeof *g);
        return common__diag_set(diag, MLR_E_NO_MEMORY, 0, 0, "mlr_gen_model_load: out of memory");
    }
    memset(g, 0, sizeof *g);
    g->alloc = a;
    g->block = blk;
    g->bytes = total;
    g->n_joints = (size_t)J;
    g->body_joint = (size_t)body;
    g->n_points = (size_t)n;
    g->k = (size_t)k;
    g->n_out = (size_t)nout;
    g->n_centers = (size_t)N;
    g->frame_time = frame_time;
    g->kernel = (int)kernel;
    g->width = kernel ? width : 0.0;
    g->names = (char *)blk + off_names;
    memcpy(g->names, nm, sz);
    g->name_at = (const char **)(void *)(blk + off_ptr);
    for (size_t j = 0, i = 0; j < J; j++) {
        g->name_at[j] = g->names + i;
        i += strlen(g->names + i) + 1;
    }
    g->parents = (int32_t *)(void *)(blk + off_par);
    for (size_t j = 0; j < J; j++)
        g->parents[j] = (int32_t)rdi(f[F_PARENTS].data + 8 * j);
    g->points = (double *)(void *)(blk + off_pts);
    for (size_t i = 0; i < 2 * n; i++)
        g->points[i] = rdf(f[F_POINTS].data + 8 * i);
    g->labels = (int64_t *)(void *)(blk + off_lab);
    for (size_t i = 0; i < n; i++)
        g->labels[i] = rdi(f[F_LABELS].data + 8 * i);
    g->centers = (double *)(void *)(blk + off_cen);
    for (size_t i = 0; i < 2 * k; i++)
        g->centers[i] = rdf(f[F_CENTERS].data + 8 * i);
    for (int i = 0; i < 4; i++)
        g->bounds[i] = rdf(f[F_BOUNDS].data + 8 * i);
    g->grbf_centers = (double *)(void *)(blk + off_gc);
    for (size_t i = 0; i < 2 * N; i++)
        g->grbf_centers[i] = rdf(f[F_GCENTERS].data + 8 * i);
    g->grbf_coef = (double *)(void *)(blk + off_coef);
    for (size_t i = 0; i < (N + 3) * nout; i++)
        g->grbf_coef[i] = rdf(f[F_COEF].data + 8 * i);
    g->n_contacts = (size_t)nc;
    g->contact_names = (char *)blk + off_cn;
    if (cnb)
        memcpy(g->contact_names, f[F_CONTACT_NAMES].data, (size_t)cnb);
    g->floor_height = floor_height;
    st = skeleton ? check_skeleton(g, skeleton, diag) : MLR_OK;
    if (!st) {
        /* the Markov model from aligned copies of its arrays (in the caller's byte order) */
        size_t kk = (size_t)(k * k), mk_n = (size_t)(kk + k + m + m * k + m * order);
        double *tmp = common__alloc(&a, mk_n * 8);
        if (!tmp) {
            st =
                common__diag_set(diag, MLR_E_NO_MEMORY, 0, 0, "mlr_gen_model_load: out of memory");
        } else {
            double *jumps = tmp, *run = tmp + kk, *seen = run + k, *probs = seen + m;
            int64_t *keys = (int64_t *)(void *)(probs + m * k);
            for (size_t i = 0; i < kk; i++)
                jumps[i] = rdf(f[F_JUMPS].data + 8 * i);
            for (size_t i = 0; i < k; i++)
                run[i] = rdf(f[F_RUN].data + 8 * i);
            for (size_t i = 0; i < m; i++)
                seen[i] = rdf(f[F_SEEN].data + 8 * i);
            for (size_t i = 0; i < m * k; i++)
                probs[i] = rdf(f[F_PROBS].data + 8 * i);
            for (size_t i = 0; i < m * (size_t)order; i++)
                keys[i] = rdi(f[F_KEYS].data + 8 * i);
            st = mlr_markov_create((size_t)k, jumps, run, (unsigned)order, (size_t)min_count,
                                   (size_t)m, keys, seen, probs, &a, &g->markov, diag);
            common__free(&a, tmp, mk_n * 8);
            if (st) {
                /* a file's Markov arrays that the model refuses: a parse error of the file */
                st = common__diag_prefix(diag, st == MLR_E_INVALID_ARG ? MLR_E_PARSE : st,
                                         "mlr_gen_model_load");
            }
        }
    }
    if (st) {
        common__free(&a, blk, total);
        common__free(&a, g, sizeof *g);
        return st;
    }
    *out = g;
    return MLR_OK;
#undef NEED
}

mlr_status mlr_gen_model_load_file(const mlr_allocator *alloc, const char *path,
                                   const mlr_motion *skeleton, mlr_gen_model **out, mlr_diag *diag)
{
    if (!out || !path)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "mlr_gen_model_load_file: %s is NULL", out ? "path" : "out");
    *out = NULL;
    char *buf = NULL;
    size_t len = 0, cap = 0;
    mlr_allocator a;
    common__allocator_resolve(alloc, &a);
    mlr_status st = file_read__read(path, 1, &a, &buf, &len, &cap, diag);
    if (st)
        return common__diag_prefix(diag, st, "mlr_gen_model_load_file");
    if (len > MAX_FILE)
        st = common__diag_set(diag, MLR_E_PARSE, 0, 0,
                              "mlr_gen_model_load_file: %zu bytes, more "
                              "than a model file has (1 GiB)",
                              len);
    else
        st = mlr_gen_model_load(&a, buf, len, skeleton, out, diag);
    common__free(&a, buf, cap);
    return st;
}

size_t mlr_gen_model_n_joints(const mlr_gen_model *m) { return m ? m->n_joints : 0; }
const char *mlr_gen_model_joint_name(const mlr_gen_model *m, size_t j)
{
    return m && j < m->n_joints ? m->name_at[j] : NULL;
}
size_t mlr_gen_model_body_joint(const mlr_gen_model *m) { return m ? m->body_joint : 0; }
size_t mlr_gen_model_n_points(const mlr_gen_model *m) { return m ? m->n_points : 0; }
size_t mlr_gen_model_n_primitives(const mlr_gen_model *m) { return m ? m->k : 0; }
double mlr_gen_model_frame_time(const mlr_gen_model *m) { return m ? m->frame_time : 0.0; }
size_t mlr_gen_model_frame_size(const mlr_gen_model *m) { return m ? 3 + 4 * m->n_joints : 0; }

void mlr_gen_model_destroy(mlr_gen_model *m)
{
    if (!m)
        return;
    mlr_allocator a = m->alloc;
    mlr_markov_destroy(m->markov);
    common__free(&a, m->block, m->bytes);
    common__free(&a, m, sizeof *m);
}
