/* BVH reader, the text up to the frames: the tokenizer, the HIERARCHY (a single pass, no
 * recursion) and the parsed skeleton into a motion. Errors carry line, column and reason.
 * Nothing here prints or keeps state. */
#include "io/bvh_read_internal.h"
#include "io/numparse.h"

#include <stdarg.h>
#include <stdio.h>

static void *vec_push(vec *v, const mlr_allocator *a)
{
    if (v->len == v->cap) {
        size_t cap = v->cap ? v->cap * 2 : 16, bytes;
        if (cap < v->cap || common__mul_size(cap, v->elsize, &bytes) != MLR_OK)
            return NULL;
        unsigned char *d = common__alloc(a, bytes);
        if (!d)
            return NULL;
        if (v->len)
            memcpy(d, v->data, v->len * v->elsize);
        common__free(a, v->data, v->cap * v->elsize);
        v->data = d;
        v->cap = cap;
    }
    return v->data + v->elsize * v->len++;
}

void bvh__vec_free(vec *v, const mlr_allocator *a)
{
    common__free(a, v->data, v->cap * v->elsize);
    v->data = NULL;
    v->len = v->cap = 0;
}

static mlr_status fail_at_v(parser *ps, const char *at, const char *fmt, va_list ap)
{
    if (ps->diag) {
        ps->diag->line = ps->line;
        ps->diag->column = at ? (size_t)(at - ps->line_start) + 1 : 0;
        vsnprintf(ps->diag->message, sizeof ps->diag->message, fmt, ap);
    }
    return MLR_E_PARSE;
}

mlr_status bvh__fail_at(parser *ps, const char *at, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    const mlr_status s = fail_at_v(ps, at, fmt, ap);
    va_end(ap);
    return s;
}

/* A printable copy of a token for messages: at most 32 bytes, control bytes as '?'. */
shown bvh__show(const char *t, size_t n)
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

static int is_token_char(unsigned char c) { return c > 0x20 && c != 0x7f && c != '{' && c != '}'; }

/* Next token: '{', '}' or a run of other visible bytes. Returns 1 with the token, 0 at the end
 * of the input, MLR_E_PARSE on a control byte. */
int bvh__next_token(parser *ps, const char **tok, size_t *len)
{
    skip_ws(ps);
    if (ps->p >= ps->end)
        return 0;
    const char *t = ps->p;
    unsigned char c = (unsigned char)*t;
    if (c == '{' || c == '}') {
        ps->p++;
    } else if (!is_token_char(c)) {
        return bvh__fail_at(ps, t, "unexpected control byte 0x%02x (binary data?)", c);
    } else {
        while (ps->p < ps->end && is_token_char((unsigned char)*ps->p))
            ps->p++;
        if (ps->p < ps->end) {
            unsigned char d = (unsigned char)*ps->p;
            if ((d < 0x20 && !is_blank((char)d) && !is_eol((char)d)) || d == 0x7f)
                return bvh__fail_at(ps, ps->p, "unexpected control byte 0x%02x (binary data?)", d);
        }
    }
    *tok = t;
    *len = (size_t)(ps->p - t);
    return 1;
}

mlr_status bvh__need_token(parser *ps, const char **tok, size_t *len, const char *fmt, ...)
{
    const int r = bvh__next_token(ps, tok, len);
    if (r > 0)
        return MLR_OK;
    if (r < 0)
        return (mlr_status)r;
    va_list ap;
    va_start(ap, fmt);
    const mlr_status s = fail_at_v(ps, ps->p, fmt, ap);
    va_end(ap);
    return s;
}

int bvh__tok_is(const char *t, size_t n, const char *kw)
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
mlr_status bvh__expect(parser *ps, const char *kw, const char *what)
{
    const char *t;
    size_t n;
    mlr_status s =
        bvh__need_token(ps, &t, &n, "unexpected end of file: expected '%s' %s", kw, what);
    if (s != MLR_OK)
        return s;
    if (!bvh__tok_is(t, n, kw))
        return bvh__fail_at(ps, t, "expected '%s' %s, found '%s'", kw, what, bvh__show(t, n).s);
    return MLR_OK;
}

static mlr_status expect_number(parser *ps, double *out, const char *what)
{
    const char *t = NULL;
    size_t n = 0;
    mlr_status s = bvh__need_token(ps, &t, &n, "unexpected end of file: expected %s", what);
    if (s != MLR_OK)
        return s;
    if (mlr_parse_decimal(t, t + n, out) != n)
        return bvh__fail_at(ps, t, "expected %s, found '%s'", what, bvh__show(t, n).s);
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
            return bvh__fail_at(ps, ps->p, "unexpected control byte 0x%02x in a %s name", c, kw);
        ps->p++;
    }
    const char *e = ps->p;
    while (e > t && is_blank(e[-1]))
        e--;
    if (e == t)
        return bvh__fail_at(ps, t, "%s without a name", kw);
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
        return bvh__fail_at(ps, ps->p, "too many joints");
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
    return bvh__expect(ps, "{", "after the joint name");
}

static const char *joint_name(parser *ps, int32_t j)
{
    return (const char *)ps->names.data + ((tjoint *)ps->joints.data)[j].name_off;
}

static mlr_status parse_channels(parser *ps, tjoint *jt, int32_t j)
{
    const char *t;
    size_t n;
    mlr_status s = bvh__need_token(ps, &t, &n, "unexpected end of file after CHANNELS");
    if (s != MLR_OK)
        return s;
    size_t count = 0;
    for (size_t i = 0; i < n; i++) {
        if (t[i] < '0' || t[i] > '9' || count > 6) {
            count = 99;
            break;
        }
        count = count * 10 + (size_t)(t[i] - '0');
    }
    if (count > BVH_MAX_CHANNELS)
        return bvh__fail_at(ps, t, "CHANNELS count must be 0 to 6, found '%s'", bvh__show(t, n).s);
    unsigned seen = 0;
    for (size_t k = 0; k < count; k++) {
        s = bvh__need_token(ps, &t, &n, "unexpected end of file in CHANNELS of joint '%s'",
                            joint_name(ps, j));
        if (s != MLR_OK)
            return s;
        int c = bvh_channel_parse(t, n);
        if (c < 0) {
            if (bvh__tok_is(t, n, "JOINT") || bvh__tok_is(t, n, "End") || bvh__tok_is(t, n, "}") ||
                bvh__tok_is(t, n, "OFFSET") || bvh__tok_is(t, n, "{"))
                return bvh__fail_at(ps, t, "CHANNELS %zu lists only %zu channel names", count, k);
            return bvh__fail_at(ps, t, "unknown channel '%s'", bvh__show(t, n).s);
        }
        if (seen & (1u << c))
            return bvh__fail_at(ps, t, "channel %s listed twice", bvh_channel_name(c));
        seen |= 1u << c;
        jt->ch[k] = (unsigned char)c;
    }
    jt->n_ch = (unsigned char)count;
    jt->has_channels = 1;
    return MLR_OK;
}

static mlr_status parse_end_site(parser *ps, int32_t parent)
{
    mlr_status s = bvh__expect(ps, "Site", "after 'End'");
    if (s == MLR_OK)
        s = bvh__expect(ps, "{", "after 'End Site'");
    if (s == MLR_OK)
        s = bvh__expect(ps, "OFFSET", "in End Site");
    if (ps->ends.len >= BVH_MAX_JOINTS)
        return bvh__fail_at(ps, ps->p, "too many End Sites");
    tend *e = s == MLR_OK ? vec_push(&ps->ends, &ps->a) : NULL;
    if (s == MLR_OK && !e)
        s = MLR_E_NO_MEMORY;
    for (int k = 0; k < 3 && s == MLR_OK; k++)
        s = expect_number(ps, &e->offset[k], "a number in the End Site OFFSET");
    if (s == MLR_OK)
        s = bvh__expect(ps, "}", "to close the End Site");
    if (s == MLR_OK) {
        e->parent = parent;
        ((tjoint *)ps->joints.data)[parent].n_end++;
    }
    return s;
}

mlr_status bvh__parse_hierarchy(parser *ps)
{
    const char *t;
    size_t n;
    mlr_status s = bvh__need_token(ps, &t, &n, "empty input: expected HIERARCHY");
    if (s != MLR_OK)
        return s;
    if (!bvh__tok_is(t, n, "HIERARCHY"))
        return bvh__fail_at(ps, t, "expected HIERARCHY at the start, found '%s'",
                            bvh__show(t, n).s);
    s = bvh__expect(ps, "ROOT", "after HIERARCHY");
    int32_t cur = -1;
    if (s == MLR_OK)
        s = open_joint(ps, "ROOT", -1, &cur);
    while (s == MLR_OK && cur >= 0) {
        s = bvh__need_token(ps, &t, &n, "unexpected end of file in joint '%s' (missing '}')",
                            joint_name(ps, cur));
        if (s != MLR_OK)
            return s;
        tjoint *jt = (tjoint *)ps->joints.data + cur;
        if (bvh__tok_is(t, n, "JOINT")) {
            s = open_joint(ps, "JOINT", cur, &cur);
        } else if (bvh__tok_is(t, n, "End")) {
            s = parse_end_site(ps, cur);
        } else if (bvh__tok_is(t, n, "OFFSET")) {
            if (jt->has_offset)
                return bvh__fail_at(ps, t, "second OFFSET in joint '%s'", joint_name(ps, cur));
            for (int k = 0; k < 3 && s == MLR_OK; k++)
                s = expect_number(ps, &jt->offset[k], "a number in OFFSET");
            jt->has_offset = 1;
        } else if (bvh__tok_is(t, n, "CHANNELS")) {
            if (jt->has_channels)
                return bvh__fail_at(ps, t, "second CHANNELS in joint '%s'", joint_name(ps, cur));
            s = parse_channels(ps, jt, cur);
        } else if (bvh__tok_is(t, n, "}")) {
            if (!jt->has_offset)
                return bvh__fail_at(ps, t, "joint '%s' has no OFFSET", joint_name(ps, cur));
            cur = jt->parent;
        } else if (bvh__tok_is(t, n, "ROOT")) {
            return bvh__fail_at(ps, t, "ROOT inside joint '%s' (missing '}')",
                                joint_name(ps, cur));
        } else if (bvh__tok_is(t, n, "MOTION")) {
            return bvh__fail_at(ps, t, "MOTION inside joint '%s' (missing '}')",
                                joint_name(ps, cur));
        } else {
            return bvh__fail_at(ps, t, "unexpected '%s' in joint '%s'", bvh__show(t, n).s,
                                joint_name(ps, cur));
        }
    }
    return s;
}

/* "Frames:" or "Frame Time:" followed by its value, possibly glued to the colon. */
mlr_status bvh__read_header_value(parser *ps, const char *label, const char **vt, size_t *vn)
{
    const char *t;
    size_t n;
    mlr_status s = bvh__need_token(ps, &t, &n, "unexpected end of file: expected '%s'", label);
    if (s != MLR_OK)
        return s;
    size_t ln = strlen(label);
    if (n < ln || !bvh__tok_is(t, ln, label))
        return bvh__fail_at(ps, t, "expected '%s', found '%s'", label, bvh__show(t, n).s);
    if (n > ln) {
        *vt = t + ln;
        *vn = n - ln;
        return MLR_OK;
    }
    skip_blank(ps);
    if (ps->p >= ps->end || is_eol(*ps->p))
        return bvh__fail_at(ps, ps->p, "missing value after '%s'", label);
    const int r = bvh__next_token(ps, vt, vn);
    return r < 0 ? (mlr_status)r : MLR_OK;
}

mlr_status bvh__build_motion(parser *ps, size_t n_frames, double frame_time, mlr_motion **out)
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
