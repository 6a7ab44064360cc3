/*
 * flexfmu_fmi2.c - the FMI 2.0 front of the flexfmu FMUs (binaries/linux64/<id>.so): co-simulation, and model
 * exchange for the models that are ODEs in fixed coordinates (the runtime says which: BridgeApi.n_states).
 *
 * It links no Python: any FMI host can load it (dlopen with RTLD_NOW, RTLD_LOCAL) on the machine the
 * FMU was built on with no set-up.  On the first fmi2Instantiate it
 *  1. reads resources/flexfmu_runtime.txt (written at build time: libpython, the interpreter's home,
 *     the build environment's site-packages), each overridable by an environment variable
 *     (FLEXFMU_LIBPYTHON, FLEXFMU_PYTHONHOME, FLEXFMU_SITE_PACKAGES) for another machine;
 *  2. loads libpython with RTLD_GLOBAL unless the process already has Python's symbols (a Python host);
 *  3. loads the bridge <id>_python.so next to this file (the runtime, flexfmu_native.c, over the Python kind,
 *     native_python.c) and starts Python.
 * It owns the FMI 2.0 semantics: the call-sequence table below (one row per function: the states in
 * which it is legal), argument checks, state transitions and the host's logger.  What no FMI version defines
 * (the instance and its lock, logging and the refusal of re-entrant calls, the FMU-state box and its serialised
 * header, the resources folder, loading the bridge) is front_common.c, compiled here (included below) and shared
 * with the FMI 3.0 front (flexfmu_fmi3.c).  The bridge only runs the slave's Python.
 *
 * Native FMUs (flexfmu.fmi.native; docs/fmu.md, "Native runtime") compile this same file with -DFLEXFMU_NATIVE
 * (or through native_front.c) and link it statically with the native bridge (flexfmu_native.c), a model
 * kind and the FMI 3.0 front: load_bridge then returns the built-in API, and nothing about libpython is read or
 * loaded.  That variant builds on Linux, macOS (dladdr, pthreads) and Windows (native_platform.h: SRW locks and
 * GetModuleFileName instead); the Python variant is Linux-only and unchanged.
 */
#if !defined(_WIN32)
#define _GNU_SOURCE /* dladdr, RTLD_DEFAULT (front_common.c) */
#endif
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"
#include "front_common.h"

#include "front_common.c" /* the shared part of the fronts: one copy per library, here */

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
    EventMode = 1 << 6,          /* model exchange: after fmi2ExitInitializationMode, fmi2EnterEventMode */
    ContinuousTimeMode = 1 << 7, /* model exchange: after fmi2EnterContinuousTimeMode */
} State;

#define ME_MODES (EventMode | ContinuousTimeMode)
#define ALL_STATES (Instantiated | InitializationMode | StepComplete | StepFailed | Terminated | Error | ME_MODES)
#define VALUES_READABLE (InitializationMode | StepComplete | StepFailed | Terminated | Error | ME_MODES)
#define VALUES_WRITABLE (Instantiated | InitializationMode | StepComplete | ME_MODES)
/* the model is made at fmi2ExitInitializationMode: states, derivatives and directional derivatives from there on */
#define MODEL_READABLE (StepComplete | StepFailed | Terminated | Error | ME_MODES)

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
    F_EnterEventMode,
    F_NewDiscreteStates,
    F_EnterContinuousTimeMode,
    F_CompletedIntegratorStep,
    F_SetTime,
    F_SetContinuousStates,
    F_GetDerivatives,
    F_GetEventIndicators,
    F_GetContinuousStates,
    F_GetNominalsOfContinuousStates,
    F_COUNT
} Function;

/* The one legal-call table (docs/fmu.md prints it).  Unsupported capabilities have no legal state
   and their own message.  Parameters (variability fixed) are settable only before
   fmi2ExitInitializationMode: the runtime checks that per variable. */
static const FrontCall CALLS[F_COUNT] = {
    [F_SetDebugLogging] = {"fmi2SetDebugLogging", ALL_STATES, NULL},
    [F_SetupExperiment] = {"fmi2SetupExperiment", Instantiated, NULL},
    [F_EnterInitializationMode] = {"fmi2EnterInitializationMode", Instantiated, NULL},
    [F_ExitInitializationMode] = {"fmi2ExitInitializationMode", InitializationMode, NULL},
    [F_Terminate] = {"fmi2Terminate", StepComplete | StepFailed | Error | ME_MODES, NULL},
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
    [F_GetDirectionalDerivative] = {"fmi2GetDirectionalDerivative", MODEL_READABLE, NULL},
    [F_SetRealInputDerivatives] = {"fmi2SetRealInputDerivatives", 0, "not supported (canInterpolateInputs is false)"},
    [F_GetRealOutputDerivatives] = {"fmi2GetRealOutputDerivatives", 0, "not supported (maxOutputDerivativeOrder is 0)"},
    [F_DoStep] = {"fmi2DoStep", StepComplete, NULL},
    [F_CancelStep] = {"fmi2CancelStep", 0, "not supported: fmi2DoStep never returns fmi2Pending"},
    [F_GetStatus] = {"fmi2GetStatus", StepComplete | StepFailed | Terminated, NULL},
    [F_GetRealStatus] = {"fmi2GetRealStatus", StepComplete | StepFailed | Terminated, NULL},
    [F_GetIntegerStatus] = {"fmi2GetIntegerStatus", StepComplete | StepFailed | Terminated, NULL},
    [F_GetBooleanStatus] = {"fmi2GetBooleanStatus", StepComplete | StepFailed | Terminated, NULL},
    [F_GetStringStatus] = {"fmi2GetStringStatus", StepComplete | StepFailed | Terminated, NULL},
    /* model exchange (a co-simulation instance never is in EventMode or ContinuousTimeMode) */
    [F_EnterEventMode] = {"fmi2EnterEventMode", ME_MODES, NULL},
    [F_NewDiscreteStates] = {"fmi2NewDiscreteStates", EventMode, NULL},
    [F_EnterContinuousTimeMode] = {"fmi2EnterContinuousTimeMode", EventMode, NULL},
    [F_CompletedIntegratorStep] = {"fmi2CompletedIntegratorStep", ContinuousTimeMode, NULL},
    [F_SetTime] = {"fmi2SetTime", ME_MODES, NULL},
    [F_SetContinuousStates] = {"fmi2SetContinuousStates", ContinuousTimeMode, NULL},
    [F_GetDerivatives] = {"fmi2GetDerivatives", ME_MODES | Terminated | Error, NULL},
    [F_GetEventIndicators] = {"fmi2GetEventIndicators", InitializationMode | ME_MODES | Terminated | Error, NULL},
    [F_GetContinuousStates] = {"fmi2GetContinuousStates", ME_MODES | Terminated | Error, NULL},
    [F_GetNominalsOfContinuousStates]
    = {"fmi2GetNominalsOfContinuousStates", Instantiated | ME_MODES | Terminated | Error, NULL},
};

static const char *state_name(int state) {
    switch (state) {
    case Instantiated: return "Instantiated";
    case InitializationMode: return "InitializationMode";
    case StepComplete: return "StepComplete";
    case StepFailed: return "StepFailed";
    case Terminated: return "Terminated";
    case Error: return "Error";
    case EventMode: return "EventMode";
    case ContinuousTimeMode: return "ContinuousTimeMode";
    default: return "?";
    }
}

/* ---- the instance ------------------------------------------------------------------------------ */

#define INSTANCE_MAGIC 0x464c5846u /* "FXLF": a pointer that is not one of our instances is refused */

typedef FrontInstance Instance;

/* Hosts treat the message as a printf format (FMI 2.0 logger): '%' is doubled so that a message can
   never make a host read arguments that are not there. */
static void deliver(const FrontInstance *inst, int status, const char *category, const char *message) {
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
    ((fmi2CallbackLogger)inst->logger)(inst->environment, inst->name, (fmi2Status)status, category, safe);
    free(safe);
}

static const FrontVersion FMI2 = {.magic = INSTANCE_MAGIC,
                                  .all_states = ALL_STATES,
                                  .error_state = Error, /* set by the calls that move the model, as they fail */
                                  .every_error = 0,
                                  .me_states = ME_MODES,
                                  .cs_states = StepComplete | StepFailed,
                                  .error_name = "fmi2Error",
                                  .serialized_size_name = "fmi2SerializedFMUstateSize",
                                  .state_name = state_name,
                                  .deliver = deliver};

static fmi2Status fail(Instance *inst, const char *function, const char *why) {
    return (fmi2Status)front_fail(inst, function, why);
}

/* Check the instance pointer and the call sequence; lock the instance. */
static Instance *enter(fmi2Component c, Function f, fmi2Status *refused) {
    *refused = fmi2Error;
    return front_enter(c, &FMI2, &CALLS[f]);
}

static fmi2Status leave(Instance *inst, int status) { return (fmi2Status)front_leave(inst, status); }

/* ---- FMI 2.0: common functions ----------------------------------------------------------------- */

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }

const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[]) {
    fmi2Status refused;
    Instance *inst = enter(c, F_SetDebugLogging, &refused);
    if (!inst) return refused;
    return leave(inst, front_set_debug_logging(inst, "fmi2SetDebugLogging", loggingOn, nCategories, categories));
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation, const fmi2CallbackFunctions *functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn) {
    if (!functions) return NULL;
    Instance *inst = front_new_instance(&FMI2, sizeof *inst, Instantiated, instanceName, fmuGUID, loggingOn,
                                        (FrontLogger)functions->logger, functions->componentEnvironment);
    if (!inst) return NULL;
    if (fmuType != fmi2CoSimulation && fmuType != fmi2ModelExchange) {
        fail(inst, "fmi2Instantiate", "fmuType: got neither fmi2ModelExchange nor fmi2CoSimulation");
        front_free_instance_memory(inst);
        return NULL;
    }
    inst->model_exchange = fmuType == fmi2ModelExchange;
    char resources[4096];
    if (front_resources_from_uri(fmuResourceLocation, resources, sizeof resources) < 0) {
        fail(inst, "fmi2Instantiate",
             "fmuResourceLocation: neither it (a file:/// URI) nor the folder next to "
             "this binary holds the FMU's resources (resources/flexfmu_build.json)");
        front_free_instance_memory(inst);
        return NULL;
    }
    if (front_instantiate_slave(inst, "fmi2Instantiate", resources, visible) < 0) {
        front_free_instance_memory(inst);
        return NULL;
    }
    if (inst->model_exchange && inst->bridge->model_exchange(inst->slave, "fmi2Instantiate") != fmi2OK) {
        inst->bridge->free_instance(inst->slave);
        front_free_instance_memory(inst);
        return NULL;
    }
    return inst;
}

void fmi2FreeInstance(fmi2Component c) {
    fmi2Status refused;
    Instance *inst = enter(c, F_FreeInstance, &refused);
    if (!inst) return;
    inst->bridge->free_instance(inst->slave);
    front_unlock(inst);
    front_free_instance_memory(inst);
}

/* ---- FMI 2.0: initialisation, termination, reset ----------------------------------------------- */

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance, fmi2Real startTime,
                               fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    fmi2Status refused;
    Instance *inst = enter(c, F_SetupExperiment, &refused);
    if (!inst) return refused;
    return leave(inst, front_setup_experiment(inst, "fmi2SetupExperiment", toleranceDefined, tolerance, startTime,
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
    inst->state = status > fmi2Warning ? Error : inst->model_exchange ? EventMode : StepComplete;
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

/* ---- FMI 2.0: FMU state (front_common.c: the box, the serialised header and their checks) ------ */

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    fmi2Status refused;
    Instance *inst = enter(c, F_GetFMUstate, &refused);
    if (!inst) return refused;
    return leave(inst, front_get_state(inst, "fmi2GetFMUstate", FMUstate));
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate) {
    fmi2Status refused;
    Instance *inst = enter(c, F_SetFMUstate, &refused);
    if (!inst) return refused;
    return leave(inst, front_set_state(inst, "fmi2SetFMUstate", FMUstate));
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    fmi2Status refused;
    Instance *inst = enter(c, F_FreeFMUstate, &refused);
    if (!inst) return refused;
    return leave(inst, front_free_state(inst, "fmi2FreeFMUstate", FMUstate));
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate FMUstate, size_t *size) {
    fmi2Status refused;
    Instance *inst = enter(c, F_SerializedFMUstateSize, &refused);
    if (!inst) return refused;
    return leave(inst, front_serialized_state_size(inst, "fmi2SerializedFMUstateSize", FMUstate, size));
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate FMUstate, fmi2Byte serializedState[], size_t size) {
    fmi2Status refused;
    Instance *inst = enter(c, F_SerializeFMUstate, &refused);
    if (!inst) return refused;
    return leave(inst, front_serialize_state(inst, "fmi2SerializeFMUstate", FMUstate, serializedState, size));
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serializedState[], size_t size,
                                   fmi2FMUstate *FMUstate) {
    fmi2Status refused;
    Instance *inst = enter(c, F_DeSerializeFMUstate, &refused);
    if (!inst) return refused;
    return leave(inst, front_deserialize_state(inst, "fmi2DeSerializeFMUstate", serializedState, size, FMUstate));
}

/* ---- FMI 2.0: directional derivatives ------------------------------------------------------------ */

fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[], size_t nUnknown,
                                        const fmi2ValueReference vKnown_ref[], size_t nKnown, const fmi2Real dvKnown[],
                                        fmi2Real dvUnknown[]) {
    fmi2Status refused;
    Instance *inst = enter(c, F_GetDirectionalDerivative, &refused);
    if (!inst) return refused;
    if (nUnknown == 0) return leave(inst, fmi2OK);
    if (!vUnknown_ref || !dvUnknown || (nKnown > 0 && (!vKnown_ref || !dvKnown)))
        return leave(inst, fail(inst, "fmi2GetDirectionalDerivative", "a value-reference or value array is NULL"));
    return leave(inst, inst->bridge->directional(inst->slave, "fmi2GetDirectionalDerivative", vUnknown_ref, nUnknown,
                                                 vKnown_ref, nKnown, dvKnown, dvUnknown));
}

/* ---- FMI 2.0: model exchange (no events: the models are linear ODEs with inputs) ------------------ */

fmi2Status fmi2EnterEventMode(fmi2Component c) {
    fmi2Status refused;
    Instance *inst = enter(c, F_EnterEventMode, &refused);
    if (!inst) return refused;
    inst->state = EventMode;
    return leave(inst, fmi2OK);
}

fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo *info) {
    fmi2Status refused;
    Instance *inst = enter(c, F_NewDiscreteStates, &refused);
    if (!inst) return refused;
    if (!info) return leave(inst, fail(inst, "fmi2NewDiscreteStates", "fmi2EventInfo is NULL"));
    info->newDiscreteStatesNeeded = fmi2False;
    info->terminateSimulation = fmi2False;
    info->nominalsOfContinuousStatesChanged = fmi2False;
    info->valuesOfContinuousStatesChanged = fmi2False;
    info->nextEventTimeDefined = fmi2False; /* no time events */
    info->nextEventTime = 0.0;
    return leave(inst, fmi2OK);
}

fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c) {
    fmi2Status refused;
    Instance *inst = enter(c, F_EnterContinuousTimeMode, &refused);
    if (!inst) return refused;
    inst->state = ContinuousTimeMode;
    return leave(inst, fmi2OK);
}

fmi2Status fmi2CompletedIntegratorStep(fmi2Component c, fmi2Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi2Boolean *enterEventMode, fmi2Boolean *terminateSimulation) {
    (void)noSetFMUStatePriorToCurrentPoint;
    fmi2Status refused;
    Instance *inst = enter(c, F_CompletedIntegratorStep, &refused);
    if (!inst) return refused;
    if (!enterEventMode || !terminateSimulation)
        return leave(inst, fail(inst, "fmi2CompletedIntegratorStep", "enterEventMode or terminateSimulation is NULL"));
    *enterEventMode = fmi2False; /* no step events */
    *terminateSimulation = fmi2False;
    return leave(inst, fmi2OK);
}

fmi2Status fmi2SetTime(fmi2Component c, fmi2Real time) {
    fmi2Status refused;
    Instance *inst = enter(c, F_SetTime, &refused);
    if (!inst) return refused;
    return leave(inst, inst->bridge->set_time(inst->slave, "fmi2SetTime", time));
}

fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real x[], size_t nx) {
    fmi2Status refused;
    Instance *inst = enter(c, F_SetContinuousStates, &refused);
    if (!inst) return refused;
    if (!x && nx > 0) return leave(inst, fail(inst, "fmi2SetContinuousStates", "x is NULL"));
    return leave(inst, inst->bridge->continuous_states(inst->slave, "fmi2SetContinuousStates", 1, (double *)x, nx));
}

fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real x[], size_t nx) {
    fmi2Status refused;
    Instance *inst = enter(c, F_GetContinuousStates, &refused);
    if (!inst) return refused;
    if (!x && nx > 0) return leave(inst, fail(inst, "fmi2GetContinuousStates", "x is NULL"));
    return leave(inst, inst->bridge->continuous_states(inst->slave, "fmi2GetContinuousStates", 0, x, nx));
}

fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real derivatives[], size_t nx) {
    fmi2Status refused;
    Instance *inst = enter(c, F_GetDerivatives, &refused);
    if (!inst) return refused;
    if (!derivatives && nx > 0) return leave(inst, fail(inst, "fmi2GetDerivatives", "derivatives is NULL"));
    return leave(inst, inst->bridge->derivatives(inst->slave, "fmi2GetDerivatives", derivatives, nx));
}

fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real eventIndicators[], size_t ni) {
    (void)eventIndicators;
    fmi2Status refused;
    Instance *inst = enter(c, F_GetEventIndicators, &refused);
    if (!inst) return refused;
    if (ni != 0) return leave(inst, fail(inst, "fmi2GetEventIndicators", "ni: this model has 0 event indicators"));
    return leave(inst, fmi2OK);
}

fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real x_nominal[], size_t nx) {
    fmi2Status refused;
    Instance *inst = enter(c, F_GetNominalsOfContinuousStates, &refused);
    if (!inst) return refused;
    if (!x_nominal && nx > 0) return leave(inst, fail(inst, "fmi2GetNominalsOfContinuousStates", "x_nominal is NULL"));
    return leave(inst, inst->bridge->nominals(inst->slave, x_nominal, nx));
}

/* ---- FMI 2.0: what these FMUs do not provide --------------------------------------------------- */

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
