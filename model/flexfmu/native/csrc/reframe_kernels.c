/*
 * reframe_kernels.c - the reframe kernels (contract and layouts: reframe_kernels.h).
 *
 * The same equations as the numpy reference flexfmu/reframe/kernels_numpy.py, written as loops on
 * preallocated arrays in the order of the former numba kernels: 3x3 matrices are row-major 9-vectors,
 * D(q) is row-major (3, nf), every nf-sized temporary lives in the caller's workspace.  Sums are
 * accumulated left to right as written (the build keeps IEEE semantics: no contraction, no reassociation).
 */
#include "reframe_kernels.h"
#include "lti_kernels.h" /* ffx_lti_expm: the 8x8 exponentials of the exponential scheme */

#include <math.h>
#include <stddef.h>
#include <string.h>

#define NR FFX_REFRAME_N_RIGID
#define BLOCK FFX_REFRAME_BLOCK
/* below this rotation angle the rate coefficient uses its series (as flexfmu.core.rotation) */
#define SERIES_THETA 0.1

typedef struct {
    int J0, A, B, C, D, k, c, A6, A6i, com, end;
} offsets_t;

static offsets_t offsets(int nf) {
    offsets_t o;
    o.J0 = 1;
    o.A = o.J0 + 9;
    o.B = o.A + nf * 9;
    o.C = o.B + nf * 9;
    o.D = o.C + nf * nf * 9;
    o.k = o.D + nf * 3 * nf;
    o.c = o.k + nf;
    o.A6 = o.c + nf;
    o.A6i = o.A6 + 36;
    o.com = o.A6i + 36;
    o.end = o.com + 3;
    return o;
}

int ffx_reframe_abi_version(void) { return FFX_REFRAME_ABI_VERSION; }

void ffx_reframe_offsets(int nf, int *off) {
    offsets_t o = offsets(nf);
    off[FFX_REFRAME_O_J0] = o.J0;
    off[FFX_REFRAME_O_A] = o.A;
    off[FFX_REFRAME_O_B] = o.B;
    off[FFX_REFRAME_O_C] = o.C;
    off[FFX_REFRAME_O_D] = o.D;
    off[FFX_REFRAME_O_K] = o.k;
    off[FFX_REFRAME_O_CF] = o.c;
    off[FFX_REFRAME_O_A6] = o.A6;
    off[FFX_REFRAME_O_A6INV] = o.A6i;
    off[FFX_REFRAME_O_COM] = o.com;
    off[FFX_REFRAME_O_END] = o.end;
}

/* ------------------------------------------------------------------------------- small 3-vector helpers */

void ffx_reframe_rodrigues(const double *phi, double *R) {
    /* I + a K + b K K with K K = phi phi^T - |phi|^2 I, element by element */
    double th2 = phi[0] * phi[0] + phi[1] * phi[1] + phi[2] * phi[2];
    double th = sqrt(th2);
    double a, b;
    double x = phi[0], y = phi[1], z = phi[2];
    if (th < 1e-4) {
        a = 1.0 - th2 / 6.0 + th2 * th2 / 120.0;
        b = 0.5 - th2 / 24.0 + th2 * th2 / 720.0;
    } else {
        a = sin(th) / th;
        b = (1.0 - cos(th)) / th2;
    }
    R[0] = 1.0 + b * (x * x - th2);
    R[4] = 1.0 + b * (y * y - th2);
    R[8] = 1.0 + b * (z * z - th2);
    R[1] = -a * z + b * x * y;
    R[3] = a * z + b * x * y;
    R[2] = a * y + b * x * z;
    R[6] = -a * y + b * x * z;
    R[5] = -a * x + b * y * z;
    R[7] = a * x + b * y * z;
}

double ffx_reframe_rate_coefficient(double th) {
    double half;
    if (th < SERIES_THETA) {
        double t2 = th * th;
        return 1.0 / 12.0 + t2 * (1.0 / 720.0 + t2 * (1.0 / 30240.0 + t2 / 1209600.0));
    }
    half = 0.5 * th;
    return (1.0 - half * cos(half) / sin(half)) / (th * th);
}

void ffx_reframe_solve3(const double *S, const double *r, double *x) {
    double A[9], b[3];
    int i, j, k, p;
    for (i = 0; i < 9; i++) A[i] = S[i];
    for (i = 0; i < 3; i++) b[i] = r[i];
    for (k = 0; k < 3; k++) {
        p = k;
        for (i = k + 1; i < 3; i++)
            if (fabs(A[3 * i + k]) > fabs(A[3 * p + k])) p = i;
        if (p != k) {
            double tmp;
            for (j = 0; j < 3; j++) {
                tmp = A[3 * k + j];
                A[3 * k + j] = A[3 * p + j];
                A[3 * p + j] = tmp;
            }
            tmp = b[k];
            b[k] = b[p];
            b[p] = tmp;
        }
        for (i = k + 1; i < 3; i++) {
            double f = A[3 * i + k] / A[3 * k + k];
            for (j = k; j < 3; j++) A[3 * i + j] -= f * A[3 * k + j];
            b[i] -= f * b[k];
        }
    }
    for (i = 2; i >= 0; i--) {
        double s = b[i];
        for (j = i + 1; j < 3; j++) s -= A[3 * i + j] * x[j];
        x[i] = s / A[3 * i + i];
    }
}

/* out = R x */
static void mv(const double *R, const double *x, double *out) {
    int a;
    for (a = 0; a < 3; a++) out[a] = R[3 * a] * x[0] + R[3 * a + 1] * x[1] + R[3 * a + 2] * x[2];
}

/* out = R^T x */
static void mtv(const double *R, const double *x, double *out) {
    int a;
    for (a = 0; a < 3; a++) out[a] = R[a] * x[0] + R[3 + a] * x[1] + R[6 + a] * x[2];
}

/* out = A B (3x3) */
static void mm(const double *A, const double *B, double *out) {
    int a, b;
    for (a = 0; a < 3; a++)
        for (b = 0; b < 3; b++) out[3 * a + b] = A[3 * a] * B[b] + A[3 * a + 1] * B[3 + b] + A[3 * a + 2] * B[6 + b];
}

/* out = a x b */
static void cr(const double *a, const double *b, double *out) {
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}

void ffx_reframe_quaternion(const double *R, double *quat) {
    double tr = R[0] + R[4] + R[8];
    double best = tr, w, x, y, z, n, scale, px, py, pz, th, s;
    int i, k = 0;
    for (i = 0; i < 3; i++) {
        if (R[4 * i] > best) {
            best = R[4 * i];
            k = i + 1;
        }
    }
    if (k == 0) {
        w = 0.5 * sqrt(1.0 + tr);
        x = (R[7] - R[5]) / (4 * w);
        y = (R[2] - R[6]) / (4 * w);
        z = (R[3] - R[1]) / (4 * w);
    } else if (k == 1) {
        x = 0.5 * sqrt(1.0 + R[0] - R[4] - R[8]);
        w = (R[7] - R[5]) / (4 * x);
        y = (R[1] + R[3]) / (4 * x);
        z = (R[2] + R[6]) / (4 * x);
    } else if (k == 2) {
        y = 0.5 * sqrt(1.0 - R[0] + R[4] - R[8]);
        w = (R[2] - R[6]) / (4 * y);
        x = (R[1] + R[3]) / (4 * y);
        z = (R[5] + R[7]) / (4 * y);
    } else {
        z = 0.5 * sqrt(1.0 - R[0] - R[4] + R[8]);
        w = (R[3] - R[1]) / (4 * z);
        x = (R[2] + R[6]) / (4 * z);
        y = (R[5] + R[7]) / (4 * z);
    }
    if (w < 0.0) {
        w = -w;
        x = -x;
        y = -y;
        z = -z;
    }
    n = sqrt(x * x + y * y + z * z);
    if (n < 1e-8) {
        double r = n / w;
        scale = (2.0 / w) * (1.0 - r * r / 3.0);
    } else {
        scale = 2.0 * atan2(n, w) / n;
    }
    px = scale * x;
    py = scale * y;
    pz = scale * z;
    th = sqrt(px * px + py * py + pz * pz);
    quat[0] = cos(0.5 * th);
    s = th == 0.0 ? 0.5 : sin(0.5 * th) / th;
    quat[1] = s * px;
    quat[2] = s * py;
    quat[3] = s * pz;
}

/* ---------------------------------------------------------------------------------------- model pieces */

/* A(x) = sum x_j A_j, B(x) = sum x_j (B_j + B_j^T), D(x) = sum x_j D_j (3 nf), Cx[9 k ..] = sum_j x_j C_jk (9 nf) */
static void lin(const double *P, int nf, const double *x, double *A9, double *B9, double *D, double *Cx) {
    offsets_t o = offsets(nf);
    const double *PA = P + o.A, *PB = P + o.B, *PC = P + o.C, *PD = P + o.D;
    int n3 = 3 * nf, n9 = 9 * nf, i, j, ab;
    for (ab = 0; ab < 9; ab++) {
        A9[ab] = 0.0;
        B9[ab] = 0.0;
    }
    for (i = 0; i < n3; i++) D[i] = 0.0;
    for (i = 0; i < n9; i++) Cx[i] = 0.0;
    for (j = 0; j < nf; j++) {
        double xj = x[j];
        const double *Aj = PA + 9 * j, *Bj = PB + 9 * j, *Dj = PD + n3 * j, *Cj = PC + n9 * j;
        for (ab = 0; ab < 9; ab++) {
            A9[ab] += xj * Aj[ab];
            B9[ab] += xj * Bj[ab];
        }
        for (i = 0; i < n3; i++) D[i] += xj * Dj[i];
        for (i = 0; i < n9; i++) Cx[i] += xj * Cj[i];
    }
}

/* A(q), J(q) = J0 + B(q) + sum_k q_k Cq_k, D(q); Cq as in lin */
static void blocks(const double *P, int nf, const double *q, double *A9, double *J9, double *D, double *Cq) {
    double B9[9];
    int ab, k;
    lin(P, nf, q, A9, B9, D, Cq);
    for (ab = 0; ab < 9; ab++) J9[ab] = P[1 + ab] + B9[ab];
    for (k = 0; k < nf; k++) {
        double qk = q[k];
        const double *Ck = Cq + 9 * k;
        for (ab = 0; ab < 9; ab++) J9[ab] += qk * Ck[ab];
    }
}

/* Solve [[m I, A, 0], [A^T, J, D], [0, D^T, I]] [x1; x2; x3] = [b1; b2; b3] (Schur complement on x2) */
static void solve_mass(double m, const double *A9, const double *J9, const double *D, int nf, const double *b1,
                       const double *b2, const double *b3, double *x1, double *x2, double *x3) {
    double S[9], r[3], x[3], s;
    const double *D0 = D, *D1 = D + nf, *D2 = D + 2 * nf;
    int a, b, c, k;
    for (a = 0; a < 3; a++) {
        const double *Da = D + a * nf;
        for (b = a; b < 3; b++) {
            const double *Db = D + b * nf;
            s = 0.0;
            for (k = 0; k < nf; k++) s += Da[k] * Db[k];
            S[3 * a + b] = J9[3 * a + b] - (A9[a] * A9[b] + A9[3 + a] * A9[3 + b] + A9[6 + a] * A9[6 + b]) / m - s;
        }
        s = 0.0;
        for (k = 0; k < nf; k++) s += Da[k] * b3[k];
        r[a] = b2[a] - (A9[a] * b1[0] + A9[3 + a] * b1[1] + A9[6 + a] * b1[2]) / m - s;
    }
    for (a = 0; a < 3; a++) /* J symmetric: S too */
        for (b = 0; b < a; b++) S[3 * a + b] = S[3 * b + a];
    ffx_reframe_solve3(S, r, x);
    for (a = 0; a < 3; a++) x2[a] = x[a];
    for (c = 0; c < 3; c++) x1[c] = (b1[c] - (A9[3 * c] * x[0] + A9[3 * c + 1] * x[1] + A9[3 * c + 2] * x[2])) / m;
    for (k = 0; k < nf; k++) x3[k] = b3[k] - (D0[k] * x[0] + D1[k] * x[1] + D2[k] * x[2]);
}

/* Global force sum, body moment about the frame point, flexible generalised forces of one stage */
static void loads(const double *LP, int n_loads, int nf, int deformed, const double *sv, const double *R9,
                  const double *q, double *F_g, double *N_b, double *Q) {
    int stride = 5 + 6 * nf, l, a, j;
    double f_b[3], m_b[3], tmp[3], arm[3];
    for (a = 0; a < 3; a++) {
        F_g[a] = 0.0;
        N_b[a] = 0.0;
    }
    for (j = 0; j < nf; j++) Q[j] = 0.0;
    for (l = 0; l < n_loads; l++) {
        int base = l * stride, o;
        const double *f = sv + 6 * l, *mo = sv + 6 * l + 3;
        if (LP[base] != 0.0) { /* follower: body components */
            for (a = 0; a < 3; a++) {
                f_b[a] = f[a];
                m_b[a] = mo[a];
            }
            mv(R9, f, tmp);
            for (a = 0; a < 3; a++) F_g[a] += tmp[a];
        } else {
            mtv(R9, f, f_b);
            mtv(R9, mo, m_b);
            for (a = 0; a < 3; a++) F_g[a] += f[a];
        }
        for (a = 0; a < 3; a++) arm[a] = LP[base + 2 + a];
        o = base + 5;
        for (a = 0; a < 3; a++) {
            double s = 0.0;
            for (j = 0; j < nf; j++) {
                Q[j] += LP[o + a * nf + j] * f_b[a];
                s += LP[o + a * nf + j] * q[j];
            }
            if (deformed) arm[a] += s;
        }
        cr(arm, f_b, tmp);
        for (a = 0; a < 3; a++) N_b[a] += tmp[a];
        if (LP[base + 1] != 0.0) {
            o = base + 5 + 3 * nf;
            for (a = 0; a < 3; a++) {
                N_b[a] += m_b[a];
                for (j = 0; j < nf; j++) Q[j] += LP[o + a * nf + j] * m_b[a];
            }
        }
    }
}

/* dT/dq_j = v^T A_j w + w^T B_j w / 2 + w^T (sum_k q_k C_jk) w + w^T D_j qdot (Cq: sum_k q_k C_kj) */
static void dTdq(const double *P, int nf, const double *v, const double *w, const double *qd, const double *Cq,
                 double *out) {
    offsets_t o = offsets(nf);
    const double *PA = P + o.A, *PB = P + o.B, *PD = P + o.D;
    double vw[9], ww[9];
    int n3 = 3 * nf, a, b, j, k, ab;
    for (a = 0; a < 3; a++)
        for (b = 0; b < 3; b++) {
            vw[3 * a + b] = v[a] * w[b];
            ww[3 * a + b] = w[a] * w[b];
        }
    for (j = 0; j < nf; j++) {
        const double *Aj = PA + 9 * j, *Bj = PB + 9 * j, *Cj = Cq + 9 * j, *Dj = PD + n3 * j;
        double s = 0.0;
        for (ab = 0; ab < 9; ab++) s += Aj[ab] * vw[ab] + (0.5 * Bj[ab] + Cj[ab]) * ww[ab];
        for (a = 0; a < 3; a++) {
            const double *Dja = Dj + a * nf;
            double t = 0.0;
            for (k = 0; k < nf; k++) t += Dja[k] * qd[k];
            s += w[a] * t;
        }
        out[j] = s;
    }
}

/* out += -(sum_ab X_ab G_ab) q, X = w w^T - |w|^2 I */
static void geometric_force(const double *G, int nf, const double *w, const double *q, double *out) {
    double ww = w[0] * w[0] + w[1] * w[1] + w[2] * w[2], X[9];
    int n2 = nf * nf, a, b, j, k, ab;
    for (a = 0; a < 3; a++)
        for (b = 0; b < 3; b++) X[3 * a + b] = w[a] * w[b] - (a == b ? ww : 0.0);
    for (j = 0; j < nf; j++) {
        double s = 0.0;
        for (k = 0; k < nf; k++) {
            double g = 0.0;
            for (ab = 0; ab < 9; ab++) g += X[ab] * G[ab * n2 + j * nf + k];
            s += g * q[k];
        }
        out[j] -= s;
    }
}

/*
 * Time derivative of the step-local state z = [phi, dpos, p_g, H, q, p_q] (12 + 2 nf); split != 0
 * (exponential scheme): N(z) = z' - L z instead, L z = [0 (12), p_q, -k q - c p_q].  work: 15 nf doubles.
 */
static void rhs(const double *P, const double *LP, int n_loads, const double *G, int nf, int deformed, const double *sv,
                const double *Rn9, const double *z, int split, double *out, double *work) {
    double m = P[0];
    offsets_t o = offsets(nf);
    double Rrel[9], R[9], p_b[3], h[3], A9[9], J9[9], v[3], w[3], F_g[3], N_b[3], pxw[3], ppw[3], vxp[3];
    double *D = work, *Cq = D + 3 * nf, *qd = Cq + 9 * nf, *Q = qd + nf, *dT = Q + nf;
    const double *phi = z, *q = z + 12, *pq = z + 12 + nf;
    double th, c;
    int a, j;
    ffx_reframe_rodrigues(phi, Rrel);
    mm(Rn9, Rrel, R);
    mtv(R, z + 6, p_b);
    mtv(Rrel, z + 9, h);
    blocks(P, nf, q, A9, J9, D, Cq);
    solve_mass(m, A9, J9, D, nf, p_b, h, pq, v, w, qd);
    loads(LP, n_loads, nf, deformed, sv, R, q, F_g, N_b, Q);
    /* rotation-vector rate (Eqs. 20-22) */
    th = sqrt(phi[0] * phi[0] + phi[1] * phi[1] + phi[2] * phi[2]);
    cr(phi, w, pxw);
    cr(phi, pxw, ppw);
    c = ffx_reframe_rate_coefficient(th);
    for (a = 0; a < 3; a++) out[a] = w[a] + 0.5 * pxw[a] + c * ppw[a];
    mv(R, v, out + 3);
    for (a = 0; a < 3; a++) out[6 + a] = F_g[a];
    cr(v, p_b, vxp);
    for (a = 0; a < 3; a++) vxp[a] = N_b[a] - vxp[a];
    mv(Rrel, vxp, out + 9);
    if (nf) {
        dTdq(P, nf, v, w, qd, Cq, dT);
        if (split) { /* q' - p_q = -D^T w, p_q' + k q + c p_q = dT/dq + c D^T w + Q */
            for (j = 0; j < nf; j++) {
                double Dtw = D[j] * w[0] + D[nf + j] * w[1] + D[2 * nf + j] * w[2];
                out[12 + j] = -Dtw;
                out[12 + nf + j] = dT[j] + P[o.c + j] * Dtw + Q[j];
            }
        } else {
            for (j = 0; j < nf; j++) {
                out[12 + j] = qd[j];
                out[12 + nf + j] = dT[j] - P[o.k + j] * q[j] - P[o.c + j] * qd[j] + Q[j];
            }
        }
        if (G) geometric_force(G, nf, w, q, out + 12 + nf);
    }
}

/* out (+)= [s z_frame; EX_k (q_j, p_j)]: added to out if add, else written */
static void expmap(const double *EX, int nf, int k, const double *z, double s, int add, double *out) {
    int i, j;
    for (i = 0; i < 12; i++) out[i] = (add ? out[i] : 0.0) + s * z[i];
    for (j = 0; j < nf; j++) {
        int o = 24 * j + 4 * k;
        double qj = z[12 + j], pj = z[12 + nf + j];
        out[12 + j] = (add ? out[12 + j] : 0.0) + EX[o] * qj + EX[o + 1] * pj;
        out[12 + nf + j] = (add ? out[12 + nf + j] : 0.0) + EX[o + 2] * qj + EX[o + 3] * pj;
    }
}

/* One step of y in place: classical RK4 (EX NULL) or ETD-RK4; 0 if the new state is not finite.
 * sv: the step's (3, n_loads, 6) stage values.  work: 48 nf + 9 (12 + 2 nf) doubles. */
static int step(const double *P, const double *LP, int n_loads, const double *G, const double *EX, int nf, int deformed,
                const double *sv, double dt, double *y, double *work) {
    double m = P[0];
    offsets_t o = offsets(nf);
    int nm = NR + nf, nz = 12 + 2 * nf, e = 12, ny = 12 + 2 * nm, a, b, i, k;
    int stage = 6 * n_loads;
    double Rn[9], vw[6], A9[9], J9[9], pb[3], Rrel[9], R1[9], RRt[9], R[9], b1[3], b2[3], v1[6];
    const double *v = vw, *w = vw + 3, *qd = y + e + nm + NR;
    double *q = work, *q1 = q + nf, *qd1 = q1 + nf, *D = qd1 + nf, *Cq = D + 3 * nf;
    double *z0 = Cq + 9 * nf, *k1 = z0 + nz, *k2 = k1 + nz, *k3 = k2 + nz, *k4 = k3 + nz, *zs = k4 + nz;
    double *E2z0 = zs + nz, *av = E2z0 + nz, *tmp = av + nz, *rw = tmp + nz, *z;
    for (i = 0; i < 9; i++) Rn[i] = y[3 + i];
    for (a = 0; a < 6; a++) {
        double s = 0.0;
        for (b = 0; b < 6; b++) s += P[o.A6 + 6 * a + b] * y[e + nm + b];
        vw[a] = s;
    }
    for (k = 0; k < nf; k++) q[k] = y[e + NR + k];
    blocks(P, nf, q, A9, J9, D, Cq);
    for (i = 0; i < nz; i++) z0[i] = 0.0;
    for (a = 0; a < 3; a++) pb[a] = m * v[a] + A9[3 * a] * w[0] + A9[3 * a + 1] * w[1] + A9[3 * a + 2] * w[2];
    mv(Rn, pb, z0 + 6);
    for (a = 0; a < 3; a++) {
        double s = A9[a] * v[0] + A9[3 + a] * v[1] + A9[6 + a] * v[2] + J9[3 * a] * w[0] + J9[3 * a + 1] * w[1]
                   + J9[3 * a + 2] * w[2];
        for (k = 0; k < nf; k++) s += D[a * nf + k] * qd[k];
        z0[9 + a] = s;
    }
    for (k = 0; k < nf; k++) {
        z0[12 + k] = q[k];
        z0[12 + nf + k] = D[k] * w[0] + D[nf + k] * w[1] + D[2 * nf + k] * w[2] + qd[k];
    }
    if (!EX) { /* classical RK4 (consistent scheme) */
        rhs(P, LP, n_loads, G, nf, deformed, sv, Rn, z0, 0, k1, rw);
        for (i = 0; i < nz; i++) zs[i] = z0[i] + 0.5 * dt * k1[i];
        rhs(P, LP, n_loads, G, nf, deformed, sv + stage, Rn, zs, 0, k2, rw);
        for (i = 0; i < nz; i++) zs[i] = z0[i] + 0.5 * dt * k2[i];
        rhs(P, LP, n_loads, G, nf, deformed, sv + stage, Rn, zs, 0, k3, rw);
        for (i = 0; i < nz; i++) zs[i] = z0[i] + dt * k3[i];
        rhs(P, LP, n_loads, G, nf, deformed, sv + 2 * stage, Rn, zs, 0, k4, rw);
        z = zs;
        for (i = 0; i < nz; i++) z[i] = z0[i] + (dt / 6.0) * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
    } else { /* Cox-Matthews ETD-RK4 (exponential scheme) */
        expmap(EX, nf, 1, z0, 1.0, 0, E2z0);
        rhs(P, LP, n_loads, G, nf, deformed, sv, Rn, z0, 1, k1, rw);
        for (i = 0; i < nz; i++) av[i] = E2z0[i];
        expmap(EX, nf, 2, k1, 0.5 * dt, 1, av);
        rhs(P, LP, n_loads, G, nf, deformed, sv + stage, Rn, av, 1, k2, rw);
        for (i = 0; i < nz; i++) zs[i] = E2z0[i];
        expmap(EX, nf, 2, k2, 0.5 * dt, 1, zs);
        rhs(P, LP, n_loads, G, nf, deformed, sv + stage, Rn, zs, 1, k3, rw);
        expmap(EX, nf, 1, av, 1.0, 0, zs);
        for (i = 0; i < nz; i++) tmp[i] = 2.0 * k3[i] - k1[i];
        expmap(EX, nf, 2, tmp, 0.5 * dt, 1, zs);
        rhs(P, LP, n_loads, G, nf, deformed, sv + 2 * stage, Rn, zs, 1, k4, rw);
        z = zs;
        expmap(EX, nf, 0, z0, 1.0, 0, z);
        expmap(EX, nf, 3, k1, dt / 6.0, 1, z);
        for (i = 0; i < nz; i++) tmp[i] = k2[i] + k3[i];
        expmap(EX, nf, 4, tmp, dt / 3.0, 1, z);
        expmap(EX, nf, 5, k4, dt / 6.0, 1, z);
    }
    ffx_reframe_rodrigues(z, Rrel);
    mm(Rn, Rrel, R1);
    for (a = 0; a < 3; a++)
        for (b = 0; b < 3; b++)
            RRt[3 * a + b] = R1[3 * a] * R1[3 * b] + R1[3 * a + 1] * R1[3 * b + 1] + R1[3 * a + 2] * R1[3 * b + 2];
    mm(RRt, R1, R); /* one Newton step of the polar decomposition */
    for (i = 0; i < 9; i++) R[i] = 1.5 * R1[i] - 0.5 * R[i];
    for (k = 0; k < nf; k++) q1[k] = z[12 + k];
    blocks(P, nf, q1, A9, J9, D, Cq);
    mtv(R, z + 6, b1);
    mtv(Rrel, z + 9, b2);
    solve_mass(m, A9, J9, D, nf, b1, b2, z + 12 + nf, v1, v1 + 3, qd1);
    for (a = 0; a < 3; a++) y[a] += z[3 + a];
    for (i = 0; i < 9; i++) y[3 + i] = R[i];
    for (i = 0; i < NR; i++) y[e + i] = 0.0;
    for (k = 0; k < nf; k++) {
        y[e + NR + k] = q1[k];
        y[e + nm + NR + k] = qd1[k];
    }
    for (a = 0; a < 6; a++) {
        double s = 0.0;
        for (b = 0; b < 6; b++) s += P[o.A6i + 6 * a + b] * v1[b];
        y[e + nm + a] = s;
    }
    for (i = 0; i < ny; i++)
        if (!isfinite(y[i])) return 0;
    return 1;
}

int ffx_reframe_steps(const double *P, const double *LP, int n_loads, const double *G, const double *EX, int nf,
                      int deformed, const double *SV, int held, double *t, double dt, int n, double *y, int *steps_done,
                      double *work) {
    int per_step = 3 * n_loads * 6, k, i;
    double tk = *t;
    for (k = 0; k < n; k++) {
        const double *sv = held ? SV : SV + (int64_t)k * per_step;
        if (!held || k == 0) {
            for (i = 0; i < per_step; i++) {
                if (!isfinite(sv[i])) {
                    *t = tk;
                    *steps_done = k;
                    return FFX_REFRAME_LOADS_NOT_FINITE;
                }
            }
        }
        if (!step(P, LP, n_loads, G, EX, nf, deformed, sv, dt, y, work)) {
            *t = tk + dt;
            *steps_done = k;
            return FFX_REFRAME_STATE_NOT_FINITE;
        }
        tk = tk + dt;
    }
    *t = tk;
    *steps_done = n;
    return FFX_REFRAME_OK;
}

int ffx_reframe_consistent_steps(const double *P, const double *LP, int n_loads, int nf, int deformed, const double *SV,
                                 int held, double *t, double dt, int n, double *y, int *steps_done, double *work) {
    return ffx_reframe_steps(P, LP, n_loads, NULL, NULL, nf, deformed, SV, held, t, dt, n, y, steps_done, work);
}

/* ------------------------------------------------------------------------ max elastic displacement search */

/* |Phi_i q|^2 of node i: its three rows' dot products summed in column order, interleaved (independent
 * chains; each sum in the order of the reference, so the same numbers as one row after the other) */
static double node_norm2(const double *Psi, int64_t ld, int col, int dpn, int64_t i, const double *q, int nf) {
    const double *r0 = Psi + (int64_t)dpn * i * ld + col, *r1 = r0 + ld, *r2 = r1 + ld;
    double u0 = 0.0, u1 = 0.0, u2 = 0.0;
    int j;
    for (j = 0; j < nf; j++) {
        double qj = q[j];
        u0 += r0[j] * qj;
        u1 += r1[j] * qj;
        u2 += r2[j] * qj;
    }
    return u0 * u0 + u1 * u1 + u2 * u2;
}

double ffx_reframe_block_norm(const double *Psi, int psi_cols, int col, int dpn, const int64_t *order, int n_nodes,
                              int b, const double *q, int nf, double best) {
    int stop = (b + 1) * BLOCK < n_nodes ? (b + 1) * BLOCK : n_nodes, k;
    int64_t ld = psi_cols;
    for (k = b * BLOCK; k + 1 < stop; k += 2) { /* two nodes at a time: six independent sums */
        const double *a0 = Psi + (int64_t)dpn * order[k] * ld + col, *a1 = a0 + ld, *a2 = a1 + ld;
        const double *c0 = Psi + (int64_t)dpn * order[k + 1] * ld + col, *c1 = c0 + ld, *c2 = c1 + ld;
        double u0 = 0.0, u1 = 0.0, u2 = 0.0, v0 = 0.0, v1 = 0.0, v2 = 0.0, s, t;
        int j;
        for (j = 0; j < nf; j++) {
            double qj = q[j];
            u0 += a0[j] * qj;
            u1 += a1[j] * qj;
            u2 += a2[j] * qj;
            v0 += c0[j] * qj;
            v1 += c1[j] * qj;
            v2 += c2[j] * qj;
        }
        s = sqrt(u0 * u0 + u1 * u1 + u2 * u2);
        t = sqrt(v0 * v0 + v1 * v1 + v2 * v2);
        if (s > best) best = s;
        if (t > best) best = t;
    }
    if (k < stop) {
        double s = sqrt(node_norm2(Psi, ld, col, dpn, order[k], q, nf));
        if (s > best) best = s;
    }
    return best;
}

double ffx_reframe_bound(const double *C, const double *r, int b, const double *q, int nf, double qn) {
    const double *c0 = C + (int64_t)b * 3 * nf, *c1 = c0 + nf, *c2 = c1 + nf;
    double u0 = 0.0, u1 = 0.0, u2 = 0.0;
    int j;
    for (j = 0; j < nf; j++) {
        double qj = q[j];
        u0 += c0[j] * qj;
        u1 += c1[j] * qj;
        u2 += c2[j] * qj;
    }
    return (sqrt(u0 * u0 + u1 * u1 + u2 * u2) + r[b] * qn) * (1.0 + 1e-12);
}

double ffx_reframe_max_node_norm(const double *Psi, int psi_cols, int col, int dpn, const int64_t *order, int n_nodes,
                                 const double *bc, const double *br, int n_blocks, const double *sc, const double *sr,
                                 int n_super, const double *q, int nf) {
    double qn, best_bound = -1.0, best, sb0 = 0.0, x;
    int s, s0 = 0, b, b0, stop, j;
    if (nf == 0) return 0.0;
    qn = 0.0;
    for (j = 0; j < nf; j++) qn += q[j] * q[j];
    qn = sqrt(qn);
    /* the superblock with the largest bound (bounds are recomputed below, to the same numbers, rather
     * than stored: no workspace) */
    for (s = 0; s < n_super; s++) {
        x = ffx_reframe_bound(sc, sr, s, q, nf, qn);
        if (s == 0 || x > sb0) {
            sb0 = x;
            s0 = s;
        }
    }
    b0 = s0 * BLOCK;
    stop = (s0 + 1) * BLOCK < n_blocks ? (s0 + 1) * BLOCK : n_blocks;
    for (b = s0 * BLOCK; b < stop; b++) {
        x = ffx_reframe_bound(bc, br, b, q, nf, qn);
        if (x > best_bound) {
            best_bound = x;
            b0 = b;
        }
    }
    best = ffx_reframe_block_norm(Psi, psi_cols, col, dpn, order, n_nodes, b0, q, nf, 0.0);
    for (s = 0; s < n_super; s++) {
        if (ffx_reframe_bound(sc, sr, s, q, nf, qn) < best) continue;
        stop = (s + 1) * BLOCK < n_blocks ? (s + 1) * BLOCK : n_blocks;
        for (b = s * BLOCK; b < stop; b++)
            if (b != b0 && ffx_reframe_bound(bc, br, b, q, nf, qn) >= best)
                best = ffx_reframe_block_norm(Psi, psi_cols, col, dpn, order, n_nodes, b, q, nf, best);
    }
    return best;
}

/* ------------------------------------------------------------------------------------ outputs of a state */

void ffx_reframe_outputs(const double *P, const double *LP, int n_loads, const double *G, int nf, int deformed,
                         const double *sv, const double *y, const double *PP, int n_points, const double *Psi,
                         int psi_cols, int dpn, const int64_t *order, int n_nodes, const double *bc, const double *br,
                         int n_blocks, const double *sc, const double *sr, int n_super, double *out, double *work) {
    double m = P[0];
    offsets_t o = offsets(nf);
    int nm = NR + nf, e = 12, a, b, k, j, ab, p, rigid, ooff, pstride = 3 + 3 * nf;
    double R[9], vw[6], v[3], w[3], A9[9], J9[9], p_b[3], h[3], F_g[3], N_b[3], F_b[3];
    double t1[3], t2[3], b1[3], b2[3], vdot[3], alpha[3], a_o[3], Ad[9], Bd[9], Jd[9];
    double X[3], u[3], ud[3], udd[3], yk[3], acc[3], c1[3], c2[3];
    double *q = work, *qd = q + nf, *D = qd + nf, *Cq = D + 3 * nf, *Q = Cq + 9 * nf, *b3 = Q + nf;
    double *Dd = b3 + nf, *Cqd = Dd + 3 * nf, *qdd = Cqd + 9 * nf;
    const double *com = P + o.com;
    for (k = 0; k < 9; k++) R[k] = y[3 + k];
    for (a = 0; a < 6; a++) {
        double s = 0.0;
        for (b = 0; b < 6; b++) s += P[o.A6 + 6 * a + b] * y[e + nm + b];
        vw[a] = s;
    }
    for (a = 0; a < 3; a++) {
        v[a] = vw[a];
        w[a] = vw[3 + a];
    }
    for (k = 0; k < nf; k++) {
        q[k] = y[e + NR + k];
        qd[k] = y[e + nm + NR + k];
    }
    blocks(P, nf, q, A9, J9, D, Cq);
    for (a = 0; a < 3; a++) {
        double s;
        p_b[a] = m * v[a] + A9[3 * a] * w[0] + A9[3 * a + 1] * w[1] + A9[3 * a + 2] * w[2];
        s = A9[a] * v[0] + A9[3 + a] * v[1] + A9[6 + a] * v[2] + J9[3 * a] * w[0] + J9[3 * a + 1] * w[1]
            + J9[3 * a + 2] * w[2];
        for (k = 0; k < nf; k++) s += D[a * nf + k] * qd[k];
        h[a] = s;
    }
    loads(LP, n_loads, nf, deformed, sv, R, q, F_g, N_b, Q);
    mtv(R, F_g, F_b);
    cr(w, p_b, t1);
    for (a = 0; a < 3; a++) b1[a] = F_b[a] - t1[a];
    cr(w, h, t1);
    cr(v, p_b, t2);
    for (a = 0; a < 3; a++) b2[a] = N_b[a] - t1[a] - t2[a];
    if (nf) {
        dTdq(P, nf, v, w, qd, Cq, b3);
        for (j = 0; j < nf; j++) b3[j] += -P[o.k + j] * q[j] - P[o.c + j] * qd[j] + Q[j];
        if (G) geometric_force(G, nf, w, q, b3);
        /* minus Mdot xi (Mm quadratic in q): A(qd), B(qd) + sum_k (qd_k Cq_k + q_k Cqd_k), D(qd) */
        lin(P, nf, qd, Ad, Bd, Dd, Cqd);
        for (ab = 0; ab < 9; ab++) {
            double s = Bd[ab];
            for (k = 0; k < nf; k++) s += qd[k] * Cq[9 * k + ab] + q[k] * Cqd[9 * k + ab];
            Jd[ab] = s;
        }
        for (a = 0; a < 3; a++) {
            double s;
            b1[a] -= Ad[3 * a] * w[0] + Ad[3 * a + 1] * w[1] + Ad[3 * a + 2] * w[2];
            s = Ad[a] * v[0] + Ad[3 + a] * v[1] + Ad[6 + a] * v[2] + Jd[3 * a] * w[0] + Jd[3 * a + 1] * w[1]
                + Jd[3 * a + 2] * w[2];
            for (k = 0; k < nf; k++) s += Dd[a * nf + k] * qd[k];
            b2[a] -= s;
        }
        for (k = 0; k < nf; k++) b3[k] -= Dd[k] * w[0] + Dd[nf + k] * w[1] + Dd[2 * nf + k] * w[2];
    }
    solve_mass(m, A9, J9, D, nf, b1, b2, b3, vdot, alpha, qdd);
    cr(w, v, t1);
    for (a = 0; a < 3; a++) a_o[a] = vdot[a] + t1[a];
    mv(R, com, t1);
    for (a = 0; a < 3; a++) out[a] = y[a] - t1[a];
    cr(w, com, t1);
    for (a = 0; a < 3; a++) t2[a] = v[a] - t1[a];
    mv(R, t2, out + 3);
    ffx_reframe_quaternion(R, out + 6);
    for (a = 0; a < 3; a++) {
        out[10 + a] = w[a];
        out[13 + a] = alpha[a];
        out[16 + a] = y[a];
        t1[a] = (m * v[a] + A9[3 * a] * w[0] + A9[3 * a + 1] * w[1] + A9[3 * a + 2] * w[2]) / m;
    }
    mv(R, t1, out + 19);
    for (k = 0; k < nf; k++) {
        out[22 + k] = q[k];
        out[22 + nf + k] = qd[k];
    }
    if (n_nodes > 0)
        out[22 + 2 * nf] = ffx_reframe_max_node_norm(Psi, psi_cols, NR, dpn, order, n_nodes, bc, br, n_blocks, sc, sr,
                                                     n_super, q, nf);
    else /* skipped on request (an empty node order) */
        out[22 + 2 * nf] = FFX_REFRAME_NOT_COMPUTED;
    ooff = 23 + 2 * nf;
    for (p = 0; p < n_points; p++) {
        const double *row = PP + (int64_t)p * pstride;
        int base0 = ooff + 18 * p;
        for (a = 0; a < 3; a++) {
            double s0 = 0.0, s1 = 0.0, s2 = 0.0;
            X[a] = row[a];
            for (j = 0; j < nf; j++) {
                double ph = row[3 + a * nf + j];
                s0 += ph * q[j];
                s1 += ph * qd[j];
                s2 += ph * qdd[j];
            }
            u[a] = s0;
            ud[a] = s1;
            udd[a] = s2;
            yk[a] = X[a] + u[a];
        }
        for (rigid = 0; rigid < 2; rigid++) {
            const double *r = rigid ? X : yk;
            int base = base0 + 9 * rigid;
            mv(R, r, t1);
            for (a = 0; a < 3; a++) out[base + a] = y[a] + t1[a];
            cr(w, r, c1);
            for (a = 0; a < 3; a++) t2[a] = v[a] + c1[a] + (rigid ? 0.0 : ud[a]);
            mv(R, t2, out + base + 3);
            cr(w, c1, c2); /* omega x (omega x r) */
            cr(alpha, r, t1);
            cr(w, ud, t2);
            for (a = 0; a < 3; a++) {
                acc[a] = a_o[a] + t1[a] + c2[a];
                if (!rigid) acc[a] += 2.0 * t2[a] + udd[a];
            }
            mv(R, acc, out + base + 6);
        }
    }
}

void ffx_reframe_consistent_outputs(const double *P, const double *LP, int n_loads, int nf, int deformed,
                                    const double *sv, const double *y, const double *PP, int n_points,
                                    const double *Psi, int psi_cols, int dpn, const int64_t *order, int n_nodes,
                                    const double *bc, const double *br, int n_blocks, const double *sc,
                                    const double *sr, int n_super, double *out, double *work) {
    ffx_reframe_outputs(P, LP, n_loads, NULL, nf, deformed, sv, y, PP, n_points, Psi, psi_cols, dpn, order, n_nodes, bc,
                        br, n_blocks, sc, sr, n_super, out, work);
}

/* ------------------------------------------------------------------------- exponential-scheme coefficients */

/* flexfmu.reframe.schemes.exponential_coefficients: per mode, the 8x8 exponentials of the augmented matrix
   [[f dt Lhat, I, 0, 0], [0, 0, I, 0], [0, 0, 0, I], [0, 0, 0, 0]] (f = 1, 1/2) in the balanced coordinates
   (omega_j q_j, p_j), their blocks e^Z, phi_1, phi_2, phi_3 combined as the Python reference does, scaled back. */
int ffx_reframe_exponential_coefficients(int nf, const double *kF, const double *cF, double dt, double *EX,
                                         double *work) {
    double *W = work, *X = work + 64, *ework = work + 128;
    double blocks[2][4][4]; /* [frac][b] 2x2 row-major: e^Z, phi_1, phi_2, phi_3 */
    int j, f, b, r, c, m, status = FFX_REFRAME_OK;
    for (j = 0; j < nf; j++) {
        const double k = kF[j], cc = cF[j];
        const double w = sqrt(k > 0.0 ? k : 0.0);
        const double s = w > 0.0 ? w : 1.0;
        const double L[4] = {0.0, s, -k / s, -cc};
        for (f = 0; f < 2; f++) {
            const double scale = (f == 0 ? 1.0 : 0.5) * dt;
            memset(W, 0, 64 * sizeof(double));
            for (r = 0; r < 2; r++)
                for (c = 0; c < 2; c++) W[8 * r + c] = scale * L[2 * r + c];
            for (b = 0; b < 3; b++) {
                W[8 * (2 * b) + 2 * b + 2] = 1.0;
                W[8 * (2 * b + 1) + 2 * b + 3] = 1.0;
            }
            if (ffx_lti_expm(8, W, X, ework) != 0) status = FFX_REFRAME_STATE_NOT_FINITE;
            for (b = 0; b < 4; b++)
                for (r = 0; r < 2; r++)
                    for (c = 0; c < 2; c++) blocks[f][b][2 * r + c] = X[8 * r + 2 * b + c];
        }
        {
            const double h = dt;
            const double *e1 = blocks[0][0], *p1 = blocks[0][1], *p2 = blocks[0][2], *p3 = blocks[0][3];
            double mats[6][4];
            for (r = 0; r < 4; r++) {
                mats[0][r] = e1[r];
                mats[1][r] = blocks[1][0][r];
                mats[2][r] = 0.5 * h * blocks[1][1][r];
                mats[3][r] = h * (p1[r] - 3.0 * p2[r] + 4.0 * p3[r]);
                mats[4][r] = h * (2.0 * p2[r] - 4.0 * p3[r]);
                mats[5][r] = h * (4.0 * p3[r] - p2[r]);
            }
            for (m = 0; m < 6; m++) {
                double *out = EX + 24 * j + 4 * m;
                out[0] = mats[m][0];
                out[1] = mats[m][1] / s;
                out[2] = mats[m][2] * s;
                out[3] = mats[m][3];
                for (r = 0; r < 4; r++)
                    if (!isfinite(out[r])) status = FFX_REFRAME_STATE_NOT_FINITE;
            }
        }
    }
    return status;
}
