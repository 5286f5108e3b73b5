/*
 * The depth-first order of a joint tree given in any order (SMPL's joint list, a glTF node
 * list, parents after their children), for callers that build a skeleton from such arrays:
 * the rest of the library takes joints in depth-first order.
 */
#include "common/mlr_internal.h"

#include <stdio.h>
#include <string.h>

/* "'Name' (index j)" or "j" into buf. */
static const char *joint_label(const char *const *names, size_t j, char *buf, size_t cap)
{
    if (names && names[j])
        snprintf(buf, cap, "'%s' (index %zu)", names[j], j);
    else
        snprintf(buf, cap, "%zu", j);
    return buf;
}

/* The parents' range, one root, no joint its own parent; *root gets the root. */
static mlr_status check_parents(size_t J, const int32_t *parents, const char *const *names,
                                size_t *root, mlr_diag *diag)
{
    char a[96], b[96];
    size_t n_roots = 0, first = 0, second = 0;
    for (size_t j = 0; j < J; j++) {
        const int32_t p = parents[j];
        if (p < -1 || (p >= 0 && (size_t)p >= J))
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    "depth-first order: joint %s has parent %d, outside -1..%zu",
                                    joint_label(names, j, a, sizeof a), (int)p, J - 1);
        if (p >= 0 && (size_t)p == j)
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    "depth-first order: joint %s is its own parent",
                                    joint_label(names, j, a, sizeof a));
        if (p == -1) {
            if (n_roots == 0)
                first = j;
            else if (n_roots == 1)
                second = j;
            n_roots++;
        }
    }
    if (n_roots == 0)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "depth-first order: the joints must form one tree, found no root "
                                "(no parent -1)");
    if (n_roots > 1)
        return common__diag_set(
            diag, MLR_E_INVALID_ARG, 0, 0,
            "depth-first order: the joints must form one tree, found %zu roots: "
            "joints %s and %s both have parent -1",
            n_roots, joint_label(names, first, a, sizeof a),
            joint_label(names, second, b, sizeof b));
    *root = first;
    return MLR_OK;
}

/* Children lists in input order (start[p] .. start[p + 1] in child[]), then a depth-first
 * walk with an explicit stack; returns the number of joints reached. */
static size_t walk(size_t J, const int32_t *parents, size_t root, size_t *start, int32_t *child,
                   int32_t *stack, int32_t *order)
{
    memset(start, 0, (J + 1) * sizeof *start);
    for (size_t j = 0; j < J; j++)
        if (parents[j] >= 0)
            start[parents[j] + 1]++;
    for (size_t p = 0; p < J; p++)
        start[p + 1] += start[p];
    /* fill with start[] as cursors, then shift it back */
    for (size_t j = 0; j < J; j++)
        if (parents[j] >= 0)
            child[start[parents[j]]++] = (int32_t)j;
    for (size_t p = J; p > 0; p--)
        start[p] = start[p - 1];
    start[0] = 0;
    size_t n = 0, top = 0;
    stack[top++] = (int32_t)root;
    while (top) {
        const int32_t j = stack[--top];
        order[n++] = j;
        for (size_t k = start[j + 1]; k > start[j]; k--) /* reversed: first child on top */
            stack[top++] = child[k - 1];
    }
    return n;
}

mlr_status mlr_rig_depth_first_order(size_t n_joints, const int32_t *parents,
                                     const char *const *names, int32_t *order,
                                     const mlr_allocator *alloc, mlr_diag *diag)
{
    if (!parents || !order)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "depth-first order: parents and order must not be NULL");
    if (n_joints == 0)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "depth-first order: needs at least one joint");
    if (n_joints > (size_t)INT32_MAX)
        return common__diag_set(diag, MLR_E_OVERFLOW, 0, 0,
                                "depth-first order: %zu joints overflow the int32 indices",
                                n_joints);
    const size_t J = n_joints;
    size_t root = 0;
    mlr_status st = check_parents(J, parents, names, &root, diag);
    if (st != MLR_OK)
        return st;
    mlr_allocator a;
    common__allocator_resolve(alloc, &a);
    size_t start_bytes, idx_bytes;
    if (common__mul_size(J + 1, sizeof(size_t), &start_bytes) != MLR_OK ||
        common__mul_size(J, sizeof(int32_t), &idx_bytes) != MLR_OK)
        return common__diag_set(diag, MLR_E_OVERFLOW, 0, 0,
                                "depth-first order: size overflow for %zu joints", J);
    size_t *start = common__alloc(&a, start_bytes);
    int32_t *child = common__alloc(&a, idx_bytes);
    int32_t *stack = common__alloc(&a, idx_bytes);
    if (!start || !child || !stack) {
        st = common__diag_set(diag, MLR_E_NO_MEMORY, 0, 0,
                              "depth-first order: out of memory for %zu joints", J);
    } else {
        const size_t reached = walk(J, parents, root, start, child, stack, order);
        if (reached != J) {
            /* a joint not reached from the root sits on a cycle, or below one: mark the
               reached ones in the J bytes at the start of start[] (it holds J + 1 sizes) */
            unsigned char *seen = (unsigned char *)start;
            memset(seen, 0, J);
            for (size_t k = 0; k < reached; k++)
                seen[order[k]] = 1;
            size_t j = 0;
            while (seen[j])
                j++;
            char b[96];
            st = common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                  "depth-first order: joint %s is not below the root (its parents "
                                  "form a cycle)",
                                  joint_label(names, j, b, sizeof b));
        }
    }
    if (start)
        common__free(&a, start, start_bytes);
    if (child)
        common__free(&a, child, idx_bytes);
    if (stack)
        common__free(&a, stack, idx_bytes);
    return st;
}
