/* Decimal numbers to doubles, correctly rounded, for the text readers. Not installed.
 *
 * mlr_parse_decimal reads an optional sign, digits with an optional '.' and fraction, and an
 * optional exponent ("e-5"); no nan, inf, hex or leading blanks. The result is the correctly
 * rounded double (as strtod in the "C" locale). It returns the number of characters consumed,
 * 0 when there is no number at p or it is out of range (overflows to infinity). It never reads
 * at or past end, and accepts as much as forms a number (the caller checks what follows).
 *
 * The inline fast path covers what motion files hold: up to 7 integer and 7 fraction digits,
 * no exponent, at least 18 bytes before end. It reads the digits eight bytes at a time (SWAR)
 * and forms the value as m / 10^f with m < 10^14 < 2^53 and f <= 7: an exactly representable
 * integer divided by an exact power of ten is a single correctly rounded operation (Clinger's
 * fast path). Everything else goes to mlr_parse_decimal_general (the same fast path digit by
 * digit for up to 19 significant digits and powers of ten up to 22, else strtod). */
#ifndef MLR_NUMPARSE_H
#define MLR_NUMPARSE_H

#include <float.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

size_t mlr_parse_decimal_general(const char *p, const char *end, double *out);

/* Exact powers of ten 10^0 .. 10^22 (as doubles). */
extern const double mlr_pow10_exact[23];

#if defined(__GNUC__) && defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__ && \
    defined(FLT_EVAL_METHOD) && FLT_EVAL_METHOD == 0
#define MLR_NUMPARSE_SWAR 1

/* The leading decimal digits among the 8 bytes at s (all readable): their count (0 to 8) and,
 * when the count is below 8, their value. */
static inline unsigned mlr_digits8(const char *s, uint32_t *value)
{
    uint64_t v;
    memcpy(&v, s, 8);
    /* Per byte, t = byte - '0'; a byte is a digit when t <= 9. A borrow or carry between bytes
     * only starts at a non-digit byte and only reaches later bytes, so the first flagged byte is
     * the first non-digit. */
    const uint64_t t = v - UINT64_C(0x3030303030303030);
    const uint64_t bad = (t | (t + UINT64_C(0x7676767676767676))) & UINT64_C(0x8080808080808080);
    if (!bad)
        return 8;
    const unsigned n = (unsigned)__builtin_ctzll(bad) >> 3;
    if (n == 0) {
        *value = 0;
        return 0;
    }
    /* Keep the n digits, moved to the top bytes (the bytes below act as leading zeros), then
     * combine pairs, quads and octets with multiplications. */
    uint64_t d = t << (8 * (8 - n));
    d = d * 10 + (d >> 8);
    d = (((d & UINT64_C(0x000000FF000000FF)) * UINT64_C(0x000F424000000064)) +
         (((d >> 16) & UINT64_C(0x000000FF000000FF)) * UINT64_C(0x0000271000000001))) >>
        32;
    *value = (uint32_t)d;
    return n;
}
#endif

static inline size_t mlr_parse_decimal(const char *p, const char *end, double *out)
{
#ifdef MLR_NUMPARSE_SWAR
    static const uint64_t pow10_u[8] = {1, 10, 100, 1000, 10000, 100000, 1000000, 10000000};
    if (end - p >= 18) { /* sign, 8 bytes, '.', 8 bytes */
        const char *s = p;
        const int neg = *s == '-';
        s += neg | (*s == '+');
        uint32_t ip, fp = 0;
        const unsigned ni = mlr_digits8(s, &ip);
        unsigned nf = 0;
        if (ni < 8) {
            s += ni;
            if (*s == '.') {
                nf = mlr_digits8(s + 1, &fp);
                s += 1 + nf;
            }
            if (nf < 8 && ni + nf > 0 && s < end && (*s | 0x20) != 'e') {
                const double v = (double)(int64_t)(ip * pow10_u[nf] + fp) / mlr_pow10_exact[nf];
                /* the sign as a bit, not a branch: signs of motion values are unpredictable */
                uint64_t bits;
                memcpy(&bits, &v, sizeof bits);
                bits |= (uint64_t)neg << 63;
                memcpy(out, &bits, sizeof bits);
                return (size_t)(s - p);
            }
        }
    }
#endif
    return mlr_parse_decimal_general(p, end, out);
}

#endif
