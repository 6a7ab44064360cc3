/*
 * native_reframe.c - the "reframe" kind of the native runtime (native_kind.h): a free flexible body by the reframe
 * integrator's exponential scheme (ETD-RK4, flexfmu.reframe.integrator), stepped by the compiled kernels of
 * reframe_kernels.h (flexfmu/native/csrc; the same code the Python library calls through ctypes), for ReframeBody.
 * It does what flexfmu.reframe.simulator.ReframeBodySimulator does per step, on the arrays that simulator's
 * integrator computed (one implementation of the numerics: Python computes the model arrays once, C steps them).
 *
 * Model-file entries (flexfmu/fmi/native.py writes them from a ReframeBodySimulator):
 *   reframe.P         float64 (FFX_REFRAME_PARAM_SIZE(nf))   the packed model (its c_F block is recomputed from
 *                                                           damping_ratio when that is a runtime parameter)
 *   reframe.LP        float64 (FFX_REFRAME_LOAD_STRIDE(nf))  the load point (one load; its follower flag from
 *                                                           force_follows_body)
 *   reframe.PP        float64 (1, 3 + 3 nf)                 the output point
 *   reframe.omega     float64 (nf)    the flexible modes' circular frequencies (c_F = 2 zeta omega)
 *   reframe.Psi       float64 (n_dof, 6 + nf), reframe.order int32 (n_nodes), reframe.bc (n_blocks, 3 nf),
 *   reframe.br (n_blocks), reframe.sc (n_super, 3 nf), reframe.sr (n_super)   the max-displacement search
 *   reframe.int       int32 (6): nf, dpn, deformed load arm, rotational DOFs (moments accepted), log_split, 0
 *   reframe.real      float64 (4): |arm| of the load point about the centre of mass, smallest principal moment of
 *                     inertia J_min, body radius about the centre of mass, mass
 *   reframe.columns   int32 (n_outputs): the kernel output-vector index of each FMU output (FMU output order)
 *   reframe.role      int32 (11): the runtime parameter (index) of damping_ratio, tolerance, internal_step,
 *                     max_internal_steps, v0_x, v0_y, v0_z, omega0_1, omega0_2, omega0_3, force_follows_body, or
 *                     -1: fixed at build, at reframe.fixed's value
 *   reframe.fixed     float64 (11): the build values of the same
 *
 * Exported free bodies (flexfmu.body FreeEngine, flexfmu.fmi.native.body_source) add:
 *   reframe.body      int32 (4): 1 (the exported free body's rules below), scheme (0 exponential, 1 consistent),
 *                     n_loads (interfaces), 0
 *   reframe.loads     int32 (n_loads, 2): each interface's first input and its number of inputs (3: F; 6: F, M);
 *                     LP then has n_loads blocks, PP (n_points, 3 + 3 nf) one row per interface
 *   reframe.limit     float64 (1): the RK4 stability limit 2.8 / omega_max (scheme consistent; inf otherwise)
 *   reframe.extra     float64 (n_extra): constant outputs (f_1 .. f_k)
 *   reframe.rows      float64 (n_rows, nf), optional: outputs linear in the flexible coordinates q_F (the gauges'
 *                     stress S q_F and strain E q_F, flexfmu.body.engines.FreeEngine.shape_rows; a zero row for a
 *                     von Mises output, overwritten below)
 *   reframe.von_mises int32 (n_vm, 7), optional: per von Mises output its index among the FMU's outputs, then those
 *                     of its six stress outputs in VOIGT order (csrc/derived_stress.h's ffx_von_mises, the formula of
 *                     flexfmu/core/stress.py); evaluated after the others
 * and reframe.columns may then be negative: -1 - j is the j-th of [rot (3), omega (3), alpha (3) global, the
 * constants of reframe.extra, the rows of reframe.rows on q_F] (flexfmu.body.simulator._frame_global of q,
 * omega_k, alpha_k); the shape coordinates q_1 .. q_nf are the kernel columns 22 .. 21 + nf.  Their split is
 * FreeEngine.split: exponential with internal_step = 0: n = ceil(h (wm + sqrt(wm^2 + 2 a theta)) / (2 theta))
 * with wm = w + a h, w, a = |omega|, |alpha| of the state with the inputs now held, theta = 0.5 tolerance^(1/4);
 * otherwise n = ceil(h / max_step (1 - 1e-12)), max_step = internal_step, or 90 % of the RK4 limit (consistent).
 *
 * The max elastic displacement (kernel column 22 + 2 nf, a search over every node) is the layout's deferred output
 * (the model file's outputs.deferred, from the spec's deferred outputs): outputs() searches only when it is asked
 * for (ffx_reframe_max_node_norm on q_F of x alone when no other output is: the value ffx_reframe_outputs gives),
 * and report notes at fmi2Terminate how many searches were done.  The other outputs come from one kernel call, so
 * one asked for writes all of them.
 *
 * A communication step h with the inputs held is n equal internal steps, n as ReframeBodySimulator._split:
 * internal_step > 0: ceil(h / internal_step (1 - 1e-12)); internal_step = 0: the rotation per internal step,
 * |omega| h + |alpha| h^2 / 2 at the step's start (omega, alpha of the state with the inputs the previous step
 * held, alpha raised by (|arm| |dF| + |dM|) / J_min when the inputs changed), at most 0.5 tolerance^(1/4) rad.
 * More than max_internal_steps: fmi2Discard when a 1e-5 s communication step would be within the cap, else
 * fmi2Error naming the input or spin behind it.  The coefficients EX are recomputed when the internal step
 * changes (ffx_reframe_exponential_coefficients, the C port of the Python scheme's).
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "flexfmu_bridge.h"
#include "native_kind.h"
#include "derived_stress.h" /* ffx_von_mises: a free body's gauges */
#include "lti_kernels.h"    /* ffx_same_step: one step for a host's last-bit variants */
#include "reframe_kernels.h"
#include "step_policy.h"

#define N_ROLES 11
#define FFX_PI 3.14159265358979323846
#define AUTO_STEP_FRACTION 0.9 /* flexfmu.body.engines.AUTO_STEP_FRACTION */
enum { R_ZETA, R_TOL, R_INTERNAL, R_CAP, R_V0, R_OMEGA0 = R_V0 + 3, R_FOLLOW = R_OMEGA0 + 3 };
static const char *const ROLE_NAMES[N_ROLES]
    = {"damping_ratio", "tolerance", "internal_step", "max_internal_steps", "v0_x", "v0_y", "v0_z",
       "omega0_1",      "omega0_2",  "omega0_3",      "force_follows_body"};

typedef struct {
    NativeLayout layout;
    int nf, dpn, deformed, rotational, log_split, psi_cols, n_nodes, n_blocks, n_super, n_out;
    int free_body, consistent, n_loads, n_points, n_extra; /* free_body: an exported free body (header) */
    int n_rows, n_vm;                                      /* reframe.rows, reframe.von_mises (0: none) */
    const double *P, *LP, *PP, *omega, *Psi, *bc, *br, *sc, *sr, *fixed, *extra, *rows;
    const int32_t *columns, *role, *loads, *von_mises;
    double limit;
    int64_t *order;
    double arm, J_min, size, mass;
    int search_column; /* the max elastic displacement's kernel column (22 + 2 nf) */
    int search_always; /* an output that is not deferred needs the search */
} ReframeModel;

typedef struct {
    const ReframeModel *m;
    double *P, *LP, *EX, *work, *ework, *out, *y;
    double *SV, *sv;
    double ex_dt; /* dt of EX (0: none yet) */
    double roles[N_ROLES];
    double theta_max, internal_step, max_step;
    long cap, last_split;
    long n_steps, n_searches; /* communication steps done, max elastic displacement searches (report) */
} ReframeSim;

static void *load(const NativeFile *file, const NativeLayout *layout, char *why, size_t why_size) {
    ReframeModel *m = calloc(1, sizeof *m);
    if (!m) {
        snprintf(why, why_size, "out of memory");
        return NULL;
    }
    m->layout = *layout;
    uint32_t s[NATIVE_MAX_DIMS];
    const int32_t *ints, *order;
    const double *reals;
    long six[1] = {6}, four[1] = {4}, roles[1] = {N_ROLES}, nout[1] = {(long)layout->n_outputs};
    if (native_i32(file, "reframe.int", 1, six, &ints, NULL, why, why_size) < 0
        || native_f64(file, "reframe.real", 1, four, &reals, NULL, why, why_size) < 0
        || native_i32(file, "reframe.columns", 1, nout, &m->columns, NULL, why, why_size) < 0
        || native_i32(file, "reframe.role", 1, roles, &m->role, NULL, why, why_size) < 0
        || native_f64(file, "reframe.fixed", 1, roles, &m->fixed, NULL, why, why_size) < 0)
        goto fail;
    m->nf = ints[0], m->dpn = ints[1], m->deformed = ints[2], m->rotational = ints[3], m->log_split = ints[4];
    m->arm = reals[0], m->J_min = reals[1], m->size = reals[2], m->mass = reals[3];
    m->n_out = (int)layout->n_outputs;
    m->n_loads = 1, m->limit = INFINITY;
    if (native_entry(file, "reframe.body")) {
        const int32_t *body;
        const double *limit;
        long sb[1] = {4}, one[1] = {1};
        if (native_i32(file, "reframe.body", 1, sb, &body, NULL, why, why_size) < 0) goto fail;
        m->free_body = body[0] != 0, m->consistent = body[1] != 0, m->n_loads = body[2];
        long sl2[2] = {m->n_loads, 2};
        if (m->n_loads < 1 || native_i32(file, "reframe.loads", 2, sl2, &m->loads, NULL, why, why_size) < 0
            || native_f64(file, "reframe.limit", 1, one, &limit, NULL, why, why_size) < 0
            || native_f64(file, "reframe.extra", 1, NULL, &m->extra, s, why, why_size) < 0)
            goto fail;
        m->limit = limit[0], m->n_extra = (int)s[0];
        long srow[2] = {-1, ints[0]}, svm[2] = {-1, 7};
        if (native_entry(file, "reframe.rows")) {
            if (native_f64(file, "reframe.rows", 2, srow, &m->rows, s, why, why_size) < 0) goto fail;
            m->n_rows = (int)s[0];
        }
        if (native_entry(file, "reframe.von_mises")) {
            if (native_i32(file, "reframe.von_mises", 2, svm, &m->von_mises, s, why, why_size) < 0) goto fail;
            m->n_vm = (int)s[0];
            for (int k = 0; k < 7 * m->n_vm; k++)
                if (m->von_mises[k] < 0 || m->von_mises[k] >= (int32_t)layout->n_outputs) goto bad_index;
        }
        for (int i = 0; i < m->n_loads; i++)
            if (m->loads[2 * i] < 0 || (m->loads[2 * i + 1] != 3 && m->loads[2 * i + 1] != 6)
                || (size_t)(m->loads[2 * i] + m->loads[2 * i + 1]) > layout->n_inputs)
                goto bad_index;
    }
    int nf = m->nf;
    if (nf < 0 || m->dpn < 3 || (!m->free_body && layout->n_inputs != 6)) {
        snprintf(why, why_size, "the model file's reframe sizes are inconsistent (nf %d, dpn %d, %zu inputs)", nf,
                 m->dpn, layout->n_inputs);
        goto fail;
    }
    long sp[1] = {FFX_REFRAME_PARAM_SIZE(nf)}, sl[1] = {(long)m->n_loads * FFX_REFRAME_LOAD_STRIDE(nf)},
         spp[2] = {m->free_body ? -1 : 1, 3 + 3 * nf}, so[1] = {nf}, spsi[2] = {-1, 6 + nf}, sbc[2] = {-1, 3 * nf};
    if (native_f64(file, "reframe.P", 1, sp, &m->P, NULL, why, why_size) < 0
        || native_f64(file, "reframe.LP", 1, sl, &m->LP, NULL, why, why_size) < 0
        || native_f64(file, "reframe.PP", 2, spp, &m->PP, s, why, why_size) < 0)
        goto fail;
    m->n_points = (int)s[0];
    if (native_f64(file, "reframe.omega", 1, so, &m->omega, NULL, why, why_size) < 0
        || native_f64(file, "reframe.Psi", 2, spsi, &m->Psi, s, why, why_size) < 0)
        goto fail;
    m->psi_cols = (int)s[1];
    long n_dof = s[0];
    if (native_i32(file, "reframe.order", 1, NULL, &order, s, why, why_size) < 0) goto fail;
    m->n_nodes = (int)s[0];
    if (native_f64(file, "reframe.bc", 2, sbc, &m->bc, s, why, why_size) < 0) goto fail;
    m->n_blocks = (int)s[0];
    long sbr[1] = {m->n_blocks};
    if (native_f64(file, "reframe.br", 1, sbr, &m->br, NULL, why, why_size) < 0
        || native_f64(file, "reframe.sc", 2, sbc, &m->sc, s, why, why_size) < 0)
        goto fail;
    m->n_super = (int)s[0];
    long ssr[1] = {m->n_super};
    if (native_f64(file, "reframe.sr", 1, ssr, &m->sr, NULL, why, why_size) < 0) goto fail;
    if (!(m->order = malloc(sizeof(int64_t) * (size_t)(m->n_nodes + 1)))) {
        snprintf(why, why_size, "out of memory");
        goto fail;
    }
    for (int i = 0; i < m->n_nodes; i++) {
        if (order[i] < 0 || (long)m->dpn * order[i] + 2 >= n_dof) goto bad_index;
        m->order[i] = order[i];
    }
    for (int k = 0; k < m->n_out; k++)
        if (m->columns[k] >= FFX_REFRAME_OUTPUT_SIZE(nf, m->n_points)
            || (m->columns[k] < 0 && !(m->free_body && -1 - m->columns[k] < 9 + m->n_extra + m->n_rows)))
            goto bad_index;
    for (int k = 0; k < N_ROLES; k++)
        if (m->role[k] >= (int32_t)layout->n_params) goto bad_index;
    m->search_column = 22 + 2 * nf;
    for (int k = 0; k < m->n_out; k++) {
        int deferred = layout->deferred && layout->deferred[k];
        if (deferred && m->columns[k] != m->search_column) {
            snprintf(why, why_size,
                     "the model file defers output %s, which the reframe kind computes with the "
                     "others (only max_elastic_displacement can be deferred)",
                     layout->output_names[k]);
            goto fail;
        }
        if (!deferred && m->columns[k] == m->search_column) m->search_always = 1;
    }
    return m;
bad_index:
    snprintf(why, why_size, "the model file's reframe index maps point outside the model or the FMU's variables");
fail:
    if (m) free(m->order);
    free(m);
    return NULL;
}

static void free_model(void *model) {
    ReframeModel *m = model;
    if (!m) return;
    free(m->order);
    free(m);
}

static size_t state_size(const void *model) {
    return (size_t)FFX_REFRAME_STATE_SIZE(((const ReframeModel *)model)->nf);
}

static void free_sim(void *sim) {
    ReframeSim *s = sim;
    if (!s) return;
    free(s->P);
    free(s->LP);
    free(s->EX);
    free(s->work);
    free(s->ework);
    free(s->out);
    free(s->y);
    free(s->SV);
    free(s->sv);
    free(s);
}

static double norm3(const double *v) {
    /* as Python's math.hypot of three (scaled against overflow) */
    double a = fabs(v[0]), b = fabs(v[1]), c = fabs(v[2]);
    double mx = a > b ? (a > c ? a : c) : (b > c ? b : c);
    if (mx == 0.0 || !isfinite(mx)) return isnan(a + b + c) && !isinf(mx) ? NAN : mx;
    a /= mx, b /= mx, c /= mx;
    return mx * sqrt(a * a + b * b + c * c);
}

/* FreeEngine.__init__'s checks of the internal step (an exported free body); sets s->max_step. */
static int free_checks(ReframeSim *s, double shortest, NativeResult *r) {
    const ReframeModel *m = s->m;
    double h = s->internal_step;
    if (h > m->limit)
        return native_refuse(r, BRIDGE_ERROR,
                             "internal_step: %g s exceeds the RK4 stability limit 2.8 / omega_max = "
                             "%.6g s (allowed: 0 (automatic) or %.3g .. %.6g s, or scheme "
                             "exponential)",
                             h, m->limit, shortest, m->limit);
    s->max_step = h > 0 ? h : (m->consistent ? AUTO_STEP_FRACTION * m->limit : INFINITY);
    if (s->max_step < shortest)
        return native_refuse(r, BRIDGE_ERROR,
                             "%s: internal steps of %.3g s need more than max_internal_steps = %ld "
                             "for a %g s communication step (allowed: scheme exponential, fewer "
                             "modes, or a larger max_internal_steps)",
                             h == 0 ? "scheme" : "internal_step", s->max_step, s->cap, FFX_MIN_COMMUNICATION_STEP);
    return 0;
}

static void *init(const void *model, const double *params, const char *const *texts, double *x, NativeResult *r) {
    (void)texts; /* no String parameters */
    const ReframeModel *m = model;
    int nf = m->nf;
    ReframeSim *s = calloc(1, sizeof *s);
    if (!s || !(s->P = malloc(sizeof(double) * FFX_REFRAME_PARAM_SIZE(nf)))
        || !(s->LP = malloc(sizeof(double) * FFX_REFRAME_LOAD_STRIDE(nf) * (size_t)m->n_loads))
        || !(s->EX = calloc((size_t)(24 * nf + 1), sizeof(double)))
        || !(s->work = malloc(sizeof(double) * FFX_REFRAME_WORK_SIZE(nf)))
        || !(s->ework = malloc(sizeof(double) * FFX_REFRAME_EXPONENTIAL_WORK_SIZE))
        || !(s->out = malloc(sizeof(double) * FFX_REFRAME_OUTPUT_SIZE(nf, m->n_points)))
        || !(s->SV = calloc((size_t)(18 * m->n_loads), sizeof(double)))
        || !(s->sv = calloc((size_t)(6 * m->n_loads), sizeof(double)))
        || !(s->y = malloc(sizeof(double) * FFX_REFRAME_STATE_SIZE(nf)))) {
        free_sim(s);
        native_refuse(r, BRIDGE_ERROR, "out of memory");
        return NULL;
    }
    s->m = m;
    for (int k = 0; k < N_ROLES; k++) s->roles[k] = m->role[k] >= 0 ? params[m->role[k]] : m->fixed[k];
    memcpy(s->P, m->P, sizeof(double) * FFX_REFRAME_PARAM_SIZE(nf));
    memcpy(s->LP, m->LP, sizeof(double) * FFX_REFRAME_LOAD_STRIDE(nf) * (size_t)m->n_loads);
    int off[FFX_REFRAME_N_OFFSETS];
    ffx_reframe_offsets(nf, off);
    if (m->role[R_ZETA] >= 0) /* as flexfmu.linalg.modal_basis: damping 2 zeta omega */
        for (int j = 0; j < nf; j++) s->P[off[FFX_REFRAME_O_CF] + j] = 2.0 * s->roles[R_ZETA] * m->omega[j];
    if (!m->free_body) s->LP[0] = s->roles[R_FOLLOW] != 0.0 ? 1.0 : 0.0;
    s->theta_max = 0.5 * pow(s->roles[R_TOL], 0.25);
    s->internal_step = s->roles[R_INTERNAL];
    s->cap = (long)s->roles[R_CAP];
    s->last_split = 0;
    double shortest = FFX_MIN_COMMUNICATION_STEP / (double)s->cap;
    if (m->free_body && free_checks(s, shortest, r)) {
        free_sim(s);
        return NULL;
    }
    const double *w0 = s->roles + R_OMEGA0;
    if (m->free_body) goto initial_state;
    if (!(s->internal_step == 0.0 || s->internal_step >= shortest)) {
        char shown[64];
        native_repr(s->internal_step, shown, sizeof shown);
        native_refuse(r, BRIDGE_ERROR,
                      "internal_step: %s s: even a %g s communication step would need more than "
                      "max_internal_steps = %ld of them (allowed: 0 (automatic), or %.3g s .. any "
                      "longer step (no stability limit))",
                      shown, FFX_MIN_COMMUNICATION_STEP, s->cap, shortest);
        free_sim(s);
        return NULL;
    }
    double omega_cap = (double)s->cap * s->theta_max / FFX_MIN_COMMUNICATION_STEP, omega0 = norm3(w0);
    if (!(omega0 <= omega_cap)) {
        int i = 0;
        for (int k = 1; k < 3; k++)
            if (fabs(w0[k]) > fabs(w0[i])) i = k;
        native_refuse(r, BRIDGE_ERROR,
                      "%s: %g rad/s (|omega0| = %.4g rad/s): at that spin even a %g s communication "
                      "step needs more than max_internal_steps = %ld internal steps of at most 0.5 "
                      "tolerance^(1/4) = %.3g rad (allowed: |omega0| <= %.4g rad/s (max_internal_steps "
                      "x 0.5 tolerance^(1/4) / %g s))",
                      ROLE_NAMES[R_OMEGA0 + i], w0[i], omega0, FFX_MIN_COMMUNICATION_STEP, s->cap, s->theta_max,
                      omega_cap, FFX_MIN_COMMUNICATION_STEP);
        free_sim(s);
        return NULL;
    }
initial_state:
    /* flexfmu.reframe.integrator.initial_state: the centre of mass at its mesh position, R = I, q = 0, qdot_R =
       A6inv [v0; omega0] */
    memset(x, 0, sizeof(double) * FFX_REFRAME_STATE_SIZE(nf));
    for (int a = 0; a < 3; a++) x[a] = s->P[off[FFX_REFRAME_O_COM] + a];
    x[3] = x[7] = x[11] = 1.0;
    double vw[6] = {s->roles[R_V0], s->roles[R_V0 + 1], s->roles[R_V0 + 2], w0[0], w0[1], w0[2]};
    const double *A6inv = s->P + off[FFX_REFRAME_O_A6INV];
    double *qdR = x + 12 + FFX_REFRAME_N_RIGID + nf;
    for (int i = 0; i < 6; i++) {
        double acc = 0.0;
        for (int k = 0; k < 6; k++) acc += A6inv[6 * i + k] * vw[k];
        qdR[i] = acc;
    }
    return s;
}

/* The load values of the held inputs u: sv (one instant) and SV (the three stages of a held step). */
static void load_values(ReframeSim *s, const double *u) {
    const ReframeModel *m = s->m;
    if (m->free_body) {
        for (int i = 0; i < m->n_loads; i++)
            for (int k = 0; k < 6; k++) s->sv[6 * i + k] = k < m->loads[2 * i + 1] ? u[m->loads[2 * i] + k] : 0.0;
    } else
        for (int k = 0; k < 6; k++) s->sv[k] = (k < 3 || m->rotational) ? u[k] : 0.0;
    size_t row = sizeof(double) * 6 * (size_t)m->n_loads;
    for (int st = 0; st < 3; st++) memcpy(s->SV + 6 * m->n_loads * st, s->sv, row);
}

static int moment_refused(ReframeSim *s, const double *u, NativeResult *r) {
    if (s->m->rotational) return 0;
    for (int k = 3; k < 6; k++)
        if (u[k] != 0.0) {
            static const char *const names[3] = {"M_x", "M_y", "M_z"};
            native_refuse(r, BRIDGE_ERROR,
                          "%s: moments need a model with rotational DOFs (beam:<scene>) (allowed: 0 "
                          "for models with 3 DOFs per node)",
                          names[k - 3]);
            return 1;
        }
    return 0;
}

/* The kernel outputs of x with the inputs u into s->out; search: with the max elastic displacement. */
static void kernel_outputs(ReframeSim *s, const double *x, const double *u, int search) {
    const ReframeModel *m = s->m;
    load_values(s, u);
    ffx_reframe_outputs(s->P, s->LP, m->n_loads, NULL, m->nf, m->deformed, s->sv, x, m->PP, m->n_points, m->Psi,
                        m->psi_cols, m->dpn, m->order, search ? m->n_nodes : 0, m->bc, m->br, m->n_blocks, m->sc, m->sr,
                        m->n_super, s->out, s->work);
}

static double dist3(const double *a, const double *b) {
    double d[3] = {a[0] - b[0], a[1] - b[1], a[2] - b[2]};
    return norm3(d);
}

/* A refusal of the step policy (step_policy.h) as the bridge reports it. */
static int step_refused(NativeResult *r, const ffx_step_refusal *refusal) {
    return native_refuse(r, refusal->status == FFX_STEP_DISCARD ? BRIDGE_DISCARD : BRIDGE_ERROR, "%s",
                         refusal->message);
}

/* ReframeBodySimulator._too_many_steps: the refusal of a split beyond the cap (rates: NULL for fixed steps, needed
   is then the policy's); the cause of an error as ReframeBodySimulator._spin_cause names it. */
static int too_many(ReframeSim *s, double t, double h, double needed, const double *rates, const double *u,
                    NativeResult *r) {
    const ReframeModel *m = s->m;
    double theta = s->theta_max;
    long cap = s->cap;
    ffx_step_refusal refusal;
    char before[256], after[128], allowed[256];
    if (!rates) {
        snprintf(before, sizeof before, "%g s: ", s->internal_step);
        ffx_step_cause cause = {"internal_step", before, NULL, "a longer internal step or a larger max_internal_steps"};
        ffx_split_refuse(h, s->internal_step, cap, &cause, &refusal);
        return step_refused(r, &refusal);
    }
    double w = rates[0], a = rates[1], hm = FFX_MIN_COMMUNICATION_STEP, disc = w * w + 2.0 * a * theta;
    double root = isfinite(disc) ? sqrt(disc) : INFINITY;
    double h_ok = w + root > 0 ? (double)cap * 2.0 * theta / (w + root) : INFINITY;
    if (ffx_step_refuse(h, needed, cap, h_ok, 0.0, NULL, &refusal) == FFX_STEP_DISCARD)
        return step_refused(r, &refusal);
    snprintf(after, sizeof after, " of at most 0.5 tolerance^(1/4) = %.3g rad (scheme exponential)", theta);
    ffx_step_cause cause = {"state", before, after, allowed};
    if (0.5 * a * hm * hm >= w * hm) {
        static const char *const names[6] = {"F_x", "F_y", "F_z", "M_x", "M_y", "M_z"};
        int best = 0;
        double best_score = -1.0;
        for (int k = 0; k < 6; k++) {
            double score = fabs(u[k]) * (k < 3 ? m->arm : 1.0);
            if (score > best_score) best = k, best_score = score;
        }
        double a_ok = fmax(2.0 * ((double)cap * theta - w * hm) / (hm * hm), 0.0), lever = best < 3 ? m->arm : 1.0;
        const char *unit = best < 3 ? "N" : "N.m";
        cause.parameter = names[best];
        snprintf(before, sizeof before, "%g %s gives an angular acceleration of up to %.3g rad/s^2: ", u[best], unit,
                 a);
        snprintf(allowed, sizeof allowed, "|%c| <= about %.3g %s at this load point (|alpha| <= %.3g rad/s^2)",
                 names[best][0], lever > 0 ? a_ok * m->J_min / lever : 0.0, unit, a_ok);
    } else {
        snprintf(before, sizeof before, "the body spins at %.4g rad/s at t = %.6g s: ", w, t);
        snprintf(allowed, sizeof allowed, "inputs that keep |omega| <= %.4g rad/s", (double)cap * theta / hm);
    }
    ffx_step_refuse(h, needed, cap, h_ok, 0.0, &cause, &refusal);
    return step_refused(r, &refusal);
}

/* ReframeBodySimulator._split: the internal steps of a communication step h (>= 1), or 0 after refusing. */
static long split(ReframeSim *s, const double *x, const double *u_before, const double *u, double t, double h,
                  NativeResult *r) {
    long cap = s->cap, n;
    char why[400];
    if (s->internal_step > 0) {
        n = ffx_split_step(h, s->internal_step, cap);
        if (n == 0) return too_many(s, t, h, 0.0, NULL, u, r), 0;
        snprintf(why, sizeof why, "internal_step = %g s requested", s->internal_step);
    } else {
        const ReframeModel *m = s->m;
        kernel_outputs(s, x, u_before, 0); /* the rates of the state with the inputs its step held */
        double w = norm3(s->out + 10), a = norm3(s->out + 13);
        int changed = 0;
        for (int k = 0; k < 6; k++) changed |= u[k] != u_before[k];
        if (changed) a = a + (m->arm * dist3(u_before, u) + dist3(u_before + 3, u + 3)) / m->J_min;
        if (!(w < INFINITY && a < INFINITY)) return 0; /* NATIVE_NOT_FINITE: the caller reports it */
        double theta = w * h + 0.5 * a * h * h, rates[2] = {w, a};
        n = ffx_split_step(theta, s->theta_max, cap); /* theta / theta_max, counted as h / step */
        if (n == 0) return too_many(s, t, h, theta / s->theta_max * FFX_STEP_GUARD, rates, u, r), 0;
        if (n > 1) {
            double hi = h / (double)n;
            int k;
            for (k = 0; k < 8; k++) {
                if (!(w * hi + 0.5 * a * hi * hi > s->theta_max)) break;
                n += 1;
                hi = h / (double)n;
            }
            if (k == 8) n = (long)ceil(theta / s->theta_max * (1 + 1e-9));
            if (n > cap) return too_many(s, t, h, (double)n, rates, u, r), 0;
        }
        snprintf(why, sizeof why,
                 "scheme exponential: no stability limit; by accuracy, rotation per internal step "
                 "%.3g rad <= 0.5 tolerance^(1/4) = %.3g rad (|omega| = %.4g rad/s, |alpha| ~ %.4g "
                 "rad/s^2)",
                 theta / (double)n, s->theta_max, w, a);
    }
    if (s->m->log_split && n != s->last_split)
        native_note(r, "t = %.6g s: communication step %g s in %ld internal step(s) of %.4g s: %s", t, h, n,
                    h / (double)n, why);
    s->last_split = n;
    return n;
}

static int culprit(void *sim, int what, const double *x, const double *u, double threshold);

/* sqrt(v . v) (numpy.linalg.norm of a short vector) */
static double norm_n(const double *v, int n) {
    double acc = 0.0;
    for (int k = 0; k < n; k++) acc += v[k] * v[k];
    return sqrt(acc);
}

/* flexfmu.body.simulator._frame_global: [rot, R omega, R alpha] (global) from [q, omega, alpha] (body) */
static void frame_global(const double *qoa, double *g) {
    double n = norm_n(qoa, 4);
    if (!(n > 0.0)) {
        for (int k = 0; k < 9; k++) g[k] = NAN;
        return;
    }
    double w = qoa[0] / n, v[3] = {qoa[1] / n, qoa[2] / n, qoa[3] / n};
    if (w < 0.0) w = -w, v[0] = -v[0], v[1] = -v[1], v[2] = -v[2];
    double sv = norm_n(v, 3), angle = 2.0 * atan2(sv, w), rot[3];
    for (int a = 0; a < 3; a++) rot[a] = sv > 1e-12 ? v[a] * (angle / sv) : 2.0 * v[a];
    /* flexfmu.core.rotation.rotation_matrix(rot).T = I + (sin t / t) K + ((1 - cos t) / t^2) K^2, K = skew(rot),
       both coefficients as numpy.sinc */
    double th = norm_n(rot, 3), x1 = FFX_PI * (th / FFX_PI), x2 = FFX_PI * (th / (2.0 * FFX_PI));
    double ca = x1 == 0.0 ? 1.0 : sin(x1) / x1, sb = x2 == 0.0 ? 1.0 : sin(x2) / x2, cb = 0.5 * sb * sb;
    double M[3][3] = {{0, rot[2], -rot[1]}, {-rot[2], 0, rot[0]}, {rot[1], -rot[0], 0}}; /* paper_skew(rot) */
    double A[3][3];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            double mm = 0.0;
            for (int k = 0; k < 3; k++) mm += M[i][k] * M[k][j];
            A[i][j] = (i == j ? 1.0 : 0.0) + ca * M[i][j] + cb * mm;
        }
    for (int a = 0; a < 3; a++) {
        g[a] = rot[a];
        double wo = 0.0, al = 0.0;
        for (int k = 0; k < 3; k++) wo += A[k][a] * qoa[4 + k], al += A[k][a] * qoa[7 + k]; /* R = A^T */
        g[3 + a] = wo, g[6 + a] = al;
    }
}

/* FreeEngine._rotation_count */
static double rotation_count(const ReframeSim *s, double h, double w, double a) {
    double wm = w + a * h, root = sqrt(wm * wm + 2.0 * a * s->theta_max);
    return isfinite(root) ? h * (wm + root) / (2.0 * s->theta_max) : INFINITY;
}

/* What FreeEngine.split's refusals name in an error (flexfmu.body.engines). */
static ffx_step_cause free_step_cause(const char *name) {
    ffx_step_cause cause = {name, NULL, NULL, "a smaller value, or a larger max_internal_steps"};
    return cause;
}

/* The culprit's name of FreeEngine.culprit, or "state". */
static const char *free_cause(const ReframeSim *s, const double *u) {
    int j = culprit((void *)s, 1, NULL, u, 0.0);
    return j >= 0 ? s->m->layout.input_names[j] : "state";
}

/* FreeEngine.split (header): the internal steps of a communication step h, or 0 after refusing. */
static long free_split(ReframeSim *s, const double *x, const double *u, double t, double h, NativeResult *r) {
    const ReframeModel *m = s->m;
    long cap = s->cap, n;
    char why[400];
    if (!m->consistent && s->internal_step == 0) {
        kernel_outputs(s, x, u, 0);
        double w = norm_n(s->out + 10, 3), a = norm_n(s->out + 13, 3);
        if (!(isfinite(w) && isfinite(a))) return 0; /* NATIVE_NOT_FINITE: the caller reports it */
        double ratio = rotation_count(s, h, w, a);
        n = ffx_step_count(ratio, FFX_STEP_GUARD, cap); /* capped as it is, counted guarded */
        if (n == 0) {
            double lo = 0.0, hi = h;
            for (int k = 0; k < 200; k++) {
                double mid = 0.5 * (lo + hi);
                if (rotation_count(s, mid, w, a) <= (double)cap)
                    lo = mid;
                else
                    hi = mid;
            }
            ffx_step_cause cause = free_step_cause(free_cause(s, u));
            ffx_step_refusal refusal;
            ffx_step_refuse(h, ratio, cap, lo, 0.0, &cause, &refusal);
            return step_refused(r, &refusal), 0;
        }
        snprintf(why, sizeof why,
                 "scheme exponential: rotation per internal step <= 0.5 tolerance^(1/4) = %.3g rad "
                 "(|omega| = %.4g rad/s, |alpha| = %.4g rad/s^2, held)",
                 s->theta_max, w, a);
    } else {
        n = ffx_split_step(h, s->max_step, cap);
        if (n == 0) {
            ffx_step_cause cause = free_step_cause("internal_step");
            ffx_step_refusal refusal;
            ffx_split_refuse(h, s->max_step, cap, &cause, &refusal);
            return step_refused(r, &refusal), 0;
        }
        if (s->internal_step > 0)
            snprintf(why, sizeof why, "internal_step = %g s", s->internal_step);
        else
            snprintf(why, sizeof why, "scheme consistent (RK4): 90 %% of the stability limit %.4g s", m->limit);
    }
    if (m->log_split && n != s->last_split)
        native_note(r, "t = %.6g s: communication step %g s in %ld internal step(s) of %.4g s: %s", t, h, n,
                    h / (double)n, why);
    s->last_split = n;
    return n;
}

static int step_held(void *sim, double *x, const double *u_before, const double *u, double t, double h,
                     NativeResult *r) {
    ReframeSim *s = sim;
    const ReframeModel *m = s->m;
    int nf = m->nf;
    if (moment_refused(s, u, r)) return r->status;
    long n = m->free_body ? free_split(s, x, u, t, h, r) : split(s, x, u_before, u, t, h, r);
    if (n == 0) return r->status >= BRIDGE_DISCARD ? r->status : NATIVE_NOT_FINITE;
    double dt = h / (double)n;
    /* the Python integrator's per-dt coefficients, by the same C function; a host's last-bit variants of the
       cached dt reuse them (FFX_STEP_RTOL in lti_kernels.h: the error bound) */
    if (!(s->ex_dt > 0.0 && ffx_same_step(s->ex_dt, dt)) && !m->consistent) {
        int off[FFX_REFRAME_N_OFFSETS];
        ffx_reframe_offsets(nf, off);
        if (ffx_reframe_exponential_coefficients(nf, s->P + off[FFX_REFRAME_O_K], s->P + off[FFX_REFRAME_O_CF], dt,
                                                 s->EX, s->ework)
            != FFX_REFRAME_OK) {
            s->ex_dt = 0.0;
            return native_refuse(r, BRIDGE_ERROR,
                                 "dt: %g s gives non-finite exponential propagators (allowed: a "
                                 "finite time step > 0 (s))",
                                 dt);
        }
        s->ex_dt = dt;
    }
    load_values(s, u);
    size_t ny = (size_t)FFX_REFRAME_STATE_SIZE(nf);
    memcpy(s->y, x, sizeof(double) * ny);
    double tk = t;
    int done = 0;
    int status = ffx_reframe_steps(s->P, s->LP, m->n_loads, NULL, (nf && !m->consistent) ? s->EX : NULL, nf,
                                   m->deformed, s->SV, 1, &tk, dt, (int)n, s->y, &done, s->work);
    if (status != FFX_REFRAME_OK) return NATIVE_NOT_FINITE;
    memcpy(x, s->y, sizeof(double) * ny);
    s->n_steps++;
    return BRIDGE_OK;
}

static int step(void *sim, double *x, const double *u, double t, double h, NativeResult *r) {
    return step_held(sim, x, u, u, t, h, r);
}

/* The outputs but the deferred ones (those too with include_deferred). */
static int cheap_outputs(ReframeSim *s, const double *x, const double *u, double *y, int include_deferred,
                         NativeResult *r) {
    const ReframeModel *m = s->m;
    const unsigned char *deferred = m->layout.deferred;
    if (moment_refused(s, u, r)) return r->status;
    int search = include_deferred || m->search_always;
    kernel_outputs(s, x, u, search);
    s->n_searches += search && m->n_nodes > 0;
    double extra[9];
    if (m->free_body) frame_global(s->out + 6, extra);
    int bad = 0;
    const double *q = s->out + 22; /* the kernels' q_F (flexfmu.reframe.layout: output_layout's q) */
    for (int k = 0; k < m->n_out; k++) {
        if (!include_deferred && deferred && deferred[k]) continue; /* not computed: its place left */
        int c = m->columns[k], j = -1 - c;
        if (c >= 0)
            y[k] = s->out[c];
        else if (j < 9)
            y[k] = extra[j];
        else if (j < 9 + m->n_extra)
            y[k] = m->extra[j - 9];
        else {
            const double *row = m->rows + (size_t)(j - 9 - m->n_extra) * (size_t)m->nf;
            double sum = 0.0;
            for (int i = 0; i < m->nf; i++) sum += row[i] * q[i];
            y[k] = sum;
        }
        bad |= !isfinite(y[k]);
    }
    for (int k = 0; k < m->n_vm; k++) { /* after their sources, as the simulator's derived_outputs */
        const int32_t *e = m->von_mises + 7 * k;
        double stress[6];
        for (int i = 0; i < 6; i++) stress[i] = y[e[1 + i]];
        y[e[0]] = ffx_von_mises(stress);
        bad |= !isfinite(y[e[0]]);
    }
    return bad ? NATIVE_NOT_FINITE : BRIDGE_OK;
}

/* The deferred outputs (the max elastic displacement): the search ffx_reframe_outputs does, on the same q_F. */
static int deferred_outputs(ReframeSim *s, const double *x, double *y) {
    const ReframeModel *m = s->m;
    const double *q = x + 12 + FFX_REFRAME_N_RIGID; /* eta = [q_R (6), q_F (nf), ...] */
    double value = FFX_REFRAME_NOT_COMPUTED;
    if (m->n_nodes > 0) {
        value = ffx_reframe_max_node_norm(m->Psi, m->psi_cols, FFX_REFRAME_N_RIGID, m->dpn, m->order, m->n_nodes, m->bc,
                                          m->br, m->n_blocks, m->sc, m->sr, m->n_super, q, m->nf);
        s->n_searches++;
    }
    int bad = 0;
    for (int k = 0; k < m->n_out; k++)
        if (m->layout.deferred && m->layout.deferred[k]) y[k] = value, bad |= !isfinite(value);
    return bad ? NATIVE_NOT_FINITE : BRIDGE_OK;
}

/* The cheap outputs come together (one kernel call): all of them when one is asked for; the deferred ones only
   when one of them is asked for. */
static int outputs(void *sim, const double *x, const double *u, double *y, unsigned char *which, NativeResult *r) {
    ReframeSim *s = sim;
    const ReframeModel *m = s->m;
    const unsigned char *deferred = m->layout.deferred;
    int cheap = 0, costly = 0;
    for (int k = 0; k < m->n_out; k++)
        if (which[k]) *(deferred && deferred[k] ? &costly : &cheap) = 1;
    int status = cheap ? cheap_outputs(s, x, u, y, costly, r) : costly ? deferred_outputs(s, x, y) : BRIDGE_OK;
    if (status >= BRIDGE_DISCARD && status != NATIVE_NOT_FINITE) return status;
    for (int k = 0; k < m->n_out; k++)
        which[k] = deferred && deferred[k] ? (unsigned char)costly : (unsigned char)cheap;
    return status;
}

/* At fmi2Terminate: how often the max elastic displacement was searched for (only when read, or when an output that
   is not deferred needs it). */
static void report(void *sim, NativeResult *r) {
    const ReframeSim *s = sim;
    native_note(r, "max_elastic_displacement: %ld search(es) over the %d nodes in %ld communication step(s) (%s)",
                s->n_searches, s->m->n_nodes, s->n_steps,
                s->m->search_always ? "computed with every output"
                                    : "deferred: computed only when read, once per state");
}

/* The held input most likely behind an overflow (ReframeBodySimulator._overflow's scores: each input's
   displacement, rotation and acceleration over the step, h = 1 s). */
/* With no input to blame: the initial condition (a runtime parameter, numbered after the inputs) behind an
   overflow, as ReframeBodySimulator._overflow ranks them: the initial velocity against the initial spin (over 1 s),
   then the largest component of the group; -1 when both are 0 or fixed at build. */
static int initial_culprit(const ReframeSim *s) {
    const ReframeModel *m = s->m;
    const double *v0 = s->roles + R_V0, *w0 = s->roles + R_OMEGA0;
    double speed = norm_n(v0, 3), spin = norm_n(w0, 3);
    if (!(speed > 0.0) && !(spin > 0.0)) return -1;
    int group = spin * m->size + spin * spin * m->size > speed ? R_OMEGA0 : R_V0, best = group;
    for (int k = group; k < group + 3; k++)
        if (fabs(s->roles[k]) > fabs(s->roles[best])) best = k;
    return m->role[best] >= 0 ? (int)m->layout.n_inputs + m->role[best] : -1;
}

static int culprit(void *sim, int what, const double *x, const double *u, double threshold) {
    (void)x, (void)what;
    const ReframeSim *s = sim;
    const ReframeModel *m = s->m;
    int best = -1;
    double best_score = 0.0;
    if (m->free_body) { /* FreeEngine.culprit: the held input of largest magnitude */
        for (int k = 0; k < (int)m->layout.n_inputs; k++) {
            double score = isnan(u[k]) ? INFINITY : fabs(u[k]);
            if (score > best_score) best = k, best_score = score;
        }
        if (best < 0) return initial_culprit(s);
        return what == 0 && !(best_score > threshold) ? -1 : best;
    }
    for (int k = 0; k < 6; k++) {
        double score
            = k < 3 ? fabs(u[k]) * (1.0 / m->mass + m->arm * m->size / m->J_min) : fabs(u[k]) * m->size / m->J_min;
        if (score > best_score || (!(score <= best_score) && best < 0)) best = k, best_score = score;
    }
    if (best < 0 || !(best_score > 0.0)) return initial_culprit(s);
    if (what == 0) return !(best_score <= threshold) ? best : -1;
    return best;
}

const NativeKind native_reframe_kind = {.name = "reframe",
                                        .load = load,
                                        .free_model = free_model,
                                        .state_size = state_size,
                                        .init = init,
                                        .free_sim = free_sim,
                                        .step = step,
                                        .outputs = outputs,
                                        .culprit = culprit,
                                        .step_held = step_held,
                                        .report = report};
