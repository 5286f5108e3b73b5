/*
 * The feet of the contact cleanup's points: ankles (anchors) and the points placed on them.
 */
#include "guards/cleanup_internal.h"

static int has_ancestor_in(const int32_t *parents, int32_t j, const uint8_t *listed)
{
    for (int32_t p = parents[j]; p >= 0; p = parents[p])
        if (listed[p])
            return 1;
    return 0;
}

mlr_status cleanup__assign_feet(const mlr_rig *rig, size_t C, const int32_t *joints,
                                const int32_t *end_sites, cleanup_foot *feet, size_t *nf_out,
                                uint8_t *listed, uint8_t *assigned, mlr_diag *diag)
{
    mlr_status st = MLR_OK;
    size_t nf = 0;
    for (size_t c = 0; c < C; c++)
        if (!end_sites || end_sites[c] < 0)
            listed[joints[c]] = 1;
    for (size_t c = 0; c < C; c++) { /* ankles: listed joints with no listed ancestor */
        const int32_t j = joints[c];
        if ((end_sites && end_sites[c] >= 0) || has_ancestor_in(rig->parents, j, listed))
            continue;
        size_t k = 0;
        while (k < nf && feet[k].anchor != j)
            k++;
        if (k == nf) {
            memset(&feet[nf], 0, sizeof feet[nf]);
            feet[nf++].anchor = j;
        }
        if (feet[k].n_cols == 16) {
            st = common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                  "cleanup: more than 16 contact "
                                  "points on the foot of joint %d",
                                  (int)j);
            return st;
        }
        feet[k].cols[feet[k].n_cols++] = c, feet[k].n_own++;
        assigned[c] = 1;
    }
    for (size_t c = 0; c < C; c++) {
        if (assigned[c])
            continue;
        const int32_t j = joints[c];
        const int es = end_sites && end_sites[c] >= 0;
        int32_t anchor = es ? j : -1;
        for (int32_t p = es ? j : rig->parents[j]; p >= 0; p = rig->parents[p])
            for (size_t k = 0; k < nf; k++)
                if (feet[k].anchor == p && feet[k].n_own)
                    anchor = p;
        if (anchor < 0)
            anchor = rig->parents[j];
        if (anchor < 0)
            anchor = j;
        size_t k = 0;
        while (k < nf && feet[k].anchor != anchor)
            k++;
        if (k == nf) {
            memset(&feet[nf], 0, sizeof feet[nf]);
            feet[nf++].anchor = anchor;
        }
        if (feet[k].n_cols == 16) {
            st = common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                  "cleanup: more than 16 contact "
                                  "points on the foot of joint %d",
                                  (int)anchor);
            return st;
        }
        feet[k].cols[feet[k].n_cols++] = c;
    }

    *nf_out = nf;
    return st;
}
