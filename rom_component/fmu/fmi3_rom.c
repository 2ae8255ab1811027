/*
 * The FMI 3.0 Co-Simulation entry points of every exported ROM, onto the instance of rom_runtime.c (the state
 * machine, logging, FMU states and their serialisation live there, the same as for FMI 2.0). The variables are
 * arrays: the time (value reference 0, the independent variable), the input (1) and the output (2) whole, then each
 * group of local_width locals (3, 4, ...); fmi3GetFloat64 and fmi3SetFloat64 move their values in row-major
 * order. No event mode, no model exchange, no scheduled execution.
 */
#include <stdlib.h>
#include <string.h>

#include "fmi3Functions.h"
#include "rom_fmu.h"

typedef struct {
    Rom rom;                  /* first: rom_of is a cast */
    fmi3InstanceEnvironment environment;
    fmi3LogMessageCallback log;
} Instance;

static void *allocate(void *host, size_t count, size_t size) { (void)host; return calloc(count, size); }
static void release(void *host, void *pointer) { (void)host; free(pointer); }

static void report(void *host, int error, const char *category, const char *message) {
    const Instance *inst = (const Instance *)host;
    if (inst->log != NULL) inst->log(inst->environment, error ? fmi3Error : fmi3OK, category, message);
}

#define INSTANCE(c) Instance *inst = (Instance *)(c); if (inst == NULL) return fmi3Error
#define ROM (&inst->rom)
#define STATUS(done) ((done) ? fmi3OK : fmi3Error)

/* the values behind a value reference and how many; 0 if there is no such variable */
static int variable(Rom *rom, fmi3ValueReference vr, double **data, size_t *size) {
    const size_t groups = (size_t)(rom->n_local / rom->local_width);
    if (vr == 0) { *data = rom->time; *size = 1; }
    else if (vr == 1) { *data = rom->inputs; *size = (size_t)rom->n_in; }
    else if (vr == 2) { *data = rom->outputs; *size = (size_t)rom->n_out; }
    else if (vr - 3 < groups) { *data = rom->outputs + rom->n_out + (size_t)(vr - 3) * rom->local_width; *size = (size_t)rom->local_width; }
    else return 0;
    return 1;
}

/* the values the value references name, and their total against nValues; refused (an error) otherwise */
static int check_variables(Rom *rom, const fmi3ValueReference vrs[], size_t n, const void *values, size_t n_values,
                           int setting, const char *function) {
    size_t i, total = 0, size;
    double *data;
    if (n > 0 && (vrs == NULL || values == NULL)) return rom_fail(rom, "%s: NULL value references or values", function);
    for (i = 0; i < n; i++) {
        if (!variable(rom, vrs[i], &data, &size))
            return rom_fail(rom, "%s: value reference %u names no variable (0 time, 1 %s, 2 %s, 3.. the locals)",
                            function, vrs[i], rom->input_name, rom->output_name);
        if (setting && vrs[i] != 1)
            return rom_fail(rom, "%s: value reference %u is %s and cannot be set", function, vrs[i],
                            vrs[i] == 0 ? "the time" : vrs[i] == 2 ? "an output" : "a local");
        total += size;
    }
    if (total != n_values)
        return rom_fail(rom, "%s: nValues is %lu, the %lu variables hold %lu values", function,
                        (unsigned long)n_values, (unsigned long)n, (unsigned long)total);
    return 1;
}

const char *fmi3GetVersion(void) { return fmi3Version; }

fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean loggingOn, size_t nCategories,
                               const fmi3String categories[]) {
    INSTANCE(instance);
    return STATUS(rom_set_logging(ROM, loggingOn, nCategories, categories, "fmi3SetDebugLogging"));
}

fmi3Instance fmi3InstantiateCoSimulation(fmi3String instanceName, fmi3String instantiationToken,
                                         fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                         fmi3Boolean eventModeUsed, fmi3Boolean earlyReturnAllowed,
                                         const fmi3ValueReference requiredIntermediateVariables[],
                                         size_t nRequiredIntermediateVariables,
                                         fmi3InstanceEnvironment instanceEnvironment,
                                         fmi3LogMessageCallback logMessage,
                                         fmi3IntermediateUpdateCallback intermediateUpdate) {
    Instance *inst = (Instance *)calloc(1, sizeof(Instance));
    (void)instanceName; (void)visible; (void)earlyReturnAllowed; (void)requiredIntermediateVariables;
    (void)nRequiredIntermediateVariables; (void)intermediateUpdate;
    if (inst == NULL) return NULL;
    inst->environment = instanceEnvironment;
    inst->log = logMessage;
    ROM->host = inst;
    ROM->allocate = allocate;
    ROM->free = release;
    ROM->report = report;
    ROM->logging = loggingOn;
    if (eventModeUsed) {
        ROM->log_errors = 1;
        rom_error(ROM, "fmi3InstantiateCoSimulation: this FMU has no event mode");
    } else if (rom_instantiate(ROM, resourcePath, instantiationToken)) {
        return inst;
    }
    fmi3FreeInstance(inst);
    return NULL;
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName, fmi3String instantiationToken,
                                          fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                          fmi3InstanceEnvironment instanceEnvironment,
                                          fmi3LogMessageCallback logMessage) {
    (void)instanceName; (void)instantiationToken; (void)resourcePath; (void)visible; (void)loggingOn;
    if (logMessage != NULL) logMessage(instanceEnvironment, fmi3Error, "logStatusError", "only Co-Simulation is supported");
    return NULL;
}

fmi3Instance fmi3InstantiateScheduledExecution(fmi3String instanceName, fmi3String instantiationToken,
                                               fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                               fmi3InstanceEnvironment instanceEnvironment,
                                               fmi3LogMessageCallback logMessage, fmi3ClockUpdateCallback clockUpdate,
                                               fmi3LockPreemptionCallback lockPreemption,
                                               fmi3UnlockPreemptionCallback unlockPreemption) {
    (void)clockUpdate; (void)lockPreemption; (void)unlockPreemption;
    return fmi3InstantiateModelExchange(instanceName, instantiationToken, resourcePath, visible, loggingOn,
                                        instanceEnvironment, logMessage);
}

void fmi3FreeInstance(fmi3Instance instance) {
    Instance *inst = (Instance *)instance;
    if (inst == NULL) return;
    rom_release_all(ROM);
    free(inst);
}

fmi3Status fmi3EnterInitializationMode(fmi3Instance instance, fmi3Boolean toleranceDefined, fmi3Float64 tolerance,
                                       fmi3Float64 startTime, fmi3Boolean stopTimeDefined, fmi3Float64 stopTime) {
    INSTANCE(instance);
    (void)toleranceDefined; (void)tolerance;
    if (!rom_allowed(ROM, ROM_INSTANTIATED, "fmi3EnterInitializationMode") ||
        !rom_start(ROM, startTime, stopTimeDefined, stopTime, "fmi3EnterInitializationMode")) return fmi3Error;
    ROM->machine = ROM_INITIALIZATION;
    return fmi3OK;
}

/* the forwarders: the runtime does the work */
fmi3Status fmi3ExitInitializationMode(fmi3Instance instance) {
    INSTANCE(instance); return STATUS(rom_exit_initialization(ROM, "fmi3ExitInitializationMode")); }
fmi3Status fmi3Terminate(fmi3Instance instance) { INSTANCE(instance); return STATUS(rom_terminate(ROM, "fmi3Terminate")); }
fmi3Status fmi3Reset(fmi3Instance instance) { INSTANCE(instance); rom_reset(ROM); return fmi3OK; }

fmi3Status fmi3GetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                          fmi3Float64 values[], size_t nValues) {
    size_t i, size = 0;
    double *data = NULL;
    INSTANCE(instance);
    if (!rom_allowed(ROM, ROM_INITIALIZATION | ROM_STEP | ROM_TERMINATED | ROM_ERROR, "fmi3GetFloat64") ||
        !check_variables(ROM, valueReferences, nValueReferences, values, nValues, 0, "fmi3GetFloat64"))
        return fmi3Error;
    rom_update(ROM);
    for (i = 0; i < nValueReferences; i++, values += size) {
        variable(ROM, valueReferences[i], &data, &size);
        memcpy(values, data, sizeof(double) * size);
    }
    return fmi3OK;
}

fmi3Status fmi3SetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                          const fmi3Float64 values[], size_t nValues) {
    size_t i;
    char name[96];
    INSTANCE(instance);
    if (!rom_allowed(ROM, ROM_INSTANTIATED | ROM_INITIALIZATION | ROM_STEP, "fmi3SetFloat64") ||
        !check_variables(ROM, valueReferences, nValueReferences, values, nValues, 1, "fmi3SetFloat64"))
        return fmi3Error;
    for (i = 0; i < nValues; i++)      /* every reference is the input: its values, once or again */
        if (!rom_finite(values[i]))
            return STATUS(rom_fail(ROM, "fmi3SetFloat64: %s = %g is not finite",
                                   rom_variable_name(ROM, (uint32_t)(i % (size_t)ROM->n_in), name, sizeof(name)),
                                   values[i]));
    for (i = 0; i < nValueReferences; i++)
        memcpy(ROM->inputs, values + i * (size_t)ROM->n_in, sizeof(double) * (size_t)ROM->n_in);
    if (nValueReferences > 0) ROM->dirty = 1;
    return fmi3OK;
}

fmi3Status fmi3GetFMUState(fmi3Instance instance, fmi3FMUState *FMUState) {
    RomState *state = NULL;
    INSTANCE(instance);
    if (FMUState != NULL) state = rom_state_get(ROM, (RomState *)*FMUState, "fmi3GetFMUState");
    else rom_fail(ROM, "fmi3GetFMUState: NULL state pointer");
    if (state != NULL) *FMUState = state;
    return STATUS(state != NULL);
}

fmi3Status fmi3SetFMUState(fmi3Instance instance, fmi3FMUState FMUState) {
    INSTANCE(instance);
    return STATUS(rom_state_set(ROM, (const RomState *)FMUState, "fmi3SetFMUState"));
}

fmi3Status fmi3FreeFMUState(fmi3Instance instance, fmi3FMUState *FMUState) {
    INSTANCE(instance);
    if (FMUState != NULL && !rom_state_free(ROM, (RomState *)*FMUState, "fmi3FreeFMUState")) return fmi3Error;
    if (FMUState != NULL) *FMUState = NULL;
    return fmi3OK;
}

fmi3Status fmi3SerializedFMUStateSize(fmi3Instance instance, fmi3FMUState FMUState, size_t *size) {
    INSTANCE(instance);
    if (size == NULL || !rom_state_owned(ROM, (const RomState *)FMUState))
        return STATUS(rom_fail(ROM, "fmi3SerializedFMUStateSize: not a state of this instance, or a NULL size"));
    *size = rom_state_bytes(ROM);
    return fmi3OK;
}

fmi3Status fmi3SerializeFMUState(fmi3Instance instance, fmi3FMUState FMUState, fmi3Byte serializedState[],
                                 size_t size) {
    INSTANCE(instance);
    return STATUS(rom_state_serialize(ROM, (const RomState *)FMUState, serializedState, size, "fmi3SerializeFMUState"));
}

fmi3Status fmi3DeserializeFMUState(fmi3Instance instance, const fmi3Byte serializedState[], size_t size,
                                   fmi3FMUState *FMUState) {
    RomState *state = NULL;
    INSTANCE(instance);
    if (FMUState != NULL)
        state = rom_state_deserialize(ROM, serializedState, size, (RomState *)*FMUState, "fmi3DeserializeFMUState");
    else rom_fail(ROM, "fmi3DeserializeFMUState: NULL state pointer");
    if (state != NULL) *FMUState = state;
    return STATUS(state != NULL);
}

fmi3Status fmi3DoStep(fmi3Instance instance, fmi3Float64 currentCommunicationPoint, fmi3Float64 communicationStepSize,
                      fmi3Boolean noSetFMUStatePriorToCurrentPoint, fmi3Boolean *eventHandlingNeeded,
                      fmi3Boolean *terminateSimulation, fmi3Boolean *earlyReturn, fmi3Float64 *lastSuccessfulTime) {
    int done;
    INSTANCE(instance);
    (void)noSetFMUStatePriorToCurrentPoint;
    done = rom_step(ROM, currentCommunicationPoint, communicationStepSize, "fmi3DoStep");
    if (eventHandlingNeeded != NULL) *eventHandlingNeeded = fmi3False;
    if (terminateSimulation != NULL) *terminateSimulation = fmi3False;
    if (earlyReturn != NULL) *earlyReturn = fmi3False;
    if (lastSuccessfulTime != NULL) *lastSuccessfulTime = *ROM->time;
    return STATUS(done);
}

/* ---- what this FMU does not have ---- */

static fmi3Status unsupported(fmi3Instance instance, const char *function) {
    INSTANCE(instance);
    return STATUS(rom_fail(ROM, "%s is not supported by this FMU", function));
}

static fmi3Status no_variables(fmi3Instance instance, const char *function, size_t nValueReferences) {
    INSTANCE(instance);
    return nValueReferences > 0 ? STATUS(rom_fail(ROM, "%s: the FMU has no variables of this type", function)) : fmi3OK;
}

#if defined(__GNUC__)
#pragma GCC diagnostic ignored "-Wunused-parameter"
#endif
fmi3Status fmi3EnterEventMode(fmi3Instance instance) { return unsupported(instance, "fmi3EnterEventMode"); }
fmi3Status fmi3GetFloat32(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, fmi3Float32 values[], size_t nValues) { return no_variables(instance, "fmi3GetFloat32", nValueReferences); }
fmi3Status fmi3GetInt8(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, fmi3Int8 values[], size_t nValues) { return no_variables(instance, "fmi3GetInt8", nValueReferences); }
fmi3Status fmi3GetUInt8(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, fmi3UInt8 values[], size_t nValues) { return no_variables(instance, "fmi3GetUInt8", nValueReferences); }
fmi3Status fmi3GetInt16(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, fmi3Int16 values[], size_t nValues) { return no_variables(instance, "fmi3GetInt16", nValueReferences); }
fmi3Status fmi3GetUInt16(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, fmi3UInt16 values[], size_t nValues) { return no_variables(instance, "fmi3GetUInt16", nValueReferences); }
fmi3Status fmi3GetInt32(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, fmi3Int32 values[], size_t nValues) { return no_variables(instance, "fmi3GetInt32", nValueReferences); }
fmi3Status fmi3GetUInt32(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, fmi3UInt32 values[], size_t nValues) { return no_variables(instance, "fmi3GetUInt32", nValueReferences); }
fmi3Status fmi3GetInt64(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, fmi3Int64 values[], size_t nValues) { return no_variables(instance, "fmi3GetInt64", nValueReferences); }
fmi3Status fmi3GetUInt64(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, fmi3UInt64 values[], size_t nValues) { return no_variables(instance, "fmi3GetUInt64", nValueReferences); }
fmi3Status fmi3GetBoolean(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, fmi3Boolean values[], size_t nValues) { return no_variables(instance, "fmi3GetBoolean", nValueReferences); }
fmi3Status fmi3GetString(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, fmi3String values[], size_t nValues) { return no_variables(instance, "fmi3GetString", nValueReferences); }
fmi3Status fmi3GetBinary(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, size_t valueSizes[], fmi3Binary values[], size_t nValues) { return no_variables(instance, "fmi3GetBinary", nValueReferences); }
fmi3Status fmi3GetClock(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, fmi3Clock values[]) { return no_variables(instance, "fmi3GetClock", nValueReferences); }
fmi3Status fmi3SetFloat32(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, const fmi3Float32 values[], size_t nValues) { return no_variables(instance, "fmi3SetFloat32", nValueReferences); }
fmi3Status fmi3SetInt8(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, const fmi3Int8 values[], size_t nValues) { return no_variables(instance, "fmi3SetInt8", nValueReferences); }
fmi3Status fmi3SetUInt8(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, const fmi3UInt8 values[], size_t nValues) { return no_variables(instance, "fmi3SetUInt8", nValueReferences); }
fmi3Status fmi3SetInt16(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, const fmi3Int16 values[], size_t nValues) { return no_variables(instance, "fmi3SetInt16", nValueReferences); }
fmi3Status fmi3SetUInt16(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, const fmi3UInt16 values[], size_t nValues) { return no_variables(instance, "fmi3SetUInt16", nValueReferences); }
fmi3Status fmi3SetInt32(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, const fmi3Int32 values[], size_t nValues) { return no_variables(instance, "fmi3SetInt32", nValueReferences); }
fmi3Status fmi3SetUInt32(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, const fmi3UInt32 values[], size_t nValues) { return no_variables(instance, "fmi3SetUInt32", nValueReferences); }
fmi3Status fmi3SetInt64(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, const fmi3Int64 values[], size_t nValues) { return no_variables(instance, "fmi3SetInt64", nValueReferences); }
fmi3Status fmi3SetUInt64(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, const fmi3UInt64 values[], size_t nValues) { return no_variables(instance, "fmi3SetUInt64", nValueReferences); }
fmi3Status fmi3SetBoolean(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, const fmi3Boolean values[], size_t nValues) { return no_variables(instance, "fmi3SetBoolean", nValueReferences); }
fmi3Status fmi3SetString(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, const fmi3String values[], size_t nValues) { return no_variables(instance, "fmi3SetString", nValueReferences); }
fmi3Status fmi3SetBinary(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, const size_t valueSizes[], const fmi3Binary values[], size_t nValues) { return no_variables(instance, "fmi3SetBinary", nValueReferences); }
fmi3Status fmi3SetClock(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, const fmi3Clock values[]) { return no_variables(instance, "fmi3SetClock", nValueReferences); }
fmi3Status fmi3GetNumberOfVariableDependencies(fmi3Instance instance, fmi3ValueReference valueReference, size_t* nDependencies) { return unsupported(instance, "fmi3GetNumberOfVariableDependencies"); }
fmi3Status fmi3GetVariableDependencies(fmi3Instance instance, fmi3ValueReference dependent, size_t elementIndicesOfDependent[], fmi3ValueReference independents[], size_t elementIndicesOfIndependents[], fmi3DependencyKind dependencyKinds[], size_t nDependencies) { return unsupported(instance, "fmi3GetVariableDependencies"); }
fmi3Status fmi3GetDirectionalDerivative(fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns, const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[], size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity) { return unsupported(instance, "fmi3GetDirectionalDerivative"); }
fmi3Status fmi3GetAdjointDerivative(fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns, const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[], size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity) { return unsupported(instance, "fmi3GetAdjointDerivative"); }
fmi3Status fmi3EnterConfigurationMode(fmi3Instance instance) { return unsupported(instance, "fmi3EnterConfigurationMode"); }
fmi3Status fmi3ExitConfigurationMode(fmi3Instance instance) { return unsupported(instance, "fmi3ExitConfigurationMode"); }
fmi3Status fmi3GetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, fmi3Float64 intervals[], fmi3IntervalQualifier qualifiers[]) { return unsupported(instance, "fmi3GetIntervalDecimal"); }
fmi3Status fmi3GetIntervalFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, fmi3UInt64 counters[], fmi3UInt64 resolutions[], fmi3IntervalQualifier qualifiers[]) { return unsupported(instance, "fmi3GetIntervalFraction"); }
fmi3Status fmi3GetShiftDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, fmi3Float64 shifts[]) { return unsupported(instance, "fmi3GetShiftDecimal"); }
fmi3Status fmi3GetShiftFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, fmi3UInt64 counters[], fmi3UInt64 resolutions[]) { return unsupported(instance, "fmi3GetShiftFraction"); }
fmi3Status fmi3SetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, const fmi3Float64 intervals[]) { return unsupported(instance, "fmi3SetIntervalDecimal"); }
fmi3Status fmi3SetIntervalFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, const fmi3UInt64 counters[], const fmi3UInt64 resolutions[]) { return unsupported(instance, "fmi3SetIntervalFraction"); }
fmi3Status fmi3SetShiftDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, const fmi3Float64 shifts[]) { return unsupported(instance, "fmi3SetShiftDecimal"); }
fmi3Status fmi3SetShiftFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, const fmi3UInt64 counters[], const fmi3UInt64 resolutions[]) { return unsupported(instance, "fmi3SetShiftFraction"); }
fmi3Status fmi3EvaluateDiscreteStates(fmi3Instance instance) { return unsupported(instance, "fmi3EvaluateDiscreteStates"); }
fmi3Status fmi3UpdateDiscreteStates(fmi3Instance instance, fmi3Boolean* discreteStatesNeedUpdate, fmi3Boolean* terminateSimulation, fmi3Boolean* nominalsOfContinuousStatesChanged, fmi3Boolean* valuesOfContinuousStatesChanged, fmi3Boolean* nextEventTimeDefined, fmi3Float64* nextEventTime) { return unsupported(instance, "fmi3UpdateDiscreteStates"); }
fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance instance) { return unsupported(instance, "fmi3EnterContinuousTimeMode"); }
fmi3Status fmi3CompletedIntegratorStep(fmi3Instance instance, fmi3Boolean noSetFMUStatePriorToCurrentPoint, fmi3Boolean* enterEventMode, fmi3Boolean* terminateSimulation) { return unsupported(instance, "fmi3CompletedIntegratorStep"); }
fmi3Status fmi3SetTime(fmi3Instance instance, fmi3Float64 time) { return unsupported(instance, "fmi3SetTime"); }
fmi3Status fmi3SetContinuousStates(fmi3Instance instance, const fmi3Float64 continuousStates[], size_t nContinuousStates) { return unsupported(instance, "fmi3SetContinuousStates"); }
fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance instance, fmi3Float64 derivatives[], size_t nContinuousStates) { return unsupported(instance, "fmi3GetContinuousStateDerivatives"); }
fmi3Status fmi3GetEventIndicators(fmi3Instance instance, fmi3Float64 eventIndicators[], size_t nEventIndicators) { return unsupported(instance, "fmi3GetEventIndicators"); }
fmi3Status fmi3GetContinuousStates(fmi3Instance instance, fmi3Float64 continuousStates[], size_t nContinuousStates) { return unsupported(instance, "fmi3GetContinuousStates"); }
fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance instance, fmi3Float64 nominals[], size_t nContinuousStates) { return unsupported(instance, "fmi3GetNominalsOfContinuousStates"); }
fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance instance, size_t* nEventIndicators) { return unsupported(instance, "fmi3GetNumberOfEventIndicators"); }
fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance instance, size_t* nContinuousStates) { return unsupported(instance, "fmi3GetNumberOfContinuousStates"); }
fmi3Status fmi3EnterStepMode(fmi3Instance instance) { return unsupported(instance, "fmi3EnterStepMode"); }
fmi3Status fmi3GetOutputDerivatives(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, const fmi3Int32 orders[], fmi3Float64 values[], size_t nValues) { return unsupported(instance, "fmi3GetOutputDerivatives"); }
fmi3Status fmi3ActivateModelPartition(fmi3Instance instance, fmi3ValueReference clockReference, fmi3Float64 activationTime) { return unsupported(instance, "fmi3ActivateModelPartition"); }

/* ---- outside FMI ---- */

Rom *rom_of(void *instance) { return &((Instance *)instance)->rom; }
