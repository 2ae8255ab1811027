/*
 * The FMI 2.0 Co-Simulation entry points of every exported ROM, onto the instance of rom_runtime.c (the state
 * machine, logging, FMU states and their serialisation live there, the same for FMI 3.0). Value references number
 * the scalars of the inputs, outputs and locals. Outside FMI, rom_open, rom_close and rom_last_error serve a
 * Python process the same binary in-process.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"
#include "rom_fmu.h"

typedef struct {
    Rom rom;                  /* first: rom_of is a cast */
    fmi2CallbackFunctions callbacks;
    char *name;
} Instance;

static void *allocate(void *host, size_t count, size_t size) {
    const fmi2CallbackFunctions *cb = &((Instance *)host)->callbacks;
    return cb->allocateMemory ? cb->allocateMemory(count, size) : calloc(count, size);
}

static void release(void *host, void *pointer) {
    const fmi2CallbackFunctions *cb = &((Instance *)host)->callbacks;
    if (cb->freeMemory) cb->freeMemory(pointer); else free(pointer);
}

/* the text goes as the format itself (with '%' doubled): readable by loggers that ignore varargs */
static void send(const fmi2CallbackFunctions *cb, fmi2String name, fmi2Status status, fmi2String category,
                 const char *message) {
    char escaped[2048];
    size_t i, n = 0;
    if (cb == NULL || cb->logger == NULL) return;
    for (i = 0; message[i] && n + 2 < sizeof(escaped); i++) {
        if (message[i] == '%') escaped[n++] = '%';
        escaped[n++] = message[i];
    }
    escaped[n] = 0;
    cb->logger(cb->componentEnvironment, name ? name : ROM_KIND.identifier, status, category, escaped);
}

static void report(void *host, int error, const char *category, const char *message) {
    const Instance *inst = (const Instance *)host;
    send(&inst->callbacks, inst->name, error ? fmi2Error : fmi2OK, category, message);
}

#define INSTANCE(c) Instance *inst = (Instance *)(c); if (inst == NULL) return fmi2Error
#define ROM (&inst->rom)
#define STATUS(done) ((done) ? fmi2OK : fmi2Error)

static fmi2Status check_references(Instance *inst, const char *function, const fmi2ValueReference vr[], size_t nvr,
                                   const void *values, int setting) {
    size_t i;
    const size_t total = (size_t)ROM->n_in + (size_t)ROM->n_out + (size_t)ROM->n_local;
    if (nvr > 0 && (vr == NULL || values == NULL))
        return STATUS(rom_fail(ROM, "%s: NULL value reference or value array for %lu values", function,
                               (unsigned long)nvr));
    if (nvr > total) return STATUS(rom_fail(ROM, "%s: %lu values requested, the FMU has %lu variables", function,
                                            (unsigned long)nvr, (unsigned long)total));
    for (i = 0; i < nvr; i++) {
        char name[96];
        if (vr[i] >= total) return STATUS(rom_fail(ROM, "%s: value reference %u is out of range (0..%lu)", function,
                                                   vr[i], (unsigned long)(total - 1)));
        if (setting && vr[i] >= (fmi2ValueReference)ROM->n_in)
            return STATUS(rom_fail(ROM, "%s: %s (value reference %u) is %s and cannot be set", function,
                                   rom_variable_name(ROM, vr[i], name, sizeof(name)), vr[i],
                                   vr[i] < (fmi2ValueReference)(ROM->n_in + ROM->n_out) ? "an output" : "a local"));
    }
    return fmi2OK;
}

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories, const fmi2String categories[]) {
    INSTANCE(c);
    return STATUS(rom_set_logging(ROM, loggingOn, nCategories, categories, "fmi2SetDebugLogging"));
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation, const fmi2CallbackFunctions *functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn) {
    Instance *inst;
    const char *name = instanceName ? instanceName : ROM_KIND.identifier;
    (void)visible;
    if (functions == NULL || functions->logger == NULL) return NULL;
    if (fmuType != fmi2CoSimulation) {
        send(functions, instanceName, fmi2Error, "logStatusError", "only Co-Simulation is supported");
        return NULL;
    }
    inst = (Instance *)(functions->allocateMemory ? functions->allocateMemory(1, sizeof(Instance))
                                                  : calloc(1, sizeof(Instance)));
    if (inst == NULL) return NULL;
    memset(inst, 0, sizeof(Instance));
    inst->callbacks = *functions;
    ROM->host = inst;
    ROM->allocate = allocate;
    ROM->free = release;
    ROM->report = report;
    ROM->logging = loggingOn;
    inst->name = (char *)rom_allocate(ROM, strlen(name) + 1, 1);
    if (inst->name) strcpy(inst->name, name);
    if (!rom_instantiate(ROM, fmuResourceLocation, fmuGUID)) {
        fmi2FreeInstance(inst);
        return NULL;
    }
    return inst;
}

void fmi2FreeInstance(fmi2Component c) {
    Instance *inst = (Instance *)c;
    if (inst == NULL) return;
    rom_release_all(ROM);
    rom_free(ROM, inst->name);
    rom_free(ROM, inst);
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    INSTANCE(c);
    (void)toleranceDefined; (void)tolerance;
    return STATUS(rom_allowed(ROM, ROM_INSTANTIATED, "fmi2SetupExperiment") &&
                  rom_start(ROM, startTime, stopTimeDefined, stopTime, "fmi2SetupExperiment"));
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    INSTANCE(c);
    if (!rom_allowed(ROM, ROM_INSTANTIATED, "fmi2EnterInitializationMode")) return fmi2Error;
    ROM->machine = ROM_INITIALIZATION;
    return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    INSTANCE(c);
    return STATUS(rom_exit_initialization(ROM, "fmi2ExitInitializationMode"));
}

fmi2Status fmi2Terminate(fmi2Component c) {
    INSTANCE(c);
    return STATUS(rom_terminate(ROM, "fmi2Terminate"));
}

fmi2Status fmi2Reset(fmi2Component c) {
    INSTANCE(c);
    rom_reset(ROM);
    return fmi2OK;
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[]) {
    size_t i;
    INSTANCE(c);
    if (!rom_allowed(ROM, ROM_INITIALIZATION | ROM_STEP | ROM_TERMINATED | ROM_ERROR, "fmi2GetReal")) return fmi2Error;
    if (check_references(inst, "fmi2GetReal", vr, nvr, value, 0) != fmi2OK) return fmi2Error;
    rom_update(ROM);
    for (i = 0; i < nvr; i++) value[i] = ROM->inputs[vr[i]];    /* inputs, outputs, locals: consecutive */
    return fmi2OK;
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[]) {
    size_t i;
    char name[96];
    INSTANCE(c);
    if (!rom_allowed(ROM, ROM_INSTANTIATED | ROM_INITIALIZATION | ROM_STEP, "fmi2SetReal")) return fmi2Error;
    if (check_references(inst, "fmi2SetReal", vr, nvr, value, 1) != fmi2OK) return fmi2Error;
    for (i = 0; i < nvr; i++)
        if (!rom_finite(value[i]))
            return STATUS(rom_fail(ROM, "fmi2SetReal: %s = %g is not finite",
                                   rom_variable_name(ROM, vr[i], name, sizeof(name)), value[i]));
    for (i = 0; i < nvr; i++) ROM->inputs[vr[i]] = value[i];
    if (nvr > 0) ROM->dirty = 1;
    return fmi2OK;
}

static fmi2Status no_variables(fmi2Component c, const char *function, size_t nvr) {
    INSTANCE(c);
    return nvr > 0 ? STATUS(rom_fail(ROM, "%s: the FMU has no variables of this type", function)) : fmi2OK;
}

fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Integer value[]) {
    (void)vr; (void)value; return no_variables(c, "fmi2GetInteger", nvr);
}
fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Boolean value[]) {
    (void)vr; (void)value; return no_variables(c, "fmi2GetBoolean", nvr);
}
fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2String value[]) {
    (void)vr; (void)value; return no_variables(c, "fmi2GetString", nvr);
}
fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Integer value[]) {
    (void)vr; (void)value; return no_variables(c, "fmi2SetInteger", nvr);
}
fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Boolean value[]) {
    (void)vr; (void)value; return no_variables(c, "fmi2SetBoolean", nvr);
}
fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2String value[]) {
    (void)vr; (void)value; return no_variables(c, "fmi2SetString", nvr);
}

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    RomState *state;
    INSTANCE(c);
    if (FMUstate == NULL) return STATUS(rom_fail(ROM, "fmi2GetFMUstate: NULL state pointer"));
    state = rom_state_get(ROM, (RomState *)*FMUstate, "fmi2GetFMUstate");
    if (state == NULL) return fmi2Error;
    *FMUstate = state;
    return fmi2OK;
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate) {
    INSTANCE(c);
    return STATUS(rom_state_set(ROM, (const RomState *)FMUstate, "fmi2SetFMUstate"));
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    INSTANCE(c);
    if (FMUstate == NULL) return fmi2OK;
    if (!rom_state_free(ROM, (RomState *)*FMUstate, "fmi2FreeFMUstate")) return fmi2Error;
    *FMUstate = NULL;
    return fmi2OK;
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate s, size_t *size) {
    INSTANCE(c);
    if (s == NULL || !rom_state_owned(ROM, (const RomState *)s))
        return STATUS(rom_fail(ROM, "fmi2SerializedFMUstateSize: not a state of this instance"));
    if (size == NULL) return STATUS(rom_fail(ROM, "fmi2SerializedFMUstateSize: NULL size pointer"));
    *size = rom_state_bytes(ROM);
    return fmi2OK;
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate s, fmi2Byte bytes[], size_t size) {
    INSTANCE(c);
    return STATUS(rom_state_serialize(ROM, (const RomState *)s, (unsigned char *)bytes, size, "fmi2SerializeFMUstate"));
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte bytes[], size_t size, fmi2FMUstate *s) {
    RomState *state;
    INSTANCE(c);
    if (s == NULL) return STATUS(rom_fail(ROM, "fmi2DeSerializeFMUstate: NULL argument"));
    state = rom_state_deserialize(ROM, (const unsigned char *)bytes, size, (RomState *)*s, "fmi2DeSerializeFMUstate");
    if (state == NULL) return fmi2Error;
    *s = state;
    return fmi2OK;
}

static fmi2Status unsupported(fmi2Component c, const char *function) {
    INSTANCE(c);
    return STATUS(rom_fail(ROM, "%s is not supported by this FMU", function));
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown[], size_t nUnknown,
                                        const fmi2ValueReference vKnown[], size_t nKnown, const fmi2Real dvKnown[],
                                        fmi2Real dvUnknown[]) {
    (void)vUnknown; (void)nUnknown; (void)vKnown; (void)nKnown; (void)dvKnown; (void)dvUnknown;
    return unsupported(c, "fmi2GetDirectionalDerivative");
}
fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[]) {
    (void)vr; (void)nvr; (void)order; (void)value; return unsupported(c, "fmi2SetRealInputDerivatives");
}
fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[]) {
    (void)vr; (void)nvr; (void)order; (void)value; return unsupported(c, "fmi2GetRealOutputDerivatives");
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint, fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
    INSTANCE(c);
    (void)noSetFMUStatePriorToCurrentPoint;
    return STATUS(rom_step(ROM, currentCommunicationPoint, communicationStepSize, "fmi2DoStep"));
}

fmi2Status fmi2CancelStep(fmi2Component c) { return unsupported(c, "fmi2CancelStep"); }

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value) {
    (void)s; (void)value; return unsupported(c, "fmi2GetStatus");
}
fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value) {
    INSTANCE(c);
    if (s == fmi2LastSuccessfulTime && value != NULL) { *value = *ROM->time; return fmi2OK; }
    return STATUS(rom_fail(ROM, "fmi2GetRealStatus: only fmi2LastSuccessfulTime is available"));
}
fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value) {
    (void)s; (void)value; return unsupported(c, "fmi2GetIntegerStatus");
}
fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value) {
    (void)s; (void)value; return unsupported(c, "fmi2GetBooleanStatus");
}
fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value) {
    (void)s; (void)value; return unsupported(c, "fmi2GetStringStatus");
}

/* ---- in-process use (not part of FMI) ---- */
/* The same binary serves a Python process directly: an instance on a resource folder with plain calloc/free and a
 * logger that keeps the last message; the ROM's own functions then act on rom_of(instance). */

static char last_message[1024];

static void keep_message(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status, fmi2String category,
                         fmi2String message, ...) {
    char *r, *w;
    (void)env; (void)name; (void)status; (void)category;
    snprintf(last_message, sizeof(last_message), "%s", message);   /* sent with '%' doubled: undo it */
    for (r = w = last_message; *r; r++, w++) { *w = *r; if (r[0] == '%' && r[1] == '%') r++; }
    *w = 0;
}

static void *plain_allocate(size_t count, size_t size) { return calloc(count, size); }
static void plain_free(void *pointer) { free(pointer); }

/* an instance reading resource_uri/rom.bin, or NULL (the reason in rom_last_error) */
void *rom_open(const char *resource_uri, const char *guid) {
    static const fmi2CallbackFunctions plain = {keep_message, plain_allocate, plain_free, NULL, NULL};
    last_message[0] = 0;
    return fmi2Instantiate(ROM_KIND.identifier, fmi2CoSimulation, guid, resource_uri, &plain, fmi2False, fmi2False);
}

/* the last error message of rom_open (empty if none) */
const char *rom_last_error(void) { return last_message; }

void rom_close(void *instance) { fmi2FreeInstance((fmi2Component)instance); }

Rom *rom_of(void *instance) { return &((Instance *)instance)->rom; }
