/* The motion handle: one allocation per motion, creation from arrays, frame copies and the
 * accessors. Nothing here prints or keeps state. */
#include "motion/bvh_internal.h"

#include <math.h>

/* ---- layout of the single block ---------------------------------------------------------- */

typedef struct layout {
    size_t size;
    int overflow;
} layout;

/* Reserve count elements of elsize bytes aligned to align; returns their offset. */
static size_t layout_add(layout *l, size_t count, size_t elsize, size_t align)
{
    size_t bytes;
    if (l->overflow || common__mul_size(count, elsize, &bytes) != MLR_OK) {
        l->overflow = 1;
        return 0;
    }
    size_t off = (l->size + (align - 1)) & ~(align - 1);
    if (off < l->size || off > SIZE_MAX - bytes) {
        l->overflow = 1;
        return 0;
    }
    l->size = off + bytes;
    return off;
}

/* The block of a motion of these sizes: its size and where each array starts. */
typedef struct motion_blocks {
    size_t size, nj4, ntn;
    size_t root_pos, rot, trans, offsets, end_offsets, names, parents, end_parents, trans_joints,
        trans_slot, n_ch, ch, order, rot_idx, ch_str, name_buf;
} motion_blocks;

static mlr_status motion_layout(size_t n_joints, size_t n_end, size_t name_bytes, size_t n_frames,
                                size_t n_trans, motion_blocks *b)
{
    size_t njn;
    if (common__mul_size(n_frames, n_joints, &njn) || common__mul_size(njn, 4, &b->nj4) ||
        common__mul_size(n_frames, n_trans, &b->ntn))
        return MLR_E_OVERFLOW;
    layout l = {0, 0};
    layout_add(&l, 1, sizeof(mlr_motion), 16);
    b->offsets = layout_add(&l, n_joints, 3 * sizeof(double), 16);
    b->end_offsets = layout_add(&l, n_end, 3 * sizeof(double), 16);
    b->root_pos = layout_add(&l, n_frames, 3 * sizeof(double), 16);
    b->rot = layout_add(&l, b->nj4, sizeof(double), 16);
    b->trans = layout_add(&l, b->ntn, 3 * sizeof(double), 16);
    b->names = layout_add(&l, n_joints, sizeof(const char *), 16);
    b->parents = layout_add(&l, n_joints, sizeof(int32_t), 16);
    b->end_parents = layout_add(&l, n_end, sizeof(int32_t), 16);
    b->trans_joints = layout_add(&l, n_trans, sizeof(int32_t), 16);
    b->trans_slot = layout_add(&l, n_joints, sizeof(int32_t), 16);
    b->n_ch = layout_add(&l, n_joints, 1, 1);
    b->ch = layout_add(&l, n_joints, BVH_MAX_CHANNELS, 1);
    b->order = layout_add(&l, n_joints, 1, 1);
    b->rot_idx = layout_add(&l, n_joints, 3, 1);
    b->ch_str = layout_add(&l, n_joints, BVH_CHSTR, 1);
    b->name_buf = layout_add(&l, name_bytes, 1, 1);
    layout_add(&l, 1, 1, 16); /* round the end up */
    if (l.overflow)
        return MLR_E_OVERFLOW;
    b->size = l.size;
    return MLR_OK;
}

/* Lay a motion of these sizes out in base (b->size bytes at least): counts and pointers set,
 * the contents not; alloc and block_size are the caller's. */
static mlr_motion *motion_place(unsigned char *base, const motion_blocks *b, size_t n_joints,
                                size_t n_end, size_t name_bytes, size_t n_frames, size_t n_trans)
{
    mlr_motion *m = (mlr_motion *)base;
    memset(m, 0, sizeof *m);
    m->n_joints = n_joints;
    m->n_end = n_end;
    m->n_frames = n_frames;
    m->n_trans = n_trans;
    m->frame_time = 1.0 / 30.0;
#define AT(type, off, count) ((count) ? (type)(void *)(base + (off)) : NULL)
    m->offsets = AT(double *, b->offsets, n_joints);
    m->end_offsets = AT(double *, b->end_offsets, n_end);
    m->root_pos = AT(double *, b->root_pos, n_frames);
    m->rot = AT(double *, b->rot, b->nj4);
    m->trans = AT(double *, b->trans, b->ntn);
    m->names = AT(const char **, b->names, n_joints);
    m->parents = AT(int32_t *, b->parents, n_joints);
    m->end_parents = AT(int32_t *, b->end_parents, n_end);
    m->trans_joints = AT(int32_t *, b->trans_joints, n_trans);
    m->trans_slot = AT(int32_t *, b->trans_slot, n_joints);
    m->n_ch = AT(unsigned char *, b->n_ch, n_joints);
    m->ch = AT(unsigned char *, b->ch, n_joints);
    m->order = AT(unsigned char *, b->order, n_joints);
    m->rot_idx = AT(unsigned char *, b->rot_idx, n_joints);
    m->ch_str = AT(char *, b->ch_str, n_joints);
    m->name_buf = AT(char *, b->name_buf, name_bytes);
#undef AT
    return m;
}

mlr_status bvh_motion_alloc(const mlr_allocator *alloc, size_t n_joints, size_t n_end,
                            size_t name_bytes, size_t n_frames, size_t n_trans, mlr_motion **out)
{
    *out = NULL;
    motion_blocks b;
    mlr_status s = motion_layout(n_joints, n_end, name_bytes, n_frames, n_trans, &b);
    if (s != MLR_OK)
        return s;
    mlr_allocator a;
    common__allocator_resolve(alloc, &a);
    unsigned char *base = common__alloc(&a, b.size);
    if (!base)
        return MLR_E_NO_MEMORY;
    mlr_motion *m = motion_place(base, &b, n_joints, n_end, name_bytes, n_frames, n_trans);
    m->alloc = a;
    m->block_size = b.size;
    *out = m;
    return MLR_OK;
}

void mlr_motion_destroy(mlr_motion *motion)
{
    if (motion) {
        mlr_allocator a = motion->alloc;
        common__free(&a, motion, motion->block_size);
    }
}

/* ---- channels ---------------------------------------------------------------------------- */

static const char *const channel_names[BVH_MAX_CHANNELS] = {
    "Xposition", "Yposition", "Zposition", "Xrotation", "Yrotation", "Zrotation",
};

/* Orders by axis triple: index = 9*a0 + 3*a1 + a2 for the valid permutations. */
static mlr_euler_order order_from_axes(const unsigned char ax[3])
{
    static const struct {
        unsigned char a[3];
        mlr_euler_order o;
    } table[6] = {
        {{0, 1, 2}, MLR_EULER_XYZ}, {{0, 2, 1}, MLR_EULER_XZY}, {{1, 0, 2}, MLR_EULER_YXZ},
        {{1, 2, 0}, MLR_EULER_YZX}, {{2, 0, 1}, MLR_EULER_ZXY}, {{2, 1, 0}, MLR_EULER_ZYX},
    };
    for (size_t i = 0; i < 6; i++)
        if (table[i].a[0] == ax[0] && table[i].a[1] == ax[1] && table[i].a[2] == ax[2])
            return table[i].o;
    return MLR_EULER_XYZ; /* not reached for a permutation */
}

int bvh_channel_parse(const char *s, size_t len)
{
    if (len != 9)
        return -1;
    for (int c = 0; c < BVH_MAX_CHANNELS; c++) {
        const char *n = channel_names[c];
        size_t i = 0;
        for (; i < 9; i++) {
            char a = s[i], b = n[i];
            if (a >= 'A' && a <= 'Z')
                a = (char)(a - 'A' + 'a');
            if (b >= 'A' && b <= 'Z')
                b = (char)(b - 'A' + 'a');
            if (a != b)
                break;
        }
        if (i == 9)
            return c;
    }
    return -1;
}

const char *bvh_channel_name(int code)
{
    return (code >= 0 && code < BVH_MAX_CHANNELS) ? channel_names[code] : "";
}

size_t bvh_layout_finish(mlr_motion *m, size_t j)
{
    const unsigned char *ch = m->ch + BVH_MAX_CHANNELS * j;
    size_t n = m->n_ch[j], n_pos = 0, n_rot = 0;
    unsigned char axes[3];
    int used[3] = {0, 0, 0};
    char *s = m->ch_str + BVH_CHSTR * j;
    size_t len = 0;
    for (size_t k = 0; k < n; k++) {
        const char *name = channel_names[ch[k]];
        if (k)
            s[len++] = ' ';
        memcpy(s + len, name, 9);
        len += 9;
        if (ch[k] < 3) {
            n_pos++;
        } else {
            axes[n_rot++] = (unsigned char)(ch[k] - 3);
            used[ch[k] - 3] = 1;
        }
    }
    s[len] = '\0';
    for (unsigned char a = 0; a < 3; a++)
        if (!used[a])
            axes[n_rot++] = a;
    m->order[j] = (unsigned char)order_from_axes(axes);
    for (unsigned char k = 0; k < 3; k++)
        m->rot_idx[3 * j + axes[k]] = k;
    return n_pos;
}

void bvh_motion_rest_frame(mlr_motion *m, size_t f)
{
    size_t J = m->n_joints, P = m->n_trans;
    double *r = m->rot + f * J * 4;
    for (size_t j = 0; j < J; j++) {
        r[4 * j] = 1.0;
        r[4 * j + 1] = r[4 * j + 2] = r[4 * j + 3] = 0.0;
    }
    memcpy(m->root_pos + 3 * f, m->offsets, 3 * sizeof(double));
    for (size_t k = 0; k < P; k++)
        memcpy(m->trans + (f * P + k) * 3, m->offsets + 3 * (size_t)m->trans_joints[k],
               3 * sizeof(double));
}

/* ---- creation from arrays ---------------------------------------------------------------- */

static const char default_root_channels[] =
    "Xposition Yposition Zposition Zrotation Yrotation Xrotation";
static const char default_joint_channels[] = "Zrotation Yrotation Xrotation";

static int is_space(char c) { return c == ' ' || c == '\t'; }

/* Parse a channel list into codes; returns the count or -1 with a reason in diag. */
static int parse_channel_list(const char *s, unsigned char *codes, size_t j, mlr_diag *diag)
{
    int n = 0, seen = 0;
    while (*s) {
        while (is_space(*s))
            s++;
        if (!*s)
            break;
        const char *t = s;
        while (*s && !is_space(*s))
            s++;
        int c = bvh_channel_parse(t, (size_t)(s - t));
        if (c < 0) {
            common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                             "channels[%zu]: unknown channel '%.*s'", j,
                             (int)((s - t) > 40 ? 40 : (s - t)), t);
            return -1;
        }
        if (seen & (1 << c)) {
            common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "channels[%zu]: %s listed twice", j,
                             channel_names[c]);
            return -1;
        }
        seen |= 1 << c;
        codes[n++] = (unsigned char)c;
    }
    return n;
}

/* Names must survive a write and a read unchanged. */
static int name_is_valid(const char *s)
{
    if (!*s || is_space(s[0]))
        return 0;
    size_t n = 0;
    for (; s[n]; n++) {
        unsigned char c = (unsigned char)s[n];
        if ((c < 0x20 && c != '\t') || c == 0x7f || c == '{' || c == '}')
            return 0;
    }
    return !is_space(s[n - 1]);
}

/* The channel list of joint j: channels[j], or the default of the root or of a joint. */
static const char *channel_list(const char *const *channels, size_t j)
{
    return channels ? channels[j] : (j == 0 ? default_root_channels : default_joint_channels);
}

/* The joints of mlr_motion_create: valid names, parents in depth-first order, finite offsets,
 * valid channel lists. Counts the bytes of the names (with their NULs) and the joints other
 * than the root with position channels. */
static mlr_status check_joints(size_t n_joints, const char *const *names, const int32_t *parents,
                               const double *offsets, const char *const *channels,
                               size_t *name_bytes, size_t *n_trans, mlr_diag *diag)
{
    unsigned char codes[BVH_MAX_CHANNELS];
    *name_bytes = *n_trans = 0;
    for (size_t j = 0; j < n_joints; j++) {
        if (!names[j] || !name_is_valid(names[j]))
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    "names[%zu] is empty or has control characters, braces, or "
                                    "leading or trailing blanks",
                                    j);
        size_t len = strlen(names[j]);
        if (*name_bytes > SIZE_MAX - len - 1)
            return common__diag_set(diag, MLR_E_OVERFLOW, 0, 0,
                                    "motion create: the names' bytes overflow a size");
        *name_bytes += len + 1;
        /* depth-first order: parents[j] is j-1 or an ancestor of j-1 */
        int32_t p = parents[j];
        if (j == 0) {
            if (p != -1)
                return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "parents[0] must be -1");
        } else {
            int32_t a = (int32_t)(j - 1);
            while (a >= 0 && a != p)
                a = parents[a];
            if (p < 0 || a != p)
                return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                        "parents[%zu] = %d: joints must be in depth-first order "
                                        "(the parent is the previous joint or one of its "
                                        "ancestors)",
                                        j, (int)p);
        }
        for (size_t k = 0; k < 3; k++)
            if (!isfinite(offsets[3 * j + k]))
                return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                        "offsets[%zu] is not finite", j);
        const char *cl = channel_list(channels, j);
        if (!cl)
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "channels[%zu] is NULL", j);
        int n = parse_channel_list(cl, codes, j, diag);
        if (n < 0)
            return MLR_E_INVALID_ARG;
        if (j > 0)
            for (int k = 0; k < n; k++)
                if (codes[k] < 3) {
                    (*n_trans)++;
                    break;
                }
    }
    return MLR_OK;
}

/* End Site parents are joint indices, non-decreasing; offsets finite. */
static mlr_status check_end_sites(size_t n_joints, size_t n_end_sites, const int32_t *end_parents,
                                  const double *end_offsets, mlr_diag *diag)
{
    for (size_t e = 0; e < n_end_sites; e++) {
        if (end_parents[e] < 0 || (size_t)end_parents[e] >= n_joints ||
            (e && end_parents[e] < end_parents[e - 1]))
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    "end_parents[%zu] = %d: must be a joint index, non-decreasing",
                                    e, (int)end_parents[e]);
        for (size_t k = 0; k < 3; k++)
            if (!isfinite(end_offsets[3 * e + k]))
                return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                        "end_offsets[%zu] is not finite", e);
    }
    return MLR_OK;
}

/* The skeleton of checked arguments into a new motion m: names, parents, offsets, channels
 * and their layout, the translated joints, the End Sites. */
static void fill_skeleton(mlr_motion *m, const char *const *names, const int32_t *parents,
                          const double *offsets, const char *const *channels,
                          const int32_t *end_parents, const double *end_offsets)
{
    char *nb = m->name_buf;
    size_t P = 0, C = 0;
    for (size_t j = 0; j < m->n_joints; j++) {
        size_t len = strlen(names[j]);
        memcpy(nb, names[j], len + 1);
        m->names[j] = nb;
        nb += len + 1;
        m->parents[j] = parents[j];
        memcpy(m->offsets + 3 * j, offsets + 3 * j, 3 * sizeof(double));
        int n =
            parse_channel_list(channel_list(channels, j), m->ch + BVH_MAX_CHANNELS * j, j, NULL);
        m->n_ch[j] = (unsigned char)n;
        C += (size_t)n;
        size_t n_pos = bvh_layout_finish(m, j);
        m->trans_slot[j] = -1;
        if (j > 0 && n_pos > 0) {
            m->trans_slot[j] = (int32_t)P;
            m->trans_joints[P++] = (int32_t)j;
        }
    }
    m->n_channels = C;
    if (m->n_end) {
        memcpy(m->end_parents, end_parents, m->n_end * sizeof(int32_t));
        memcpy(m->end_offsets, end_offsets, 3 * m->n_end * sizeof(double));
    }
}

mlr_status mlr_motion_create(size_t n_joints, const char *const *names, const int32_t *parents,
                             const double *offsets, const char *const *channels,
                             size_t n_end_sites, const int32_t *end_parents,
                             const double *end_offsets, size_t n_frames, double frame_time,
                             const mlr_allocator *alloc, mlr_motion **out, mlr_diag *diag)
{
    if (!out)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "out is NULL");
    *out = NULL;
    if (n_joints == 0 || n_joints > BVH_MAX_JOINTS || n_end_sites > BVH_MAX_JOINTS)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "bad joint or End Site count");
    if (!names || !parents || !offsets || (n_end_sites && (!end_parents || !end_offsets)))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "a required array is NULL");
    if (!isfinite(frame_time) || frame_time <= 0.0)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "frame_time must be finite and positive");
    size_t name_bytes, n_trans;
    mlr_status s =
        check_joints(n_joints, names, parents, offsets, channels, &name_bytes, &n_trans, diag);
    if (s == MLR_OK)
        s = check_end_sites(n_joints, n_end_sites, end_parents, end_offsets, diag);
    if (s != MLR_OK)
        return s;

    mlr_motion *m;
    s = bvh_motion_alloc(alloc, n_joints, n_end_sites, name_bytes, n_frames, n_trans, &m);
    if (s != MLR_OK)
        return common__diag_set(diag, s, 0, 0, "motion create: %zu frames of %zu joints: %s",
                                n_frames, n_joints, mlr_status_string(s));
    m->frame_time = frame_time;
    fill_skeleton(m, names, parents, offsets, channels, end_parents, end_offsets);
    for (size_t f = 0; f < n_frames; f++)
        bvh_motion_rest_frame(m, f);
    *out = m;
    return MLR_OK;
}

/* The skeleton, channel layout and frame time of src into m (laid out for them). */
static void copy_skeleton(mlr_motion *m, const mlr_motion *src, size_t name_bytes)
{
    const size_t J = src->n_joints, E = src->n_end, P = src->n_trans;
    m->frame_time = src->frame_time;
    m->n_channels = src->n_channels;
    memcpy(m->name_buf, src->name_buf, name_bytes);
    for (size_t j = 0; j < J; j++)
        m->names[j] = m->name_buf + (src->names[j] - src->name_buf);
    memcpy(m->parents, src->parents, J * sizeof(int32_t));
    memcpy(m->offsets, src->offsets, 3 * J * sizeof(double));
    memcpy(m->n_ch, src->n_ch, J);
    memcpy(m->ch, src->ch, BVH_MAX_CHANNELS * J);
    memcpy(m->order, src->order, J);
    memcpy(m->rot_idx, src->rot_idx, 3 * J);
    memcpy(m->ch_str, src->ch_str, BVH_CHSTR * J);
    memcpy(m->trans_slot, src->trans_slot, J * sizeof(int32_t));
    if (E) {
        memcpy(m->end_parents, src->end_parents, E * sizeof(int32_t));
        memcpy(m->end_offsets, src->end_offsets, 3 * E * sizeof(double));
    }
    if (P)
        memcpy(m->trans_joints, src->trans_joints, P * sizeof(int32_t));
}

static size_t name_bytes_of(const mlr_motion *src)
{
    size_t name_bytes = 0;
    for (size_t j = 0; j < src->n_joints; j++)
        name_bytes += strlen(src->names[j]) + 1;
    return name_bytes;
}

mlr_status bvh_motion_fit(mlr_motion **dst, const mlr_motion *src, size_t n_frames,
                          const mlr_allocator *alloc)
{
    const size_t J = src->n_joints, E = src->n_end, P = src->n_trans;
    const size_t name_bytes = name_bytes_of(src);
    motion_blocks b;
    mlr_status s = motion_layout(J, E, name_bytes, n_frames, P, &b);
    if (s != MLR_OK)
        return s;
    mlr_motion *old = *dst;
    if (old && old->block_size >= b.size) {
        const mlr_allocator a = old->alloc;
        const size_t block_size = old->block_size;
        mlr_motion *m = motion_place((unsigned char *)old, &b, J, E, name_bytes, n_frames, P);
        m->alloc = a;
        m->block_size = block_size;
        copy_skeleton(m, src, name_bytes);
        return MLR_OK;
    }
    mlr_motion *m;
    s = bvh_motion_alloc(alloc, J, E, name_bytes, n_frames, P, &m);
    if (s != MLR_OK)
        return s;
    copy_skeleton(m, src, name_bytes);
    mlr_motion_destroy(old);
    *dst = m;
    return MLR_OK;
}

mlr_status mlr_motion_copy_frames(const mlr_motion *src, size_t begin, size_t count,
                                  mlr_motion **out, mlr_diag *diag)
{
    if (!out || !src)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "motion copy: src or out is NULL");
    *out = NULL;
    if (begin > src->n_frames || count > src->n_frames - begin)
        return common__diag_set(
            diag, MLR_E_INVALID_ARG, 0, 0,
            "motion copy: frames [%zu, %zu + %zu) are not within the %zu frames", begin, begin,
            count, src->n_frames);
    const size_t J = src->n_joints, P = src->n_trans;
    const size_t name_bytes = name_bytes_of(src);
    mlr_motion *m;
    mlr_status s = bvh_motion_alloc(&src->alloc, J, src->n_end, name_bytes, count, P, &m);
    if (s != MLR_OK)
        return common__diag_set(diag, s, 0, 0, "motion copy: %zu frames of %zu joints: %s", count,
                                J, mlr_status_string(s));
    copy_skeleton(m, src, name_bytes);
    if (count) {
        memcpy(m->root_pos, src->root_pos + 3 * begin, 3 * count * sizeof(double));
        memcpy(m->rot, src->rot + 4 * J * begin, 4 * J * count * sizeof(double));
        if (P)
            memcpy(m->trans, src->trans + 3 * P * begin, 3 * P * count * sizeof(double));
    }
    *out = m;
    return MLR_OK;
}

/* ---- accessors --------------------------------------------------------------------------- */

size_t mlr_motion_n_joints(const mlr_motion *m) { return m ? m->n_joints : 0; }
size_t mlr_motion_n_frames(const mlr_motion *m) { return m ? m->n_frames : 0; }
size_t mlr_motion_n_channels(const mlr_motion *m) { return m ? m->n_channels : 0; }
double mlr_motion_frame_time(const mlr_motion *m) { return m ? m->frame_time : 0.0; }

mlr_status mlr_motion_set_frame_time(mlr_motion *m, double frame_time)
{
    if (!m || !isfinite(frame_time) || frame_time <= 0.0)
        return MLR_E_INVALID_ARG;
    m->frame_time = frame_time;
    return MLR_OK;
}

const char *mlr_motion_joint_name(const mlr_motion *m, size_t j)
{
    return (m && j < m->n_joints) ? m->names[j] : NULL;
}

const int32_t *mlr_motion_parents(const mlr_motion *m) { return m ? m->parents : NULL; }
const double *mlr_motion_offsets(const mlr_motion *m) { return m ? m->offsets : NULL; }

size_t mlr_motion_joint_n_channels(const mlr_motion *m, size_t j)
{
    return (m && j < m->n_joints) ? m->n_ch[j] : 0;
}

size_t mlr_motion_joint_channel_codes(const mlr_motion *m, size_t j, unsigned char *codes)
{
    if (!m || j >= m->n_joints || !codes)
        return 0;
    memcpy(codes, m->ch + BVH_MAX_CHANNELS * j, m->n_ch[j]);
    return m->n_ch[j];
}

const char *mlr_motion_joint_channels(const mlr_motion *m, size_t j)
{
    return (m && j < m->n_joints) ? m->ch_str + BVH_CHSTR * j : NULL;
}

int mlr_motion_joint_has_position(const mlr_motion *m, size_t j)
{
    if (!m || j >= m->n_joints)
        return 0;
    for (size_t k = 0; k < m->n_ch[j]; k++)
        if (m->ch[BVH_MAX_CHANNELS * j + k] < 3)
            return 1;
    return 0;
}

mlr_euler_order mlr_motion_joint_euler_order(const mlr_motion *m, size_t j)
{
    return (m && j < m->n_joints) ? (mlr_euler_order)m->order[j] : MLR_EULER_XYZ;
}

/* The J strings str(m, j) one after another with their NULs into buf (when cap allows);
 * returns their size. */
static size_t pack_strings(const mlr_motion *m, const char *(*str)(const mlr_motion *, size_t),
                           char *buf, size_t cap)
{
    if (!m)
        return 0;
    size_t need = 0;
    for (size_t j = 0; j < m->n_joints; j++)
        need += strlen(str(m, j)) + 1;
    if (buf && cap >= need) {
        for (size_t j = 0; j < m->n_joints; j++) {
            const char *t = str(m, j);
            const size_t n = strlen(t) + 1;
            memcpy(buf, t, n);
            buf += n;
        }
    }
    return need;
}

size_t mlr_motion_joint_names_packed(const mlr_motion *m, char *buf, size_t cap)
{
    return pack_strings(m, mlr_motion_joint_name, buf, cap);
}

size_t mlr_motion_joint_channels_packed(const mlr_motion *m, char *buf, size_t cap)
{
    return pack_strings(m, mlr_motion_joint_channels, buf, cap);
}

size_t mlr_motion_joint_euler_orders(const mlr_motion *m, int32_t *out)
{
    if (!m || !out)
        return 0;
    for (size_t j = 0; j < m->n_joints; j++)
        out[j] = (int32_t)m->order[j];
    return m->n_joints;
}

size_t mlr_motion_n_end_sites(const mlr_motion *m) { return m ? m->n_end : 0; }
const int32_t *mlr_motion_end_site_parents(const mlr_motion *m)
{
    return m ? m->end_parents : NULL;
}
const double *mlr_motion_end_site_offsets(const mlr_motion *m)
{
    return m ? m->end_offsets : NULL;
}
const double *mlr_motion_root_pos(const mlr_motion *m) { return m ? m->root_pos : NULL; }
double *mlr_motion_root_pos_mut(mlr_motion *m) { return m ? m->root_pos : NULL; }
const double *mlr_motion_rot(const mlr_motion *m) { return m ? m->rot : NULL; }
double *mlr_motion_rot_mut(mlr_motion *m) { return m ? m->rot : NULL; }
size_t mlr_motion_n_trans(const mlr_motion *m) { return m ? m->n_trans : 0; }
const int32_t *mlr_motion_trans_joints(const mlr_motion *m) { return m ? m->trans_joints : NULL; }
const double *mlr_motion_trans(const mlr_motion *m) { return m ? m->trans : NULL; }
double *mlr_motion_trans_mut(mlr_motion *m) { return m ? m->trans : NULL; }
