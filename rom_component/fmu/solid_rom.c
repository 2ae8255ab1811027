/*
 * Solid ROM as an FMI 2.0 Co-Simulation FMU: the online interface path of a trained
 * non-intrusive ROM (rom_component), with no Python at run time.
 *
 *   x   = E f - e                     encoder (r_f), input scaling folded in
 *   z   = [phi(|x - c_i|^2), x, 1]    thin-plate-spline kernel values (RBF), or
 *       = [x_qi * x_qj, x, 1]         unique quadratic terms (sparse polynomial)
 *   u~  = H z                         reduced displacements (r_u)
 *   u_G = base + A u~ [+ B q(u~)]     interface displacements (linear or quadratic manifold decoder)
 *
 * Every array and size is read at fmi2Instantiate from resources/rom.bin (little-endian):
 *   char magic[8] = "CSROM01"; char guid[40];
 *   int32 n_in, n_out, r_f, r_u, m, regressor (0 rbf, 1 poly), decoder (0 linear, 1 quadratic), reserved;
 *   float64 E[r_f][n_in], e[r_f];
 *   rbf: float64 centres[m][r_f]   |   poly: int32 qi[m], qj[m];
 *   float64 H[r_u][m + r_f + 1], A[n_out][r_u], base[n_out];
 *   quadratic decoder: float64 B[n_out][r_u (r_u + 1) / 2].
 * Value references: inputs 0 .. n_in-1, outputs n_in .. n_in+n_out-1.
 * Every sum runs in the order of OnlineRom(arithmetic="reproducible") (numpy's pairwise row
 * sums, sequential short sums, libm's log), so results are bit-identical to the Python ROM;
 * build without -ffast-math and with -ffp-contract=off.
 * The ROM is stateless; an FMU state is a copy of inputs, outputs and time.
 */
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"

#define MAGIC "CSROM01"
#define GUID_LENGTH 40
#define MAX_PATH_LENGTH 4096

typedef struct {
    int32_t n_in, n_out, r_f, r_u, m, regressor, decoder, reserved;
    double *E, *e, *centres, *H, *A, *base, *B, *c2;
    int32_t *qi, *qj;
    int32_t n_quad;           /* r_u (r_u + 1) / 2 */
    char guid[GUID_LENGTH + 1];
} Model;

typedef struct {
    double *inputs, *outputs;
    double time;
} State;

typedef struct {
    fmi2CallbackFunctions callbacks;
    char *name;
    int logging;
    Model model;
    double *inputs, *outputs, *x, *z, *reduced, *scratch, *quad;
    double time;
    char *buffer;             /* the resource file, all arrays point into it */
} Instance;

/* ---- helpers -------------------------------------------------------------------- */

static void log_message(const fmi2CallbackFunctions *cb, fmi2String name, fmi2Status status,
                        fmi2String category, const char *format, ...) {
    char message[1024], escaped[2048];
    size_t i, n = 0;
    va_list args;
    if (cb == NULL || cb->logger == NULL) return;
    va_start(args, format);
    vsnprintf(message, sizeof(message), format, args);
    va_end(args);
    /* the text goes as the format itself (with '%' doubled): readable by loggers that ignore varargs */
    for (i = 0; message[i] && n + 2 < sizeof(escaped); i++) {
        if (message[i] == '%') escaped[n++] = '%';
        escaped[n++] = message[i];
    }
    escaped[n] = 0;
    cb->logger(cb->componentEnvironment, name ? name : "solid_rom", status, category, escaped);
}

#define FAIL(inst, ...) do { log_message(&(inst)->callbacks, (inst)->name, fmi2Error, "logStatusError", __VA_ARGS__); \
                             return fmi2Error; } while (0)

static void *allocate(const fmi2CallbackFunctions *cb, size_t count, size_t size) {
    if (count == 0) count = 1;
    return cb->allocateMemory ? cb->allocateMemory(count, size) : calloc(count, size);
}

static void release(const fmi2CallbackFunctions *cb, void *pointer) {
    if (pointer == NULL) return;
    if (cb->freeMemory) cb->freeMemory(pointer); else free(pointer);
}

/* "file:///a/b%20c/" or "file:/a/b" or "file://localhost/a" -> "/a/b c/rom.bin" */
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
    size_t offset = 0, need;
    Model *m = &inst->model;
    if (f == NULL) {
        log_message(&inst->callbacks, inst->name, fmi2Error, "logStatusError", "cannot open resource file '%s'", file);
        return 0;
    }
    fseek(f, 0, SEEK_END);
    length = ftell(f);
    fseek(f, 0, SEEK_SET);
    if (length < (long)(8 + GUID_LENGTH + 8 * sizeof(int32_t))) {
        fclose(f);
        log_message(&inst->callbacks, inst->name, fmi2Error, "logStatusError", "resource file '%s' is truncated", file);
        return 0;
    }
    inst->buffer = (char *)allocate(&inst->callbacks, (size_t)length + 8, 1);
    if (inst->buffer == NULL || fread(inst->buffer, 1, (size_t)length, f) != (size_t)length) {
        fclose(f);
        log_message(&inst->callbacks, inst->name, fmi2Error, "logStatusError", "cannot read resource file '%s'", file);
        return 0;
    }
    fclose(f);
    if (memcmp(inst->buffer, MAGIC, 8) != 0) {
        log_message(&inst->callbacks, inst->name, fmi2Error, "logStatusError", "'%s' is not a solid ROM resource", file);
        return 0;
    }
    offset = 8;
    memcpy(m->guid, inst->buffer + offset, GUID_LENGTH);
    m->guid[GUID_LENGTH] = 0;
    offset += GUID_LENGTH;
    if (guid == NULL || strcmp(guid, m->guid) != 0) {
        log_message(&inst->callbacks, inst->name, fmi2Error, "logStatusError",
                    "GUID '%s' does not match the resource's '%s'", guid ? guid : "(null)", m->guid);
        return 0;
    }
    memcpy(&m->n_in, inst->buffer + offset, 8 * sizeof(int32_t));
    offset += 8 * sizeof(int32_t);
    if (m->n_in <= 0 || m->n_out <= 0 || m->r_f <= 0 || m->r_u <= 0 || m->m <= 0 ||
        (m->regressor != 0 && m->regressor != 1) || (m->decoder != 0 && m->decoder != 1)) {
        log_message(&inst->callbacks, inst->name, fmi2Error, "logStatusError", "resource '%s' has invalid sizes", file);
        return 0;
    }
    m->n_quad = m->r_u * (m->r_u + 1) / 2;
    need = offset + sizeof(double) * ((size_t)m->r_f * m->n_in + m->r_f + (size_t)m->r_u * (m->m + m->r_f + 1) +
                                      (size_t)m->n_out * m->r_u + m->n_out)
         + (m->regressor == 0 ? sizeof(double) * (size_t)m->m * m->r_f : 2 * sizeof(int32_t) * (size_t)m->m)
         + (m->decoder == 1 ? sizeof(double) * (size_t)m->n_out * m->n_quad : 0);
    if ((size_t)length != need) {
        log_message(&inst->callbacks, inst->name, fmi2Error, "logStatusError",
                    "resource '%s' has %ld bytes, the sizes in its header need %lu", file, length, (unsigned long)need);
        return 0;
    }
#define TAKE(target, type, count) do { target = (type *)(inst->buffer + offset); offset += sizeof(type) * (size_t)(count); } while (0)
    TAKE(m->E, double, (size_t)m->r_f * m->n_in);
    TAKE(m->e, double, m->r_f);
    if (m->regressor == 0) {
        TAKE(m->centres, double, (size_t)m->m * m->r_f);
    } else {
        TAKE(m->qi, int32_t, m->m);
        TAKE(m->qj, int32_t, m->m);
    }
    TAKE(m->H, double, (size_t)m->r_u * (m->m + m->r_f + 1));
    TAKE(m->A, double, (size_t)m->n_out * m->r_u);
    TAKE(m->base, double, m->n_out);
    if (m->decoder == 1) TAKE(m->B, double, (size_t)m->n_out * m->n_quad);
#undef TAKE
    if (m->regressor == 1) {
        int32_t i;
        for (i = 0; i < m->m; i++)
            if (m->qi[i] < 0 || m->qi[i] >= m->r_f || m->qj[i] < 0 || m->qj[i] >= m->r_f) {
                log_message(&inst->callbacks, inst->name, fmi2Error, "logStatusError", "resource '%s': bad term index", file);
                return 0;
            }
    }
    return 1;
}

/* numpy's pairwise summation (the order of ndarray.sum along a contiguous axis):
 * 8 running sums over blocks of at most 128 values, halving recursively above that */
static double pairwise_sum(const double *a, int32_t n) {
    if (n < 8) {
        double res = -0.0;
        int32_t i;
        for (i = 0; i < n; i++) res += a[i];
        return res;
    }
    if (n <= 128) {
        double r[8], res;
        int32_t i, j;
        for (j = 0; j < 8; j++) r[j] = a[j];
        for (i = 8; i < n - (n % 8); i += 8)
            for (j = 0; j < 8; j++) r[j] += a[i + j];
        res = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]));
        for (; i < n; i++) res += a[i];
        return res;
    } else {
        int32_t n2 = n / 2;
        n2 -= n2 % 8;
        return pairwise_sum(a, n2) + pairwise_sum(a + n2, n - n2);
    }
}

/* sum_i row[i] * v[i] in the pairwise order; products go through a scratch row */
static double pairwise_dot(const double *row, const double *v, int32_t n, double *scratch) {
    int32_t i;
    for (i = 0; i < n; i++) scratch[i] = row[i] * v[i];
    return pairwise_sum(scratch, n);
}

/* the interface path, operation for operation as OnlineRom(arithmetic="reproducible") */
static void evaluate(Instance *inst) {
    const Model *m = &inst->model;
    const int32_t width = m->m + m->r_f + 1;
    int32_t i, k, a, o;
    for (k = 0; k < m->r_f; k++)
        inst->x[k] = pairwise_dot(m->E + (size_t)k * m->n_in, inst->inputs, m->n_in, inst->scratch) - m->e[k];
    if (m->regressor == 0) {
        for (i = 0; i < m->m; i++) {
            const double *c = m->centres + (size_t)i * m->r_f;
            double d = inst->x[0] - c[0], d2 = d * d;
            for (k = 1; k < m->r_f; k++) { d = inst->x[k] - c[k]; d2 = d2 + d * d; }
            inst->z[i] = d2 == 0.0 ? 0.0 : d2 * log(d2);   /* 0.5 of the kernel is folded into H */
        }
    } else {
        for (i = 0; i < m->m; i++) inst->z[i] = inst->x[m->qi[i]] * inst->x[m->qj[i]];
    }
    for (k = 0; k < m->r_f; k++) inst->z[m->m + k] = inst->x[k];
    inst->z[m->m + m->r_f] = 1.0;
    for (a = 0; a < m->r_u; a++)
        inst->reduced[a] = pairwise_dot(m->H + (size_t)a * width, inst->z, width, inst->scratch);
    if (m->decoder == 1) {
        int32_t q = 0, b;
        for (a = 0; a < m->r_u; a++)
            for (b = a; b < m->r_u; b++) inst->quad[q++] = inst->reduced[a] * inst->reduced[b];
    }
    for (o = 0; o < m->n_out; o++) {
        const double *row = m->A + (size_t)o * m->r_u;
        double s = row[0] * inst->reduced[0];                 /* sequential over r_u */
        for (a = 1; a < m->r_u; a++) s = s + row[a] * inst->reduced[a];
        s = s + m->base[o];
        if (m->decoder == 1) {
            const double *brow = m->B + (size_t)o * m->n_quad;
            double t = brow[0] * inst->quad[0];
            int32_t q;
            for (q = 1; q < m->n_quad; q++) t = t + brow[q] * inst->quad[q];
            s = s + t;
        }
        inst->outputs[o] = s;
    }
}

static fmi2Status check_references(Instance *inst, const char *function, const fmi2ValueReference vr[], size_t nvr,
                                   const void *values, int writable_outputs) {
    size_t i;
    const size_t total = (size_t)inst->model.n_in + (size_t)inst->model.n_out;
    if (nvr > 0 && (vr == NULL || values == NULL)) FAIL(inst, "%s: NULL value reference or value array for %lu values",
                                                      function, (unsigned long)nvr);
    if (nvr > total) FAIL(inst, "%s: %lu values requested, the FMU has %lu variables", function,
                          (unsigned long)nvr, (unsigned long)total);
    for (i = 0; i < nvr; i++) {
        if (vr[i] >= total) FAIL(inst, "%s: value reference %u is out of range (0..%lu)", function, vr[i],
                                 (unsigned long)(total - 1));
        if (!writable_outputs && vr[i] >= (fmi2ValueReference)inst->model.n_in)
            FAIL(inst, "%s: value reference %u is an output and cannot be set", function, vr[i]);
    }
    return fmi2OK;
}

#define INSTANCE(c, function) Instance *inst = (Instance *)(c); if (inst == NULL) return fmi2Error; (void)(function)

/* ---- FMI 2.0 functions ---------------------------------------------------------- */

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories, const fmi2String categories[]) {
    INSTANCE(c, "fmi2SetDebugLogging");
    (void)nCategories; (void)categories;
    inst->logging = loggingOn;
    return fmi2OK;
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation, const fmi2CallbackFunctions *functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn) {
    Instance *inst;
    char path[MAX_PATH_LENGTH];
    const Model *m;
    (void)visible;
    if (functions == NULL) return NULL;
    if (fmuType != fmi2CoSimulation) {
        log_message(functions, instanceName, fmi2Error, "logStatusError", "only Co-Simulation is supported");
        return NULL;
    }
    inst = (Instance *)allocate(functions, 1, sizeof(Instance));
    if (inst == NULL) return NULL;
    inst->callbacks = *functions;
    inst->logging = loggingOn;
    inst->name = (char *)allocate(functions, strlen(instanceName ? instanceName : "solid_rom") + 1, 1);
    if (inst->name) strcpy(inst->name, instanceName ? instanceName : "solid_rom");
    if (!resource_file(fmuResourceLocation, path, sizeof(path))) {
        log_message(functions, instanceName, fmi2Error, "logStatusError",
                    "resource location '%s' is not a file URI", fmuResourceLocation ? fmuResourceLocation : "(null)");
        fmi2FreeInstance(inst);
        return NULL;
    }
    if (!load_model(inst, path, fmuGUID)) {
        fmi2FreeInstance(inst);
        return NULL;
    }
    m = &inst->model;
    inst->inputs = (double *)allocate(functions, (size_t)m->n_in, sizeof(double));
    inst->outputs = (double *)allocate(functions, (size_t)m->n_out, sizeof(double));
    inst->x = (double *)allocate(functions, (size_t)m->r_f, sizeof(double));
    inst->z = (double *)allocate(functions, (size_t)(m->m + m->r_f + 1), sizeof(double));
    inst->reduced = (double *)allocate(functions, (size_t)m->r_u, sizeof(double));
    inst->quad = (double *)allocate(functions, (size_t)m->n_quad, sizeof(double));
    inst->scratch = (double *)allocate(functions, (size_t)(m->n_in > m->m + m->r_f + 1 ? m->n_in : m->m + m->r_f + 1),
                                       sizeof(double));
    if (!inst->inputs || !inst->outputs || !inst->x || !inst->z || !inst->reduced || !inst->quad || !inst->scratch) {
        log_message(functions, instanceName, fmi2Error, "logStatusError", "out of memory");
        fmi2FreeInstance(inst);
        return NULL;
    }
    evaluate(inst);
    return inst;
}

void fmi2FreeInstance(fmi2Component c) {
    Instance *inst = (Instance *)c;
    fmi2CallbackFunctions cb;
    if (inst == NULL) return;
    cb = inst->callbacks;
    release(&cb, inst->inputs);
    release(&cb, inst->outputs);
    release(&cb, inst->x);
    release(&cb, inst->z);
    release(&cb, inst->reduced);
    release(&cb, inst->quad);
    release(&cb, inst->scratch);
    release(&cb, inst->buffer);
    release(&cb, inst->name);
    release(&cb, inst);
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    INSTANCE(c, "fmi2SetupExperiment");
    (void)toleranceDefined; (void)tolerance; (void)stopTimeDefined; (void)stopTime;
    inst->time = startTime;
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) { INSTANCE(c, 0); return fmi2OK; }

fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    INSTANCE(c, 0);
    evaluate(inst);
    return fmi2OK;
}

fmi2Status fmi2Terminate(fmi2Component c) { INSTANCE(c, 0); return fmi2OK; }

fmi2Status fmi2Reset(fmi2Component c) {
    INSTANCE(c, 0);
    memset(inst->inputs, 0, sizeof(double) * (size_t)inst->model.n_in);
    inst->time = 0.0;
    evaluate(inst);
    return fmi2OK;
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[]) {
    size_t i;
    INSTANCE(c, 0);
    if (check_references(inst, "fmi2GetReal", vr, nvr, value, 1) != fmi2OK) return fmi2Error;
    for (i = 0; i < nvr; i++)
        value[i] = vr[i] < (fmi2ValueReference)inst->model.n_in ? inst->inputs[vr[i]]
                                                                : inst->outputs[vr[i] - inst->model.n_in];
    return fmi2OK;
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[]) {
    size_t i;
    INSTANCE(c, 0);
    if (check_references(inst, "fmi2SetReal", vr, nvr, value, 0) != fmi2OK) return fmi2Error;
    for (i = 0; i < nvr; i++) inst->inputs[vr[i]] = value[i];
    return fmi2OK;
}

static fmi2Status no_variables(fmi2Component c, const char *function, size_t nvr) {
    INSTANCE(c, 0);
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

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    State *state;
    INSTANCE(c, 0);
    if (FMUstate == NULL) FAIL(inst, "fmi2GetFMUstate: NULL state pointer");
    state = (State *)*FMUstate;
    if (state == NULL) {
        state = (State *)allocate(&inst->callbacks, 1, sizeof(State));
        if (state == NULL) FAIL(inst, "fmi2GetFMUstate: out of memory");
        state->inputs = (double *)allocate(&inst->callbacks, (size_t)inst->model.n_in, sizeof(double));
        state->outputs = (double *)allocate(&inst->callbacks, (size_t)inst->model.n_out, sizeof(double));
        if (!state->inputs || !state->outputs) FAIL(inst, "fmi2GetFMUstate: out of memory");
    }
    memcpy(state->inputs, inst->inputs, sizeof(double) * (size_t)inst->model.n_in);
    memcpy(state->outputs, inst->outputs, sizeof(double) * (size_t)inst->model.n_out);
    state->time = inst->time;
    *FMUstate = state;
    return fmi2OK;
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate) {
    const State *state = (const State *)FMUstate;
    INSTANCE(c, 0);
    if (state == NULL) FAIL(inst, "fmi2SetFMUstate: NULL state");
    memcpy(inst->inputs, state->inputs, sizeof(double) * (size_t)inst->model.n_in);
    memcpy(inst->outputs, state->outputs, sizeof(double) * (size_t)inst->model.n_out);
    inst->time = state->time;
    return fmi2OK;
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    State *state;
    INSTANCE(c, 0);
    if (FMUstate == NULL || *FMUstate == NULL) return fmi2OK;
    state = (State *)*FMUstate;
    release(&inst->callbacks, state->inputs);
    release(&inst->callbacks, state->outputs);
    release(&inst->callbacks, state);
    *FMUstate = NULL;
    return fmi2OK;
}

static fmi2Status unsupported(fmi2Component c, const char *function) {
    INSTANCE(c, 0);
    FAIL(inst, "%s is not supported by this FMU", function);
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate s, size_t *size) {
    (void)s; (void)size; return unsupported(c, "fmi2SerializedFMUstateSize");
}
fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate s, fmi2Byte bytes[], size_t size) {
    (void)s; (void)bytes; (void)size; return unsupported(c, "fmi2SerializeFMUstate");
}
fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte bytes[], size_t size, fmi2FMUstate *s) {
    (void)bytes; (void)size; (void)s; return unsupported(c, "fmi2DeSerializeFMUstate");
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
    INSTANCE(c, 0);
    (void)noSetFMUStatePriorToCurrentPoint;
    if (communicationStepSize < 0.0) FAIL(inst, "fmi2DoStep: negative step size %g", communicationStepSize);
    evaluate(inst);
    inst->time = currentCommunicationPoint + communicationStepSize;
    return fmi2OK;
}

fmi2Status fmi2CancelStep(fmi2Component c) { return unsupported(c, "fmi2CancelStep"); }

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value) {
    (void)s; (void)value; return unsupported(c, "fmi2GetStatus");
}
fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value) {
    INSTANCE(c, 0);
    if (s == fmi2LastSuccessfulTime && value != NULL) { *value = inst->time; return fmi2OK; }
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
