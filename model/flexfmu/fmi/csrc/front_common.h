/*
 * front_common.h - what the FMI 2.0 front (flexfmu_fmi2.c) and the FMI 3.0 front (flexfmu_fmi3.c) share, written
 * once in front_common.c: the instance (its lock, the call running, the host's logger and debug-logging settings),
 * entering and leaving a call against a front's call-sequence table (and refusing a call that the host's logger
 * makes while the instance's own call is logging), one refusal message per refused call, the FMU-state box and its
 * serialised header (GUID, runtime, payload size, CRC-32), the resources folder, the set-up checks of the
 * experiment, and loading the bridge (flexfmu_bridge.h: the runtime under every front).
 *
 * A front keeps what its FMI version defines: its entry points, its states and call-sequence table, and how a
 * message reaches its host's logger (FrontVersion).  front_common.c is compiled inside flexfmu_fmi2.c, which
 * includes it: the Python FMUs' front stays one source file (flexfmu.fmi.runtime compiles it alone), and a native
 * FMU's library, which links both fronts, holds one copy of it.
 */
#ifndef FLEXFMU_FRONT_COMMON_H
#define FLEXFMU_FRONT_COMMON_H

#if defined(_WIN32) /* front_common.c takes pthread mutexes on SRW locks from native_platform.h */
#ifndef WIN32_LEAN_AND_MEAN
#define WIN32_LEAN_AND_MEAN
#endif
#include <windows.h>
typedef DWORD FrontThread;
typedef SRWLOCK FrontLock;
#else
#include <pthread.h>
typedef pthread_t FrontThread;
typedef pthread_mutex_t FrontLock;
#endif
#include <stddef.h>
#include <stdint.h>

#include "flexfmu_bridge.h"

typedef struct FrontInstance FrontInstance;

/* One row of a front's call-sequence table. */
typedef struct {
    const char *name;
    int states;              /* the front's states (bits) in which the call is legal */
    const char *unsupported; /* why the call is refused in every state (a capability not provided), or NULL */
} FrontCall;

/* What differs between the fronts of the FMI versions. */
typedef struct {
    uint32_t magic;  /* the instances of this front: a pointer that is not one (another front's too) is refused */
    int all_states;  /* every state of the front's state machine (bits) */
    int error_state; /* the state a call that moves the model enters when it returns Error */
    int every_error; /* nonzero: every call that returns Error enters error_state (FMI 3.0's Terminated) */
    int me_states;   /* the states only a model-exchange instance enters: its FMU states are not set in another */
    int cs_states;   /* the states only a co-simulation instance enters */
    const char *error_name;           /* the Error status's name, in messages */
    const char *serialized_size_name; /* the function that tells a serialised state's size, named in a refusal */
    const char *(*state_name)(int state);
    /* hand a message the host wants to its logger, in the form the FMI version's logger expects */
    void (*deliver)(const FrontInstance *inst, int status, const char *category, const char *message);
} FrontVersion;

/* A host's logger as the front stores it (each front calls it with its own FMI type). */
typedef void (*FrontLogger)(void);

/* An instance; a front that keeps more per instance embeds it as its first member. */
struct FrontInstance {
    uint32_t magic;
    int state;
    int model_exchange; /* instantiated for model exchange (the host integrates the continuous states) */
    const FrontVersion *version;
    void *slave; /* the bridge's */
    const BridgeApi *bridge;
    FrontLogger logger; /* the host's logger, or NULL */
    void *environment;  /* the logger's first argument (componentEnvironment, instanceEnvironment) */
    char *name, *guid;
    int logging_on;
    size_t n_categories;
    char **categories;
    FrontLock lock;             /* FMI allows any thread; one call at a time per instance */
    volatile int busy;          /* a call is running: set and cleared under the lock */
    volatile FrontThread owner; /* the thread running it */
    const char *running;        /* the function running (set under the lock) */
    const char *reentered;      /* a function the logger called during `running`: refused, reported on leaving */
};

char *front_copy_string(const char *text);

/* The bridge's log (BridgeLog): the message goes to the host if it wants it (errors always; the rest per its
   debug-logging settings). */
void front_emit(void *context, int status, const char *category, const char *message);

/* Log "function: why" as an Error; returns BRIDGE_ERROR. */
int front_fail(FrontInstance *inst, const char *function, const char *why);

/* Check the instance pointer (an instance of `version`), that the call is not made from this instance's logger
   during its own call, and the call sequence; lock the instance.  NULL when refused (the caller returns Error; the
   refusal is logged, except for a pointer that is not an instance, which has no logger). */
FrontInstance *front_enter(void *instance, const FrontVersion *version, const FrontCall *call);

/* Report a call the logger made during this one, apply the version's error transition, unlock; returns status. */
int front_leave(FrontInstance *inst, int status);

/* Unlock without reporting (the instance is freed next). */
void front_unlock(FrontInstance *inst);

/* A new instance of `size` bytes (>= sizeof(FrontInstance)) in `state`; NULL when out of memory. */
FrontInstance *front_new_instance(const FrontVersion *version, size_t size, int state, const char *name,
                                  const char *guid, int logging_on, FrontLogger logger, void *environment);
void front_free_instance_memory(FrontInstance *inst);

/* Load the bridge and make the instance's slave from the FMU's resources folder; -1 after logging why. */
int front_instantiate_slave(FrontInstance *inst, const char *function, const char *resources, int visible);

/* The FMU's resources folder (holding flexfmu_build.json): from a file URI ("file:///a%20b/resources",
   "file:/...", "file://localhost/...": FMI 2.0's fmuResourceLocation) or a folder path (FMI 3.0's resourcePath,
   a trailing separator allowed; a file URI is accepted too); when `location` is missing or does not hold this
   FMU's resources (hosts differ), the resources next to this library (<fmu>/binaries/<platform>/<id>.so).
   -1 when neither holds them. */
int front_resources_from_uri(const char *uri, char *path, size_t size);
int front_resources_from_path(const char *location, char *path, size_t size);

int front_set_debug_logging(FrontInstance *inst, const char *function, int logging_on, size_t n_categories,
                            const char *const categories[]);

/* The experiment's arguments checked (finite start time, stop time >= start time, tolerance > 0), then passed to
   the bridge. */
int front_setup_experiment(FrontInstance *inst, const char *function, int tolerance_defined, double tolerance,
                           double start_time, int stop_time_defined, double stop_time);

/* FMU states: the box (its label read first: another FMU, runtime or build is refused before anything else of it
   is read) around the bridge's snapshot, and the serialised header. */
int front_get_state(FrontInstance *inst, const char *function, void **state);
int front_set_state(FrontInstance *inst, const char *function, void *state);
int front_free_state(FrontInstance *inst, const char *function, void **state);
int front_serialized_state_size(FrontInstance *inst, const char *function, void *state, size_t *size);
int front_serialize_state(FrontInstance *inst, const char *function, void *state, char *bytes, size_t size);
int front_deserialize_state(FrontInstance *inst, const char *function, const char *bytes, size_t size, void **state);

#endif
