/*
 * What every exported ROM shares whatever the FMI version: memory and messages through the skeleton's services,
 * the resource file with its common header, the values block, the names of the variables, and the sums and the
 * trust the ROMs compute with (rom_fmu.h has the contract).
 */
#include "rom_arithmetic.h"

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "rom_fmu.h"

#define MAX_PATH_LENGTH 4096

void *rom_allocate(Rom *rom, size_t count, size_t size) { return rom->allocate(rom->host, count ? count : 1, size); }

void rom_free(Rom *rom, void *pointer) {
    if (pointer != NULL) rom->free(rom->host, pointer);
}

/* an error is reported unless the importer switched logStatusError off; an event only with loggingOn and
 * logEvents enabled */
static void say(Rom *rom, int error, const char *category, const char *format, va_list args) {
    char message[1024];
    if (!(error ? rom->log_errors : rom->logging && rom->log_events)) return;
    vsnprintf(message, sizeof(message), format, args);
    rom->report(rom->host, error, category, message);
}

/* an error, in the category logStatusError */
void rom_error(Rom *rom, const char *format, ...) {
    va_list args;
    va_start(args, format);
    say(rom, 1, "logStatusError", format, args);
    va_end(args);
}

/* an event, in the category logEvents */
void rom_event(Rom *rom, const char *format, ...) {
    va_list args;
    va_start(args, format);
    say(rom, 0, "logEvents", format, args);
    va_end(args);
}

int rom_finite(double v) { return v - v == 0.0; }   /* false for NaN and +-Inf, without libm */

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

/* resources/rom.bin read whole, its common header checked (magic, the GUID the importer gave), then the ROM's
 * sizes and arrays (rom_load); 0 with an error reported otherwise. The resources folder is a file URI (FMI 2.0)
 * or an absolute path (FMI 3.0). */
static int read_resource(Rom *rom, const char *resources, const char *guid) {
    char file[MAX_PATH_LENGTH];
    FILE *f;
    long length;
    if (resources != NULL && resources[0] == '/') {
        size_t n = strlen(resources);
        while (n > 0 && resources[n - 1] == '/') n--;
        if (n + strlen("/rom.bin") + 1 > sizeof(file)) {
            rom_error(rom, "resource path '%s' is too long", resources);
            return 0;
        }
        memcpy(file, resources, n);
        strcpy(file + n, "/rom.bin");
    } else if (!resource_file(resources, file, sizeof(file))) {
        rom_error(rom, "resource location '%s' is not a file URI", resources ? resources : "(null)");
        return 0;
    }
    f = fopen(file, "rb");
    if (f == NULL) {
        rom_error(rom, "cannot open resource file '%s'", file);
        return 0;
    }
    fseek(f, 0, SEEK_END);
    length = ftell(f);
    fseek(f, 0, SEEK_SET);
    if (length < (long)(ROM_HEADER_BYTES + ROM_KIND.header_ints * sizeof(int32_t))) {
        fclose(f);
        rom_error(rom, "resource file '%s' is truncated", file);
        return 0;
    }
    rom->buffer = (char *)rom_allocate(rom, (size_t)length + 8, 1);
    if (rom->buffer == NULL || fread(rom->buffer, 1, (size_t)length, f) != (size_t)length) {
        fclose(f);
        rom_error(rom, "cannot read resource file '%s'", file);
        return 0;
    }
    fclose(f);
    rom->length = (size_t)length;
    if (memcmp(rom->buffer, ROM_KIND.resource_magic, 8) != 0) {
        rom_error(rom, "'%s' is not a %s resource", file, ROM_KIND.what);
        return 0;
    }
    memcpy(rom->guid, rom->buffer + 8, ROM_GUID_LENGTH);
    rom->guid[ROM_GUID_LENGTH] = 0;
    if (guid == NULL || strcmp(guid, rom->guid) != 0) {
        rom_error(rom, "GUID '%s' does not match the resource's '%s'", guid ? guid : "(null)", rom->guid);
        return 0;
    }
    memcpy(rom->input_name, rom->buffer + 8 + ROM_GUID_LENGTH, ROM_NAME_LENGTH);
    rom->input_name[ROM_NAME_LENGTH] = 0;
    memcpy(rom->output_name, rom->buffer + 8 + ROM_GUID_LENGTH + ROM_NAME_LENGTH, ROM_NAME_LENGTH);
    rom->output_name[ROM_NAME_LENGTH] = 0;
    return rom_load(rom, file);
}

/* the ROM's model struct (bytes, zeroed, freed with the instance), starting with the resource's int32 sizes as
 * they follow its common header; NULL (reported) if out of memory */
void *rom_model(Rom *rom, size_t bytes) {
    rom->model = rom_allocate(rom, 1, bytes);
    if (rom->model == NULL) rom_error(rom, "out of memory");
    else memcpy(rom->model, rom->buffer + ROM_HEADER_BYTES, sizeof(int32_t) * (size_t)ROM_KIND.header_ints);
    return rom->model;
}

/* the ROM's variables (inputs, outputs, locals in groups of local_width) and the doubles of its history */
void rom_declare(Rom *rom, int32_t n_in, int32_t n_out, int32_t n_local, int32_t local_width, int32_t components,
                 size_t n_history) {
    rom->n_in = n_in;
    rom->n_out = n_out;
    rom->n_local = n_local;
    rom->local_width = local_width > 0 ? local_width : 1;
    rom->components = components;
    rom->n_history = n_history;
}

/* count zeroed doubles for the ROM's working arrays, freed with the instance; NULL (reported) if out of memory */
double *rom_work(Rom *rom, size_t count) {
    rom->work = (double *)rom_allocate(rom, count, sizeof(double));
    if (rom->work == NULL) rom_error(rom, "out of memory");
    return rom->work;
}

/* the values block for the sizes rom_load declared */
static int allocate_values(Rom *rom) {
    rom->n_values = rom->n_history + (size_t)rom->n_in + (size_t)rom->n_out + (size_t)rom->n_local + 1;
    rom->values = (double *)rom_allocate(rom, rom->n_values, sizeof(double));
    if (rom->values == NULL) return 0;
    rom->history = rom->values;
    rom->inputs = rom->history + rom->n_history;
    rom->outputs = rom->inputs + rom->n_in;
    rom->time = rom->outputs + rom->n_out + rom->n_local;
    return 1;
}

/* inputs zero, time zero, the history at rest, the outputs evaluated */
static void reset_values(Rom *rom) {
    memset(rom->values, 0, sizeof(double) * rom->n_values);
    rom_rest(rom);
    rom_evaluate(rom);
    rom->dirty = 0;
}

/* "pressure[12]" or "force[3].y": the scalar of the inputs, outputs and locals in that order at index
 * ("local 3" beyond the outputs) */
const char *rom_variable_name(const Rom *rom, uint32_t scalar, char *text, size_t size) {
    int input = scalar < (uint32_t)rom->n_in;
    long index = input ? (long)scalar : (long)scalar - rom->n_in;
    int c = rom->components > 1 ? rom->components : 1;
    if (!input && index >= rom->n_out) snprintf(text, size, "local %ld", index - rom->n_out);
    else if (c == 1) snprintf(text, size, "%s[%ld]", input ? rom->input_name : rom->output_name, index + 1);
    else snprintf(text, size, "%s[%ld].%c", input ? rom->input_name : rom->output_name, index / c + 1, "xyz"[index % c]);
    return text;
}

/* sum_i row[i] * v[i], each product rounded, then summed in numpy's pairwise order (the order of
 * ndarray.sum along a contiguous axis: 8 running sums over blocks of at most 128 values, halving
 * recursively above that), without a scratch row */
HOT double rom_pairwise_dot(const double *row, const double *v, int32_t n) {
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
        return rom_pairwise_dot(row, v, n2) + rom_pairwise_dot(row + n2, v + n2, n - n2);
    }
}

/* the trust of reduced forces x (r values) against a training envelope (rom_component.envelope.trust):
 * out[0] the largest excess beyond [low, high] in range widths (0 inside, NaN if an x is NaN), out[1] the squared
 * Mahalanobis distance to mean (precision: r x r, row-major), clipped at 0; no libm, so no root */
void rom_trust(const double *x, int32_t r, const double *low, const double *high, const double *mean,
               const double *precision, double out[2]) {
    double excess = 0.0, quadratic = 0.0;
    int32_t i, j;
    for (i = 0; i < r; i++) {
        const double below = low[i] - x[i], above = x[i] - high[i];
        double width = high[i] - low[i], e = below > above ? below : above;
        if (x[i] != x[i]) excess = x[i];
        if (excess != excess) continue;
        if (!(width > 1e-300)) width = 1e-300;
        e = e > 0.0 ? e / width : 0.0;
        if (e > excess) excess = e;
    }
    for (i = 0; i < r; i++) {
        const double *row = precision + (size_t)i * r;
        double s = 0.0;
        for (j = 0; j < r; j++) s += row[j] * (x[j] - mean[j]);
        quadratic += (x[i] - mean[i]) * s;
    }
    out[0] = excess;
    out[1] = quadratic > 0.0 ? quadratic : 0.0;
}

/* square root of q >= 0 without libm: the SSE2 instruction (IEEE, correctly rounded, as Python's math.sqrt),
 * else Newton's method from q (the last bit may differ) */
double rom_root(double q) {
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

/* ---- the instance, whatever the FMI version ---- */

/* an error: reported, and the instance enters its error state; returns 0 */
int rom_fail(Rom *rom, const char *format, ...) {
    va_list args;
    va_start(args, format);
    say(rom, 1, "logStatusError", format, args);
    va_end(args);
    rom->machine = ROM_ERROR;
    return 0;
}

static const char *machine_name(int machine) {
    static const char *const names[] = {
        "the instantiated state (before EnterInitializationMode)", "Initialization Mode", "Step Mode",
        "the terminated state", "the error state (only Reset and FreeInstance lead out)"};
    int bit = 0;
    while (bit < 4 && machine != 1 << bit) bit++;
    return names[bit];
}

/* whether function may be called in the present machine state; refused (an error) otherwise */
int rom_allowed(Rom *rom, int allowed, const char *function) {
    if (rom->machine & allowed) return 1;
    return rom_fail(rom, "%s is not allowed in %s", function, machine_name(rom->machine));
}

/* the instance read from its resources, its values at rest, in the instantiated state; 0 (reported) otherwise */
int rom_instantiate(Rom *rom, const char *resources, const char *guid) {
    char description[512];
    rom->machine = ROM_INSTANTIATED;
    rom->log_events = 1;
    rom->log_errors = 1;
    if (!read_resource(rom, resources, guid)) return 0;
    if (!allocate_values(rom)) {
        rom_error(rom, "out of memory");
        return 0;
    }
    reset_values(rom);
    rom_describe(rom, description, sizeof(description));
    rom_event(rom, "instantiated: %s", description);
    return 1;
}

/* everything the instance holds but the skeleton's own */
void rom_release_all(Rom *rom) {
    while (rom->states != NULL) {
        RomState *next = rom->states->next;
        rom_free(rom, rom->states->values);
        rom_free(rom, rom->states);
        rom->states = next;
    }
    rom_free(rom, rom->work);
    rom_free(rom, rom->model);
    rom_free(rom, rom->values);
    rom_free(rom, rom->buffer);
}

/* SetDebugLogging: no categories, every category follows loggingOn; a list, those categories do */
int rom_set_logging(Rom *rom, int on, size_t n, const char *const categories[], const char *function) {
    static const char *const known[] = {"logEvents", "logStatusError"};
    size_t i, k;
    if (n > 0 && categories == NULL) return rom_fail(rom, "%s: NULL category list", function);
    for (i = 0; i < n; i++) {
        int found = 0;
        for (k = 0; k < sizeof(known) / sizeof(known[0]); k++)
            if (categories[i] && strcmp(categories[i], known[k]) == 0) found = 1;
        if (!found) return rom_fail(rom, "%s: unknown log category '%s' (known: logEvents, logStatusError)", function,
                                    categories[i] ? categories[i] : "(null)");
    }
    rom->logging = on;
    if (n == 0) rom->log_events = rom->log_errors = 1;
    for (i = 0; i < n; i++) {
        if (strcmp(categories[i], "logEvents") == 0) rom->log_events = on;
        else rom->log_errors = on;
    }
    return 1;
}

/* the experiment's start (and stop) time, checked */
int rom_start(Rom *rom, double start, int stop_defined, double stop, const char *function) {
    if (!rom_finite(start)) return rom_fail(rom, "%s: start time %g is not finite", function, start);
    if (stop_defined && !(stop >= start))
        return rom_fail(rom, "%s: stop time %g is before the start time %g", function, stop, start);
    *rom->time = start;
    return 1;
}

int rom_exit_initialization(Rom *rom, const char *function) {
    if (!rom_allowed(rom, ROM_INITIALIZATION, function)) return 0;
    rom_evaluate(rom);
    rom->dirty = 0;
    rom->machine = ROM_STEP;
    return 1;
}

int rom_terminate(Rom *rom, const char *function) {
    if (!rom_allowed(rom, ROM_STEP, function)) return 0;
    rom->machine = ROM_TERMINATED;
    rom_event(rom, "terminated at t = %g", *rom->time);
    return 1;
}

void rom_reset(Rom *rom) {
    reset_values(rom);
    rom->machine = ROM_INSTANTIATED;
}

/* before outputs are read: in Initialization Mode they follow the inputs set there */
void rom_update(Rom *rom) {
    if (rom->machine == ROM_INITIALIZATION && rom->dirty) {
        rom_evaluate(rom);
        rom->dirty = 0;
    }
}

/* one step: the outputs from the inputs and the history, then the step joins the history */
int rom_step(Rom *rom, double t, double h, const char *function) {
    int32_t i;
    if (!rom_allowed(rom, ROM_STEP, function)) return 0;
    if (!rom_finite(t)) return rom_fail(rom, "%s: communication point %g is not finite", function, t);
    if (!(h > 0.0) || !rom_finite(h)) return rom_fail(rom, "%s: step size %g is not a positive finite number", function, h);
    rom_evaluate(rom);
    rom->dirty = 0;
    /* a state of values out of range (a damaged serialisation, say) gives no number: say so, never OK */
    for (i = 0; i < rom->n_out + rom->n_local; i++)
        if (!rom_finite(rom->outputs[i]))
            return rom_fail(rom, "%s: output %d at t = %g is not finite (the state or the inputs are out of range)",
                            function, (int)i, t);
    rom_commit(rom);
    *rom->time = t + h;
    return 1;
}

int rom_state_owned(const Rom *rom, const RomState *state) {
    const RomState *s;
    for (s = rom->states; s != NULL; s = s->next)
        if (s == state) return 1;
    return 0;
}

/* the instance's values and machine state into reuse (a state of this instance) or a new state */
RomState *rom_state_get(Rom *rom, RomState *reuse, const char *function) {
    RomState *state = reuse;
    if (state == NULL || !rom_state_owned(rom, state)) {
        state = (RomState *)rom_allocate(rom, 1, sizeof(RomState));
        if (state != NULL) state->values = (double *)rom_allocate(rom, rom->n_values, sizeof(double));
        if (state == NULL || state->values == NULL) {
            rom_free(rom, state);
            rom_fail(rom, "%s: out of memory", function);
            return NULL;
        }
        state->next = rom->states;
        rom->states = state;
    }
    memcpy(state->values, rom->values, sizeof(double) * rom->n_values);
    state->machine = rom->machine;
    return state;
}

int rom_state_set(Rom *rom, const RomState *state, const char *function) {
    if (state == NULL || !rom_state_owned(rom, state)) return rom_fail(rom, "%s: not a state of this instance", function);
    memcpy(rom->values, state->values, sizeof(double) * rom->n_values);
    rom->dirty = 0;
    rom->machine = state->machine;     /* FMI lets an importer go on from a state saved before an error */
    return 1;
}

int rom_state_free(Rom *rom, RomState *state, const char *function) {
    RomState **link;
    if (state == NULL) return 1;
    for (link = &rom->states; *link != NULL && *link != state; link = &(*link)->next) {}
    if (*link == NULL) return rom_fail(rom, "%s: not a state of this instance", function);
    *link = state->next;
    rom_free(rom, state->values);
    rom_free(rom, state);
    return 1;
}

#define STATE_HEADER (8 + ROM_GUID_LENGTH + 2 * sizeof(int64_t))

size_t rom_state_bytes(const Rom *rom) { return STATE_HEADER + sizeof(double) * rom->n_values; }

int rom_state_serialize(Rom *rom, const RomState *state, unsigned char *bytes, size_t size, const char *function) {
    int64_t header[2];
    if (state == NULL || !rom_state_owned(rom, state)) return rom_fail(rom, "%s: not a state of this instance", function);
    if (bytes == NULL || size != rom_state_bytes(rom))
        return rom_fail(rom, "%s: a buffer of %lu bytes is needed", function, (unsigned long)rom_state_bytes(rom));
    header[0] = (int64_t)rom->n_values;
    header[1] = (int64_t)state->machine;
    memcpy(bytes, ROM_KIND.state_magic, 8);
    memcpy(bytes + 8, rom->guid, ROM_GUID_LENGTH);
    memcpy(bytes + 8 + ROM_GUID_LENGTH, header, sizeof header);
    memcpy(bytes + STATE_HEADER, state->values, sizeof(double) * rom->n_values);
    return 1;
}

/* a serialised state checked whole (this ROM's, this model's, its size, a valid machine state, finite values),
 * then read into reuse (a state of this instance) or a new state; NULL (reported) otherwise */
RomState *rom_state_deserialize(Rom *rom, const unsigned char *bytes, size_t size, RomState *reuse,
                                const char *function) {
    int64_t header[2];
    size_t i;
    double value;
    RomState *state;
    if (bytes == NULL) { rom_fail(rom, "%s: NULL argument", function); return NULL; }
    if (size < STATE_HEADER || memcmp(bytes, ROM_KIND.state_magic, 8) != 0) {
        rom_fail(rom, "%s: not a serialised state of this FMU (%lu bytes)", function, (unsigned long)size);
        return NULL;
    }
    if (memcmp(bytes + 8, rom->guid, ROM_GUID_LENGTH) != 0) {
        rom_fail(rom, "%s: a state of another model (GUID %.40s, this FMU's is %s)", function,
                 (const char *)bytes + 8, rom->guid);
        return NULL;
    }
    memcpy(header, bytes + 8 + ROM_GUID_LENGTH, sizeof header);
    if (header[0] != (int64_t)rom->n_values || size != rom_state_bytes(rom)) {
        rom_fail(rom, "%s: a state of %ld values in %lu bytes, this model has %lu", function, (long)header[0],
                 (unsigned long)size, (unsigned long)rom->n_values);
        return NULL;
    }
    if (header[1] != ROM_INSTANTIATED && header[1] != ROM_INITIALIZATION && header[1] != ROM_STEP &&
        header[1] != ROM_TERMINATED) {
        rom_fail(rom, "%s: the state was taken in no valid FMI state (%ld)", function, (long)header[1]);
        return NULL;
    }
    for (i = 0; i < rom->n_values; i++) {
        memcpy(&value, bytes + STATE_HEADER + i * sizeof(double), sizeof value);
        if (!rom_finite(value)) {
            rom_fail(rom, "%s: value %lu of the state is %g, not finite", function, (unsigned long)i, value);
            return NULL;
        }
    }
    state = rom_state_get(rom, reuse, function);      /* a state of this instance to fill */
    if (state == NULL) return NULL;
    memcpy(state->values, bytes + STATE_HEADER, sizeof(double) * rom->n_values);
    state->machine = (int)header[1];
    return state;
}
