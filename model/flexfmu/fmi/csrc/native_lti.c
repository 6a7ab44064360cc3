/*
 * native_lti.c - the "lti" kind of the native runtime (native_kind.h): a clamped flexible body on a moving base
 * as the parameter-dependent linear system of lti_kernels.h (flexfmu/native/csrc; coefficients extracted by
 * flexfmu.native.lti from the library's own maps), for FFRBeam and exported clamped bodies.
 *
 * Model-file entries (flexfmu/fmi/native.py writes them from an LtiModel):
 *   lti.A, lti.B, lti.b, lti.Cx, lti.Cu, lti.y0     float64, the ffx_lti_model coefficient arrays
 *   lti.quad_row, lti.quad_i, lti.quad_j (int32), lti.quad_value (float64)   the quadratic output terms
 *   lti.u_from_input  int32 (nu)   the FMU input (index in the FMU's input order) of each u_k
 *   lti.p_from_input  int32 (np)   the FMU input of each p_k, or -1: fed by a runtime parameter or constant
 *   lti.p_param       int32 (np)   for p_from_input = -1: the runtime parameter feeding p_k, or -1: p_start
 *   lti.p_start       float64 (np) the value of a constant p_k
 *   lti.y_to_output   int32 (ny)   the FMU output (index in the FMU's output order) of each y_k
 *   lti.internal_step, lti.max_internal_steps   int32 scalars: the runtime parameters with these roles, or -1
 *   lti.log_split     int32 scalar: 1 = log (status OK) how a communication step is split, when that changes
 * and, optional (none: no derived outputs; flexfmu.fmi.model_file.derived_entries writes them), the outputs computed
 * after the others from them, not linearly (derived_stress.h: von Mises stresses, a beam section's largest stresses;
 * their rows of Cx, Cu, y0 are zero), n_derived of them:
 *   lti.derived.kind, lti.derived.shape, lti.derived.output   int32 (n_derived): FFX_DERIVED_*, FFX_SECTION_*, the
 *                     y_k (index among the model's outputs, as lti.quad_row) it is written to
 *   lti.derived.sources  int32 (n_derived, 6): the y_k it is computed from (-1 after the kind's number of them)
 *   lti.derived.fibres   float64 (n_derived, 7): the section's A, Iy, Iz, J, y_max, z_max, torsion_arm (SI)
 * checked at load (ffx_derived_check: a bad one refuses the model file, naming the entry and its output).
 *
 * A communication step h is one exact zero-order-hold step, or with internal_step > 0 n = ceil(h /
 * internal_step) equal exact steps (as flexfmu.body.engines.ClampedEngine), refused beyond max_internal_steps
 * (fmi2Discard when a smaller communication step would do): the rule of step_policy.h (flexfmu/native/csrc).  The
 * step maps are cached in the simulator for the last (p, h) by the kernels.  A step whose held base motion moved by
 * little from the one the step before held (the bridge's inputs of the state's step, step_held) goes by the series
 * of its exponential on the state instead (ffx_lti_steps_held's rule, as flexfmu.native.lti_taylor): base motion
 * that changes at every step (a floating platform's) costs no exponential per step.
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "derived_stress.h"
#include "flexfmu_bridge.h"
#include "lti_kernels.h"
#include "native_kind.h"
#include "step_policy.h"

typedef struct {
    ffx_lti_model kernel;
    NativeLayout layout;
    const int32_t *u_from_input, *p_from_input, *p_param, *y_to_output;
    const double *p_start;
    int internal_step, max_internal_steps, log_split;
    int *quadratic; /* per p_k: appears in a degree-2 monomial with a non-zero coefficient */
    int *quad_row, *quad_i, *quad_j, *quad_start;
    int n_derived; /* the derived outputs (derived_stress.h), 0: none */
    const int32_t *derived_kind, *derived_shape, *derived_output, *derived_sources;
    const double *derived_fibres;
} LtiModel;

typedef struct {
    const LtiModel *m;
    ffx_lti_maps maps;
    double *work, *p, *p_before, *u, *y, *params;
    int *rows;           /* the y_k asked for (outputs) */
    unsigned char *need; /* per y_k: asked for, or a source of a derived output asked for */
    double internal_step;
    long cap, last_split;
    double last_h; /* internal step of the last step (for the culprit) */
    /* model exchange and directional derivatives: monomials of p and their derivative along dp, the direction's
       u and p, z = [x; u; mono] and its derivative (the quadratic output terms) */
    double *mono, *dmono, *du, *dp, *z, *dz, *dy;
} LtiSim;

/* The optional derived-output entries (header comment), checked; 0, or -1 with why naming the entry. */
static int load_derived(LtiModel *m, const NativeFile *file, char *why, size_t why_size) {
    uint32_t s[NATIVE_MAX_DIMS];
    if (!native_entry(file, "lti.derived.kind")) return 0; /* a model without derived outputs (or an older file) */
    if (native_i32(file, "lti.derived.kind", 1, NULL, &m->derived_kind, s, why, why_size) < 0) return -1;
    long n = s[0], ns[1] = {n}, sources[2] = {n, FFX_DERIVED_MAX_SOURCES}, fibres[2] = {n, FFX_DERIVED_N_FIBRES};
    if (native_i32(file, "lti.derived.shape", 1, ns, &m->derived_shape, NULL, why, why_size) < 0
        || native_i32(file, "lti.derived.output", 1, ns, &m->derived_output, NULL, why, why_size) < 0
        || native_i32(file, "lti.derived.sources", 2, sources, &m->derived_sources, NULL, why, why_size) < 0
        || native_f64(file, "lti.derived.fibres", 2, fibres, &m->derived_fibres, NULL, why, why_size) < 0)
        return -1;
    const char *what = "", *allowed = "";
    int ny = m->kernel.ny;
    int bad = ffx_derived_check((int)n, m->derived_kind, m->derived_shape, m->derived_output, m->derived_sources,
                                m->derived_fibres, ny, &what, &allowed);
    if (bad >= 0) {
        int32_t out = m->derived_output[bad];
        const char *name = out >= 0 && out < ny ? m->layout.output_names[m->y_to_output[out]] : "(none)";
        snprintf(why, why_size, "model file entry lti.derived [%d] (output %s) has %s (allowed: %s)", bad, name, what,
                 allowed);
        return -1;
    }
    m->n_derived = (int)n;
    return 0;
}

static void *load(const NativeFile *file, const NativeLayout *layout, char *why, size_t why_size) {
    LtiModel *m = calloc(1, sizeof *m);
    if (!m) {
        snprintf(why, why_size, "out of memory");
        return NULL;
    }
    m->layout = *layout;
    uint32_t s[NATIVE_MAX_DIMS];
    const double *A;
    if (native_f64(file, "lti.A", 3, NULL, &A, s, why, why_size) < 0) goto fail;
    long nmono = s[0], nx = s[1];
    if (s[2] != s[1]) {
        snprintf(why, why_size, "model file entry lti.A is not square");
        goto fail;
    }
    const double *B, *b, *Cx, *Cu, *y0, *quad_value;
    const int32_t *quad_row, *quad_i, *quad_j, *internal, *cap, *log_split;
    long shape_B[3] = {nmono, nx, -1};
    if (native_f64(file, "lti.B", 3, shape_B, &B, s, why, why_size) < 0) goto fail;
    long nu = s[2];
    long shape_b[2] = {nmono, nx}, shape_y0[2] = {nmono, -1};
    if (native_f64(file, "lti.b", 2, shape_b, &b, NULL, why, why_size) < 0
        || native_f64(file, "lti.y0", 2, shape_y0, &y0, s, why, why_size) < 0)
        goto fail;
    long ny = s[1];
    long shape_Cx[3] = {nmono, ny, nx}, shape_Cu[3] = {nmono, ny, nu};
    if (native_f64(file, "lti.Cx", 3, shape_Cx, &Cx, NULL, why, why_size) < 0
        || native_f64(file, "lti.Cu", 3, shape_Cu, &Cu, NULL, why, why_size) < 0
        || native_f64(file, "lti.quad_value", 1, NULL, &quad_value, s, why, why_size) < 0)
        goto fail;
    long nquad = s[0], np = -1;
    for (long k = 0; k <= nmono; k++) /* np from nmono = 1 + np + np (np + 1) / 2 */
        if (FFX_LTI_N_MONOMIALS(k) == nmono) np = k;
    if (np < 0) {
        snprintf(why, why_size, "model file entry lti.A has %ld monomials, not 1 + np + np (np + 1) / 2", nmono);
        goto fail;
    }
    long nps[1] = {np}, nus[1] = {nu}, nys[1] = {ny}, nqs[1] = {nquad};
    if (native_i32(file, "lti.quad_row", 1, nqs, &quad_row, NULL, why, why_size) < 0
        || native_i32(file, "lti.quad_i", 1, nqs, &quad_i, NULL, why, why_size) < 0
        || native_i32(file, "lti.quad_j", 1, nqs, &quad_j, NULL, why, why_size) < 0
        || native_i32(file, "lti.u_from_input", 1, nus, &m->u_from_input, NULL, why, why_size) < 0
        || native_i32(file, "lti.p_from_input", 1, nps, &m->p_from_input, NULL, why, why_size) < 0
        || native_i32(file, "lti.p_param", 1, nps, &m->p_param, NULL, why, why_size) < 0
        || native_f64(file, "lti.p_start", 1, nps, &m->p_start, NULL, why, why_size) < 0
        || native_i32(file, "lti.y_to_output", 1, nys, &m->y_to_output, NULL, why, why_size) < 0
        || native_i32(file, "lti.internal_step", 0, NULL, &internal, NULL, why, why_size) < 0
        || native_i32(file, "lti.max_internal_steps", 0, NULL, &cap, NULL, why, why_size) < 0
        || native_i32(file, "lti.log_split", 0, NULL, &log_split, NULL, why, why_size) < 0)
        goto fail;
    m->internal_step = *internal, m->max_internal_steps = *cap, m->log_split = *log_split;
    long n_in = (long)layout->n_inputs, n_out = (long)layout->n_outputs, n_par = (long)layout->n_params;
    for (long k = 0; k < nu; k++)
        if (m->u_from_input[k] < 0 || m->u_from_input[k] >= n_in) goto bad_index;
    for (long k = 0; k < np; k++)
        if (m->p_from_input[k] >= n_in || (m->p_from_input[k] < 0 && m->p_param[k] >= n_par)) goto bad_index;
    if (ny != n_out) goto bad_index;
    for (long k = 0; k < ny; k++) { /* a permutation of the outputs */
        if (m->y_to_output[k] < 0 || m->y_to_output[k] >= n_out) goto bad_index;
        for (long j = 0; j < k; j++)
            if (m->y_to_output[j] == m->y_to_output[k]) goto bad_index;
    }
    if (m->internal_step >= n_par || m->max_internal_steps >= n_par) goto bad_index;
    /* the kernel takes int arrays */
    m->quad_row = malloc(sizeof(int) * (size_t)(nquad + 1));
    m->quad_i = malloc(sizeof(int) * (size_t)(nquad + 1));
    m->quad_j = malloc(sizeof(int) * (size_t)(nquad + 1));
    m->quadratic = calloc((size_t)np + 1, sizeof(int));
    m->quad_start = malloc(sizeof(int) * (size_t)(ny + 1));
    if (!m->quad_row || !m->quad_i || !m->quad_j || !m->quadratic || !m->quad_start) {
        snprintf(why, why_size, "out of memory");
        goto fail;
    }
    for (long k = 0; k < nquad; k++) m->quad_row[k] = quad_row[k], m->quad_i[k] = quad_i[k], m->quad_j[k] = quad_j[k];
    m->kernel = (ffx_lti_model){(int)nx, (int)nu, (int)ny,    (int)np,     (int)nmono, A,         B,          b,   Cx,
                                Cu,      y0,      (int)nquad, m->quad_row, m->quad_i,  m->quad_j, quad_value, NULL};
    for (long q = 0; q < nquad; q++) /* ffx_lti_quad_starts reads the rows: checked first */
        if (quad_row[q] < 0 || quad_row[q] >= ny) goto bad_index;
    if (ffx_lti_quad_starts(&m->kernel, m->quad_start)) m->kernel.quad_start = m->quad_start; /* rows alone */
    if (ffx_lti_check_model(&m->kernel) != FFX_LTI_OK) {
        snprintf(why, why_size, "the model file's lti arrays are inconsistent (sizes or quadratic-term indices)");
        goto fail;
    }
    if (load_derived(m, file, why, why_size) < 0) goto fail;
    /* which p enter squared (for naming the culprit of an overflow: the spin enters squared) */
    long k = 1 + np;
    size_t sizes[6]
        = {(size_t)(nx * nx), (size_t)(nx * nu), (size_t)nx, (size_t)(ny * nx), (size_t)(ny * nu), (size_t)ny};
    const double *arrays[6] = {A, B, b, Cx, Cu, y0};
    for (long i = 0; i < np; i++)
        for (long j = i; j < np; j++, k++)
            for (int a = 0; a < 6; a++)
                for (size_t e = 0; e < sizes[a]; e++)
                    if (arrays[a][(size_t)k * sizes[a] + e] != 0.0) m->quadratic[i] = m->quadratic[j] = 1;
    return m;
bad_index:
    snprintf(why, why_size, "the model file's lti index maps point outside the FMU's variables");
fail:
    if (m) {
        free(m->quad_row);
        free(m->quad_i);
        free(m->quad_j);
        free(m->quadratic);
        free(m->quad_start);
    }
    free(m);
    return NULL;
}

static void free_model(void *model) {
    LtiModel *m = model;
    if (!m) return;
    free(m->quad_row);
    free(m->quad_i);
    free(m->quad_j);
    free(m->quadratic);
    free(m->quad_start);
    free(m);
}

static size_t state_size(const void *model) { return (size_t)((const LtiModel *)model)->kernel.nx; }

static void free_sim(void *sim) {
    LtiSim *s = sim;
    if (!s) return;
    free(s->work);
    free(s->p);
    free(s->p_before);
    free(s->u);
    free(s->y);
    free(s->params);
    free(s->rows);
    free(s->need);
    free(s->mono);
    free(s->dmono);
    free(s->du);
    free(s->dp);
    free(s->z);
    free(s->dz);
    free(s->dy);
    free(s);
}

static void *init(const void *model, const double *params, const char *const *texts, double *x, NativeResult *r) {
    (void)texts; /* no String parameters */
    const LtiModel *m = model;
    const ffx_lti_model *k = &m->kernel;
    LtiSim *s = calloc(1, sizeof *s);
    size_t n = ffx_lti_maps_work_len(k);
    if (!s || !(s->work = malloc(sizeof(double) * (n + 1))) || !(s->p = calloc((size_t)k->np + 1, sizeof(double)))
        || !(s->p_before = calloc((size_t)k->np + 1, sizeof(double)))
        || !(s->u = calloc((size_t)k->nu + 1, sizeof(double))) || !(s->y = calloc((size_t)k->ny + 1, sizeof(double)))
        || !(s->params = calloc(m->layout.n_params + 1, sizeof(double)))
        || !(s->rows = calloc((size_t)k->ny + 1, sizeof(int))) || !(s->need = calloc((size_t)k->ny + 1, 1))
        || !(s->mono = calloc((size_t)k->nmono + 1, sizeof(double)))
        || !(s->dmono = calloc((size_t)k->nmono + 1, sizeof(double)))
        || !(s->du = calloc((size_t)k->nu + 1, sizeof(double))) || !(s->dp = calloc((size_t)k->np + 1, sizeof(double)))
        || !(s->z = calloc((size_t)(k->nx + k->nu + k->nmono) + 1, sizeof(double)))
        || !(s->dz = calloc((size_t)(k->nx + k->nu + k->nmono) + 1, sizeof(double)))
        || !(s->dy = calloc((size_t)k->ny + 1, sizeof(double)))) {
        free_sim(s);
        native_refuse(r, BRIDGE_ERROR, "out of memory");
        return NULL;
    }
    s->m = m;
    memcpy(s->params, params, m->layout.n_params * sizeof(double));
    if (ffx_lti_maps_init(&s->maps, k, s->work, n) != FFX_LTI_OK) {
        free_sim(s);
        native_refuse(r, BRIDGE_ERROR, "the model's lti arrays are inconsistent");
        return NULL;
    }
    s->internal_step = m->internal_step >= 0 ? params[m->internal_step] : 0.0;
    s->cap = m->max_internal_steps >= 0 ? (long)params[m->max_internal_steps] : 0;
    if (s->cap > 0 && s->internal_step > 0 && s->internal_step < FFX_MIN_COMMUNICATION_STEP / (double)s->cap) {
        native_refuse(r, BRIDGE_ERROR,
                      "internal_step: %g s needs more than max_internal_steps = %ld for a %g s "
                      "communication step (allowed: 0 (one exact step) or >= %.3g s)",
                      s->internal_step, s->cap, FFX_MIN_COMMUNICATION_STEP,
                      FFX_MIN_COMMUNICATION_STEP / (double)s->cap);
        free_sim(s);
        return NULL;
    }
    memset(x, 0, sizeof(double) * (size_t)k->nx);
    return s;
}

/* p of the FMU inputs `in` (and the runtime parameters). */
static void held_p(const LtiSim *s, const double *in, double *p) {
    const LtiModel *m = s->m;
    for (int k = 0; k < m->kernel.np; k++)
        p[k] = m->p_from_input[k] >= 0 ? in[m->p_from_input[k]]
               : m->p_param[k] >= 0    ? s->params[m->p_param[k]]
                                       : m->p_start[k];
}

/* p and u of the FMU inputs `in` (and the runtime parameters). */
static void assemble(LtiSim *s, const double *in) {
    const LtiModel *m = s->m;
    for (int k = 0; k < m->kernel.nu; k++) s->u[k] = in[m->u_from_input[k]];
    held_p(s, in, s->p);
}

/* Internal steps of a communication step h (>= 1), or 0 after refusing (step_policy.h, as ClampedEngine.split). */
static long split(LtiSim *s, double t, double h, NativeResult *r) {
    long n = 1;
    const char *exact = "exact zero-order hold: one internal step of any length";
    char why[160];
    snprintf(why, sizeof why, "%s", exact);
    if (s->internal_step > 0) {
        n = ffx_split_step(h, s->internal_step, s->cap);
        if (n == 0) {
            static const ffx_step_cause cause
                = {"internal_step", NULL, NULL, "a smaller value, or a larger max_internal_steps"};
            ffx_step_refusal refusal;
            ffx_split_refuse(h, s->internal_step, s->cap, &cause, &refusal);
            native_refuse(r, refusal.status == FFX_STEP_DISCARD ? BRIDGE_DISCARD : BRIDGE_ERROR, "%s", refusal.message);
            return 0;
        }
        snprintf(why, sizeof why, "internal_step = %g s (each exact)", s->internal_step);
    }
    if (s->m->log_split && n != s->last_split)
        native_note(r, "t = %.6g s: communication step %g s in %ld internal step(s) of %.4g s: %s", t, h, n,
                    h / (double)n, why);
    s->last_split = n;
    return n;
}

/* Step maps that are not finite (as flexfmu.ffr.ffrbeam_diagnostics' _map_failure): the held base motion when
   the maps of the same step without it are finite (the bridge then names the input), else the step itself, whose
   transition matrix overflows: fmi2Discard, since a smaller communication step may succeed. */
static int maps_failure(LtiSim *s, double h, double hi, NativeResult *r) {
    const LtiModel *m = s->m;
    int base = 0;
    for (int k = 0; k < m->kernel.np; k++)
        if (m->p_from_input[k] >= 0 && s->p[k] != 0.0) base = 1, s->p[k] = 0.0;
    int still = !base || ffx_lti_update_step_maps(&s->maps, s->p, hi) != FFX_LTI_OK;
    if (!still) return NATIVE_NOT_FINITE;
    char shown[64];
    native_repr(h, shown, sizeof shown);
    return native_refuse(r, BRIDGE_DISCARD,
                         "step_size: a communication step of %s s makes the step's transition matrix overflow "
                         "(not finite); take a smaller communication step",
                         shown);
}

/* n internal steps hi of the communication step h by the maps (p and u assembled). */
static int step_by_maps(LtiSim *s, double *x, double h, long n, double hi, NativeResult *r) {
    int status = ffx_lti_update_step_maps(&s->maps, s->p, hi);
    if (status == FFX_LTI_NONFINITE || status == FFX_LTI_SINGULAR) return maps_failure(s, h, hi, r);
    if (status == FFX_LTI_OK) status = ffx_lti_steps(&s->maps, s->p, hi, n, x, s->u, x);
    if (status == FFX_LTI_OK) return BRIDGE_OK;
    if (status == FFX_LTI_BAD_ARGUMENT)
        return native_refuse(r, BRIDGE_ERROR, "step_size: %s", ffx_lti_status_string(status));
    return NATIVE_NOT_FINITE; /* the state overflows: the bridge names the culprit */
}

static int step(void *sim, double *x, const double *in, double t, double h, NativeResult *r) {
    LtiSim *s = sim;
    long n = split(s, t, h, r);
    if (n == 0) return r->status;
    assemble(s, in);
    double hi = h / (double)n;
    s->last_h = hi;
    return step_by_maps(s, x, h, n, hi, r);
}

/* The step, knowing the inputs the state's step held (in_before): base motion that moved by little since goes by
   the series (ffx_lti_taylor_prepare's rule), else the maps as step(). */
static int step_held(void *sim, double *x, const double *in_before, const double *in, double t, double h,
                     NativeResult *r) {
    LtiSim *s = sim;
    long n = split(s, t, h, r);
    if (n == 0) return r->status;
    assemble(s, in);
    held_p(s, in_before, s->p_before);
    double hi = h / (double)n;
    s->last_h = hi;
    if (!ffx_lti_taylor_prepare(&s->maps, s->p_before, s->p, hi, n, s->u)) return step_by_maps(s, x, h, n, hi, r);
    int status = ffx_lti_taylor_steps(&s->maps, n, x, x);
    if (status == FFX_LTI_OK) return BRIDGE_OK;
    if (status == FFX_LTI_BAD_ARGUMENT) return native_refuse(r, BRIDGE_ERROR, "%s", ffx_lti_status_string(status));
    return NATIVE_NOT_FINITE; /* the state overflows: the bridge names the culprit */
}

/* Only the outputs asked for: a host often reads a few of them (an accelerometer of a 25-output body).  A derived
   output asked for brings its sources (they are written too, and marked in which), then is computed from them. */
static int outputs(void *sim, const double *x, const double *in, double *y, unsigned char *which, NativeResult *r) {
    LtiSim *s = sim;
    const LtiModel *m = s->m;
    assemble(s, in);
    int n = 0, ny = m->kernel.ny;
    if (m->n_derived) {
        for (int k = 0; k < ny; k++) s->need[k] = which[m->y_to_output[k]] != 0;
        for (int d = 0; d < m->n_derived; d++) {
            if (!s->need[m->derived_output[d]]) continue;
            const int32_t *src = m->derived_sources + (size_t)d * FFX_DERIVED_MAX_SOURCES;
            for (int i = 0; i < ffx_derived_n_sources(m->derived_kind[d]); i++) s->need[src[i]] = 1;
        }
    }
    const unsigned char *asked = m->n_derived ? s->need : NULL;
    for (int k = 0; k < ny; k++) { /* branch-free: which is a pattern the predictor does not learn */
        s->rows[n] = k;
        n += (asked ? asked[k] : which[m->y_to_output[k]]) != 0;
    }
    int status = ffx_lti_output_rows(&s->maps, s->p, x, s->u, s->rows, n, s->y);
    if (status == FFX_LTI_BAD_ARGUMENT) return native_refuse(r, BRIDGE_ERROR, "%s", ffx_lti_status_string(status));
    if (m->n_derived)
        ffx_derived_evaluate(m->n_derived, m->derived_kind, m->derived_shape, m->derived_output, m->derived_sources,
                             m->derived_fibres, s->need, s->y);
    for (int q = 0; q < n; q++) {
        int out = m->y_to_output[s->rows[q]];
        y[out] = s->y[s->rows[q]];
        which[out] = 1;
    }
    return status == FFX_LTI_OK ? BRIDGE_OK : NATIVE_NOT_FINITE;
}

/* The held input most likely behind an overflow (as flexfmu.ffr.simulator's _divergence and _output_failure):
   each linearly acting input scored by its largest contribution (Bd u_j over the last internal step, or Cu u_j
   in the outputs); the base motion (the inputs feeding p) as one: the largest of them (the spin squared, as it
   enters), scored by the largest forcing it makes (bd, or y0).  State: the largest score above `threshold`, else
   -1; outputs: the largest that alone overflows (>= 1e300), else the largest; -1 when all inputs are 0. */
static int culprit(void *sim, int what, const double *x, const double *in, double threshold) {
    (void)x;
    LtiSim *s = sim;
    const LtiModel *m = s->m;
    const ffx_lti_model *k = &m->kernel;
    assemble(s, in);
    int maps_ok = what == 0 ? ffx_lti_update_step_maps(&s->maps, s->p, s->last_h) == FFX_LTI_OK
                            : ffx_lti_update_output_maps(&s->maps, s->p) == FFX_LTI_OK;
    int rows = what == 0 ? k->nx : k->ny;
    const double *M = what == 0 ? s->maps.Bd : s->maps.Cu, *c = what == 0 ? s->maps.bd : s->maps.y0;
    int base = -1;
    double base_size = 0.0;
    for (int q = 0; q < k->np; q++) {
        int j = m->p_from_input[q];
        if (j < 0) continue;
        double v = fabs(in[j]), size = m->quadratic[q] ? v * v : v;
        if (size > base_size || (!(size <= base_size) && base < 0)) base = j, base_size = size;
    }
    int best = -1;
    double best_score = 0.0;
    if (base >= 0) {
        double score = maps_ok ? 0.0 : INFINITY;
        for (int i = 0; maps_ok && i < rows; i++)
            if (!(fabs(c[i]) <= score)) score = fabs(c[i]);
        best = base, best_score = score;
    }
    for (int q = 0; q < k->nu; q++) {
        int j = m->u_from_input[q];
        double v = fabs(in[j]), score = 0.0;
        if (v == 0.0) continue;
        if (!maps_ok) score = v;
        for (int i = 0; maps_ok && i < rows; i++) {
            double contribution = fabs(M[(size_t)i * (size_t)k->nu + (size_t)q] * v);
            if (!(contribution <= score)) score = contribution; /* NaN, inf win */
        }
        if (best < 0 || !(score <= best_score)) best = j, best_score = score;
    }
    if (what == 0) return best >= 0 && !(best_score <= threshold) ? best : -1;
    return best; /* outputs: the largest contributor (one that overflows alone is the largest) */
}

/* ---- model exchange and directional derivatives ------------------------------------------------------- */

/* out (rows) += sum_k w[k] (M[k] x + N[k] u + c[k]) (M: (nmono, rows, nx), N: (nmono, rows, nu), c: (nmono, rows) or
   NULL); the k with w[k] = 0 are skipped (the base motion is often zero: only the constant term then). */
static void add_affine(const ffx_lti_model *k, int rows, const double *M, const double *N, const double *c,
                       const double *w, const double *x, const double *u, double *out) {
    for (int q = 0; q < k->nmono; q++) {
        if (w[q] == 0.0) continue;
        const double *Mq = M + (size_t)q * (size_t)rows * (size_t)k->nx;
        const double *Nq = N + (size_t)q * (size_t)rows * (size_t)k->nu;
        for (int i = 0; i < rows; i++) {
            double sum = c ? c[(size_t)q * (size_t)rows + (size_t)i] : 0.0;
            for (int j = 0; j < k->nx; j++) sum += Mq[(size_t)i * (size_t)k->nx + (size_t)j] * x[j];
            for (int j = 0; j < k->nu; j++) sum += Nq[(size_t)i * (size_t)k->nu + (size_t)j] * u[j];
            out[i] += w[q] * sum;
        }
    }
}

/* x' = A(p) x + B(p) u + b(p) (lti_kernels.h): the continuous-time system whose exact zero-order hold is the step
   (the same coefficients), so model exchange and co-simulation integrate one ODE. */
static int derivatives(void *sim, const double *x, const double *in, double *dx, NativeResult *r) {
    (void)r;
    LtiSim *s = sim;
    const ffx_lti_model *k = &s->m->kernel;
    assemble(s, in);
    ffx_lti_monomials(k->np, s->p, s->mono);
    memset(dx, 0, sizeof(double) * (size_t)k->nx);
    add_affine(k, k->nx, k->A, k->B, k->b, s->mono, x, s->u, dx);
    for (int i = 0; i < k->nx; i++)
        if (!isfinite(dx[i])) return NATIVE_NOT_FINITE;
    return BRIDGE_OK;
}

/* The exact derivative along (dx, du) of f and of the outputs: both are sums over the monomials of p of terms
   affine in (x, u), plus the outputs' products z_i z_j of z = [x; u; mono(p)], so by the product rule
       df = A(p) dx + B(p) du + sum_k dmono_k (A_k x + B_k u + b_k)
       dy = Cx(p) dx + Cu(p) du + sum_k dmono_k (Cx_k x + Cu_k u + y0_k) + sum v (dz_i z_j + z_i dz_j)
   with dmono the monomials' derivative along dp (0 for the constant, dp_i, p_i dp_j + dp_i p_j): no differences
   are taken, so the result is exact up to rounding.  The FMU inputs feeding p (the base motion) move p. */
static int directional(void *sim, const double *x, const double *in, const double *dx, const double *din, double *dy,
                       double *ddx, NativeResult *r) {
    (void)r;
    LtiSim *s = sim;
    const LtiModel *m = s->m;
    const ffx_lti_model *k = &m->kernel;
    assemble(s, in);
    for (int q = 0; q < k->nu; q++) s->du[q] = din[m->u_from_input[q]];
    for (int q = 0; q < k->np; q++) s->dp[q] = m->p_from_input[q] >= 0 ? din[m->p_from_input[q]] : 0.0;
    ffx_lti_monomials(k->np, s->p, s->mono);
    s->dmono[0] = 0.0;
    for (int i = 0; i < k->np; i++) s->dmono[1 + i] = s->dp[i];
    for (int i = 0, q = 1 + k->np; i < k->np; i++)
        for (int j = i; j < k->np; j++) s->dmono[q++] = s->p[i] * s->dp[j] + s->dp[i] * s->p[j];
    int nx = k->nx, nu = k->nu;
    if (ddx) {
        memset(ddx, 0, sizeof(double) * (size_t)nx);
        add_affine(k, nx, k->A, k->B, NULL, s->mono, dx, s->du, ddx);
        add_affine(k, nx, k->A, k->B, k->b, s->dmono, x, s->u, ddx);
    }
    double *d = s->dy;
    memset(d, 0, sizeof(double) * (size_t)k->ny);
    add_affine(k, k->ny, k->Cx, k->Cu, NULL, s->mono, dx, s->du, d);
    add_affine(k, k->ny, k->Cx, k->Cu, k->y0, s->dmono, x, s->u, d);
    memcpy(s->z, x, sizeof(double) * (size_t)nx);
    memcpy(s->z + nx, s->u, sizeof(double) * (size_t)nu);
    memcpy(s->z + nx + nu, s->mono, sizeof(double) * (size_t)k->nmono);
    memcpy(s->dz, dx, sizeof(double) * (size_t)nx);
    memcpy(s->dz + nx, s->du, sizeof(double) * (size_t)nu);
    memcpy(s->dz + nx + nu, s->dmono, sizeof(double) * (size_t)k->nmono);
    for (int q = 0; q < k->nquad; q++) {
        int i = k->quad_i[q], j = k->quad_j[q];
        d[k->quad_row[q]] += k->quad_value[q] * (s->dz[i] * s->z[j] + s->z[i] * s->dz[j]);
    }
    if (m->n_derived) { /* the chain rule on the sources' values and derivatives */
        int status = ffx_lti_output_rows(&s->maps, s->p, x, s->u, NULL, k->ny, s->y);
        if (status == FFX_LTI_BAD_ARGUMENT) return native_refuse(r, BRIDGE_ERROR, "%s", ffx_lti_status_string(status));
        ffx_derived_directional(m->n_derived, m->derived_kind, m->derived_shape, m->derived_output, m->derived_sources,
                                m->derived_fibres, s->y, d);
    }
    int finite = 1;
    for (int q = 0; q < k->ny; q++) {
        dy[m->y_to_output[q]] = d[q];
        finite &= isfinite(d[q]) != 0;
    }
    for (int i = 0; ddx && i < nx; i++) finite &= isfinite(ddx[i]) != 0;
    return finite ? BRIDGE_OK : NATIVE_NOT_FINITE;
}

const NativeKind native_lti_kind = {.name = "lti",
                                    .load = load,
                                    .free_model = free_model,
                                    .state_size = state_size,
                                    .init = init,
                                    .free_sim = free_sim,
                                    .step = step,
                                    .step_held = step_held,
                                    .outputs = outputs,
                                    .culprit = culprit,
                                    .derivatives = derivatives,
                                    .directional = directional};
