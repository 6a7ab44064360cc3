/*
 * flexfmu_bridge.h - the interface between the FMU's front (flexfmu_fmi2.c: FMI 2.0 entry points, call-sequence
 * table, FMU-state header, finding libpython; no Python symbols) and the runtime under it (flexfmu_native.c:
 * variables, checks, time, FMU states, over a model kind, native_kind.h).  A native FMU links the runtime into the
 * front's library; a Python FMU's runtime, over the Python kind (native_python.c, compiled against Python.h), is a
 * second library the front loads once libpython's symbols are global.
 */
#ifndef FLEXFMU_BRIDGE_H
#define FLEXFMU_BRIDGE_H

#include <stddef.h>
#include <stdint.h>

#define FLEXFMU_BRIDGE_VERSION 3

/* Statuses as fmi2Status (0 OK, 1 Warning, 2 Discard, 3 Error, 4 Fatal). */
enum { BRIDGE_OK = 0, BRIDGE_WARNING = 1, BRIDGE_DISCARD = 2, BRIDGE_ERROR = 3, BRIDGE_FATAL = 4 };

/* Where the bridge reports a message: status, category ("logStatusError", "logAll", ...), text. */
typedef void BridgeLog(void *context, int status, const char *category, const char *message);

/* What the front read from resources/flexfmu_runtime.txt and the environment. */
typedef struct {
    const char *python_home;    /* the embedded interpreter's home (its standard library) */
    const char *site_dirs;      /* ':'-separated folders added with site.addsitedir */
    const char *python_version; /* "3.11": the version the bridge was compiled for */
} BridgeSettings;

typedef enum {
    CALL_ENTER_INITIALIZATION_MODE,
    CALL_EXIT_INITIALIZATION_MODE,
    CALL_TERMINATE,
    CALL_RESET
} BridgeSimpleCall;

typedef enum { VALUE_REAL, VALUE_INTEGER, VALUE_BOOLEAN, VALUE_STRING } BridgeValueType;

/* FMI 3.0 array variables (version 3): further views of the runtime's own Real values, declared by the model
   file's fmi3.* entries (flexfmu.fmi.fmi3_arrays); only the FMI 3.0 front asks for them (FMI 2.0 has no arrays). */
typedef struct {
    unsigned int vr; /* its FMI 3.0 value reference: a block of its own, above every runtime reference */
    const char *name;
    size_t size;            /* its elements (one dimension) */
    const int32_t *element; /* per element: the runtime value reference it views (a Real variable, continuous state
                               or state derivative: get_values / set_values), or -1: the constant value[k] */
    const double *value;
    int input; /* nonzero: an input (setting the array sets its elements); else read only */
} BridgeArray;

/* A structural parameter (FMI 3.0 UInt64, causality structuralParameter, fixed at build): an array's size. */
typedef struct {
    unsigned int vr;
    const char *name;
    uint64_t value;
    const char *fixed; /* why it is fixed and how to get another value: the end of a refusal */
} BridgeSize;

typedef struct {
    size_t n_arrays, n_sizes;
    const BridgeArray *arrays;
    const BridgeSize *sizes;
    unsigned int lowest; /* the smallest value reference of an array or a structural parameter (none: UINT32_MAX) */
} BridgeArrays;

typedef struct {
    int version;
    /* Initialise Python in this process if nobody has (C hosts), else check its version.  Returns 0
       on success; else writes why into `error`. */
    int (*start)(const BridgeSettings *settings, char *error, size_t error_size);
    /* A new slave; NULL after logging why.  `log`/`context` are kept for the instance's lifetime. */
    void *(*instantiate)(const char *resources_dir, const char *instance_name, const char *guid, int visible,
                         BridgeLog *log, void *context);
    void (*free_instance)(void *slave);
    int (*setup_experiment)(void *slave, int tolerance_defined, double tolerance, double start_time,
                            int stop_time_defined, double stop_time);
    int (*simple_call)(void *slave, BridgeSimpleCall call);
    int (*do_step)(void *slave, double current_time, double step_size);
    /* get: `values` is double*, int* (fmi2Integer/fmi2Boolean) or const char ** (valid until the next call) */
    int (*get_values)(void *slave, BridgeValueType type, const unsigned int *vr, size_t nvr, void *values);
    int (*set_values)(void *slave, BridgeValueType type, const unsigned int *vr, size_t nvr, const void *values);
    /* FMU states are opaque, owned by the caller until free_state. */
    int (*get_state)(void *slave, void **state);
    int (*set_state)(void *slave, void *state);
    void (*free_state)(void *state);
    /* serialize: with bytes == NULL, writes the size only */
    int (*serialize_state)(void *slave, void *state, char *bytes, size_t *size);
    int (*deserialize_state)(void *slave, const char *bytes, size_t size, void **state);
    /* the time of the last successful step (fmi2LastSuccessfulTime) */
    int (*last_successful_time)(void *slave, double *time);
    /* Model exchange and directional derivatives (version 2).  `function` is the FMI function the front runs, named
       in a refusal.  The continuous states have the value references n_vars .. n_vars + nx - 1 and their
       derivatives the next nx (n_vars: the model file's variables), readable with get_values (Real). */
    size_t (*n_states)(void *slave); /* 0: the model is co-simulation only */
    /* the host integrates this instance (model exchange): refused when the model is co-simulation only */
    int (*model_exchange)(void *slave, const char *function);
    int (*set_time)(void *slave, const char *function, double time);
    /* set 0: x = the continuous states; set 1: the continuous states = x (nx of them) */
    int (*continuous_states)(void *slave, const char *function, int set, double *x, size_t nx);
    int (*derivatives)(void *slave, const char *function, double *dx, size_t nx);
    /* sensitivity[i] = sum_j d unknown[i] / d known[j] seed[j]: unknowns outputs, state derivatives or (version 3:
       the FMI 3.0 arrays of the states) states, knowns inputs or states, at the current state and the inputs as last
       set */
    int (*directional)(void *slave, const char *function, const unsigned int *unknown, size_t n_unknown,
                       const unsigned int *known, size_t n_known, const double *seed, double *sensitivity);
    /* the continuous states' nominal values (their typical sizes: a host scales its absolute tolerance by them) */
    int (*nominals)(void *slave, double *x, size_t nx);
    /* FMI 3.0 array variables and structural parameters (version 3): the model file's, valid as long as the slave */
    const BridgeArrays *(*arrays)(void *slave);
} BridgeApi;

/* The bridge library's one exported symbol. */
typedef const BridgeApi *BridgeEntry(void);
#define FLEXFMU_BRIDGE_ENTRY "flexfmu_bridge_api"

#endif
