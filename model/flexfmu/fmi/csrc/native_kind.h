/*
 * native_kind.h - what a model kind plugs into the native runtime (flexfmu_native.c).
 *
 * The native bridge (flexfmu_native.c) owns everything an FMU does that does not depend on the model's
 * equations: the model file (resources/flexfmu_model.bin, format in flexfmu/fmi/native.py and docs/fmu.md),
 * the variables (value references, types, causality, start values), the checks of set values and of the
 * runtime parameters' ranges, the structural parameters fixed at build, time, the validity of the state and
 * the outputs, FMU states and their serialised layout, and the log.  A *kind* (the equations of one family
 * of models) is one table of function pointers, NativeKind below, registered in flexfmu_native.c's KINDS
 * array and named by the model file's "kind" entry:
 *
 *   load        parse the kind's entries of the model file ("<kind>.*") into a model object shared (read-only)
 *               by the instance's simulators
 *   state_size  the length of the state vector x (what an FMU state saves and restores)
 *   init        a simulator for the runtime parameters' values (already range-checked by the bridge; a String
 *               parameter's value in `texts`, the others' in `params`) and its initial state x; kind-specific
 *               checks of the parameters here
 *   step        advance x over h with the inputs u held; x is written only on success
 *   outputs     the outputs (model-file order) of x with u held that the host reads: `which` marks them (1) on entry,
 *               and on return marks every output the call wrote (a kind may write more than asked when they come
 *               together, e.g. all the cheap ones); the bridge keeps each until the state or inputs change, so an
 *               output is computed once per step and only if read.  The layout's `deferred` outputs (costly ones
 *               such as a search over the mesh) should be written only when asked for.
 *   report      (optional) status-OK notes at fmi2Terminate (e.g. how often the deferred outputs were computed)
 *   step_held   (optional) step, also given the inputs held before this step
 *   culprit     the input most likely behind a non-finite or diverged state or output (index), or a runtime
 *               parameter (n_inputs + its index: e.g. an initial condition), or -1 (the bridge then names "state")
 *   start       (optional) what the process needs once before any instance (the Python kind: the interpreter)
 *   save, restore, check_saved
 *               (optional) a state the kind keeps beside x, as bytes of its own format and size (the Python kind:
 *               the simulator's state): an FMU state holds them (and serialises them after the bridge's layout);
 *               check_saved refuses, before any instance sees them, bytes that are not such a state
 *   derivatives (optional) x' = f(x, u) with the inputs as set now: a kind that is an ODE in fixed coordinates
 *               offers model exchange (its continuous states: x; their derivatives: f)
 *   directional (optional) the exact derivatives of the outputs and of f along a direction (dx, du): FMI's
 *               directional derivatives (outputs and derivatives with respect to inputs and states)
 *
 * The LTI kind (clamped bodies: FFRBeam, exported clamped bodies) is native_lti.c; the reframe kind (free bodies:
 * ReframeBody, exported free bodies) native_reframe.c; both are listed in native_kinds.c, the kinds of a native
 * FMU's library.  The Python kind (every Python-runtime FMU: a simulator written in Python, called through the
 * embedded interpreter) is native_python.c, which lists itself as the one kind of the Python runtime's library.
 * A new kind: its file (native_<kind>.c) with one `const NativeKind native_<kind>_kind`, its line in
 * native_kinds.c, its writer in flexfmu/fmi/native.py.
 *
 * Thread-safety: a kind's functions are called for one instance at a time (the front locks the instance);
 * the model object is only read after load; simulators belong to one instance.  No globals (but the Python kind's
 * interpreter, which is the process's).
 */
#ifndef FLEXFMU_NATIVE_KIND_H
#define FLEXFMU_NATIVE_KIND_H

#include <stddef.h>
#include <stdint.h>

#include "flexfmu_bridge.h"

/* ---- the model file, parsed (flexfmu_native.c) ------------------------------------------------- */

enum { NATIVE_F64 = 1, NATIVE_I32 = 2, NATIVE_STR = 3 };
#define NATIVE_MAX_DIMS 8

typedef struct {
    char *name;
    int type; /* NATIVE_F64, NATIVE_I32, NATIVE_STR */
    int ndim; /* 0: a scalar */
    uint32_t shape[NATIVE_MAX_DIMS];
    size_t count; /* product of shape (1 for a scalar) */
    void *data;   /* double[count], int32_t[count] or char *[count] (NUL-terminated) */
} NativeEntry;

typedef struct NativeFile NativeFile;

/* The entry `name`, or NULL. */
const NativeEntry *native_entry(const NativeFile *file, const char *name);

/* Typed lookups: 0 and *data on success; else -1 and `why` names the entry and what was expected.  `ndim` is
   the expected number of dimensions; `shape` (may be NULL) the expected sizes, -1 = any.  `found` (may be NULL)
   receives the shape. */
int native_f64(const NativeFile *file, const char *name, int ndim, const long *shape, const double **data,
               uint32_t *found, char *why, size_t why_size);
int native_i32(const NativeFile *file, const char *name, int ndim, const long *shape, const int32_t **data,
               uint32_t *found, char *why, size_t why_size);

/* ---- what a kind sees of the FMU -------------------------------------------------------------- */

typedef struct {
    const char *resources;                /* the FMU's resources folder (where the model file is) */
    size_t n_inputs, n_outputs, n_params; /* params: the runtime parameters (settable until initialisation) */
    const char *const *input_names;
    const char *const *output_names;
    const char *const *param_names;
    /* per output: 1 if it is deferred (costly: computed only when that output is read, the model file's
       "outputs.deferred"; an FMU state holds it only if it was read), else 0; n_deferred of them */
    const unsigned char *deferred;
    size_t n_deferred;
} NativeLayout;

/* What a refused kind call reports (status >= BRIDGE_DISCARD with one message naming the variable), and the
   status-OK messages it wants logged (note). */
typedef struct {
    int status;
    char message[2048];
    void (*note)(void *context, const char *text);
    void *note_context;
} NativeResult;

/* step: x not finite after the step (x not written); outputs: an output not finite (y written).  The bridge
   then names the culprit (culprit below) in its message. */
#define NATIVE_NOT_FINITE 16

typedef struct {
    const char *name; /* the model file's "kind" */
    void *(*load)(const NativeFile *file, const NativeLayout *layout, char *why, size_t why_size);
    void (*free_model)(void *model);
    size_t (*state_size)(const void *model);
    /* texts: per runtime parameter, its value if it is a String, else NULL */
    void *(*init)(const void *model, const double *params, const char *const *texts, double *x, NativeResult *result);
    void (*free_sim)(void *sim);
    int (*step)(void *sim, double *x, const double *u, double t, double h, NativeResult *result);
    /* which (n_outputs): in, the outputs to compute; out, the outputs written into y (at least those asked) */
    int (*outputs)(void *sim, const double *x, const double *u, double *y, unsigned char *which, NativeResult *result);
    /* what: 0 the state after the last step (from x with u): the input whose contribution alone is above
       `threshold` (the largest), else -1; 1 the outputs of x with u: the input that alone overflows them, else
       the largest contributor, -1 when all inputs are 0 */
    int (*culprit)(void *sim, int what, const double *x, const double *u, double threshold);
    /* optional (NULL: step): step with, besides the inputs u held now, the inputs u_before held by the step before
       (or at initialisation, or in the restored FMU state): the reframe kind's choice of internal steps
       estimates the rotation from the state's rates with the inputs its step held */
    int (*step_held)(void *sim, double *x, const double *u_before, const double *u, double t, double h,
                     NativeResult *result);
    /* optional: status-OK notes (native_note) at fmi2Terminate */
    void (*report)(void *sim, NativeResult *result);
    /* optional: once per process before the first instance; 0, else -1 with why in `error` */
    int (*start)(const BridgeSettings *settings, char *error, size_t error_size);
    /* optional, all three or none: the kind's own state as bytes (malloc'd; the caller frees them), restored from
       such bytes (the simulator is left as it was on a refusal), and refused (with one message) when the bytes are
       not such a state */
    int (*save)(void *sim, unsigned char **bytes, size_t *size, NativeResult *result);
    int (*restore)(void *sim, const unsigned char *bytes, size_t size, NativeResult *result);
    int (*check_saved)(const void *model, const unsigned char *bytes, size_t size, NativeResult *result);
    /* optional (model exchange; NULL: co-simulation only): the state's time derivative dx (nx) = f(x, u) with the
       inputs u as they are now (the kind is an ODE in fixed coordinates: x' = f(x, u)) */
    int (*derivatives)(void *sim, const double *x, const double *u, double *dx, NativeResult *result);
    /* optional (directional derivatives; NULL: none): the exact derivatives of the outputs and of f along the
       direction (dx, du) at (x, u): dy (n_outputs, the outputs' order) and ddx (nx) */
    int (*directional)(void *sim, const double *x, const double *u, const double *dx, const double *du, double *dy,
                       double *ddx, NativeResult *result);
} NativeKind;

/* The kinds of this library (native_kinds.c: a native FMU's; native_python.c: the Python runtime's). */
extern const NativeKind *const native_kinds[];
extern const size_t native_kind_count;

/* Helpers the bridge offers the kinds: Python's repr of a float ("0.001", "1e-05", "nan", "100.0"), and a
   status with its message (printf format). */
void native_repr(double value, char *text, size_t size);
int native_refuse(NativeResult *result, int status, const char *format, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;
void native_note(NativeResult *result, const char *format, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;

#endif
