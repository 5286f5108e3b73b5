/* Joint patterns as Python's fnmatch.fnmatchcase reads them (pipeline_internal.h). */
#include "pipeline/pipeline_internal.h"

/* The code point at s (UTF-8; a byte that starts no valid sequence is itself) and its length. */
static size_t next_cp(const unsigned char *s, uint32_t *cp)
{
    const unsigned c = s[0];
    size_t n = c < 0x80 ? 1 : (c >> 5) == 0x6 ? 2 : (c >> 4) == 0xE ? 3 : (c >> 3) == 0x1E ? 4 : 0;
    if (n <= 1) {
        *cp = c;
        return 1;
    }
    uint32_t v = c & (0x7Fu >> n);
    for (size_t k = 1; k < n; k++) {
        if ((s[k] & 0xC0) != 0x80) { /* a broken sequence: the byte alone */
            *cp = c;
            return 1;
        }
        v = (v << 6) | (s[k] & 0x3F);
    }
    *cp = v;
    return n;
}

/* The class that starts at pat[0] == '[': its end (one past ']') in *end, or 0 when there is
 * no closing ']' (the '[' is then a literal). As fnmatch.translate: a '!' first, then a ']'
 * first, are members of the syntax, not the end. */
static int class_end(const unsigned char *pat, const unsigned char **end)
{
    const unsigned char *j = pat + 1;
    if (*j == '!')
        j++;
    if (*j == ']')
        j++;
    while (*j && *j != ']')
        j++;
    if (!*j)
        return 0;
    *end = j + 1;
    return 1;
}

/* Whether cp is in the class pat[1 .. end - 2] (between '[' and ']'). */
static int class_match(const unsigned char *pat, const unsigned char *end, uint32_t cp)
{
    const unsigned char *s = pat + 1, *stop = end - 1;
    if (s == stop)
        return 0; /* "[]" cannot be: ']' first is a member; kept for safety */
    int negate = 0;
    if (*s == '!') {
        if (s + 1 == stop)
            return 1; /* "[!]": any character, as fnmatch */
        negate = 1;
        s++;
    }
    int in = 0;
    while (s < stop) {
        uint32_t lo, hi;
        s += next_cp(s, &lo);
        hi = lo;
        if (s + 1 < stop && *s == '-') { /* a range, unless '-' is last */
            s++;
            s += next_cp(s, &hi);
        }
        if (lo <= cp && cp <= hi)
            in = 1;
    }
    return in != negate;
}

/* Match one pattern element at *p against the character at *n; advance both on a match. */
static int match_one(const unsigned char **p, const unsigned char **n)
{
    uint32_t c;
    const size_t len = next_cp(*n, &c);
    const unsigned char *end;
    if (**p == '?') {
        *p += 1;
    } else if (**p == '[' && class_end(*p, &end)) {
        if (!class_match(*p, end, c))
            return 0;
        *p = end;
    } else {
        uint32_t pc;
        const size_t plen = next_cp(*p, &pc);
        if (pc != c)
            return 0;
        *p += plen;
    }
    *n += len;
    return 1;
}

int pipeline__glob_match(const char *pattern, const char *name)
{
    const unsigned char *p = (const unsigned char *)pattern, *n = (const unsigned char *)name;
    const unsigned char *star_p = NULL, *star_n = NULL;
    while (*n) {
        if (*p == '*') {
            while (*p == '*')
                p++;
            star_p = p;
            star_n = n;
            continue;
        }
        if (*p && match_one(&p, &n))
            continue;
        if (!star_p)
            return 0;
        uint32_t c;
        star_n += next_cp(star_n, &c); /* the star takes one more character */
        p = star_p;
        n = star_n;
    }
    while (*p == '*')
        p++;
    return *p == 0;
}
