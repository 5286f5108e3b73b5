/*
 * Whole arrays of doubles: order statistics (selection, median) and the finiteness check.
 */
#include "common/mlr_internal.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

static int cmp_double(const void *a, const void *b)
{
    const double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* Reorders v[0..n) so that v[k] is the value a sort would put there, everything before it no
 * larger and everything after it no smaller: quickselect (median-of-three pivots, Hoare
 * partition), O(n) on average; after 2 log2(n) + 8 rounds the rest is sorted (bounded worst
 * case). Values are finite; mlr_internal.h. */
void common__select_kth(double *v, size_t n, size_t k)
{
    size_t lo = 0, hi = n - 1, rounds = 8;
    for (size_t m = n; m > 1; m >>= 1)
        rounds += 2;
    while (hi > lo) {
        if (rounds-- == 0) {
            qsort(v + lo, hi - lo + 1, sizeof(double), cmp_double);
            return;
        }
        const size_t mid = lo + (hi - lo) / 2;
        double a = v[lo], b = v[mid], c = v[hi];
        const double pivot = a < b ? (b < c ? b : (a < c ? c : a)) : (a < c ? a : (b < c ? c : b));
        size_t i = lo, j = hi;
        for (;;) {
            while (v[i] < pivot)
                i++;
            while (v[j] > pivot)
                j--;
            if (i >= j)
                break;
            const double t = v[i];
            v[i] = v[j], v[j] = t;
            i++, j--;
        }
        /* now v[lo..j] <= pivot <= v[j+1..hi] */
        if (k <= j)
            hi = j;
        else
            lo = j + 1;
    }
}

/* numpy's median of n >= 1 finite values (reorders v); mlr_internal.h. */
double common__median(double *v, size_t n)
{
    common__select_kth(v, n, n / 2);
    if (n % 2)
        return v[n / 2];
    double below = v[0]; /* the largest of v[0 .. n/2), all <= v[n/2] */
    for (size_t i = 1; i < n / 2; i++)
        below = v[i] > below ? v[i] : below;
    return 0.5 * (below + v[n / 2]);
}

/* The index of the first value of x[0..n) that is NaN or infinite, or n. A value is not
   finite when its exponent bits are all ones: (bits & EXP) + 2^52 then sets bit 63, and only
   then; blocks of 64 values are tested with integer operations alone (no branch per value,
   so the loop vectorizes), then the block that holds one is searched. */
size_t common__first_nonfinite(const double *x, size_t n)
{
    const uint64_t exp_bits = 0x7ff0000000000000u, one = 0x0010000000000000u;
    size_t k = 0;
    for (; k + 64 <= n; k += 64) {
        uint64_t bad = 0;
        for (size_t i = 0; i < 64; i++) {
            uint64_t b;
            memcpy(&b, x + k + i, sizeof b);
            bad |= (b & exp_bits) + one;
        }
        if (bad >> 63)
            break;
    }
    for (; k < n; k++)
        if (!isfinite(x[k]))
            return k;
    return n;
}
