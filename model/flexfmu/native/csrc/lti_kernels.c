/*
 * lti_kernels.c - evaluation of the parameter-dependent linear system of lti_kernels.h: monomials, assembly,
 * the matrix exponential (scaling and squaring, [13/13] Pade), the cached step and output maps, the step and the
 * outputs.  C99, libc/libm only, no allocation.
 */
#include "lti_kernels.h"

#include <math.h>
#include <string.h>

/* ------------------------------------------------------------------ small helpers */

static int all_finite(const double *v, size_t n) {
    size_t i;
    for (i = 0; i < n; i++) {
        if (!isfinite(v[i])) return 0;
    }
    return 1;
}

/* sum_j a[j] v[j], summed in order j = 0, 1, ... from 0.0 (the order every mat-vec here uses). */
static double dot(const double *a, const double *v, int n) {
    double sum = 0.0;
    int j;
    for (j = 0; j < n; j++) sum += a[j] * v[j];
    return sum;
}

/* to[i] = sum_j M[i][j] v[j] + add[i] (M (rows, n) row-major), each sum in the order of dot().  Four rows at a
 * time: four independent sums keep the adder busy where one sum would wait on its previous add (the per-step
 * mat-vec of a small model is latency-bound); the order within each row, and so every bit, is dot()'s. */
static void matvec_add(const double *M, const double *v, const double *add, int rows, int n, double *to) {
    int i = 0, j;
    for (; i + 4 <= rows; i += 4) {
        const double *m0 = M + (size_t)i * n, *m1 = m0 + n, *m2 = m1 + n, *m3 = m2 + n;
        double s0 = 0.0, s1 = 0.0, s2 = 0.0, s3 = 0.0;
        for (j = 0; j < n; j++) {
            double vj = v[j];
            s0 += m0[j] * vj;
            s1 += m1[j] * vj;
            s2 += m2[j] * vj;
            s3 += m3[j] * vj;
        }
        to[i] = s0 + add[i];
        to[i + 1] = s1 + add[i + 1];
        to[i + 2] = s2 + add[i + 2];
        to[i + 3] = s3 + add[i + 3];
    }
    for (; i < rows; i++) to[i] = dot(M + (size_t)i * n, v, n) + add[i];
}

/* to[i] = sum_j M[i][j] v[j] (M (rows, n) row-major), four rows at a time as matvec_add (the series' products:
 * latency-bound like the step's, so the four independent sums matter more than skipping A's zeros). */
static void matvec(const double *M, const double *v, int rows, int n, double *to) {
    int i = 0, j;
    for (; i + 4 <= rows; i += 4) {
        const double *m0 = M + (size_t)i * n, *m1 = m0 + n, *m2 = m1 + n, *m3 = m2 + n;
        double s0 = 0.0, s1 = 0.0, s2 = 0.0, s3 = 0.0;
        for (j = 0; j < n; j++) {
            double vj = v[j];
            s0 += m0[j] * vj;
            s1 += m1[j] * vj;
            s2 += m2[j] * vj;
            s3 += m3[j] * vj;
        }
        to[i] = s0;
        to[i + 1] = s1;
        to[i + 2] = s2;
        to[i + 3] = s3;
    }
    for (; i < rows; i++) to[i] = dot(M + (size_t)i * n, v, n);
}

/* C = A B, all (n, n) row-major; C must not alias A or B. */
static void matmul(int n, const double *A, const double *B, double *C) {
    int i, j, k;
    for (i = 0; i < n; i++) {
        double *c = C + (size_t)i * n;
        for (j = 0; j < n; j++) c[j] = 0.0;
        for (k = 0; k < n; k++) {
            const double a = A[(size_t)i * n + k];
            const double *b = B + (size_t)k * n;
            if (a == 0.0) continue;
            for (j = 0; j < n; j++) c[j] += a * b[j];
        }
    }
}

/* 1-norm (largest column sum of absolute values) of the (n, n) matrix A. */
static double norm1(int n, const double *A, double *col) {
    int i, j;
    double best = 0.0;
    for (j = 0; j < n; j++) col[j] = 0.0;
    for (i = 0; i < n; i++) {
        for (j = 0; j < n; j++) col[j] += fabs(A[(size_t)i * n + j]);
    }
    for (j = 0; j < n; j++) {
        if (col[j] > best) best = col[j];
    }
    return best;
}

/* to = from^T |A| (the row vector of column sums of |A| weighted by from), |A| given as absA. */
static void spin(int n, const double *absA, const double *from, double *to) {
    int i, j;
    for (j = 0; j < n; j++) to[j] = 0.0;
    for (i = 0; i < n; i++) {
        const double f = from[i];
        const double *row = absA + (size_t)i * n;
        for (j = 0; j < n; j++) to[j] += f * row[j];
    }
}

static double vmax(int n, const double *v) {
    int i;
    double best = 0.0;
    for (i = 0; i < n; i++) {
        if (v[i] > best) best = v[i];
    }
    return best;
}

/* ------------------------------------------------------------------ model, monomials, assembly */

int ffx_lti_check_model(const ffx_lti_model *m) {
    int k, nz;
    if (m == NULL) return FFX_LTI_BAD_ARGUMENT;
    if (m->nx < 0 || m->nu < 0 || m->ny < 0 || m->np < 0 || m->nquad < 0) return FFX_LTI_BAD_ARGUMENT;
    if (m->nmono != FFX_LTI_N_MONOMIALS(m->np)) return FFX_LTI_BAD_ARGUMENT;
    if ((m->nx > 0 && (m->A == NULL || m->b == NULL)) || (m->nx > 0 && m->nu > 0 && m->B == NULL))
        return FFX_LTI_BAD_ARGUMENT;
    if (m->ny > 0 && (m->y0 == NULL || (m->nx > 0 && m->Cx == NULL) || (m->nu > 0 && m->Cu == NULL)))
        return FFX_LTI_BAD_ARGUMENT;
    if (m->nquad > 0 && (m->quad_row == NULL || m->quad_i == NULL || m->quad_j == NULL || m->quad_value == NULL))
        return FFX_LTI_BAD_ARGUMENT;
    nz = m->nx + m->nu + m->nmono;
    for (k = 0; k < m->nquad; k++) {
        if (m->quad_row[k] < 0 || m->quad_row[k] >= m->ny || m->quad_i[k] < 0 || m->quad_i[k] >= nz || m->quad_j[k] < 0
            || m->quad_j[k] >= nz)
            return FFX_LTI_BAD_ARGUMENT;
    }
    if (m->quad_start != NULL) {
        int r;
        if (m->quad_start[0] != 0 || m->quad_start[m->ny] != m->nquad) return FFX_LTI_BAD_ARGUMENT;
        for (r = 0; r < m->ny; r++) {
            if (m->quad_start[r + 1] < m->quad_start[r]) return FFX_LTI_BAD_ARGUMENT;
            for (k = m->quad_start[r]; k < m->quad_start[r + 1]; k++)
                if (m->quad_row[k] != r) return FFX_LTI_BAD_ARGUMENT;
        }
    }
    return FFX_LTI_OK;
}

int ffx_lti_quad_starts(const ffx_lti_model *m, int *quad_start) {
    int k, r = 0;
    for (k = 1; k < m->nquad; k++)
        if (m->quad_row[k] < m->quad_row[k - 1]) return 0;
    quad_start[0] = 0;
    for (k = 0; k < m->nquad; k++)
        while (r < m->quad_row[k]) quad_start[++r] = k;
    while (r < m->ny) quad_start[++r] = m->nquad;
    return 1;
}

void ffx_lti_monomials(int np, const double *p, double *mono) {
    int i, j, k = 1 + np;
    mono[0] = 1.0;
    for (i = 0; i < np; i++) mono[1 + i] = p[i];
    for (i = 0; i < np; i++) {
        for (j = i; j < np; j++) mono[k++] = p[i] * p[j];
    }
}

/* out (len) = sum_k mono[k] coef[k] (coef: (nmono, len)); monomials that are zero are skipped. */
static void combine(int nmono, size_t len, const double *coef, const double *mono, double *out) {
    int k;
    size_t i;
    for (i = 0; i < len; i++) out[i] = coef[i]; /* mono[0] = 1 */
    for (k = 1; k < nmono; k++) {
        const double c = mono[k];
        const double *a = coef + (size_t)k * len;
        if (c == 0.0) continue;
        for (i = 0; i < len; i++) out[i] += c * a[i];
    }
}

/* combine() over the monomials whose block is in use (used[k] != 0): an all-zero block adds nothing (but the sign
 * of a zero).  The cached maps and the rows assembled alone (ffx_lti_output_rows) both go through it, entry by entry
 * in the same order: the same bits. */
static void combine_used(int nmono, size_t len, const double *coef, const double *mono, const double *used,
                         double *out) {
    int k;
    size_t i;
    for (i = 0; i < len; i++) out[i] = coef[i];
    for (k = 1; k < nmono; k++) {
        const double c = mono[k];
        const double *a = coef + (size_t)k * len;
        if (c == 0.0 || used[k] == 0.0) continue;
        for (i = 0; i < len; i++) out[i] += c * a[i];
    }
}

/* row r (len entries) of a (nmono, rows, len) coefficient array, combined as combine_used does for that row */
static void combine_row(int nmono, size_t rows, size_t len, size_t r, const double *coef, const double *mono,
                        const double *used, double *out) {
    int k;
    size_t i;
    const double *c0 = coef + r * len;
    for (i = 0; i < len; i++) out[i] = c0[i];
    for (k = 1; k < nmono; k++) {
        const double c = mono[k];
        const double *a = coef + ((size_t)k * rows + r) * len;
        if (c == 0.0 || used[k] == 0.0) continue;
        for (i = 0; i < len; i++) out[i] += c * a[i];
    }
}

void ffx_lti_assemble_dynamics(const ffx_lti_model *m, const double *mono, double *A, double *B, double *b) {
    const size_t nx = (size_t)m->nx, nu = (size_t)m->nu;
    if (nx == 0) return;
    combine(m->nmono, nx * nx, m->A, mono, A);
    if (nu > 0) combine(m->nmono, nx * nu, m->B, mono, B);
    combine(m->nmono, nx, m->b, mono, b);
}

void ffx_lti_assemble_outputs(const ffx_lti_model *m, const double *mono, double *Cx, double *Cu, double *y0) {
    const size_t nx = (size_t)m->nx, nu = (size_t)m->nu, ny = (size_t)m->ny;
    if (ny == 0) return;
    if (nx > 0) combine(m->nmono, ny * nx, m->Cx, mono, Cx);
    if (nu > 0) combine(m->nmono, ny * nu, m->Cu, mono, Cu);
    combine(m->nmono, ny, m->y0, mono, y0);
}

/* ------------------------------------------------------------------ matrix exponential */

/* [13/13] Pade coefficients b_0 .. b_13 (Higham 2005, Table 2.3 / scipy) */
static const double PADE13[14] = {64764752532480000.0,
                                  32382376266240000.0,
                                  7771770303897600.0,
                                  1187353796428800.0,
                                  129060195264000.0,
                                  10559470521600.0,
                                  670442572800.0,
                                  33522128640.0,
                                  1323241920.0,
                                  40840800.0,
                                  960960.0,
                                  16380.0,
                                  182.0,
                                  1.0};
/* theta_13 of Al-Mohy & Higham (2009) and the constant of their backward-error bound for m = 13 (the values
 * scipy.linalg.expm uses) */
static const double THETA13 = 4.25;
static const double ELL13 = 1.2573361865339437e+19;
/* more squarings than 2^-1100 |A| needs for any finite A */
#define MAX_SQUARINGS 1100

size_t ffx_lti_expm_work_len(int n) {
    const size_t nn = (size_t)(n > 0 ? n : 0) * (size_t)(n > 0 ? n : 0);
    return 8 * nn + 3 * (size_t)(n > 0 ? n : 0);
}

/* Solve Q X = P (n, n; X overwrites P) by LU with partial pivoting of Q (overwritten); 0, or 1 if singular. */
static int lu_solve(int n, double *Q, double *P) {
    int i, j, k, piv;
    for (k = 0; k < n; k++) {
        double best = fabs(Q[(size_t)k * n + k]);
        double pivot, inv;
        piv = k;
        for (i = k + 1; i < n; i++) {
            const double v = fabs(Q[(size_t)i * n + k]);
            if (v > best) {
                best = v;
                piv = i;
            }
        }
        if (!(best > 0.0)) return 1;
        if (piv != k) {
            double *r1 = Q + (size_t)k * n, *r2 = Q + (size_t)piv * n;
            for (j = 0; j < n; j++) {
                const double t = r1[j];
                r1[j] = r2[j];
                r2[j] = t;
            }
            r1 = P + (size_t)k * n;
            r2 = P + (size_t)piv * n;
            for (j = 0; j < n; j++) {
                const double t = r1[j];
                r1[j] = r2[j];
                r2[j] = t;
            }
        }
        pivot = Q[(size_t)k * n + k];
        inv = 1.0 / pivot;
        for (i = k + 1; i < n; i++) {
            double *qi = Q + (size_t)i * n, *pi = P + (size_t)i * n;
            const double *qk = Q + (size_t)k * n, *pk = P + (size_t)k * n;
            const double l = qi[k] * inv;
            qi[k] = l;
            if (l == 0.0) continue;
            for (j = k + 1; j < n; j++) qi[j] -= l * qk[j];
            for (j = 0; j < n; j++) pi[j] -= l * pk[j]; /* forward substitution with L */
        }
    }
    for (k = n - 1; k >= 0; k--) { /* back substitution with U */
        double *pk = P + (size_t)k * n;
        const double *qk = Q + (size_t)k * n;
        const double inv = 1.0 / qk[k];
        for (i = k + 1; i < n; i++) {
            const double u = qk[i];
            const double *pi = P + (size_t)i * n;
            if (u == 0.0) continue;
            for (j = 0; j < n; j++) pk[j] -= u * pi[j];
        }
        for (j = 0; j < n; j++) pk[j] *= inv;
    }
    return 0;
}

int ffx_lti_expm(int n, const double *M, double *E, double *work) {
    const size_t nn = (size_t)(n > 0 ? n : 0) * (size_t)(n > 0 ? n : 0);
    double *A = work, *A2 = work + nn, *A4 = work + 2 * nn, *A6 = work + 3 * nn;
    double *U = work + 4 * nn, *V = work + 5 * nn, *T = work + 6 * nn, *absA = work + 7 * nn;
    double *v0 = work + 8 * nn, *v1 = v0 + n, *col = v1 + n;
    double normA, d6, d8, d10, eta, ratio;
    const double *b = PADE13;
    int s = 0, i, j, k;
    size_t q;

    if (n < 0 || (n > 0 && (M == NULL || E == NULL || work == NULL))) return FFX_LTI_BAD_ARGUMENT;
    if (n == 0) return FFX_LTI_OK;
    if (!all_finite(M, nn)) {
        for (q = 0; q < nn; q++) E[q] = NAN;
        return FFX_LTI_NONFINITE;
    }
    memcpy(A, M, nn * sizeof(double));
    for (q = 0; q < nn; q++) absA[q] = fabs(A[q]);
    for (i = 0; i < n; i++) v0[i] = 1.0;
    spin(n, absA, v0, v1); /* ||A||_1 = max of 1^T |A| */
    normA = vmax(n, v1);
    if (normA == 0.0) { /* the zero matrix */
        for (q = 0; q < nn; q++) E[q] = 0.0;
        for (i = 0; i < n; i++) E[(size_t)i * n + i] = 1.0;
        return FFX_LTI_OK;
    }

    /* The scaling s of Al-Mohy & Higham (2009) for the degree 13 (as scipy.linalg.expm): from
     * eta = min(max(d6, d8), max(d8, d10)), d_k = ||A^k||_1^(1/k), then raised by the bound on |A|^27. */
    matmul(n, A, A, A2);
    matmul(n, A2, A2, A4);
    matmul(n, A4, A2, A6);
    d6 = pow(norm1(n, A6, col), 1.0 / 6.0);
    matmul(n, A4, A4, T); /* A^8 */
    d8 = pow(norm1(n, T, col), 0.125);
    matmul(n, A6, A4, T); /* A^10 */
    d10 = pow(norm1(n, T, col), 0.1);
    eta = fmin(fmax(d6, d8), fmax(d8, d10));
    if (!isfinite(eta) || !isfinite(normA)) {
        /* powers beyond the double range (|A| > ~1e51): s from the 1-norm (Higham 2005), the powers of 2^-s A
         * recomputed, no further bound; the result then mostly overflows, reported by the final check */
        const double r = isfinite(normA) ? ceil(log2(normA / THETA13)) : (double)MAX_SQUARINGS;
        const double s0 = ldexp(1.0, -(s = r < MAX_SQUARINGS ? (int)r : MAX_SQUARINGS));
        for (q = 0; q < nn; q++) A[q] *= s0;
        matmul(n, A, A, A2);
        matmul(n, A2, A2, A4);
        matmul(n, A4, A2, A6);
        goto pade;
    }
    if (eta > THETA13) {
        const double r = ceil(log2(eta / THETA13));
        s = r > 0.0 ? (r < MAX_SQUARINGS ? (int)r : MAX_SQUARINGS) : 0;
    }
    /* || |2^-s A|^27 ||_1 by 27 products 1^T |A| ...; the first is v1 */
    {
        const double scale = ldexp(1.0, -s);
        double *from = v1, *to = v0, *t;
        for (q = 0; q < nn; q++) absA[q] *= scale;
        for (i = 0; i < n; i++) v1[i] *= scale;
        normA *= scale;
        for (k = 1; k < 27; k++) {
            spin(n, absA, from, to);
            t = from;
            from = to;
            to = t;
        }
        ratio = vmax(n, from) / normA / ELL13;
        if (ratio > 1.0 && isfinite(ratio)) {
            const double r = ceil(log2(ratio) / 26.0);
            s += r > 0.0 ? (r < MAX_SQUARINGS ? (int)r : MAX_SQUARINGS) : 0;
        }
    }
    if (s > 0) {
        const double s0 = ldexp(1.0, -s), s1 = ldexp(1.0, -2 * s), s2 = ldexp(1.0, -4 * s), s3 = ldexp(1.0, -6 * s);
        for (q = 0; q < nn; q++) {
            A[q] *= s0;
            A2[q] *= s1;
            A4[q] *= s2;
            A6[q] *= s3;
        }
    }

pade:
    /* U = A [A6 (b13 A6 + b11 A4 + b9 A2) + b7 A6 + b5 A4 + b3 A2 + b1 I]
     * V =    A6 (b12 A6 + b10 A4 + b8 A2) + b6 A6 + b4 A4 + b2 A2 + b0 I */
    for (q = 0; q < nn; q++) T[q] = b[13] * A6[q] + b[11] * A4[q] + b[9] * A2[q];
    matmul(n, A6, T, V);
    for (q = 0; q < nn; q++) V[q] += b[7] * A6[q] + b[5] * A4[q] + b[3] * A2[q];
    for (i = 0; i < n; i++) V[(size_t)i * n + i] += b[1];
    matmul(n, A, V, U);
    for (q = 0; q < nn; q++) T[q] = b[12] * A6[q] + b[10] * A4[q] + b[8] * A2[q];
    matmul(n, A6, T, V);
    for (q = 0; q < nn; q++) V[q] += b[6] * A6[q] + b[4] * A4[q] + b[2] * A2[q];
    for (i = 0; i < n; i++) V[(size_t)i * n + i] += b[0];
    /* R = (V - U)^-1 (V + U) = (V + U) (V - U)^-1 (U and V commute): solved as R (V - U) = V + U, i.e.
     * (V - U)^T R^T = (V + U)^T, as scipy.linalg.expm does (LAPACK on the row-major arrays). */
    for (i = 0; i < n; i++) {
        for (j = 0; j < n; j++) {
            const size_t ij = (size_t)i * n + j, ji = (size_t)j * n + i;
            T[ji] = V[ij] - U[ij];  /* (V - U)^T */
            A2[ji] = V[ij] + U[ij]; /* (V + U)^T, then R^T */
        }
    }
    if (lu_solve(n, T, A2)) return FFX_LTI_SINGULAR;
    for (i = 0; i < n; i++) {
        for (j = 0; j < n; j++) E[(size_t)i * n + j] = A2[(size_t)j * n + i];
    }
    /* A row of M that is zero is that row of I in expm(M) and in the Pade approximant (e_i^T (V - U) = b0 e_i^T):
     * set exactly, so that the squarings do not amplify its rounding (the augmented matrix's last rows: else the
     * input columns Bd, bd would lose ~2^s eps) */
    for (i = 0; i < n; i++) {
        const double *row = M + (size_t)i * n;
        for (j = 0; j < n && row[j] == 0.0; j++) {}
        if (j == n) {
            for (j = 0; j < n; j++) E[(size_t)i * n + j] = (i == j) ? 1.0 : 0.0;
        }
    }
    for (j = 0; j < s; j++) { /* squaring */
        matmul(n, E, E, T);
        memcpy(E, T, nn * sizeof(double));
        if (!all_finite(E, nn)) return FFX_LTI_NONFINITE;
    }
    return all_finite(E, nn) ? FFX_LTI_OK : FFX_LTI_NONFINITE;
}

/* ------------------------------------------------------------------ the moving-base step: rule and norms */

void ffx_lti_balance(int n, const double *A, double *d) {
    int sweep, i, j;
    for (i = 0; i < n; i++) d[i] = 1.0;
    for (sweep = 0; sweep < FFX_LTI_BALANCE_SWEEPS; sweep++) {
        for (i = 0; i < n; i++) {
            double r = 0.0, c = 0.0;
            for (j = 0; j < n; j++) {
                if (j == i) continue;
                r += fabs(A[(size_t)i * n + j]) * d[j];
                c += fabs(A[(size_t)j * n + i]) / d[j];
            }
            if (r > 0.0 && c > 0.0 && isfinite(r) && isfinite(c)) d[i] = sqrt(r / c);
        }
    }
}

/* ||D^-1 A D||_inf, d the weights (n, n). */
static double scaled_norm(int n, const double *A, const double *d) {
    int i, j;
    double best = 0.0;
    for (i = 0; i < n; i++) {
        double sum = 0.0;
        for (j = 0; j < n; j++) sum += fabs(A[(size_t)i * n + j]) * d[j];
        sum /= d[i];
        if (!(sum <= best)) best = sum; /* a NaN wins */
    }
    return best;
}

double ffx_lti_taylor_tail(double theta, int terms) {
    double first = 1.0;
    int k;
    if (!(theta < terms + 2.0)) return INFINITY;
    for (k = 1; k <= terms; k++) first *= theta / (k + 1.0);
    return first / (1.0 - theta / (terms + 2.0));
}

int ffx_lti_taylor_plan(double theta, int *substeps, int *terms) {
    const double u = ldexp(1.0, -53);
    double s, t, first = 1.0;
    int K;
    if (!(isfinite(theta) && theta >= 0.0)) return 0;
    s = ceil(theta / FFX_LTI_THETA_SUBSTEP);
    if (s < 1.0) s = 1.0;
    if (s > 1e9) return 0; /* a step no series takes: the maps */
    t = theta / s;
    for (K = 1; K <= FFX_LTI_MAX_TERMS; K++) { /* t^K / (K+1)!, as ffx_lti_taylor_tail builds it */
        first *= t / (K + 1.0);
        if (t < K + 2.0 && first / (1.0 - t / (K + 2.0)) <= u) {
            *substeps = (int)s;
            *terms = K;
            return 1;
        }
    }
    return 0;
}

/* used flags, weights and norms of the model (ffx_lti_maps_init) */
static void moving_base_init(ffx_lti_maps *maps) {
    const ffx_lti_model *m = maps->model;
    const size_t nx = (size_t)m->nx, nu = (size_t)m->nu, ny = (size_t)m->ny, nmono = (size_t)m->nmono;
    const size_t sizes[6] = {nx * nx, nx * nu, nx, ny * nx, ny * nu, ny};
    const double *arrays[6] = {m->A, m->B, m->b, m->Cx, m->Cu, m->y0};
    size_t a, k, e;
    for (a = 0; a < 6; a++) {
        for (k = 0; k < nmono; k++) {
            double any = 0.0;
            for (e = 0; e < sizes[a] && any == 0.0; e++)
                if (arrays[a][k * sizes[a] + e] != 0.0) any = 1.0;
            maps->used[a * nmono + k] = any;
        }
    }
    if (nx == 0) return;
    for (e = 0; e < nx; e++) { /* the columns of row e that any A_k fills */
        size_t lo = nx, hi = 0, j;
        for (k = 0; k < nmono; k++)
            for (j = 0; j < nx; j++)
                if (m->A[(k * nx + e) * nx + j] != 0.0) {
                    if (j < lo) lo = j;
                    if (j + 1 > hi) hi = j + 1;
                }
        if (hi == 0) lo = 0;
        maps->a_cols[e] = (double)lo;
        maps->a_cols[nx + e] = (double)hi;
    }
    ffx_lti_balance((int)nx, m->A, maps->weights);
    for (k = 0; k < nmono; k++) maps->norms[k] = scaled_norm((int)nx, m->A + k * nx * nx, maps->weights);
}

/* ------------------------------------------------------------------ cached maps */

static size_t aug_n(const ffx_lti_model *m) { return (size_t)m->nx + (size_t)m->nu + 1; }

size_t ffx_lti_maps_work_len(const ffx_lti_model *m) {
    const size_t nx = (size_t)m->nx, nu = (size_t)m->nu, ny = (size_t)m->ny, np = (size_t)m->np;
    const size_t nmono = (size_t)FFX_LTI_N_MONOMIALS(m->np), n = aug_n(m);
    return 2 * np                                                   /* p_step, p_output */
           + nx * nx + nx * nu + nx                                 /* Ad, Bd, bd */
           + ny * nx + ny * nu + ny                                 /* Cx, Cu, y0 */
           + (nx + nu + nmono)                                      /* z */
           + nmono + nx                                             /* mono, x_new */
           + 2 * n * n                                              /* aug, its exponential */
           + ffx_lti_expm_work_len((int)n) + nx + nmono + 6 * nmono /* weights, norms, used */
           + nx * nx + nx                                           /* A_held, g_held */
           + np + nmono                                             /* p_taylor, mono_before */
           + 2 * nx;                                                /* a_cols */
}

int ffx_lti_maps_init(ffx_lti_maps *maps, const ffx_lti_model *m, double *work, size_t work_len) {
    size_t nx, nu, ny, np, n;
    double *w = work;
    if (maps == NULL || ffx_lti_check_model(m) != FFX_LTI_OK) return FFX_LTI_BAD_ARGUMENT;
    if (work == NULL || work_len < ffx_lti_maps_work_len(m)) return FFX_LTI_BAD_ARGUMENT;
    nx = (size_t)m->nx;
    nu = (size_t)m->nu;
    ny = (size_t)m->ny;
    np = (size_t)m->np;
    n = aug_n(m);
    memset(maps, 0, sizeof(*maps));
    maps->model = m;
    maps->p_step = w;
    w += np;
    maps->p_output = w;
    w += np;
    maps->Ad = w;
    w += nx * nx;
    maps->Bd = w;
    w += nx * nu;
    maps->bd = w;
    w += nx;
    maps->Cx = w;
    w += ny * nx;
    maps->Cu = w;
    w += ny * nu;
    maps->y0 = w;
    w += ny;
    maps->z = w;
    w += nx + nu + (size_t)m->nmono;
    maps->mono = w;
    w += (size_t)m->nmono;
    maps->x_new = w;
    w += nx;
    maps->aug = w;
    w += 2 * n * n;
    maps->expm_work = w;
    w += ffx_lti_expm_work_len((int)n);
    maps->weights = w;
    w += nx;
    maps->norms = w;
    w += (size_t)m->nmono;
    maps->used = w;
    w += 6 * (size_t)m->nmono;
    maps->A_held = w;
    w += nx * nx;
    maps->g_held = w;
    w += nx;
    maps->p_taylor = w;
    w += np;
    maps->mono_before = w;
    w += (size_t)m->nmono;
    maps->a_cols = w;
    moving_base_init(maps);
    ffx_lti_maps_invalidate(maps);
    return FFX_LTI_OK;
}

void ffx_lti_maps_invalidate(ffx_lti_maps *maps) {
    maps->step_valid = 0;
    maps->output_valid = 0;
    maps->taylor_ready = 0;
    maps->taylor_last = 0;
}

double ffx_step_rtol(void) { return FFX_STEP_RTOL; }

int ffx_same_step(double cached, double h) { return h == cached || fabs(h - cached) <= FFX_STEP_RTOL * fabs(cached); }

static int same_p(int np, const double *a, const double *p) {
    int i;
    for (i = 0; i < np; i++) {
        if (!(a[i] == p[i])) return 0;
    }
    return 1;
}

int ffx_lti_update_step_maps(ffx_lti_maps *maps, const double *p, double h) {
    const ffx_lti_model *m = maps->model;
    const size_t nx = (size_t)m->nx, nu = (size_t)m->nu, n = aug_n(m);
    double *M = maps->aug, *E = maps->aug + n * n;
    size_t i, j, k;
    int status;

    if (!isfinite(h) || h < 0.0) return FFX_LTI_BAD_ARGUMENT;
    /* a host's last-bit variants of the cached step reuse its maps (FFX_STEP_RTOL: the error bound) */
    if (maps->step_valid && ffx_same_step(maps->h, h) && same_p(m->np, maps->p_step, p)) return FFX_LTI_OK;
    maps->step_valid = 0;
    maps->n_step_updates++;
    ffx_lti_monomials(m->np, p, maps->mono);
    /* M = [[A B b]; [0 0 0]] h, assembled in place (rows of A, B, b side by side) */
    memset(M, 0, n * n * sizeof(double));
    for (i = 0; i < nx; i++) {
        double *row = M + i * n;
        for (j = 0; j < nx; j++) row[j] = m->A[i * nx + j];
        for (j = 0; j < nu; j++) row[nx + j] = m->B[i * nu + j];
        row[nx + nu] = m->b[i];
    }
    for (k = 1; k < (size_t)m->nmono && nx > 0; k++) {
        const double c = maps->mono[k];
        const double *Ak = m->A + k * nx * nx, *Bk = nu > 0 ? m->B + k * nx * nu : NULL, *bk = m->b + k * nx;
        const double *used = maps->used + k;
        const size_t stride = (size_t)m->nmono;
        if (c == 0.0 || (used[0] == 0.0 && used[stride] == 0.0 && used[2 * stride] == 0.0)) continue;
        for (i = 0; i < nx; i++) {
            double *row = M + i * n;
            for (j = 0; j < nx; j++) row[j] += c * Ak[i * nx + j];
            for (j = 0; j < nu; j++) row[nx + j] += c * Bk[i * nu + j];
            row[nx + nu] += c * bk[i];
        }
    }
    for (i = 0; i < nx; i++) {
        for (j = 0; j < n; j++) M[i * n + j] *= h;
    }
    status = ffx_lti_expm((int)n, M, E, maps->expm_work);
    if (status != FFX_LTI_OK) return status;
    for (i = 0; i < nx; i++) {
        const double *row = E + i * n;
        for (j = 0; j < nx; j++) maps->Ad[i * nx + j] = row[j];
        for (j = 0; j < nu; j++) maps->Bd[i * nu + j] = row[nx + j];
        maps->bd[i] = row[nx + nu];
    }
    for (i = 0; i < (size_t)m->np; i++) maps->p_step[i] = p[i];
    maps->h = h;
    maps->step_valid = 1;
    return FFX_LTI_OK;
}

int ffx_lti_update_output_maps(ffx_lti_maps *maps, const double *p) {
    const ffx_lti_model *m = maps->model;
    const size_t nx = (size_t)m->nx, nu = (size_t)m->nu, ny = (size_t)m->ny;
    double *mono = maps->z + nx + nu;
    size_t i;
    if (maps->output_valid && same_p(m->np, maps->p_output, p)) return FFX_LTI_OK;
    maps->output_valid = 0;
    maps->n_output_updates++;
    ffx_lti_monomials(m->np, p, mono);
    if (ny > 0) { /* ffx_lti_assemble_outputs over the blocks in use (combine_row assembles a row alike) */
        const double *used = maps->used + 3 * (size_t)m->nmono;
        if (nx > 0) combine_used(m->nmono, ny * nx, m->Cx, mono, used, maps->Cx);
        if (nu > 0) combine_used(m->nmono, ny * nu, m->Cu, mono, used + m->nmono, maps->Cu);
        combine_used(m->nmono, ny, m->y0, mono, used + 2 * (size_t)m->nmono, maps->y0);
    }
    if (!all_finite(mono, (size_t)m->nmono) || !all_finite(maps->Cx, ny * nx) || !all_finite(maps->Cu, ny * nu)
        || !all_finite(maps->y0, ny))
        return FFX_LTI_NONFINITE;
    for (i = 0; i < (size_t)m->np; i++) maps->p_output[i] = p[i];
    maps->output_valid = 1;
    return FFX_LTI_OK;
}

int ffx_lti_step(ffx_lti_maps *maps, const double *p, double h, const double *x, const double *u, double *x_next) {
    return ffx_lti_steps(maps, p, h, 1, x, u, x_next);
}

int ffx_lti_steps(ffx_lti_maps *maps, const double *p, double h, long n, const double *x, const double *u,
                  double *x_next) {
    const ffx_lti_model *m = maps->model;
    const size_t nx = (size_t)m->nx, nu = (size_t)m->nu;
    double *a = maps->x_new, *c = maps->aug; /* two state buffers: aug is free between map updates */
    long k;
    int status;
    if (n < 0) return FFX_LTI_BAD_ARGUMENT;
    maps->taylor_last = 0;
    status = ffx_lti_update_step_maps(maps, p, h);
    if (status != FFX_LTI_OK) return status;
    if (n == 0) {
        if (x_next != x) memmove(x_next, x, nx * sizeof(double));
        return FFX_LTI_OK;
    }
    /* the per-step input term Bd u + bd once: c[nx..2nx) */
    {
        double *g = c + nx;
        matvec_add(maps->Bd, u, maps->bd, (int)nx, (int)nu, g);
        {
            const double *from = x;
            double *to = a;
            for (k = 0; k < n; k++) {
                matvec_add(maps->Ad, from, g, (int)nx, (int)nx, to);
                from = to;
                to = (to == a) ? c : a;
            }
            if (from != a) memcpy(a, from, nx * sizeof(double));
        }
    }
    if (!all_finite(a, nx)) return FFX_LTI_NONFINITE;
    memcpy(x_next, a, nx * sizeof(double));
    return FFX_LTI_OK;
}

int ffx_lti_outputs(ffx_lti_maps *maps, const double *p, const double *x, const double *u, double *y) {
    return ffx_lti_output_rows(maps, p, x, u, NULL, maps->model->ny, y);
}

int ffx_lti_output_rows(ffx_lti_maps *maps, const double *p, const double *x, const double *u, const int *rows,
                        int n_rows, double *y) {
    const ffx_lti_model *m = maps->model;
    const int nx = m->nx, nu = m->nu;
    double *z = maps->z;
    int n, r, k, status, finite = 1;
    if (n_rows < 0 || n_rows > m->ny) return FFX_LTI_BAD_ARGUMENT;
    if (!(maps->output_valid && same_p(m->np, maps->p_output, p)) && maps->taylor_last
        && same_p(m->np, maps->p_taylor, p)) {
        /* after a step by the series, at its p (base motion that moves at every step): only the rows asked for,
           each assembled as the cached maps would hold it (combine_row), not kept */
        const size_t nmono = (size_t)m->nmono, ny = (size_t)m->ny;
        const double *used = maps->used + 3 * nmono;
        double *cx = maps->aug, *cu = maps->aug + nx, *mono = z + nx + nu, y0r;
        maps->output_valid = 0; /* z's monomials are p's now */
        ffx_lti_monomials(m->np, p, mono);
        if (!all_finite(mono, nmono)) {
            for (n = 0; n < n_rows; n++) y[rows ? rows[n] : n] = NAN;
            return FFX_LTI_NONFINITE;
        }
        for (n = 0; n < n_rows; n++) {
            r = rows ? rows[n] : n;
            if (nx > 0) combine_row(m->nmono, ny, (size_t)nx, (size_t)r, m->Cx, mono, used, cx);
            if (nu > 0) combine_row(m->nmono, ny, (size_t)nu, (size_t)r, m->Cu, mono, used + nmono, cu);
            combine_row(m->nmono, ny, 1, (size_t)r, m->y0, mono, used + 2 * nmono, &y0r);
            y[r] = dot(cx, x, nx) + dot(cu, u, nu) + y0r;
        }
    } else {
        status = ffx_lti_update_output_maps(maps, p);
        if (status != FFX_LTI_OK) {
            for (n = 0; n < n_rows; n++) y[rows ? rows[n] : n] = NAN;
            return status;
        }
        for (n = 0; n < n_rows; n++) {
            r = rows ? rows[n] : n;
            y[r] = dot(maps->Cx + (size_t)r * nx, x, nx) + dot(maps->Cu + (size_t)r * nu, u, nu) + maps->y0[r];
        }
    }
    if (m->nquad > 0) {
        memcpy(z, x, (size_t)nx * sizeof(double));
        memcpy(z + nx, u, (size_t)nu * sizeof(double)); /* z[nx + nu ..] = mono(p): kept, or just made */
        if (m->quad_start != NULL) {
            /* each row's terms summed in a register, in the order of the general loop below (a store and reload
               per term would make each add wait on the last) */
            for (n = 0; n < n_rows; n++) {
                double sum;
                r = rows ? rows[n] : n;
                sum = y[r];
                for (k = m->quad_start[r]; k < m->quad_start[r + 1]; k++)
                    sum += m->quad_value[k] * z[m->quad_i[k]] * z[m->quad_j[k]];
                y[r] = sum;
            }
        } else if (rows == NULL) {
            for (k = 0; k < m->nquad; k++) y[m->quad_row[k]] += m->quad_value[k] * z[m->quad_i[k]] * z[m->quad_j[k]];
        } else {
            for (n = 0; n < n_rows; n++) {
                r = rows[n];
                for (k = 0; k < m->nquad; k++)
                    if (m->quad_row[k] == r) y[r] += m->quad_value[k] * z[m->quad_i[k]] * z[m->quad_j[k]];
            }
        }
    }
    for (n = 0; n < n_rows; n++)
        if (!isfinite(y[rows ? rows[n] : n])) finite = 0;
    return finite ? FFX_LTI_OK : FFX_LTI_NONFINITE;
}

/* ------------------------------------------------------------------ the moving-base step */

int ffx_lti_taylor_prepare(ffx_lti_maps *maps, const double *p_before, const double *p, double h, long n,
                           const double *u) {
    const ffx_lti_model *m = maps->model;
    const size_t nx = (size_t)m->nx, nu = (size_t)m->nu, nmono = (size_t)m->nmono, naug = nx + nu + 1;
    const double *usedA = maps->used, *usedB = maps->used + nmono, *usedb = maps->used + 2 * nmono;
    double *mono = maps->mono, *before = maps->mono_before, change = 0.0, theta;
    size_t i, j, k;
    int s, K;
    maps->taylor_ready = 0;
#ifdef FFX_LTI_NO_SERIES /* every step by the maps: the old path, for benchmarks/moving_base_step.py's comparison */
    (void)change, (void)theta, (void)i, (void)j, (void)k, (void)s, (void)K, (void)usedA, (void)usedB, (void)usedb;
    (void)mono, (void)before, (void)p_before, (void)p, (void)h, (void)n, (void)u, (void)naug;
    return 0;
#endif
    if (p_before == NULL || !isfinite(h) || !(h > 0.0) || n < 1 || nx == 0) return 0;
    if (same_p(m->np, p_before, p)) return 0;
    ffx_lti_monomials(m->np, p, mono);
    ffx_lti_monomials(m->np, p_before, before);
    for (k = 1; k < nmono; k++)
        if (usedA[k] != 0.0) change += fabs(mono[k] - before[k]) * maps->norms[k];
    /* no change of A, a jump (its rate against the structure's time scale), or not finite: the maps */
    if (!(change > 0.0 && change / (h * maps->norms[0] * maps->norms[0]) <= FFX_LTI_RATE_MAX)) return 0;
    for (i = 0; i < nx; i++) { /* A(p) over the rows' spans (zero elsewhere), as combine_used */
        const size_t lo = (size_t)maps->a_cols[i], hi = (size_t)maps->a_cols[nx + i];
        double *row = maps->A_held + i * nx;
        for (j = 0; j < nx; j++) row[j] = (j >= lo && j < hi) ? m->A[i * nx + j] : 0.0;
        for (k = 1; k < nmono; k++) {
            const double c = mono[k];
            const double *a = m->A + (k * nx + i) * nx;
            if (c == 0.0 || usedA[k] == 0.0) continue;
            for (j = lo; j < hi; j++) row[j] += c * a[j];
        }
    }
    theta = h * scaled_norm((int)nx, maps->A_held, maps->weights);
    if (!ffx_lti_taylor_plan(theta, &s, &K)) return 0;
    if (!((double)n * s * ((double)K * (double)(nx * nx) + (double)nx)
          < FFX_LTI_EXPM_COST_FACTOR * (double)naug * (double)naug * (double)naug))
        return 0;
    /* g = sum_k mono_k (B_k u + b_k) over the blocks in use */
    for (i = 0; i < nx; i++) maps->g_held[i] = 0.0;
    for (k = 0; k < nmono; k++) {
        const double c = mono[k];
        if (c == 0.0 || (usedB[k] == 0.0 && usedb[k] == 0.0)) continue;
        for (i = 0; i < nx; i++) {
            double sum = m->b[k * nx + i];
            if (nu > 0 && usedB[k] != 0.0)
                for (j = 0; j < nu; j++) sum += m->B[(k * nx + i) * nu + j] * u[j];
            maps->g_held[i] += c * sum;
        }
    }
    if (!all_finite(maps->A_held, nx * nx) || !all_finite(maps->g_held, nx)) return 0;
    for (i = 0; i < (size_t)m->np; i++) maps->p_taylor[i] = p[i];
    maps->taylor_h = h;
    maps->taylor_substeps = s;
    maps->taylor_terms = K;
    maps->taylor_ready = 1;
    return 1;
}

int ffx_lti_taylor_steps(ffx_lti_maps *maps, long n, const double *x, double *x_next) {
    const ffx_lti_model *m = maps->model;
    const int nx = m->nx;
    const double hs = maps->taylor_h / maps->taylor_substeps;
    double *xa = maps->x_new, *w = maps->aug, *t = maps->aug + nx, *acc = maps->aug + 2 * nx;
    long rep, total;
    int i, k;
    if (!maps->taylor_ready || n < 1) return FFX_LTI_BAD_ARGUMENT;
    maps->taylor_ready = 0;
    maps->taylor_last = 0;
    memcpy(xa, x, (size_t)nx * sizeof(double));
    total = n * (long)maps->taylor_substeps;
    for (rep = 0; rep < total; rep++) {
        /* w_1 = hs (A x + g); the increments summed first, then added to x */
        matvec_add(maps->A_held, xa, maps->g_held, nx, nx, t);
        for (i = 0; i < nx; i++) acc[i] = w[i] = hs * t[i];
        for (k = 2; k <= maps->taylor_terms; k++) {
            const double c = hs / k;
            matvec(maps->A_held, w, nx, nx, t);
            for (i = 0; i < nx; i++) {
                w[i] = c * t[i];
                acc[i] += w[i];
            }
        }
        for (i = 0; i < nx; i++) xa[i] += acc[i];
    }
    if (!all_finite(xa, (size_t)nx)) return FFX_LTI_NONFINITE;
    memcpy(x_next, xa, (size_t)nx * sizeof(double));
    maps->taylor_last = 1;
    maps->n_taylor_steps += n;
    return FFX_LTI_OK;
}

int ffx_lti_steps_held(ffx_lti_maps *maps, const double *p_before, const double *p, double h, long n, const double *x,
                       const double *u, double *x_next) {
    if (n >= 1 && ffx_lti_taylor_prepare(maps, p_before, p, h, n, u)) return ffx_lti_taylor_steps(maps, n, x, x_next);
    return ffx_lti_steps(maps, p, h, n, x, u, x_next);
}

const char *ffx_lti_status_string(int status) {
    switch (status) {
    case FFX_LTI_OK: return "ok";
    case FFX_LTI_NONFINITE: return "a result is not finite (NaN or overflow)";
    case FFX_LTI_SINGULAR: return "the Pade denominator of the matrix exponential is singular";
    case FFX_LTI_BAD_ARGUMENT:
        return "bad argument: inconsistent model, too little workspace, or a step not finite "
               "or negative";
    default: return "unknown status";
    }
}
