/* Private parts of the BVH reader, shared by its files: bvh_parse.c (tokenizer, HIERARCHY,
 * the parsed skeleton into a motion), bvh_read_frames.c (the MOTION lines, on several threads),
 * bvh_read_lenient.c (what follows the declared frames) and bvh_read.c (the sequence of a read
 * and the entry points). Not installed. The cursor helpers are inline: the frame loop calls
 * them on every line. */
#ifndef MLR_BVH_READ_INTERNAL_H
#define MLR_BVH_READ_INTERNAL_H

#include "io/bvh_frames.h"
#include "motion/bvh_internal.h"

/* Most threads a read uses. */
#define BVH_MAX_THREADS 16

/* ---- growable arrays through the allocator ------------------------------------------------ */

typedef struct vec {
    unsigned char *data;
    size_t len, cap, elsize;
} vec;

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

static inline int is_blank(char c) { return c == ' ' || c == '\t' || c == '\v' || c == '\f'; }
static inline int is_eol(char c) { return c == '\n' || c == '\r'; }

static inline void eat_eol(parser *ps)
{
    if (ps->p < ps->end && *ps->p == '\r')
        ps->p++;
    if (ps->p < ps->end && *ps->p == '\n')
        ps->p++;
    ps->line++;
    ps->line_start = ps->p;
}

static inline void skip_blank(parser *ps)
{
    while (ps->p < ps->end && is_blank(*ps->p))
        ps->p++;
}

/* Past blank lines (and the blanks that start the next line). */
static inline void skip_blank_lines(parser *ps)
{
    for (;;) {
        skip_blank(ps);
        if (ps->p < ps->end && is_eol(*ps->p))
            eat_eol(ps);
        else
            break;
    }
}

static inline void skip_ws(parser *ps)
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

/* ---- bvh_parse.c ------------------------------------------------------------------------- */

void bvh__vec_free(vec *v, const mlr_allocator *a);

/* MLR_E_PARSE with diag (if any) at the line of ps and the column of at (NULL: none). */
mlr_status bvh__fail_at(parser *ps, const char *at, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

/* A printable copy of a token for messages: at most 32 bytes, control bytes as '?'. */
typedef struct shown {
    char s[40];
} shown;
shown bvh__show(const char *t, size_t n);

/* Next token: '{', '}' or a run of other visible bytes. Returns 1 with the token, 0 at the end
 * of the input, MLR_E_PARSE on a control byte. */
int bvh__next_token(parser *ps, const char **tok, size_t *len);
/* The next token, or a failure: MLR_E_PARSE on a control byte, and at the end of the input
 * MLR_E_PARSE with the message fmt (at the end's position). */
mlr_status bvh__need_token(parser *ps, const char **tok, size_t *len, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 4, 5)))
#endif
    ;
/* t (n bytes) equals kw, ASCII case-insensitively. */
int bvh__tok_is(const char *t, size_t n, const char *kw);
/* Expect a token equal to kw; what describes the place for the message. */
mlr_status bvh__expect(parser *ps, const char *kw, const char *what);
/* "Frames:" or "Frame Time:" followed by its value, possibly glued to the colon. */
mlr_status bvh__read_header_value(parser *ps, const char *label, const char **vt, size_t *vn);
/* HIERARCHY up to the ROOT's closing brace into ps->joints, ps->ends and ps->names. */
mlr_status bvh__parse_hierarchy(parser *ps);
/* A motion of n_frames (unset) frames with the skeleton that ps parsed. */
mlr_status bvh__build_motion(parser *ps, size_t n_frames, double frame_time, mlr_motion **out);

/* ---- bvh_read_frames.c ------------------------------------------------------------------- */

/* Everything the frame loop shares, read-only, between threads. */
typedef struct frames_plan {
    bvh_conv cv;
    bvh_kernels k;
    mlr_motion *m;
    const char *text; /* start of the input: the line kernel reads up to 16 bytes back */
    size_t n_declared; /* the count of Frames: (m may hold fewer frames when lenient) */
} frames_plan;

/* The values of one frame line into row: returns MLR_OK with ps->p at the end of the line. */
mlr_status bvh__parse_row(parser *ps, size_t f, size_t C, double *row);
/* Frames [f0, f1) from ps->p on, the careful way where the line kernel declines a line (a
 * blank line, an exponent, an error, ...). Returns with ps->p after the last frame's line. */
mlr_status bvh__frames_loop(parser *ps, const frames_plan *pl, const bvh_scratch *s, size_t f0,
                            size_t f1);
/* Threads for n_threads == 0: one per 512 KiB of frame text, at most the online processors
 * and 8. */
size_t bvh__auto_threads(size_t bytes);
/* The conversion plan and T threads' scratch in one block of *bytes. */
mlr_status bvh__frames_setup(parser *ps, mlr_motion *m, size_t T, frames_plan *pl,
                             bvh_scratch *scratch, unsigned char **block, size_t *bytes);
/* The MOTION lines on T threads; the result and the first error (line, reason) are those of a
 * single-threaded parse. */
mlr_status bvh__parse_frames(parser *ps, const frames_plan *pl, const bvh_scratch *scratch,
                             size_t T);

/* ---- bvh_read_lenient.c ------------------------------------------------------------------ */

/* Add a warning (kept up to MLR_BVH_WARNINGS_KEPT, all counted) when ps->warn is not NULL. */
void bvh__warn_add(parser *ps, int code, size_t line, size_t column, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 5, 6)))
#endif
    ;
/* The text's last byte other than blanks and NULs is a line end. */
int bvh__ends_with_eol(const char *begin, const char *end);
/* The lenient end of the MOTION section (mlr_bvh.h), after the frame loop returned s: extra
 * frame lines, a few missing ones, trailing data, a missing final line end, a truncated file.
 * On MLR_OK *mp may be a new motion (of the frames read) and ps->p is at the end. */
mlr_status bvh__lenient_tail(parser *ps, frames_plan *pl, const bvh_scratch *scr, mlr_motion **mp,
                             mlr_status s);

#endif
