/* BVH reader, the lenient end of the MOTION section: extra or missing frame lines, trailing
 * data, a missing final line end, a truncated file (mlr_bvh_read_memory_opts). Nothing here
 * prints or keeps state. */
#include "io/bvh_read_internal.h"
#include "io/numparse.h"

#include <stdarg.h>
#include <stdio.h>

/* ---- lenient reading: what follows the declared frames ------------------------------------ */

void bvh__warn_add(parser *ps, int code, size_t line, size_t column, const char *fmt, ...)
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
int bvh__ends_with_eol(const char *begin, const char *end)
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
        skip_blank_lines(&q);
        if (q.p >= q.end) {
            *stop = q.end;
            break;
        }
        const size_t line = q.line;
        if (bvh__parse_row(&q, X, C, row) != MLR_OK) {
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
    mlr_status s = bvh__build_motion(ps, F + X, m->frame_time, &g);
    if (s != MLR_OK)
        return s;
    if (F > 0) {
        memcpy(g->root_pos, m->root_pos, 3 * F * sizeof(double));
        memcpy(g->rot, m->rot, 4 * J * F * sizeof(double));
        if (P)
            memcpy(g->trans, m->trans, 3 * P * F * sizeof(double));
    }
    pl->m = g;
    s = bvh__frames_loop(ps, pl, scr, F, F + X); /* the lines were checked: cannot fail */
    pl->m = m;
    if (s != MLR_OK) {
        mlr_motion_destroy(g);
        return s;
    }
    mlr_motion_destroy(m);
    *mp = g;
    return MLR_OK;
}

/* Every declared frame was read: more frame lines (read too), then data after them or a missing
 * final line end (warnings). ps->p ends at the end. */
static mlr_status after_all_frames(parser *ps, frames_plan *pl, const bvh_scratch *scr,
                                   mlr_motion **mp, int eol_at_end)
{
    const size_t declared = pl->n_declared, C = pl->cv.C;
    size_t X = 0, first_line = 0, stop_line;
    const char *stop = ps->end;
    mlr_status s;
    if (C > 0)
        X = count_frame_lines(ps, C, scr->row, &first_line, &stop, &stop_line);
    if (X > 0) {
        if ((s = read_extra_frames(ps, pl, scr, mp, X)) != MLR_OK)
            return s;
        bvh__warn_add(ps, MLR_BVH_WARN_EXTRA_FRAMES, first_line, 0,
                      "%zu frame lines, but Frames: declares %zu; all %zu are read", declared + X,
                      declared, declared + X);
    }
    parser q = *ps;
    skip_ws(&q);
    if (!rest_is_blank(q.p, q.end)) {
        const char *e = line_end(q.p, q.end);
        bvh__warn_add(ps, MLR_BVH_WARN_TRAILING_DATA, q.line, (size_t)(q.p - q.line_start) + 1,
                      "data after the last frame ('%s'), ignored from here on",
                      bvh__show(q.p, (size_t)(e - q.p)).s);
    } else if ((*mp)->n_frames > 0 && !eol_at_end) {
        bvh__warn_add(ps, MLR_BVH_WARN_NO_FINAL_NEWLINE, ps->line, 0,
                      "no line end after the last frame line (was the file cut short?)");
    }
    ps->p = ps->end;
    return MLR_OK;
}

/* Where the frames stopped short of the declared count, after the frame loop returned s: *F
 * frames read, the line that ended them (*bad, number *bad_line). Returns the error that line
 * gives (s itself, or for a loop that ended early because the frames could not fit, the error
 * of parsing the next line), or s unchanged when it is not a parse error. */
static mlr_status where_frames_stop(parser *ps, const frames_plan *pl, const bvh_scratch *scr,
                                    mlr_status s, size_t *F, const char **bad, size_t *bad_line)
{
    if (s == MLR_OK) { /* fewer frames fitted than declared (Frames: beyond the bytes): the
                        * next line, too short for a frame, gives the reason */
        *F = pl->m->n_frames;
        parser q = *ps;
        skip_blank_lines(&q);
        if (q.p >= q.end || (s = bvh__parse_row(&q, *F, pl->cv.C, scr->row)) == MLR_OK)
            s = bvh__fail_at(&q, q.p, "unexpected end of file: %zu of %zu frames", *F,
                             pl->n_declared);
        *bad = q.line_start;
        *bad_line = q.line;
    } else if (s == MLR_E_PARSE) {
        *F = ps->fail_frame;
        *bad = ps->fail_line;
        *bad_line = ps->fail_line_no;
    }
    return s;
}

/* Keep the F complete frames of *mp with a warning (truncated, or missing frames) and one for
 * junk (the data after them, NULL: none); the diag of the frame error is cleared. */
static mlr_status keep_frames(parser *ps, mlr_motion **mp, size_t F, size_t declared,
                              int truncated, const char *junk, size_t bad_line)
{
    mlr_diag *d = ps->diag; /* the reader always gives one (bvh_read) */
    mlr_motion *g;
    mlr_status s;
    if ((s = mlr_motion_copy_frames(*mp, 0, F, &g, NULL)) != MLR_OK)
        return s;
    mlr_motion_destroy(*mp);
    *mp = g;
    if (truncated)
        bvh__warn_add(ps, MLR_BVH_WARN_TRUNCATED, d->line, d->column,
                      "truncated file: kept the %zu complete frames of %zu (%s)", F, declared,
                      d->message);
    else
        bvh__warn_add(ps, MLR_BVH_WARN_MISSING_FRAMES, bad_line, 0,
                      "Frames: declares %zu, but the file has %zu frame lines; they are read",
                      declared, F);
    if (junk) {
        const char *t = junk;
        while (t < ps->end && is_blank(*t))
            t++;
        bvh__warn_add(ps, MLR_BVH_WARN_TRAILING_DATA, bad_line, (size_t)(t - junk) + 1,
                      "data after the last frame ('%s'), ignored from here on",
                      bvh__show(t, (size_t)(line_end(t, ps->end) - t)).s);
    }
    d->line = d->column = 0;
    d->message[0] = '\0';
    ps->p = ps->end;
    return MLR_OK;
}

/* The lenient end of the MOTION section (mlr_bvh.h), after the frame loop returned s: extra
 * frame lines, a few missing ones, trailing data, a missing final line end, a truncated file.
 * On MLR_OK *mp may be a new motion (of the frames read) and ps->p is at the end. */
mlr_status bvh__lenient_tail(parser *ps, frames_plan *pl, const bvh_scratch *scr, mlr_motion **mp,
                             mlr_status s)
{
    const size_t declared = pl->n_declared;
    const int eol_at_end = bvh__ends_with_eol(ps->begin, ps->end);
    if (s == MLR_OK && (*mp)->n_frames == declared)
        return after_all_frames(ps, pl, scr, mp, eol_at_end);
    if (s != MLR_OK && s != MLR_E_PARSE)
        return s;
    size_t F = 0, bad_line = 0;
    const char *bad = NULL;
    s = where_frames_stop(ps, pl, scr, s, &F, &bad, &bad_line);
    /* what follows the last complete frame: nothing, a cut frame line, or other data */
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
    if (truncated && !ps->keep_truncated) {
        mlr_diag *d = ps->diag; /* the reader always gives one (bvh_read) */
        const size_t n = strlen(d->message);
        snprintf(d->message + n, sizeof d->message - n, " (truncated file: %zu of %zu frames)", F,
                 declared);
        return s;
    }
    return keep_frames(ps, mp, F, declared, truncated, junk, bad_line);
}
