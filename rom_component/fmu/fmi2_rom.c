/*
 * The FMI 2.0 Co-Simulation skeleton of every exported ROM: the entry points, the state machine (a call out of
 * turn returns fmi2Error with a message), logging by category, instance handling, and the FMU state with its
 * serialisation. The ROM behind it supplies its arithmetic and its state (rom_fmu.h). Outside FMI, rom_open,
 * rom_close and rom_last_error serve a Python process the same binary in-process.
 */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"
#include "rom_fmu.h"

typedef struct State {
    double *values;           /* a copy of the instance's values */
    int machine;              /* the instance's FMI state when it was taken: restoring it leaves an error */
    struct State *next;       /* every state an instance hands out, freed with it at the latest */
} State;

/* FMI 2.0 Co-Simulation states, as bits so that a function can name the states it is allowed in */
enum { INSTANTIATED = 1, INITIALIZATION = 2, STEP_COMPLETE = 4, TERMINATED = 8, ERROR = 16 };
#define ANY (INSTANTIATED | INITIALIZATION | STEP_COMPLETE | TERMINATED | ERROR)

typedef struct {
    Rom rom;
    fmi2CallbackFunctions callbacks;
    char *name;
    int logging, log_events, log_errors;   /* loggingOn and the enabled categories */
    int state;
    int dirty;                /* inputs set since the outputs were computed */
    State *states;
} Instance;

static const char *const CATEGORIES[] = {"logEvents", "logStatusError"};

/* ---- the services the ROM and the runtime use ---- */

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

/* an error is reported unless the importer switched logStatusError off; an event only with loggingOn and
 * logEvents enabled */
static void report(void *host, int error, const char *category, const char *message) {
    const Instance *inst = (const Instance *)host;
    if (error ? inst->log_errors : inst->logging && inst->log_events)
        send(&inst->callbacks, inst->name, error ? fmi2Error : fmi2OK, category, message);
}

/* an error: reported; the FMU enters its error state */
#define FAIL(inst, ...) do { rom_error(&(inst)->rom, __VA_ARGS__); (inst)->state = ERROR; return fmi2Error; } while (0)
/* refuse a call in a state the FMI 2.0 state machine does not allow it in */
#define REQUIRE(inst, allowed, function) do { if (!((inst)->state & (allowed))) \
    FAIL(inst, "%s is not allowed in %s", function, state_name((inst)->state)); } while (0)
#define INSTANCE(c) Instance *inst = (Instance *)(c); if (inst == NULL) return fmi2Error

static const char *state_name(int state) {
    switch (state) {
    case INSTANTIATED: return "the instantiated state (before fmi2EnterInitializationMode)";
    case INITIALIZATION: return "Initialization Mode";
    case STEP_COMPLETE: return "Step Mode";
    case TERMINATED: return "the terminated state";
    default: return "the error state (only fmi2Reset and fmi2FreeInstance lead out)";
    }
}

static void evaluate(Instance *inst) {
    rom_evaluate(&inst->rom);
    inst->dirty = 0;
}

static fmi2Status check_references(Instance *inst, const char *function, const fmi2ValueReference vr[], size_t nvr,
                                   const void *values, int setting) {
    size_t i;
    const Rom *rom = &inst->rom;
    const size_t total = (size_t)rom->n_in + (size_t)rom->n_out + (size_t)rom->n_local;
    if (nvr > 0 && (vr == NULL || values == NULL)) FAIL(inst, "%s: NULL value reference or value array for %lu values",
                                                      function, (unsigned long)nvr);
    if (nvr > total) FAIL(inst, "%s: %lu values requested, the FMU has %lu variables", function,
                          (unsigned long)nvr, (unsigned long)total);
    for (i = 0; i < nvr; i++) {
        if (vr[i] >= total) FAIL(inst, "%s: value reference %u is out of range (0..%lu)", function, vr[i],
                                 (unsigned long)(total - 1));
        if (setting && vr[i] >= (fmi2ValueReference)rom->n_in) {
            char name[96];
            FAIL(inst, "%s: %s (value reference %u) is %s and cannot be set", function,
                 rom_variable_name(rom, vr[i], name, sizeof(name)), vr[i],
                 vr[i] < (fmi2ValueReference)(rom->n_in + rom->n_out) ? "an output" : "a local");
        }
    }
    return fmi2OK;
}

/* ---- FMI 2.0 functions ---- */

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories, const fmi2String categories[]) {
    size_t i, k;
    INSTANCE(c);
    if (nCategories > 0 && categories == NULL) FAIL(inst, "fmi2SetDebugLogging: NULL category list");
    for (i = 0; i < nCategories; i++) {
        int known = 0;
        for (k = 0; k < sizeof(CATEGORIES) / sizeof(CATEGORIES[0]); k++)
            if (categories[i] && strcmp(categories[i], CATEGORIES[k]) == 0) known = 1;
        if (!known) FAIL(inst, "fmi2SetDebugLogging: unknown log category '%s' (known: logEvents, logStatusError)",
                         categories[i] ? categories[i] : "(null)");
    }
    inst->logging = loggingOn;
    if (nCategories == 0) {            /* no list: every category follows loggingOn */
        inst->log_events = 1;
        inst->log_errors = 1;
    } else {                           /* a list: those categories are switched to loggingOn */
        for (i = 0; i < nCategories; i++) {
            if (strcmp(categories[i], "logEvents") == 0) inst->log_events = loggingOn;
            else inst->log_errors = loggingOn;
        }
    }
    return fmi2OK;
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation, const fmi2CallbackFunctions *functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn) {
    Instance *inst;
    const char *name = instanceName ? instanceName : ROM_KIND.identifier;
    char description[512];
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
    inst->logging = loggingOn;
    inst->log_events = 1;
    inst->log_errors = 1;
    inst->state = INSTANTIATED;
    inst->rom.host = inst;
    inst->rom.allocate = allocate;
    inst->rom.free = release;
    inst->rom.report = report;
    inst->name = (char *)rom_allocate(&inst->rom, strlen(name) + 1, 1);
    if (inst->name) strcpy(inst->name, name);
    if (!rom_read_resource(&inst->rom, fmuResourceLocation, fmuGUID)) {
        fmi2FreeInstance(inst);
        return NULL;
    }
    if (!rom_allocate_values(&inst->rom)) {
        rom_error(&inst->rom, "out of memory");
        fmi2FreeInstance(inst);
        return NULL;
    }
    rom_reset_values(&inst->rom);
    rom_describe(&inst->rom, description, sizeof(description));
    rom_event(&inst->rom, "instantiated: %s", description);
    return inst;
}

static void free_states(Instance *inst) {
    while (inst->states != NULL) {
        State *next = inst->states->next;
        rom_free(&inst->rom, inst->states->values);
        rom_free(&inst->rom, inst->states);
        inst->states = next;
    }
}

void fmi2FreeInstance(fmi2Component c) {
    Instance *inst = (Instance *)c;
    if (inst == NULL) return;
    free_states(inst);
    rom_free(&inst->rom, inst->rom.work);
    rom_free(&inst->rom, inst->rom.model);
    rom_free(&inst->rom, inst->rom.values);
    rom_free(&inst->rom, inst->rom.buffer);
    rom_free(&inst->rom, inst->name);
    rom_free(&inst->rom, inst);
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    INSTANCE(c);
    (void)toleranceDefined; (void)tolerance;
    REQUIRE(inst, INSTANTIATED, "fmi2SetupExperiment");
    if (!rom_finite(startTime)) FAIL(inst, "fmi2SetupExperiment: start time %g is not finite", startTime);
    if (stopTimeDefined && !(stopTime >= startTime))
        FAIL(inst, "fmi2SetupExperiment: stop time %g is before the start time %g", stopTime, startTime);
    *inst->rom.time = startTime;
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    INSTANCE(c);
    REQUIRE(inst, INSTANTIATED, "fmi2EnterInitializationMode");
    inst->state = INITIALIZATION;
    return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    INSTANCE(c);
    REQUIRE(inst, INITIALIZATION, "fmi2ExitInitializationMode");
    evaluate(inst);
    inst->state = STEP_COMPLETE;
    return fmi2OK;
}

fmi2Status fmi2Terminate(fmi2Component c) {
    INSTANCE(c);
    REQUIRE(inst, STEP_COMPLETE, "fmi2Terminate");
    inst->state = TERMINATED;
    rom_event(&inst->rom, "terminated at t = %g", *inst->rom.time);
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component c) {
    INSTANCE(c);
    rom_reset_values(&inst->rom);
    inst->dirty = 0;
    inst->state = INSTANTIATED;
    return fmi2OK;
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[]) {
    size_t i;
    INSTANCE(c);
    REQUIRE(inst, INITIALIZATION | STEP_COMPLETE | TERMINATED | ERROR, "fmi2GetReal");
    if (check_references(inst, "fmi2GetReal", vr, nvr, value, 0) != fmi2OK) return fmi2Error;
    if (inst->state == INITIALIZATION && inst->dirty) evaluate(inst);   /* outputs follow the inputs set there */
    for (i = 0; i < nvr; i++)   /* inputs, outputs and locals are consecutive in the values */
        value[i] = inst->rom.inputs[vr[i]];
    return fmi2OK;
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[]) {
    size_t i;
    INSTANCE(c);
    REQUIRE(inst, INSTANTIATED | INITIALIZATION | STEP_COMPLETE, "fmi2SetReal");
    if (check_references(inst, "fmi2SetReal", vr, nvr, value, 1) != fmi2OK) return fmi2Error;
    for (i = 0; i < nvr; i++)
        if (!rom_finite(value[i])) {
            char name[96];
            FAIL(inst, "fmi2SetReal: %s = %g is not finite", rom_variable_name(&inst->rom, vr[i], name, sizeof(name)),
                 value[i]);
        }
    for (i = 0; i < nvr; i++) inst->rom.inputs[vr[i]] = value[i];
    if (nvr > 0) inst->dirty = 1;
    return fmi2OK;
}

static fmi2Status no_variables(fmi2Component c, const char *function, size_t nvr) {
    INSTANCE(c);
    if (nvr > 0) FAIL(inst, "%s: the FMU has no variables of this type", function);
    return fmi2OK;
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

static int owns_state(const Instance *inst, const State *state) {
    const State *s;
    for (s = inst->states; s != NULL; s = s->next)
        if (s == state) return 1;
    return 0;
}

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    State *state;
    INSTANCE(c);
    if (FMUstate == NULL) FAIL(inst, "fmi2GetFMUstate: NULL state pointer");
    state = (State *)*FMUstate;
    if (state == NULL || !owns_state(inst, state)) {
        state = (State *)rom_allocate(&inst->rom, 1, sizeof(State));
        if (state == NULL) FAIL(inst, "fmi2GetFMUstate: out of memory");
        state->values = (double *)rom_allocate(&inst->rom, inst->rom.n_values, sizeof(double));
        if (state->values == NULL) {
            rom_free(&inst->rom, state);
            FAIL(inst, "fmi2GetFMUstate: out of memory");
        }
        state->next = inst->states;
        inst->states = state;
    }
    memcpy(state->values, inst->rom.values, sizeof(double) * inst->rom.n_values);
    state->machine = inst->state;
    *FMUstate = state;
    return fmi2OK;
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate) {
    const State *state = (const State *)FMUstate;
    INSTANCE(c);
    if (state == NULL || !owns_state(inst, state)) FAIL(inst, "fmi2SetFMUstate: not a state of this instance");
    memcpy(inst->rom.values, state->values, sizeof(double) * inst->rom.n_values);
    inst->dirty = 0;
    inst->state = state->machine;      /* FMI 2.0 lets an importer go on from a state saved before an error */
    return fmi2OK;
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    State *state, **link;
    INSTANCE(c);
    if (FMUstate == NULL || *FMUstate == NULL) return fmi2OK;
    state = (State *)*FMUstate;
    for (link = &inst->states; *link != NULL && *link != state; link = &(*link)->next) {}
    if (*link == NULL) FAIL(inst, "fmi2FreeFMUstate: not a state of this instance");
    *link = state->next;
    rom_free(&inst->rom, state->values);
    rom_free(&inst->rom, state);
    *FMUstate = NULL;
    return fmi2OK;
}

/* a serialised state: the ROM's state magic, the model's GUID (40 characters, a digest of its arrays), the number
 * of values and the FMI state it was taken in (int64), the values, in the machine's byte order: a checkpoint is
 * read back by the same FMU on the same kind of machine */
#define STATE_HEADER (8 + ROM_GUID_LENGTH + 2 * sizeof(int64_t))

static size_t serialized_size(const Instance *inst) { return STATE_HEADER + sizeof(double) * inst->rom.n_values; }

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate s, size_t *size) {
    INSTANCE(c);
    if (s == NULL || !owns_state(inst, (const State *)s)) FAIL(inst, "fmi2SerializedFMUstateSize: not a state of this instance");
    if (size == NULL) FAIL(inst, "fmi2SerializedFMUstateSize: NULL size pointer");
    *size = serialized_size(inst);
    return fmi2OK;
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate s, fmi2Byte bytes[], size_t size) {
    const State *state = (const State *)s;
    int64_t header[2];
    INSTANCE(c);
    if (state == NULL || !owns_state(inst, state)) FAIL(inst, "fmi2SerializeFMUstate: not a state of this instance");
    if (bytes == NULL || size != serialized_size(inst))
        FAIL(inst, "fmi2SerializeFMUstate: a buffer of %lu bytes is needed", (unsigned long)serialized_size(inst));
    header[0] = (int64_t)inst->rom.n_values;
    header[1] = (int64_t)state->machine;
    memcpy(bytes, ROM_KIND.state_magic, 8);
    memcpy(bytes + 8, inst->rom.guid, ROM_GUID_LENGTH);
    memcpy(bytes + 8 + ROM_GUID_LENGTH, header, sizeof header);
    memcpy(bytes + STATE_HEADER, state->values, sizeof(double) * inst->rom.n_values);
    return fmi2OK;
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte bytes[], size_t size, fmi2FMUstate *s) {
    int64_t header[2];
    size_t i;
    double value;
    fmi2FMUstate handle = NULL;
    INSTANCE(c);
    if (bytes == NULL || s == NULL) FAIL(inst, "fmi2DeSerializeFMUstate: NULL argument");
    if (size < STATE_HEADER || memcmp(bytes, ROM_KIND.state_magic, 8) != 0)
        FAIL(inst, "fmi2DeSerializeFMUstate: not a serialised state of this FMU (%lu bytes)", (unsigned long)size);
    if (memcmp(bytes + 8, inst->rom.guid, ROM_GUID_LENGTH) != 0)
        FAIL(inst, "fmi2DeSerializeFMUstate: a state of another model (GUID %.40s, this FMU's is %s)",
             (const char *)bytes + 8, inst->rom.guid);
    memcpy(header, bytes + 8 + ROM_GUID_LENGTH, sizeof header);
    if (header[0] != (int64_t)inst->rom.n_values || size != serialized_size(inst))
        FAIL(inst, "fmi2DeSerializeFMUstate: a state of %ld values in %lu bytes, this model has %lu", (long)header[0],
             (unsigned long)size, (unsigned long)inst->rom.n_values);
    if (header[1] != INSTANTIATED && header[1] != INITIALIZATION && header[1] != STEP_COMPLETE && header[1] != TERMINATED)
        FAIL(inst, "fmi2DeSerializeFMUstate: the state was taken in no valid FMI state (%ld)", (long)header[1]);
    for (i = 0; i < inst->rom.n_values; i++) {
        memcpy(&value, bytes + STATE_HEADER + i * sizeof(double), sizeof value);
        if (!rom_finite(value)) FAIL(inst, "fmi2DeSerializeFMUstate: value %lu of the state is %g, not finite",
                                     (unsigned long)i, value);
    }
    handle = (*s != NULL && owns_state(inst, (const State *)*s)) ? *s : NULL;
    if (fmi2GetFMUstate(c, &handle) != fmi2OK) return fmi2Error;    /* a state of this instance to fill */
    memcpy(((State *)handle)->values, bytes + STATE_HEADER, sizeof(double) * inst->rom.n_values);
    ((State *)handle)->machine = (int)header[1];
    *s = handle;
    return fmi2OK;
}

static fmi2Status unsupported(fmi2Component c, const char *function) {
    INSTANCE(c);
    FAIL(inst, "%s is not supported by this FMU", function);
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

/* one step: the outputs from the inputs and the history, then the step joins the history */
fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint, fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
    int32_t i;
    INSTANCE(c);
    (void)noSetFMUStatePriorToCurrentPoint;
    REQUIRE(inst, STEP_COMPLETE, "fmi2DoStep");
    if (!rom_finite(currentCommunicationPoint))
        FAIL(inst, "fmi2DoStep: communication point %g is not finite", currentCommunicationPoint);
    if (!(communicationStepSize > 0.0) || !rom_finite(communicationStepSize))
        FAIL(inst, "fmi2DoStep: step size %g is not a positive finite number", communicationStepSize);
    evaluate(inst);
    /* a state of values out of range (a damaged serialisation, say) gives no number: say so, never fmi2OK */
    for (i = 0; i < inst->rom.n_out + inst->rom.n_local; i++)
        if (!rom_finite(inst->rom.outputs[i]))
            FAIL(inst, "fmi2DoStep: output %d at t = %g is not finite (the state or the inputs are out of range)",
                 (int)i, currentCommunicationPoint);
    rom_commit(&inst->rom);
    *inst->rom.time = currentCommunicationPoint + communicationStepSize;
    return fmi2OK;
}

fmi2Status fmi2CancelStep(fmi2Component c) { return unsupported(c, "fmi2CancelStep"); }

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value) {
    (void)s; (void)value; return unsupported(c, "fmi2GetStatus");
}
fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value) {
    INSTANCE(c);
    if (s == fmi2LastSuccessfulTime && value != NULL) { *value = *inst->rom.time; return fmi2OK; }
    FAIL(inst, "fmi2GetRealStatus: only fmi2LastSuccessfulTime is available");
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
