/* BVH reader, the MOTION lines: the careful line parser, the frame loop and its split over
 * threads, and the conversion plan with the threads' scratch. The kernels are in bvh_frames.c.
 * Nothing here prints or keeps state. */
#include "io/bvh_read_internal.h"
#include "io/numparse.h"
#include "common/parallel_internal.h"

#include <stdatomic.h>

/* The values of one frame line into row: returns MLR_OK with ps->p at the end of the line. */
mlr_status bvh__parse_row(parser *ps, size_t f, size_t C, double *row)
{
    const char *p = ps->p, *const end = ps->end;
    for (size_t c = 0; c < C; c++) {
        while (p < end && is_blank(*p))
            p++;
        if (p >= end || is_eol(*p)) {
            ps->p = p;
            return bvh__fail_at(ps, p, "frame %zu has %zu values, expected %zu", f + 1, c, C);
        }
        size_t k = mlr_parse_decimal(p, end, row + c);
        if (k == 0 || (p + k < end && !is_blank(p[k]) && !is_eol(p[k]))) {
            const char *e = p;
            while (e < end && !is_blank(*e) && !is_eol(*e))
                e++;
            ps->p = p;
            return bvh__fail_at(ps, p, "frame %zu: invalid number '%s'", f + 1,
                                bvh__show(p, (size_t)(e - p)).s);
        }
        p += k;
    }
    while (p < end && is_blank(*p))
        p++;
    ps->p = p;
    if (p < end && !is_eol(*p))
        return bvh__fail_at(ps, p, "frame %zu has more than %zu values", f + 1, C);
    return MLR_OK;
}

/* Remember where the frame loop failed (frame f, on the current line) for the lenient tail. */
static void note_fail(parser *ps, size_t f)
{
    ps->fail_frame = f;
    ps->fail_line = ps->line_start;
    ps->fail_line_no = ps->line;
}

/* Frames [f0, f1) from ps->p on, the careful way where the line kernel declines a line (a
 * blank line, an exponent, an error, ...). Returns with ps->p after the last frame's line. */
mlr_status bvh__frames_loop(parser *ps, const frames_plan *pl, const bvh_scratch *s, size_t f0,
                            size_t f1)
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
            skip_blank_lines(ps);
            if (ps->p >= ps->end) {
                note_fail(ps, f);
                return bvh__fail_at(ps, ps->p, "unexpected end of file: %zu of %zu frames", f, N);
            }
            mlr_status st = bvh__parse_row(ps, f, C, s->row);
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
    const mlr_status st = bvh__frames_loop(&own, &plan, &scratch, f0, f1);
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
    const size_t f0 = parallel__wait_nonzero(&tk->first) - 1;
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
size_t bvh__auto_threads(size_t bytes)
{
    size_t t = bytes >> 19;
    if (t <= 1)
        return 1; /* small files do not ask for the processor count */
    const size_t cpus = parallel__online_cpus();
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
mlr_status bvh__parse_frames(parser *ps, const frames_plan *pl, const bvh_scratch *scratch,
                             size_t T)
{
    const size_t N = pl->m->n_frames, len = (size_t)(ps->end - ps->p);
    if (T <= 1)
        return parse_frames_range(ps, pl, &scratch[0], 0, N);
    size_t K = len / FRAMES_CHUNK;
    K = K < T ? T : K > 16 * T ? 16 * T : K;
    const size_t bytes = K * sizeof(frames_task) + _Alignof(frames_task);
    unsigned char *block = common__alloc(&ps->a, bytes);
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
    parallel__run_workers(T, used, frames_task_run, (void *)&r);
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
    common__free(&ps->a, block, bytes);
    return s;
}

#define SCRATCH_ALIGN 128

/* n bytes rounded up to a multiple of SCRATCH_ALIGN (n is far below SIZE_MAX here) */
static size_t scratch_round(size_t n)
{
    return (n + SCRATCH_ALIGN - 1) / SCRATCH_ALIGN * SCRATCH_ALIGN;
}

/* The conversion plan and T threads' scratch in one block of *bytes. */
mlr_status bvh__frames_setup(parser *ps, mlr_motion *m, size_t T, frames_plan *pl,
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
    if (common__mul_size(per, T, &total) != MLR_OK || total > SIZE_MAX - shared - SCRATCH_ALIGN)
        return MLR_E_OVERFLOW;
    total += shared + SCRATCH_ALIGN;
    unsigned char *b = common__alloc(&ps->a, total);
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
