/* A character playing a clip through mlr_stream with per-frame guards: see character.h. */
#define _POSIX_C_SOURCE 200809L
#include "character.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define RELEASE_S 0.2   /* a pinned foot is let go over this long */
#define LET_DOWN 1.0    /* the floor guard's lift comes down at most this (body heights / s) */
#define FLOOR_Q 0.05    /* the floor: this quantile of the contact points' heights (guards) */

static void *sys_allocate(void *user, size_t size, size_t align)
{
    (void)user;
    void *p = NULL;
    return posix_memalign(&p, align < sizeof(void *) ? sizeof(void *) : align, size) ? NULL : p;
}

static void sys_release(void *user, void *ptr, size_t size)
{
    (void)user, (void)size;
    free(ptr);
}

static mlr_allocator resolve(const mlr_allocator *a)
{
    if (a)
        return *a;
    mlr_allocator s = {sys_allocate, sys_release, NULL};
    return s;
}

static mlr_status fail(mlr_diag *diag, mlr_status s, const char *what)
{
    if (diag)
        snprintf(diag->message, sizeof diag->message, "%s", what);
    return s;
}

/* An array of the clip, remembered for char_clip_free. */
static void *clip_alloc(char_clip *c, size_t bytes)
{
    if (c->n_blk == sizeof c->blk / sizeof c->blk[0] || bytes == 0)
        return NULL;
    void *p = c->alloc.allocate(c->alloc.user, bytes, 64);
    if (p) {
        c->blk[c->n_blk] = p;
        c->blk_size[c->n_blk++] = bytes;
    }
    return p;
}

void char_clip_free(char_clip *c)
{
    if (!c)
        return;
    mlr_limits_destroy(c->limits);
    mlr_motion_destroy(c->motion);
    for (size_t i = 0; i < c->n_blk; i++)
        c->alloc.release(c->alloc.user, c->blk[i], c->blk_size[i]);
    memset(c, 0, sizeof *c);
}

/* The clip at CHAR_STEP_HZ: one step of the game pushes one frame. */
static mlr_status resample(char_clip *c, mlr_diag *diag)
{
    const mlr_motion *m = c->motion;
    const size_t n = mlr_motion_n_frames(m), j = c->n_joints, p = c->n_trans;
    const double fps = 1.0 / mlr_motion_frame_time(m);
    size_t n_out = n;
    double *t = NULL;
    mlr_status s = MLR_OK;
    if (fabs(fps - CHAR_STEP_HZ) > 1e-6 * CHAR_STEP_HZ) {
        t = c->alloc.allocate(c->alloc.user, n * sizeof *t, 64);
        if (!t)
            return fail(diag, MLR_E_NO_MEMORY, "resample: out of memory");
        s = mlr_resample_rate_map(n, fps, CHAR_STEP_HZ, MLR_RESAMPLE_OPEN_END, t, &n_out, diag);
    }
    if (s >= 0) {
        c->n_frames = n_out;
        c->root_pos = clip_alloc(c, n_out * 3 * sizeof(double));
        c->rot = clip_alloc(c, n_out * j * 4 * sizeof(double));
        c->trans = p ? clip_alloc(c, n_out * p * 3 * sizeof(double)) : NULL;
        if (!c->root_pos || !c->rot || (p && !c->trans))
            s = fail(diag, MLR_E_NO_MEMORY, "resample: out of memory");
    }
    if (s >= 0 && t)
        s = mlr_slerp_resample_arrays(n, j, p, mlr_motion_root_pos(m), mlr_motion_rot(m),
                                      mlr_motion_trans(m), t, n_out, MLR_RESAMPLE_OPEN_END,
                                      c->root_pos, c->rot, c->trans, diag);
    else if (s >= 0) {
        memcpy(c->root_pos, mlr_motion_root_pos(m), n * 3 * sizeof(double));
        memcpy(c->rot, mlr_motion_rot(m), n * j * 4 * sizeof(double));
        if (p)
            memcpy(c->trans, mlr_motion_trans(m), n * p * 3 * sizeof(double));
    }
    if (t)
        c->alloc.release(c->alloc.user, t, n * sizeof *t);
    return s;
}

/* Is joint a (or a descendant of it) b? */
static int in_subtree(const int32_t *parents, int32_t a, int32_t b)
{
    for (; b >= 0; b = parents[b])
        if (b == a)
            return 1;
    return 0;
}

/* The feet: the points that are joints with no other point's joint above them (ankles), their
 * legs, hinge axes and per-frame contacts (any point of the foot touching). */
static mlr_status find_feet(char_clip *c, const uint8_t *contacts, const double *wpos,
                            const double *wrot, mlr_diag *diag)
{
    const int32_t *parents = c->rig.parents;
    for (size_t i = 0; i < c->n_points && c->n_feet < CHAR_MAX_FEET; i++) {
        int32_t a = c->pt_joint[i];
        int top = c->pt_end[i] < 0;
        for (size_t k = 0; k < c->n_points && top; k++)
            if (c->pt_joint[k] != a && in_subtree(parents, c->pt_joint[k], a))
                top = 0;
        for (size_t f = 0; f < c->n_feet && top; f++)
            if (c->ankle[f] == a)
                top = 0;
        if (!top)
            continue;
        size_t f = c->n_feet;
        if (mlr_ik_leg_chain(&c->rig, a, &c->hip[f], &c->knee[f], NULL) < 0)
            continue; /* no two-bone chain above it: not pinned */
        c->ankle[f] = a;
        mlr_status s = mlr_ik_bend_axis_local(c->n_frames, c->n_joints, wpos, wrot, c->hip[f],
                                              c->knee[f], a, c->bend[f], diag);
        if (s < 0)
            return s;
        c->n_feet++;
    }
    if (c->n_feet) {
        c->contact = clip_alloc(c, c->n_frames * c->n_feet);
        if (!c->contact)
            return fail(diag, MLR_E_NO_MEMORY, "feet: out of memory");
        for (size_t n = 0; n < c->n_frames; n++)
            for (size_t f = 0; f < c->n_feet; f++) {
                uint8_t on = 0;
                for (size_t i = 0; i < c->n_points; i++)
                    if (contacts[n * c->n_points + i] &&
                        in_subtree(parents, c->ankle[f], c->pt_joint[i]))
                        on = 1;
                c->contact[n * c->n_feet + f] = on;
            }
    }
    return MLR_OK;
}

mlr_status char_clip_load(const char *path, const mlr_allocator *alloc, char_clip *c,
                          mlr_diag *diag)
{
    memset(c, 0, sizeof *c);
    c->alloc = resolve(alloc);
    c->floor_height = NAN;
    mlr_status s = mlr_bvh_read_file(path, &c->alloc, &c->motion, diag);
    if (s < 0)
        return s;
    const mlr_motion *m = c->motion;
    const size_t j = c->n_joints = mlr_motion_n_joints(m);
    const size_t p = c->n_trans = mlr_motion_n_trans(m);
    c->width = 3 + 3 * p + 4 * j;
    c->names = clip_alloc(c, j * sizeof *c->names);
    if (!c->names) {
        s = fail(diag, MLR_E_NO_MEMORY, "load: out of memory");
        goto done;
    }
    for (size_t k = 0; k < j; k++)
        c->names[k] = mlr_motion_joint_name(m, k);
    mlr_rig rig = {j,
                   mlr_motion_parents(m),
                   mlr_motion_offsets(m),
                   c->names,
                   p,
                   mlr_motion_trans_joints(m),
                   mlr_motion_n_end_sites(m),
                   mlr_motion_end_site_parents(m),
                   mlr_motion_end_site_offsets(m)};
    c->rig = rig;
    if (rig.n_end_sites) { /* End Site k below its parent joint, for drawing */
        c->end_index = clip_alloc(c, rig.n_end_sites * sizeof(int32_t));
        if (!c->end_index) {
            s = fail(diag, MLR_E_NO_MEMORY, "load: out of memory");
            goto done;
        }
        for (size_t k = 0; k < rig.n_end_sites; k++)
            c->end_index[k] = (int32_t)k;
    }
    s = resample(c, diag);
    if (s < 0 || c->n_frames < 3) {
        s = s < 0 ? s : fail(diag, MLR_E_INVALID_ARG, "load: the clip is shorter than 3 steps");
        goto done;
    }
    const size_t n = c->n_frames;

    /* Forward kinematics of the whole clip (scratch), the up axis and the body's height. */
    double *wpos = c->alloc.allocate(c->alloc.user, n * j * 7 * sizeof(double), 64);
    double *wrot = wpos ? wpos + n * j * 3 : NULL;
    mlr_guards *g = NULL;
    uint8_t *contacts = NULL;
    size_t n_contacts = 0;
    if (!wpos) {
        s = fail(diag, MLR_E_NO_MEMORY, "load: out of memory");
        goto done;
    }
    s = mlr_fk_arrays(n, j, rig.parents, rig.offsets, c->root_pos, c->rot, p, rig.trans_joints,
                      c->trans, wpos, wrot, &c->alloc, diag);
    mlr_up_guess up = {0};
    if (s >= 0)
        s = mlr_rig_up_axis(&rig, n, wpos, &up, &c->alloc, diag);
    c->up = up.axis;
    if (s >= 0)
        s = mlr_rig_body_height(n, j, wpos, c->up, &c->body_height, &c->alloc, diag);

    /* The guards of the clip find its feet and their contacts; the floor from those. */
    if (s >= 0) {
        const mlr_guards_option opt[] = {{MLR_GUARDS_OPT_UP, (double)c->up}};
        const mlr_guards_input in = {
            &rig, CHAR_STEP_HZ, {n, c->root_pos, c->rot, c->trans}, opt, 1};
        s = mlr_guards_create_from(&in, &c->alloc, &g, diag);
    }
    if (s >= 0 && (c->n_points = mlr_guards_n_points(g)) > 0) {
        const size_t cp = c->n_points;
        c->pt_joint = clip_alloc(c, 2 * cp * sizeof(int32_t));
        c->pt_height = clip_alloc(c, n * cp * sizeof(double));
        n_contacts = n * cp;
        contacts = c->alloc.allocate(c->alloc.user, n_contacts, 64);
        double *pts = c->alloc.allocate(c->alloc.user, n * cp * 3 * sizeof(double), 64);
        if (!c->pt_joint || !c->pt_height || !contacts || !pts)
            s = fail(diag, MLR_E_NO_MEMORY, "load: out of memory");
        else {
            c->pt_end = c->pt_joint + cp;
            s = mlr_guards_get_contacts(g, c->pt_joint, c->pt_end, contacts);
        }
        if (s >= 0)
            s = mlr_rig_point_positions(&rig, n, wpos, wrot, cp, c->pt_joint, c->pt_end, pts,
                                        diag);
        for (size_t k = 0; s >= 0 && k < n * cp; k++)
            c->pt_height[k] = pts[3 * k + (size_t)c->up];
        if (pts)
            c->alloc.release(c->alloc.user, pts, n * cp * 3 * sizeof(double));
        if (s >= 0) {
            mlr_cleanup_job job = {0};
            job.rig = &rig, job.up = c->up;
            job.motion = (mlr_frames){n, c->root_pos, c->rot, c->trans};
            job.points = (mlr_cleanup_points){cp, c->pt_joint, c->pt_end, contacts};
            s = mlr_cleanup_job_floor_height(&job, FLOOR_Q, &c->floor_height, &c->alloc, diag);
        }
        if (s >= 0)
            s = find_feet(c, contacts, wpos, wrot, diag);
    }
    /* The joint limits, learned from the clip with the guards' defaults. */
    if (s >= 0) {
        const mlr_limits_clip lc = {n, c->rot, c->trans};
        s = mlr_limits_create(&rig, &lc, 1, NULL, 0, &c->alloc, &c->limits, diag);
    }
    /* Looping: each loop carries the root on by the clip's ground displacement. */
    for (int a = 0; a < 3; a++)
        c->loop_shift[a] = a == c->up
                               ? 0.0
                               : 2.0 * c->root_pos[3 * (n - 1) + (size_t)a] -
                                     c->root_pos[3 * (n - 2) + (size_t)a] - c->root_pos[(size_t)a];
    if (contacts)
        c->alloc.release(c->alloc.user, contacts, n_contacts);
    mlr_guards_destroy(g);
    c->alloc.release(c->alloc.user, wpos, n * j * 7 * sizeof(double));
done:
    if (s < 0)
        char_clip_free(c);
    return s;
}

mlr_status char_init(character *c, const char_clip *clip, size_t phase, size_t lag,
                     const mlr_allocator *alloc, mlr_diag *diag)
{
    memset(c, 0, sizeof *c);
    c->clip = clip;
    c->alloc = resolve(alloc);
    c->lag = lag;
    c->phase = phase % clip->n_frames;
    c->filter = 1;
    const size_t w = clip->width, j = clip->n_joints, e = clip->rig.n_end_sites;
    const size_t np = clip->n_points > e ? clip->n_points : e;
    const size_t doubles = 3 * w + j + 7 * j + 3 * np + 3 * e;
    c->bytes = doubles * sizeof(double);
    c->block = c->alloc.allocate(c->alloc.user, c->bytes, 64);
    if (!c->block)
        return fail(diag, MLR_E_NO_MEMORY, "character: out of memory");
    double *d = c->block;
    c->in = d, d += w;
    c->out = d, d += w;
    c->pose = d, d += w;
    c->alpha_j = d, d += j;
    c->world_pos = d, d += 3 * j;
    c->world_rot = d, d += 4 * j;
    c->points = d, d += 3 * np;
    c->ends = d;
    mlr_status s = mlr_stream_create_layered(j, 1, clip->n_trans, 1.0, 1.0, 20.0, 1.0, lag,
                                             &c->alloc, &c->stream, diag);
    if (s >= 0)
        s = char_set_guards(c, 1, diag);
    if (s >= 0)
        s = char_set_alpha(c, 1.0, diag);
    for (size_t f = 0; f < CHAR_MAX_FEET; f++)
        c->released[f] = RELEASE_S;
    if (s < 0)
        char_free(c);
    return s;
}

void char_free(character *c)
{
    if (!c)
        return;
    mlr_stream_destroy(c->stream);
    if (c->block)
        c->alloc.release(c->alloc.user, c->block, c->bytes);
    memset(c, 0, sizeof *c);
}

mlr_status char_set_alpha(character *c, double alpha, mlr_diag *diag)
{
    for (size_t k = 0; k < c->clip->n_joints; k++)
        c->alpha_j[k] = alpha;
    mlr_status s = mlr_stream_set_alpha(c->stream, alpha, c->alpha_j, c->clip->n_joints, diag);
    if (s >= 0)
        c->alpha = alpha;
    return s;
}

mlr_status char_set_guards(character *c, int on, mlr_diag *diag)
{
    mlr_status s = mlr_stream_set_limits(c->stream, on ? c->clip->limits : NULL, diag);
    if (s >= 0)
        c->guards = on;
    return s;
}

void char_set_filter(character *c, int on) { c->filter = on; }

size_t char_shown_frame(const character *c)
{
    const size_t k = c->pushed > c->lag ? c->pushed - 1 - c->lag : 0;
    return (c->phase + k) % c->clip->n_frames;
}

/* Frame k of the endless clip (k counted from the character's phase) in the stream's layout. */
static void clip_frame(const character *c, size_t k, double *dst)
{
    const char_clip *cl = c->clip;
    const size_t n = cl->n_frames, g = c->phase + k, f = g % n, loops = g / n;
    const size_t p = cl->n_trans, j = cl->n_joints;
    for (int a = 0; a < 3; a++)
        dst[a] = cl->root_pos[3 * f + (size_t)a] + (double)loops * cl->loop_shift[a];
    if (p)
        memcpy(dst + 3, cl->trans + 3 * p * f, 3 * p * sizeof(double));
    memcpy(dst + 3 + 3 * p, cl->rot + 4 * j * f, 4 * j * sizeof(double));
}

static mlr_status fk(character *c, mlr_diag *diag)
{
    const char_clip *cl = c->clip;
    const size_t p = cl->n_trans;
    return mlr_fk_arrays(1, cl->n_joints, cl->rig.parents, cl->rig.offsets, c->pose,
                         c->pose + 3 + 3 * p, p, cl->rig.trans_joints, p ? c->pose + 3 : NULL,
                         c->world_pos, c->world_rot, NULL, diag);
}

static double smoothstep(double x)
{
    x = x < 0.0 ? 0.0 : x > 1.0 ? 1.0 : x;
    return x * x * (3.0 - 2.0 * x);
}

/* The feet: pinned where they touched down while the clip says they touch, then let go. */
static mlr_status pin_feet(character *c, size_t frame, mlr_diag *diag)
{
    const char_clip *cl = c->clip;
    const size_t j = cl->n_joints;
    double *rot = c->pose + 3 + 3 * cl->n_trans;
    int moved = 0;
    for (size_t f = 0; f < cl->n_feet; f++) {
        const double *a = c->world_pos + 3 * (size_t)cl->ankle[f];
        double target[3], w = 1.0;
        if (cl->contact[frame * cl->n_feet + f]) {
            if (!c->pinned[f])
                memcpy(c->held[f], a, sizeof c->held[f]);
            c->pinned[f] = 1;
            c->released[f] = 0.0;
        } else {
            c->pinned[f] = 0;
            if (c->released[f] >= RELEASE_S)
                continue;
            c->released[f] += 1.0 / CHAR_STEP_HZ;
            w = 1.0 - smoothstep(c->released[f] / RELEASE_S);
        }
        for (int k = 0; k < 3; k++)
            target[k] = a[k] + w * (c->held[f][k] - a[k]);
        /* The hinge axis of the clip, turned by this frame's hip. */
        const double *q = c->world_rot + 4 * (size_t)cl->hip[f];
        const mlr_quat hq = {q[0], q[1], q[2], q[3]};
        const mlr_vec3 lv = {cl->bend[f][0], cl->bend[f][1], cl->bend[f][2]};
        mlr_vec3 wv;
        mlr_quat_rotate(&hq, &lv, &wv);
        const double axis[3] = {wv.x, wv.y, wv.z};
        const int no_axis = lv.x == 0.0 && lv.y == 0.0 && lv.z == 0.0;
        mlr_status s =
            mlr_ik_apply_leg(1, j, cl->rig.parents, rot, c->world_pos, c->world_rot, cl->hip[f],
                             cl->knee[f], cl->ankle[f], target, no_axis ? NULL : axis, diag);
        if (s < 0)
            return s;
        moved = 1;
    }
    return moved ? fk(c, diag) : MLR_OK;
}

/* The floor: no foot point below min(floor, the clip's own height of it); the lift eased down. */
static mlr_status floor_guard(character *c, size_t frame, mlr_diag *diag)
{
    const char_clip *cl = c->clip;
    const size_t cp = cl->n_points, up = (size_t)cl->up;
    if (!cp || isnan(cl->floor_height))
        return MLR_OK;
    mlr_status s = mlr_rig_point_positions(&cl->rig, 1, c->world_pos, c->world_rot, cp,
                                           cl->pt_joint, cl->pt_end, c->points, diag);
    if (s < 0)
        return s;
    double need = 0.0;
    for (size_t i = 0; i < cp; i++) {
        double lo = cl->pt_height[frame * cp + i];
        lo = lo < cl->floor_height ? lo : cl->floor_height;
        const double d = lo - c->points[3 * i + up];
        need = d > need ? d : need;
    }
    const double down = c->lift - LET_DOWN * cl->body_height / CHAR_STEP_HZ;
    c->lift = need > down ? need : down > 0.0 ? down : 0.0;
    c->pose[up] += c->lift;
    for (size_t k = 0; k < cl->n_joints; k++)
        c->world_pos[3 * k + up] += c->lift;
    return MLR_OK;
}

mlr_status char_step(character *c, mlr_diag *diag)
{
    const char_clip *cl = c->clip;
    const size_t w = cl->width;
    size_t ready = 0;
    clip_frame(c, c->pushed, c->in);
    mlr_status s = mlr_stream_push(c->stream, c->in, w, c->out, w, &ready, diag);
    if (s < 0)
        return s;
    c->pushed++;
    const size_t shown = c->pushed > c->lag ? c->pushed - 1 - c->lag : 0;
    if (ready && c->filter)
        memcpy(c->pose, c->out, w * sizeof(double));
    else /* the raw clip, as far behind as the stream (the filter toggles without a jump) */
        clip_frame(c, shown, c->pose);
    s = fk(c, diag);
    const size_t frame = char_shown_frame(c);
    if (s >= 0 && c->guards && cl->n_feet)
        s = pin_feet(c, frame, diag);
    if (s >= 0 && c->guards)
        s = floor_guard(c, frame, diag);
    if (s >= 0 && cl->rig.n_end_sites) {
        const size_t e = cl->rig.n_end_sites;
        s = mlr_rig_point_positions(&cl->rig, 1, c->world_pos, c->world_rot, e,
                                    cl->rig.end_site_parents, cl->end_index, c->ends, diag);
    }
    return s;
}
