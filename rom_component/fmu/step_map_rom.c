/*
 * A step-map ROM of a structure with inertia (rom_component.dynamic.model) as an FMI 2.0 Co-Simulation FMU whose
 * state is the structure's reduced history. One fmi2DoStep advances one window:
 *
 *   x   = E f - e                                      reduced force (r_f)
 *   s   = (x + 2 x_1) + x_2                            Newmark's weighted sum with the last two windows' forces
 *   z   = ((W s + A [z_1 ... z_p]) + c) [+ Q q(z_1)]   reduced displacement (r_u); q: products of the leading k
 *   u   = At^T z + base,  probes = Pt^T z + p0         interface displacement and probe points
 *
 * after which z and x join the history (z_1 <- z, x_1 <- x). An importer repeats a window (a coupling iteration)
 * the FMI way: fmi2GetFMUstate before it, fmi2SetFMUstate before each repeat (which also leaves an error state,
 * as FMI 2.0 allows). The state (history, inputs, outputs, time) serialises to bytes with the model's GUID
 * (fmi2SerializeFMUstate); a state of another model or with a value that is not finite is refused.
 *
 * resources/rom.bin (little-endian):
 *   char magic[8] = "CSSTEP1"; char guid[40]; char input_name[32], output_name[32];
 *   int32 n_in, n_out, n_probe, r_f, r_u, p, k, components;
 *   float64 E[r_f][n_in], e[r_f], W[r_u][r_f], A[r_u][p r_u], Q[r_u][k (k + 1) / 2], c[r_u],
 *           At[r_u][n_out], base[n_out], Pt[r_u][n_probe], p0[n_probe], Ap[r_u][n_out] (pseudo-inverse of At^T),
 *           z_rest[r_u], x_rest[r_f] (the history at rest).
 * Value references: inputs 0 .. n_in-1, outputs n_in .. n_in+n_out-1, probes (locals) after them.
 * Every sum runs in the order of the Python component's reproducible arithmetic (numpy's pairwise row sums,
 * sequential sums over r_u), with no fused multiply-add: results are bit-identical to it.
 *
 * Outside FMI (rom_component.compiled_step_map): step_map_open, step_map_evaluate (a window's call, from the
 * history, without moving it), step_map_commit (the window's last call joins the history), step_map_history
 * (read or write the history), step_map_take_over (a history from a full-order run's converged windows).
 */
#if defined(__clang__)
#pragma STDC FP_CONTRACT OFF
#elif defined(__GNUC__)
#pragma GCC optimize("fp-contract=off")
#else
#pragma STDC FP_CONTRACT OFF
#endif
#if defined(__FAST_MATH__)
#error "step_map_rom.c must not be built with -ffast-math: its results are defined bit for bit"
#endif
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"

#define MAGIC "CSSTEP1"
#define GUID_LENGTH 40
#define NAME_LENGTH 32
#define MAX_PATH_LENGTH 4096
#define HEADER_INTS 8

typedef struct {
    int32_t n_in, n_out, n_probe, r_f, r_u, p, k, components;
    int32_t n_quad;
    double *E, *e, *W, *A, *Q, *c, *At, *base, *Pt, *p0, *Ap, *z_rest, *x_rest;
    char guid[GUID_LENGTH + 1];
    char input_name[NAME_LENGTH + 1], output_name[NAME_LENGTH + 1];
} Model;

/* everything a window changes: the history, the last inputs and outputs, the time */
typedef struct State {
    double *values;
    int machine;              /* the instance's FMI state when it was taken: restoring it leaves an error */
    struct State *next;
} State;

enum { INSTANTIATED = 1, INITIALIZATION = 2, STEP_COMPLETE = 4, TERMINATED = 8, ERROR = 16 };
#define ANY (INSTANTIATED | INITIALIZATION | STEP_COMPLETE | TERMINATED | ERROR)

typedef struct {
    fmi2CallbackFunctions callbacks;
    char *name;
    int logging, state;
    Model model;
    double *values;           /* the state: zh[p][r_u], xh[2][r_f], inputs[n_in], outputs[n_out + n_probe], time */
    double *zh, *xh, *inputs, *outputs, *time;
    double *x, *s, *z, *quad, *d;
    const double *low, *high, *mean, *precision;   /* the training envelope of the served path (step_map_serve) */
    double max_distance, *trust;
    size_t n_values;
    State *states;
    char *buffer;
} Instance;

static void log_message(const fmi2CallbackFunctions *cb, fmi2String name, fmi2Status status, const char *format, ...) {
    char message[1024], escaped[2048];
    size_t i, n = 0;
    va_list args;
    if (cb == NULL || cb->logger == NULL) return;
    va_start(args, format);
    vsnprintf(message, sizeof(message), format, args);
    va_end(args);
    for (i = 0; message[i] && n + 2 < sizeof(escaped); i++) {
        if (message[i] == '%') escaped[n++] = '%';
        escaped[n++] = message[i];
    }
    escaped[n] = 0;
    cb->logger(cb->componentEnvironment, name ? name : "step_map_rom", status, "logStatusError", escaped);
}

#define FAIL(inst, ...) do { log_message(&(inst)->callbacks, (inst)->name, fmi2Error, __VA_ARGS__); \
                             (inst)->state = ERROR; return fmi2Error; } while (0)
#define REQUIRE(inst, allowed, function) do { if (!((inst)->state & (allowed))) \
    FAIL(inst, "%s is not allowed in this state (%d)", function, (inst)->state); } while (0)
#define INSTANCE(c) Instance *inst = (Instance *)(c); if (inst == NULL) return fmi2Error

static int finite(double v) { return v - v == 0.0; }

static void *allocate(const fmi2CallbackFunctions *cb, size_t count, size_t size) {
    if (count == 0) count = 1;
    return cb->allocateMemory ? cb->allocateMemory(count, size) : calloc(count, size);
}

static void release(const fmi2CallbackFunctions *cb, void *pointer) {
    if (pointer == NULL) return;
    if (cb->freeMemory) cb->freeMemory(pointer); else free(pointer);
}

/* sum_i row[i] * v[i] in numpy's pairwise order (as ndarray.sum along a contiguous axis) */
static double pairwise_dot(const double *row, const double *v, int32_t n) {
    if (n < 8) {
        double res = -0.0;
        int32_t i;
        for (i = 0; i < n; i++) res += row[i] * v[i];
        return res;
    }
    if (n <= 128) {
        double r[8], res;
        int32_t i, j;
        for (j = 0; j < 8; j++) r[j] = row[j] * v[j];
        for (i = 8; i < n - (n % 8); i += 8)
            for (j = 0; j < 8; j++) r[j] += row[i + j] * v[i + j];
        res = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]));
        for (; i < n; i++) res += row[i] * v[i];
        return res;
    } else {
        int32_t n2 = n / 2;
        n2 -= n2 % 8;
        return pairwise_dot(row, v, n2) + pairwise_dot(row + n2, v + n2, n - n2);
    }
}

/* out[j] = sum_i Mt[i][j] z[i] (i = 0 .. r - 1 in order) + add[j]: numpy's sum over the first axis */
static void combine(const double *Mt, const double *z, int32_t r, int32_t n, const double *add, double *out) {
    int32_t i, j;
    for (j = 0; j < n; j++) out[j] = Mt[j] * z[0];
    for (i = 1; i < r; i++)
        for (j = 0; j < n; j++) out[j] += Mt[(size_t)i * n + j] * z[i];
    for (j = 0; j < n; j++) out[j] += add[j];
}

static void encode(const Model *m, const double *f, double *x) {
    int32_t i;
    for (i = 0; i < m->r_f; i++) x[i] = pairwise_dot(m->E + (size_t)i * m->n_in, f, m->n_in) - m->e[i];
}

/* the window's call from the history: x, z, outputs (the history does not move) */
static void evaluate(Instance *inst) {
    const Model *m = &inst->model;
    int32_t i, a, b, q = 0;
    encode(m, inst->inputs, inst->x);
    for (i = 0; i < m->r_f; i++) inst->s[i] = (inst->x[i] + 2.0 * inst->xh[i]) + inst->xh[m->r_f + i];
    for (a = 0; a < m->k; a++)
        for (b = a; b < m->k; b++) inst->quad[q++] = inst->zh[a] * inst->zh[b];
    for (i = 0; i < m->r_u; i++) {
        double z = pairwise_dot(m->W + (size_t)i * m->r_f, inst->s, m->r_f)
                 + pairwise_dot(m->A + (size_t)i * m->p * m->r_u, inst->zh, m->p * m->r_u);
        z += m->c[i];
        if (m->n_quad) z += pairwise_dot(m->Q + (size_t)i * m->n_quad, inst->quad, m->n_quad);
        inst->z[i] = z;
    }
    combine(m->At, inst->z, m->r_u, m->n_out, m->base, inst->outputs);
    if (m->n_probe) combine(m->Pt, inst->z, m->r_u, m->n_probe, m->p0, inst->outputs + m->n_out);
}

/* the last call's z and x join the history */
static void commit(Instance *inst) {
    const Model *m = &inst->model;
    memmove(inst->zh + m->r_u, inst->zh, sizeof(double) * (size_t)(m->p - 1) * m->r_u);
    memcpy(inst->zh, inst->z, sizeof(double) * (size_t)m->r_u);
    memcpy(inst->xh + m->r_f, inst->xh, sizeof(double) * (size_t)m->r_f);
    memcpy(inst->xh, inst->x, sizeof(double) * (size_t)m->r_f);
}

static void at_rest(Instance *inst) {
    const Model *m = &inst->model;
    int32_t i;
    memset(inst->values, 0, sizeof(double) * inst->n_values);
    for (i = 0; i < m->p; i++) memcpy(inst->zh + (size_t)i * m->r_u, m->z_rest, sizeof(double) * (size_t)m->r_u);
    for (i = 0; i < 2; i++) memcpy(inst->xh + (size_t)i * m->r_f, m->x_rest, sizeof(double) * (size_t)m->r_f);
    evaluate(inst);
}

static int resource_file(const char *uri, char *path, size_t size) {
    const char *p;
    size_t n = 0;
    if (uri == NULL) return 0;
    if (strncmp(uri, "file://localhost/", 17) == 0) p = uri + 16;
    else if (strncmp(uri, "file:///", 8) == 0) p = uri + 7;
    else if (strncmp(uri, "file:/", 6) == 0) p = uri + 5;
    else return 0;
    while (*p && n + 1 < size) {
        if (p[0] == '%' && p[1] && p[2]) {
            char hex[3] = {p[1], p[2], 0};
            path[n++] = (char)strtol(hex, NULL, 16);
            p += 3;
        } else {
            path[n++] = *p++;
        }
    }
    if (n > 0 && path[n - 1] == '/') n--;
    if (n + strlen("/rom.bin") + 1 > size) return 0;
    strcpy(path + n, "/rom.bin");
    return 1;
}

static int load_model(Instance *inst, const char *file, const char *guid) {
    FILE *f = fopen(file, "rb");
    long length;
    size_t offset, need;
    Model *m = &inst->model;
    const size_t header = 8 + GUID_LENGTH + 2 * NAME_LENGTH + HEADER_INTS * sizeof(int32_t);
    if (f == NULL) { log_message(&inst->callbacks, inst->name, fmi2Error, "cannot open '%s'", file); return 0; }
    fseek(f, 0, SEEK_END);
    length = ftell(f);
    fseek(f, 0, SEEK_SET);
    if (length < (long)header) {
        fclose(f);
        log_message(&inst->callbacks, inst->name, fmi2Error, "resource file '%s' is truncated", file);
        return 0;
    }
    inst->buffer = (char *)allocate(&inst->callbacks, (size_t)length + 8, 1);
    if (inst->buffer == NULL || fread(inst->buffer, 1, (size_t)length, f) != (size_t)length) {
        fclose(f);
        log_message(&inst->callbacks, inst->name, fmi2Error, "cannot read '%s'", file);
        return 0;
    }
    fclose(f);
    if (memcmp(inst->buffer, MAGIC, 8) != 0) {
        log_message(&inst->callbacks, inst->name, fmi2Error, "'%s' is not a step-map ROM resource", file);
        return 0;
    }
    memcpy(m->guid, inst->buffer + 8, GUID_LENGTH);
    m->guid[GUID_LENGTH] = 0;
    if (guid == NULL || strcmp(guid, m->guid) != 0) {
        log_message(&inst->callbacks, inst->name, fmi2Error, "GUID '%s' does not match the resource's '%s'",
                    guid ? guid : "(null)", m->guid);
        return 0;
    }
    offset = 8 + GUID_LENGTH;
    memcpy(m->input_name, inst->buffer + offset, NAME_LENGTH);
    m->input_name[NAME_LENGTH] = 0;
    memcpy(m->output_name, inst->buffer + offset + NAME_LENGTH, NAME_LENGTH);
    m->output_name[NAME_LENGTH] = 0;
    offset += 2 * NAME_LENGTH;
    memcpy(&m->n_in, inst->buffer + offset, HEADER_INTS * sizeof(int32_t));
    offset += HEADER_INTS * sizeof(int32_t);
    if (m->n_in <= 0 || m->n_out <= 0 || m->n_probe < 0 || m->r_f <= 0 || m->r_u <= 0 || m->p <= 0 || m->k < 0 ||
        m->k > m->r_u || m->components < 1 || m->components > 3 || m->n_in % m->components ||
        m->n_out % m->components) {
        log_message(&inst->callbacks, inst->name, fmi2Error, "resource '%s' has invalid sizes", file);
        return 0;
    }
    m->n_quad = m->k * (m->k + 1) / 2;
    need = offset + sizeof(double) * ((size_t)m->r_f * m->n_in + m->r_f + (size_t)m->r_u * m->r_f
                                      + (size_t)m->r_u * m->p * m->r_u + (size_t)m->r_u * m->n_quad + m->r_u
                                      + 2 * (size_t)m->r_u * m->n_out + m->n_out + (size_t)m->r_u * m->n_probe
                                      + m->n_probe + m->r_u + m->r_f);
    if ((size_t)length != need) {
        log_message(&inst->callbacks, inst->name, fmi2Error, "resource '%s' has %ld bytes, its sizes need %lu", file,
                    length, (unsigned long)need);
        return 0;
    }
#define TAKE(target, count) do { target = (double *)(inst->buffer + offset); offset += sizeof(double) * (size_t)(count); } while (0)
    TAKE(m->E, (size_t)m->r_f * m->n_in);
    TAKE(m->e, m->r_f);
    TAKE(m->W, (size_t)m->r_u * m->r_f);
    TAKE(m->A, (size_t)m->r_u * m->p * m->r_u);
    TAKE(m->Q, (size_t)m->r_u * m->n_quad);
    TAKE(m->c, m->r_u);
    TAKE(m->At, (size_t)m->r_u * m->n_out);
    TAKE(m->base, m->n_out);
    TAKE(m->Pt, (size_t)m->r_u * m->n_probe);
    TAKE(m->p0, m->n_probe);
    TAKE(m->Ap, (size_t)m->r_u * m->n_out);
    TAKE(m->z_rest, m->r_u);
    TAKE(m->x_rest, m->r_f);
#undef TAKE
    return 1;
}

/* ---- FMI 2.0 ---------------------------------------------------------------------- */

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories, const fmi2String categories[]) {
    INSTANCE(c);
    (void)nCategories; (void)categories;
    inst->logging = loggingOn;
    return fmi2OK;
}

void fmi2FreeInstance(fmi2Component c);

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation, const fmi2CallbackFunctions *functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn) {
    Instance *inst;
    Model *m;
    char path[MAX_PATH_LENGTH];
    (void)visible;
    if (functions == NULL || functions->logger == NULL) return NULL;
    if (fmuType != fmi2CoSimulation) {
        log_message(functions, instanceName, fmi2Error, "only Co-Simulation is supported");
        return NULL;
    }
    inst = (Instance *)allocate(functions, 1, sizeof(Instance));
    if (inst == NULL) return NULL;
    memset(inst, 0, sizeof(Instance));
    inst->callbacks = *functions;
    inst->logging = loggingOn;
    inst->state = INSTANTIATED;
    inst->name = (char *)allocate(functions, strlen(instanceName ? instanceName : "step_map_rom") + 1, 1);
    if (inst->name) strcpy(inst->name, instanceName ? instanceName : "step_map_rom");
    if (!resource_file(fmuResourceLocation, path, sizeof(path))) {
        log_message(functions, instanceName, fmi2Error, "resource location '%s' is not a file URI",
                    fmuResourceLocation ? fmuResourceLocation : "(null)");
        fmi2FreeInstance(inst);
        return NULL;
    }
    if (!load_model(inst, path, fmuGUID)) { fmi2FreeInstance(inst); return NULL; }
    m = &inst->model;
    inst->n_values = (size_t)m->p * m->r_u + 2 * (size_t)m->r_f + m->n_in + m->n_out + m->n_probe + 1;
    inst->values = (double *)allocate(functions, inst->n_values, sizeof(double));
    inst->x = (double *)allocate(functions, (size_t)m->r_f, sizeof(double));
    inst->s = (double *)allocate(functions, (size_t)m->r_f, sizeof(double));
    inst->z = (double *)allocate(functions, (size_t)m->r_u, sizeof(double));
    inst->quad = (double *)allocate(functions, (size_t)m->n_quad, sizeof(double));
    inst->d = (double *)allocate(functions, (size_t)m->n_out, sizeof(double));
    if (!inst->values || !inst->x || !inst->s || !inst->z || !inst->quad || !inst->d) {
        log_message(functions, instanceName, fmi2Error, "out of memory");
        fmi2FreeInstance(inst);
        return NULL;
    }
    inst->zh = inst->values;
    inst->xh = inst->zh + (size_t)m->p * m->r_u;
    inst->inputs = inst->xh + 2 * (size_t)m->r_f;
    inst->outputs = inst->inputs + m->n_in;
    inst->time = inst->outputs + m->n_out + m->n_probe;
    at_rest(inst);
    return inst;
}

static void free_states(Instance *inst) {
    while (inst->states != NULL) {
        State *next = inst->states->next;
        release(&inst->callbacks, inst->states->values);
        release(&inst->callbacks, inst->states);
        inst->states = next;
    }
}

void fmi2FreeInstance(fmi2Component c) {
    Instance *inst = (Instance *)c;
    fmi2CallbackFunctions cb;
    if (inst == NULL) return;
    cb = inst->callbacks;
    free_states(inst);
    release(&cb, inst->values);
    release(&cb, inst->x);
    release(&cb, inst->s);
    release(&cb, inst->z);
    release(&cb, inst->quad);
    release(&cb, inst->d);
    release(&cb, inst->buffer);
    release(&cb, inst->name);
    release(&cb, inst);
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    INSTANCE(c);
    (void)toleranceDefined; (void)tolerance; (void)stopTimeDefined; (void)stopTime;
    REQUIRE(inst, INSTANTIATED, "fmi2SetupExperiment");
    if (!finite(startTime)) FAIL(inst, "fmi2SetupExperiment: start time %g is not finite", startTime);
    *inst->time = startTime;
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
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component c) {
    INSTANCE(c);
    at_rest(inst);
    inst->state = INSTANTIATED;
    return fmi2OK;
}

static fmi2Status check_references(Instance *inst, const char *function, const fmi2ValueReference vr[], size_t nvr,
                                   const void *values, int setting) {
    size_t i;
    const Model *m = &inst->model;
    const size_t total = (size_t)m->n_in + m->n_out + m->n_probe;
    if (nvr > 0 && (vr == NULL || values == NULL)) FAIL(inst, "%s: NULL value reference or value array", function);
    for (i = 0; i < nvr; i++) {
        if (vr[i] >= total) FAIL(inst, "%s: value reference %u is out of range (0..%lu)", function, vr[i],
                                 (unsigned long)(total - 1));
        if (setting && vr[i] >= (fmi2ValueReference)m->n_in)
            FAIL(inst, "%s: value reference %u is an output and cannot be set", function, vr[i]);
    }
    return fmi2OK;
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[]) {
    size_t i;
    INSTANCE(c);
    REQUIRE(inst, INITIALIZATION | STEP_COMPLETE | TERMINATED | ERROR, "fmi2GetReal");
    if (check_references(inst, "fmi2GetReal", vr, nvr, value, 0) != fmi2OK) return fmi2Error;
    for (i = 0; i < nvr; i++)   /* inputs and outputs are consecutive in the state */
        value[i] = inst->inputs[vr[i]];
    return fmi2OK;
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[]) {
    size_t i;
    INSTANCE(c);
    REQUIRE(inst, INSTANTIATED | INITIALIZATION | STEP_COMPLETE, "fmi2SetReal");
    if (check_references(inst, "fmi2SetReal", vr, nvr, value, 1) != fmi2OK) return fmi2Error;
    for (i = 0; i < nvr; i++)
        if (!finite(value[i])) FAIL(inst, "fmi2SetReal: value reference %u = %g is not finite", vr[i], value[i]);
    for (i = 0; i < nvr; i++) inst->inputs[vr[i]] = value[i];
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
        state = (State *)allocate(&inst->callbacks, 1, sizeof(State));
        if (state == NULL) FAIL(inst, "fmi2GetFMUstate: out of memory");
        state->values = (double *)allocate(&inst->callbacks, inst->n_values, sizeof(double));
        if (state->values == NULL) { release(&inst->callbacks, state); FAIL(inst, "fmi2GetFMUstate: out of memory"); }
        state->next = inst->states;
        inst->states = state;
    }
    memcpy(state->values, inst->values, sizeof(double) * inst->n_values);
    state->machine = inst->state;
    *FMUstate = state;
    return fmi2OK;
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate) {
    const State *state = (const State *)FMUstate;
    INSTANCE(c);
    if (state == NULL || !owns_state(inst, state)) FAIL(inst, "fmi2SetFMUstate: not a state of this instance");
    memcpy(inst->values, state->values, sizeof(double) * inst->n_values);
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
    release(&inst->callbacks, state->values);
    release(&inst->callbacks, state);
    *FMUstate = NULL;
    return fmi2OK;
}

/* a serialised state: "CSSTPST2", the model's GUID (40 characters, a digest of its arrays), its number of doubles
 * (int64), the FMI state it was taken in (int64), the doubles, in the machine's byte order */
static const char STATE_MAGIC[8] = {'C', 'S', 'S', 'T', 'P', 'S', 'T', '2'};
#define STATE_HEADER (sizeof STATE_MAGIC + GUID_LENGTH + 2 * sizeof(int64_t))

static size_t serialized_size(const Instance *inst) {
    return STATE_HEADER + sizeof(double) * inst->n_values;
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate s, size_t *size) {
    INSTANCE(c);
    if (s == NULL || !owns_state(inst, (const State *)s) || size == NULL)
        FAIL(inst, "fmi2SerializedFMUstateSize: not a state of this instance");
    *size = serialized_size(inst);
    return fmi2OK;
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate s, fmi2Byte bytes[], size_t size) {
    const State *state = (const State *)s;
    int64_t count, machine;
    INSTANCE(c);
    if (state == NULL || !owns_state(inst, state)) FAIL(inst, "fmi2SerializeFMUstate: not a state of this instance");
    if (bytes == NULL || size != serialized_size(inst))
        FAIL(inst, "fmi2SerializeFMUstate: a buffer of %lu bytes is needed", (unsigned long)serialized_size(inst));
    count = (int64_t)inst->n_values;
    machine = (int64_t)state->machine;
    memcpy(bytes, STATE_MAGIC, sizeof STATE_MAGIC);
    memcpy(bytes + sizeof STATE_MAGIC, inst->model.guid, GUID_LENGTH);
    memcpy(bytes + sizeof STATE_MAGIC + GUID_LENGTH, &count, sizeof count);
    memcpy(bytes + sizeof STATE_MAGIC + GUID_LENGTH + sizeof count, &machine, sizeof machine);
    memcpy(bytes + STATE_HEADER, state->values, sizeof(double) * inst->n_values);
    return fmi2OK;
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte bytes[], size_t size, fmi2FMUstate *s) {
    int64_t count, machine;
    size_t i;
    double value;
    fmi2FMUstate handle = NULL;
    INSTANCE(c);
    if (bytes == NULL || s == NULL) FAIL(inst, "fmi2DeSerializeFMUstate: NULL argument");
    if (size < STATE_HEADER || memcmp(bytes, STATE_MAGIC, sizeof STATE_MAGIC) != 0)
        FAIL(inst, "fmi2DeSerializeFMUstate: not a serialised state of this FMU (%lu bytes)", (unsigned long)size);
    if (memcmp(bytes + sizeof STATE_MAGIC, inst->model.guid, GUID_LENGTH) != 0)
        FAIL(inst, "fmi2DeSerializeFMUstate: a state of another model (GUID %.40s, this FMU's is %s)",
             (const char *)bytes + sizeof STATE_MAGIC, inst->model.guid);
    memcpy(&count, bytes + sizeof STATE_MAGIC + GUID_LENGTH, sizeof count);
    memcpy(&machine, bytes + sizeof STATE_MAGIC + GUID_LENGTH + sizeof count, sizeof machine);
    if (count != (int64_t)inst->n_values || size != serialized_size(inst))
        FAIL(inst, "fmi2DeSerializeFMUstate: a state of %ld values in %lu bytes, this model has %lu", (long)count,
             (unsigned long)size, (unsigned long)inst->n_values);
    if (machine != INSTANTIATED && machine != INITIALIZATION && machine != STEP_COMPLETE && machine != TERMINATED)
        FAIL(inst, "fmi2DeSerializeFMUstate: the state was taken in no valid FMI state (%ld)", (long)machine);
    for (i = 0; i < inst->n_values; i++) {
        memcpy(&value, bytes + STATE_HEADER + i * sizeof(double), sizeof value);
        if (!finite(value)) FAIL(inst, "fmi2DeSerializeFMUstate: value %lu of the state is %g, not finite",
                                 (unsigned long)i, value);
    }
    handle = (*s != NULL && owns_state(inst, (const State *)*s)) ? *s : NULL;
    if (fmi2GetFMUstate(c, &handle) != fmi2OK) return fmi2Error;
    memcpy(((State *)handle)->values, bytes + STATE_HEADER, sizeof(double) * inst->n_values);
    ((State *)handle)->machine = (int)machine;
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

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint, fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
    INSTANCE(c);
    (void)noSetFMUStatePriorToCurrentPoint;
    REQUIRE(inst, STEP_COMPLETE, "fmi2DoStep");
    if (!finite(currentCommunicationPoint) || !(communicationStepSize > 0.0) || !finite(communicationStepSize))
        FAIL(inst, "fmi2DoStep: communication point %g and step %g", currentCommunicationPoint, communicationStepSize);
    evaluate(inst);
    {   /* a state of values out of range (a damaged serialisation, say) gives no number: say so, never fmi2OK */
        int32_t i;
        for (i = 0; i < inst->model.n_out + inst->model.n_probe; i++)
            if (!finite(inst->outputs[i]))
                FAIL(inst, "fmi2DoStep: output %d at t = %g is not finite (the state or the inputs are out of range)",
                     (int)i, currentCommunicationPoint);
    }
    commit(inst);
    *inst->time = currentCommunicationPoint + communicationStepSize;
    return fmi2OK;
}

fmi2Status fmi2CancelStep(fmi2Component c) { return unsupported(c, "fmi2CancelStep"); }
fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value) {
    (void)s; (void)value; return unsupported(c, "fmi2GetStatus");
}
fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value) {
    INSTANCE(c);
    if (s == fmi2LastSuccessfulTime && value != NULL) { *value = *inst->time; return fmi2OK; }
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

/* ---- outside FMI: the in-process path and the take-over ------------------------------- */

static char last_message[1024];

static void keep_message(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status, fmi2String category,
                         fmi2String message, ...) {
    (void)env; (void)name; (void)status; (void)category;
    snprintf(last_message, sizeof(last_message), "%s", message);
}

static void *plain_allocate(size_t count, size_t size) { return calloc(count, size); }
static void plain_free(void *pointer) { free(pointer); }

const char *step_map_last_error(void) { return last_message; }

void *step_map_open(const char *resource_uri, const char *guid) {
    static const fmi2CallbackFunctions plain = {keep_message, plain_allocate, plain_free, NULL, NULL};
    last_message[0] = 0;
    return fmi2Instantiate("step_map_rom", fmi2CoSimulation, guid, resource_uri, &plain, fmi2False, fmi2False);
}

void step_map_close(void *c) { fmi2FreeInstance((fmi2Component)c); }

/* a window's call: f (n_in) in; u (n_out), probes (n_probe), x (r_f), z (r_u) out; the history stays */
void step_map_evaluate(void *c, const double *f, double *u, double *probes, double *x, double *z) {
    Instance *inst = (Instance *)c;
    const Model *m = &inst->model;
    memcpy(inst->inputs, f, sizeof(double) * (size_t)m->n_in);
    evaluate(inst);
    /* the caller's arrays may be the instance's own buffers (step_map_view): then there is nothing to copy */
    if (u != inst->outputs) memcpy(u, inst->outputs, sizeof(double) * (size_t)m->n_out);
    if (probes != inst->outputs + m->n_out) memcpy(probes, inst->outputs + m->n_out, sizeof(double) * (size_t)m->n_probe);
    if (x != inst->x) memcpy(x, inst->x, sizeof(double) * (size_t)m->r_f);
    if (z != inst->z) memcpy(z, inst->z, sizeof(double) * (size_t)m->r_u);
}

/* the last call's z and x join the history (a window closed) */
void step_map_commit(void *c) { commit((Instance *)c); }

/* write == 0: copy the history out into zh (p r_u) and xh (2 r_f); otherwise set it from them */
void step_map_history(void *c, double *zh, double *xh, int write) {
    Instance *inst = (Instance *)c;
    const Model *m = &inst->model;
    const size_t nz = sizeof(double) * (size_t)m->p * m->r_u, nx = sizeof(double) * 2 * (size_t)m->r_f;
    if (write) { memcpy(inst->zh, zh, nz); memcpy(inst->xh, xh, nx); }
    else { memcpy(zh, inst->zh, nz); memcpy(xh, inst->xh, nx); }
}

/* the history from n converged windows of a full-order run, oldest first: forces (n x n_in) encoded, interface
 * displacements (n x n_out) projected, z = Ap (u - base); each joins the history as a committed window would */
int step_map_take_over(void *c, int32_t n, const double *forces, const double *displacements) {
    Instance *inst = (Instance *)c;
    const Model *m = &inst->model;
    int32_t w, i, j;
    if (inst == NULL || n < 0) return 0;
    for (w = 0; w < n; w++) {
        const double *u = displacements + (size_t)w * m->n_out;
        encode(m, forces + (size_t)w * m->n_in, inst->x);
        for (j = 0; j < m->n_out; j++) inst->d[j] = u[j] - m->base[j];
        for (i = 0; i < m->r_u; i++) inst->z[i] = pairwise_dot(m->Ap + (size_t)i * m->n_out, inst->d, m->n_out);
        commit(inst);
    }
    return 1;
}

/* square root of q >= 0 without libm: the SSE2 instruction where there is one, else Newton's method */
#if defined(__SSE2__)
#include <emmintrin.h>
#endif
static double root(double q) {
#if defined(__SSE2__)
    return _mm_cvtsd_f64(_mm_sqrt_sd(_mm_setzero_pd(), _mm_set_sd(q)));
#else
    double r = q > 1.0 ? q : 1.0, previous = 0.0;
    int i;
    if (!(q > 0.0)) return q;
    for (i = 0; i < 2000 && r != previous; i++) { previous = r; r = 0.5 * (r + q / r); }
    return r;
#endif
}

/* the served path's envelope (r_f bounds, mean, precision r_f x r_f) and where its trust goes (3 values) */
void step_map_bind(void *c, const double *low, const double *high, const double *mean, const double *precision,
                   double max_distance, double *trust) {
    Instance *inst = (Instance *)c;
    inst->low = low; inst->high = high; inst->mean = mean; inst->precision = precision;
    inst->max_distance = max_distance; inst->trust = trust;
}

/* a served call: the window's call on f (n_in, or NULL for the inputs already held), then its trust
 * (excess beyond the envelope in range widths, Mahalanobis distance over the largest training one, 1.0 if the
 * excess passes margin); outputs, x and z stay in the instance (step_map_view); returns 1 if out of range */
int step_map_serve(void *c, const double *f, double margin) {
    Instance *inst = (Instance *)c;
    const Model *m = &inst->model;
    const int32_t r = m->r_f;
    double excess = 0.0, quadratic = 0.0;
    int32_t i, j;
    if (f != NULL) memcpy(inst->inputs, f, sizeof(double) * (size_t)m->n_in);
    evaluate(inst);
    if (inst->trust == NULL) return 0;
    for (i = 0; i < r; i++) {
        const double x = inst->x[i], below = inst->low[i] - x, above = x - inst->high[i];
        double width = inst->high[i] - inst->low[i], e = below > above ? below : above;
        if (!(width > 1e-300)) width = 1e-300;
        e = e > 0.0 ? e / width : 0.0;
        if (e > excess) excess = e;
    }
    for (i = 0; i < r; i++) {
        const double *row = inst->precision + (size_t)i * r;
        double s = 0.0;
        for (j = 0; j < r; j++) s += row[j] * (inst->x[j] - inst->mean[j]);
        quadratic += (inst->x[i] - inst->mean[i]) * s;
    }
    inst->trust[0] = excess;
    inst->trust[1] = root(quadratic > 0.0 ? quadratic : 0.0) / inst->max_distance;
    inst->trust[2] = excess > margin ? 1.0 : 0.0;
    return excess > margin;
}

/* the instance's own buffers: 0 the outputs then the probes (n_out + n_probe), 1 x (r_f), 2 z (r_u) */
double *step_map_view(void *c, int which) {
    Instance *inst = (Instance *)c;
    return which == 0 ? inst->outputs : which == 1 ? inst->x : inst->z;
}
