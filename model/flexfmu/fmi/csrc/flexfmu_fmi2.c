/*
 * flexfmu_fmi2.c - the FMI 2.0 co-simulation front of the flexfmu FMUs (binaries/linux64/<id>.so).
 *
 * It links no Python: any FMI host can load it (dlopen with RTLD_NOW, RTLD_LOCAL) on the machine the
 * FMU was built on with no set-up.  On the first fmi2Instantiate it
 *  1. reads resources/flexfmu_runtime.txt (written at build time: libpython, the interpreter's home,
 *     the build environment's site-packages), each overridable by an environment variable
 *     (FLEXFMU_LIBPYTHON, FLEXFMU_PYTHONHOME, FLEXFMU_SITE_PACKAGES) for another machine;
 *  2. loads libpython with RTLD_GLOBAL unless the process already has Python's symbols (a Python host);
 *  3. loads the bridge <id>_python.so next to this file (the runtime, flexfmu_native.c, over the Python kind,
 *     native_python.c) and starts Python.
 * It owns the FMI semantics: the call-sequence table below (one row per function: the states in
 * which it is legal), argument checks, state transitions, the FMU-state wrapper and its serialised
 * header, and the host's logging settings.  The bridge only runs the slave's Python.
 * Nothing is ever dlclose()d or finalised (see native_python.c): the host may unload this library.
 *
 * Native FMUs (flexfmu.fmi.native; docs/fmu.md, "Native runtime") compile this same file with -DFLEXFMU_NATIVE
 * (or through native_front.c) and link it statically with the native bridge (flexfmu_native.c) and a model
 * kind: load_bridge then returns the built-in API, and nothing about libpython is read or loaded.  That
 * variant builds on Linux, macOS (dladdr, pthreads) and Windows (native_platform.h: SRW locks and
 * GetModuleFileName instead); the Python variant is Linux-only and unchanged.
 */
#if defined(_WIN32)
#include "native_platform.h" /* pthread mutexes on SRW locks, dladdr on GetModuleHandleEx */
#else
#define _GNU_SOURCE /* dladdr, RTLD_DEFAULT */
#include <dlfcn.h>
#include <pthread.h>
#endif
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"
#include "flexfmu_bridge.h"

/* ---- states and the call-sequence table ------------------------------------------------------- */

typedef enum {
    Instantiated = 1 << 0,       /* after fmi2Instantiate, fmi2Reset */
    InitializationMode = 1 << 1, /* after fmi2EnterInitializationMode */
    StepComplete = 1 << 2,       /* after fmi2ExitInitializationMode, a successful fmi2DoStep */
    StepFailed = 1 << 3,         /* after fmi2DoStep returned fmi2Discard (the state is the step's start) */
    Terminated = 1 << 4,         /* after fmi2Terminate */
    Error = 1 << 5,              /* after fmi2Error from a call that moves the model: fmi2ExitInitializationMode,
                                    fmi2DoStep, fmi2Reset, fmi2SetFMUstate.  A refused get/set of values,
                                    set-up, logging or FMU-state call leaves the state as it was. */
} State;

#define ALL_STATES (Instantiated | InitializationMode | StepComplete | StepFailed | Terminated | Error)
#define VALUES_READABLE (InitializationMode | StepComplete | StepFailed | Terminated | Error)
#define VALUES_WRITABLE (Instantiated | InitializationMode | StepComplete)

typedef enum {
    F_SetDebugLogging,
    F_SetupExperiment,
    F_EnterInitializationMode,
    F_ExitInitializationMode,
    F_Terminate,
    F_Reset,
    F_FreeInstance,
    F_GetReal,
    F_GetInteger,
    F_GetBoolean,
    F_GetString,
    F_SetReal,
    F_SetInteger,
    F_SetBoolean,
    F_SetString,
    F_GetFMUstate,
    F_SetFMUstate,
    F_FreeFMUstate,
    F_SerializedFMUstateSize,
    F_SerializeFMUstate,
    F_DeSerializeFMUstate,
    F_GetDirectionalDerivative,
    F_SetRealInputDerivatives,
    F_GetRealOutputDerivatives,
    F_DoStep,
    F_CancelStep,
    F_GetStatus,
    F_GetRealStatus,
    F_GetIntegerStatus,
    F_GetBooleanStatus,
    F_GetStringStatus,
    F_COUNT
} Function;

/* The one legal-call table (docs/fmu.md prints it).  Unsupported capabilities have no legal state
   and their own message.  Parameters (variability fixed) are settable only before
   fmi2ExitInitializationMode: the runtime checks that per variable. */
static const struct {
    const char *name;
    int states;
    const char *unsupported; /* why the function is refused in every state, or NULL */
} CALLS[F_COUNT] = {
    [F_SetDebugLogging] = {"fmi2SetDebugLogging", ALL_STATES, NULL},
    [F_SetupExperiment] = {"fmi2SetupExperiment", Instantiated, NULL},
    [F_EnterInitializationMode] = {"fmi2EnterInitializationMode", Instantiated, NULL},
    [F_ExitInitializationMode] = {"fmi2ExitInitializationMode", InitializationMode, NULL},
    [F_Terminate] = {"fmi2Terminate", StepComplete | StepFailed | Error, NULL},
    [F_Reset] = {"fmi2Reset", ALL_STATES, NULL},
    [F_FreeInstance] = {"fmi2FreeInstance", ALL_STATES, NULL},
    [F_GetReal] = {"fmi2GetReal", VALUES_READABLE, NULL},
    [F_GetInteger] = {"fmi2GetInteger", VALUES_READABLE, NULL},
    [F_GetBoolean] = {"fmi2GetBoolean", VALUES_READABLE, NULL},
    [F_GetString] = {"fmi2GetString", VALUES_READABLE, NULL},
    [F_SetReal] = {"fmi2SetReal", VALUES_WRITABLE, NULL},
    [F_SetInteger] = {"fmi2SetInteger", VALUES_WRITABLE, NULL},
    [F_SetBoolean] = {"fmi2SetBoolean", VALUES_WRITABLE, NULL},
    [F_SetString] = {"fmi2SetString", VALUES_WRITABLE, NULL},
    [F_GetFMUstate] = {"fmi2GetFMUstate", ALL_STATES & ~Error, NULL},
    [F_SetFMUstate] = {"fmi2SetFMUstate", ALL_STATES, NULL},
    [F_FreeFMUstate] = {"fmi2FreeFMUstate", ALL_STATES, NULL},
    [F_SerializedFMUstateSize] = {"fmi2SerializedFMUstateSize", ALL_STATES, NULL},
    [F_SerializeFMUstate] = {"fmi2SerializeFMUstate", ALL_STATES, NULL},
    [F_DeSerializeFMUstate] = {"fmi2DeSerializeFMUstate", ALL_STATES, NULL},
    [F_GetDirectionalDerivative]
    = {"fmi2GetDirectionalDerivative", 0, "not supported (providesDirectionalDerivative is false)"},
    [F_SetRealInputDerivatives] = {"fmi2SetRealInputDerivatives", 0, "not supported (canInterpolateInputs is false)"},
    [F_GetRealOutputDerivatives] = {"fmi2GetRealOutputDerivatives", 0, "not supported (maxOutputDerivativeOrder is 0)"},
    [F_DoStep] = {"fmi2DoStep", StepComplete, NULL},
    [F_CancelStep] = {"fmi2CancelStep", 0, "not supported: fmi2DoStep never returns fmi2Pending"},
    [F_GetStatus] = {"fmi2GetStatus", StepComplete | StepFailed | Terminated, NULL},
    [F_GetRealStatus] = {"fmi2GetRealStatus", StepComplete | StepFailed | Terminated, NULL},
    [F_GetIntegerStatus] = {"fmi2GetIntegerStatus", StepComplete | StepFailed | Terminated, NULL},
    [F_GetBooleanStatus] = {"fmi2GetBooleanStatus", StepComplete | StepFailed | Terminated, NULL},
    [F_GetStringStatus] = {"fmi2GetStringStatus", StepComplete | StepFailed | Terminated, NULL},
};

static const char *state_name(int state) {
    switch (state) {
    case Instantiated: return "Instantiated";
    case InitializationMode: return "InitializationMode";
    case StepComplete: return "StepComplete";
    case StepFailed: return "StepFailed";
    case Terminated: return "Terminated";
    case Error: return "Error";
    default: return "?";
    }
}

/* ---- the instance ------------------------------------------------------------------------------ */

#define INSTANCE_MAGIC 0x464c5846u /* "FXLF": a pointer that is not one of our instances is refused */
#define STATE_MAGIC 0x53584c46u    /* "FLXS" */
/* the StateBox layout below, second word of a box: a box of another flexfmu build (whose second word is an FMI
   state, 1 .. 32, in the first layout) is recognised by it before anything beyond it is read */
#define STATE_BOX_LAYOUT 0x4c580002u

/* Which runtime an FMU state belongs to: the Python bridge's states are Python objects, the native bridge's C
   snapshots; a state of one must never reach the other. */
#if defined(FLEXFMU_NATIVE)
#define RUNTIME_ID 2u
#define RUNTIME_NAME "native"
#else
#define RUNTIME_ID 1u
#define RUNTIME_NAME "Python"
#endif

#if defined(_WIN32)
typedef DWORD ThreadId;
static ThreadId this_thread(void) { return GetCurrentThreadId(); }
static int same_thread(ThreadId a, ThreadId b) { return a == b; }
#else
typedef pthread_t ThreadId;
static ThreadId this_thread(void) { return pthread_self(); }
static int same_thread(ThreadId a, ThreadId b) { return pthread_equal(a, b); }
#endif

typedef struct {
    uint32_t magic;
    int state;
    void *slave; /* the bridge's */
    const BridgeApi *bridge;
    fmi2CallbackFunctions host;
    char *name, *guid;
    fmi2Boolean logging_on;
    size_t n_categories;
    char **categories;
    pthread_mutex_t lock;    /* FMI allows any thread; one call at a time per instance */
    volatile int busy;       /* a call is running: set and cleared under the lock */
    volatile ThreadId owner; /* the thread running it */
    const char *running;     /* the function running (set under the lock) */
    const char *reentered;   /* a function the logger called during `running`: refused, reported on leaving */
} Instance;

/* The header (magic, layout, runtime, GUID) comes first and is read before anything else: a state from another
   FMU, another runtime or another flexfmu build is refused before its contents are touched. */
typedef struct {
    uint32_t magic, layout, runtime;
    char guid[128]; /* the FMU's GUID (cut to 127 bytes; the full GUID is compared on deserialising) */
    int fmi_state;  /* the instance's FMI state when it was taken: fmi2SetFMUstate restores it too */
    void *python;   /* the runtime's snapshot (flexfmu_native.c) */
} StateBox;

static char *copy_string(const char *text) {
    size_t n = strlen(text ? text : "") + 1;
    char *copy = malloc(n);
    if (copy) memcpy(copy, text ? text : "", n);
    return copy;
}

/* Does the host want this message?  Errors always; the rest per its debug-logging settings. */
static int wanted(const Instance *inst, int status, const char *category) {
    if (!inst->host.logger) return 0;
    if (status >= fmi2Discard) return 1;
    if (!inst->logging_on) return 0;
    if (inst->n_categories == 0) return 1;
    for (size_t i = 0; i < inst->n_categories; i++)
        if (strcmp(category, inst->categories[i]) == 0 || strcmp(inst->categories[i], "logAll") == 0) return 1;
    return 0;
}

/* Hosts treat the message as a printf format (FMI 2.0 logger): '%' is doubled so that a message can
   never make a host read arguments that are not there. */
static void emit(void *context, int status, const char *category, const char *message) {
    Instance *inst = context;
    if (!wanted(inst, status, category)) return;
    size_t n = strlen(message), extra = 0;
    for (size_t i = 0; i < n; i++) extra += message[i] == '%';
    char *safe = malloc(n + extra + 1);
    if (!safe) return;
    char *out = safe;
    for (size_t i = 0; i < n; i++) {
        *out++ = message[i];
        if (message[i] == '%') *out++ = '%';
    }
    *out = '\0';
    inst->host.logger(inst->host.componentEnvironment, inst->name, (fmi2Status)status, category, safe);
    free(safe);
}

static fmi2Status fail(Instance *inst, const char *function, const char *why) {
    char message[4096];
    snprintf(message, sizeof message, "%s: %s", function, why);
    emit(inst, fmi2Error, "logStatusError", message);
    return fmi2Error;
}

/* A host's logger that calls back into an instance whose call is running (and logging) on the same thread would
   wait forever on the instance's lock: such a call is refused instead (fmi2Error), and reported once the running
   call leaves.  `owner` is read without the lock: another thread's id never equals ours, whatever it reads. */
static int called_back(const Instance *inst) { return inst->busy && same_thread(inst->owner, this_thread()); }

static void unlock(Instance *inst) {
    inst->busy = 0;
    inst->running = NULL;
    pthread_mutex_unlock(&inst->lock);
}

static fmi2Status leave(Instance *inst, int status);

/* Check the instance pointer and the call sequence; lock the instance. */
static Instance *enter(fmi2Component c, Function f, fmi2Status *refused) {
    Instance *inst = c;
    *refused = fmi2Error;
    if (!inst || inst->magic != INSTANCE_MAGIC) return NULL; /* no logger to tell */
    if (called_back(inst)) { /* from the logger of this instance's running call: no logging (it would recurse) */
        if (!inst->reentered) inst->reentered = CALLS[f].name; /* this thread holds the lock: safe */
        return NULL;
    }
    pthread_mutex_lock(&inst->lock);
    inst->owner = this_thread();
    inst->busy = 1;
    inst->running = CALLS[f].name;
    char why[256];
    if (CALLS[f].unsupported) {
        fail(inst, CALLS[f].name, CALLS[f].unsupported);
    } else if (!(CALLS[f].states & inst->state)) {
        snprintf(why, sizeof why, "illegal call sequence (state %s)", state_name(inst->state));
        fail(inst, CALLS[f].name, why);
    } else {
        return inst;
    }
    leave(inst, fmi2Error); /* a call its logger made while it was refused is reported too */
    return NULL;
}

static fmi2Status leave(Instance *inst, int status) {
    if (inst->reentered) { /* once per call: a logger that calls again while told is refused again, silently */
        char message[512];
        snprintf(message, sizeof message,
                 "%s: called from the logger callback while %s was running on this instance; refused (fmi2Error): "
                 "call the FMU after the callback returns",
                 inst->reentered, inst->running ? inst->running : "a call");
        inst->reentered = NULL;
        emit(inst, fmi2Error, "logStatusError", message);
        inst->reentered = NULL;
    }
    unlock(inst);
    return (fmi2Status)status;
}

/* ---- loading Python and the bridge (once per loaded copy of this library) ---------------------- */

static pthread_mutex_t load_lock = PTHREAD_MUTEX_INITIALIZER;
static const BridgeApi *loaded_bridge = NULL;
static char load_error[3072];

/* This library's own file name, e.g. /tmp/x/binaries/linux64/FFRBeam.so */
static int own_path(char *path, size_t size) {
    Dl_info info;
    if (!dladdr((void *)&own_path, &info) || !info.dli_fname || strlen(info.dli_fname) + 1 > size) return -1;
    snprintf(path, size, "%s", info.dli_fname);
    return 0;
}

static int resources_uri_path(const char *uri, char *path, size_t size);

static int is_resources(const char *path) {
    char probe[4200];
    snprintf(probe, sizeof probe, "%s/flexfmu_build.json", path);
    FILE *file = fopen(probe, "r");
    if (file) fclose(file);
    return file != NULL;
}

/* fmuResourceLocation ("file:///a%20b/resources", "file:/...", "file://localhost/...") as a path; when it is
   missing or does not hold this FMU's resources (hosts differ), the resources next to this library. */
static int resources_path(const char *uri, char *path, size_t size) {
    if (uri && strncmp(uri, "file:", 5) == 0 && resources_uri_path(uri, path, size) == 0 && is_resources(path))
        return 0;
    char own[4096];
    if (own_path(own, sizeof own) < 0) return -1;
    for (int up = 0; up < 3; up++) { /* <fmu>/binaries/linux64/<id>.so -> <fmu> */
        char *slash = strrchr(own, '/');
        if (!slash) return -1;
        *slash = '\0';
    }
    snprintf(path, size, "%s/resources", own);
    return is_resources(path) ? 0 : -1;
}

/* "file:///a%20b/resources", "file:/...", "file://localhost/..." -> "/a b/resources" */
static int resources_uri_path(const char *uri, char *path, size_t size) {
    const char *p = uri + 5;
    if (strncmp(p, "///", 3) == 0)
        p += 2;
    else if (strncmp(p, "//localhost/", 12) == 0)
        p += 11;
    else if (strncmp(p, "//", 2) == 0)
        return -1; /* another host */
    size_t j = 0;
    for (; *p && j + 1 < size; p++) {
        unsigned int byte;
        if (p[0] == '%' && p[1] && p[2] && sscanf(p + 1, "%2x", &byte) == 1) {
            path[j++] = (char)byte;
            p += 2;
        } else {
            path[j++] = *p;
        }
    }
    path[j] = '\0';
    while (j > 1 && path[j - 1] == '/') path[--j] = '\0';
#if defined(_WIN32)
    if (path[0] == '/' && path[1] && path[2] == ':') memmove(path, path + 1, j); /* "/C:/a" -> "C:/a" */
#endif
    return 0;
}

#if defined(FLEXFMU_NATIVE)
/* The native bridge is linked in (flexfmu_native.c): no libpython, no second library. */
const BridgeApi *flexfmu_native_api(void);

static const BridgeApi *load_bridge(const char *resources) {
    (void)resources;
    pthread_mutex_lock(&load_lock);
    if (!loaded_bridge && !load_error[0]) {
        const BridgeApi *api = flexfmu_native_api();
        char why[2048] = "";
        if (!api || api->version != FLEXFMU_BRIDGE_VERSION)
            snprintf(load_error, sizeof load_error, "the FMU's native bridge has another version than its front");
        else if (api->start(NULL, why, sizeof why) != 0)
            snprintf(load_error, sizeof load_error, "%s", why);
        else
            loaded_bridge = api;
    }
    pthread_mutex_unlock(&load_lock);
    return loaded_bridge;
}
#else
typedef struct {
    char libpython[4096], python_home[4096], python_version[32], site_dirs[16384];
} RuntimeSettings;

static void read_settings(const char *resources, RuntimeSettings *rs) {
    memset(rs, 0, sizeof *rs);
    char path[4200], line[8192];
    snprintf(path, sizeof path, "%s/flexfmu_runtime.txt", resources);
    FILE *file = fopen(path, "r");
    while (file && fgets(line, sizeof line, file)) {
        line[strcspn(line, "\r\n")] = '\0';
        char *eq = strchr(line, '=');
        if (line[0] == '#' || !eq) continue;
        *eq = '\0';
        const char *key = line, *value = eq + 1;
        if (strcmp(key, "libpython") == 0)
            snprintf(rs->libpython, sizeof rs->libpython, "%s", value);
        else if (strcmp(key, "python_home") == 0)
            snprintf(rs->python_home, sizeof rs->python_home, "%s", value);
        else if (strcmp(key, "python_version") == 0)
            snprintf(rs->python_version, sizeof rs->python_version, "%s", value);
        else if (strcmp(key, "site") == 0) {
            size_t used = strlen(rs->site_dirs);
            snprintf(rs->site_dirs + used, sizeof rs->site_dirs - used, "%s%s", used ? ":" : "", value);
        }
    }
    if (file) fclose(file);
    const char *env;
    if ((env = getenv("FLEXFMU_LIBPYTHON")) && *env) snprintf(rs->libpython, sizeof rs->libpython, "%s", env);
    if ((env = getenv("FLEXFMU_PYTHONHOME")) && *env) snprintf(rs->python_home, sizeof rs->python_home, "%s", env);
    if ((env = getenv("FLEXFMU_SITE_PACKAGES"))) snprintf(rs->site_dirs, sizeof rs->site_dirs, "%s", env);
}

static const BridgeApi *load_bridge(const char *resources) {
    pthread_mutex_lock(&load_lock);
    if (loaded_bridge || load_error[0]) goto done;
    RuntimeSettings rs;
    read_settings(resources, &rs);
    if (!dlsym(RTLD_DEFAULT, "Py_IsInitialized")) { /* not a Python host: bring libpython in, globally */
        if (!rs.libpython[0]) {
            snprintf(load_error, sizeof load_error,
                     "no libpython recorded in %s/flexfmu_runtime.txt; set FLEXFMU_LIBPYTHON to a "
                     "libpython%s.so",
                     resources, rs.python_version);
            goto done;
        }
        if (!dlopen(rs.libpython, RTLD_NOW | RTLD_GLOBAL)) {
            snprintf(load_error, sizeof load_error,
                     "cannot load libpython (%s); set FLEXFMU_LIBPYTHON to the libpython%s.so of a Python %s "
                     "that has the packages in resources/requirements.txt (docs/fmu.md, 'Another machine')",
                     dlerror(), rs.python_version, rs.python_version);
            goto done;
        }
    }
    char own[4096], bridge_path[4200];
    if (own_path(own, sizeof own) < 0 || strlen(own) < 4) {
        snprintf(load_error, sizeof load_error, "the FMU cannot locate its own binary");
        goto done;
    }
    snprintf(bridge_path, sizeof bridge_path, "%.*s_python.so", (int)(strlen(own) - 3), own);
    void *lib = dlopen(bridge_path, RTLD_NOW | RTLD_LOCAL);
    BridgeEntry *entry = lib ? (BridgeEntry *)dlsym(lib, FLEXFMU_BRIDGE_ENTRY) : NULL;
    if (!entry) {
        snprintf(load_error, sizeof load_error, "cannot load the FMU's Python bridge: %s", dlerror());
        goto done;
    }
    const BridgeApi *api = entry();
    if (!api || api->version != FLEXFMU_BRIDGE_VERSION) {
        snprintf(load_error, sizeof load_error, "the FMU's Python bridge has another version than its front");
        goto done;
    }
    BridgeSettings settings = {rs.python_home, rs.site_dirs, rs.python_version};
    char why[2048] = "";
    if (api->start(&settings, why, sizeof why) != 0) {
        snprintf(load_error, sizeof load_error, "%s", why);
        goto done;
    }
    loaded_bridge = api;
done:
    pthread_mutex_unlock(&load_lock);
    return loaded_bridge;
}
#endif /* FLEXFMU_NATIVE */

/* ---- FMI 2.0: common functions ----------------------------------------------------------------- */

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }

const char *fmi2GetVersion(void) { return fmi2Version; }

static void free_categories(Instance *inst) {
    for (size_t i = 0; i < inst->n_categories; i++) free(inst->categories[i]);
    free(inst->categories);
    inst->categories = NULL;
    inst->n_categories = 0;
}

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[]) {
    fmi2Status refused;
    Instance *inst = enter(c, F_SetDebugLogging, &refused);
    if (!inst) return refused;
    if (nCategories > 0 && !categories) return leave(inst, fail(inst, "fmi2SetDebugLogging", "categories is NULL"));
    free_categories(inst);
    inst->logging_on = loggingOn;
    if (nCategories > 0) {
        inst->categories = calloc(nCategories, sizeof *inst->categories);
        for (size_t i = 0; inst->categories && i < nCategories; i++) {
            inst->categories[i] = copy_string(categories[i]);
            inst->n_categories = i + 1;
        }
    }
    return leave(inst, fmi2OK);
}

static void free_instance_memory(Instance *inst) {
    free_categories(inst);
    free(inst->name);
    free(inst->guid);
    inst->magic = 0;
    pthread_mutex_destroy(&inst->lock);
    free(inst);
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation, const fmi2CallbackFunctions *functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn) {
    if (!functions) return NULL;
    Instance *inst = calloc(1, sizeof *inst);
    if (!inst) return NULL;
    inst->magic = INSTANCE_MAGIC;
    inst->host = *functions;
    inst->name = copy_string(instanceName);
    inst->guid = copy_string(fmuGUID);
    inst->logging_on = loggingOn;
    inst->state = Instantiated;
    pthread_mutex_init(&inst->lock, NULL);
    if (!inst->name || !inst->guid) {
        free_instance_memory(inst);
        return NULL;
    }
    if (fmuType != fmi2CoSimulation) {
        fail(inst, "fmi2Instantiate", "fmuType: this FMU supports co-simulation only (fmi2CoSimulation)");
        free_instance_memory(inst);
        return NULL;
    }
    char resources[4096];
    if (resources_path(fmuResourceLocation, resources, sizeof resources) < 0) {
        fail(inst, "fmi2Instantiate",
             "fmuResourceLocation: neither it (a file:/// URI) nor the folder next to "
             "this binary holds the FMU's resources (resources/flexfmu_build.json)");
        free_instance_memory(inst);
        return NULL;
    }
    inst->bridge = load_bridge(resources);
    if (!inst->bridge) {
        fail(inst, "fmi2Instantiate", load_error);
        free_instance_memory(inst);
        return NULL;
    }
    inst->slave = inst->bridge->instantiate(resources, inst->name, inst->guid, visible, emit, inst);
    if (!inst->slave) { /* the bridge has logged why */
        free_instance_memory(inst);
        return NULL;
    }
    return inst;
}

void fmi2FreeInstance(fmi2Component c) {
    fmi2Status refused;
    Instance *inst = enter(c, F_FreeInstance, &refused);
    if (!inst) return;
    inst->bridge->free_instance(inst->slave);
    unlock(inst);
    free_instance_memory(inst);
}

/* ---- FMI 2.0: initialisation, termination, reset ----------------------------------------------- */

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance, fmi2Real startTime,
                               fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    fmi2Status refused;
    Instance *inst = enter(c, F_SetupExperiment, &refused);
    if (!inst) return refused;
    if (!isfinite(startTime))
        return leave(inst, fail(inst, "fmi2SetupExperiment", "startTime is not finite (allowed: a finite time in s)"));
    if (stopTimeDefined && !(isfinite(stopTime) && stopTime >= startTime))
        return leave(inst, fail(inst, "fmi2SetupExperiment", "stopTime must be finite and >= startTime"));
    if (toleranceDefined && !(isfinite(tolerance) && tolerance > 0))
        return leave(inst, fail(inst, "fmi2SetupExperiment", "tolerance must be finite and > 0"));
    return leave(inst, inst->bridge->setup_experiment(inst->slave, toleranceDefined, tolerance, startTime,
                                                      stopTimeDefined, stopTime));
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    fmi2Status refused;
    Instance *inst = enter(c, F_EnterInitializationMode, &refused);
    if (!inst) return refused;
    int status = inst->bridge->simple_call(inst->slave, CALL_ENTER_INITIALIZATION_MODE);
    if (status <= fmi2Warning) inst->state = InitializationMode;
    return leave(inst, status);
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    fmi2Status refused;
    Instance *inst = enter(c, F_ExitInitializationMode, &refused);
    if (!inst) return refused;
    int status = inst->bridge->simple_call(inst->slave, CALL_EXIT_INITIALIZATION_MODE);
    inst->state = status <= fmi2Warning ? StepComplete : Error;
    return leave(inst, status);
}

fmi2Status fmi2Terminate(fmi2Component c) {
    fmi2Status refused;
    Instance *inst = enter(c, F_Terminate, &refused);
    if (!inst) return refused;
    int status = inst->state == Error ? fmi2OK : inst->bridge->simple_call(inst->slave, CALL_TERMINATE);
    if (status <= fmi2Warning) inst->state = Terminated;
    return leave(inst, status);
}

fmi2Status fmi2Reset(fmi2Component c) {
    fmi2Status refused;
    Instance *inst = enter(c, F_Reset, &refused);
    if (!inst) return refused;
    int status = inst->bridge->simple_call(inst->slave, CALL_RESET);
    inst->state = status <= fmi2Warning ? Instantiated : Error;
    return leave(inst, status);
}

/* ---- FMI 2.0: getting and setting variable values ---------------------------------------------- */

static fmi2Status get_values(fmi2Component c, Function f, BridgeValueType type, const fmi2ValueReference vr[],
                             size_t nvr, void *value) {
    fmi2Status refused;
    Instance *inst = enter(c, f, &refused);
    if (!inst) return refused;
    if (nvr == 0) return leave(inst, fmi2OK);
    if (!vr || !value) return leave(inst, fail(inst, CALLS[f].name, "vr or value is NULL"));
    return leave(inst, inst->bridge->get_values(inst->slave, type, vr, nvr, value));
}

static fmi2Status set_values(fmi2Component c, Function f, BridgeValueType type, const fmi2ValueReference vr[],
                             size_t nvr, const void *value) {
    fmi2Status refused;
    Instance *inst = enter(c, f, &refused);
    if (!inst) return refused;
    if (nvr == 0) return leave(inst, fmi2OK);
    if (!vr || !value) return leave(inst, fail(inst, CALLS[f].name, "vr or value is NULL"));
    return leave(inst, inst->bridge->set_values(inst->slave, type, vr, nvr, value));
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[]) {
    return get_values(c, F_GetReal, VALUE_REAL, vr, nvr, value);
}
fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Integer value[]) {
    return get_values(c, F_GetInteger, VALUE_INTEGER, vr, nvr, value);
}
fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Boolean value[]) {
    return get_values(c, F_GetBoolean, VALUE_BOOLEAN, vr, nvr, value);
}
fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2String value[]) {
    return get_values(c, F_GetString, VALUE_STRING, vr, nvr, (void *)value);
}
fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[]) {
    return set_values(c, F_SetReal, VALUE_REAL, vr, nvr, value);
}
fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Integer value[]) {
    return set_values(c, F_SetInteger, VALUE_INTEGER, vr, nvr, value);
}
fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Boolean value[]) {
    return set_values(c, F_SetBoolean, VALUE_BOOLEAN, vr, nvr, value);
}
fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2String value[]) {
    return set_values(c, F_SetString, VALUE_STRING, vr, nvr, (const void *)value);
}

/* ---- FMI 2.0: FMU state ------------------------------------------------------------------------ */

/* Serialised (little-endian): "FLEXFMU-STATE\n" (14 bytes), u32 format (2), u32 runtime (1 Python, 2 native),
   u32 FMI state, u64 payload size, u32 CRC-32 of all the bytes after it, u32 GUID length, the GUID, then the
   bridge's payload.  The GUID ties a state to the FMU (and build) that wrote it, the runtime to its bridge, the size
   and the checksum refuse a truncated or damaged state before the bridge reads it. */
static const char STATE_HEADER[] = "FLEXFMU-STATE\n";
#define HEADER_SIZE (sizeof STATE_HEADER - 1)
#define STATE_FORMAT 2u
#define FIXED_HEADER (HEADER_SIZE + 28) /* format, runtime, FMI state, size (8), CRC, GUID length */
#define CRC_AT (HEADER_SIZE + 20)

/* CRC-32 (IEEE 802.3, as zlib's crc32) of n bytes, bit by bit: states are small and this runs per serialisation. */
static uint32_t crc32_of(const unsigned char *bytes, size_t n) {
    uint32_t crc = 0xffffffffu;
    for (size_t i = 0; i < n; i++) {
        crc ^= bytes[i];
        for (int k = 0; k < 8; k++) crc = (crc >> 1) ^ (0xedb88320u & (0u - (crc & 1u)));
    }
    return ~crc;
}

/* The box of a state this instance may use, or NULL (why says what it is): the header is read first. */
static StateBox *box_of_instance(const Instance *inst, fmi2FMUstate state, const char **why) {
    StateBox *box = (StateBox *)state;
    *why = "not an FMU state (or it was freed)";
    if (!box || box->magic != STATE_MAGIC) return NULL;
    *why = "a state of another flexfmu build (its layout differs)";
    if (box->layout != STATE_BOX_LAYOUT) return NULL;
    *why = box->runtime == 1u ? "a state of a Python-runtime FMU; this FMU runs the " RUNTIME_NAME " runtime"
                              : "a state of a native-runtime FMU; this FMU runs the " RUNTIME_NAME " runtime";
    if (box->runtime != RUNTIME_ID) return NULL;
    *why = "a state of another FMU (its GUID differs)";
    if (strncmp(box->guid, inst->guid, sizeof box->guid - 1) != 0) return NULL;
    return box;
}

static void label_box(const Instance *inst, StateBox *box) {
    box->magic = STATE_MAGIC;
    box->layout = STATE_BOX_LAYOUT;
    box->runtime = RUNTIME_ID;
    snprintf(box->guid, sizeof box->guid, "%s", inst->guid);
}

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    fmi2Status refused;
    Instance *inst = enter(c, F_GetFMUstate, &refused);
    if (!inst) return refused;
    if (!FMUstate) return leave(inst, fail(inst, "fmi2GetFMUstate", "FMUstate is NULL"));
    const char *why;
    StateBox *box = *FMUstate ? box_of_instance(inst, *FMUstate, &why) : NULL;
    if (*FMUstate && !box) return leave(inst, fail(inst, "fmi2GetFMUstate", "*FMUstate is not a state of this FMU"));
    void *python = NULL;
    int status = inst->bridge->get_state(inst->slave, &python);
    if (status > fmi2Warning) return leave(inst, status);
    if (box) { /* FMI 2.0: a given state is overwritten */
        inst->bridge->free_state(box->python);
    } else if (!(box = malloc(sizeof *box))) {
        inst->bridge->free_state(python);
        return leave(inst, fail(inst, "fmi2GetFMUstate", "out of memory"));
    }
    label_box(inst, box);
    box->fmi_state = inst->state;
    box->python = python;
    *FMUstate = box;
    return leave(inst, status);
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate) {
    fmi2Status refused;
    Instance *inst = enter(c, F_SetFMUstate, &refused);
    if (!inst) return refused;
    const char *why;
    StateBox *box = box_of_instance(inst, FMUstate, &why);
    if (!box) {
        char text[256];
        snprintf(text, sizeof text, "FMUstate is not a state of this FMU: %s", why);
        return leave(inst, fail(inst, "fmi2SetFMUstate", text));
    }
    int status = inst->bridge->set_state(inst->slave, box->python);
    if (status <= fmi2Warning)
        inst->state = box->fmi_state;
    else if (status >= fmi2Error)
        inst->state = Error;
    return leave(inst, status);
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    fmi2Status refused;
    Instance *inst = enter(c, F_FreeFMUstate, &refused);
    if (!inst) return refused;
    if (!FMUstate || !*FMUstate) return leave(inst, fmi2OK);
    const char *why;
    StateBox *box = box_of_instance(inst, *FMUstate, &why);
    if (!box) return leave(inst, fail(inst, "fmi2FreeFMUstate", "*FMUstate is not a state of this FMU"));
    inst->bridge->free_state(box->python);
    box->magic = 0;
    free(box);
    *FMUstate = NULL;
    return leave(inst, fmi2OK);
}

static void put_u32(char *at, uint32_t value) {
    for (int i = 0; i < 4; i++) at[i] = (char)((value >> (8 * i)) & 0xff);
}

static uint32_t get_u32(const char *at) {
    uint32_t value = 0;
    for (int i = 0; i < 4; i++) value |= (uint32_t)(unsigned char)at[i] << (8 * i);
    return value;
}

static void put_u64(char *at, uint64_t value) {
    put_u32(at, (uint32_t)value);
    put_u32(at + 4, (uint32_t)(value >> 32));
}

static uint64_t get_u64(const char *at) { return (uint64_t)get_u32(at) | (uint64_t)get_u32(at + 4) << 32; }

static size_t header_size(const Instance *inst) { return FIXED_HEADER + strlen(inst->guid); }

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate FMUstate, size_t *size) {
    fmi2Status refused;
    Instance *inst = enter(c, F_SerializedFMUstateSize, &refused);
    if (!inst) return refused;
    const char *why;
    StateBox *box = box_of_instance(inst, FMUstate, &why);
    if (!box || !size) return leave(inst, fail(inst, "fmi2SerializedFMUstateSize", "not a state of this FMU"));
    size_t n = 0;
    int status = inst->bridge->serialize_state(inst->slave, box->python, NULL, &n);
    if (status <= fmi2Warning) *size = header_size(inst) + n;
    return leave(inst, status);
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate FMUstate, fmi2Byte serializedState[], size_t size) {
    fmi2Status refused;
    Instance *inst = enter(c, F_SerializeFMUstate, &refused);
    if (!inst) return refused;
    const char *why;
    StateBox *box = box_of_instance(inst, FMUstate, &why);
    if (!box || !serializedState) return leave(inst, fail(inst, "fmi2SerializeFMUstate", "not a state of this FMU"));
    size_t head = header_size(inst), payload = 0;
    int status = inst->bridge->serialize_state(inst->slave, box->python, NULL, &payload);
    if (status > fmi2Warning) return leave(inst, status);
    if (size < head + payload) {
        char text[256];
        snprintf(text, sizeof text, "size: got %zu bytes, the state needs %zu (fmi2SerializedFMUstateSize)", size,
                 head + payload);
        return leave(inst, fail(inst, "fmi2SerializeFMUstate", text));
    }
    memcpy(serializedState, STATE_HEADER, HEADER_SIZE);
    put_u32(serializedState + HEADER_SIZE, STATE_FORMAT);
    put_u32(serializedState + HEADER_SIZE + 4, RUNTIME_ID);
    put_u32(serializedState + HEADER_SIZE + 8, (uint32_t)box->fmi_state);
    put_u64(serializedState + HEADER_SIZE + 12, (uint64_t)payload);
    put_u32(serializedState + HEADER_SIZE + 24, (uint32_t)strlen(inst->guid));
    memcpy(serializedState + FIXED_HEADER, inst->guid, strlen(inst->guid));
    size_t rest = payload;
    status = inst->bridge->serialize_state(inst->slave, box->python, serializedState + head, &rest);
    if (status > fmi2Warning) return leave(inst, status);
    if (rest != payload)
        return leave(inst, fail(inst, "fmi2SerializeFMUstate", "the state changed size while written"));
    put_u32(serializedState + CRC_AT,
            crc32_of((const unsigned char *)serializedState + CRC_AT + 4, head + payload - CRC_AT - 4));
    return leave(inst, status);
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serializedState[], size_t size,
                                   fmi2FMUstate *FMUstate) {
    static const char *name = "fmi2DeSerializeFMUstate";
    fmi2Status refused;
    Instance *inst = enter(c, F_DeSerializeFMUstate, &refused);
    if (!inst) return refused;
    if (!serializedState || !FMUstate) return leave(inst, fail(inst, name, "serializedState or FMUstate is NULL"));
    if (size < HEADER_SIZE + 4 || memcmp(serializedState, STATE_HEADER, HEADER_SIZE) != 0)
        return leave(inst, fail(inst, name, "the bytes are not a serialized flexfmu FMU state (bad header)"));
    uint32_t format = get_u32(serializedState + HEADER_SIZE);
    if (format != STATE_FORMAT) {
        char text[160];
        snprintf(text, sizeof text, "the state was serialized in format %u; this FMU reads format %u", (unsigned)format,
                 STATE_FORMAT);
        return leave(inst, fail(inst, name, text));
    }
    if (size < FIXED_HEADER) return leave(inst, fail(inst, name, "the state is truncated (shorter than its header)"));
    uint32_t runtime = get_u32(serializedState + HEADER_SIZE + 4);
    uint32_t fmi_state = get_u32(serializedState + HEADER_SIZE + 8);
    uint64_t payload = get_u64(serializedState + HEADER_SIZE + 12);
    uint32_t guid_length = get_u32(serializedState + HEADER_SIZE + 24);
    if (guid_length > size - FIXED_HEADER || payload != size - FIXED_HEADER - guid_length) {
        char text[200];
        snprintf(text, sizeof text, "the state is truncated or extended: %zu bytes, its header says %llu", size,
                 (unsigned long long)(FIXED_HEADER + (uint64_t)guid_length + payload));
        return leave(inst, fail(inst, name, text));
    }
    if (get_u32(serializedState + CRC_AT)
        != crc32_of((const unsigned char *)serializedState + CRC_AT + 4, size - CRC_AT - 4))
        return leave(inst, fail(inst, name, "the state is damaged (its CRC-32 checksum does not match its bytes)"));
    if (runtime != RUNTIME_ID)
        return leave(inst,
                     fail(inst, name,
                          runtime == 1u
                              ? "the state is of a Python-runtime FMU; this FMU runs the " RUNTIME_NAME " runtime"
                              : "the state is of a native-runtime FMU; this FMU runs the " RUNTIME_NAME " runtime"));
    if (guid_length != strlen(inst->guid) || memcmp(serializedState + FIXED_HEADER, inst->guid, guid_length) != 0)
        return leave(inst, fail(inst, name, "the state is of another FMU or build (its GUID differs)"));
    if (!(fmi_state & ALL_STATES) || (fmi_state & (fmi_state - 1)))
        return leave(inst, fail(inst, name, "the state's FMI state field is invalid"));
    const char *why;
    StateBox *box = *FMUstate ? box_of_instance(inst, *FMUstate, &why) : NULL;
    if (*FMUstate && !box) return leave(inst, fail(inst, name, "*FMUstate is not a state of this FMU"));
    void *python = NULL;
    size_t head = header_size(inst);
    int status = inst->bridge->deserialize_state(inst->slave, serializedState + head, size - head, &python);
    if (status > fmi2Warning) return leave(inst, status);
    if (box) {
        inst->bridge->free_state(box->python);
    } else if (!(box = malloc(sizeof *box))) {
        inst->bridge->free_state(python);
        return leave(inst, fail(inst, name, "out of memory"));
    }
    label_box(inst, box);
    box->fmi_state = (int)fmi_state;
    box->python = python;
    *FMUstate = box;
    return leave(inst, status);
}

/* ---- FMI 2.0: what these FMUs do not provide --------------------------------------------------- */

fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[], size_t nUnknown,
                                        const fmi2ValueReference vKnown_ref[], size_t nKnown, const fmi2Real dvKnown[],
                                        fmi2Real dvUnknown[]) {
    (void)vUnknown_ref, (void)nUnknown, (void)vKnown_ref, (void)nKnown, (void)dvKnown, (void)dvUnknown;
    fmi2Status refused;
    enter(c, F_GetDirectionalDerivative, &refused);
    return refused;
}

fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[]) {
    (void)vr, (void)nvr, (void)order, (void)value;
    fmi2Status refused;
    enter(c, F_SetRealInputDerivatives, &refused);
    return refused;
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[]) {
    (void)vr, (void)nvr, (void)order, (void)value;
    fmi2Status refused;
    enter(c, F_GetRealOutputDerivatives, &refused);
    return refused;
}

fmi2Status fmi2CancelStep(fmi2Component c) {
    fmi2Status refused;
    enter(c, F_CancelStep, &refused);
    return refused;
}

/* ---- FMI 2.0: co-simulation -------------------------------------------------------------------- */

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint, fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
    (void)noSetFMUStatePriorToCurrentPoint;
    fmi2Status refused;
    Instance *inst = enter(c, F_DoStep, &refused);
    if (!inst) return refused;
    int status;
    if (!isfinite(currentCommunicationPoint))
        status = fail(inst, "fmi2DoStep", "currentCommunicationPoint is not finite (allowed: the FMU's time)");
    else if (!(isfinite(communicationStepSize) && communicationStepSize > 0))
        status = fail(inst, "fmi2DoStep", "communicationStepSize must be finite and > 0 s");
    else
        status = inst->bridge->do_step(inst->slave, currentCommunicationPoint, communicationStepSize);
    if (status == fmi2Discard)
        inst->state = StepFailed;
    else if (status >= fmi2Error)
        inst->state = Error;
    return leave(inst, status);
}

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value) {
    fmi2Status refused;
    Instance *inst = enter(c, F_GetStatus, &refused);
    if (!inst) return refused;
    if (!value) return leave(inst, fail(inst, "fmi2GetStatus", "value is NULL"));
    if (s != fmi2DoStepStatus) return leave(inst, fmi2Discard);
    *value = inst->state == StepFailed ? fmi2Discard : fmi2OK; /* fmi2DoStep is never pending */
    return leave(inst, fmi2OK);
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value) {
    fmi2Status refused;
    Instance *inst = enter(c, F_GetRealStatus, &refused);
    if (!inst) return refused;
    if (!value) return leave(inst, fail(inst, "fmi2GetRealStatus", "value is NULL"));
    if (s != fmi2LastSuccessfulTime) return leave(inst, fmi2Discard);
    return leave(inst, inst->bridge->last_successful_time(inst->slave, value));
}

fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value) {
    (void)s, (void)value;
    fmi2Status refused;
    Instance *inst = enter(c, F_GetIntegerStatus, &refused);
    return inst ? leave(inst, fmi2Discard) : refused; /* FMI 2.0 defines no integer status */
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value) {
    fmi2Status refused;
    Instance *inst = enter(c, F_GetBooleanStatus, &refused);
    if (!inst) return refused;
    if (!value) return leave(inst, fail(inst, "fmi2GetBooleanStatus", "value is NULL"));
    if (s != fmi2Terminated) return leave(inst, fmi2Discard);
    *value = fmi2False; /* the FMU never asks the master to stop */
    return leave(inst, fmi2OK);
}

fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value) {
    (void)s, (void)value;
    fmi2Status refused;
    Instance *inst = enter(c, F_GetStringStatus, &refused);
    return inst ? leave(inst, fmi2Discard) : refused; /* no pending step, so no status text */
}
