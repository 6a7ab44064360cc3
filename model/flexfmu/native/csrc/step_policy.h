/*
 * step_policy.h - the one rule by which every flexfmu simulator splits a communication step h into n equal internal
 * steps, and refuses a step that would need more than the cap max_internal_steps.  The Python simulators call it
 * through ctypes (flexfmu.native.step_policy, which also holds the pure-Python reference used when no C compiler is
 * available) and the native FMU kinds link it (flexfmu/fmi/csrc/native_lti.c, native_reframe.c).
 *
 * The rule:
 *   - n = max(1, ceil(ratio)), ratio the internal steps h needs: h / step counted with FFX_STEP_GUARD for a longest
 *     internal step `step` (ffx_split_step), or a count the kind computes itself (ffx_step_count: the RK4 sub-steps
 *     of FFRBeam, the rotation per internal step of the exponential scheme).
 *   - !(ratio <= cap) (NaN too) is refused before anything is stepped: fmi2Discard (StepRejected, "take a smaller
 *     communication step (<= h_ok s)", h_ok rounded down to 4 digits) when the longest communication step within
 *     the cap, h_ok, is at least FFX_MIN_COMMUNICATION_STEP; else fmi2Error (ParameterError) naming the cause: the
 *     input or parameter that makes even such a step need more (ffx_step_cause).
 * What stays with each kind: its per-step limit (a user internal_step, 90 % of an RK4 stability limit, the rotation
 * per step from |omega| and |alpha|), its h_ok, and which culprit its error names.
 *
 * C99, libc/libm only, nothing allocates; the texts are written to the caller's ffx_step_refusal.
 */
#ifndef FLEXFMU_STEP_POLICY_H
#define FLEXFMU_STEP_POLICY_H

#include <stddef.h>

/* The smallest communication step a co-simulation master is expected to take (s): a step needing more than the cap
   is a Discard while one of at least this size would fit (flexfmu.core.checks.MIN_COMMUNICATION_STEP; the tests
   compare them through ffx_min_communication_step). */
#define FFX_MIN_COMMUNICATION_STEP 1e-5
/* h / step is counted as h / step (1 - 1e-12): a step a rounding error longer than k internal steps is k of them */
#define FFX_STEP_GUARD (1 - 1e-12)
/* a refusal's status: fmi2Discard (a smaller communication step will do) or fmi2Error */
#define FFX_STEP_DISCARD 2
#define FFX_STEP_ERROR 3
#define FFX_STEP_TEXT_SIZE 1024
#define FFX_STEP_MESSAGE_SIZE 2048 /* the detail with the names around it */

/* What an error names when not even a FFX_MIN_COMMUNICATION_STEP step fits the cap: "parameter: before<reason>after
   (allowed: allowed)", reason = "even a 1e-05 s communication step needs more than max_internal_steps = <cap>
   internal steps" (the RK4 wording: see ffx_step_refuse).  before, after, allowed may be NULL. */
typedef struct {
    const char *parameter;
    const char *before, *after;
    const char *allowed;
} ffx_step_cause;

/* A refused step, in the caller's memory (parameter and allowed of an error point into its cause's strings). */
typedef struct {
    int status;                          /* FFX_STEP_DISCARD or FFX_STEP_ERROR */
    const char *parameter;               /* "max_internal_steps" (a discard) or the cause's (NULL: no cause given) */
    const char *allowed;                 /* the error's allowed values, or NULL */
    char detail[FFX_STEP_TEXT_SIZE];     /* what is said of the parameter (without a cause: the reason alone) */
    char message[FFX_STEP_MESSAGE_SIZE]; /* the whole message: "parameter: detail[ (allowed: allowed)]" */
} ffx_step_refusal;

/* n >= 1 internal steps for a communication step h with internal steps of at most `step` (s): ratio = h / step
   FFX_STEP_GUARD; 0: refused (ffx_split_refuse says why). */
long ffx_split_step(double h, double step, long cap);

/* n = max(1, ceil(ratio count_scale)) when ratio <= cap, else 0 (refused).  ratio: the internal steps a kind counted
   itself; count_scale in (0, 1]: 1, or FFX_STEP_GUARD for a ratio that is capped as it is and counted guarded. */
long ffx_step_count(double ratio, double count_scale, long cap);

/* The refusal of a step h that needs `needed` internal steps (> cap, or NaN), h_ok the longest communication step
   within the cap; returns refusal->status.  rk4_limit > 0: the steps are FFRBeam's RK4 sub-steps under that stable
   step limit (s), worded as such ("integrator rk4 needs ... (cap <cap>; stable step limit <limit> s); take a
   communication step <= <h_ok> s ..."; the error's reason "integrator rk4: the stable step limit <limit> s
   (2.8 / omega_max) needs more than max_internal_steps = <cap> sub-steps even for a 1e-05 s communication step");
   0: internal steps.  cause: what an error names, or NULL: the error's detail is then the reason alone. */
int ffx_step_refuse(double h, double needed, long cap, double h_ok, double rk4_limit, const ffx_step_cause *cause,
                    ffx_step_refusal *refusal);

/* The refusal of a step that ffx_split_step(h, step, cap) refused (needed = its ratio, h_ok = cap step). */
int ffx_split_refuse(double h, double step, long cap, const ffx_step_cause *cause, ffx_step_refusal *refusal);

/* x > 0 rounded down to 4 significant digits (a bound quoted in a message that still holds); x otherwise */
double ffx_round_down(double x);
double ffx_min_communication_step(void);

#endif
