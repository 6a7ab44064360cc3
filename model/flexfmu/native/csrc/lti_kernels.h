/*
 * lti_kernels.h - a clamped flexible body on a moving base as a linear system whose matrices depend on
 * held parameters p (the base rotation rate and acceleration, the damping ratio, ...):
 *
 *     x' = A(p) x + B(p) u + b(p)                           (continuous time, inputs u held over a step)
 *     y  = Cx(p) x + Cu(p) u + y0(p) + sum_k v_k z[i_k] z[j_k] e_{r_k},   z = [x; u; mono(p)]
 *
 * Every matrix is a sum over monomials of p up to degree 2 (mono = [1, p_1..p_np, p_i p_j for i <= j],
 * FFX_LTI_N_MONOMIALS(np) of them) of constant coefficient matrices, so the physics is written once
 * (in Python, flexfmu.native.lti extracts the coefficients from the library's own maps) and this file only
 * evaluates it.  A step of length h is the exact zero-order hold: expm([[A B b];[0 0 0]] h), recomputed
 * only when p or h changes; or, for base motion that moves by little at every step (ffx_lti_steps_held), the
 * same exponential's Taylor series applied to the step's vector (no maps; the rule and the truncation bound:
 * flexfmu/native/lti_taylor.py, which follows the same rule in numpy).  All arrays row-major doubles.  C99,
 * libc/libm only.
 *
 * Monomial order (0-based p): mono[0] = 1, mono[1 + i] = p[i], then p[i] * p[j] for i = 0..np-1, j = i..np-1
 * (i outer, j inner).  Coefficient k of a matrix multiplies mono[k]: A(p) = sum_k mono[k] A[k].
 *
 * Memory: nothing here allocates.  The caller gives ffx_lti_maps its workspace (ffx_lti_maps_work_len doubles),
 * and ffx_lti_expm its own (ffx_lti_expm_work_len doubles); the model (the struct and its arrays) is only read and
 * must outlive the maps.  Functions returning int return one of the FFX_LTI_* codes below.
 */
#ifndef FLEXFMU_LTI_KERNELS_H
#define FLEXFMU_LTI_KERNELS_H

#include <stddef.h>

#define FFX_LTI_N_MONOMIALS(np) (1 + (np) + (np) * ((np) + 1) / 2)

/* return codes */
#define FFX_LTI_OK 0
#define FFX_LTI_NONFINITE 1    /* a result (step maps, new state or outputs) is not finite: NaN or overflow */
#define FFX_LTI_SINGULAR 2     /* the Pade denominator of the exponential is singular (a non-finite matrix) */
#define FFX_LTI_BAD_ARGUMENT 3 /* inconsistent model, too little workspace, or h not finite or < 0 */

/* Step sizes within FFX_STEP_RTOL (relative) of each other are one step: what was computed for the first (step
 * maps, exponential coefficients) is reused for the other.  Hosts that compute each step as h = t(k+1) - t(k)
 * pass steps that differ in their last bits (about eps |t| / h relative), and a matrix exponential per step would
 * cost 10-20x the step.  The state then advances by the cached step hc: the exact solution at a time shifted by
 * |h - hc| <= FFX_STEP_RTOL hc, i.e. at most FFX_STEP_RTOL hc max|x'| per step; for h = t(k+1) - t(k) the shifts
 * sum to the rounding of the host's own clock.  The full bound is in flexfmu.core.step_size, whose STEP_RTOL
 * equals this (checked by the tests through ffx_step_rtol). */
#define FFX_STEP_RTOL 1e-6
double ffx_step_rtol(void);
int ffx_same_step(double cached, double h); /* 1 when step h may reuse what was computed for step cached */

typedef struct {
    int nx, nu, ny, np, nmono; /* nmono = FFX_LTI_N_MONOMIALS(np) */
    const double *A;           /* (nmono, nx, nx) */
    const double *B;           /* (nmono, nx, nu) */
    const double *b;           /* (nmono, nx) */
    const double *Cx;          /* (nmono, ny, nx) */
    const double *Cu;          /* (nmono, ny, nu) */
    const double *y0;          /* (nmono, ny) */
    int nquad;                 /* quadratic output terms y[row] += value * z[i] * z[j] */
    const int *quad_row, *quad_i, *quad_j;
    const double *quad_value;
    const int *quad_start; /* (ny + 1) or NULL: with the terms ordered by row, those of row r are
                                      quad_start[r] .. quad_start[r + 1] - 1 (ffx_lti_quad_starts); output rows
                                      alone then visit their own terms only */
} ffx_lti_model;

/* The maps of the last (p, h) (step) and the last p (outputs), in caller memory (ffx_lti_maps_init).  Read-only
 * for the caller; Ad (nx, nx), Bd (nx, nu), bd (nx) are valid while step_valid, Cx (ny, nx), Cu (ny, nu),
 * y0 (ny) while output_valid.  The counters count the recomputations (tests, benchmarks).  One ffx_lti_maps per
 * instance (not thread-safe); it holds no state of the system: x is the caller's (FMU get/set state need only x). */
typedef struct {
    const ffx_lti_model *model;
    int step_valid, output_valid;
    double h;                  /* step of Ad, Bd, bd */
    double *p_step, *p_output; /* (np) p of the step maps, of the output maps */
    double *Ad, *Bd, *bd;
    double *Cx, *Cu, *y0;
    double *z;               /* (nx + nu + nmono) [x; u; mono(p_output)] for the quadratic terms */
    double *mono, *x_new;    /* scratch: (nmono), (nx) */
    double *aug, *expm_work; /* scratch: the augmented matrix and its exponential (2, n, n), n = nx + nu + 1
                                      (ffx_lti_steps' state buffers between updates), and ffx_lti_expm's workspace */
    long n_step_updates, n_output_updates;
    /* the moving-base step (ffx_lti_taylor_prepare, ffx_lti_taylor_steps) */
    double *weights;         /* (nx) the series' norm: balance of A's constant coefficient (ffx_lti_balance) */
    double *norms;           /* (nmono) ||D^-1 A_k D||_inf per monomial: the weights of the change's rate */
    double *used;            /* (6, nmono) 1 where monomial k's block of A, B, b, Cx, Cu, y0 is not all zero */
    double *A_held, *g_held; /* (nx, nx), (nx): A(p) and B(p) u + b(p) of the prepared series step */
    double *p_taylor;        /* (np) p of the prepared / last series step */
    double *mono_before;     /* scratch (nmono) */
    double *a_cols;          /* (2, nx) per row of A: its first column and one past its last that any A_k has
                                non-zero (integers): the series' products visit those only */
    double taylor_h;         /* the prepared step */
    int taylor_substeps, taylor_terms, taylor_ready, taylor_last; /* plan (s, K); prepared; last step by it */
    long n_taylor_steps;                                          /* steps taken by the series */
} ffx_lti_maps;

/* 0 (FFX_LTI_OK) if the model's sizes and quadratic-term indices are consistent (nmono, 0 <= rows < ny,
 * 0 <= i, j < nx + nu + nmono, non-null arrays where sizes are non-zero, quad_start NULL or the row starts),
 * else FFX_LTI_BAD_ARGUMENT. */
int ffx_lti_check_model(const ffx_lti_model *m);

/* quad_start (ny + 1) of m's terms when they are ordered by row (non-decreasing quad_row): returns 1; else 0
 * (quad_start not valid: leave the model's NULL). */
int ffx_lti_quad_starts(const ffx_lti_model *m, int *quad_start);

/* mono[0 .. FFX_LTI_N_MONOMIALS(np) - 1] of p[0 .. np - 1] (order above). */
void ffx_lti_monomials(int np, const double *p, double *mono);

/* Continuous-time matrices for the monomials ``mono`` (ffx_lti_monomials of p): A (nx, nx), B (nx, nu), b (nx). */
void ffx_lti_assemble_dynamics(const ffx_lti_model *m, const double *mono, double *A, double *B, double *b);

/* Output matrices for ``mono``: Cx (ny, nx), Cu (ny, nu), y0 (ny) (the quadratic terms are not in them). */
void ffx_lti_assemble_outputs(const ffx_lti_model *m, const double *mono, double *Cx, double *Cu, double *y0);

/* Doubles of workspace ffx_lti_expm needs for an n x n matrix. */
size_t ffx_lti_expm_work_len(int n);

/* E = expm(M), M and E (n, n) row-major (E may not alias M): scaling and squaring with the [13/13] Pade
 * approximant (Higham 2005).  The scaling 2^-s as scipy.linalg.expm chooses it for degree 13 (Al-Mohy & Higham
 * 2009: from ||M^k||_1^(1/k), k = 6, 8, 10, raised by the bound on || |M|^27 ||_1), R from R (V - U) = V + U by LU
 * with partial pivoting (as scipy), then s squarings; a row of M that is zero gives exactly that row of I.
 * work: ffx_lti_expm_work_len(n) doubles.  FFX_LTI_NONFINITE if M or E is not finite, FFX_LTI_SINGULAR if the
 * Pade denominator is singular (only for |M| near the double range). */
int ffx_lti_expm(int n, const double *M, double *E, double *work);

/* Doubles of workspace the maps of model m need (ffx_lti_maps_init). */
size_t ffx_lti_maps_work_len(const ffx_lti_model *m);

/* Point ``maps`` at model m (checked, ffx_lti_check_model) and at ``work`` (work_len doubles, at least
 * ffx_lti_maps_work_len(m)); no maps valid yet.  FFX_LTI_BAD_ARGUMENT if the model is inconsistent or the
 * workspace too small. */
int ffx_lti_maps_init(ffx_lti_maps *maps, const ffx_lti_model *m, double *work, size_t work_len);

/* Forget the cached maps (the next step and outputs recompute them). */
void ffx_lti_maps_invalidate(ffx_lti_maps *maps);

/* Make Ad, Bd, bd those of step h (s, finite, >= 0) and parameters p (np): recomputed (expm of the augmented
 * matrix M = [[A B b]; [0 0 0]] h, E = expm(M): Ad = E[:nx, :nx], Bd = E[:nx, nx:nx+nu], bd = E[:nx, nx+nu])
 * only when h or any p[i] differs (!=) from the cached ones (a NaN never equals: recomputed, and fails).
 * FFX_LTI_NONFINITE if the maps are not finite (p or h too large), FFX_LTI_BAD_ARGUMENT for h.  On failure the
 * step maps are invalid. */
int ffx_lti_update_step_maps(ffx_lti_maps *maps, const double *p, double h);

/* Make Cx, Cu, y0 (and z's monomials) those of p: recomputed only when p differs from the cached one.
 * FFX_LTI_NONFINITE if not finite; on failure invalid. */
int ffx_lti_update_output_maps(ffx_lti_maps *maps, const double *p);

/* One exact zero-order-hold step: x_next = Ad x + Bd u + bd with the maps of (p, h) (updated as needed).
 * x_next may alias x; it is written only on FFX_LTI_OK (a failed step leaves it as it was). */
int ffx_lti_step(ffx_lti_maps *maps, const double *p, double h, const double *x, const double *u, double *x_next);

/* n >= 0 such steps with the same p, h and u (a communication step in n internal steps, or a benchmark loop);
 * x_next is written only if all n are finite. */
int ffx_lti_steps(ffx_lti_maps *maps, const double *p, double h, long n, const double *x, const double *u,
                  double *x_next);

/* y (ny) = Cx x + Cu u + y0 + the quadratic terms, with the output maps of p (updated as needed).  y is
 * written in any case; FFX_LTI_NONFINITE if an output is not finite. */
int ffx_lti_outputs(ffx_lti_maps *maps, const double *p, const double *x, const double *u, double *y);

/* The outputs of rows[0 .. n_rows - 1] only (distinct rows; rows NULL: rows 0 .. n_rows - 1), each with the same
 * arithmetic as ffx_lti_outputs; the other places of y are not written.  What a host reads is computed, not every
 * output: FFX_LTI_NONFINITE if a computed one is not finite. */
int ffx_lti_output_rows(ffx_lti_maps *maps, const double *p, const double *x, const double *u, const int *rows,
                        int n_rows, double *y);

/* ---- the moving-base step (flexfmu/native/lti_taylor.py: the same rule, constants and bound) ----
 *
 * With p held, x' = A x + g (g = B(p) u + b(p)) and x+ = x + sum_{k>=1} w_k, w_1 = h (A x + g), w_k = (h/k) A w_{k-1}
 * (the top rows of expm([[hA, hg]; [0, 0]]) [x; 1]).  In ||y||_D = max_i |y_i| / d_i (d = weights) with theta =
 * ||D^-1 hA D||_inf, the terms after the K-th sum to at most tail(theta, K) ||w_1||_D, tail <= theta^K / (K+1)! /
 * (1 - theta/(K+2)); K is the least with tail <= 2^-53 (truncation below the rounding of w_1), in s =
 * ceil(theta / FFX_LTI_THETA_SUBSTEP) equal sub-steps.  Rule, for a step with p after p_before (the p the step
 * before held): p = p_before, or a jump, rate = sum_k |mono_k(p) - mono_k(p_before)| norms_k / (h norms_0^2) >
 * FFX_LTI_RATE_MAX (A's rate of change against the structure's time scale 1 / ||A_0||): the maps (one exponential,
 * reused while p holds); else the series when n s (K nx^2 + nx) < FFX_LTI_EXPM_COST_FACTOR (nx + nu + 1)^3, else
 * the maps.  Outputs read after a series step at its p: the rows asked for are assembled
 * without the cache, with the arithmetic of the cached maps (the same bits). */
#define FFX_LTI_THETA_SUBSTEP 2.5
#define FFX_LTI_MAX_TERMS 60
#define FFX_LTI_EXPM_COST_FACTOR 10.0
#define FFX_LTI_RATE_MAX (1.0 / 16384.0)
#define FFX_LTI_BALANCE_SWEEPS 20

/* d (n) balancing the (n, n) matrix A (Osborne: d_i = sqrt(r_i / c_i), r_i = sum_{j != i} |a_ij| d_j, c_i =
 * sum_{j != i} |a_ji| / d_j, FFX_LTI_BALANCE_SWEEPS sweeps in index order; zero row or column: d_i kept). */
void ffx_lti_balance(int n, const double *A, double *d);

/* The plan for theta = ||D^-1 hA D||_inf: 1 and s, K (above); 0 if theta is not finite or negative. */
int ffx_lti_taylor_plan(double theta, int *substeps, int *terms);

/* theta^K / (K+1)! / (1 - theta/(K+2)) (>= sum_{k>K} theta^(k-1) / k!), or inf for theta >= K + 2. */
double ffx_lti_taylor_tail(double theta, int terms);

/* 1 when n steps h with p held after p_before go by the series (the rule above; A(p), g and the plan then prepared
 * in maps), else 0: take the maps (ffx_lti_steps).  p_before NULL: 0.  0 also when A(p) or g is not finite (the
 * maps then fail with their own diagnostics). */
int ffx_lti_taylor_prepare(ffx_lti_maps *maps, const double *p_before, const double *p, double h, long n,
                           const double *u);

/* n steps by the prepared series (n as prepared); x_next may alias x and is written only on FFX_LTI_OK
 * (FFX_LTI_NONFINITE: the state overflows); FFX_LTI_BAD_ARGUMENT if nothing is prepared. */
int ffx_lti_taylor_steps(ffx_lti_maps *maps, long n, const double *x, double *x_next);

/* n steps with p held after p_before: the series when ffx_lti_taylor_prepare takes them, else ffx_lti_steps. */
int ffx_lti_steps_held(ffx_lti_maps *maps, const double *p_before, const double *p, double h, long n, const double *x,
                       const double *u, double *x_next);

/* A static English description of a return code. */
const char *ffx_lti_status_string(int status);

#endif
