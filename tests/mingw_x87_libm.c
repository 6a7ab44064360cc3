/* sin, cos, sincos and atan2 as MinGW-w64's libmingwex computes them on x86-64 (mingw-w64-crt's math/x86: one x87
 * instruction, fsin, fcos, fsincos or fpatan, in the x87 unit's 64-bit precision, the result rounded to double),
 * for LD_PRELOAD into a Linux x86-64 process: the linux64 binary of a native FMU then calls these in place of
 * glibc's.  tests/test_fmu_platforms.py uses it to show that the win64 binary's numbers differ from the linux64
 * binary's by the C library's sin, cos and atan2 alone: the win64 DLL links them statically from libmingwex, while
 * the linux64 library calls glibc's.
 *
 * Not a general replacement: no argument reduction (fsin and fcos take |x| < 2^63 only, far beyond the angles of a
 * body's rotation), and errno is not set.
 */
#if !defined(__x86_64__)
#error "the x87 versions of sin, cos and atan2 are for x86-64"
#endif

double sin(double x) {
    long double r;
    __asm__("fsin" : "=t"(r) : "0"((long double)x));
    return (double)r;
}

double cos(double x) {
    long double r;
    __asm__("fcos" : "=t"(r) : "0"((long double)x));
    return (double)r;
}

void sincos(double x, double *sine, double *cosine) {
    long double s, c;
    __asm__("fsincos" : "=t"(c), "=u"(s) : "0"((long double)x));
    *sine = (double)s;
    *cosine = (double)c;
}

double atan2(double y, double x) {
    long double r;
    __asm__("fpatan" : "=t"(r) : "0"((long double)x), "u"((long double)y) : "st(1)");
    return (double)r;
}
