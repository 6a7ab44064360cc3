/*
 * step_policy.c - the internal-step count and the refusal beyond max_internal_steps (step_policy.h).
 *
 * Numbers are written as Python's format() writes them (flexfmu.native.step_policy holds the Python reference and
 * the tests compare the two): %g-style conversions for finite values, "nan", "inf", "-inf" otherwise (printf may
 * write "-nan").
 */
#include <math.h>
#include <stdio.h>

#include "step_policy.h"

double ffx_min_communication_step(void) { return FFX_MIN_COMMUNICATION_STEP; }

double ffx_round_down(double x) {
    if (!(isfinite(x) && x > 0)) return x;
    double scale = pow(10.0, floor(log10(x)) - 3);
    return floor(x / scale * (1 - 1e-12)) * scale;
}

long ffx_step_count(double ratio, double count_scale, long cap) {
    if (!(ratio <= (double)cap)) return 0;
    double n = ceil(ratio * count_scale);
    return n > 1.0 ? (long)n : 1;
}

long ffx_split_step(double h, double step, long cap) { return ffx_step_count(h / step * FFX_STEP_GUARD, 1.0, cap); }

/* x by `format` (one double conversion), non-finite values as Python writes them */
static const char *number(char *buf, size_t size, const char *format, double x) {
    if (isnan(x))
        snprintf(buf, size, "nan");
    else if (isinf(x))
        snprintf(buf, size, x > 0 ? "inf" : "-inf");
    else
        snprintf(buf, size, format, x);
    return buf;
}

int ffx_step_refuse(double h, double needed, long cap, double h_ok, double rk4_limit, const ffx_step_cause *cause,
                    ffx_step_refusal *refusal) {
    char count[64], step[64], ok[64], limit[64];
    int rk4 = rk4_limit > 0;
    if (isfinite(needed) && needed < 1e15) /* the exact count while a double holds it to the unit */
        snprintf(count, sizeof count, "%.0f", ceil(needed));
    else
        number(count, sizeof count, "%.3g", needed);
    number(step, sizeof step, "%g", h);
    if (h_ok >= FFX_MIN_COMMUNICATION_STEP) {
        refusal->status = FFX_STEP_DISCARD;
        refusal->parameter = "max_internal_steps";
        refusal->allowed = NULL;
        number(ok, sizeof ok, "%.4g", ffx_round_down(h_ok));
        if (rk4)
            snprintf(refusal->detail, sizeof refusal->detail,
                     "integrator rk4 needs %s internal steps for this communication step of %s s (cap %ld; stable "
                     "step limit %s s); take a communication step <= %s s or raise max_internal_steps",
                     count, step, cap, number(limit, sizeof limit, "%.4g", rk4_limit), ok);
        else
            snprintf(refusal->detail, sizeof refusal->detail,
                     "needs %s internal steps for this communication step of %s s (cap %ld); take a smaller "
                     "communication step (<= %s s) or raise max_internal_steps",
                     count, step, cap, ok);
        snprintf(refusal->message, sizeof refusal->message, "%s: %s", refusal->parameter, refusal->detail);
        return refusal->status;
    }
    char reason[256];
    if (rk4)
        snprintf(reason, sizeof reason,
                 "integrator rk4: the stable step limit %s s (2.8 / omega_max) needs more than max_internal_steps = "
                 "%ld sub-steps even for a %g s communication step",
                 number(limit, sizeof limit, "%.3g", rk4_limit), cap, FFX_MIN_COMMUNICATION_STEP);
    else
        snprintf(reason, sizeof reason,
                 "even a %g s communication step needs more than max_internal_steps = %ld internal steps",
                 FFX_MIN_COMMUNICATION_STEP, cap);
    refusal->status = FFX_STEP_ERROR;
    refusal->parameter = cause ? cause->parameter : NULL;
    refusal->allowed = cause && cause->allowed && cause->allowed[0] ? cause->allowed : NULL;
    snprintf(refusal->detail, sizeof refusal->detail, "%s%s%s", cause && cause->before ? cause->before : "", reason,
             cause && cause->after ? cause->after : "");
    if (refusal->allowed)
        snprintf(refusal->message, sizeof refusal->message, "%s: %s (allowed: %s)",
                 refusal->parameter ? refusal->parameter : "", refusal->detail, refusal->allowed);
    else
        snprintf(refusal->message, sizeof refusal->message, "%s: %s", refusal->parameter ? refusal->parameter : "",
                 refusal->detail);
    return refusal->status;
}

int ffx_split_refuse(double h, double step, long cap, const ffx_step_cause *cause, ffx_step_refusal *refusal) {
    return ffx_step_refuse(h, h / step * FFX_STEP_GUARD, cap, (double)cap * step, 0.0, cause, refusal);
}
