/*
 * reframe_kernels.h - the reframe free-body integrator's per-step kernels (consistent scheme: classical
 * RK4; exponential scheme: Cox-Matthews ETD-RK4) and the outputs of one state, in modal space, on flat
 * arrays of doubles.  The one compiled implementation: the Python library calls it through ctypes
 * (flexfmu/native/reframe.py), native FMUs link it.  The numpy reference of the same equations is
 * flexfmu/reframe/kernels_numpy.py (tests/test_native_reframe_kernels.py compares the two).
 *
 * C99, libc/libm only, no global state, no allocation: every function is reentrant (thread-safe as
 * long as threads do not share a workspace or an output array).  Built with IEEE semantics
 * (flexfmu/native/compiler.py: -O2 -ffp-contract=off, no fast-math).
 *
 * Conventions
 *   - every array is a contiguous row-major array of double (except `order`: int64_t);
 *   - 3x3 matrices are row-major 9-vectors: M[3 a + b] = M_ab;
 *   - nf = number of flexible modes (>= 0); there are FFX_REFRAME_N_RIGID = 6 rigid modes before them;
 *   - "empty" optional arrays (G, EX) are passed as NULL.
 *
 * Flat arrays (Python declarations: flexfmu/reframe/layout.py; docstring of flexfmu/reframe/kernels.py)
 *
 *   P   model parameters, FFX_REFRAME_PARAM_SIZE(nf) doubles, blocks in this order (start offsets:
 *       ffx_reframe_offsets, the same numbers as layout.param_layout(nf)):
 *         m         1           total mass
 *         J0        9           body-frame inertia about the frame point (the centre of mass), undeformed
 *         A_j       nf * 9      (nf, 3, 3)       A(q) = sum_j q_j A_j
 *         B_j       nf * 9      (nf, 3, 3)       B_j + B_j^T (symmetrised)
 *         C_jk      nf*nf * 9   (nf, nf, 3, 3)   J(q) = J0 + sum_j q_j B_j + sum_jk q_j q_k C_jk,
 *                                                C_kj = C_jk^T (the kernels rely on it)
 *         D_j       nf * 3*nf   (nf, 3, nf)      D(q) = sum_j q_j D_j  (3 x nf)
 *         k_F       nf          modal stiffnesses (omega_j^2)
 *         c_F       nf          modal damping coefficients
 *         A6        36          (6, 6)  (v, omega) = A6 qdot_R
 *         A6inv     36          (6, 6)  its inverse
 *         com       3           the centre of mass c in the mesh's coordinates (the frame origin is at
 *                                  y[0:3] - R c; arms and output points are given as X - c)
 *       The generalised mass matrix of (v, omega, qdot_F) is [[m I, A, 0], [A^T, J, D], [0, D^T, I]].
 *
 *   y   state, FFX_REFRAME_STATE_SIZE(nf) = 12 + 2 (6 + nf) doubles (layout.STATE):
 *         [0, 3)   frame point = centre of mass (global)
 *         [3, 12)  rotation body -> global (3x3 row-major)
 *         [12, ..) eta = [q_R (6), q_F (nf), qdot_R (6), qdot_F (nf)]
 *
 *   LP  loads, n_loads blocks of FFX_REFRAME_LOAD_STRIDE(nf) = 5 + 6 nf doubles each:
 *         [0]           follower (1.0: force/moment given in body components; 0.0: global)
 *         [1]           1.0 if the load point has rotational DOFs (the moment acts on the modes), else 0.0
 *         [2, 5)        arm X_i - c (body frame)
 *         [5, 5+3nf)    translational rows of Phi at the load node (3, nf)
 *         [5+3nf, ..)   rotational rows of Phi at the node (3, nf) (zeros if none)
 *
 *   SV  load values, (n_rows, 3, n_loads, 6): per step, per stage (t, t + dt/2, t + dt), per load
 *       [force (3), moment (3)].  n_rows = 1 if `held` (the same values every step), else >= n.
 *   sv  the load values of one instant, (n_loads, 6) (the output kernels).
 *
 *   G   geometric stiffness, 9 nf^2 doubles, (3, 3, nf, nf) row-major, body frame, or NULL: adds
 *       -(sum_ab X_ab G_ab) q_F with X = skew(omega)^2 = omega omega^T - |omega|^2 I to the flexible
 *       momentum rate.
 *
 *   EX  exponential-scheme coefficients for one dt, 24 nf doubles, (nf, 6, 2, 2) row-major: per mode
 *       E1, E2, A2, B1, B2, B4 acting on (q_j, p_j) (flexfmu.reframe.schemes.exponential_coefficients),
 *       or NULL: classical RK4 (the consistent scheme).
 *
 *   PP  output points, (n_points, 3 + 3 nf): per point [X - c (3), translational rows of Phi (3, nf)].
 *
 *   out outputs of one state, FFX_REFRAME_OUTPUT_SIZE(nf, n_points) doubles (layout.output_layout):
 *         [0,3) frame origin (the mesh origin, global)  [3,6) its velocity  [6,10) quaternion (w, x, y, z;
 *         w >= 0) of R  [10,13) omega (body)  [13,16) alpha (body)  [16,19) centre of mass (= y[0:3])
 *         [19,22) centre-of-mass velocity (global)  [22, 22+nf) q_F  [22+nf, 22+2nf) qdot_F
 *         [22+2nf] max elastic displacement (FFX_REFRAME_NOT_COMPUTED when the search is skipped),
 *         then per point 18 doubles: position,
 *         velocity, acceleration (global, with the elastic motion), and the same three of the rigid
 *         motion alone (point fixed at X).
 *
 *   Max elastic displacement search (flexfmu.reframe.kernel_data.max_displacement_blocks):
 *   Psi     the modal matrix, (n_dof, psi_cols) row-major; node i's translational rows are
 *           dpn * i + 0..2, the flexible modes' columns col .. col + nf - 1 (col = 6 in the outputs)
 *   order   (n_nodes,) int64 node indices along a space-filling curve; n_nodes = 0 skips the search
 *   bc, br  per block of FFX_REFRAME_BLOCK consecutive nodes of `order`: mean of the nodes' Phi_i
 *           (n_blocks, 3 nf) and radius (n_blocks,)
 *   sc, sr  per superblock of FFX_REFRAME_BLOCK blocks: the same, (n_super, 3 nf) and (n_super,)
 *
 * Workspace: the steps and output kernels take `work`, FFX_REFRAME_WORK_SIZE(nf) doubles the caller
 * owns (contents need not be initialised, are garbage afterwards; one per concurrent caller).
 */
#ifndef FLEXFMU_REFRAME_KERNELS_H
#define FLEXFMU_REFRAME_KERNELS_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* bumped whenever a signature or a layout below changes */
#define FFX_REFRAME_ABI_VERSION 1

#define FFX_REFRAME_N_RIGID 6
/* nodes per block and blocks per superblock of the max elastic displacement search */
#define FFX_REFRAME_BLOCK 16
/* the max elastic displacement's value when its search was skipped (a norm is never < 0) */
#define FFX_REFRAME_NOT_COMPUTED (-1.0)

#define FFX_REFRAME_PARAM_SIZE(nf) (85 + 20 * (nf) + 12 * (nf) * (nf))
#define FFX_REFRAME_STATE_SIZE(nf) (12 + 2 * (FFX_REFRAME_N_RIGID + (nf)))
#define FFX_REFRAME_LOAD_STRIDE(nf) (5 + 6 * (nf))
#define FFX_REFRAME_OUTPUT_SIZE(nf, n_points) (23 + 2 * (nf) + 18 * (n_points))
/* doubles of workspace the steps and output kernels need (an upper bound; both kernels) */
#define FFX_REFRAME_WORK_SIZE(nf) (256 + 64 * (nf))

/* return values of ffx_reframe_steps */
#define FFX_REFRAME_OK 0
#define FFX_REFRAME_LOADS_NOT_FINITE 1
#define FFX_REFRAME_STATE_NOT_FINITE 2

/* index of each block's start in FFX_REFRAME_OFFSETS order, for ffx_reframe_offsets */
enum {
    FFX_REFRAME_O_J0 = 0,
    FFX_REFRAME_O_A,
    FFX_REFRAME_O_B,
    FFX_REFRAME_O_C,
    FFX_REFRAME_O_D,
    FFX_REFRAME_O_K,
    FFX_REFRAME_O_CF,
    FFX_REFRAME_O_A6,
    FFX_REFRAME_O_A6INV,
    FFX_REFRAME_O_COM,
    FFX_REFRAME_O_END,
    FFX_REFRAME_N_OFFSETS
};

/* FFX_REFRAME_ABI_VERSION of the compiled library (check it after loading). */
int ffx_reframe_abi_version(void);

/* ------------------------------------------------------------------------------------------- whole steps */

/*
 * n steps of dt of the free body from state y at time *t, in place.
 *   P, LP, n_loads, G, EX, nf, deformed, SV, held: as above.  deformed != 0: a load's moment about the
 *     frame point uses the deformed load point (arm + Phi q), else the undeformed arm.
 *   G == NULL: no geometric stiffness.  EX == NULL: classical RK4 (consistent scheme), else ETD-RK4
 *     with the coefficients EX of this dt (exponential scheme).
 *   t      in: the time of y; out: the time of y on return (t + dt per step done, by repeated addition;
 *          also + dt for the failed step when the state is not finite)
 *   n      number of steps (>= 0)
 *   y      in: the state; out: the state after *steps_done steps (after the failed step when the
 *          return value is FFX_REFRAME_STATE_NOT_FINITE)
 *   steps_done  out: the steps completed (n on success, else the index of the step that failed)
 *   work   FFX_REFRAME_WORK_SIZE(nf) doubles
 * Returns FFX_REFRAME_OK, FFX_REFRAME_LOADS_NOT_FINITE (the load values of step *steps_done are not all
 * finite; y and *t unchanged by it) or FFX_REFRAME_STATE_NOT_FINITE (the state after that step is not
 * finite).  The Python names: flexfmu.reframe.kernels.reframe_steps / consistent_steps.
 */
int ffx_reframe_steps(const double *P, const double *LP, int n_loads, const double *G, const double *EX, int nf,
                      int deformed, const double *SV, int held, double *t, double dt, int n, double *y, int *steps_done,
                      double *work);

/* ffx_reframe_steps with G = EX = NULL (the consistent scheme without geometric stiffness). */
int ffx_reframe_consistent_steps(const double *P, const double *LP, int n_loads, int nf, int deformed, const double *SV,
                                 int held, double *t, double dt, int n, double *y, int *steps_done, double *work);

/* ---------------------------------------------------------------------------------- outputs of a state */

/*
 * All outputs of state y with the load values sv (n_loads, 6) at its time, into
 * out[FFX_REFRAME_OUTPUT_SIZE(nf, n_points)] (layout above).  G: as ffx_reframe_steps (NULL: none).
 * PP: n_points output points.  The max elastic displacement: ffx_reframe_max_node_norm(Psi, psi_cols,
 * FFX_REFRAME_N_RIGID, dpn, order, n_nodes, bc, br, n_blocks, sc, sr, n_super, q, nf), or
 * FFX_REFRAME_NOT_COMPUTED when n_nodes == 0 (Psi ... sr may then be NULL).
 * work: FFX_REFRAME_WORK_SIZE(nf) doubles.  Python: flexfmu.reframe.kernels.reframe_outputs.
 */
void ffx_reframe_outputs(const double *P, const double *LP, int n_loads, const double *G, int nf, int deformed,
                         const double *sv, const double *y, const double *PP, int n_points, const double *Psi,
                         int psi_cols, int dpn, const int64_t *order, int n_nodes, const double *bc, const double *br,
                         int n_blocks, const double *sc, const double *sr, int n_super, double *out, double *work);

/* ffx_reframe_outputs with G = NULL.  Python: flexfmu.reframe.kernels.consistent_outputs. */
void ffx_reframe_consistent_outputs(const double *P, const double *LP, int n_loads, int nf, int deformed,
                                    const double *sv, const double *y, const double *PP, int n_points,
                                    const double *Psi, int psi_cols, int dpn, const int64_t *order, int n_nodes,
                                    const double *bc, const double *br, int n_blocks, const double *sc,
                                    const double *sr, int n_super, double *out, double *work);

/* ---------------------------------------------------------------------- max elastic displacement search */

/*
 * max over nodes i of |Phi_i q| (Phi_i: rows dpn*i .. dpn*i+2, columns col .. col+nf-1 of Psi), exact,
 * by the block bounds (see the layout above): 0 if nf == 0.  Python: kernels.max_node_norm.
 */
double ffx_reframe_max_node_norm(const double *Psi, int psi_cols, int col, int dpn, const int64_t *order, int n_nodes,
                                 const double *bc, const double *br, int n_blocks, const double *sc, const double *sr,
                                 int n_super, const double *q, int nf);

/* Upper bound of |Phi_i q| over (super)block b: (|C_b q| + r_b qn) (1 + 1e-12), C: (n, 3 nf), r: (n,),
 * qn = |q|.  Python: kernels_numpy._bound. */
double ffx_reframe_bound(const double *C, const double *r, int b, const double *q, int nf, double qn);

/* max(best, max over the nodes of block b of |Phi_i q|) (block b: order[b*BLOCK .. min((b+1)*BLOCK,
 * n_nodes)-1]).  Python: kernels_numpy._block_norm. */
double ffx_reframe_block_norm(const double *Psi, int psi_cols, int col, int dpn, const int64_t *order, int n_nodes,
                              int b, const double *q, int nf, double best);

/* ------------------------------------------------------------------------ exponential-scheme coefficients */

/* doubles of workspace of ffx_reframe_exponential_coefficients (two 8x8 matrices and ffx_lti_expm's 8x8
 * workspace, ffx_lti_expm_work_len(8) = 536) */
#define FFX_REFRAME_EXPONENTIAL_WORK_SIZE (128 + 536)

/*
 * EX (24 nf doubles, the layout above) of the exponential scheme for a step dt from the modal stiffnesses
 * kF (nf) and damping coefficients cF (nf): a port of flexfmu.reframe.schemes.exponential_coefficients (the
 * scipy reference), the 8x8 exponentials by ffx_lti_expm (lti_kernels.c: link it too).  work:
 * FFX_REFRAME_EXPONENTIAL_WORK_SIZE doubles.  Returns FFX_REFRAME_OK, or FFX_REFRAME_STATE_NOT_FINITE when a
 * coefficient is not finite (EX then holds them anyway).  Python: flexfmu.native.reframe.exponential_coefficients.
 */
int ffx_reframe_exponential_coefficients(int nf, const double *kF, const double *cF, double dt, double *EX,
                                         double *work);

/* ------------------------------------------------------------------------------------- small helpers */

/* Start offsets of P's blocks for nf modes into off[FFX_REFRAME_N_OFFSETS] (J0, A, B, C, D, k, c, A6,
 * A6inv, com, end = FFX_REFRAME_PARAM_SIZE(nf)).  Python: layout.param_layout. */
void ffx_reframe_offsets(int nf, int *off);

/* R = exp(skew(phi)) (Rodrigues), row-major.  Python: core.rotation.rodrigues_into. */
void ffx_reframe_rodrigues(const double *phi, double *R);

/* c(theta) of the rotation-vector rate phi' = w + phi x w / 2 + c(theta) phi x (phi x w).
 * Python: core.rotation.rotvec_rate_coefficient. */
double ffx_reframe_rate_coefficient(double theta);

/* x = S^{-1} r for a 3x3 row-major S (Gaussian elimination with partial pivoting).
 * Python: kernels_numpy._solve3. */
void ffx_reframe_solve3(const double *S, const double *r, double *x);

/* Unit quaternion (w, x, y, z), w >= 0, of the rotation matrix R (row-major).  Python: core.rotation.quaternion_from_rotation. */
void ffx_reframe_quaternion(const double *R, double *quat);

#ifdef __cplusplus
}
#endif

#endif
