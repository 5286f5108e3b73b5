/* BVH reader: a single pass over the text, no recursion, every count checked against the
 * bytes that remain before anything is allocated from it. Errors carry line, column and reason.
 * Nothing here prints or keeps state. */
#include "bvh_frames.h"
#include "bvh_internal.h"
#include "file_read_internal.h"
#include "parallel_internal.h"
#include "numparse.h"
#include "options_internal.h"

#include <float.h>
#include <locale.h>
#include <math.h>
#include <stdarg.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>

/* Most threads a read uses. */
#define BVH_MAX_THREADS 16

/* ---- growable arrays through the allocator ------------------------------------------------ */

typedef struct vec {
    unsigned char *data;
    size_t len, cap, elsize;
} vec;

static void *vec_push(vec *v, const mlr_allocator *a)
{
    if (v->len == v->cap) {
        size_t cap = v->cap ? v->cap * 2 : 16, bytes;
        if (cap < v->cap || mlr_mul_size(cap, v->elsize, &bytes) != MLR_OK)
            return NULL;
        unsigned char *d = mlr_alloc(a, bytes);
        if (!d)
            return NULL;
        if (v->len)
            memcpy(d, v->data, v->len * v->elsize);
        mlr_free(a, v->data, v->cap * v->elsize);
        v->data = d;
        v->cap = cap;
    }
    return v->data + v->elsize * v->len++;
}

static void vec_free(vec *v, const mlr_allocator *a)
{
    mlr_free(a, v->data, v->cap * v->elsize);
    v->data = NULL;
    v->len = v->cap = 0;
}

/* ---- the parser -------------------------------------------------------------------------- */

typedef struct tjoint {
    size_t name_off, name_len, line;
    int32_t parent;
    double offset[3];
    unsigned char n_ch, ch[BVH_MAX_CHANNELS];
    unsigned char has_offset, has_channels;
    size_t n_end, end_next;
} tjoint;

typedef struct tend {
    int32_t parent;
    double offset[3];
} tend;

typedef struct parser {
    const char *begin, *p, *end, *line_start;
    size_t line;
    mlr_diag *diag;
    mlr_allocator a;
    vec joints, ends, names;
    /* lenient reading (mlr_bvh_read_memory_opts) */
    int strict, keep_truncated;
    mlr_bvh_warnings *warn;                  /* NULL: warnings not wanted */
    size_t fail_frame, fail_line_no;         /* where the frame loop stopped with an error */
    const char *fail_line;
} parser;

static int is_blank(char c) { return c == ' ' || c == '\t' || c == '\v' || c == '\f'; }
static int is_eol(char c) { return c == '\n' || c == '\r'; }

static mlr_status fail_at(parser *ps, const char *at, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

static mlr_status fail_at(parser *ps, const char *at, const char *fmt, ...)
{
    if (ps->diag) {
        va_list ap;
        va_start(ap, fmt);
        ps->diag->line = ps->line;
        ps->diag->column = at ? (size_t)(at - ps->line_start) + 1 : 0;
        vsnprintf(ps->diag->message, sizeof ps->diag->message, fmt, ap);
        va_end(ap);
    }
    return MLR_E_PARSE;
}

/* A printable copy of a token for messages: at most 32 bytes, control bytes as '?'. */
typedef struct shown { char s[40]; } shown;
static shown show(const char *t, size_t n)
{
    shown r;
    size_t k = n > 32 ? 32 : n;
    for (size_t i = 0; i < k; i++) {
        unsigned char c = (unsigned char)t[i];
        r.s[i] = (c < 0x20 || c == 0x7f) ? '?' : (char)c;
    }
    if (n > k) {
        memcpy(r.s + k, "...", 4);
    } else {
        r.s[k] = '\0';
    }
    return r;
}

static void eat_eol(parser *ps)
{
    if (ps->p < ps->end && *ps->p == '\r')
        ps->p++;
    if (ps->p < ps->end && *ps->p == '\n')
        ps->p++;
    ps->line++;
    ps->line_start = ps->p;
}

static void skip_blank(parser *ps)
{
    while (ps->p < ps->end && is_blank(*ps->p))
        ps->p++;
}

static void skip_ws(parser *ps)
{
    while (ps->p < ps->end) {
        char c = *ps->p;
        if (is_blank(c))
            ps->p++;
        else if (is_eol(c))
            eat_eol(ps);
        else
            break;
    }
}

static int is_token_char(unsigned char c) { return c > 0x20 && c != 0x7f && c != '{' && c != '}'; }

/* Next token: '{', '}' or a run of other visible bytes. Returns 1 with the token, 0 at the end
 * of the input, MLR_E_PARSE on a control byte. */
static int next_token(parser *ps, const char **tok, size_t *len)
{
    skip_ws(ps);
    if (ps->p >= ps->end)
        return 0;
    const char *t = ps->p;
    unsigned char c = (unsigned char)*t;
    if (c == '{' || c == '}') {
        ps->p++;
    } else if (!is_token_char(c)) {
        return fail_at(ps, t, "unexpected control byte 0x%02x (binary data?)", c);
    } else {
        while (ps->p < ps->end && is_token_char((unsigned char)*ps->p))
            ps->p++;
        if (ps->p < ps->end) {
            unsigned char d = (unsigned char)*ps->p;
            if ((d < 0x20 && !is_blank((char)d) && !is_eol((char)d)) || d == 0x7f)
                return fail_at(ps, ps->p, "unexpected control byte 0x%02x (binary data?)", d);
        }
    }
    *tok = t;
    *len = (size_t)(ps->p - t);
    return 1;
}

static int tok_is(const char *t, size_t n, const char *kw)
{
    size_t i = 0;
    for (; i < n && kw[i]; i++) {
        char a = t[i];
        if (a >= 'a' && a <= 'z')
            a = (char)(a - 'a' + 'A');
        char b = kw[i];
        if (b >= 'a' && b <= 'z')
            b = (char)(b - 'a' + 'A');
        if (a != b)
            return 0;
    }
    return i == n && kw[i] == '\0';
}

/* Expect a token equal to kw; what describes the place for the message. */
static mlr_status expect(parser *ps, const char *kw, const char *what)
{
    const char *t;
    size_t n;
    int r = next_token(ps, &t, &n);
    if (r < 0)
        return r;
    if (r == 0)
        return fail_at(ps, ps->p, "unexpected end of file: expected '%s' %s", kw, what);
    if (!tok_is(t, n, kw))
        return fail_at(ps, t, "expected '%s' %s, found '%s'", kw, what, show(t, n).s);
    return MLR_OK;
}

static mlr_status expect_number(parser *ps, double *out, const char *what)
{
    const char *t = NULL;
    size_t n = 0;
    int r = next_token(ps, &t, &n);
    if (r < 0)
        return r;
    if (r == 0)
        return fail_at(ps, ps->p, "unexpected end of file: expected %s", what);
    if (mlr_parse_decimal(t, t + n, out) != n)
        return fail_at(ps, t, "expected %s, found '%s'", what, show(t, n).s);
    return MLR_OK;
}

/* Name after ROOT or JOINT: the rest of the line up to a brace, blanks trimmed. */
static mlr_status read_name(parser *ps, const char *kw, size_t *off, size_t *len)
{
    skip_blank(ps);
    const char *t = ps->p;
    while (ps->p < ps->end && !is_eol(*ps->p) && *ps->p != '{' && *ps->p != '}') {
        unsigned char c = (unsigned char)*ps->p;
        if ((c < 0x20 && c != '\t' && c != '\v' && c != '\f') || c == 0x7f)
            return fail_at(ps, ps->p, "unexpected control byte 0x%02x in a %s name", c, kw);
        ps->p++;
    }
    const char *e = ps->p;
    while (e > t && is_blank(e[-1]))
        e--;
    if (e == t)
        return fail_at(ps, t, "%s without a name", kw);
    size_t n = (size_t)(e - t);
    *off = ps->names.len;
    *len = n;
    for (size_t i = 0; i < n; i++) {
        char *c = vec_push(&ps->names, &ps->a);
        if (!c)
            return MLR_E_NO_MEMORY;
        *c = is_blank(t[i]) && t[i] != '\t' ? ' ' : t[i];
    }
    char *z = vec_push(&ps->names, &ps->a);
    if (!z)
        return MLR_E_NO_MEMORY;
    *z = '\0';
    return MLR_OK;
}

static mlr_status open_joint(parser *ps, const char *kw, int32_t parent, int32_t *index)
{
    if (ps->joints.len >= BVH_MAX_JOINTS)
        return fail_at(ps, ps->p, "too many joints");
    size_t line = ps->line;
    tjoint *jt = vec_push(&ps->joints, &ps->a);
    if (!jt)
        return MLR_E_NO_MEMORY;
    memset(jt, 0, sizeof *jt);
    jt->parent = parent;
    jt->line = line;
    *index = (int32_t)(ps->joints.len - 1);
    size_t off, len;
    mlr_status s = read_name(ps, kw, &off, &len);
    if (s != MLR_OK)
        return s;
    jt = (tjoint *)ps->joints.data + *index; /* names vec is separate; jt still valid */
    jt->name_off = off;
    jt->name_len = len;
    return expect(ps, "{", "after the joint name");
}

static const char *joint_name(parser *ps, int32_t j)
{
    return (const char *)ps->names.data + ((tjoint *)ps->joints.data)[j].name_off;
}

static mlr_status parse_channels(parser *ps, tjoint *jt, int32_t j)
{
    const char *t;
    size_t n;
    int r = next_token(ps, &t, &n);
    if (r < 0)
        return r;
    if (r == 0)
        return fail_at(ps, ps->p, "unexpected end of file after CHANNELS");
    size_t count = 0;
    for (size_t i = 0; i < n; i++) {
        if (t[i] < '0' || t[i] > '9' || count > 6) {
            count = 99;
            break;
        }
        count = count * 10 + (size_t)(t[i] - '0');
    }
    if (count > BVH_MAX_CHANNELS)
        return fail_at(ps, t, "CHANNELS count must be 0 to 6, found '%s'", show(t, n).s);
    unsigned seen = 0;
    for (size_t k = 0; k < count; k++) {
        r = next_token(ps, &t, &n);
        if (r < 0)
            return r;
        if (r == 0)
            return fail_at(ps, ps->p, "unexpected end of file in CHANNELS of joint '%s'",
                           joint_name(ps, j));
        int c = bvh_channel_parse(t, n);
        if (c < 0) {
            if (tok_is(t, n, "JOINT") || tok_is(t, n, "End") || tok_is(t, n, "}") ||
                tok_is(t, n, "OFFSET") || tok_is(t, n, "{"))
                return fail_at(ps, t, "CHANNELS %zu lists only %zu channel names", count, k);
            return fail_at(ps, t, "unknown channel '%s'", show(t, n).s);
        }
        if (seen & (1u << c))
            return fail_at(ps, t, "channel %s listed twice", bvh_channel_name(c));
        seen |= 1u << c;
        jt->ch[k] = (unsigned char)c;
    }
    jt->n_ch = (unsigned char)count;
    jt->has_channels = 1;
    return MLR_OK;
}

static mlr_status parse_end_site(parser *ps, int32_t parent)
{
    mlr_status s = expect(ps, "Site", "after 'End'");
    if (s == MLR_OK)
        s = expect(ps, "{", "after 'End Site'");
    if (s == MLR_OK)
        s = expect(ps, "OFFSET", "in End Site");
    if (ps->ends.len >= BVH_MAX_JOINTS)
        return fail_at(ps, ps->p, "too many End Sites");
    tend *e = s == MLR_OK ? vec_push(&ps->ends, &ps->a) : NULL;
    if (s == MLR_OK && !e)
        s = MLR_E_NO_MEMORY;
    for (int k = 0; k < 3 && s == MLR_OK; k++)
        s = expect_number(ps, &e->offset[k], "a number in the End Site OFFSET");
    if (s == MLR_OK)
        s = expect(ps, "}", "to close the End Site");
    if (s == MLR_OK) {
        e->parent = parent;
        ((tjoint *)ps->joints.data)[parent].n_end++;
    }
    return s;
}

static mlr_status parse_hierarchy(parser *ps)
{
    const char *t;
    size_t n;
    int r = next_token(ps, &t, &n);
    if (r < 0)
        return r;
    if (r == 0)
        return fail_at(ps, ps->p, "empty input: expected HIERARCHY");
    if (!tok_is(t, n, "HIERARCHY"))
        return fail_at(ps, t, "expected HIERARCHY at the start, found '%s'", show(t, n).s);
    mlr_status s = expect(ps, "ROOT", "after HIERARCHY");
    int32_t cur = -1;
    if (s == MLR_OK)
        s = open_joint(ps, "ROOT", -1, &cur);
    while (s == MLR_OK && cur >= 0) {
        r = next_token(ps, &t, &n);
        if (r < 0)
            return r;
        tjoint *jt = (tjoint *)ps->joints.data + cur;
        if (r == 0)
            return fail_at(ps, ps->p, "unexpected end of file in joint '%s' (missing '}')",
                           joint_name(ps, cur));
        if (tok_is(t, n, "JOINT")) {
            s = open_joint(ps, "JOINT", cur, &cur);
        } else if (tok_is(t, n, "End")) {
            s = parse_end_site(ps, cur);
        } else if (tok_is(t, n, "OFFSET")) {
            if (jt->has_offset)
                return fail_at(ps, t, "second OFFSET in joint '%s'", joint_name(ps, cur));
            for (int k = 0; k < 3 && s == MLR_OK; k++)
                s = expect_number(ps, &jt->offset[k], "a number in OFFSET");
            jt->has_offset = 1;
        } else if (tok_is(t, n, "CHANNELS")) {
            if (jt->has_channels)
                return fail_at(ps, t, "second CHANNELS in joint '%s'", joint_name(ps, cur));
            s = parse_channels(ps, jt, cur);
        } else if (tok_is(t, n, "}")) {
            if (!jt->has_offset)
                return fail_at(ps, t, "joint '%s' has no OFFSET", joint_name(ps, cur));
            cur = jt->parent;
        } else if (tok_is(t, n, "ROOT")) {
            return fail_at(ps, t, "ROOT inside joint '%s' (missing '}')", joint_name(ps, cur));
        } else if (tok_is(t, n, "MOTION")) {
            return fail_at(ps, t, "MOTION inside joint '%s' (missing '}')", joint_name(ps, cur));
        } else {
            return fail_at(ps, t, "unexpected '%s' in joint '%s'", show(t, n).s,
                           joint_name(ps, cur));
        }
    }
    return s;
}

/* "Frames:" or "Frame Time:" followed by its value, possibly glued to the colon. */
static mlr_status read_header_value(parser *ps, const char *label, const char **vt, size_t *vn)
{
    const char *t;
    size_t n;
    int r = next_token(ps, &t, &n);
    if (r < 0)
        return r;
    size_t ln = strlen(label);
    if (r == 0)
        return fail_at(ps, ps->p, "unexpected end of file: expected '%s'", label);
    if (n < ln || !tok_is(t, ln, label))
        return fail_at(ps, t, "expected '%s', found '%s'", label, show(t, n).s);
    if (n > ln) {
        *vt = t + ln;
        *vn = n - ln;
        return MLR_OK;
    }
    skip_blank(ps);
    if (ps->p >= ps->end || is_eol(*ps->p))
        return fail_at(ps, ps->p, "missing value after '%s'", label);
    r = next_token(ps, vt, vn);
    return r < 0 ? r : MLR_OK;
}

/* The values of one frame line into row: returns MLR_OK with ps->p at the end of the line. */
static mlr_status parse_row(parser *ps, size_t f, size_t C, double *row)
{
    const char *p = ps->p, *const end = ps->end;
    for (size_t c = 0; c < C; c++) {
        while (p < end && is_blank(*p))
            p++;
        if (p >= end || is_eol(*p)) {
            ps->p = p;
            return fail_at(ps, p, "frame %zu has %zu values, expected %zu", f + 1, c, C);
        }
        size_t k = mlr_parse_decimal(p, end, row + c);
        if (k == 0 || (p + k < end && !is_blank(p[k]) && !is_eol(p[k]))) {
            const char *e = p;
            while (e < end && !is_blank(*e) && !is_eol(*e))
                e++;
            ps->p = p;
            return fail_at(ps, p, "frame %zu: invalid number '%s'", f + 1,
                           show(p, (size_t)(e - p)).s);
        }
        p += k;
    }
    while (p < end && is_blank(*p))
        p++;
    ps->p = p;
    if (p < end && !is_eol(*p))
        return fail_at(ps, p, "frame %zu has more than %zu values", f + 1, C);
    return MLR_OK;
}

/* Everything the frame loop shares, read-only, between threads. */
typedef struct frames_plan {
    bvh_conv cv;
    bvh_kernels k;
    mlr_motion *m;
    const char *text; /* start of the input: the line kernel reads up to 16 bytes back */
    size_t n_declared; /* the count of Frames: (m may hold fewer frames when lenient) */
} frames_plan;

/* Remember where the frame loop failed (frame f, on the current line) for the lenient tail. */
static void note_fail(parser *ps, size_t f)
{
    ps->fail_frame = f;
    ps->fail_line = ps->line_start;
    ps->fail_line_no = ps->line;
}

/* Frames [f0, f1) from ps->p on, the careful way where the line kernel declines a line (a
 * blank line, an exponent, an error, ...). Returns with ps->p after the last frame's line. */
static mlr_status frames_loop(parser *ps, const frames_plan *pl, const bvh_scratch *s,
                              size_t f0, size_t f1)
{
    const size_t C = pl->cv.C, J = pl->cv.J, P = pl->cv.P, N = pl->n_declared;
    mlr_motion *m = pl->m;
    const bvh_line_fn line = pl->k.line;
    const bvh_frame_fn frame = pl->k.frame;
    for (size_t f = f0; f < f1; f++) {
        const char *le;
        if (line && ps->p - pl->text >= 16 && ps->p < ps->end &&
            line(ps->p, ps->end, C, s->ends, s->row, &le)) {
            ps->p = le;
        } else {
            for (;;) { /* skip blank lines */
                skip_blank(ps);
                if (ps->p < ps->end && is_eol(*ps->p))
                    eat_eol(ps);
                else
                    break;
            }
            if (ps->p >= ps->end) {
                note_fail(ps, f);
                return fail_at(ps, ps->p, "unexpected end of file: %zu of %zu frames", f, N);
            }
            mlr_status st = parse_row(ps, f, C, s->row);
            if (st != MLR_OK) {
                note_fail(ps, f);
                return st;
            }
        }
        if (ps->p < ps->end)
            eat_eol(ps);
        frame(&pl->cv, s->row, s->tmp, m->root_pos + 3 * f, P ? m->trans + 3 * P * f : NULL,
              m->rot + 4 * J * f);
    }
    return MLR_OK;
}

/* frames_loop on copies in this thread's stack frame of the parser, plan and scratch pointers:
 * the loop reads and writes them every frame, and where they sit beside another thread's
 * (the tasks array, the caller's plan) the cache line would travel between the cores each
 * time (measured: 9% of a two-thread parse of lafan1_clip_a went to those loads). */
static mlr_status parse_frames_range(parser *ps, const frames_plan *pl, const bvh_scratch *s,
                                     size_t f0, size_t f1)
{
    parser own = *ps;
    const frames_plan plan = *pl;
    const bvh_scratch scratch = *s;
    const mlr_status st = frames_loop(&own, &plan, &scratch, f0, f1);
    *ps = own;
    return st;
}

/* The MOTION text is cut into chunks (tasks) at line starts; a thread takes the next chunk
 * when it is free, so a thread that starts late or runs slow (a busy machine) holds up no more
 * than a chunk. A chunk's first frame is the number of '\n' before it (a guess that holds when
 * every frame is one line): the task of the chunk before counts its own lines first and
 * publishes the sum, then parses, so no thread counts the whole text. */
typedef struct frames_task {
    _Alignas(128) atomic_size_t first; /* the chunk's first frame + 1; 0 until published */
    const char *start;                 /* the chunk's first line */
    size_t f0;                         /* its first frame, once running */
    parser ps;                         /* the cursor where the task stopped */
    mlr_status status;
} frames_task; /* on its own cache lines: a task spins on first while another writes ps */

typedef struct frames_run {
    const frames_plan *pl;
    const parser *base; /* the caller's parser at the first frame */
    const bvh_scratch *scratch; /* one per thread */
    frames_task *tasks;
    size_t K;
} frames_run;

static void frames_task_run(void *ctx, size_t k, size_t worker)
{
    const frames_run *r = ctx;
    frames_task *tk = &r->tasks[k];
    const size_t N = r->pl->m->n_frames;
    /* the task before publishes early in its run (its thread is running: tasks go out in order) */
    const size_t f0 = mlr_wait_nonzero(&tk->first) - 1;
    size_t f1 = N;
    if (k + 1 < r->K) {
        const size_t n = r->pl->k.count_newlines(tk->start, r->tasks[k + 1].start);
        f1 = n < N - f0 ? f0 + n : N;
        atomic_store_explicit(&r->tasks[k + 1].first, f1 + 1, memory_order_release);
    }
    tk->f0 = f0;
    tk->ps = *r->base;
    if (k > 0) {
        tk->ps.p = tk->ps.line_start = tk->start;
        tk->ps.line = 1;
        tk->ps.diag = NULL;
    }
    tk->status = parse_frames_range(&tk->ps, r->pl, &r->scratch[worker], f0, f1);
}

/* Threads for n_threads == 0: one per 512 KiB of frame text, at most the online processors
 * and 8. */
static size_t auto_threads(size_t bytes)
{
    size_t t = bytes >> 19;
    if (t <= 1)
        return 1; /* small files do not ask for the processor count */
    const size_t cpus = mlr_online_cpus();
    if (t > cpus)
        t = cpus;
    return t > 8 ? 8 : t;
}

/* Bytes of MOTION text per task (a chunk): small enough that a late thread holds up little. */
#define FRAMES_CHUNK ((size_t)128 << 10)

/* The MOTION lines on T threads (see frames_task). Threads write disjoint frames. Afterwards the
 * chunks are chained from the first: a chunk counts only if the one before ended exactly where
 * it starts; from the first that does not (or that failed) on, the frames are parsed again on
 * the calling thread, so the result and the first error (line, reason) are those of a
 * single-threaded parse. */
static mlr_status parse_frames(parser *ps, const frames_plan *pl, const bvh_scratch *scratch,
                               size_t T)
{
    const size_t N = pl->m->n_frames, len = (size_t)(ps->end - ps->p);
    if (T <= 1)
        return parse_frames_range(ps, pl, &scratch[0], 0, N);
    size_t K = len / FRAMES_CHUNK;
    K = K < T ? T : K > 16 * T ? 16 * T : K;
    const size_t bytes = K * sizeof(frames_task) + _Alignof(frames_task);
    unsigned char *block = mlr_alloc(&ps->a, bytes);
    if (!block)
        return MLR_E_NO_MEMORY;
    frames_task *tasks =
        (frames_task *)(void *)(block + (_Alignof(frames_task) -
                                         (uintptr_t)block % _Alignof(frames_task)) %
                                            _Alignof(frames_task));
    tasks[0].start = ps->p;
    size_t used = 1;
    for (size_t k = 1; k < K; k++) {
        const char *from = ps->p + len / K * k;
        const char *nl = memchr(from, '\n', (size_t)(ps->end - from));
        if (!nl || nl + 1 >= ps->end)
            break;
        if (nl + 1 > tasks[used - 1].start)
            tasks[used++].start = nl + 1;
    }
    for (size_t k = 0; k < used; k++)
        atomic_init(&tasks[k].first, k == 0 ? 1 : 0);
    const frames_run r = {pl, ps, scratch, tasks, used};
    mlr_parallel_run_workers(T, used, frames_task_run, (void *)&r);
    mlr_status s = MLR_OK;
    *ps = tasks[0].ps;
    if (tasks[0].status != MLR_OK)
        s = tasks[0].status;
    for (size_t k = 1; k < used && s == MLR_OK; k++) {
        if (ps->p != tasks[k].start || tasks[k].status != MLR_OK) {
            s = parse_frames_range(ps, pl, &scratch[0], tasks[k].f0, N);
            break;
        }
        ps->p = tasks[k].ps.p;
        ps->line_start = tasks[k].ps.line_start;
        ps->line += tasks[k].ps.line - 1;
    }
    mlr_free(&ps->a, block, bytes);
    return s;
}

#define SCRATCH_ALIGN 128

/* n bytes rounded up to a multiple of SCRATCH_ALIGN (n is far below SIZE_MAX here) */
static size_t scratch_round(size_t n)
{
    return (n + SCRATCH_ALIGN - 1) / SCRATCH_ALIGN * SCRATCH_ALIGN;
}

/* The conversion plan and T threads' scratch in one block of *bytes. */
static mlr_status frames_setup(parser *ps, mlr_motion *m, size_t T, frames_plan *pl,
                               bvh_scratch *scratch, unsigned char **block, size_t *bytes)
{
    const size_t C = m->n_channels, J = m->n_joints, P = m->n_trans;
    bvh_conv *cv = &pl->cv;
    /* C, J and P are bounded by the text's length (a joint takes bytes, a channel too) */
    if (C > SIZE_MAX / 64 || J > SIZE_MAX / 64 || P > J || C + 8 + 7 + 3 * P > UINT32_MAX)
        return MLR_E_OVERFLOW;
    cv->C = C;
    cv->J = J;
    cv->Jp = (J + 7) & ~(size_t)7;
    cv->P = P;
    cv->R = (C + 7) & ~(size_t)7;
    const size_t Jp = cv->Jp, n_src = 3 + 3 * P + 3 * Jp + Jp; /* src, then tri */
    const size_t row_n = bvh_frame_row_size(cv), tmp_n = bvh_frame_tmp_size(cv);
    /* per thread: row, tmp, ends (C + 16 pointers), each part on its own 128-byte boundary
     * (two cache lines: the threads write their scratch every frame, and a line shared by two
     * of them would travel between their cores each time); shared: par (Jp doubles), src
     * (uint32), sel (bytes) */
    const size_t row_b = scratch_round(row_n * sizeof(double));
    const size_t tmp_b = scratch_round(tmp_n * sizeof(double));
    const size_t ends_b = scratch_round((C + 16) * sizeof(const char *));
    const size_t per = row_b + tmp_b + ends_b;
    const size_t shared = Jp * sizeof(double) + n_src * sizeof(uint32_t) + 4 * Jp + 64;
    size_t total;
    if (mlr_mul_size(per, T, &total) != MLR_OK || total > SIZE_MAX - shared - SCRATCH_ALIGN)
        return MLR_E_OVERFLOW;
    total += shared + SCRATCH_ALIGN;
    unsigned char *b = mlr_alloc(&ps->a, total);
    if (!b)
        return MLR_E_NO_MEMORY;
    *block = b;
    *bytes = total;
    /* the threads' scratch from the first 128-byte boundary, then par (doubles), src (uint32),
     * bytes */
    unsigned char *sp = b + (SCRATCH_ALIGN - (uintptr_t)b % SCRATCH_ALIGN) % SCRATCH_ALIGN;
    for (size_t t = 0; t < T; t++, sp += per) {
        scratch[t].row = (double *)(void *)sp;
        scratch[t].tmp = (double *)(void *)(sp + row_b);
        scratch[t].ends = (const char **)(void *)(sp + row_b + tmp_b);
    }
    double *par = (double *)(void *)sp;
    uint32_t *src = (uint32_t *)(void *)(par + Jp);
    uint32_t *tri = src + n_src - Jp;
    unsigned char *sel = (unsigned char *)(src + n_src), *tri_ok = sel + 3 * Jp;
    cv->src = src;
    cv->tri = tri;
    cv->tri_ok = tri_ok;
    cv->sel = sel;
    cv->par = par;

    /* constants of the row: zeros at R, then the root's OFFSET and each translated joint's */
    const size_t R = cv->R;
    double *row0 = scratch[0].row;
    memset(row0, 0, row_n * sizeof(double));
    memcpy(row0 + R + 4, m->offsets, 3 * sizeof(double));
    for (size_t k = 0; k < P; k++)
        memcpy(row0 + R + 7 + 3 * k, m->offsets + 3 * (size_t)m->trans_joints[k],
               3 * sizeof(double));
    for (size_t t = 1; t < T; t++)
        memcpy(scratch[t].row, row0, row_n * sizeof(double));
    for (size_t k = 0; k < 3; k++)
        src[k] = (uint32_t)(R + 4 + k);
    for (size_t k = 0; k < 3 * P; k++)
        src[3 + k] = (uint32_t)(R + 7 + k);
    uint32_t *g = src + 3 + 3 * P;
    for (size_t k = 0; k < 3 * Jp; k++)
        g[k] = (uint32_t)R;
    memset(sel, 0, 3 * Jp);
    for (size_t j = J; j < Jp; j++) {
        par[j] = 1.0;
        tri[j] = (uint32_t)R;
    }
    memset(tri_ok, 1, Jp / 8);
    size_t c = 0;
    for (size_t j = 0; j < J; j++) {
        const unsigned char *ch = m->ch + BVH_MAX_CHANNELS * j;
        for (size_t k = 0; k < m->n_ch[j]; k++, c++) {
            if (ch[k] < 3 && j == 0)
                src[ch[k]] = (uint32_t)c;
            else if (ch[k] < 3)
                src[3 + 3 * (size_t)m->trans_slot[j] + ch[k]] = (uint32_t)c;
            else
                g[m->rot_idx[3 * j + ch[k] - 3] * Jp + j] = (uint32_t)c;
        }
        if (g[j] + 1 == g[Jp + j] && g[j] + 2 == g[2 * Jp + j] && g[j] < C)
            tri[j] = g[j];
        else
            tri_ok[j / 8] = 0;
        const unsigned o = m->order[j];
        par[j] = mlr_euler_parity[o];
        for (size_t k = 0; k < 3; k++)
            sel[mlr_euler_axes[o][k] * Jp + j] = (unsigned char)k;
    }
    return MLR_OK;
}

static mlr_status build_motion(parser *ps, size_t n_frames, double frame_time,
                               mlr_motion **out)
{
    const size_t J = ps->joints.len, E = ps->ends.len;
    tjoint *tj = (tjoint *)ps->joints.data;
    size_t P = 0, C = 0;
    for (size_t j = 0; j < J; j++) {
        C += tj[j].n_ch;
        if (j > 0)
            for (size_t k = 0; k < tj[j].n_ch; k++)
                if (tj[j].ch[k] < 3) {
                    P++;
                    break;
                }
    }
    mlr_motion *m;
    mlr_status s = bvh_motion_alloc(&ps->a, J, E, ps->names.len, n_frames, P, &m);
    if (s != MLR_OK)
        return s;
    m->frame_time = frame_time;
    m->n_channels = C;
    memcpy(m->name_buf, ps->names.data, ps->names.len);
    size_t p = 0, end_next = 0;
    for (size_t j = 0; j < J; j++) {
        m->names[j] = m->name_buf + tj[j].name_off;
        m->parents[j] = tj[j].parent;
        memcpy(m->offsets + 3 * j, tj[j].offset, 3 * sizeof(double));
        m->n_ch[j] = tj[j].n_ch;
        memcpy(m->ch + BVH_MAX_CHANNELS * j, tj[j].ch, BVH_MAX_CHANNELS);
        size_t n_pos = bvh_layout_finish(m, j);
        m->trans_slot[j] = -1;
        if (j > 0 && n_pos > 0) {
            m->trans_slot[j] = (int32_t)p;
            m->trans_joints[p++] = (int32_t)j;
        }
        tj[j].end_next = end_next; /* End Sites sorted by joint, stable */
        end_next += tj[j].n_end;
    }
    const tend *te = (const tend *)ps->ends.data;
    for (size_t e = 0; e < E; e++) {
        size_t k = tj[te[e].parent].end_next++;
        m->end_parents[k] = te[e].parent;
        memcpy(m->end_offsets + 3 * k, te[e].offset, 3 * sizeof(double));
    }
    *out = m;
    return MLR_OK;
}

/* ---- lenient reading: what follows the declared frames ------------------------------------ */

static void warn_add(parser *ps, int code, size_t line, size_t column, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 5, 6)))
#endif
    ;

static void warn_add(parser *ps, int code, size_t line, size_t column, const char *fmt, ...)
{
    mlr_bvh_warnings *w = ps->warn;
    if (!w)
        return;
    if (w->count < MLR_BVH_WARNINGS_KEPT) {
        mlr_bvh_warning *x = &w->first[w->count];
        va_list ap;
        va_start(ap, fmt);
        x->code = code;
        x->line = line;
        x->column = column;
        vsnprintf(x->message, sizeof x->message, fmt, ap);
        va_end(ap);
    }
    w->count++;
}

/* Only whitespace and NUL bytes in [p, end). */
static int rest_is_blank(const char *p, const char *end)
{
    for (; p < end; p++)
        if (!is_blank(*p) && !is_eol(*p) && *p != '\0')
            return 0;
    return 1;
}

/* The text's last byte other than blanks and NULs is a line end. */
static int ends_with_eol(const char *begin, const char *end)
{
    while (end > begin && (is_blank(end[-1]) || end[-1] == '\0'))
        end--;
    return end > begin && is_eol(end[-1]);
}

static const char *line_end(const char *p, const char *end)
{
    while (p < end && !is_eol(*p))
        p++;
    return p;
}

/* The line at p starts (after blanks) with a whole number token. */
static int starts_with_number(const char *p, const char *end)
{
    while (p < end && is_blank(*p))
        p++;
    double v;
    size_t k = mlr_parse_decimal(p, end, &v);
    return k > 0 && (p + k == end || is_blank(p[k]) || is_eol(p[k]));
}

/* Complete frame lines of C values from ps->p on (blank lines between them skipped), parsed
 * into row and dropped: their number, the line of the first, and where the first line that is
 * not one starts (or end). ps is not moved. */
static size_t count_frame_lines(const parser *ps, size_t C, double *row, size_t *first_line,
                                const char **stop, size_t *stop_line)
{
    parser q = *ps;
    q.diag = NULL;
    size_t X = 0;
    *first_line = 0;
    for (;;) {
        for (;;) {
            skip_blank(&q);
            if (q.p < q.end && is_eol(*q.p))
                eat_eol(&q);
            else
                break;
        }
        if (q.p >= q.end) {
            *stop = q.end;
            break;
        }
        const size_t line = q.line;
        if (parse_row(&q, X, C, row) != MLR_OK) {
            *stop = q.line_start;
            break;
        }
        if (X++ == 0)
            *first_line = line;
        if (q.p < q.end)
            eat_eol(&q);
    }
    *stop_line = q.line;
    return X;
}

/* Read X more frame lines from ps->p into a motion of n_frames + X frames that replaces *mp. */
static mlr_status read_extra_frames(parser *ps, frames_plan *pl, const bvh_scratch *scr,
                                    mlr_motion **mp, size_t X)
{
    mlr_motion *m = *mp, *g;
    const size_t F = m->n_frames, J = m->n_joints, P = m->n_trans;
    mlr_status s = build_motion(ps, F + X, m->frame_time, &g);
    if (s != MLR_OK)
        return s;
    if (F > 0) {
        memcpy(g->root_pos, m->root_pos, 3 * F * sizeof(double));
        memcpy(g->rot, m->rot, 4 * J * F * sizeof(double));
        if (P)
            memcpy(g->trans, m->trans, 3 * P * F * sizeof(double));
    }
    pl->m = g;
    s = frames_loop(ps, pl, scr, F, F + X); /* the lines were checked: cannot fail */
    pl->m = m;
    if (s != MLR_OK) {
        mlr_motion_destroy(g);
        return s;
    }
    mlr_motion_destroy(m);
    *mp = g;
    return MLR_OK;
}

/* The lenient end of the MOTION section (mlr_bvh.h), after the frame loop returned s: extra
 * frame lines, a few missing ones, trailing data, a missing final line end, a truncated file.
 * On MLR_OK *mp may be a new motion (of the frames read) and ps->p is at the end. */
static mlr_status lenient_tail(parser *ps, frames_plan *pl, const bvh_scratch *scr,
                               mlr_motion **mp, mlr_status s)
{
    mlr_motion *m = *mp;
    const size_t declared = pl->n_declared, C = pl->cv.C;
    const int eol_at_end = ends_with_eol(ps->begin, ps->end);
    if (s == MLR_OK && m->n_frames == declared) {
        size_t X = 0, first_line = 0, stop_line;
        const char *stop = ps->end;
        if (C > 0)
            X = count_frame_lines(ps, C, scr->row, &first_line, &stop, &stop_line);
        if (X > 0) {
            if ((s = read_extra_frames(ps, pl, scr, mp, X)) != MLR_OK)
                return s;
            warn_add(ps, MLR_BVH_WARN_EXTRA_FRAMES, first_line, 0,
                     "%zu frame lines, but Frames: declares %zu; all %zu are read",
                     declared + X, declared, declared + X);
        }
        parser q = *ps;
        skip_ws(&q);
        if (!rest_is_blank(q.p, q.end)) {
            const char *e = line_end(q.p, q.end);
            warn_add(ps, MLR_BVH_WARN_TRAILING_DATA, q.line, (size_t)(q.p - q.line_start) + 1,
                     "data after the last frame ('%s'), ignored from here on",
                     show(q.p, (size_t)(e - q.p)).s);
        } else if ((*mp)->n_frames > 0 && !eol_at_end) {
            warn_add(ps, MLR_BVH_WARN_NO_FINAL_NEWLINE, ps->line, 0,
                     "no line end after the last frame line (was the file cut short?)");
        }
        ps->p = ps->end;
        return MLR_OK;
    }
    size_t F;
    const char *bad;
    size_t bad_line;
    if (s == MLR_OK) { /* fewer frames fitted than declared (Frames: beyond the bytes): the
                        * next line, too short for a frame, gives the reason */
        F = m->n_frames;
        parser q = *ps;
        for (;;) {
            skip_blank(&q);
            if (q.p < q.end && is_eol(*q.p))
                eat_eol(&q);
            else
                break;
        }
        if (q.p >= q.end || (s = parse_row(&q, F, C, scr->row)) == MLR_OK)
            s = fail_at(&q, q.p, "unexpected end of file: %zu of %zu frames", F, declared);
        bad = q.line_start;
        bad_line = q.line;
    } else if (s == MLR_E_PARSE) {
        F = ps->fail_frame;
        bad = ps->fail_line;
        bad_line = ps->fail_line_no;
    } else {
        return s;
    }
    const size_t missing = declared - F;
    const char *junk = NULL;
    int truncated;
    if (rest_is_blank(bad, ps->end)) {
        truncated = missing > MLR_BVH_MAX_MISSING_FRAMES || !eol_at_end;
    } else if (starts_with_number(bad, ps->end)) {
        if (!rest_is_blank(line_end(bad, ps->end), ps->end))
            return s; /* a malformed frame line with more after it */
        truncated = 1; /* the last line is incomplete */
    } else {
        junk = bad;
        truncated = missing > MLR_BVH_MAX_MISSING_FRAMES;
    }
    mlr_diag *d = ps->diag; /* the reader always gives one (bvh_read) */
    if (truncated && !ps->keep_truncated) {
        const size_t n = strlen(d->message);
        snprintf(d->message + n, sizeof d->message - n, " (truncated file: %zu of %zu frames)",
                 F, declared);
        return s;
    }
    mlr_motion *g;
    if ((s = mlr_motion_copy_frames(m, 0, F, &g, NULL)) != MLR_OK)
        return s;
    mlr_motion_destroy(m);
    *mp = g;
    if (truncated)
        warn_add(ps, MLR_BVH_WARN_TRUNCATED, d->line, d->column,
                 "truncated file: kept the %zu complete frames of %zu (%s)", F, declared,
                 d->message);
    else
        warn_add(ps, MLR_BVH_WARN_MISSING_FRAMES, bad_line, 0,
                 "Frames: declares %zu, but the file has %zu frame lines; they are read",
                 declared, F);
    if (junk) {
        const char *t = junk;
        while (t < ps->end && is_blank(*t))
            t++;
        warn_add(ps, MLR_BVH_WARN_TRAILING_DATA, bad_line, (size_t)(t - junk) + 1,
                 "data after the last frame ('%s'), ignored from here on",
                 show(t, (size_t)(line_end(t, ps->end) - t)).s);
    }
    d->line = d->column = 0;
    d->message[0] = '\0';
    ps->p = ps->end;
    return MLR_OK;
}

static mlr_status parse(parser *ps, size_t n_threads, int kernels, mlr_motion **out)
{
    mlr_status s = parse_hierarchy(ps);
    if (s != MLR_OK)
        return s;

    const char *t;
    size_t n;
    int r = next_token(ps, &t, &n);
    if (r < 0)
        return r;
    if (r == 0)
        return fail_at(ps, ps->p, "unexpected end of file: expected MOTION");
    if (tok_is(t, n, "ROOT"))
        return fail_at(ps, t, "more than one ROOT: not supported");
    if (!tok_is(t, n, "MOTION"))
        return fail_at(ps, t, "expected MOTION after the hierarchy, found '%s'", show(t, n).s);

    const char *vt;
    size_t vn;
    if ((s = read_header_value(ps, "Frames:", &vt, &vn)) != MLR_OK)
        return s;
    size_t frames_line = ps->line;
    size_t n_frames = 0;
    for (size_t i = 0; i < vn; i++) {
        if (vt[i] < '0' || vt[i] > '9')
            return fail_at(ps, vt, "Frames: needs a whole number, found '%s'", show(vt, vn).s);
        unsigned d = (unsigned)(vt[i] - '0');
        if (n_frames > (SIZE_MAX - d) / 10)
            return fail_at(ps, vt, "Frames: %s is out of range", show(vt, vn).s);
        n_frames = n_frames * 10 + d;
    }
    if ((s = expect(ps, "Frame", "after Frames:")) != MLR_OK)
        return s;
    if ((s = read_header_value(ps, "Time:", &vt, &vn)) != MLR_OK)
        return s;
    double frame_time;
    if (mlr_parse_decimal(vt, vt + vn, &frame_time) != vn)
        return fail_at(ps, vt, "Frame Time: needs a number, found '%s'", show(vt, vn).s);
    if (!(frame_time > 0.0))
        return fail_at(ps, vt, "Frame Time: must be positive");
    skip_blank(ps);
    if (ps->p < ps->end && !is_eol(*ps->p))
        return fail_at(ps, ps->p, "unexpected data after Frame Time:");
    if (ps->p < ps->end)
        eat_eol(ps);

    /* Every value takes a byte and a separator: bound N by what is left. */
    size_t C = 0, J = ps->joints.len;
    for (size_t j = 0; j < J; j++)
        C += ((tjoint *)ps->joints.data)[j].n_ch;
    size_t left = (size_t)(ps->end - ps->p);
    if (n_frames > 0 && C == 0) {
        ps->line = frames_line;
        return fail_at(ps, NULL, "Frames: %zu, but the hierarchy declares no channels",
                       n_frames);
    }
    size_t n_alloc = n_frames; /* frames to allocate: fewer when lenient and they cannot fit */
    if (n_frames > 0) {
        /* N frames of C values take at least 2 N C - 1 bytes */
        size_t per = 2 * C, most = left / per + (left % per == per - 1);
        if (n_frames > most && ps->strict) {
            ps->line = frames_line;
            return fail_at(ps, NULL,
                           "Frames: %zu, but the %zu bytes that follow hold at most %zu frames "
                           "of %zu values", n_frames, left, most, C);
        }
        if (n_frames > most)
            n_alloc = most;
    }

    mlr_motion *m;
    if ((s = build_motion(ps, n_alloc, frame_time, &m)) != MLR_OK)
        return s;
    if (n_alloc > 0 || (!ps->strict && C > 0)) {
        size_t T = n_threads ? n_threads : auto_threads(left);
        if (T > BVH_MAX_THREADS)
            T = BVH_MAX_THREADS;
        if (T > n_alloc)
            T = n_alloc;
        if (T == 0)
            T = 1;
        frames_plan pl;
        bvh_scratch scratch[BVH_MAX_THREADS];
        unsigned char *block = NULL;
        size_t bytes = 0;
        s = frames_setup(ps, m, T, &pl, scratch, &block, &bytes);
        if (s == MLR_OK) {
            bvh_kernels_pick(&pl.k, kernels);
            pl.m = m;
            pl.text = ps->begin;
            pl.n_declared = n_frames;
            if (n_alloc > 0)
                s = parse_frames(ps, &pl, scratch, T);
            if (!ps->strict)
                s = lenient_tail(ps, &pl, scratch, &m, s);
            mlr_free(&ps->a, block, bytes);
        }
        if (s != MLR_OK) {
            mlr_motion_destroy(m);
            return s;
        }
    }
    /* only whitespace (and NUL padding) may follow */
    skip_ws(ps);
    if (ps->p < ps->end) {
        const char *t = ps->p;
        while (t < ps->end && *t == '\0')
            t++;
        if (t < ps->end) {
            mlr_motion_destroy(m);
            return fail_at(ps, ps->p, "data after the %zu frames declared by Frames:", n_frames);
        }
    }
    if (ps->strict && n_frames > 0 && !ends_with_eol(ps->begin, ps->end))
        warn_add(ps, MLR_BVH_WARN_NO_FINAL_NEWLINE, ps->line, 0,
                 "no line end after the last frame line (was the file cut short?)");
    *out = m;
    return MLR_OK;
}

/* How a read treats deviations (mlr_bvh_read_option). */
typedef struct read_mode {
    int strict, keep_truncated;
} read_mode;

static const read_mode strict_mode = {1, 0};

/* The reader of every entry point. diag_user and warnings optional. */
static mlr_status bvh_read(const char *text, size_t len, size_t n_threads, int kernels,
                           const read_mode *mode, const mlr_allocator *alloc, mlr_motion **out,
                           mlr_bvh_warnings *warnings, mlr_diag *diag_user)
{
    /* the lenient tail reads the reason of a frame error back: always keep one */
    mlr_diag local, *diag = diag_user ? diag_user : &local;
    if (warnings)
        warnings->count = 0;
    if (!out)
        return mlr_diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "out is NULL");
    *out = NULL;
    if (!text && len)
        return mlr_diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "text is NULL");
    if (diag) {
        diag->line = diag->column = 0;
        diag->message[0] = '\0';
    }
    parser ps;
    memset(&ps, 0, sizeof ps);
    mlr_allocator_resolve(alloc, &ps.a);
    ps.begin = ps.p = text ? text : "";
    ps.end = ps.p + len;
    ps.line_start = ps.p;
    ps.line = 1;
    ps.diag = diag;
    ps.strict = mode->strict;
    ps.keep_truncated = mode->keep_truncated;
    ps.warn = warnings;
    ps.joints.elsize = sizeof(tjoint);
    ps.ends.elsize = sizeof(tend);
    ps.names.elsize = 1;
    if (len >= 3 && (unsigned char)ps.p[0] == 0xEF && (unsigned char)ps.p[1] == 0xBB &&
        (unsigned char)ps.p[2] == 0xBF)
        ps.p += 3;
    mlr_status s = parse(&ps, n_threads, kernels, out);
    vec_free(&ps.joints, &ps.a);
    vec_free(&ps.ends, &ps.a);
    vec_free(&ps.names, &ps.a);
    if (s == MLR_E_NO_MEMORY || s == MLR_E_OVERFLOW)
        mlr_diag_set(diag, s, 0, 0, "%s", mlr_status_string(s));
    if (s != MLR_OK && warnings)
        warnings->count = 0;
    return s;
}

mlr_status bvh_read_memory_ex(const char *text, size_t len, size_t n_threads, int kernels,
                              const mlr_allocator *alloc, mlr_motion **out, mlr_diag *diag)
{
    return bvh_read(text, len, n_threads, kernels, &strict_mode, alloc, out, NULL, diag);
}

/* The options of a lenient read into mode; out and warnings cleared first (the outputs of a
 * failed call). */
static const mlr_opt_spec bvh_read_opts[] = {
    {MLR_BVH_OPT_STRICT, "strict", MLR_OPT_BOOL, 0.0, 1.0, 0, 0, 0.0, NULL},
    {MLR_BVH_OPT_KEEP_TRUNCATED, "keep_truncated", MLR_OPT_BOOL, 0.0, 1.0, 0, 0, 0.0, NULL},
};

static mlr_status read_options(const mlr_bvh_read_option *opts, size_t n_opts, read_mode *mode,
                               mlr_motion **out, mlr_bvh_warnings *warnings, mlr_diag *diag)
{
    if (warnings)
        warnings->count = 0;
    if (out)
        *out = NULL;
    mlr_opt_values o;
    mlr_status st = MLR_OPTIONS_READ("bvh read", bvh_read_opts, opts, n_opts, &o, diag);
    mode->strict = o.v[MLR_BVH_OPT_STRICT] != 0.0;
    mode->keep_truncated = !mode->strict && o.v[MLR_BVH_OPT_KEEP_TRUNCATED] != 0.0;
    return st;
}

mlr_status mlr_bvh_read_memory_opts(const char *text, size_t len, size_t n_threads,
                                    const mlr_bvh_read_option *opts, size_t n_opts,
                                    const mlr_allocator *alloc, mlr_motion **out,
                                    mlr_bvh_warnings *warnings, mlr_diag *diag)
{
    read_mode mode;
    mlr_status s = read_options(opts, n_opts, &mode, out, warnings, diag);
    if (s != MLR_OK)
        return s;
    return bvh_read(text, len, n_threads, BVH_KERNELS_BEST, &mode, alloc, out, warnings, diag);
}

mlr_status mlr_bvh_read_memory(const char *text, size_t len, const mlr_allocator *alloc,
                               mlr_motion **out, mlr_diag *diag)
{
    return bvh_read_memory_ex(text, len, 1, BVH_KERNELS_BEST, alloc, out, diag);
}

mlr_status mlr_bvh_read_memory_mt(const char *text, size_t len, size_t n_threads,
                                  const mlr_allocator *alloc, mlr_motion **out, mlr_diag *diag)
{
    return bvh_read_memory_ex(text, len, n_threads, BVH_KERNELS_BEST, alloc, out, diag);
}

/* ---- files ------------------------------------------------------------------------------- */

/* mlr_bvh_read_file_mt and mlr_bvh_read_file_opts. */
static mlr_status read_file(const char *path, size_t n_threads, const read_mode *mode,
                            const mlr_allocator *alloc, mlr_motion **out,
                            mlr_bvh_warnings *warnings, mlr_diag *diag)
{
    if (warnings)
        warnings->count = 0;
    if (!out)
        return mlr_diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "out is NULL");
    *out = NULL;
    if (!path)
        return mlr_diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "path is NULL");
    mlr_allocator a;
    mlr_allocator_resolve(alloc, &a);
    char *buf;
    size_t len, cap;
    /* a large file is read in parallel chunks (n_threads permitting), then parsed */
    mlr_status s = mlr_read_file(path, n_threads, &a, &buf, &len, &cap, diag);
    if (s != MLR_OK)
        return s;
    s = bvh_read(buf, len, n_threads, BVH_KERNELS_BEST, mode, &a, out, warnings, diag);
    mlr_free(&a, buf, cap);
    return s;
}

mlr_status mlr_bvh_read_file_mt(const char *path, size_t n_threads, const mlr_allocator *alloc,
                                mlr_motion **out, mlr_diag *diag)
{
    return read_file(path, n_threads, &strict_mode, alloc, out, NULL, diag);
}

mlr_status mlr_bvh_read_file_opts(const char *path, size_t n_threads,
                                  const mlr_bvh_read_option *opts, size_t n_opts,
                                  const mlr_allocator *alloc, mlr_motion **out,
                                  mlr_bvh_warnings *warnings, mlr_diag *diag)
{
    read_mode mode;
    mlr_status s = read_options(opts, n_opts, &mode, out, warnings, diag);
    if (s != MLR_OK)
        return s;
    return read_file(path, n_threads, &mode, alloc, out, warnings, diag);
}

mlr_status mlr_bvh_read_file(const char *path, const mlr_allocator *alloc, mlr_motion **out,
                             mlr_diag *diag)
{
    return mlr_bvh_read_file_mt(path, 1, alloc, out, diag);
}
