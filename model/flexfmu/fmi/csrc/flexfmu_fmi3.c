/*
 * flexfmu_fmi3.c - the FMI 3.0 front of the native flexfmu FMUs (binaries/x86_64-linux/<id>.so): co-simulation, and
 * model exchange for the models that are ODEs in fixed coordinates (the runtime says which: BridgeApi.n_states).
 *
 * The same library as the FMI 2.0 front's (flexfmu_fmi2.c, with front_common.c: the instance, its lock, logging and
 * the refusal of re-entrant calls, the FMU-state box and its serialised header, the resources folder, the bridge),
 * over the same runtime (flexfmu_native.c and its kinds): one binary serves an FMI 2.0 and an FMI 3.0 FMU.  This
 * file holds what FMI 3.0 defines: its entry points, its call-sequence table (the standard's state machine for
 * co-simulation without Event Mode: eventModeUsed = false; model exchange with an Event Mode that never has events
 * to handle), its argument checks and its logger.
 *
 * What differs from the FMI 2.0 front:
 *  - fmi3EnterInitializationMode takes the experiment (tolerance, startTime, stopTime: fmi2SetupExperiment's
 *    checks); a step that would end after a defined stopTime is refused;
 *  - fmi3DoStep's out-arguments: eventHandlingNeeded, terminateSimulation and earlyReturn are always false (no
 *    events, no early return), lastSuccessfulTime is the FMU's time after the call (the step's start after
 *    fmi3Discard, which leaves the instance in Step Mode at the step's start: retry a smaller step);
 *  - every call that returns fmi3Error enters Terminated (the standard's rule for the super state FMU State
 *    Settable), from where fmi3Reset, fmi3SetFMUState or fmi3FreeInstance continue;
 *  - variables: Float64, Int32 (FMI 2.0's Integer), Boolean (C bool, converted to and from the runtime's int) and
 *    String, the runtime's scalars with their FMI 2.0 names and value references; the independent variable `time`
 *    has value reference TIME_VALUE_REFERENCE (flexfmu.fmi.description_fmi3) and reads as the FMU's time;
 *  - Float64 arrays (an FMU built with them, flexfmu.fmi.fmi3_arrays): further views of the runtime's values (3-vectors
 *    of scalars, the modal coordinates and rates of the states, natural frequencies as constants), value references
 *    in a block of their own that the runtime declares (BridgeApi.arrays); this front expands an array's value
 *    reference into its elements' (nValues: a scalar counts 1, an array its elements) and serves the arrays' sizes,
 *    UInt64 structural parameters fixed at build (fmi3GetUInt64; fmi3SetUInt64 in Configuration Mode takes the built
 *    value only);
 *  - the runtime names FMI 2.0 functions in its messages: the logger gets them with their FMI 3.0 names
 *    (fmi2GetReal -> fmi3GetFloat64, fmi2Discard -> fmi3Discard, ...), and with '#' doubled (FMI 3.0 messages
 *    reference variables as #<valueReference>#); the message is not a format, so '%' stays as it is.
 * Every other FMI 3.0 function is present and returns fmi3Error, logging that it is not provided.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi3Functions.h"
#include "front_common.h"

/* the runtime's value types are FMI 2.0's: unsigned int value references, int Integer */
typedef char value_reference_is_unsigned_int[sizeof(fmi3ValueReference) == sizeof(unsigned int) ? 1 : -1];
typedef char int32_is_int[sizeof(fmi3Int32) == sizeof(int) ? 1 : -1];

/* the value reference of the independent variable `time` (flexfmu.fmi.description_fmi3.TIME_VALUE_REFERENCE):
   after any variable's of the runtime, which numbers them from 0 */
#define TIME_VALUE_REFERENCE 2147483647u

/* a step ending this little (relative to the step) after stopTime ends at stopTime: a host's clock is the sum of its
   steps, rounded (the step-size rule's relative tolerance, docs/fmu.md "Step sizes a host passes") */
#define STOP_TIME_RTOL 1e-6

/* ---- states and the call-sequence table ------------------------------------------------------- */

typedef enum {
    Instantiated = 1 << 0,       /* after fmi3InstantiateCoSimulation, fmi3Reset */
    InitializationMode = 1 << 1, /* after fmi3EnterInitializationMode */
    StepMode = 1 << 2,           /* after fmi3ExitInitializationMode, fmi3DoStep (fmi3OK, fmi3Warning, fmi3Discard) */
    Terminated = 1 << 4,         /* after fmi3Terminate, and after any call that returned fmi3Error */
    EventMode = 1 << 5,          /* model exchange: after fmi3ExitInitializationMode, fmi3EnterEventMode */
    ContinuousTimeMode = 1 << 6, /* model exchange: after fmi3EnterContinuousTimeMode */
    ConfigurationMode = 1 << 7,  /* after fmi3EnterConfigurationMode (an FMU with structural parameters) */
} State;

#define ME_MODES (EventMode | ContinuousTimeMode)
#define ALL_STATES (Instantiated | InitializationMode | StepMode | Terminated | ME_MODES | ConfigurationMode)
#define VALUES_READABLE (InitializationMode | StepMode | Terminated | ME_MODES)
#define VALUES_WRITABLE (Instantiated | InitializationMode | StepMode | ME_MODES)
/* the model is made at fmi3ExitInitializationMode: states, derivatives and directional derivatives from there on */
#define MODEL_READABLE (StepMode | Terminated | ME_MODES)

typedef enum {
    F_SetDebugLogging,
    F_FreeInstance,
    F_EnterInitializationMode,
    F_ExitInitializationMode,
    F_EnterEventMode,
    F_Terminate,
    F_Reset,
    F_GetFloat32,
    F_GetFloat64,
    F_GetInt8,
    F_GetUInt8,
    F_GetInt16,
    F_GetUInt16,
    F_GetInt32,
    F_GetUInt32,
    F_GetInt64,
    F_GetUInt64,
    F_GetBoolean,
    F_GetString,
    F_GetBinary,
    F_GetClock,
    F_SetFloat32,
    F_SetFloat64,
    F_SetInt8,
    F_SetUInt8,
    F_SetInt16,
    F_SetUInt16,
    F_SetInt32,
    F_SetUInt32,
    F_SetInt64,
    F_SetUInt64,
    F_SetBoolean,
    F_SetString,
    F_SetBinary,
    F_SetClock,
    F_GetNumberOfVariableDependencies,
    F_GetVariableDependencies,
    F_GetFMUState,
    F_SetFMUState,
    F_FreeFMUState,
    F_SerializedFMUStateSize,
    F_SerializeFMUState,
    F_DeserializeFMUState,
    F_GetDirectionalDerivative,
    F_GetAdjointDerivative,
    F_EnterConfigurationMode,
    F_ExitConfigurationMode,
    F_GetIntervalDecimal,
    F_GetIntervalFraction,
    F_GetShiftDecimal,
    F_GetShiftFraction,
    F_SetIntervalDecimal,
    F_SetIntervalFraction,
    F_SetShiftDecimal,
    F_SetShiftFraction,
    F_EvaluateDiscreteStates,
    F_UpdateDiscreteStates,
    F_EnterContinuousTimeMode,
    F_CompletedIntegratorStep,
    F_SetTime,
    F_SetContinuousStates,
    F_GetContinuousStateDerivatives,
    F_GetEventIndicators,
    F_GetContinuousStates,
    F_GetNominalsOfContinuousStates,
    F_GetNumberOfEventIndicators,
    F_GetNumberOfContinuousStates,
    F_EnterStepMode,
    F_GetOutputDerivatives,
    F_DoStep,
    F_ActivateModelPartition,
    F_COUNT
} Function;

#define NO_TYPE                                                                                                        \
    "not provided: this FMU has variables of the types Float64, Int32, Boolean, String and UInt64 (structural "        \
    "parameters) only"
#define NO_EVENT_MODE "not provided: this FMU has no Event Mode (hasEventMode is false)"
#define NO_CLOCKS "not provided: this FMU has no clocks"
#define NO_SCHEDULED_EXECUTION "not provided: this FMU is for co-simulation only (no scheduled execution)"

/* The one legal-call table (docs/fmu.md prints it): the FMI 3.0 standard's co-simulation state machine without
   Event Mode, Configuration Mode or clocks.  Parameters (variability fixed) are settable only before
   fmi3ExitInitializationMode: the runtime checks that per variable. */
static const FrontCall CALLS[F_COUNT] = {
    [F_SetDebugLogging] = {"fmi3SetDebugLogging", ALL_STATES, NULL},
    [F_FreeInstance] = {"fmi3FreeInstance", ALL_STATES, NULL},
    [F_EnterInitializationMode] = {"fmi3EnterInitializationMode", Instantiated, NULL},
    [F_ExitInitializationMode] = {"fmi3ExitInitializationMode", InitializationMode, NULL},
    [F_EnterEventMode] = {"fmi3EnterEventMode", ME_MODES, NULL}, /* co-simulation: no Event Mode */
    [F_Terminate] = {"fmi3Terminate", StepMode | ME_MODES, NULL},
    [F_Reset] = {"fmi3Reset", ALL_STATES, NULL},
    [F_GetFloat32] = {"fmi3GetFloat32", 0, NO_TYPE},
    [F_GetFloat64] = {"fmi3GetFloat64", VALUES_READABLE, NULL},
    [F_GetInt8] = {"fmi3GetInt8", 0, NO_TYPE},
    [F_GetUInt8] = {"fmi3GetUInt8", 0, NO_TYPE},
    [F_GetInt16] = {"fmi3GetInt16", 0, NO_TYPE},
    [F_GetUInt16] = {"fmi3GetUInt16", 0, NO_TYPE},
    [F_GetInt32] = {"fmi3GetInt32", VALUES_READABLE, NULL},
    [F_GetUInt32] = {"fmi3GetUInt32", 0, NO_TYPE},
    [F_GetInt64] = {"fmi3GetInt64", 0, NO_TYPE},
    [F_GetUInt64] = {"fmi3GetUInt64", VALUES_READABLE | ConfigurationMode, NULL}, /* structural parameters */
    [F_GetBoolean] = {"fmi3GetBoolean", VALUES_READABLE, NULL},
    [F_GetString] = {"fmi3GetString", VALUES_READABLE, NULL},
    [F_GetBinary] = {"fmi3GetBinary", 0, NO_TYPE},
    [F_GetClock] = {"fmi3GetClock", 0, NO_CLOCKS},
    [F_SetFloat32] = {"fmi3SetFloat32", 0, NO_TYPE},
    [F_SetFloat64] = {"fmi3SetFloat64", VALUES_WRITABLE, NULL},
    [F_SetInt8] = {"fmi3SetInt8", 0, NO_TYPE},
    [F_SetUInt8] = {"fmi3SetUInt8", 0, NO_TYPE},
    [F_SetInt16] = {"fmi3SetInt16", 0, NO_TYPE},
    [F_SetUInt16] = {"fmi3SetUInt16", 0, NO_TYPE},
    [F_SetInt32] = {"fmi3SetInt32", VALUES_WRITABLE, NULL},
    [F_SetUInt32] = {"fmi3SetUInt32", 0, NO_TYPE},
    [F_SetInt64] = {"fmi3SetInt64", 0, NO_TYPE},
    [F_SetUInt64] = {"fmi3SetUInt64", ConfigurationMode, NULL},
    [F_SetBoolean] = {"fmi3SetBoolean", VALUES_WRITABLE, NULL},
    [F_SetString] = {"fmi3SetString", VALUES_WRITABLE, NULL},
    [F_SetBinary] = {"fmi3SetBinary", 0, NO_TYPE},
    [F_SetClock] = {"fmi3SetClock", 0, NO_CLOCKS},
    [F_GetNumberOfVariableDependencies]
    = {"fmi3GetNumberOfVariableDependencies", 0, "not provided: this FMU gives no variable dependencies"},
    [F_GetVariableDependencies]
    = {"fmi3GetVariableDependencies", 0, "not provided: this FMU gives no variable dependencies"},
    [F_GetFMUState] = {"fmi3GetFMUState", ALL_STATES, NULL},
    [F_SetFMUState] = {"fmi3SetFMUState", ALL_STATES, NULL},
    [F_FreeFMUState] = {"fmi3FreeFMUState", ALL_STATES, NULL},
    [F_SerializedFMUStateSize] = {"fmi3SerializedFMUStateSize", ALL_STATES, NULL},
    [F_SerializeFMUState] = {"fmi3SerializeFMUState", ALL_STATES, NULL},
    [F_DeserializeFMUState] = {"fmi3DeserializeFMUState", ALL_STATES, NULL},
    [F_GetDirectionalDerivative] = {"fmi3GetDirectionalDerivative", MODEL_READABLE, NULL},
    [F_GetAdjointDerivative] = {"fmi3GetAdjointDerivative", 0, "not provided (providesAdjointDerivatives is false)"},
    [F_EnterConfigurationMode] = {"fmi3EnterConfigurationMode", Instantiated, NULL},
    [F_ExitConfigurationMode] = {"fmi3ExitConfigurationMode", ConfigurationMode, NULL},
    [F_GetIntervalDecimal] = {"fmi3GetIntervalDecimal", 0, NO_CLOCKS},
    [F_GetIntervalFraction] = {"fmi3GetIntervalFraction", 0, NO_CLOCKS},
    [F_GetShiftDecimal] = {"fmi3GetShiftDecimal", 0, NO_CLOCKS},
    [F_GetShiftFraction] = {"fmi3GetShiftFraction", 0, NO_CLOCKS},
    [F_SetIntervalDecimal] = {"fmi3SetIntervalDecimal", 0, NO_CLOCKS},
    [F_SetIntervalFraction] = {"fmi3SetIntervalFraction", 0, NO_CLOCKS},
    [F_SetShiftDecimal] = {"fmi3SetShiftDecimal", 0, NO_CLOCKS},
    [F_SetShiftFraction] = {"fmi3SetShiftFraction", 0, NO_CLOCKS},
    /* model exchange (a co-simulation instance is never in EventMode or ContinuousTimeMode) */
    [F_EvaluateDiscreteStates] = {"fmi3EvaluateDiscreteStates", ME_MODES, NULL},
    [F_UpdateDiscreteStates] = {"fmi3UpdateDiscreteStates", EventMode, NULL},
    [F_EnterContinuousTimeMode] = {"fmi3EnterContinuousTimeMode", EventMode, NULL},
    [F_CompletedIntegratorStep] = {"fmi3CompletedIntegratorStep", ContinuousTimeMode, NULL},
    [F_SetTime] = {"fmi3SetTime", ME_MODES, NULL},
    [F_SetContinuousStates] = {"fmi3SetContinuousStates", ContinuousTimeMode, NULL},
    [F_GetContinuousStateDerivatives] = {"fmi3GetContinuousStateDerivatives", ME_MODES | Terminated, NULL},
    [F_GetEventIndicators] = {"fmi3GetEventIndicators", InitializationMode | ME_MODES | Terminated, NULL},
    [F_GetContinuousStates] = {"fmi3GetContinuousStates", ME_MODES | Terminated, NULL},
    [F_GetNominalsOfContinuousStates] = {"fmi3GetNominalsOfContinuousStates", ALL_STATES, NULL},
    [F_GetNumberOfEventIndicators] = {"fmi3GetNumberOfEventIndicators", ALL_STATES, NULL},
    [F_GetNumberOfContinuousStates] = {"fmi3GetNumberOfContinuousStates", ALL_STATES, NULL},
    [F_EnterStepMode] = {"fmi3EnterStepMode", 0, NO_EVENT_MODE},
    [F_GetOutputDerivatives] = {"fmi3GetOutputDerivatives", 0, "not provided (maxOutputDerivativeOrder is 0)"},
    [F_DoStep] = {"fmi3DoStep", StepMode, NULL},
    [F_ActivateModelPartition] = {"fmi3ActivateModelPartition", 0, NO_SCHEDULED_EXECUTION},
};

static const char *state_name(int state) {
    switch (state) {
    case Instantiated: return "Instantiated";
    case InitializationMode: return "InitializationMode";
    case StepMode: return "StepMode";
    case Terminated: return "Terminated";
    case EventMode: return "EventMode";
    case ContinuousTimeMode: return "ContinuousTimeMode";
    case ConfigurationMode: return "ConfigurationMode";
    default: return "?";
    }
}

/* ---- the instance ------------------------------------------------------------------------------ */

#define INSTANCE_MAGIC 0x33584c46u /* "FLX3": an FMI 2.0 instance (or any other pointer) is refused */

typedef struct {
    FrontInstance front;
    int stop_time_defined; /* fmi3EnterInitializationMode's stopTime: no step ends after it */
    double stop_time;
    const BridgeArrays *arrays; /* the runtime's array variables and structural parameters (none: NULL) */
} Instance;

/* The runtime's FMI 2.0 function names, as FMI 3.0 names them (any other fmi2X is fmi3X). */
static const struct {
    const char *fmi2, *fmi3;
} RENAMED[] = {
    {"fmi2GetReal", "fmi3GetFloat64"},
    {"fmi2SetReal", "fmi3SetFloat64"},
    {"fmi2GetInteger", "fmi3GetInt32"},
    {"fmi2SetInteger", "fmi3SetInt32"},
    {"fmi2Instantiate", "fmi3InstantiateCoSimulation"},
    {"fmi2SetupExperiment", "fmi3EnterInitializationMode"},
    {"fmi2GetFMUstate", "fmi3GetFMUState"},
    {"fmi2SetFMUstate", "fmi3SetFMUState"},
    {"fmi2FreeFMUstate", "fmi3FreeFMUState"},
    {"fmi2SerializedFMUstateSize", "fmi3SerializedFMUStateSize"},
    {"fmi2SerializeFMUstate", "fmi3SerializeFMUState"},
    {"fmi2DeSerializeFMUstate", "fmi3DeserializeFMUState"},
};

/* The runtime's FMI 2.0 type names in its messages ("value reference 3 is 'x', a Real variable"). */
static const struct {
    const char *fmi2, *fmi3;
} RETYPED[] = {{"a Real variable", "a Float64 variable"}, {"a Integer variable", "an Int32 variable"}};

#define LONGEST_GROWTH 16 /* the most a renamed name or type is longer than its FMI 2.0 form */

static int identifier_char(char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_';
}

/* `message` with FMI 3.0's names and '#' doubled, in malloc'ed memory (NULL when out of memory). */
static char *fmi3_text(const char *message) {
    size_t n = strlen(message), marks = 0;
    for (const char *p = strstr(message, "fmi2"); p; p = strstr(p + 4, "fmi2")) marks++;
    for (size_t k = 0; k < sizeof RETYPED / sizeof *RETYPED; k++)
        for (const char *p = strstr(message, RETYPED[k].fmi2); p; p = strstr(p + 1, RETYPED[k].fmi2)) marks++;
    char *text = malloc(2 * n + LONGEST_GROWTH * marks + 1);
    if (!text) return NULL;
    char *out = text;
    for (size_t i = 0; i < n;) {
        const char *at = message + i;
        size_t taken = 0;
        for (size_t k = 0; !taken && k < sizeof RETYPED / sizeof *RETYPED; k++) {
            size_t length = strlen(RETYPED[k].fmi2);
            if (strncmp(at, RETYPED[k].fmi2, length) == 0) {
                out += strlen(strcpy(out, RETYPED[k].fmi3));
                taken = length;
            }
        }
        if (!taken && strncmp(at, "fmi2", 4) == 0 && (i == 0 || !identifier_char(at[-1]))) {
            size_t length = 4;
            while (identifier_char(at[length])) length++;
            const char *renamed = NULL;
            for (size_t k = 0; !renamed && k < sizeof RENAMED / sizeof *RENAMED; k++)
                if (strlen(RENAMED[k].fmi2) == length && strncmp(at, RENAMED[k].fmi2, length) == 0)
                    renamed = RENAMED[k].fmi3;
            if (renamed) {
                out += strlen(strcpy(out, renamed));
            } else {
                memcpy(out, "fmi3", 4);
                memcpy(out + 4, at + 4, length - 4);
                out += length;
            }
            taken = length;
        }
        if (!taken) {
            if (*at == '#') *out++ = '#';
            *out++ = *at;
            taken = 1;
        }
        i += taken;
    }
    *out = '\0';
    return text;
}

static void deliver(const FrontInstance *inst, int status, const char *category, const char *message) {
    char *text = fmi3_text(message);
    ((fmi3LogMessageCallback)inst->logger)(inst->environment, (fmi3Status)status, category, text ? text : message);
    free(text);
}

static const FrontVersion FMI3 = {.magic = INSTANCE_MAGIC,
                                  .all_states = ALL_STATES,
                                  .error_state = Terminated,
                                  .every_error = 1,
                                  .me_states = ME_MODES,
                                  .cs_states = StepMode,
                                  .error_name = "fmi3Error",
                                  .serialized_size_name = "fmi3SerializedFMUStateSize",
                                  .state_name = state_name,
                                  .deliver = deliver};

/* Check the instance pointer and the call sequence; lock the instance.  NULL: refused (return fmi3Error). */
static Instance *enter(fmi3Instance instance, Function f) {
    return (Instance *)front_enter(instance, &FMI3, &CALLS[f]);
}

static fmi3Status leave(Instance *inst, int status) { return (fmi3Status)front_leave(&inst->front, status); }

static int fail(Instance *inst, Function f, const char *why) { return front_fail(&inst->front, CALLS[f].name, why); }

/* A function this FMU does not provide: refused in every state, naming it. */
static fmi3Status not_provided(fmi3Instance instance, Function f) {
    enter(instance, f);
    return fmi3Error;
}

/* ---- FMI 3.0: common functions ----------------------------------------------------------------- */

const char *fmi3GetVersion(void) { return fmi3Version; }

fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean loggingOn, size_t nCategories,
                               const fmi3String categories[]) {
    Instance *inst = enter(instance, F_SetDebugLogging);
    if (!inst) return fmi3Error;
    return leave(
        inst, front_set_debug_logging(&inst->front, CALLS[F_SetDebugLogging].name, loggingOn, nCategories, categories));
}

/* Instantiation functions of other interface types: refused through the host's logger (no instance exists). */
static fmi3Instance not_instantiated(const char *function, const char *why, fmi3InstanceEnvironment environment,
                                     fmi3LogMessageCallback logMessage) {
    char message[256];
    snprintf(message, sizeof message, "%s: %s", function, why);
    if (logMessage) logMessage(environment, fmi3Error, "logStatusError", message);
    return NULL;
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName, fmi3String instantiationToken,
                                          fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                          fmi3InstanceEnvironment instanceEnvironment,
                                          fmi3LogMessageCallback logMessage) {
    static const char *name = "fmi3InstantiateModelExchange";
    Instance *inst = (Instance *)front_new_instance(&FMI3, sizeof *inst, Instantiated, instanceName, instantiationToken,
                                                    loggingOn, (FrontLogger)logMessage, instanceEnvironment);
    if (!inst) return NULL;
    FrontInstance *front = &inst->front;
    front->model_exchange = 1;
    char resources[4096];
    if (front_resources_from_path(resourcePath, resources, sizeof resources) < 0) {
        front_fail(front, name,
                   "resourcePath: neither it (the resources folder of the extracted FMU) nor the folder next to "
                   "this binary holds the FMU's resources (resources/flexfmu_build.json)");
    } else if (front_instantiate_slave(front, name, resources, visible) == 0) {
        if (front->bridge->model_exchange(front->slave, name) == BRIDGE_OK) {
            inst->arrays = front->bridge->arrays(front->slave);
            return inst;
        }
        front->bridge->free_instance(front->slave);
    }
    front_free_instance_memory(front);
    return NULL;
}

fmi3Instance fmi3InstantiateScheduledExecution(fmi3String instanceName, fmi3String instantiationToken,
                                               fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                               fmi3InstanceEnvironment instanceEnvironment,
                                               fmi3LogMessageCallback logMessage, fmi3ClockUpdateCallback clockUpdate,
                                               fmi3LockPreemptionCallback lockPreemption,
                                               fmi3UnlockPreemptionCallback unlockPreemption) {
    (void)instanceName, (void)instantiationToken, (void)resourcePath, (void)visible, (void)loggingOn;
    (void)clockUpdate, (void)lockPreemption, (void)unlockPreemption;
    return not_instantiated("fmi3InstantiateScheduledExecution", NO_SCHEDULED_EXECUTION, instanceEnvironment,
                            logMessage);
}

fmi3Instance fmi3InstantiateCoSimulation(fmi3String instanceName, fmi3String instantiationToken,
                                         fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                         fmi3Boolean eventModeUsed, fmi3Boolean earlyReturnAllowed,
                                         const fmi3ValueReference requiredIntermediateVariables[],
                                         size_t nRequiredIntermediateVariables,
                                         fmi3InstanceEnvironment instanceEnvironment, fmi3LogMessageCallback logMessage,
                                         fmi3IntermediateUpdateCallback intermediateUpdate) {
    /* earlyReturnAllowed: fmi3DoStep never returns early; intermediateUpdate: never called (no intermediate
       variables) */
    (void)earlyReturnAllowed, (void)requiredIntermediateVariables, (void)intermediateUpdate;
    static const char *name = "fmi3InstantiateCoSimulation";
    Instance *inst = (Instance *)front_new_instance(&FMI3, sizeof *inst, Instantiated, instanceName, instantiationToken,
                                                    loggingOn, (FrontLogger)logMessage, instanceEnvironment);
    if (!inst) return NULL;
    FrontInstance *front = &inst->front;
    char resources[4096];
    if (eventModeUsed) {
        front_fail(front, name,
                   "eventModeUsed: this FMU has no Event Mode (hasEventMode is false); "
                   "instantiate it with eventModeUsed = false");
    } else if (nRequiredIntermediateVariables > 0) {
        front_fail(front, name,
                   "requiredIntermediateVariables: this FMU has no intermediate update (no variable has "
                   "intermediateUpdate = true); pass none");
    } else if (front_resources_from_path(resourcePath, resources, sizeof resources) < 0) {
        front_fail(front, name,
                   "resourcePath: neither it (the resources folder of the extracted FMU) nor the folder next to "
                   "this binary holds the FMU's resources (resources/flexfmu_build.json)");
    } else if (front_instantiate_slave(front, name, resources, visible) == 0) {
        inst->arrays = front->bridge->arrays(front->slave);
        return inst;
    }
    front_free_instance_memory(front);
    return NULL;
}

void fmi3FreeInstance(fmi3Instance instance) {
    Instance *inst = enter(instance, F_FreeInstance);
    if (!inst) return;
    inst->front.bridge->free_instance(inst->front.slave);
    front_unlock(&inst->front);
    front_free_instance_memory(&inst->front);
}

/* ---- FMI 3.0: initialisation, termination, reset ----------------------------------------------- */

fmi3Status fmi3EnterInitializationMode(fmi3Instance instance, fmi3Boolean toleranceDefined, fmi3Float64 tolerance,
                                       fmi3Float64 startTime, fmi3Boolean stopTimeDefined, fmi3Float64 stopTime) {
    Instance *inst = enter(instance, F_EnterInitializationMode);
    if (!inst) return fmi3Error;
    FrontInstance *front = &inst->front;
    int status = front_setup_experiment(front, CALLS[F_EnterInitializationMode].name, toleranceDefined, tolerance,
                                        startTime, stopTimeDefined, stopTime);
    if (status <= BRIDGE_WARNING) {
        int entered = front->bridge->simple_call(front->slave, CALL_ENTER_INITIALIZATION_MODE);
        if (entered > status) status = entered;
    }
    if (status <= BRIDGE_WARNING) {
        front->state = InitializationMode;
        inst->stop_time_defined = stopTimeDefined;
        inst->stop_time = stopTime;
    }
    return leave(inst, status);
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance instance) {
    Instance *inst = enter(instance, F_ExitInitializationMode);
    if (!inst) return fmi3Error;
    int status = inst->front.bridge->simple_call(inst->front.slave, CALL_EXIT_INITIALIZATION_MODE);
    if (status <= BRIDGE_WARNING) inst->front.state = inst->front.model_exchange ? EventMode : StepMode;
    return leave(inst, status);
}

fmi3Status fmi3Terminate(fmi3Instance instance) {
    Instance *inst = enter(instance, F_Terminate);
    if (!inst) return fmi3Error;
    int status = inst->front.bridge->simple_call(inst->front.slave, CALL_TERMINATE);
    if (status <= BRIDGE_WARNING) inst->front.state = Terminated;
    return leave(inst, status);
}

fmi3Status fmi3Reset(fmi3Instance instance) {
    Instance *inst = enter(instance, F_Reset);
    if (!inst) return fmi3Error;
    int status = inst->front.bridge->simple_call(inst->front.slave, CALL_RESET);
    if (status <= BRIDGE_WARNING) {
        inst->front.state = Instantiated;
        inst->stop_time_defined = 0;
    }
    return leave(inst, status);
}

fmi3Status fmi3EnterEventMode(fmi3Instance instance) {
    Instance *inst = enter(instance, F_EnterEventMode);
    if (!inst) return fmi3Error;
    inst->front.state = EventMode;
    return leave(inst, fmi3OK);
}

/* ---- FMI 3.0: getting and setting variable values ---------------------------------------------- */

/* The array variable (size_of: the structural parameter) with value reference `vr`, or NULL.  Every runtime value
   reference is below `lowest`: a scalar costs one comparison. */
static const BridgeArray *array_of(const Instance *inst, unsigned int vr) {
    const BridgeArrays *a = inst->arrays;
    if (!a || vr < a->lowest) return NULL;
    for (size_t k = 0; k < a->n_arrays; k++)
        if (a->arrays[k].vr == vr) return &a->arrays[k];
    return NULL;
}

static const BridgeSize *size_of(const Instance *inst, unsigned int vr) {
    const BridgeArrays *a = inst->arrays;
    if (!a || vr < a->lowest) return NULL;
    for (size_t k = 0; k < a->n_sizes; k++)
        if (a->sizes[k].vr == vr) return &a->sizes[k];
    return NULL;
}

static int has_views(const Instance *inst) { return inst->arrays && (inst->arrays->n_arrays || inst->arrays->n_sizes); }

/* nValues is the number of the variables' values (FMI 3.0: a scalar 1, an array its elements); `time`, the arrays
   (Float64) and the structural parameters (UInt64) only through their own type.  *arrays: an array is among them. */
static int check_values(Instance *inst, Function f, BridgeValueType type, const fmi3ValueReference vr[], size_t nvr,
                        const void *values, size_t nValues, int *arrays) {
    *arrays = 0;
    if (!vr || !values) return fail(inst, f, "valueReferences or values is NULL");
    const char *verb = f < F_SetFloat32 ? "Get" : "Set";
    size_t expected = nvr;
    for (size_t i = 0; (type != VALUE_REAL || has_views(inst)) && i < nvr; i++) {
        char why[300];
        const BridgeArray *a = array_of(inst, vr[i]);
        const BridgeSize *s = a ? NULL : size_of(inst, vr[i]);
        if (vr[i] == TIME_VALUE_REFERENCE && type != VALUE_REAL) {
            snprintf(why, sizeof why, "value reference %u is 'time', a Float64 variable; use fmi3%sFloat64",
                     TIME_VALUE_REFERENCE, verb);
            return fail(inst, f, why);
        }
        if (a && type != VALUE_REAL) {
            snprintf(why, sizeof why, "value reference %u is '%s', a Float64 array; use fmi3%sFloat64", vr[i], a->name,
                     verb);
            return fail(inst, f, why);
        }
        if (s) {
            snprintf(why, sizeof why, "value reference %u is '%s', a UInt64 structural parameter; use fmi3%sUInt64",
                     vr[i], s->name, verb);
            return fail(inst, f, why);
        }
        if (a) expected += a->size - 1, *arrays = 1;
    }
    if (nValues != expected) {
        char why[300];
        if (inst->arrays && inst->arrays->n_arrays)
            snprintf(why, sizeof why,
                     "nValues: got %zu for %zu value references (their variables hold %zu values: a scalar one, an "
                     "array its elements)",
                     nValues, nvr, expected);
        else
            snprintf(why, sizeof why,
                     "nValues: got %zu for %zu value references (this FMU has no array variables: one "
                     "value per value reference)",
                     nValues, nvr);
        return fail(inst, f, why);
    }
    return BRIDGE_OK;
}

/* fmi3GetFloat64 with `time` among the value references: the others from the runtime, time from its clock. */
static int get_with_time(Instance *inst, const fmi3ValueReference vr[], size_t nvr, double values[]) {
    FrontInstance *front = &inst->front;
    unsigned int *others = malloc(nvr * sizeof *others);
    double *got = malloc(nvr * sizeof *got), now = 0.0;
    if (!others || !got) {
        free(others), free(got);
        return fail(inst, F_GetFloat64, "out of memory");
    }
    size_t n = 0;
    for (size_t i = 0; i < nvr; i++)
        if (vr[i] != TIME_VALUE_REFERENCE) others[n++] = vr[i];
    int status = n ? front->bridge->get_values(front->slave, VALUE_REAL, others, n, got) : BRIDGE_OK;
    if (status <= BRIDGE_WARNING) {
        int timed = front->bridge->last_successful_time(front->slave, &now);
        if (timed > status) status = timed;
    }
    if (status <= BRIDGE_WARNING)
        for (size_t i = 0, k = 0; i < nvr; i++) values[i] = vr[i] == TIME_VALUE_REFERENCE ? now : got[k++];
    free(others), free(got);
    return status;
}

/* Float64 values of scalars: the runtime's, `time` from the clock. */
static int get_scalars(Instance *inst, const fmi3ValueReference vr[], size_t nvr, double values[]) {
    for (size_t i = 0; i < nvr; i++)
        if (vr[i] == TIME_VALUE_REFERENCE) return get_with_time(inst, vr, nvr, values);
    return inst->front.bridge->get_values(inst->front.slave, VALUE_REAL, vr, nvr, values);
}

/* An array's view, expanded: value reference i at values[at[i]] (scalars, and the elements that are runtime values;
   constants are written at once).  n: the values (nValues, checked).  Returns the number of references. */
static size_t expand(const Instance *inst, const fmi3ValueReference vr[], size_t nvr, unsigned int *refs, size_t *at,
                     double *values) {
    size_t m = 0, position = 0;
    for (size_t i = 0; i < nvr; i++) {
        const BridgeArray *a = array_of(inst, vr[i]);
        if (!a) {
            refs[m] = vr[i], at[m++] = position++;
            continue;
        }
        for (size_t k = 0; k < a->size; k++, position++) {
            if (a->element[k] < 0) {
                if (values) values[position] = a->value[k];
            } else {
                refs[m] = (unsigned int)a->element[k], at[m++] = position;
            }
        }
    }
    return m;
}

/* fmi3GetFloat64 with arrays among the value references: their elements read with the scalars in one runtime call. */
static int get_arrays(Instance *inst, const fmi3ValueReference vr[], size_t nvr, double values[], size_t n) {
    unsigned int *refs = malloc(n * sizeof *refs);
    size_t *at = malloc(n * sizeof *at);
    double *got = malloc(n * sizeof *got);
    int status = BRIDGE_OK;
    if (!refs || !at || !got) {
        status = fail(inst, F_GetFloat64, "out of memory");
    } else {
        size_t m = expand(inst, vr, nvr, refs, at, values);
        status = m ? get_scalars(inst, refs, m, got) : BRIDGE_OK;
        for (size_t j = 0; status <= BRIDGE_WARNING && j < m; j++) values[at[j]] = got[j];
    }
    free(refs), free(at), free(got);
    return status;
}

/* fmi3SetFloat64 with arrays among the value references: only input arrays, each element set as its scalar; an input
   given twice in one call (an array and its scalar, or two arrays) with two values is refused (which one should
   hold?).  The runtime checks the values and names the scalar behind a refused element. */
static int set_arrays(Instance *inst, const fmi3ValueReference vr[], size_t nvr, const double values[], size_t n) {
    char why[400];
    for (size_t i = 0; i < nvr; i++) {
        const BridgeArray *a = array_of(inst, vr[i]);
        if (a && !a->input) {
            snprintf(why, sizeof why, "'%s' (value reference %u) is an output; outputs cannot be set", a->name, vr[i]);
            return fail(inst, F_SetFloat64, why);
        }
    }
    unsigned int *refs = malloc(n * sizeof *refs);
    size_t *at = malloc(n * sizeof *at), *element = malloc(n * sizeof *element);
    double *given = malloc(n * sizeof *given);
    const BridgeArray **from = malloc(n * sizeof *from); /* per value: its array (NULL: a scalar) and element */
    int status = BRIDGE_OK;
    if (!refs || !at || !element || !given || !from) {
        free(refs), free(at), free(element), free(given), free(from);
        return fail(inst, F_SetFloat64, "out of memory");
    }
    size_t m = expand(inst, vr, nvr, refs, at, NULL), position = 0;
    for (size_t i = 0; i < nvr; i++) {
        const BridgeArray *a = array_of(inst, vr[i]);
        for (size_t k = 0; k < (a ? a->size : 1); k++, position++) from[position] = a, element[position] = k;
    }
    for (size_t j = 0; j < m; j++) given[j] = values[at[j]];
    for (size_t j = 0; status == BRIDGE_OK && j < m; j++) {
        for (size_t q = 0; from[at[j]] && q < m; q++) {
            if (q == j || refs[q] != refs[j] || given[q] == given[j]) continue;
            char other[160];
            if (from[at[q]])
                snprintf(other, sizeof other, "element %zu of '%s'", element[at[q]], from[at[q]]->name);
            else
                snprintf(other, sizeof other, "value reference %u", refs[q]);
            snprintf(why, sizeof why,
                     "element %zu of '%s' (%.17g) and %s (%.17g) are one input (value reference %u), given two "
                     "values in one call; set it through one of its views",
                     element[at[j]], from[at[j]]->name, given[j], other, given[q], refs[j]);
            status = fail(inst, F_SetFloat64, why);
            break;
        }
    }
    if (status == BRIDGE_OK) status = inst->front.bridge->set_values(inst->front.slave, VALUE_REAL, refs, m, given);
    free(refs), free(at), free(element), free(given), free(from);
    return status;
}

static fmi3Status get_values(fmi3Instance instance, Function f, BridgeValueType type, const fmi3ValueReference vr[],
                             size_t nvr, void *values, size_t nValues) {
    Instance *inst = enter(instance, f);
    if (!inst) return fmi3Error;
    if (nvr == 0) return leave(inst, fmi3OK);
    int arrays, status = check_values(inst, f, type, vr, nvr, values, nValues, &arrays);
    if (status != BRIDGE_OK) return leave(inst, status);
    FrontInstance *front = &inst->front;
    if (type == VALUE_REAL) {
        return leave(inst, arrays ? get_arrays(inst, vr, nvr, values, nValues) : get_scalars(inst, vr, nvr, values));
    } else if (type == VALUE_BOOLEAN) { /* the runtime's booleans are int */
        int *got = malloc(nvr * sizeof *got);
        if (!got) return leave(inst, fail(inst, f, "out of memory"));
        status = front->bridge->get_values(front->slave, type, vr, nvr, got);
        if (status <= BRIDGE_WARNING)
            for (size_t i = 0; i < nvr; i++) ((fmi3Boolean *)values)[i] = got[i] != 0;
        free(got);
        return leave(inst, status);
    }
    return leave(inst, front->bridge->get_values(front->slave, type, vr, nvr, values));
}

static fmi3Status set_values(fmi3Instance instance, Function f, BridgeValueType type, const fmi3ValueReference vr[],
                             size_t nvr, const void *values, size_t nValues) {
    Instance *inst = enter(instance, f);
    if (!inst) return fmi3Error;
    if (nvr == 0) return leave(inst, fmi3OK);
    int arrays, status = check_values(inst, f, type, vr, nvr, values, nValues, &arrays);
    if (status != BRIDGE_OK) return leave(inst, status);
    FrontInstance *front = &inst->front;
    for (size_t i = 0; type == VALUE_REAL && i < nvr; i++)
        if (vr[i] == TIME_VALUE_REFERENCE) {
            char why[200];
            snprintf(why, sizeof why,
                     "value reference %u is 'time', the independent variable: it cannot be set (fmi3DoStep "
                     "advances it)",
                     TIME_VALUE_REFERENCE);
            return leave(inst, fail(inst, f, why));
        }
    if (arrays) return leave(inst, set_arrays(inst, vr, nvr, values, nValues));
    if (type == VALUE_BOOLEAN) { /* the runtime's booleans are int */
        int *given = malloc(nvr * sizeof *given);
        if (!given) return leave(inst, fail(inst, f, "out of memory"));
        for (size_t i = 0; i < nvr; i++) given[i] = ((const fmi3Boolean *)values)[i] ? 1 : 0;
        status = front->bridge->set_values(front->slave, type, vr, nvr, given);
        free(given);
        return leave(inst, status);
    }
    return leave(inst, front->bridge->set_values(front->slave, type, vr, nvr, values));
}

fmi3Status fmi3GetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                          fmi3Float64 values[], size_t nValues) {
    return get_values(instance, F_GetFloat64, VALUE_REAL, valueReferences, nValueReferences, values, nValues);
}
fmi3Status fmi3GetInt32(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        fmi3Int32 values[], size_t nValues) {
    return get_values(instance, F_GetInt32, VALUE_INTEGER, valueReferences, nValueReferences, values, nValues);
}
fmi3Status fmi3GetBoolean(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                          fmi3Boolean values[], size_t nValues) {
    return get_values(instance, F_GetBoolean, VALUE_BOOLEAN, valueReferences, nValueReferences, values, nValues);
}
fmi3Status fmi3GetString(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         fmi3String values[], size_t nValues) {
    return get_values(instance, F_GetString, VALUE_STRING, valueReferences, nValueReferences, (void *)values, nValues);
}
fmi3Status fmi3SetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                          const fmi3Float64 values[], size_t nValues) {
    return set_values(instance, F_SetFloat64, VALUE_REAL, valueReferences, nValueReferences, values, nValues);
}
fmi3Status fmi3SetInt32(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        const fmi3Int32 values[], size_t nValues) {
    return set_values(instance, F_SetInt32, VALUE_INTEGER, valueReferences, nValueReferences, values, nValues);
}
fmi3Status fmi3SetBoolean(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                          const fmi3Boolean values[], size_t nValues) {
    return set_values(instance, F_SetBoolean, VALUE_BOOLEAN, valueReferences, nValueReferences, values, nValues);
}
fmi3Status fmi3SetString(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         const fmi3String values[], size_t nValues) {
    return set_values(instance, F_SetString, VALUE_STRING, valueReferences, nValueReferences, (const void *)values,
                      nValues);
}

/* ---- FMI 3.0: structural parameters (UInt64, fixed at build: the arrays' sizes) ---------------- */

/* Every value reference is a structural parameter's, one value each; else a refusal naming what it is. */
static int check_sizes(Instance *inst, Function f, const fmi3ValueReference vr[], size_t nvr, const void *values,
                       size_t nValues) {
    if (!vr || !values) return fail(inst, f, "valueReferences or values is NULL");
    char why[400];
    if (nValues != nvr) {
        snprintf(why, sizeof why, "nValues: got %zu for %zu value references (the UInt64 variables are scalars)",
                 nValues, nvr);
        return fail(inst, f, why);
    }
    const char *verb = f == F_GetUInt64 ? "Get" : "Set";
    for (size_t i = 0; i < nvr; i++) {
        if (size_of(inst, vr[i])) continue;
        const BridgeArray *a = array_of(inst, vr[i]);
        if (vr[i] == TIME_VALUE_REFERENCE || a) {
            snprintf(why, sizeof why, "value reference %u is '%s', a Float64 %s; use fmi3%sFloat64", vr[i],
                     a ? a->name : "time", a ? "array" : "variable", verb);
            return fail(inst, f, why);
        }
        const BridgeArrays *all = inst->arrays;
        size_t used
            = (size_t)snprintf(why, sizeof why, "value reference %u is not a UInt64 variable (this FMU's: ", vr[i]);
        for (size_t k = 0; all && k < all->n_sizes && used < sizeof why; k++)
            used += (size_t)snprintf(why + used, sizeof why - used, "%s%u '%s'", k ? ", " : "", all->sizes[k].vr,
                                     all->sizes[k].name);
        if (used < sizeof why)
            snprintf(why + used, sizeof why - used, "%s)", all && all->n_sizes ? "" : "none: no structural parameters");
        return fail(inst, f, why);
    }
    return BRIDGE_OK;
}

fmi3Status fmi3GetUInt64(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         fmi3UInt64 values[], size_t nValues) {
    Instance *inst = enter(instance, F_GetUInt64);
    if (!inst) return fmi3Error;
    if (nValueReferences == 0) return leave(inst, fmi3OK);
    int status = check_sizes(inst, F_GetUInt64, valueReferences, nValueReferences, values, nValues);
    for (size_t i = 0; status == BRIDGE_OK && i < nValueReferences; i++)
        values[i] = size_of(inst, valueReferences[i])->value;
    return leave(inst, status);
}

/* Configuration Mode: a structural parameter takes its build value only (the model file, and the arrays, were made
   for it); another value is refused naming the parameter, its value and how to get another (BridgeSize.fixed). */
fmi3Status fmi3SetUInt64(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         const fmi3UInt64 values[], size_t nValues) {
    Instance *inst = enter(instance, F_SetUInt64);
    if (!inst) return fmi3Error;
    if (nValueReferences == 0) return leave(inst, fmi3OK);
    int status = check_sizes(inst, F_SetUInt64, valueReferences, nValueReferences, values, nValues);
    for (size_t i = 0; status == BRIDGE_OK && i < nValueReferences; i++) {
        const BridgeSize *s = size_of(inst, valueReferences[i]);
        if (values[i] == s->value) continue;
        char why[1200];
        snprintf(why, sizeof why, "%s: got %llu, but this FMU was built with %s = %llu, %s", s->name,
                 (unsigned long long)values[i], s->name, (unsigned long long)s->value, s->fixed);
        status = fail(inst, F_SetUInt64, why);
    }
    return leave(inst, status);
}

/* ---- FMI 3.0: FMU state (front_common.c: the box, the serialised header and their checks) ------ */

fmi3Status fmi3GetFMUState(fmi3Instance instance, fmi3FMUState *FMUState) {
    Instance *inst = enter(instance, F_GetFMUState);
    if (!inst) return fmi3Error;
    return leave(inst, front_get_state(&inst->front, CALLS[F_GetFMUState].name, FMUState));
}

fmi3Status fmi3SetFMUState(fmi3Instance instance, fmi3FMUState FMUState) {
    Instance *inst = enter(instance, F_SetFMUState);
    if (!inst) return fmi3Error;
    return leave(inst, front_set_state(&inst->front, CALLS[F_SetFMUState].name, FMUState));
}

fmi3Status fmi3FreeFMUState(fmi3Instance instance, fmi3FMUState *FMUState) {
    Instance *inst = enter(instance, F_FreeFMUState);
    if (!inst) return fmi3Error;
    return leave(inst, front_free_state(&inst->front, CALLS[F_FreeFMUState].name, FMUState));
}

fmi3Status fmi3SerializedFMUStateSize(fmi3Instance instance, fmi3FMUState FMUState, size_t *size) {
    Instance *inst = enter(instance, F_SerializedFMUStateSize);
    if (!inst) return fmi3Error;
    return leave(inst, front_serialized_state_size(&inst->front, CALLS[F_SerializedFMUStateSize].name, FMUState, size));
}

fmi3Status fmi3SerializeFMUState(fmi3Instance instance, fmi3FMUState FMUState, fmi3Byte serializedState[],
                                 size_t size) {
    Instance *inst = enter(instance, F_SerializeFMUState);
    if (!inst) return fmi3Error;
    return leave(inst, front_serialize_state(&inst->front, CALLS[F_SerializeFMUState].name, FMUState,
                                             (char *)serializedState, size));
}

fmi3Status fmi3DeserializeFMUState(fmi3Instance instance, const fmi3Byte serializedState[], size_t size,
                                   fmi3FMUState *FMUState) {
    Instance *inst = enter(instance, F_DeserializeFMUState);
    if (!inst) return fmi3Error;
    return leave(inst, front_deserialize_state(&inst->front, CALLS[F_DeserializeFMUState].name,
                                               (const char *)serializedState, size, FMUState));
}

/* ---- FMI 3.0: co-simulation -------------------------------------------------------------------- */

fmi3Status fmi3DoStep(fmi3Instance instance, fmi3Float64 currentCommunicationPoint, fmi3Float64 communicationStepSize,
                      fmi3Boolean noSetFMUStatePriorToCurrentPoint, fmi3Boolean *eventHandlingNeeded,
                      fmi3Boolean *terminateSimulation, fmi3Boolean *earlyReturn, fmi3Float64 *lastSuccessfulTime) {
    (void)noSetFMUStatePriorToCurrentPoint;
    Instance *inst = enter(instance, F_DoStep);
    if (!inst) return fmi3Error;
    FrontInstance *front = &inst->front;
    double h = communicationStepSize;
    int status;
    if (!eventHandlingNeeded || !terminateSimulation || !earlyReturn || !lastSuccessfulTime)
        return leave(inst, fail(inst, F_DoStep,
                                "eventHandlingNeeded, terminateSimulation, earlyReturn or lastSuccessfulTime is NULL"));
    *eventHandlingNeeded = fmi3False; /* no events */
    *terminateSimulation = fmi3False; /* the FMU never asks the importer to stop */
    *earlyReturn = fmi3False;         /* every step is taken whole, or refused */
    if (!isfinite(currentCommunicationPoint)) {
        status = fail(inst, F_DoStep, "currentCommunicationPoint is not finite (allowed: the FMU's time)");
    } else if (!(isfinite(h) && h > 0)) {
        status = fail(inst, F_DoStep, "communicationStepSize must be finite and > 0 s");
    } else if (inst->stop_time_defined && currentCommunicationPoint + h > inst->stop_time + STOP_TIME_RTOL * h) {
        char why[300];
        snprintf(why, sizeof why,
                 "communicationStepSize: the step from %.17g s by %.17g s ends after stopTime = %.17g s "
                 "(fmi3EnterInitializationMode); allowed: steps ending at stopTime or before",
                 currentCommunicationPoint, h, inst->stop_time);
        status = fail(inst, F_DoStep, why);
    } else {
        status = front->bridge->do_step(front->slave, currentCommunicationPoint, h);
    }
    double reached = currentCommunicationPoint;
    if (front->bridge->last_successful_time(front->slave, &reached) <= BRIDGE_WARNING) *lastSuccessfulTime = reached;
    return leave(inst, status);
}

/* ---- FMI 3.0: what these FMUs do not provide --------------------------------------------------- */

fmi3Status fmi3GetFloat32(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                          fmi3Float32 values[], size_t nValues) {
    (void)valueReferences, (void)nValueReferences, (void)values, (void)nValues;
    return not_provided(instance, F_GetFloat32);
}
fmi3Status fmi3GetInt8(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                       fmi3Int8 values[], size_t nValues) {
    (void)valueReferences, (void)nValueReferences, (void)values, (void)nValues;
    return not_provided(instance, F_GetInt8);
}
fmi3Status fmi3GetUInt8(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        fmi3UInt8 values[], size_t nValues) {
    (void)valueReferences, (void)nValueReferences, (void)values, (void)nValues;
    return not_provided(instance, F_GetUInt8);
}
fmi3Status fmi3GetInt16(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        fmi3Int16 values[], size_t nValues) {
    (void)valueReferences, (void)nValueReferences, (void)values, (void)nValues;
    return not_provided(instance, F_GetInt16);
}
fmi3Status fmi3GetUInt16(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         fmi3UInt16 values[], size_t nValues) {
    (void)valueReferences, (void)nValueReferences, (void)values, (void)nValues;
    return not_provided(instance, F_GetUInt16);
}
fmi3Status fmi3GetUInt32(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         fmi3UInt32 values[], size_t nValues) {
    (void)valueReferences, (void)nValueReferences, (void)values, (void)nValues;
    return not_provided(instance, F_GetUInt32);
}
fmi3Status fmi3GetInt64(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        fmi3Int64 values[], size_t nValues) {
    (void)valueReferences, (void)nValueReferences, (void)values, (void)nValues;
    return not_provided(instance, F_GetInt64);
}
fmi3Status fmi3GetBinary(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         size_t valueSizes[], fmi3Binary values[], size_t nValues) {
    (void)valueReferences, (void)nValueReferences, (void)valueSizes, (void)values, (void)nValues;
    return not_provided(instance, F_GetBinary);
}
fmi3Status fmi3GetClock(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        fmi3Clock values[]) {
    (void)valueReferences, (void)nValueReferences, (void)values;
    return not_provided(instance, F_GetClock);
}
fmi3Status fmi3SetFloat32(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                          const fmi3Float32 values[], size_t nValues) {
    (void)valueReferences, (void)nValueReferences, (void)values, (void)nValues;
    return not_provided(instance, F_SetFloat32);
}
fmi3Status fmi3SetInt8(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                       const fmi3Int8 values[], size_t nValues) {
    (void)valueReferences, (void)nValueReferences, (void)values, (void)nValues;
    return not_provided(instance, F_SetInt8);
}
fmi3Status fmi3SetUInt8(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        const fmi3UInt8 values[], size_t nValues) {
    (void)valueReferences, (void)nValueReferences, (void)values, (void)nValues;
    return not_provided(instance, F_SetUInt8);
}
fmi3Status fmi3SetInt16(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        const fmi3Int16 values[], size_t nValues) {
    (void)valueReferences, (void)nValueReferences, (void)values, (void)nValues;
    return not_provided(instance, F_SetInt16);
}
fmi3Status fmi3SetUInt16(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         const fmi3UInt16 values[], size_t nValues) {
    (void)valueReferences, (void)nValueReferences, (void)values, (void)nValues;
    return not_provided(instance, F_SetUInt16);
}
fmi3Status fmi3SetUInt32(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         const fmi3UInt32 values[], size_t nValues) {
    (void)valueReferences, (void)nValueReferences, (void)values, (void)nValues;
    return not_provided(instance, F_SetUInt32);
}
fmi3Status fmi3SetInt64(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        const fmi3Int64 values[], size_t nValues) {
    (void)valueReferences, (void)nValueReferences, (void)values, (void)nValues;
    return not_provided(instance, F_SetInt64);
}
fmi3Status fmi3SetBinary(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         const size_t valueSizes[], const fmi3Binary values[], size_t nValues) {
    (void)valueReferences, (void)nValueReferences, (void)valueSizes, (void)values, (void)nValues;
    return not_provided(instance, F_SetBinary);
}
fmi3Status fmi3SetClock(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        const fmi3Clock values[]) {
    (void)valueReferences, (void)nValueReferences, (void)values;
    return not_provided(instance, F_SetClock);
}

fmi3Status fmi3GetNumberOfVariableDependencies(fmi3Instance instance, fmi3ValueReference valueReference,
                                               size_t *nDependencies) {
    (void)valueReference, (void)nDependencies;
    return not_provided(instance, F_GetNumberOfVariableDependencies);
}
fmi3Status fmi3GetVariableDependencies(fmi3Instance instance, fmi3ValueReference dependent,
                                       size_t elementIndicesOfDependent[], fmi3ValueReference independents[],
                                       size_t elementIndicesOfIndependents[], fmi3DependencyKind dependencyKinds[],
                                       size_t nDependencies) {
    (void)dependent, (void)elementIndicesOfDependent, (void)independents, (void)elementIndicesOfIndependents;
    (void)dependencyKinds, (void)nDependencies;
    return not_provided(instance, F_GetVariableDependencies);
}

/* Directional derivatives with arrays among the knowns or unknowns: each expanded into its elements (an array's seed
   and sensitivity are its elements'); a constant element's sensitivity is 0, a constant is no known. */
static int directional_arrays(Instance *inst, const fmi3ValueReference unknowns[], size_t nUnknowns,
                              const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[], size_t nSeed,
                              fmi3Float64 sensitivity[], size_t nSensitivity) {
    unsigned int *known = malloc((nSeed + 1) * sizeof *known), *unknown = malloc((nSensitivity + 1) * sizeof *unknown);
    double *given = malloc((nSeed + 1) * sizeof *given), *got = malloc((nSensitivity + 1) * sizeof *got);
    size_t *at = malloc((nSensitivity + 1) * sizeof *at), *known_at = malloc((nSeed + 1) * sizeof *known_at);
    int status = BRIDGE_OK;
    if (!known || !unknown || !given || !got || !at || !known_at) {
        status = fail(inst, F_GetDirectionalDerivative, "out of memory");
    } else {
        size_t mk = expand(inst, knowns, nKnowns, known, known_at, NULL);
        if (mk < nSeed) { /* a constant among the knowns */
            for (size_t j = 0; j < nKnowns; j++) {
                const BridgeArray *a = array_of(inst, knowns[j]);
                for (size_t k = 0; a && k < a->size; k++)
                    if (a->element[k] < 0) {
                        char why[300];
                        snprintf(why, sizeof why,
                                 "known value reference %u ('%s') is an array of constants, not an input or a "
                                 "continuous state",
                                 knowns[j], a->name);
                        status = fail(inst, F_GetDirectionalDerivative, why);
                        break;
                    }
                if (status != BRIDGE_OK) break;
            }
        }
        for (size_t j = 0; j < mk; j++) given[j] = seed[known_at[j]];
        size_t mu = expand(inst, unknowns, nUnknowns, unknown, at, NULL);
        for (size_t i = 0; i < nSensitivity; i++) sensitivity[i] = 0.0; /* the constants' */
        if (status == BRIDGE_OK) {
            FrontInstance *front = &inst->front;
            status = front->bridge->directional(front->slave, CALLS[F_GetDirectionalDerivative].name, unknown, mu,
                                                known, mk, given, got);
        }
        for (size_t i = 0; status <= BRIDGE_WARNING && i < mu; i++) sensitivity[at[i]] = got[i];
    }
    free(known), free(unknown), free(given), free(got), free(at), free(known_at);
    return status;
}

fmi3Status fmi3GetDirectionalDerivative(fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns,
                                        const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[],
                                        size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity) {
    Instance *inst = enter(instance, F_GetDirectionalDerivative);
    if (!inst) return fmi3Error;
    size_t n_seed = nKnowns, n_sensitivity = nUnknowns;              /* the values of the knowns and unknowns */
    int arrays = inst->arrays && inst->arrays->n_arrays, viewed = 0; /* viewed: an array among them */
    for (size_t j = 0; arrays && knowns && j < nKnowns; j++) {
        const BridgeArray *a = array_of(inst, knowns[j]);
        if (a) n_seed += a->size - 1, viewed = 1;
    }
    for (size_t i = 0; arrays && unknowns && i < nUnknowns; i++) {
        const BridgeArray *a = array_of(inst, unknowns[i]);
        if (a) n_sensitivity += a->size - 1, viewed = 1;
    }
    if (nSeed != n_seed || nSensitivity != n_sensitivity) {
        char why[300];
        if (arrays)
            snprintf(why, sizeof why,
                     "nSeed, nSensitivity: got %zu and %zu for knowns and unknowns of %zu and %zu values (a scalar "
                     "one, an array its elements)",
                     nSeed, nSensitivity, n_seed, n_sensitivity);
        else
            snprintf(why, sizeof why,
                     "nSeed, nSensitivity: got %zu and %zu for %zu knowns and %zu unknowns (the variables are "
                     "scalars: one value each)",
                     nSeed, nSensitivity, nKnowns, nUnknowns);
        return leave(inst, fail(inst, F_GetDirectionalDerivative, why));
    }
    if (nUnknowns == 0) return leave(inst, fmi3OK);
    if (!unknowns || !sensitivity || (nKnowns > 0 && (!knowns || !seed)))
        return leave(inst, fail(inst, F_GetDirectionalDerivative, "a value-reference or value array is NULL"));
    if (viewed)
        return leave(inst, directional_arrays(inst, unknowns, nUnknowns, knowns, nKnowns, seed, nSeed, sensitivity,
                                              nSensitivity));
    FrontInstance *front = &inst->front;
    return leave(inst, front->bridge->directional(front->slave, CALLS[F_GetDirectionalDerivative].name, unknowns,
                                                  nUnknowns, knowns, nKnowns, seed, sensitivity));
}
fmi3Status fmi3GetAdjointDerivative(fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns,
                                    const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[],
                                    size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity) {
    (void)unknowns, (void)nUnknowns, (void)knowns, (void)nKnowns, (void)seed, (void)nSeed, (void)sensitivity;
    (void)nSensitivity;
    return not_provided(instance, F_GetAdjointDerivative);
}

/* Configuration Mode sets structural parameters: an FMU without them has nothing to configure. */
fmi3Status fmi3EnterConfigurationMode(fmi3Instance instance) {
    Instance *inst = enter(instance, F_EnterConfigurationMode);
    if (!inst) return fmi3Error;
    if (!inst->arrays || !inst->arrays->n_sizes)
        return leave(inst, fail(inst, F_EnterConfigurationMode,
                                "this FMU has no structural parameters (no array variables): nothing to configure"));
    inst->front.state = ConfigurationMode;
    return leave(inst, fmi3OK);
}

fmi3Status fmi3ExitConfigurationMode(fmi3Instance instance) {
    Instance *inst = enter(instance, F_ExitConfigurationMode);
    if (!inst) return fmi3Error;
    inst->front.state = Instantiated;
    return leave(inst, fmi3OK);
}

fmi3Status fmi3GetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                  size_t nValueReferences, fmi3Float64 intervals[],
                                  fmi3IntervalQualifier qualifiers[]) {
    (void)valueReferences, (void)nValueReferences, (void)intervals, (void)qualifiers;
    return not_provided(instance, F_GetIntervalDecimal);
}
fmi3Status fmi3GetIntervalFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                   size_t nValueReferences, fmi3UInt64 counters[], fmi3UInt64 resolutions[],
                                   fmi3IntervalQualifier qualifiers[]) {
    (void)valueReferences, (void)nValueReferences, (void)counters, (void)resolutions, (void)qualifiers;
    return not_provided(instance, F_GetIntervalFraction);
}
fmi3Status fmi3GetShiftDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                               size_t nValueReferences, fmi3Float64 shifts[]) {
    (void)valueReferences, (void)nValueReferences, (void)shifts;
    return not_provided(instance, F_GetShiftDecimal);
}
fmi3Status fmi3GetShiftFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                size_t nValueReferences, fmi3UInt64 counters[], fmi3UInt64 resolutions[]) {
    (void)valueReferences, (void)nValueReferences, (void)counters, (void)resolutions;
    return not_provided(instance, F_GetShiftFraction);
}
fmi3Status fmi3SetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                  size_t nValueReferences, const fmi3Float64 intervals[]) {
    (void)valueReferences, (void)nValueReferences, (void)intervals;
    return not_provided(instance, F_SetIntervalDecimal);
}
fmi3Status fmi3SetIntervalFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                   size_t nValueReferences, const fmi3UInt64 counters[],
                                   const fmi3UInt64 resolutions[]) {
    (void)valueReferences, (void)nValueReferences, (void)counters, (void)resolutions;
    return not_provided(instance, F_SetIntervalFraction);
}
fmi3Status fmi3SetShiftDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                               size_t nValueReferences, const fmi3Float64 shifts[]) {
    (void)valueReferences, (void)nValueReferences, (void)shifts;
    return not_provided(instance, F_SetShiftDecimal);
}
fmi3Status fmi3SetShiftFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                size_t nValueReferences, const fmi3UInt64 counters[], const fmi3UInt64 resolutions[]) {
    (void)valueReferences, (void)nValueReferences, (void)counters, (void)resolutions;
    return not_provided(instance, F_SetShiftFraction);
}

/* ---- FMI 3.0: model exchange (no events: the models are linear ODEs with inputs) ------------------ */

fmi3Status fmi3EvaluateDiscreteStates(fmi3Instance instance) {
    Instance *inst = enter(instance, F_EvaluateDiscreteStates);
    return inst ? leave(inst, fmi3OK) : fmi3Error; /* no discrete states */
}

fmi3Status fmi3UpdateDiscreteStates(fmi3Instance instance, fmi3Boolean *discreteStatesNeedUpdate,
                                    fmi3Boolean *terminateSimulation, fmi3Boolean *nominalsOfContinuousStatesChanged,
                                    fmi3Boolean *valuesOfContinuousStatesChanged, fmi3Boolean *nextEventTimeDefined,
                                    fmi3Float64 *nextEventTime) {
    Instance *inst = enter(instance, F_UpdateDiscreteStates);
    if (!inst) return fmi3Error;
    /* each out-argument may be NULL (FMI 3.0: the host is not interested) */
    if (discreteStatesNeedUpdate) *discreteStatesNeedUpdate = fmi3False;
    if (terminateSimulation) *terminateSimulation = fmi3False;
    if (nominalsOfContinuousStatesChanged) *nominalsOfContinuousStatesChanged = fmi3False;
    if (valuesOfContinuousStatesChanged) *valuesOfContinuousStatesChanged = fmi3False;
    if (nextEventTimeDefined) *nextEventTimeDefined = fmi3False; /* no time events */
    if (nextEventTime) *nextEventTime = 0.0;
    return leave(inst, fmi3OK);
}

fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance instance) {
    Instance *inst = enter(instance, F_EnterContinuousTimeMode);
    if (!inst) return fmi3Error;
    inst->front.state = ContinuousTimeMode;
    return leave(inst, fmi3OK);
}

fmi3Status fmi3CompletedIntegratorStep(fmi3Instance instance, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi3Boolean *enterEventMode, fmi3Boolean *terminateSimulation) {
    (void)noSetFMUStatePriorToCurrentPoint;
    Instance *inst = enter(instance, F_CompletedIntegratorStep);
    if (!inst) return fmi3Error;
    if (!enterEventMode || !terminateSimulation)
        return leave(inst, fail(inst, F_CompletedIntegratorStep, "enterEventMode or terminateSimulation is NULL"));
    *enterEventMode = fmi3False; /* no step events */
    *terminateSimulation = fmi3False;
    return leave(inst, fmi3OK);
}

fmi3Status fmi3SetTime(fmi3Instance instance, fmi3Float64 time) {
    Instance *inst = enter(instance, F_SetTime);
    if (!inst) return fmi3Error;
    return leave(inst, inst->front.bridge->set_time(inst->front.slave, CALLS[F_SetTime].name, time));
}

/* get (set 0) or set (set 1) the continuous states */
static fmi3Status states_call(fmi3Instance instance, Function f, int set, fmi3Float64 *x, size_t n) {
    Instance *inst = enter(instance, f);
    if (!inst) return fmi3Error;
    if (!x && n > 0) return leave(inst, fail(inst, f, "the array is NULL"));
    return leave(inst, inst->front.bridge->continuous_states(inst->front.slave, CALLS[f].name, set, x, n));
}

fmi3Status fmi3SetContinuousStates(fmi3Instance instance, const fmi3Float64 continuousStates[],
                                   size_t nContinuousStates) {
    return states_call(instance, F_SetContinuousStates, 1, (fmi3Float64 *)continuousStates, nContinuousStates);
}

fmi3Status fmi3GetContinuousStates(fmi3Instance instance, fmi3Float64 continuousStates[], size_t nContinuousStates) {
    return states_call(instance, F_GetContinuousStates, 0, continuousStates, nContinuousStates);
}

fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance instance, fmi3Float64 derivatives[],
                                             size_t nContinuousStates) {
    Instance *inst = enter(instance, F_GetContinuousStateDerivatives);
    if (!inst) return fmi3Error;
    if (!derivatives && nContinuousStates > 0)
        return leave(inst, fail(inst, F_GetContinuousStateDerivatives, "derivatives is NULL"));
    return leave(inst, inst->front.bridge->derivatives(inst->front.slave, CALLS[F_GetContinuousStateDerivatives].name,
                                                       derivatives, nContinuousStates));
}

fmi3Status fmi3GetEventIndicators(fmi3Instance instance, fmi3Float64 eventIndicators[], size_t nEventIndicators) {
    (void)eventIndicators;
    Instance *inst = enter(instance, F_GetEventIndicators);
    if (!inst) return fmi3Error;
    if (nEventIndicators != 0)
        return leave(inst, fail(inst, F_GetEventIndicators, "nEventIndicators: this model has 0 event indicators"));
    return leave(inst, fmi3OK);
}

fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance instance, fmi3Float64 nominals[], size_t nContinuousStates) {
    Instance *inst = enter(instance, F_GetNominalsOfContinuousStates);
    if (!inst) return fmi3Error;
    if (!nominals && nContinuousStates > 0)
        return leave(inst, fail(inst, F_GetNominalsOfContinuousStates, "nominals is NULL"));
    return leave(inst, inst->front.bridge->nominals(inst->front.slave, nominals, nContinuousStates));
}

fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance instance, size_t *nEventIndicators) {
    Instance *inst = enter(instance, F_GetNumberOfEventIndicators);
    if (!inst) return fmi3Error;
    if (!nEventIndicators) return leave(inst, fail(inst, F_GetNumberOfEventIndicators, "nEventIndicators is NULL"));
    *nEventIndicators = 0;
    return leave(inst, fmi3OK);
}

fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance instance, size_t *nContinuousStates) {
    Instance *inst = enter(instance, F_GetNumberOfContinuousStates);
    if (!inst) return fmi3Error;
    if (!nContinuousStates) return leave(inst, fail(inst, F_GetNumberOfContinuousStates, "nContinuousStates is NULL"));
    *nContinuousStates = inst->front.bridge->n_states(inst->front.slave);
    return leave(inst, fmi3OK);
}

fmi3Status fmi3EnterStepMode(fmi3Instance instance) { return not_provided(instance, F_EnterStepMode); }
fmi3Status fmi3GetOutputDerivatives(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                    size_t nValueReferences, const fmi3Int32 orders[], fmi3Float64 values[],
                                    size_t nValues) {
    (void)valueReferences, (void)nValueReferences, (void)orders, (void)values, (void)nValues;
    return not_provided(instance, F_GetOutputDerivatives);
}
fmi3Status fmi3ActivateModelPartition(fmi3Instance instance, fmi3ValueReference clockReference,
                                      fmi3Float64 activationTime) {
    (void)clockReference, (void)activationTime;
    return not_provided(instance, F_ActivateModelPartition);
}
