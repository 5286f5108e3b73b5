/* BVH writer: to a callback, to caller memory, or atomically to a file (temporary file in the
 * same directory, then rename). Output is independent of the locale. Nothing here prints or
 * keeps state. */
#include "motion/bvh_internal.h"
#include "io/numparse.h"

#include <errno.h>
#include <locale.h>
#include <math.h>
#include <stdio.h>
#include <time.h>
#ifndef _WIN32
#include <sys/stat.h>
#endif

#ifdef _WIN32
#define WIN32_LEAN_AND_MEAN
#include <windows.h>
#endif

#define MAX_INDENT 64

typedef struct sink {
    mlr_bvh_write_fn fn;
    void *user;
    int failed;
    const char *dp;   /* the locale's decimal point when it is not "." */
    size_t dp_len;
    size_t len;
    char buf[4096];
} sink;

static void flush(sink *s)
{
    if (s->len && !s->failed && s->fn(s->user, s->buf, s->len) != 0)
        s->failed = 1;
    s->len = 0;
}

static void put(sink *s, const char *d, size_t n)
{
    if (s->len + n > sizeof s->buf) {
        flush(s);
        if (n > sizeof s->buf) {
            if (!s->failed && s->fn(s->user, d, n) != 0)
                s->failed = 1;
            return;
        }
    }
    memcpy(s->buf + s->len, d, n);
    s->len += n;
}

static void puts_(sink *s, const char *z) { put(s, z, strlen(z)); }

static void indent(sink *s, size_t depth)
{
    static const char tabs[MAX_INDENT] = {
        '\t', '\t', '\t', '\t', '\t', '\t', '\t', '\t', '\t', '\t', '\t', '\t', '\t',
        '\t', '\t', '\t', '\t', '\t', '\t', '\t', '\t', '\t', '\t', '\t', '\t', '\t',
        '\t', '\t', '\t', '\t', '\t', '\t', '\t', '\t', '\t', '\t', '\t', '\t', '\t',
        '\t', '\t', '\t', '\t', '\t', '\t', '\t', '\t', '\t', '\t', '\t', '\t', '\t',
        '\t', '\t', '\t', '\t', '\t', '\t', '\t', '\t', '\t', '\t', '\t', '\t',
    };
    put(s, tabs, depth < MAX_INDENT ? depth : MAX_INDENT);
}

/* printf("%.*g") with the locale's decimal point turned back into '.'; returns the length. */
static size_t format_g(const sink *s, char *out, size_t cap, double v, int prec)
{
    int n = snprintf(out, cap, "%.*g", prec, v);
    if (n < 0 || (size_t)n >= cap) { /* cannot happen for a finite double and cap >= 32 */
        out[0] = '0';
        return 1;
    }
    size_t len = (size_t)n;
    if (s->dp) {
        char *p = strstr(out, s->dp);
        if (p) {
            *p = '.';
            memmove(p + 1, p + s->dp_len, len - (size_t)(p - out) - s->dp_len + 1);
            len -= s->dp_len - 1;
        }
    }
    return len;
}

/* printf("%.9g") for 1e-4 <= |v| < 1e8 and +0 without printf (which took 70% of the writer's
 * time): 9 significant digits, trailing zeros and a bare point dropped. The digits are those of
 * round(|v| 10^k) for k = 8 - the decimal exponent, one rounding in the product, so the ninth
 * digit can differ from printf's (exact) one by 1 when |v| 10^k lies within an ulp of a half:
 * a relative change below 1e-8, far inside what the writer promises. Returns 0 for any other
 * value (printf takes it). */
static size_t format_g9_fast(double v, char *out)
{
    static const double p10[13] = {1e-4, 1e-3, 1e-2, 1e-1, 1e0, 1e1, 1e2,
                                   1e3,  1e4,  1e5,  1e6,  1e7, 1e8};
    static const double scale[13] = {1e12, 1e11, 1e10, 1e9, 1e8, 1e7, 1e6,
                                     1e5,  1e4,  1e3,  1e2, 1e1, 1e0};
    if (v == 0.0 && !signbit(v)) {
        out[0] = '0';
        return 1;
    }
    const double a = fabs(v);
    if (!(a >= p10[0] && a < p10[12]))
        return 0;
    int e = 0; /* p10[e] <= a < p10[e + 1] */
    while (a >= p10[e + 1])
        e++;
    const double m = nearbyint(a * scale[e]);
    if (!(m >= 1e8 && m < 1e9)) /* rounded up to 10 digits, or a near the boundary: printf */
        return 0;
    const int frac = 8 - (e - 4); /* digits after the point */
    char d[9];
    unsigned long long x = (unsigned long long)m;
    for (int i = 8; i >= 0; i--, x /= 10)
        d[i] = (char)('0' + x % 10);
    size_t n = 0;
    if (v < 0)
        out[n++] = '-';
    const int whole = 9 - frac; /* digits before the point; <= 0: "0.00ddd" */
    int last = 8;               /* the last digit kept: trailing zeros after the point go */
    while (last >= whole && last > 0 && d[last] == '0')
        last--;
    if (whole <= 0) {
        out[n++] = '0';
        out[n++] = '.';
        for (int i = whole; i < 0; i++)
            out[n++] = '0';
        for (int i = 0; i <= last; i++)
            out[n++] = d[i];
    } else {
        for (int i = 0; i < whole; i++)
            out[n++] = d[i];
        if (last >= whole) {
            out[n++] = '.';
            for (int i = whole; i <= last; i++)
                out[n++] = d[i];
        }
    }
    return n;
}

/* Fewest digits from min_prec on that read back exactly (17 always do). */
static void put_exact(sink *s, double v, int min_prec, int step_to_17)
{
    char b[48];
    for (int prec = min_prec;; prec = step_to_17 ? 17 : prec + 1) {
        size_t n = 0;
        if (prec == 9)
            n = format_g9_fast(v, b);
        if (n == 0)
            n = format_g(s, b, sizeof b, v, prec);
        double back;
        if (prec >= 17 || (mlr_parse_decimal(b, b + n, &back) == n && back == v &&
                           signbit(back) == signbit(v))) {
            put(s, b, n);
            return;
        }
    }
}

static void put_g9(sink *s, double v)
{
    char b[48];
    size_t n = format_g9_fast(v, b);
    put(s, b, n ? n : format_g(s, b, sizeof b, v, 9));
}

static void put_size(sink *s, size_t v)
{
    char b[32];
    int n = snprintf(b, sizeof b, "%zu", v);
    put(s, b, (size_t)n);
}

static void put_vec3(sink *s, const char *label, const double *v)
{
    puts_(s, label);
    for (int k = 0; k < 3; k++) {
        put(s, " ", 1);
        put_exact(s, v[k], 1, 0);
    }
    put(s, "\n", 1);
}

/* Index of the first non-finite value of v, or n. */
static size_t first_nonfinite(const double *v, size_t n)
{
    for (size_t i = 0; i < n; i++)
        if (!isfinite(v[i]))
            return i;
    return n;
}

/* Index of the first quaternion of q that is not finite or is zero, or n. */
static size_t first_unusable_quat(const double *q, size_t n)
{
    for (size_t i = 0; i < n; i++, q += 4) {
        if (!isfinite(q[0]) || !isfinite(q[1]) || !isfinite(q[2]) || !isfinite(q[3]))
            return i;
        if (q[0] == 0.0 && q[1] == 0.0 && q[2] == 0.0 && q[3] == 0.0)
            return i;
    }
    return n;
}

/* MLR_OK when every value of m can be written, else MLR_E_INVALID_ARG naming the first bad one
 * (checked before anything is written). */
static mlr_status check_writable(const mlr_motion *m, mlr_diag *diag)
{
    const size_t J = m->n_joints, N = m->n_frames, P = m->n_trans, E = m->n_end;
    size_t i;
    if (!isfinite(m->frame_time) || !(m->frame_time > 0.0))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "bvh write: frame_time %g is not finite and > 0", m->frame_time);
    if ((i = first_nonfinite(m->offsets, 3 * J)) < 3 * J)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "bvh write: offsets: joint %zu ('%s') is NaN or infinite", i / 3,
                                m->names[i / 3]);
    if ((i = first_nonfinite(m->end_offsets, 3 * E)) < 3 * E)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "bvh write: end site offsets: End Site %zu is NaN or infinite",
                                i / 3);
    if ((i = first_nonfinite(m->root_pos, 3 * N)) < 3 * N)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "bvh write: root_pos: frame %zu is NaN or infinite", i / 3);
    if ((i = first_nonfinite(m->trans, 3 * N * P)) < 3 * N * P)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "bvh write: trans: frame %zu, joint '%s' is NaN or infinite",
                                i / (3 * P), m->names[m->trans_joints[i / 3 % P]]);
    if ((i = first_unusable_quat(m->rot, N * J)) < N * J)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "bvh write: rot: frame %zu, joint '%s' is a zero, NaN or infinite "
                                "quaternion",
                                i / J, m->names[i % J]);
    return MLR_OK;
}

static void write_hierarchy(const mlr_motion *m, sink *s)
{
    const size_t J = m->n_joints, E = m->n_end;
    puts_(s, "HIERARCHY\n");
    int32_t cur = -1;
    size_t depth = 0, e = 0;
    for (size_t j = 0; j < J; j++) {
        int32_t p = m->parents[j];
        while (cur != p && cur >= 0) {
            indent(s, --depth);
            puts_(s, "}\n");
            cur = m->parents[cur];
        }
        indent(s, depth);
        puts_(s, j == 0 ? "ROOT " : "JOINT ");
        puts_(s, m->names[j]);
        put(s, "\n", 1);
        indent(s, depth);
        puts_(s, "{\n");
        depth++;
        indent(s, depth);
        put_vec3(s, "OFFSET", m->offsets + 3 * j);
        indent(s, depth);
        puts_(s, "CHANNELS ");
        put_size(s, m->n_ch[j]);
        if (m->n_ch[j]) {
            put(s, " ", 1);
            puts_(s, m->ch_str + BVH_CHSTR * j);
        }
        put(s, "\n", 1);
        for (; e < E && (size_t)m->end_parents[e] == j; e++) {
            indent(s, depth);
            puts_(s, "End Site\n");
            indent(s, depth);
            puts_(s, "{\n");
            indent(s, depth + 1);
            put_vec3(s, "OFFSET", m->end_offsets + 3 * e);
            indent(s, depth);
            puts_(s, "}\n");
        }
        cur = (int32_t)j;
    }
    while (cur >= 0) {
        indent(s, --depth);
        puts_(s, "}\n");
        cur = m->parents[cur];
    }
}

static void write_frames(const mlr_motion *m, sink *s)
{
    const size_t J = m->n_joints, N = m->n_frames, P = m->n_trans;
    puts_(s, "MOTION\nFrames: ");
    put_size(s, N);
    puts_(s, "\nFrame Time: ");
    put_exact(s, m->frame_time, 1, 0);
    put(s, "\n", 1);
    for (size_t f = 0; f < N && !s->failed; f++) {
        const double *rot = m->rot + 4 * J * f;
        int first = 1;
        for (size_t j = 0; j < J; j++) {
            size_t nch = m->n_ch[j];
            if (nch == 0)
                continue;
            const unsigned char *ch = m->ch + BVH_MAX_CHANNELS * j;
            const double *t = j == 0 ? m->root_pos + 3 * f
                              : m->trans_slot[j] >= 0
                                  ? m->trans + 3 * (P * f + (size_t)m->trans_slot[j])
                                  : NULL;
            double ang[3] = {0.0, 0.0, 0.0};
            int have_ang = 0;
            for (size_t k = 0; k < nch; k++) {
                if (!first)
                    put(s, " ", 1);
                first = 0;
                if (ch[k] < 3) {
                    put_exact(s, t[ch[k]], 9, 1);
                } else {
                    if (!have_ang) {
                        mlr_quat q = {rot[4 * j], rot[4 * j + 1], rot[4 * j + 2], rot[4 * j + 3]};
                        mlr_quat_to_euler_array(&q, 1, (mlr_euler_order)m->order[j], ang, NULL);
                        have_ang = 1;
                    }
                    double deg = ang[m->rot_idx[3 * j + ch[k] - 3]] * BVH_RAD2DEG;
                    put_g9(s, deg + 0.0); /* + 0.0: -0 is written as 0 */
                }
            }
        }
        put(s, "\n", 1);
    }
}

mlr_status mlr_bvh_write(const mlr_motion *m, mlr_bvh_write_fn fn, void *user, mlr_diag *diag)
{
    if (!m || !fn)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "bvh write: %s is NULL",
                                !m ? "motion" : "fn");
    /* Validate everything first so that nothing is written for bad data. */
    mlr_status st = check_writable(m, diag);
    if (st != MLR_OK)
        return st;
    sink s;
    s.fn = fn;
    s.user = user;
    s.failed = 0;
    s.len = 0;
    const struct lconv *lc = localeconv();
    s.dp = NULL;
    s.dp_len = 0;
    if (lc && lc->decimal_point && lc->decimal_point[0] && strcmp(lc->decimal_point, ".") != 0) {
        s.dp = lc->decimal_point;
        s.dp_len = strlen(s.dp);
    }
    write_hierarchy(m, &s);
    write_frames(m, &s);
    flush(&s);
    if (s.failed)
        return common__diag_set(diag, MLR_E_IO, 0, 0, "bvh write: fn returned nonzero (stop)");
    return MLR_OK;
}

/* ---- memory ------------------------------------------------------------------------------ */

typedef struct mem_sink {
    char *buf;
    size_t cap, len;
} mem_sink;

static int mem_write(void *user, const char *data, size_t len)
{
    mem_sink *ms = user;
    if (ms->buf && ms->len < ms->cap) {
        size_t k = ms->cap - ms->len < len ? ms->cap - ms->len : len;
        memcpy(ms->buf + ms->len, data, k);
    }
    if (len > SIZE_MAX - ms->len)
        return 1;
    ms->len += len;
    return 0;
}

mlr_status mlr_bvh_write_memory(const mlr_motion *m, char *buf, size_t cap, size_t *len,
                                mlr_diag *diag)
{
    if (!len)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "bvh write_memory: len is NULL");
    *len = 0;
    mem_sink ms = {buf, buf ? cap : 0, 0};
    mlr_status s = mlr_bvh_write(m, mem_write, &ms, diag);
    if (s == MLR_E_IO) /* mem_write stops only when the length overflows a size_t */
        return common__diag_set(diag, MLR_E_OVERFLOW, 0, 0,
                                "bvh write_memory: the text is longer than SIZE_MAX bytes");
    if (s != MLR_OK)
        return s;
    *len = ms.len;
    if (buf && ms.len > cap)
        return common__diag_set(diag, MLR_E_OVERFLOW, 0, 0,
                                "bvh write_memory: cap %zu < the %zu bytes of the text", cap,
                                ms.len);
    return MLR_OK;
}

/* ---- files ------------------------------------------------------------------------------- */

static int file_write(void *user, const char *data, size_t len)
{
    return fwrite(data, 1, len, (FILE *)user) == len ? 0 : 1;
}

/* The mode of an existing regular file at to given to from (which replaces it), so that
   rewriting a 0600 output keeps it 0600 (it became 0644 under umask 022). */
static void keep_mode(const char *from, const char *to)
{
#ifndef _WIN32
    struct stat st;
    if (stat(to, &st) == 0 && S_ISREG(st.st_mode))
        (void)chmod(from, st.st_mode & 07777);
#else
    (void)from, (void)to;
#endif
}

static int replace_file(const char *from, const char *to)
{
#ifdef _WIN32
    return MoveFileExA(from, to, MOVEFILE_REPLACE_EXISTING | MOVEFILE_WRITE_THROUGH) ? 0 : -1;
#else
    return rename(from, to);
#endif
}

/* The name of path's temporary by the rule of mlr_bvh.h (mlr_bvh_write_file):
 * "DIR/.NAME.tmp-" and nonce as 16 lowercase hexadecimal digits. base is where NAME starts in
 * path; out holds at least strlen(path) + 23 bytes. */
static void temp_name(char *out, size_t cap, const char *path, const char *base, uint64_t nonce)
{
    const size_t dlen = (size_t)(base - path);
    memcpy(out, path, dlen);
    snprintf(out + dlen, cap - dlen, ".%s.tmp-%016llx", base, (unsigned long long)nonce);
}

/* Where the file name starts in path: after the last path separator. */
static const char *base_name(const char *path)
{
    const char *base = path;
    for (const char *p = path; *p; p++) {
#ifdef _WIN32
        if (*p == '\\' || *p == ':')
            base = p + 1;
#endif
        if (*p == '/')
            base = p + 1;
    }
    return base;
}

mlr_status mlr_bvh_write_file(const mlr_motion *m, const char *path, mlr_diag *diag)
{
    if (diag) {
        diag->line = diag->column = 0;
        diag->message[0] = '\0';
    }
    if (!m || !path || !*path)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "motion or path is NULL or empty");
    const char *base = base_name(path);
    if (!*base)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "path names a folder (it ends with a "
                                "path separator)");
    size_t plen = strlen(path);
    const size_t suffix = 24; /* "." + ".tmp-" + 16 hex digits + NUL, rounded up */
    if (plen > SIZE_MAX - suffix)
        return common__diag_set(diag, MLR_E_OVERFLOW, 0, 0,
                                "bvh write: the path's length overflows");
    char *tmp = common__alloc(&m->alloc, plen + suffix);
    if (!tmp)
        return common__diag_set(diag, MLR_E_NO_MEMORY, 0, 0,
                                "bvh write: out of memory for the temporary file's name");

    /* A name no other writer is likely to pick; "x" makes the creation exclusive. */
    uint64_t seed = (uint64_t)time(NULL) ^ ((uint64_t)clock() << 20) ^ (uint64_t)(uintptr_t)tmp ^
                    ((uint64_t)(uintptr_t)&seed << 7);
    FILE *fp = NULL;
    int err = 0;
    for (int attempt = 0; attempt < 32 && !fp; attempt++) {
        seed = seed * 6364136223846793005ull + 1442695040888963407ull;
        temp_name(tmp, plen + suffix, path, base, seed >> 1);
        errno = 0;
        fp = fopen(tmp, "wbx");
        err = errno;
        if (!fp && err != EEXIST)
            break;
    }
    if (!fp) {
        common__free(&m->alloc, tmp, plen + suffix);
        return common__diag_set(diag, MLR_E_IO, 0, 0,
                                "cannot create a temporary file next to the "
                                "target: %s",
                                strerror(err ? err : EEXIST));
    }
    mlr_status s = mlr_bvh_write(m, file_write, fp, diag); /* names the first bad value */
    if (s == MLR_E_IO)
        common__diag_set(diag, s, 0, 0, "write failed: %s", strerror(errno));
    if (fclose(fp) != 0 && s == MLR_OK)
        s = common__diag_set(diag, MLR_E_IO, 0, 0, "write failed: %s", strerror(errno));
    if (s == MLR_OK)
        keep_mode(tmp, path);
    if (s == MLR_OK && replace_file(tmp, path) != 0)
        s = common__diag_set(diag, MLR_E_IO, 0, 0, "cannot rename the temporary file: %s",
                             strerror(errno));
    if (s != MLR_OK)
        remove(tmp);
    common__free(&m->alloc, tmp, plen + suffix);
    return s;
}
