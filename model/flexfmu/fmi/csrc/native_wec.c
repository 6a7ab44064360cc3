/*
 * native_wec.c - the "wec" kind of the native runtime (native_kind.h): the four components of the reference point
 * absorber (examples/point_absorber; the Python simulators in flexfmu.wec.absorber, the same equations) in C:
 *
 *   wave   AbsorberWave   elevation and excitation loads of a regular wave or a JONSWAP sea from the BEM database's
 *                         excitation X(omega) (components built here at initialisation from the runtime parameters)
 *   float  AbsorberFloat  the rigid float: xi, xi_dot and the work of each load group, exact for held loads
 *   hydro  AbsorberHydro  hydrostatics, radiation memory (the exact zero-order hold of (A_r, B_r)) and quadratic drag
 *   pto    HeavePTO       a linear heave damper and spring with a force limit (memoryless)
 *
 * The hull's data are baked into the model file by flexfmu/fmi/native.py; every parameter of the component stays a
 * runtime parameter (sea_state, a String, too), so one FMU serves a whole power matrix.  Variables are matched by
 * name: the FMU's inputs, outputs and runtime parameters (the layout's names) against the component's own lists
 * below, so the FMU may declare them in any order.
 *
 * Model-file entries:
 *   wec.component    string: wave | float | hydro | pto
 *   wec.fixed        float64 (n_roles): the build value of each of the component's parameters (ROLES below), used
 *                    for one that is not a runtime parameter
 *   wec.sea_state    string: the build value of sea_state (wave)
 *   wec.omega        float64 (n_w) rad/s, increasing; wec.X float64 (n_w, 6, 2): Re and Im of the excitation per
 *                    unit wave amplitude about O, global axes (wave)
 *   wec.M, wec.M_inv float64 (6, 6): M_total = M_rb + A_inf about O and its inverse (float)
 *   wec.C            float64 (6, 6) hydrostatic stiffness; wec.A_r (n, n), wec.B_r (n, 6), wec.C_r (6, n) the
 *                    radiation model; wec.rho float64 scalar (hydro)
 *   wec.divergence_limit  float64: the largest |xi|, |xi_dot| (float) or |x_r| (hydro) of a step's result; beyond
 *                    it the step is refused as the Python simulator refuses it ("state: ... diverged ...", with the
 *                    model file's divergence_allowed).  The bridge's own limit (divergence_limit) stays inf: the
 *                    float's state also holds the work, which is not bounded by it.
 *
 * States (what an FMU state holds; the bridge holds the time):
 *   wave   [t, t_anchor, h_rotation, n]: see "The wave's sum" below
 *   float  [xi (6), xi_dot (6), work_wave, work_hydro, work_pto, work_mooring]
 *   hydro  x_r (n)
 *   pto    none
 *
 * The wave's sum.  Each output is sum_k c_k cos(theta_k) + s_k sin(theta_k), theta_k = w_k t - phi_k, over ~500
 * components: one sin and cos per component per step would be most of the cost (~20 ns each).  Instead the phasors
 * z_k = e^{i theta_k} follow a recurrence: computed exactly (cos, sin) at an anchor time t_a, then advanced by the
 * rotations e^{i w_k h} of the host's step h (computed once per step size), z_k(t_a + n h) = z_k(t_a) r_k^n, and
 * re-anchored exactly every ANCHOR_EVERY steps, when the step size changes, or when the time drifts from
 * t_a + n h.  Each complex product adds at most ~2.5 eps of relative error to z_k, so between anchors the error
 * stays below ANCHOR_EVERY x 2.5 eps = 3.6e-14 of each component's amplitude: rounding, as the direct evaluation's
 * own (the rounding of w_k t is eps w_k t, 1e-13 at t = 1000 s).  The host's clock t (the sum of its steps, rounded)
 * differs from t_a + n h by delta, a few ulp of t; the outputs take it exactly to first order (z e^{i w delta} =
 * z (1 + i w delta) with |w delta| <= DRIFT_MAX = 1e-8: the second-order term is < 1e-16), so they are those of
 * cos(w_k t - phi_k) at the host's own t.  (t_a, h, n) are the FMU state beside t, and the phasor of a state is
 * always made by the same operations (anchor, then n products), so an FMU state restored and stepped again gives
 * the same numbers bit for bit.
 *
 * The hydro's step maps (Phi, Gamma) = expm([[A_r, B_r], [0, 0]] h) (as RadiationModel.discretize) come from the
 * LTI kernels' matrix exponential (ffx_lti_expm: scaling and squaring, [13/13] Pade, scipy's choice of scaling),
 * computed when the step size first appears and recomputed only when it changes beyond FFX_STEP_RTOL (ffx_same_step,
 * as the LTI kind keys its maps: hosts whose steps differ in the last bits do not recompute; lti_kernels.h gives
 * the error bound of stepping by the cached step).
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "flexfmu_bridge.h"
#include "lti_kernels.h"
#include "native_kind.h"

#define WEC_PI 3.141592653589793
#ifndef ANCHOR_EVERY
#define ANCHOR_EVERY 64 /* wave: steps between exact evaluations of the phasors (benchmarks: -D) */
#endif
#define DRIFT_MAX 1e-8      /* wave: largest w_max |delta| taken by the first-order correction */
#define MAX_COMPONENTS 5000 /* wave: the largest number of components (n_components' range) */

enum { WAVE = 0, FLOAT = 1, HYDRO = 2, PTO = 3, N_COMPONENTS };
static const char *const COMPONENT_NAMES[N_COMPONENTS] = {"wave", "float", "hydro", "pto"};

/* ---- each component's variables (matched by name against the FMU's) ---------------------------------------- */

#define MAX_ROLES 13
#define MAX_INPUTS 24
#define MAX_OUTPUTS 23

/* wave */
enum { W_SEA_STATE, W_HEIGHT, W_PERIOD, W_GAMMA, W_SEED, W_N, W_RECORD, W_RAMP, W_ROLES };
static const char *const WAVE_ROLES[]
    = {"sea_state", "wave_height", "wave_period", "gamma", "seed", "n_components", "record_length", "ramp_time", NULL};
static const char *const WAVE_OUTPUTS[] = {"elevation", "F_x", "F_y", "F_z", "M_x", "M_y", "M_z", NULL};
static const char *const NO_NAMES[] = {NULL};

/* float */
enum { F_HEAVE_ONLY, F_ROLES };
static const char *const FLOAT_ROLES[] = {"heave_only", NULL};
static const char *const FLOAT_INPUTS[]
    = {"wave_F_x",    "wave_F_y",    "wave_F_z",    "wave_M_x",  "wave_M_y",    "wave_M_z",    "hydro_F_x",
       "hydro_F_y",   "hydro_F_z",   "hydro_M_x",   "hydro_M_y", "hydro_M_z",   "pto_F_x",     "pto_F_y",
       "pto_F_z",     "pto_M_x",     "pto_M_y",     "pto_M_z",   "mooring_F_x", "mooring_F_y", "mooring_F_z",
       "mooring_M_x", "mooring_M_y", "mooring_M_z", NULL};
static const char *const FLOAT_OUTPUTS[]
    = {"pos_x",   "pos_y",   "pos_z",          "rot_x",     "rot_y",      "rot_z",    "vel_x",        "vel_y",
       "vel_z",   "omega_x", "omega_y",        "omega_z",   "acc_x",      "acc_y",    "acc_z",        "alpha_x",
       "alpha_y", "alpha_z", "kinetic_energy", "work_wave", "work_hydro", "work_pto", "work_mooring", NULL};
enum { O_KINETIC = 18, O_WORK = 19 };

/* hydro */
enum { H_DRAG, H_CD, H_AREA = H_CD + 6, H_ROLES = H_AREA + 6 };
static const char *const HYDRO_ROLES[] = {"drag",
                                          "drag_coefficient_x",
                                          "drag_coefficient_y",
                                          "drag_coefficient_z",
                                          "drag_coefficient_rx",
                                          "drag_coefficient_ry",
                                          "drag_coefficient_rz",
                                          "drag_area_x",
                                          "drag_area_y",
                                          "drag_area_z",
                                          "drag_area_rx",
                                          "drag_area_ry",
                                          "drag_area_rz",
                                          NULL};
static const char *const HYDRO_INPUTS[] = {"pos_x", "pos_y", "pos_z",   "rot_x",   "rot_y",   "rot_z", "vel_x",
                                           "vel_y", "vel_z", "omega_x", "omega_y", "omega_z", NULL};
static const char *const HYDRO_OUTPUTS[] = {"F_x", "F_y", "F_z", "M_x", "M_y", "M_z", "drag_power", NULL};

/* pto */
enum { P_DAMPING, P_STIFFNESS, P_LIMIT, P_ROLES };
static const char *const PTO_ROLES[] = {"damping", "stiffness", "force_limit", NULL};
static const char *const PTO_INPUTS[] = {"pos_z", "vel_z", NULL};
static const char *const PTO_OUTPUTS[] = {"F_z", "power", NULL};

static const char *const *const ROLES[N_COMPONENTS] = {WAVE_ROLES, FLOAT_ROLES, HYDRO_ROLES, PTO_ROLES};
static const char *const *const INPUTS[N_COMPONENTS] = {NO_NAMES, FLOAT_INPUTS, HYDRO_INPUTS, PTO_INPUTS};
static const char *const *const OUTPUTS[N_COMPONENTS] = {WAVE_OUTPUTS, FLOAT_OUTPUTS, HYDRO_OUTPUTS, PTO_OUTPUTS};

static int count(const char *const *names) {
    int n = 0;
    while (names[n]) n++;
    return n;
}

/* ---- the model ----------------------------------------------------------------------------------------------- */

typedef struct {
    int component;
    NativeLayout layout;
    int n_roles, n_inputs, n_outputs;
    int role_param[MAX_ROLES];   /* the runtime parameter of each role, or -1: fixed at build */
    const double *fixed;         /* (n_roles) */
    const char *sea_state_fixed; /* wave */
    int input_of[MAX_INPUTS];    /* the FMU input (index) of each of the component's inputs */
    int output_of[MAX_OUTPUTS];  /* the FMU output (index) of each of the component's outputs */
    /* wave */
    long n_w;
    const double *omega, *X;
    /* float */
    const double *M, *M_inv;
    /* hydro */
    long n_r;
    const double *C, *A_r, *B_r, *C_r;
    double rho;
    double divergence_limit;
    const char *divergence_allowed;
} WecModel;

/* The index of `name` in `names`, or -1. */
static int find(const char *const *names, size_t n, const char *name) {
    for (size_t k = 0; k < n; k++)
        if (strcmp(names[k], name) == 0) return (int)k;
    return -1;
}

static void *load(const NativeFile *file, const NativeLayout *layout, char *why, size_t why_size) {
    WecModel *m = calloc(1, sizeof *m);
    if (!m) {
        snprintf(why, why_size, "out of memory");
        return NULL;
    }
    m->layout = *layout;
    const NativeEntry *component = native_entry(file, "wec.component");
    m->component = -1;
    if (component && component->type == NATIVE_STR && component->ndim == 0)
        for (int c = 0; c < N_COMPONENTS; c++)
            if (strcmp(((char **)component->data)[0], COMPONENT_NAMES[c]) == 0) m->component = c;
    if (m->component < 0) {
        snprintf(why, why_size, "model file entry wec.component is not one of wave, float, hydro, pto");
        goto fail;
    }
    int c = m->component;
    m->n_roles = count(ROLES[c]), m->n_inputs = count(INPUTS[c]), m->n_outputs = count(OUTPUTS[c]);
    long roles[1] = {m->n_roles};
    const double *limit;
    const NativeEntry *allowed = native_entry(file, "divergence_allowed");
    if (native_f64(file, "wec.fixed", 1, roles, &m->fixed, NULL, why, why_size) < 0
        || native_f64(file, "wec.divergence_limit", 0, NULL, &limit, NULL, why, why_size) < 0)
        goto fail;
    m->divergence_limit = *limit;
    m->divergence_allowed
        = allowed && allowed->type == NATIVE_STR && allowed->ndim == 0 ? ((char **)allowed->data)[0] : "a smaller step";
    for (int k = 0; k < m->n_roles; k++) m->role_param[k] = find(layout->param_names, layout->n_params, ROLES[c][k]);
    /* the FMU's inputs and outputs are the component's, by name */
    if ((size_t)m->n_inputs != layout->n_inputs || (size_t)m->n_outputs != layout->n_outputs) {
        snprintf(why, why_size,
                 "the FMU has %zu inputs and %zu outputs; the wec kind's %s has %d and %d (model file and binary "
                 "of different versions?)",
                 layout->n_inputs, layout->n_outputs, COMPONENT_NAMES[c], m->n_inputs, m->n_outputs);
        goto fail;
    }
    for (int k = 0; k < m->n_inputs; k++)
        if ((m->input_of[k] = find(layout->input_names, layout->n_inputs, INPUTS[c][k])) < 0) {
            snprintf(why, why_size, "the FMU has no input %s, which the wec kind's %s reads", INPUTS[c][k],
                     COMPONENT_NAMES[c]);
            goto fail;
        }
    for (int k = 0; k < m->n_outputs; k++)
        if ((m->output_of[k] = find(layout->output_names, layout->n_outputs, OUTPUTS[c][k])) < 0) {
            snprintf(why, why_size, "the FMU has no output %s, which the wec kind's %s writes", OUTPUTS[c][k],
                     COMPONENT_NAMES[c]);
            goto fail;
        }
    uint32_t s[NATIVE_MAX_DIMS];
    long six_six[2] = {6, 6};
    if (c == WAVE) {
        const NativeEntry *sea = native_entry(file, "wec.sea_state");
        if (!sea || sea->type != NATIVE_STR || sea->ndim != 0) {
            snprintf(why, why_size, "model file entry wec.sea_state is missing or not a string");
            goto fail;
        }
        m->sea_state_fixed = ((char **)sea->data)[0];
        if (native_f64(file, "wec.omega", 1, NULL, &m->omega, s, why, why_size) < 0) goto fail;
        m->n_w = s[0];
        long shape_X[3] = {m->n_w, 6, 2};
        if (native_f64(file, "wec.X", 3, shape_X, &m->X, NULL, why, why_size) < 0) goto fail;
        int increasing = m->n_w >= 2;
        for (long k = 0; k < m->n_w; k++)
            increasing &= isfinite(m->omega[k]) && m->omega[k] > 0 && (k == 0 || m->omega[k] > m->omega[k - 1]);
        if (!increasing) {
            snprintf(why, why_size, "model file entry wec.omega is not >= 2 increasing positive frequencies");
            goto fail;
        }
    } else if (c == FLOAT) {
        if (native_f64(file, "wec.M", 2, six_six, &m->M, NULL, why, why_size) < 0
            || native_f64(file, "wec.M_inv", 2, six_six, &m->M_inv, NULL, why, why_size) < 0)
            goto fail;
    } else if (c == HYDRO) {
        const double *rho;
        if (native_f64(file, "wec.C", 2, six_six, &m->C, NULL, why, why_size) < 0
            || native_f64(file, "wec.A_r", 2, NULL, &m->A_r, s, why, why_size) < 0)
            goto fail;
        m->n_r = s[0];
        long shape_B[2] = {m->n_r, 6}, shape_C[2] = {6, m->n_r};
        if (s[1] != s[0]) {
            snprintf(why, why_size, "model file entry wec.A_r is not square");
            goto fail;
        }
        if (native_f64(file, "wec.B_r", 2, shape_B, &m->B_r, NULL, why, why_size) < 0
            || native_f64(file, "wec.C_r", 2, shape_C, &m->C_r, NULL, why, why_size) < 0
            || native_f64(file, "wec.rho", 0, NULL, &rho, NULL, why, why_size) < 0)
            goto fail;
        m->rho = *rho;
    }
    return m;
fail:
    free(m);
    return NULL;
}

static void free_model(void *model) { free(model); }

static size_t state_size(const void *model) {
    const WecModel *m = model;
    switch (m->component) {
    case WAVE: return 4;
    case FLOAT: return 16;
    case HYDRO: return (size_t)m->n_r;
    default: return 0;
    }
}

/* ---- simulators ---------------------------------------------------------------------------------------------- */

typedef struct {
    const WecModel *m;
    double role[MAX_ROLES]; /* the parameters' values */
    double last_h;          /* the last step (culprits) */
    /* wave: n components; per component w, phase and the 13 coefficients [a, a Re X (6), a Im X (6)] */
    long n;
    double w_max, ramp_time;
    double *w, *phase, *coef;
    double *anchor_re, *anchor_im, *z_re, *z_im, *rot_re, *rot_im;
    int anchor_valid, rot_valid;
    double anchor_t, rot_h, z_h; /* the anchor's time, the rotations' step, the step z was advanced by */
    long z_n;                    /* z = anchor * rot^z_n */
    /* hydro: the drag rates 1/2 rho Cd_i A_i (0 without drag), the step maps of step_h */
    double rate[6];
    int maps_valid;
    double step_h;
    double *Phi, *Gamma, *aug, *E, *expm_work, *x_new;
} WecSim;

static void free_sim(void *sim) {
    WecSim *s = sim;
    if (!s) return;
    free(s->w);
    free(s->phase);
    free(s->coef);
    free(s->anchor_re);
    free(s->anchor_im);
    free(s->z_re);
    free(s->z_im);
    free(s->rot_re);
    free(s->rot_im);
    free(s->Phi);
    free(s->Gamma);
    free(s->aug);
    free(s->E);
    free(s->expm_work);
    free(s->x_new);
    free(s);
}

/* SplitMix64 (Steele, Lea, Flood 2014): the next uniform in [0, 1) with 53 random bits */
static double splitmix64(uint64_t *state) {
    uint64_t z = (*state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    z ^= z >> 31;
    return (double)(z >> 11) * 0x1.0p-53;
}

/* The JONSWAP shape s(w) (unnormalised) */
static double jonswap_shape(double w, double wp, double gamma) {
    double sigma = w <= wp ? 0.07 : 0.09, r = (w - wp) / (sigma * wp);
    return pow(w, -5.0) * exp(-1.25 * pow(wp / w, 4.0)) * pow(gamma, exp(-0.5 * r * r));
}

/* Linear interpolation of Re and Im of X at w (inside the database's range, checked by the caller) into the 12
   coefficients a Re X (6), a Im X (6). */
static void interpolate_X(const WecModel *m, double w, double a, double *out) {
    long lo = 0, hi = m->n_w - 1;
    while (hi - lo > 1) { /* omega[lo] <= w <= omega[hi] */
        long mid = (lo + hi) / 2;
        if (m->omega[mid] <= w)
            lo = mid;
        else
            hi = mid;
    }
    double f = (w - m->omega[lo]) / (m->omega[hi] - m->omega[lo]);
    for (int i = 0; i < 6; i++)
        for (int part = 0; part < 2; part++) {
            double x0 = m->X[(lo * 6 + i) * 2 + part], x1 = m->X[(hi * 6 + i) * 2 + part];
            out[part * 6 + i] = a * (x0 + f * (x1 - x0));
        }
}

static int wave_init(WecSim *s, const char *sea_state, NativeResult *r) {
    const WecModel *m = s->m;
    double H = s->role[W_HEIGHT], T = s->role[W_PERIOD], gamma = s->role[W_GAMMA];
    int jonswap = strcmp(sea_state, "jonswap") == 0;
    if (!jonswap && strcmp(sea_state, "regular") != 0)
        return native_refuse(r, BRIDGE_ERROR, "sea_state: got '%s' (allowed: regular | jonswap)", sea_state);
    double wp = 2.0 * WEC_PI / T, dw = 0.0;
    long n = 1;
    char shown[64], shown_T[64];
    if (jonswap) {
        n = (long)s->role[W_N];
        if (n == 0) { /* AbsorberWaveConfig's check of the automatic count */
            /* ceil(2.5 w_p L / (2 pi)) = ceil(2.5 L / Tp), with AbsorberWave's guard: through w_p a whole
               2.5 L / Tp rounds up to the next integer (Tp = 9 s, L = 1800 s: 501 for 500) */
            double automatic = ceil(2.5 * s->role[W_RECORD] / T - 1e-9);
            if (!(automatic <= MAX_COMPONENTS)) {
                native_repr(s->role[W_RECORD], shown, sizeof shown);
                native_repr(T, shown_T, sizeof shown_T);
                return native_refuse(r, BRIDGE_ERROR,
                                     "record_length: %s s needs %.0f components at Tp = %s s (allowed: <= %d "
                                     "components: record_length <= %.6g s (or set n_components))",
                                     shown, automatic, shown_T, MAX_COMPONENTS, MAX_COMPONENTS * T / 2.5);
            }
            n = (long)automatic;
        }
        dw = 2.5 * wp / (double)n;
    }
    /* the components' frequencies (increasing) inside the database's, as interpolate_excitation refuses them */
    double w_first = jonswap ? 0.5 * wp + 0.5 * dw : wp, w_last = jonswap ? 0.5 * wp + ((double)n - 0.5) * dw : wp;
    double lo = m->omega[0], hi = m->omega[m->n_w - 1];
    if (!(w_first >= lo && w_last <= hi))
        return native_refuse(r, BRIDGE_ERROR,
                             "wave_period: wave frequencies %.6g .. %.6g rad/s lie outside the BEM database's "
                             "(allowed: wave frequencies within %.6g .. %.6g rad/s: a regular period %.6g .. %.6g s; a "
                             "JONSWAP Tp whose band 0.5 .. 3 w_p lies within it, about %.4g .. %.4g s)",
                             w_first, w_last, lo, hi, 2.0 * WEC_PI / hi, 2.0 * WEC_PI / lo, 3.0 * 2.0 * WEC_PI / hi,
                             0.5 * 2.0 * WEC_PI / lo);
    s->n = n;
    if (!(s->w = malloc(sizeof(double) * (size_t)n)) || !(s->phase = malloc(sizeof(double) * (size_t)n))
        || !(s->coef = malloc(sizeof(double) * 13 * (size_t)n)) || !(s->anchor_re = malloc(sizeof(double) * (size_t)n))
        || !(s->anchor_im = malloc(sizeof(double) * (size_t)n)) || !(s->z_re = malloc(sizeof(double) * (size_t)n))
        || !(s->z_im = malloc(sizeof(double) * (size_t)n)) || !(s->rot_re = malloc(sizeof(double) * (size_t)n))
        || !(s->rot_im = malloc(sizeof(double) * (size_t)n)))
        return native_refuse(r, BRIDGE_ERROR, "out of memory");
    if (!jonswap) {
        s->w[0] = wp, s->phase[0] = 0.0, s->coef[0] = H / 2.0;
    } else {
        double sum = 0.0;
        for (long k = 0; k < n; k++) {
            s->w[k] = 0.5 * wp + ((double)k + 0.5) * dw;
            s->coef[13 * k] = jonswap_shape(s->w[k], wp, gamma);
            sum += s->coef[13 * k];
        }
        uint64_t state = (uint64_t)(int64_t)s->role[W_SEED];
        double scale = (H / 4.0) * (H / 4.0) / (dw * sum);
        for (long k = 0; k < n; k++) {
            double S = scale * s->coef[13 * k];
            s->coef[13 * k] = sqrt(2.0 * S * dw);
            s->phase[k] = 2.0 * WEC_PI * splitmix64(&state);
        }
    }
    s->w_max = 0.0;
    for (long k = 0; k < n; k++) {
        interpolate_X(m, s->w[k], s->coef[13 * k], s->coef + 13 * k + 1);
        if (s->w[k] > s->w_max) s->w_max = s->w[k];
        for (int j = 0; j < 13; j++)
            if (!isfinite(s->coef[13 * k + j]))
                return native_refuse(r, BRIDGE_ERROR,
                                     "wave_height: got %g m: the components' amplitudes overflow "
                                     "(allowed: a finite sea)",
                                     H);
    }
    s->ramp_time = s->role[W_RAMP];
    return BRIDGE_OK;
}

static void *init(const void *model, const double *params, const char *const *texts, double *x, NativeResult *r) {
    const WecModel *m = model;
    WecSim *s = calloc(1, sizeof *s);
    if (!s) {
        native_refuse(r, BRIDGE_ERROR, "out of memory");
        return NULL;
    }
    s->m = m;
    for (int k = 0; k < m->n_roles; k++) s->role[k] = m->role_param[k] >= 0 ? params[m->role_param[k]] : m->fixed[k];
    memset(x, 0, sizeof(double) * state_size(m));
    if (m->component == WAVE) {
        const char *sea = m->role_param[W_SEA_STATE] >= 0 ? texts[m->role_param[W_SEA_STATE]] : m->sea_state_fixed;
        if (wave_init(s, sea ? sea : "", r) != BRIDGE_OK) {
            free_sim(s);
            return NULL;
        }
    } else if (m->component == HYDRO) {
        size_t n = (size_t)m->n_r, na = n + 6;
        if (!(s->Phi = malloc(sizeof(double) * (n * n + 1))) || !(s->Gamma = malloc(sizeof(double) * (n * 6 + 1)))
            || !(s->aug = calloc(na * na, sizeof(double))) || !(s->E = malloc(sizeof(double) * na * na))
            || !(s->expm_work = malloc(sizeof(double) * ffx_lti_expm_work_len((int)na)))
            || !(s->x_new = malloc(sizeof(double) * (n + 1)))) {
            free_sim(s);
            native_refuse(r, BRIDGE_ERROR, "out of memory");
            return NULL;
        }
        int finite = 1;
        for (int i = 0; i < 6; i++) {
            s->rate[i] = s->role[H_DRAG] != 0.0 ? 0.5 * m->rho * s->role[H_CD + i] * s->role[H_AREA + i] : 0.0;
            finite &= isfinite(s->rate[i]) != 0;
        }
        if (!finite) { /* as AbsorberHydroSimulator: the largest coefficient or area (the first of equals) */
            int best = H_CD;
            for (int k = H_CD; k < H_ROLES; k++)
                if (s->role[k] > s->role[best]) best = k;
            char shown[64];
            native_repr(s->role[best], shown, sizeof shown);
            native_refuse(r, BRIDGE_ERROR,
                          "%s: %s makes the drag rate overflow (not finite) (allowed: values whose product with rho / "
                          "2 stays within the floating-point range)",
                          HYDRO_ROLES[best], shown);
            free_sim(s);
            return NULL;
        }
    }
    return s;
}

/* ---- wave ---------------------------------------------------------------------------------------------------- */

/* z = e^{i theta(t_a)} r^n, r = e^{i w h}: the phasor of the state (t_a, h, n), always by the same operations. */
static void wave_phasors(WecSim *s, double t_a, double h, long n) {
    long nc = s->n;
    if (!s->anchor_valid || s->anchor_t != t_a) {
        for (long k = 0; k < nc; k++) {
            double theta = s->w[k] * t_a - s->phase[k];
            s->anchor_re[k] = cos(theta), s->anchor_im[k] = sin(theta);
        }
        s->anchor_valid = 1, s->anchor_t = t_a, s->z_n = -1;
    }
    if (n > 0 && (!s->rot_valid || s->rot_h != h)) {
        for (long k = 0; k < nc; k++) {
            double angle = s->w[k] * h;
            s->rot_re[k] = cos(angle), s->rot_im[k] = sin(angle);
        }
        s->rot_valid = 1, s->rot_h = h, s->z_n = -1;
    }
    if (s->z_n < 0 || s->z_n > n || (n > 0 && s->z_h != h)) {
        memcpy(s->z_re, s->anchor_re, sizeof(double) * (size_t)nc);
        memcpy(s->z_im, s->anchor_im, sizeof(double) * (size_t)nc);
        s->z_n = 0, s->z_h = h;
    }
    for (; s->z_n < n; s->z_n++) {
        double *zr = s->z_re, *zi = s->z_im;
        const double *rr = s->rot_re, *ri = s->rot_im;
        for (long k = 0; k < nc; k++) {
            double re = zr[k] * rr[k] - zi[k] * ri[k];
            zi[k] = zr[k] * ri[k] + zi[k] * rr[k];
            zr[k] = re;
        }
    }
}

/* flexfmu.wec.wave.ramp */
static double ramp(double t, double ramp_time) {
    if (ramp_time <= 0.0 || t >= ramp_time) return 1.0;
    if (t <= 0.0) return 0.0;
    return 0.5 * (1.0 - cos(WEC_PI * t / ramp_time));
}

static int wave_step(WecSim *s, double *x, double h) {
    double t1 = x[0] + h, t_a = x[1], hr = x[2], n1 = x[3] + 1.0;
    if (hr > 0.0 && n1 < ANCHOR_EVERY && fabs(s->w_max * ((t1 - t_a) - n1 * hr)) <= DRIFT_MAX) {
        x[0] = t1, x[3] = n1;
    } else {
        x[0] = t1, x[1] = t1, x[2] = h, x[3] = 0.0;
    }
    return BRIDGE_OK;
}

static int wave_outputs(WecSim *s, const double *x, double *y) {
    const WecModel *m = s->m;
    double t = x[0], t_a = x[1], hr = x[2];
    long n = (long)x[3];
    if (!(n >= 0 && n < ANCHOR_EVERY) || !(hr >= 0.0)) t_a = t, hr = 0.0, n = 0; /* not a state of wave_step's */
    wave_phasors(s, t_a, hr, n);
    double delta = (t - t_a) - (double)n * hr;
    if (!(fabs(s->w_max * delta) <= DRIFT_MAX)) { /* a crafted state: evaluate exactly at t */
        wave_phasors(s, t, 0.0, 0);
        delta = 0.0;
    }
    double acc[13] = {0.0};
    const double *w = s->w, *zr = s->z_re, *zi = s->z_im, *coef = s->coef;
    for (long k = 0; k < s->n; k++) {
        double c = zr[k], sn = zi[k], wd = w[k] * delta;
        double cd = c - sn * wd, sd = sn + c * wd; /* e^{i w delta} to first order */
        const double *q = coef + 13 * k;
        acc[0] += q[0] * cd;
        for (int i = 0; i < 6; i++) acc[1 + i] += q[1 + i] * cd + q[7 + i] * sd;
    }
    double r = ramp(t, s->ramp_time);
    for (int j = 0; j < 7; j++) y[m->output_of[j]] = r * acc[j];
    return BRIDGE_OK;
}

/* ---- float --------------------------------------------------------------------------------------------------- */

/* acc (6) = M_total^-1 Q, or heave only: Q_z / M_total[2][2] in heave */
static void float_acceleration(const WecSim *s, const double *Q, double *acc) {
    const WecModel *m = s->m;
    if (s->role[F_HEAVE_ONLY] != 0.0) {
        for (int i = 0; i < 6; i++) acc[i] = 0.0;
        acc[2] = Q[2] / m->M[2 * 6 + 2];
        return;
    }
    for (int i = 0; i < 6; i++) {
        double sum = 0.0;
        for (int j = 0; j < 6; j++) sum += m->M_inv[i * 6 + j] * Q[j];
        acc[i] = sum;
    }
}

/* the four load groups (4, 6) and their sum Q (6) from the FMU inputs */
static void float_loads(const WecSim *s, const double *u, double *groups, double *Q) {
    const WecModel *m = s->m;
    for (int g = 0; g < 4; g++)
        for (int i = 0; i < 6; i++) groups[g * 6 + i] = u[m->input_of[g * 6 + i]];
    for (int i = 0; i < 6; i++) Q[i] = ((groups[i] + groups[6 + i]) + groups[12 + i]) + groups[18 + i];
}

/* The step of x (the bridge's copy: kept only on success); a result not finite is NATIVE_NOT_FINITE (the bridge
   names the input behind it), |xi| or |xi_dot| beyond the limit is refused as AbsorberFloatSimulator.step does. */
static int float_step(WecSim *s, double *x, const double *u, double t, double h, NativeResult *r) {
    double groups[24], Q[6], acc[6], d[6], size = 0.0;
    float_loads(s, u, groups, Q);
    float_acceleration(s, Q, acc);
    for (int i = 0; i < 6; i++) d[i] = h * x[6 + i] + 0.5 * (h * h) * acc[i];
    for (int g = 0; g < 4; g++) {
        double work = 0.0;
        for (int i = 0; i < 6; i++) work += groups[g * 6 + i] * d[i];
        x[12 + g] += work;
    }
    for (int i = 0; i < 6; i++) x[i] += d[i], x[6 + i] += h * acc[i];
    for (int i = 0; i < 16; i++) {
        if (!isfinite(x[i])) return NATIVE_NOT_FINITE;
        if (i < 12 && fabs(x[i]) > size) size = fabs(x[i]);
    }
    if (size > s->m->divergence_limit)
        return native_refuse(r, BRIDGE_ERROR, "state: diverged at t = %.6g s (|xi|, |xi_dot| up to %.3g) (allowed: %s)",
                             t + h, size, s->m->divergence_allowed);
    return BRIDGE_OK;
}

static int float_outputs(WecSim *s, const double *x, const double *u, double *y) {
    const WecModel *m = s->m;
    double groups[24], Q[6], acc[6], v[18 + 5];
    float_loads(s, u, groups, Q);
    float_acceleration(s, Q, acc);
    for (int i = 0; i < 12; i++) v[i] = x[i];
    for (int i = 0; i < 6; i++) v[12 + i] = acc[i];
    double kinetic = 0.0;
    for (int i = 0; i < 6; i++) {
        double Mv = 0.0;
        for (int j = 0; j < 6; j++) Mv += m->M[i * 6 + j] * x[6 + j];
        kinetic += x[6 + i] * Mv;
    }
    v[O_KINETIC] = 0.5 * kinetic;
    for (int g = 0; g < 4; g++) v[O_WORK + g] = x[12 + g];
    for (int k = 0; k < m->n_outputs; k++) y[m->output_of[k]] = v[k];
    return BRIDGE_OK;
}

/* ---- hydro --------------------------------------------------------------------------------------------------- */

/* Phi, Gamma of step h: expm([[A_r, B_r], [0, 0]] h) (RadiationModel.discretize); reused for steps within
   FFX_STEP_RTOL of the cached one (the state then advances by the cached step: lti_kernels.h's bound). */
static int hydro_maps(WecSim *s, double h, NativeResult *r) {
    const WecModel *m = s->m;
    if (s->maps_valid && ffx_same_step(s->step_h, h)) return BRIDGE_OK;
    int n = (int)m->n_r, na = n + 6;
    memset(s->aug, 0, sizeof(double) * (size_t)na * (size_t)na);
    for (int i = 0; i < n; i++) {
        for (int j = 0; j < n; j++) s->aug[i * na + j] = m->A_r[i * n + j] * h;
        for (int j = 0; j < 6; j++) s->aug[i * na + n + j] = m->B_r[i * 6 + j] * h;
    }
    s->maps_valid = 0;
    if (ffx_lti_expm(na, s->aug, s->E, s->expm_work) != FFX_LTI_OK) {
        char shown[64];
        native_repr(h, shown, sizeof shown);
        return native_refuse(r, BRIDGE_DISCARD,
                             "step_size: a communication step of %s s makes the radiation model's step map overflow "
                             "(not finite); take a smaller communication step",
                             shown);
    }
    for (int i = 0; i < n; i++) {
        for (int j = 0; j < n; j++) s->Phi[i * n + j] = s->E[i * na + j];
        for (int j = 0; j < 6; j++) s->Gamma[i * 6 + j] = s->E[i * na + n + j];
    }
    s->maps_valid = 1, s->step_h = h;
    return BRIDGE_OK;
}

static int hydro_step(WecSim *s, double *x, const double *u, double t, double h, NativeResult *r) {
    const WecModel *m = s->m;
    int status = hydro_maps(s, h, r);
    if (status != BRIDGE_OK) return status;
    int n = (int)m->n_r;
    double v[6];
    for (int j = 0; j < 6; j++) v[j] = u[m->input_of[6 + j]];
    for (int i = 0; i < n; i++) {
        double sum = 0.0;
        for (int j = 0; j < n; j++) sum += s->Phi[i * n + j] * x[j];
        for (int j = 0; j < 6; j++) sum += s->Gamma[i * 6 + j] * v[j];
        s->x_new[i] = sum;
    }
    double size = 0.0;
    for (int i = 0; i < n; i++) {
        if (!isfinite(s->x_new[i])) return NATIVE_NOT_FINITE;
        if (fabs(s->x_new[i]) > size) size = fabs(s->x_new[i]);
    }
    if (size > m->divergence_limit) /* as AbsorberHydroSimulator.step */
        return native_refuse(r, BRIDGE_ERROR, "state: the radiation memory diverged at t = %.6g s (allowed: %s)", t + h,
                             m->divergence_allowed);
    memcpy(x, s->x_new, sizeof(double) * (size_t)n);
    return BRIDGE_OK;
}

/* drag_i = 1/2 rho Cd_i A_i |v_i| v_i (0 without drag) */
static double hydro_drag(const WecSim *s, int i, double v) { return s->rate[i] * fabs(v) * v; }

static int hydro_outputs(WecSim *s, const double *x, const double *u, double *y) {
    const WecModel *m = s->m;
    int n = (int)m->n_r;
    double xi[6], v[6], out[7];
    for (int j = 0; j < 6; j++) xi[j] = u[m->input_of[j]], v[j] = u[m->input_of[6 + j]];
    double power = 0.0;
    for (int i = 0; i < 6; i++) {
        double stiffness = 0.0, memory = 0.0;
        for (int j = 0; j < 6; j++) stiffness += m->C[i * 6 + j] * xi[j];
        for (int j = 0; j < n; j++) memory += m->C_r[i * n + j] * x[j];
        double drag = hydro_drag(s, i, v[i]);
        out[i] = -stiffness - memory - drag;
        power += drag * v[i];
    }
    out[6] = power;
    for (int k = 0; k < 7; k++) y[m->output_of[k]] = out[k];
    return BRIDGE_OK;
}

/* ---- pto ----------------------------------------------------------------------------------------------------- */

static int pto_outputs(WecSim *s, const double *u, double *y) {
    const WecModel *m = s->m;
    double z = u[m->input_of[0]], v = u[m->input_of[1]], limit = s->role[P_LIMIT];
    double F = -(s->role[P_DAMPING] * v + s->role[P_STIFFNESS] * z);
    if (limit > 0.0) F = F > limit ? limit : F < -limit ? -limit : F;
    y[m->output_of[0]] = F;
    y[m->output_of[1]] = -F * v;
    return BRIDGE_OK;
}

/* ---- the kind's functions ------------------------------------------------------------------------------------ */

static int step(void *sim, double *x, const double *u, double t, double h, NativeResult *r) {
    WecSim *s = sim;
    s->last_h = h;
    switch (s->m->component) {
    case WAVE: return wave_step(s, x, h);
    case FLOAT: return float_step(s, x, u, t, h, r);
    case HYDRO: return hydro_step(s, x, u, t, h, r);
    default: return BRIDGE_OK;
    }
}

/* Every output at once: they come from the same sums. */
static int outputs(void *sim, const double *x, const double *u, double *y, unsigned char *which, NativeResult *r) {
    (void)r;
    WecSim *s = sim;
    int status = BRIDGE_OK;
    switch (s->m->component) {
    case WAVE: status = wave_outputs(s, x, y); break;
    case FLOAT: status = float_outputs(s, x, u, y); break;
    case HYDRO: status = hydro_outputs(s, x, u, y); break;
    default: status = pto_outputs(s, u, y); break;
    }
    memset(which, 1, s->m->layout.n_outputs);
    return status;
}

/* The runtime parameter behind a role as the bridge's culprit index (n_inputs + its index), or -1 (fixed). */
static int role_culprit(const WecSim *s, int role) {
    int p = s->m->role_param[role];
    return p >= 0 ? (int)s->m->layout.n_inputs + p : -1;
}

/* Keep (j, score) when the score is larger (NaN and inf win). */
static void consider(int j, double score, int *best, double *best_score) {
    if (*best < 0 || !(score <= *best_score)) *best = j, *best_score = score;
}

/* The input behind a non-finite or diverged state (what 0: the largest contribution of one input to the state over
   the last step, if above `threshold`) or output (what 1: the largest contributor): for the float, each load through
   M_total^-1 (h acc and h^2/2 acc); for the hydro, each velocity through Gamma (state) or each position through C and
   velocity through C and the drag (outputs); for the PTO, pos_z through the stiffness and vel_z through the damping;
   the wave has no inputs: its wave_height. */
static int culprit(void *sim, int what, const double *x, const double *u, double threshold) {
    (void)x;
    WecSim *s = sim;
    const WecModel *m = s->m;
    int best = -1;
    double best_score = 0.0, h = s->last_h > 0.0 ? s->last_h : 1.0;
    switch (m->component) {
    case WAVE: return role_culprit(s, W_HEIGHT);
    case FLOAT:
        for (int k = 0; k < 24; k++) {
            int i = k % 6, j = m->input_of[k];
            double value = u[j], score = 0.0;
            if (value == 0.0) continue;
            for (int row = 0; row < 6; row++) {
                double gain = s->role[F_HEAVE_ONLY] != 0.0 ? (row == 2 && i == 2 ? 1.0 / m->M[2 * 6 + 2] : 0.0)
                                                           : m->M_inv[row * 6 + i];
                double c = fabs(gain * value) * (what == 0 ? fmax(h, 0.5 * h * h) : 1.0);
                if (!(c <= score)) score = c;
            }
            consider(j, score, &best, &best_score);
        }
        break;
    case HYDRO:
        for (int k = 0; k < 12; k++) {
            int j = m->input_of[k], i = k % 6;
            double value = u[j], score = 0.0;
            if (value == 0.0) continue;
            if (what == 0) {
                for (int row = 0; k >= 6 && s->maps_valid && row < (int)m->n_r; row++) {
                    double c = fabs(s->Gamma[row * 6 + i] * value);
                    if (!(c <= score)) score = c;
                }
            } else {
                for (int row = 0; row < 6; row++) {
                    double c = fabs(m->C[row * 6 + i] * value);
                    if (!(c <= score)) score = c;
                }
                if (k >= 6 && !(fabs(hydro_drag(s, i, value)) <= score)) score = fabs(hydro_drag(s, i, value));
            }
            consider(j, score, &best, &best_score);
        }
        break;
    default:
        consider(m->input_of[0], fabs(s->role[P_STIFFNESS] * u[m->input_of[0]]), &best, &best_score);
        consider(m->input_of[1], fabs(s->role[P_DAMPING] * u[m->input_of[1]]), &best, &best_score);
        if (best_score == 0.0) best = -1;
        break;
    }
    if (what == 0) return best >= 0 && !(best_score <= threshold) ? best : -1;
    return best;
}

const NativeKind native_wec_kind = {.name = "wec",
                                    .load = load,
                                    .free_model = free_model,
                                    .state_size = state_size,
                                    .init = init,
                                    .free_sim = free_sim,
                                    .step = step,
                                    .outputs = outputs,
                                    .culprit = culprit};
