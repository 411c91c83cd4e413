/*
 * binaries/x86_64-linux/<id>.so: the FMI 3.0 Co-Simulation library of IceImpact3.fmu and
 * ModalStructure3.fmu, compiled by build_fmu.py.
 *
 * The slave is the FMI 2.0 FMU's: the same Python class, run by PythonFMU's FMI 2.0 library
 * (binaries/x86_64-linux/pythonfmu/<id>.so) behind the FMI 2.0 loader (loader.c, compiled into
 * this library with its fmi2 entry points made internal: everything it does for native hosts,
 * Python versions, the standalone runtime and failed calls holds here too). This file is the FMI
 * 3.0 plumbing only:
 *
 *  1. fmi3InstantiateCoSimulation instantiates the FMI 2.0 component, with a logger that hands
 *     its messages to the host's fmi3LogMessageCallback; the resource folder is passed as a file
 *     URI (or, when the host gives none, the FMU's own resources/ is used).
 *  2. Float64, Int32, Boolean (fmi3Boolean is a C bool, fmi2Boolean an int: converted) and
 *     String go to fmi2Get/Set Real, Integer, Boolean, String with the same value references;
 *     the FMU has no variables of the other types, whose calls are refused (fmi3Error) with a
 *     message. The FMU state functions are passed on; statuses keep their values (fmi3OK ..
 *     fmi3Fatal are fmi2OK .. fmi2Fatal).
 *  3. Early return: when the host allows it (earlyReturnAllowed), the slave is told so through
 *     the value reference EARLY_RETURN_VR, and its steps end at the first impact in them; after
 *     each step the time the slave reached is read through REACHED_TIME_VR, and a step that ended
 *     before currentCommunicationPoint + communicationStepSize returns earlyReturn = true and
 *     lastSuccessfulTime = that time (the impact's). The value references are the slave's
 *     (iceimpact.fmi.slave_base.FMI3_CHANNEL), passed by build_fmu.py.
 *  4. Event mode (eventModeUsed): fmi3ExitInitializationMode enters Event Mode; a step that
 *     returned at an impact asks for event handling (eventHandlingNeeded); fmi3EnterEventMode,
 *     fmi3UpdateDiscreteStates (nothing to update: the impact is already applied) and
 *     fmi3EnterStepMode follow the standard's state machine, and a step in Event Mode is refused.
 *  5. A NULL instance gets fmi3Error and is never dereferenced, as in loader.c.
 */
#define EXPORT static __attribute__((unused))
#include "loader.c"

#include <stdbool.h>

#include "fmi3Functions.h"

#ifndef EARLY_RETURN_VR
#error "build_fmu.py passes EARLY_RETURN_VR and REACHED_TIME_VR (slave_base.FMI3_CHANNEL)"
#endif

/* One FMI 3.0 instance: the FMI 2.0 layer's instance and what the host gave. */
typedef struct {
    fmi2Component inner;
    fmi2CallbackFunctions callbacks; /* given to the FMI 2.0 layer: its logger is ours */
    fmi3InstanceEnvironment environment;
    fmi3LogMessageCallback log;
    char *name;
    bool event_mode_used;
    bool early_return;
    bool in_event_mode;
    bool logging_on; /* the host's loggingOn (fmi3SetDebugLogging changes it) */
} Instance3;

/* A message the host's logger may not take (FMI 3.0: the FMU does not call logMessage while
   logging is off): warnings and errors go to stderr instead, so that the user still learns of
   them, as of a failed start. */
static void to_stderr(fmi2Status status, const char *text) {
    if (status >= fmi2Warning) fprintf(stderr, MODEL_IDENTIFIER ".fmu: %s\n", text);
}

/* The FMI 2.0 layer's messages, to the host's FMI 3.0 logger (same status values). */
static void log_to_host(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status,
                        fmi2String category, fmi2String message, ...) {
    (void)name;
    Instance3 *inst = env;
    if (!inst) return;
    char small[1024];
    va_list args;
    va_start(args, message);
    char *text = format_text(small, sizeof small, message, args);
    va_end(args);
    if (inst->log && inst->logging_on)
        inst->log(inst->environment, (fmi3Status)status, category ? category : "logAll", text);
    else
        to_stderr(status, text);
    if (text != small) free(text);
}

static void *allocate(size_t n, size_t size) { return calloc(n, size); }

/* An error of the FMI 3.0 layer itself: to the host's logger and, without one, to stderr. */
static fmi3Status refuse(Instance3 *inst, const char *fmt, ...) {
    char text[1024];
    va_list args;
    va_start(args, fmt);
    vsnprintf(text, sizeof text, fmt, args);
    va_end(args);
    if (inst && inst->log && inst->logging_on)
        inst->log(inst->environment, fmi3Error, "logStatusError", text);
    else
        fprintf(stderr, MODEL_IDENTIFIER ".fmu: %s\n", text);
    return fmi3Error;
}

/* The instance of a call, or NULL (said once per function kind) for a NULL one. */
static Instance3 *instance_of(fmi3Instance instance, const char *function) {
    static int said_null = 0;
    if (!instance)
        refused_once(&said_null, function,
                     "was called with a NULL instance (did fmi3InstantiateCoSimulation fail?): "
                     "fmi3Error");
    return instance;
}

#define INSTANCE(function)                                   \
    Instance3 *inst = instance_of(instance, function);       \
    if (!inst) return fmi3Error

/* Inquire version numbers and set debug logging ----------------------------------------------- */

FMI3_Export const char *fmi3GetVersion(void) { return fmi3Version; }

FMI3_Export fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean loggingOn,
                                           size_t nCategories, const fmi3String categories[]) {
    INSTANCE("fmi3SetDebugLogging");
    inst->logging_on = loggingOn;
    return (fmi3Status)fmi2SetDebugLogging(inst->inner, loggingOn, nCategories, categories);
}

/* Creation and destruction of instances ------------------------------------------------------- */

FMI3_Export fmi3Instance fmi3InstantiateModelExchange(
    fmi3String instanceName, fmi3String instantiationToken, fmi3String resourcePath,
    fmi3Boolean visible, fmi3Boolean loggingOn, fmi3InstanceEnvironment instanceEnvironment,
    fmi3LogMessageCallback logMessage) {
    (void)instantiationToken, (void)resourcePath, (void)visible;
    Instance3 host = {.environment = instanceEnvironment, .log = logMessage,
                      .logging_on = loggingOn};
    refuse(&host, "%s: " MODEL_IDENTIFIER ".fmu is a Co-Simulation FMU only "
           "(fmi3InstantiateCoSimulation)", instanceName ? instanceName : MODEL_IDENTIFIER);
    return NULL;
}

FMI3_Export fmi3Instance fmi3InstantiateScheduledExecution(
    fmi3String instanceName, fmi3String instantiationToken, fmi3String resourcePath,
    fmi3Boolean visible, fmi3Boolean loggingOn, fmi3InstanceEnvironment instanceEnvironment,
    fmi3LogMessageCallback logMessage, fmi3ClockUpdateCallback clockUpdate,
    fmi3LockPreemptionCallback lockPreemption, fmi3UnlockPreemptionCallback unlockPreemption) {
    (void)instantiationToken, (void)resourcePath, (void)visible;
    (void)clockUpdate, (void)lockPreemption, (void)unlockPreemption;
    Instance3 host = {.environment = instanceEnvironment, .log = logMessage,
                      .logging_on = loggingOn};
    refuse(&host, "%s: " MODEL_IDENTIFIER ".fmu is a Co-Simulation FMU only "
           "(fmi3InstantiateCoSimulation)", instanceName ? instanceName : MODEL_IDENTIFIER);
    return NULL;
}

/* The resource folder as the file URI PythonFMU's library reads (it drops "file://"). */
static int resource_uri(fmi3String resourcePath, char *out, size_t n) {
    if (resourcePath && resourcePath[0])
        return snprintf(out, n, "file://%s", resourcePath) < (int)n;
    char dir[4096];
    if (!own_directory(dir, sizeof dir)) return 0;
    return snprintf(out, n, "file://%s/../../resources/", dir) < (int)n;
}

FMI3_Export fmi3Instance fmi3InstantiateCoSimulation(
    fmi3String instanceName, fmi3String instantiationToken, fmi3String resourcePath,
    fmi3Boolean visible, fmi3Boolean loggingOn, fmi3Boolean eventModeUsed,
    fmi3Boolean earlyReturnAllowed, const fmi3ValueReference requiredIntermediateVariables[],
    size_t nRequiredIntermediateVariables, fmi3InstanceEnvironment instanceEnvironment,
    fmi3LogMessageCallback logMessage, fmi3IntermediateUpdateCallback intermediateUpdate) {
    (void)requiredIntermediateVariables, (void)intermediateUpdate;
    Instance3 *inst = calloc(1, sizeof *inst);
    if (!inst) return NULL;
    inst->environment = instanceEnvironment;
    inst->log = logMessage;
    inst->logging_on = loggingOn;
    inst->name = copy_string(instanceName ? instanceName : MODEL_IDENTIFIER);
    char uri[4200];
    if (!inst->name || !resource_uri(resourcePath, uri, sizeof uri)) {
        refuse(inst, "%s: cannot locate the FMU's resources", MODEL_IDENTIFIER);
        free(inst->name);
        free(inst);
        return NULL;
    }
    if (nRequiredIntermediateVariables > 0)
        log_to_host(inst, inst->name, fmi2Warning, "logStatusWarning",
                    "%s has no intermediate variables: the %zu required are ignored "
                    "(providesIntermediateUpdate = false)", MODEL_IDENTIFIER ".fmu",
                    nRequiredIntermediateVariables);
    inst->callbacks.logger = log_to_host;
    inst->callbacks.allocateMemory = allocate;
    inst->callbacks.freeMemory = free;
    inst->callbacks.componentEnvironment = inst;
    inst->event_mode_used = eventModeUsed;
    inst->inner = fmi2Instantiate(inst->name, fmi2CoSimulation, instantiationToken, uri,
                                  &inst->callbacks, visible, loggingOn);
    if (!inst->inner) { /* the reason went to the host's logger and stderr */
        free(inst->name);
        free(inst);
        return NULL;
    }
    if (earlyReturnAllowed) {
        const fmi2ValueReference vr = EARLY_RETURN_VR;
        const fmi2Boolean on = 1;
        if (fmi2SetBoolean(inst->inner, &vr, 1, &on) > fmi2Warning) {
            fmi2FreeInstance(inst->inner);
            free(inst->name);
            free(inst);
            return NULL;
        }
        inst->early_return = true;
    }
    return inst;
}

FMI3_Export void fmi3FreeInstance(fmi3Instance instance) {
    Instance3 *inst = instance;
    if (!inst) return;
    fmi2FreeInstance(inst->inner);
    free(inst->name);
    free(inst);
}

/* Enter and exit initialization mode, terminate and reset ------------------------------------ */

FMI3_Export fmi3Status fmi3EnterInitializationMode(fmi3Instance instance,
                                                   fmi3Boolean toleranceDefined,
                                                   fmi3Float64 tolerance, fmi3Float64 startTime,
                                                   fmi3Boolean stopTimeDefined,
                                                   fmi3Float64 stopTime) {
    INSTANCE("fmi3EnterInitializationMode");
    fmi2Status status = fmi2SetupExperiment(inst->inner, toleranceDefined, tolerance, startTime,
                                            stopTimeDefined, stopTime);
    if (status > fmi2Warning) return (fmi3Status)status;
    fmi2Status entered = fmi2EnterInitializationMode(inst->inner);
    return (fmi3Status)(entered > status ? entered : status);
}

FMI3_Export fmi3Status fmi3ExitInitializationMode(fmi3Instance instance) {
    INSTANCE("fmi3ExitInitializationMode");
    fmi2Status status = fmi2ExitInitializationMode(inst->inner);
    if (status <= fmi2Warning) inst->in_event_mode = inst->event_mode_used;
    return (fmi3Status)status;
}

FMI3_Export fmi3Status fmi3EnterEventMode(fmi3Instance instance) {
    INSTANCE("fmi3EnterEventMode");
    if (!inst->event_mode_used)
        return refuse(inst, "fmi3EnterEventMode: the instance was created with eventModeUsed = "
                      "false: no Event Mode");
    inst->in_event_mode = true;
    return fmi3OK;
}

FMI3_Export fmi3Status fmi3Terminate(fmi3Instance instance) {
    INSTANCE("fmi3Terminate");
    inst->in_event_mode = false;
    return (fmi3Status)fmi2Terminate(inst->inner);
}

FMI3_Export fmi3Status fmi3Reset(fmi3Instance instance) {
    INSTANCE("fmi3Reset");
    inst->in_event_mode = false;
    return (fmi3Status)fmi2Reset(inst->inner);
}

/* Getting and setting variable values --------------------------------------------------------- */

/* The FMU's variables are scalars: one value per value reference. */
static int scalar_counts(Instance3 *inst, const char *function, size_t nvr, size_t nValues) {
    if (nValues == nvr) return 1;
    refuse(inst, "%s: nValues = %zu is not allowed: the FMU's variables are scalars, nValues = "
           "nValueReferences = %zu; nothing is read or set", function, nValues, nvr);
    return 0;
}

FMI3_Export fmi3Status fmi3GetFloat64(fmi3Instance instance,
                                      const fmi3ValueReference valueReferences[],
                                      size_t nValueReferences, fmi3Float64 values[],
                                      size_t nValues) {
    INSTANCE("fmi3GetFloat64");
    if (!scalar_counts(inst, "fmi3GetFloat64", nValueReferences, nValues)) return fmi3Error;
    return (fmi3Status)fmi2GetReal(inst->inner, valueReferences, nValueReferences, values);
}

FMI3_Export fmi3Status fmi3SetFloat64(fmi3Instance instance,
                                      const fmi3ValueReference valueReferences[],
                                      size_t nValueReferences, const fmi3Float64 values[],
                                      size_t nValues) {
    INSTANCE("fmi3SetFloat64");
    if (!scalar_counts(inst, "fmi3SetFloat64", nValueReferences, nValues)) return fmi3Error;
    return (fmi3Status)fmi2SetReal(inst->inner, valueReferences, nValueReferences, values);
}

FMI3_Export fmi3Status fmi3GetInt32(fmi3Instance instance,
                                    const fmi3ValueReference valueReferences[],
                                    size_t nValueReferences, fmi3Int32 values[], size_t nValues) {
    INSTANCE("fmi3GetInt32");
    if (!scalar_counts(inst, "fmi3GetInt32", nValueReferences, nValues)) return fmi3Error;
    return (fmi3Status)fmi2GetInteger(inst->inner, valueReferences, nValueReferences, values);
}

FMI3_Export fmi3Status fmi3SetInt32(fmi3Instance instance,
                                    const fmi3ValueReference valueReferences[],
                                    size_t nValueReferences, const fmi3Int32 values[],
                                    size_t nValues) {
    INSTANCE("fmi3SetInt32");
    if (!scalar_counts(inst, "fmi3SetInt32", nValueReferences, nValues)) return fmi3Error;
    return (fmi3Status)fmi2SetInteger(inst->inner, valueReferences, nValueReferences, values);
}

/* fmi3Boolean (bool) and fmi2Boolean (int) arrays, converted through a buffer. */
static fmi2Boolean *boolean_buffer(Instance3 *inst, const char *function, size_t n,
                                   fmi2Boolean *small, size_t small_n) {
    if (n <= small_n) return small;
    fmi2Boolean *buffer = calloc(n, sizeof *buffer);
    if (!buffer) refuse(inst, "%s: out of memory for %zu values", function, n);
    return buffer;
}

FMI3_Export fmi3Status fmi3GetBoolean(fmi3Instance instance,
                                      const fmi3ValueReference valueReferences[],
                                      size_t nValueReferences, fmi3Boolean values[],
                                      size_t nValues) {
    INSTANCE("fmi3GetBoolean");
    if (!scalar_counts(inst, "fmi3GetBoolean", nValueReferences, nValues)) return fmi3Error;
    fmi2Boolean small[64];
    fmi2Boolean *buffer = boolean_buffer(inst, "fmi3GetBoolean", nValueReferences, small, 64);
    if (!buffer) return fmi3Error;
    fmi2Status status = fmi2GetBoolean(inst->inner, valueReferences, nValueReferences, buffer);
    for (size_t i = 0; i < nValueReferences; i++) values[i] = buffer[i] != 0;
    if (buffer != small) free(buffer);
    return (fmi3Status)status;
}

FMI3_Export fmi3Status fmi3SetBoolean(fmi3Instance instance,
                                      const fmi3ValueReference valueReferences[],
                                      size_t nValueReferences, const fmi3Boolean values[],
                                      size_t nValues) {
    INSTANCE("fmi3SetBoolean");
    if (!scalar_counts(inst, "fmi3SetBoolean", nValueReferences, nValues)) return fmi3Error;
    fmi2Boolean small[64];
    fmi2Boolean *buffer = boolean_buffer(inst, "fmi3SetBoolean", nValueReferences, small, 64);
    if (!buffer) return fmi3Error;
    for (size_t i = 0; i < nValueReferences; i++) buffer[i] = values[i] ? 1 : 0;
    fmi2Status status = fmi2SetBoolean(inst->inner, valueReferences, nValueReferences, buffer);
    if (buffer != small) free(buffer);
    return (fmi3Status)status;
}

FMI3_Export fmi3Status fmi3GetString(fmi3Instance instance,
                                     const fmi3ValueReference valueReferences[],
                                     size_t nValueReferences, fmi3String values[],
                                     size_t nValues) {
    INSTANCE("fmi3GetString");
    if (!scalar_counts(inst, "fmi3GetString", nValueReferences, nValues)) return fmi3Error;
    return (fmi3Status)fmi2GetString(inst->inner, valueReferences, nValueReferences, values);
}

FMI3_Export fmi3Status fmi3SetString(fmi3Instance instance,
                                     const fmi3ValueReference valueReferences[],
                                     size_t nValueReferences, const fmi3String values[],
                                     size_t nValues) {
    INSTANCE("fmi3SetString");
    if (!scalar_counts(inst, "fmi3SetString", nValueReferences, nValues)) return fmi3Error;
    return (fmi3Status)fmi2SetString(inst->inner, valueReferences, nValueReferences, values);
}

/* Types the FMU has no variables of: every such call is refused, naming the type. */
static fmi3Status no_variables_of(fmi3Instance instance, const char *function,
                                  const char *type) {
    INSTANCE(function);
    return refuse(inst, "%s: " MODEL_IDENTIFIER ".fmu has no %s variables (its types: Float64, "
                  "Int32, Boolean); nothing is read or set", function, type);
}

#define NO_GET(TYPE, CTYPE)                                                                  \
    FMI3_Export fmi3Status fmi3Get##TYPE(fmi3Instance instance,                              \
                                         const fmi3ValueReference valueReferences[],          \
                                         size_t nValueReferences, CTYPE values[],             \
                                         size_t nValues) {                                    \
        (void)valueReferences, (void)nValueReferences, (void)values, (void)nValues;           \
        return no_variables_of(instance, "fmi3Get" #TYPE, #TYPE);                             \
    }                                                                                        \
    FMI3_Export fmi3Status fmi3Set##TYPE(fmi3Instance instance,                              \
                                         const fmi3ValueReference valueReferences[],          \
                                         size_t nValueReferences, const CTYPE values[],       \
                                         size_t nValues) {                                    \
        (void)valueReferences, (void)nValueReferences, (void)values, (void)nValues;           \
        return no_variables_of(instance, "fmi3Set" #TYPE, #TYPE);                             \
    }

NO_GET(Float32, fmi3Float32)
NO_GET(Int8, fmi3Int8)
NO_GET(UInt8, fmi3UInt8)
NO_GET(Int16, fmi3Int16)
NO_GET(UInt16, fmi3UInt16)
NO_GET(UInt32, fmi3UInt32)
NO_GET(Int64, fmi3Int64)
NO_GET(UInt64, fmi3UInt64)

FMI3_Export fmi3Status fmi3GetBinary(fmi3Instance instance,
                                     const fmi3ValueReference valueReferences[],
                                     size_t nValueReferences, size_t valueSizes[],
                                     fmi3Binary values[], size_t nValues) {
    (void)valueReferences, (void)nValueReferences, (void)valueSizes, (void)values, (void)nValues;
    return no_variables_of(instance, "fmi3GetBinary", "Binary");
}

FMI3_Export fmi3Status fmi3SetBinary(fmi3Instance instance,
                                     const fmi3ValueReference valueReferences[],
                                     size_t nValueReferences, const size_t valueSizes[],
                                     const fmi3Binary values[], size_t nValues) {
    (void)valueReferences, (void)nValueReferences, (void)valueSizes, (void)values, (void)nValues;
    return no_variables_of(instance, "fmi3SetBinary", "Binary");
}

FMI3_Export fmi3Status fmi3GetClock(fmi3Instance instance,
                                    const fmi3ValueReference valueReferences[],
                                    size_t nValueReferences, fmi3Clock values[]) {
    (void)valueReferences, (void)nValueReferences, (void)values;
    return no_variables_of(instance, "fmi3GetClock", "Clock");
}

FMI3_Export fmi3Status fmi3SetClock(fmi3Instance instance,
                                    const fmi3ValueReference valueReferences[],
                                    size_t nValueReferences, const fmi3Clock values[]) {
    (void)valueReferences, (void)nValueReferences, (void)values;
    return no_variables_of(instance, "fmi3SetClock", "Clock");
}

/* Functions of capabilities the model description does not declare: refused, naming them. */
static fmi3Status not_provided(fmi3Instance instance, const char *function, const char *why) {
    INSTANCE(function);
    return refuse(inst, "%s: not provided by " MODEL_IDENTIFIER ".fmu (%s)", function, why);
}

#define CO_SIMULATION_ONLY "a Co-Simulation FMU without clocks"

/* Getting variable dependency information ----------------------------------------------------- */

FMI3_Export fmi3Status fmi3GetNumberOfVariableDependencies(fmi3Instance instance,
                                                           fmi3ValueReference valueReference,
                                                           size_t *nDependencies) {
    (void)valueReference, (void)nDependencies;
    return not_provided(instance, "fmi3GetNumberOfVariableDependencies",
                        "the dependencies are in modelDescription.xml's ModelStructure");
}

FMI3_Export fmi3Status fmi3GetVariableDependencies(
    fmi3Instance instance, fmi3ValueReference dependent, size_t elementIndicesOfDependent[],
    fmi3ValueReference independents[], size_t elementIndicesOfIndependents[],
    fmi3DependencyKind dependencyKinds[], size_t nDependencies) {
    (void)dependent, (void)elementIndicesOfDependent, (void)independents;
    (void)elementIndicesOfIndependents, (void)dependencyKinds, (void)nDependencies;
    return not_provided(instance, "fmi3GetVariableDependencies",
                        "the dependencies are in modelDescription.xml's ModelStructure");
}

/* Getting and setting the internal FMU state -------------------------------------------------- */

FMI3_Export fmi3Status fmi3GetFMUState(fmi3Instance instance, fmi3FMUState *FMUState) {
    INSTANCE("fmi3GetFMUState");
    return (fmi3Status)fmi2GetFMUstate(inst->inner, FMUState);
}

FMI3_Export fmi3Status fmi3SetFMUState(fmi3Instance instance, fmi3FMUState FMUState) {
    INSTANCE("fmi3SetFMUState");
    return (fmi3Status)fmi2SetFMUstate(inst->inner, FMUState);
}

FMI3_Export fmi3Status fmi3FreeFMUState(fmi3Instance instance, fmi3FMUState *FMUState) {
    INSTANCE("fmi3FreeFMUState");
    return (fmi3Status)fmi2FreeFMUstate(inst->inner, FMUState);
}

FMI3_Export fmi3Status fmi3SerializedFMUStateSize(fmi3Instance instance, fmi3FMUState FMUState,
                                                  size_t *size) {
    INSTANCE("fmi3SerializedFMUStateSize");
    return (fmi3Status)fmi2SerializedFMUstateSize(inst->inner, FMUState, size);
}

FMI3_Export fmi3Status fmi3SerializeFMUState(fmi3Instance instance, fmi3FMUState FMUState,
                                             fmi3Byte serializedState[], size_t size) {
    INSTANCE("fmi3SerializeFMUState");
    return (fmi3Status)fmi2SerializeFMUstate(inst->inner, FMUState, (fmi2Byte *)serializedState,
                                             size);
}

FMI3_Export fmi3Status fmi3DeserializeFMUState(fmi3Instance instance,
                                               const fmi3Byte serializedState[], size_t size,
                                               fmi3FMUState *FMUState) {
    INSTANCE("fmi3DeserializeFMUState");
    return (fmi3Status)fmi2DeSerializeFMUstate(inst->inner, (const fmi2Byte *)serializedState,
                                               size, FMUState);
}

/* Getting partial derivatives ----------------------------------------------------------------- */

FMI3_Export fmi3Status fmi3GetDirectionalDerivative(
    fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns,
    const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[], size_t nSeed,
    fmi3Float64 sensitivity[], size_t nSensitivity) {
    (void)unknowns, (void)nUnknowns, (void)knowns, (void)nKnowns, (void)seed, (void)nSeed;
    (void)sensitivity, (void)nSensitivity;
    return not_provided(instance, "fmi3GetDirectionalDerivative",
                        "providesDirectionalDerivatives = false");
}

FMI3_Export fmi3Status fmi3GetAdjointDerivative(
    fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns,
    const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[], size_t nSeed,
    fmi3Float64 sensitivity[], size_t nSensitivity) {
    (void)unknowns, (void)nUnknowns, (void)knowns, (void)nKnowns, (void)seed, (void)nSeed;
    (void)sensitivity, (void)nSensitivity;
    return not_provided(instance, "fmi3GetAdjointDerivative",
                        "providesAdjointDerivatives = false");
}

/* Configuration mode, clocks ------------------------------------------------------------------ */

FMI3_Export fmi3Status fmi3EnterConfigurationMode(fmi3Instance instance) {
    return not_provided(instance, "fmi3EnterConfigurationMode", "no structural parameters");
}

FMI3_Export fmi3Status fmi3ExitConfigurationMode(fmi3Instance instance) {
    return not_provided(instance, "fmi3ExitConfigurationMode", "no structural parameters");
}

FMI3_Export fmi3Status fmi3GetIntervalDecimal(fmi3Instance instance,
                                              const fmi3ValueReference valueReferences[],
                                              size_t nValueReferences, fmi3Float64 intervals[],
                                              fmi3IntervalQualifier qualifiers[]) {
    (void)valueReferences, (void)nValueReferences, (void)intervals, (void)qualifiers;
    return not_provided(instance, "fmi3GetIntervalDecimal", CO_SIMULATION_ONLY);
}

FMI3_Export fmi3Status fmi3GetIntervalFraction(fmi3Instance instance,
                                               const fmi3ValueReference valueReferences[],
                                               size_t nValueReferences, fmi3UInt64 counters[],
                                               fmi3UInt64 resolutions[],
                                               fmi3IntervalQualifier qualifiers[]) {
    (void)valueReferences, (void)nValueReferences, (void)counters, (void)resolutions;
    (void)qualifiers;
    return not_provided(instance, "fmi3GetIntervalFraction", CO_SIMULATION_ONLY);
}

FMI3_Export fmi3Status fmi3GetShiftDecimal(fmi3Instance instance,
                                           const fmi3ValueReference valueReferences[],
                                           size_t nValueReferences, fmi3Float64 shifts[]) {
    (void)valueReferences, (void)nValueReferences, (void)shifts;
    return not_provided(instance, "fmi3GetShiftDecimal", CO_SIMULATION_ONLY);
}

FMI3_Export fmi3Status fmi3GetShiftFraction(fmi3Instance instance,
                                            const fmi3ValueReference valueReferences[],
                                            size_t nValueReferences, fmi3UInt64 counters[],
                                            fmi3UInt64 resolutions[]) {
    (void)valueReferences, (void)nValueReferences, (void)counters, (void)resolutions;
    return not_provided(instance, "fmi3GetShiftFraction", CO_SIMULATION_ONLY);
}

FMI3_Export fmi3Status fmi3SetIntervalDecimal(fmi3Instance instance,
                                              const fmi3ValueReference valueReferences[],
                                              size_t nValueReferences,
                                              const fmi3Float64 intervals[]) {
    (void)valueReferences, (void)nValueReferences, (void)intervals;
    return not_provided(instance, "fmi3SetIntervalDecimal", CO_SIMULATION_ONLY);
}

FMI3_Export fmi3Status fmi3SetIntervalFraction(fmi3Instance instance,
                                               const fmi3ValueReference valueReferences[],
                                               size_t nValueReferences,
                                               const fmi3UInt64 counters[],
                                               const fmi3UInt64 resolutions[]) {
    (void)valueReferences, (void)nValueReferences, (void)counters, (void)resolutions;
    return not_provided(instance, "fmi3SetIntervalFraction", CO_SIMULATION_ONLY);
}

FMI3_Export fmi3Status fmi3SetShiftDecimal(fmi3Instance instance,
                                           const fmi3ValueReference valueReferences[],
                                           size_t nValueReferences, const fmi3Float64 shifts[]) {
    (void)valueReferences, (void)nValueReferences, (void)shifts;
    return not_provided(instance, "fmi3SetShiftDecimal", CO_SIMULATION_ONLY);
}

FMI3_Export fmi3Status fmi3SetShiftFraction(fmi3Instance instance,
                                            const fmi3ValueReference valueReferences[],
                                            size_t nValueReferences,
                                            const fmi3UInt64 counters[],
                                            const fmi3UInt64 resolutions[]) {
    (void)valueReferences, (void)nValueReferences, (void)counters, (void)resolutions;
    return not_provided(instance, "fmi3SetShiftFraction", CO_SIMULATION_ONLY);
}

FMI3_Export fmi3Status fmi3EvaluateDiscreteStates(fmi3Instance instance) {
    return not_provided(instance, "fmi3EvaluateDiscreteStates", CO_SIMULATION_ONLY);
}

/* Event Mode (eventModeUsed): the impact a step returned at is applied already. */
FMI3_Export fmi3Status fmi3UpdateDiscreteStates(fmi3Instance instance,
                                                fmi3Boolean *discreteStatesNeedUpdate,
                                                fmi3Boolean *terminateSimulation,
                                                fmi3Boolean *nominalsOfContinuousStatesChanged,
                                                fmi3Boolean *valuesOfContinuousStatesChanged,
                                                fmi3Boolean *nextEventTimeDefined,
                                                fmi3Float64 *nextEventTime) {
    INSTANCE("fmi3UpdateDiscreteStates");
    if (!inst->in_event_mode)
        return refuse(inst, "fmi3UpdateDiscreteStates: allowed in Event Mode only (eventModeUsed "
                      "and fmi3EnterEventMode)");
    if (discreteStatesNeedUpdate) *discreteStatesNeedUpdate = false;
    if (terminateSimulation) *terminateSimulation = false;
    if (nominalsOfContinuousStatesChanged) *nominalsOfContinuousStatesChanged = false;
    if (valuesOfContinuousStatesChanged) *valuesOfContinuousStatesChanged = false;
    if (nextEventTimeDefined) *nextEventTimeDefined = false;
    if (nextEventTime) *nextEventTime = 0.0;
    return fmi3OK;
}

/* Model Exchange ------------------------------------------------------------------------------ */

#define ME_ONLY "Model Exchange, and this is a Co-Simulation FMU"

FMI3_Export fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance instance) {
    return not_provided(instance, "fmi3EnterContinuousTimeMode", ME_ONLY);
}

FMI3_Export fmi3Status fmi3CompletedIntegratorStep(fmi3Instance instance,
                                                   fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                                                   fmi3Boolean *enterEventMode,
                                                   fmi3Boolean *terminateSimulation) {
    (void)noSetFMUStatePriorToCurrentPoint, (void)enterEventMode, (void)terminateSimulation;
    return not_provided(instance, "fmi3CompletedIntegratorStep", ME_ONLY);
}

FMI3_Export fmi3Status fmi3SetTime(fmi3Instance instance, fmi3Float64 time) {
    (void)time;
    return not_provided(instance, "fmi3SetTime", ME_ONLY);
}

FMI3_Export fmi3Status fmi3SetContinuousStates(fmi3Instance instance,
                                               const fmi3Float64 continuousStates[],
                                               size_t nContinuousStates) {
    (void)continuousStates, (void)nContinuousStates;
    return not_provided(instance, "fmi3SetContinuousStates", ME_ONLY);
}

FMI3_Export fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance instance,
                                                         fmi3Float64 derivatives[],
                                                         size_t nContinuousStates) {
    (void)derivatives, (void)nContinuousStates;
    return not_provided(instance, "fmi3GetContinuousStateDerivatives", ME_ONLY);
}

FMI3_Export fmi3Status fmi3GetEventIndicators(fmi3Instance instance,
                                              fmi3Float64 eventIndicators[],
                                              size_t nEventIndicators) {
    (void)eventIndicators, (void)nEventIndicators;
    return not_provided(instance, "fmi3GetEventIndicators", ME_ONLY);
}

FMI3_Export fmi3Status fmi3GetContinuousStates(fmi3Instance instance,
                                               fmi3Float64 continuousStates[],
                                               size_t nContinuousStates) {
    (void)continuousStates, (void)nContinuousStates;
    return not_provided(instance, "fmi3GetContinuousStates", ME_ONLY);
}

FMI3_Export fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance instance,
                                                         fmi3Float64 nominals[],
                                                         size_t nContinuousStates) {
    (void)nominals, (void)nContinuousStates;
    return not_provided(instance, "fmi3GetNominalsOfContinuousStates", ME_ONLY);
}

FMI3_Export fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance instance,
                                                      size_t *nEventIndicators) {
    (void)nEventIndicators;
    return not_provided(instance, "fmi3GetNumberOfEventIndicators", ME_ONLY);
}

FMI3_Export fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance instance,
                                                       size_t *nContinuousStates) {
    (void)nContinuousStates;
    return not_provided(instance, "fmi3GetNumberOfContinuousStates", ME_ONLY);
}

/* Co-Simulation ------------------------------------------------------------------------------- */

FMI3_Export fmi3Status fmi3EnterStepMode(fmi3Instance instance) {
    INSTANCE("fmi3EnterStepMode");
    if (!inst->in_event_mode)
        return refuse(inst, "fmi3EnterStepMode: allowed in Event Mode only (eventModeUsed)");
    inst->in_event_mode = false;
    return fmi3OK;
}

FMI3_Export fmi3Status fmi3GetOutputDerivatives(fmi3Instance instance,
                                                const fmi3ValueReference valueReferences[],
                                                size_t nValueReferences,
                                                const fmi3Int32 orders[], fmi3Float64 values[],
                                                size_t nValues) {
    (void)valueReferences, (void)nValueReferences, (void)orders, (void)values, (void)nValues;
    return not_provided(instance, "fmi3GetOutputDerivatives", "maxOutputDerivativeOrder = 0");
}

FMI3_Export fmi3Status fmi3DoStep(fmi3Instance instance, fmi3Float64 currentCommunicationPoint,
                                  fmi3Float64 communicationStepSize,
                                  fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                                  fmi3Boolean *eventHandlingNeeded,
                                  fmi3Boolean *terminateSimulation, fmi3Boolean *earlyReturn,
                                  fmi3Float64 *lastSuccessfulTime) {
    bool event = false, early = false;
    fmi3Float64 reached = currentCommunicationPoint; /* nothing done yet */
    fmi3Status status = fmi3Error;
    Instance3 *inst = instance_of(instance, "fmi3DoStep");
    if (!inst) goto done;
    if (inst->in_event_mode) {
        status = refuse(inst, "fmi3DoStep: the instance is in Event Mode: call "
                        "fmi3UpdateDiscreteStates and fmi3EnterStepMode first");
        goto done;
    }
    status = (fmi3Status)fmi2DoStep(inst->inner, currentCommunicationPoint,
                                    communicationStepSize, noSetFMUStatePriorToCurrentPoint);
    if (status > fmi3Warning) goto done;
    reached = currentCommunicationPoint + communicationStepSize;
    if (inst->early_return) {
        const fmi2ValueReference vr = REACHED_TIME_VR;
        fmi2Real time;
        fmi2Status read = fmi2GetReal(inst->inner, &vr, 1, &time);
        if (read > fmi2Warning) {
            status = (fmi3Status)read;
            goto done;
        }
        if (time != reached) { /* the step returned at an impact */
            reached = time;
            early = true;
            event = inst->event_mode_used;
        }
    }
done:
    if (eventHandlingNeeded) *eventHandlingNeeded = event;
    if (terminateSimulation) *terminateSimulation = false;
    if (earlyReturn) *earlyReturn = early;
    if (lastSuccessfulTime) *lastSuccessfulTime = reached;
    return status;
}

FMI3_Export fmi3Status fmi3ActivateModelPartition(fmi3Instance instance,
                                                  fmi3ValueReference clockReference,
                                                  fmi3Float64 activationTime) {
    (void)clockReference, (void)activationTime;
    return not_provided(instance, "fmi3ActivateModelPartition", "Scheduled Execution only");
}
