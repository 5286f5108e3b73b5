/* Decimal numbers to doubles: the general path behind mlr_parse_decimal (numparse.h). */
#include "io/numparse.h"

#include <locale.h>
#include <math.h>
#include <stdlib.h>

const double mlr_pow10_exact[23] = {
    1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,  1e8,  1e9,  1e10, 1e11,
    1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
};

/* strtod on a copy, with '.' turned into the locale's decimal point. */
static int parse_number_slow(const char *p, size_t n, double *out)
{
    char buf[256];
    if (n >= sizeof buf)
        return 0;
    const struct lconv *lc = localeconv();
    char dp = (lc && lc->decimal_point && lc->decimal_point[0] && !lc->decimal_point[1])
                  ? lc->decimal_point[0]
                  : '.';
    for (size_t i = 0; i < n; i++)
        buf[i] = p[i] == '.' ? dp : p[i];
    buf[n] = '\0';
    char *endp = NULL;
    double v = strtod(buf, &endp);
    if (endp != buf + n || isinf(v) || isnan(v))
        return 0;
    *out = v;
    return 1;
}

/* Digit by digit. Clinger's fast path: a mantissa of at most 2^53 times or divided by an exact
 * power of ten (up to 10^22) is one correctly rounded operation. Anything else goes to strtod. */
size_t mlr_parse_decimal_general(const char *p, const char *end, double *out)
{
    const char *s = p;
    int neg = 0;
    if (s < end && (*s == '-' || *s == '+')) {
        neg = *s == '-';
        s++;
    }
    uint64_t m = 0;
    int sig = 0, ndig = 0, dropped = 0;
    long e10 = 0;
    while (s < end && (unsigned)(*s - '0') < 10u) {
        unsigned d = (unsigned)(*s - '0');
        if (sig < 19) {
            m = m * 10 + d;
            sig += m != 0;
        } else {
            e10++;
            dropped |= d != 0;
        }
        ndig++;
        s++;
    }
    if (s < end && *s == '.') {
        s++;
        while (s < end && (unsigned)(*s - '0') < 10u) {
            unsigned d = (unsigned)(*s - '0');
            if (sig < 19) {
                m = m * 10 + d;
                sig += m != 0;
                e10--;
            } else {
                dropped |= d != 0;
            }
            ndig++;
            s++;
        }
    }
    if (ndig == 0)
        return 0;
    if (s < end && (*s == 'e' || *s == 'E')) {
        const char *t = s + 1;
        int eneg = 0;
        if (t < end && (*t == '-' || *t == '+')) {
            eneg = *t == '-';
            t++;
        }
        if (t < end && (unsigned)(*t - '0') < 10u) {
            long ev = 0;
            while (t < end && (unsigned)(*t - '0') < 10u) {
                if (ev < 100000)
                    ev = ev * 10 + (*t - '0');
                t++;
            }
            e10 += eneg ? -ev : ev;
            s = t;
        }
    }
    size_t n = (size_t)(s - p);
#if defined(FLT_EVAL_METHOD) && FLT_EVAL_METHOD == 0
    if (!dropped && m <= (UINT64_C(1) << 53)) {
        double v;
        if (m == 0)
            v = 0.0;
        else if (e10 >= 0 && e10 <= 22)
            v = (double)m * mlr_pow10_exact[e10];
        else if (e10 < 0 && e10 >= -22)
            v = (double)m / mlr_pow10_exact[-e10];
        else
            goto slow;
        *out = neg ? -v : v;
        return n;
    }
slow:
#else
    (void)dropped;
    (void)neg;
#endif
    return parse_number_slow(p, n, out) ? n : 0;
}
