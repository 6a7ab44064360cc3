/*
 * fmi2_shim.c - an FMI 2.0 co-simulation shim around pythonfmu 0.7's binary wrapper (Linux only).
 *
 * pythonfmu turns every Python exception raised in a slave method into fmi2Fatal.  Our slaves
 * report a bad parameter, call or input by logging a message with status fmi2Error and then
 * raising; the FMI standard (and the FMI Reference FMUs) answer such cases with fmi2Error.  This
 * library is installed as binaries/linux64/<modelIdentifier>.so; pythonfmu's library is renamed
 * to <modelIdentifier>_pythonfmu.so next to it and loaded with dlopen() on fmi2Instantiate.
 *
 *  - The inner component gets a logger of ours.  It records whether the slave logged an fmi2Error
 *    message during the current call and forwards the message to the host.
 *  - An inner call that returns fmi2Fatal after the slave logged an fmi2Error message returns
 *    fmi2Error.  A fatal without such a message (an unexpected exception) stays fmi2Fatal.
 *  - Every other call and status is passed through.
 *
 * What is safe after an inner fmi2Fatal (pythonfmu 0.7, PySlaveInstance::handle_py_exception):
 * pythonfmu Py_DECREFs its Python class, slave instance and log queue but does not clear the
 * pointers.  The slave object is then freed as soon as Python's garbage collector runs.  After
 * that, every call into the inner component that reaches Python uses freed memory: Get*, Set*,
 * fmi2Terminate, fmi2Reset, fmi2GetFMUstate and the destructor run by fmi2FreeInstance, which
 * decrefs the same objects again.  This was observed as segfaults after gc.collect().
 * So once the inner component is "broken", the shim never calls it again:
 *  - fmi2Terminate: returns fmi2OK in the error state and fmi2Fatal after a fatal.  The slave's
 *    terminate() is not called because the slave is gone.
 *  - fmi2FreeInstance: frees the shim but deliberately leaks the broken inner component, a few
 *    hundred bytes of C++ objects.  The Python objects are already released, so Python's
 *    reference counts stay balanced.
 *  - fmi2Reset and fmi2SetFMUstate: instantiate a fresh inner component (leaking the broken one
 *    as above) and, for fmi2SetFMUstate, forward the call.  pythonfmu FMU states are
 *    self-contained Python objects.
 *  - fmi2FreeFMUstate: forwarded.  It only decrefs the state object and never touches the slave.
 *  - fmi2Get* and every other call: log an error and return fmi2Error (fmi2Fatal after a
 *    fatal).  Forwarding them would read freed memory.
 *
 * Logging: pythonfmu forwards messages only when its debug logging is on.  The inner component
 * is therefore always instantiated with loggingOn = fmi2True and no category filter, so errors
 * are always seen.  The host's loggingOn and fmi2SetDebugLogging categories are applied here:
 * fmi2Error/fmi2Fatal messages always reach the host, others only if the host asked for them.
 *
 * The inner library is never dlclose()d: broken components are leaked, and unloading pythonfmu
 * may finalise the Python interpreter.  No global state: each instance keeps its own dlopen
 * handle (the loader reference-counts it) and its own table of inner entry points.
 */
#define _GNU_SOURCE /* dladdr */
#include <dlfcn.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"

/* pythonfmu entry points the shim calls (fmi2GetTypesPlatform, fmi2GetVersion and
   fmi2SetDebugLogging are answered here). */
#define INNER_FUNCTIONS(X)                                                                          \
    X(Instantiate) X(FreeInstance) X(SetupExperiment) X(EnterInitializationMode)                    \
    X(ExitInitializationMode) X(Terminate) X(Reset) X(GetReal) X(GetInteger) X(GetBoolean)          \
    X(GetString) X(SetReal) X(SetInteger) X(SetBoolean) X(SetString) X(GetFMUstate)                 \
    X(SetFMUstate) X(FreeFMUstate) X(SerializedFMUstateSize) X(SerializeFMUstate)                   \
    X(DeSerializeFMUstate) X(GetDirectionalDerivative) X(SetRealInputDerivatives)                   \
    X(GetRealOutputDerivatives) X(DoStep) X(CancelStep) X(GetStatus) X(GetRealStatus)               \
    X(GetIntegerStatus) X(GetBooleanStatus) X(GetStringStatus)

typedef struct {
#define DECLARE(name) fmi2##name##TYPE *name;
    INNER_FUNCTIONS(DECLARE)
#undef DECLARE
} InnerApi;

typedef struct {
    InnerApi api;                /* entry points of <modelIdentifier>_pythonfmu.so */
    void *lib;                   /* its dlopen handle (never closed) */
    fmi2Component inner;         /* pythonfmu's component */
    fmi2Status broken;           /* fmi2OK, or the status (fmi2Error/fmi2Fatal) that broke `inner` */
    fmi2Boolean errorLogged;     /* the slave logged an fmi2Error message during the current call */
    fmi2CallbackFunctions host;  /* the host's callbacks */
    fmi2CallbackFunctions own;   /* given to pythonfmu, which keeps a pointer to it: our logger */
    /* fmi2Instantiate's arguments, kept to instantiate a fresh inner component */
    char *instanceName, *guid, *resourceLocation;
    fmi2Type fmuType;
    fmi2Boolean visible;
    /* the host's debug-logging settings (fmi2Instantiate, fmi2SetDebugLogging) */
    fmi2Boolean loggingOn;
    size_t nCategories;
    char **categories;
} Shim;

static char *copy_string(const char *text) {
    char *copy = malloc(strlen(text ? text : "") + 1);
    if (copy) strcpy(copy, text ? text : "");
    return copy;
}

static void free_categories(Shim *s) {
    for (size_t i = 0; i < s->nCategories; i++) free(s->categories[i]);
    free(s->categories);
    s->categories = NULL;
    s->nCategories = 0;
}

/* Does the host want this message?  Errors always; the rest per its debug-logging settings. */
static int wanted(const Shim *s, fmi2Status status, fmi2String category) {
    if (!s->host.logger) return 0;
    if (status == fmi2Error || status == fmi2Fatal) return 1;
    if (!s->loggingOn) return 0;
    if (s->nCategories == 0) return 1;
    for (size_t i = 0; i < s->nCategories; i++)
        if (category && strcmp(category, s->categories[i]) == 0) return 1;
    return 0;
}

/* The logger pythonfmu calls (messages arrive pre-formatted, without arguments). */
static void shim_logger(fmi2ComponentEnvironment environment, fmi2String instanceName,
                        fmi2Status status, fmi2String category, fmi2String message, ...) {
    Shim *s = (Shim *)environment;
    if (status == fmi2Error)
        s->errorLogged = fmi2True;
    else if (status == fmi2Fatal && s->errorLogged)
        status = fmi2Error; /* pythonfmu's report of the exception that followed the slave's error */
    if (wanted(s, status, category))
        s->host.logger(s->host.componentEnvironment, instanceName, status, category, message);
}

/* A message of the shim itself (kept free of '%': hosts treat messages as printf formats). */
static void shim_log(const Shim *s, fmi2Status status, const char *message) {
    const char *category = status == fmi2Fatal ? "logStatusFatal" : "logStatusError";
    if (wanted(s, status, category))
        s->host.logger(s->host.componentEnvironment, s->instanceName, status, category, message);
}

/* Load <this library minus ".so">_pythonfmu.so from our own directory and resolve its entry points. */
static int load_inner(Shim *s) {
    Dl_info info;
    char path[4096], message[4352];
    /* shim_logger is static, so its address cannot be interposed by another library's symbol */
    if (!dladdr((void *)&shim_logger, &info) || !info.dli_fname) {
        shim_log(s, fmi2Error, "fmi2Instantiate: the FMI shim cannot locate its own library file");
        return 0;
    }
    size_t n = strlen(info.dli_fname);
    if (n < 3 || strcmp(info.dli_fname + n - 3, ".so") != 0 || n + 16 > sizeof path) {
        shim_log(s, fmi2Error, "fmi2Instantiate: unexpected file name of the FMI shim library");
        return 0;
    }
    snprintf(path, sizeof path, "%.*s_pythonfmu.so", (int)(n - 3), info.dli_fname);
    s->lib = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (!s->lib) {
        snprintf(message, sizeof message, "fmi2Instantiate: cannot load the pythonfmu library: %s", dlerror());
        shim_log(s, fmi2Error, message);
        return 0;
    }
    /* POSIX: a function pointer may be assigned from dlsym through a void* lvalue */
#define RESOLVE(name)                                                                              \
    if (!(*(void **)&s->api.name = dlsym(s->lib, "fmi2" #name))) {                                 \
        shim_log(s, fmi2Error, "fmi2Instantiate: the pythonfmu library lacks fmi2" #name);          \
        return 0;                                                                                  \
    }
    INNER_FUNCTIONS(RESOLVE)
#undef RESOLVE
    return 1;
}

/* A new inner component.  pythonfmu always logs everything to us, and we filter for the host. */
static fmi2Component new_inner(Shim *s) {
    return s->api.Instantiate(s->instanceName, s->fmuType, s->guid, s->resourceLocation,
                              &s->own, s->visible, fmi2True);
}

/* Replace a broken inner component by a fresh one; the broken one is leaked (see top). */
static fmi2Status reinstantiate(Shim *s, const char *function) {
    fmi2Component fresh = new_inner(s);
    if (!fresh) {
        char message[256];
        snprintf(message, sizeof message, "%s: cannot instantiate a new pythonfmu component", function);
        shim_log(s, fmi2Error, message);
        return fmi2Error;
    }
    s->inner = fresh;
    s->broken = fmi2OK;
    return fmi2OK;
}

/* Before forwarding: refuse if the inner component is broken, else clear the error flag. */
static int enter(Shim *s, const char *function) {
    if (s->broken != fmi2OK) {
        char message[256];
        snprintf(message, sizeof message,
                 "%s: not available after an error: pythonfmu has released this instance's Python "
                 "slave (call fmi2Reset or fmi2FreeInstance)", function);
        shim_log(s, s->broken, message);
        return 0;
    }
    s->errorLogged = fmi2False;
    return 1;
}

/* After forwarding: an inner fatal breaks the component; it is an error if the slave logged one. */
static fmi2Status leave(Shim *s, fmi2Status status) {
    if (status == fmi2Fatal) {
        s->broken = s->errorLogged ? fmi2Error : fmi2Fatal;
        return s->broken;
    }
    return status;
}

/* ---- FMI 2.0: common functions -------------------------------------------------------------- */

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }

const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[]) {
    Shim *s = (Shim *)c; /* applied here only: the inner component keeps logging everything */
    free_categories(s);
    s->loggingOn = loggingOn;
    if (nCategories > 0) {
        s->categories = calloc(nCategories, sizeof *s->categories);
        if (!s->categories) return fmi2Error;
        for (size_t i = 0; i < nCategories; i++) {
            s->categories[i] = copy_string(categories[i]);
            s->nCategories = i + 1;
            if (!s->categories[i]) return fmi2Error;
        }
    }
    return fmi2OK;
}

static void free_shim(Shim *s) {
    free_categories(s);
    free(s->instanceName);
    free(s->guid);
    free(s->resourceLocation);
    free(s);
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation, const fmi2CallbackFunctions *functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn) {
    if (!functions) return NULL;
    Shim *s = calloc(1, sizeof *s);
    if (!s) return NULL;
    s->host = *functions;
    s->own = *functions;
    s->own.logger = shim_logger;
    s->own.componentEnvironment = s;
    s->instanceName = copy_string(instanceName);
    s->guid = copy_string(fmuGUID);
    s->resourceLocation = copy_string(fmuResourceLocation);
    s->fmuType = fmuType;
    s->visible = visible;
    s->loggingOn = loggingOn;
    if (!s->instanceName || !s->guid || !s->resourceLocation || !load_inner(s)
        || !(s->inner = new_inner(s))) { /* pythonfmu has logged why */
        free_shim(s);
        return NULL;
    }
    return s;
}

void fmi2FreeInstance(fmi2Component c) {
    Shim *s = (Shim *)c;
    if (!s) return;
    if (s->broken == fmi2OK) s->api.FreeInstance(s->inner);
    /* else: leak the broken inner component; its destructor would decref freed Python objects */
    free_shim(s);
}

/* ---- FMI 2.0: initialisation, termination, reset -------------------------------------------- */

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    Shim *s = (Shim *)c;
    if (!enter(s, "fmi2SetupExperiment")) return s->broken;
    return leave(s, s->api.SetupExperiment(s->inner, toleranceDefined, tolerance, startTime,
                                           stopTimeDefined, stopTime));
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    Shim *s = (Shim *)c;
    if (!enter(s, "fmi2EnterInitializationMode")) return s->broken;
    return leave(s, s->api.EnterInitializationMode(s->inner));
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    Shim *s = (Shim *)c;
    if (!enter(s, "fmi2ExitInitializationMode")) return s->broken;
    return leave(s, s->api.ExitInitializationMode(s->inner));
}

fmi2Status fmi2Terminate(fmi2Component c) {
    Shim *s = (Shim *)c;
    if (s->broken == fmi2Error) return fmi2OK; /* answered here: forwarding would crash */
    if (!enter(s, "fmi2Terminate")) return s->broken;
    return leave(s, s->api.Terminate(s->inner));
}

fmi2Status fmi2Reset(fmi2Component c) {
    Shim *s = (Shim *)c;
    if (s->broken != fmi2OK) return reinstantiate(s, "fmi2Reset");
    s->errorLogged = fmi2False;
    return leave(s, s->api.Reset(s->inner));
}

/* ---- FMI 2.0: getting and setting variable values ------------------------------------------- */

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[]) {
    Shim *s = (Shim *)c;
    if (!enter(s, "fmi2GetReal")) return s->broken;
    return leave(s, s->api.GetReal(s->inner, vr, nvr, value));
}

fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Integer value[]) {
    Shim *s = (Shim *)c;
    if (!enter(s, "fmi2GetInteger")) return s->broken;
    return leave(s, s->api.GetInteger(s->inner, vr, nvr, value));
}

fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Boolean value[]) {
    Shim *s = (Shim *)c;
    if (!enter(s, "fmi2GetBoolean")) return s->broken;
    return leave(s, s->api.GetBoolean(s->inner, vr, nvr, value));
}

fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2String value[]) {
    Shim *s = (Shim *)c;
    if (!enter(s, "fmi2GetString")) return s->broken;
    return leave(s, s->api.GetString(s->inner, vr, nvr, value));
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[]) {
    Shim *s = (Shim *)c;
    if (!enter(s, "fmi2SetReal")) return s->broken;
    return leave(s, s->api.SetReal(s->inner, vr, nvr, value));
}

fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Integer value[]) {
    Shim *s = (Shim *)c;
    if (!enter(s, "fmi2SetInteger")) return s->broken;
    return leave(s, s->api.SetInteger(s->inner, vr, nvr, value));
}

fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Boolean value[]) {
    Shim *s = (Shim *)c;
    if (!enter(s, "fmi2SetBoolean")) return s->broken;
    return leave(s, s->api.SetBoolean(s->inner, vr, nvr, value));
}

fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2String value[]) {
    Shim *s = (Shim *)c;
    if (!enter(s, "fmi2SetString")) return s->broken;
    return leave(s, s->api.SetString(s->inner, vr, nvr, value));
}

/* ---- FMI 2.0: FMU state --------------------------------------------------------------------- */

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *state) {
    Shim *s = (Shim *)c;
    if (!enter(s, "fmi2GetFMUstate")) return s->broken;
    return leave(s, s->api.GetFMUstate(s->inner, state));
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate state) {
    Shim *s = (Shim *)c; /* allowed in the error state: roll back onto a fresh inner component */
    if (s->broken != fmi2OK && reinstantiate(s, "fmi2SetFMUstate") != fmi2OK) return fmi2Error;
    s->errorLogged = fmi2False;
    return leave(s, s->api.SetFMUstate(s->inner, state));
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *state) {
    Shim *s = (Shim *)c; /* always forwarded: it only decrefs the state, even on a broken component */
    s->errorLogged = fmi2False;
    return leave(s, s->api.FreeFMUstate(s->inner, state));
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate state, size_t *size) {
    Shim *s = (Shim *)c;
    if (!enter(s, "fmi2SerializedFMUstateSize")) return s->broken;
    return leave(s, s->api.SerializedFMUstateSize(s->inner, state, size));
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate state, fmi2Byte bytes[], size_t size) {
    Shim *s = (Shim *)c;
    if (!enter(s, "fmi2SerializeFMUstate")) return s->broken;
    return leave(s, s->api.SerializeFMUstate(s->inner, state, bytes, size));
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte bytes[], size_t size, fmi2FMUstate *state) {
    Shim *s = (Shim *)c;
    if (!enter(s, "fmi2DeSerializeFMUstate")) return s->broken;
    return leave(s, s->api.DeSerializeFMUstate(s->inner, bytes, size, state));
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[], size_t nUnknown,
                                        const fmi2ValueReference vKnown_ref[], size_t nKnown,
                                        const fmi2Real dvKnown[], fmi2Real dvUnknown[]) {
    Shim *s = (Shim *)c;
    if (!enter(s, "fmi2GetDirectionalDerivative")) return s->broken;
    return leave(s, s->api.GetDirectionalDerivative(s->inner, vUnknown_ref, nUnknown, vKnown_ref, nKnown,
                                                    dvKnown, dvUnknown));
}

/* ---- FMI 2.0: co-simulation ----------------------------------------------------------------- */

fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[]) {
    Shim *s = (Shim *)c;
    if (!enter(s, "fmi2SetRealInputDerivatives")) return s->broken;
    return leave(s, s->api.SetRealInputDerivatives(s->inner, vr, nvr, order, value));
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[]) {
    Shim *s = (Shim *)c;
    if (!enter(s, "fmi2GetRealOutputDerivatives")) return s->broken;
    return leave(s, s->api.GetRealOutputDerivatives(s->inner, vr, nvr, order, value));
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint, fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
    Shim *s = (Shim *)c;
    if (!enter(s, "fmi2DoStep")) return s->broken;
    return leave(s, s->api.DoStep(s->inner, currentCommunicationPoint, communicationStepSize,
                                  noSetFMUStatePriorToCurrentPoint));
}

fmi2Status fmi2CancelStep(fmi2Component c) {
    Shim *s = (Shim *)c;
    if (!enter(s, "fmi2CancelStep")) return s->broken;
    return leave(s, s->api.CancelStep(s->inner));
}

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind kind, fmi2Status *value) {
    Shim *s = (Shim *)c;
    if (!enter(s, "fmi2GetStatus")) return s->broken;
    return leave(s, s->api.GetStatus(s->inner, kind, value));
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind kind, fmi2Real *value) {
    Shim *s = (Shim *)c;
    if (!enter(s, "fmi2GetRealStatus")) return s->broken;
    return leave(s, s->api.GetRealStatus(s->inner, kind, value));
}

fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind kind, fmi2Integer *value) {
    Shim *s = (Shim *)c;
    if (!enter(s, "fmi2GetIntegerStatus")) return s->broken;
    return leave(s, s->api.GetIntegerStatus(s->inner, kind, value));
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind kind, fmi2Boolean *value) {
    Shim *s = (Shim *)c;
    if (!enter(s, "fmi2GetBooleanStatus")) return s->broken;
    return leave(s, s->api.GetBooleanStatus(s->inner, kind, value));
}

fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind kind, fmi2String *value) {
    Shim *s = (Shim *)c;
    if (!enter(s, "fmi2GetStringStatus")) return s->broken;
    return leave(s, s->api.GetStringStatus(s->inner, kind, value));
}
