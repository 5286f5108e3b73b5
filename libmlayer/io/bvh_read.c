/* BVH reader: a single pass over the text, no recursion, every count checked against the
 * bytes that remain before anything is allocated from it. Errors carry line, column and reason.
 * Nothing here prints or keeps state. */
#include "io/bvh_read_internal.h"
#include "io/file_read_internal.h"
#include "io/numparse.h"
#include "common/options_internal.h"

/* "MOTION", "Frames: N" and "Frame Time: T" up to the end of their line; *frames_line is the
 * line of Frames:. */
static mlr_status parse_motion_header(parser *ps, size_t *n_frames_out, double *frame_time_out,
                                      size_t *frames_line)
{
    const char *t;
    size_t n;
    mlr_status s = bvh__need_token(ps, &t, &n, "unexpected end of file: expected MOTION");
    if (s != MLR_OK)
        return s;
    if (bvh__tok_is(t, n, "ROOT"))
        return bvh__fail_at(ps, t, "more than one ROOT: not supported");
    if (!bvh__tok_is(t, n, "MOTION"))
        return bvh__fail_at(ps, t, "expected MOTION after the hierarchy, found '%s'",
                            bvh__show(t, n).s);

    const char *vt;
    size_t vn;
    if ((s = bvh__read_header_value(ps, "Frames:", &vt, &vn)) != MLR_OK)
        return s;
    *frames_line = ps->line;
    size_t n_frames = 0;
    for (size_t i = 0; i < vn; i++) {
        if (vt[i] < '0' || vt[i] > '9')
            return bvh__fail_at(ps, vt, "Frames: needs a whole number, found '%s'",
                                bvh__show(vt, vn).s);
        unsigned d = (unsigned)(vt[i] - '0');
        if (n_frames > (SIZE_MAX - d) / 10)
            return bvh__fail_at(ps, vt, "Frames: %s is out of range", bvh__show(vt, vn).s);
        n_frames = n_frames * 10 + d;
    }
    if ((s = bvh__expect(ps, "Frame", "after Frames:")) != MLR_OK)
        return s;
    if ((s = bvh__read_header_value(ps, "Time:", &vt, &vn)) != MLR_OK)
        return s;
    double frame_time;
    if (mlr_parse_decimal(vt, vt + vn, &frame_time) != vn)
        return bvh__fail_at(ps, vt, "Frame Time: needs a number, found '%s'", bvh__show(vt, vn).s);
    if (!(frame_time > 0.0))
        return bvh__fail_at(ps, vt, "Frame Time: must be positive");
    skip_blank(ps);
    if (ps->p < ps->end && !is_eol(*ps->p))
        return bvh__fail_at(ps, ps->p, "unexpected data after Frame Time:");
    if (ps->p < ps->end)
        eat_eol(ps);
    *n_frames_out = n_frames;
    *frame_time_out = frame_time;
    return MLR_OK;
}

/* The frames to allocate for the n_frames that Frames: declares, bounded by the bytes left
 * (every value takes a byte and a separator): fewer when lenient and they cannot fit, an error
 * when strict. *C gets the channel count. */
static mlr_status frames_to_allocate(parser *ps, size_t n_frames, size_t frames_line,
                                     size_t *C_out, size_t *n_alloc)
{
    size_t C = 0, J = ps->joints.len;
    for (size_t j = 0; j < J; j++)
        C += ((tjoint *)ps->joints.data)[j].n_ch;
    *C_out = C;
    size_t left = (size_t)(ps->end - ps->p);
    if (n_frames > 0 && C == 0) {
        ps->line = frames_line;
        return bvh__fail_at(ps, NULL, "Frames: %zu, but the hierarchy declares no channels",
                            n_frames);
    }
    *n_alloc = n_frames;
    if (n_frames > 0) {
        /* N frames of C values take at least 2 N C - 1 bytes */
        size_t per = 2 * C, most = left / per + (left % per == per - 1);
        if (n_frames > most && ps->strict) {
            ps->line = frames_line;
            return bvh__fail_at(ps, NULL,
                                "Frames: %zu, but the %zu bytes that follow hold at most %zu "
                                "frames of %zu values",
                                n_frames, left, most, C);
        }
        if (n_frames > most)
            *n_alloc = most;
    }
    return MLR_OK;
}

/* The frame lines into *mp (n_alloc frames allocated of the n_frames declared) on up to
 * n_threads threads (0: by the size), then, when lenient, what follows them (*mp may then be
 * replaced). */
static mlr_status read_frames(parser *ps, size_t n_threads, int kernels, size_t n_frames,
                              size_t n_alloc, mlr_motion **mp)
{
    size_t T = n_threads ? n_threads : bvh__auto_threads((size_t)(ps->end - ps->p));
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
    mlr_status s = bvh__frames_setup(ps, *mp, T, &pl, scratch, &block, &bytes);
    if (s != MLR_OK)
        return s;
    bvh_kernels_pick(&pl.k, kernels);
    pl.m = *mp;
    pl.text = ps->begin;
    pl.n_declared = n_frames;
    if (n_alloc > 0)
        s = bvh__parse_frames(ps, &pl, scratch, T);
    if (!ps->strict)
        s = bvh__lenient_tail(ps, &pl, scratch, mp, s);
    common__free(&ps->a, block, bytes);
    return s;
}

/* Only whitespace (and NUL padding) may follow the frames; a strict read warns when the last
 * frame line has no line end. */
static mlr_status check_end(parser *ps, size_t n_frames)
{
    skip_ws(ps);
    if (ps->p < ps->end) {
        const char *t = ps->p;
        while (t < ps->end && *t == '\0')
            t++;
        if (t < ps->end)
            return bvh__fail_at(ps, ps->p,
                                "data after the %zu frames declared by Frames:", n_frames);
    }
    if (ps->strict && n_frames > 0 && !bvh__ends_with_eol(ps->begin, ps->end))
        bvh__warn_add(ps, MLR_BVH_WARN_NO_FINAL_NEWLINE, ps->line, 0,
                      "no line end after the last frame line (was the file cut short?)");
    return MLR_OK;
}

/* The whole text: hierarchy, MOTION header, frames, end. */
static mlr_status parse(parser *ps, size_t n_threads, int kernels, mlr_motion **out)
{
    size_t n_frames = 0, frames_line = 0, C = 0, n_alloc = 0;
    double frame_time = 0.0;
    mlr_status s = bvh__parse_hierarchy(ps);
    if (s == MLR_OK)
        s = parse_motion_header(ps, &n_frames, &frame_time, &frames_line);
    if (s == MLR_OK)
        s = frames_to_allocate(ps, n_frames, frames_line, &C, &n_alloc);
    if (s != MLR_OK)
        return s;
    mlr_motion *m;
    if ((s = bvh__build_motion(ps, n_alloc, frame_time, &m)) != MLR_OK)
        return s;
    if (n_alloc > 0 || (!ps->strict && C > 0))
        s = read_frames(ps, n_threads, kernels, n_frames, n_alloc, &m);
    if (s == MLR_OK)
        s = check_end(ps, n_frames);
    if (s != MLR_OK) {
        mlr_motion_destroy(m);
        return s;
    }
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
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "out is NULL");
    *out = NULL;
    if (!text && len)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "text is NULL");
    if (diag) {
        diag->line = diag->column = 0;
        diag->message[0] = '\0';
    }
    parser ps;
    memset(&ps, 0, sizeof ps);
    common__allocator_resolve(alloc, &ps.a);
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
    bvh__vec_free(&ps.joints, &ps.a);
    bvh__vec_free(&ps.ends, &ps.a);
    bvh__vec_free(&ps.names, &ps.a);
    if (s == MLR_E_NO_MEMORY || s == MLR_E_OVERFLOW)
        common__diag_set(diag, s, 0, 0, "bvh read: %s", mlr_status_string(s));
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
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "out is NULL");
    *out = NULL;
    if (!path)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "path is NULL");
    mlr_allocator a;
    common__allocator_resolve(alloc, &a);
    char *buf;
    size_t len, cap;
    /* a large file is read in parallel chunks (n_threads permitting), then parsed */
    mlr_status s = file_read__read(path, n_threads, &a, &buf, &len, &cap, diag);
    if (s == MLR_E_NO_MEMORY || s == MLR_E_OVERFLOW)
        return common__diag_prefix(diag, s, "bvh read");
    if (s != MLR_OK)
        return s;
    s = bvh_read(buf, len, n_threads, BVH_KERNELS_BEST, mode, &a, out, warnings, diag);
    common__free(&a, buf, cap);
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
