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

static void say(Rom *rom, int error, const char *category, const char *format, va_list args) {
    char message[1024];
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
 * sizes and arrays (rom_load); 0 with an error reported otherwise */
int rom_read_resource(Rom *rom, const char *resource_uri, const char *guid) {
    char file[MAX_PATH_LENGTH];
    FILE *f;
    long length;
    if (!resource_file(resource_uri, file, sizeof(file))) {
        rom_error(rom, "resource location '%s' is not a file URI", resource_uri ? resource_uri : "(null)");
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

/* the ROM's variables (value references: inputs, outputs, locals) and the doubles of its history */
void rom_declare(Rom *rom, int32_t n_in, int32_t n_out, int32_t n_local, int32_t components, size_t n_history) {
    rom->n_in = n_in;
    rom->n_out = n_out;
    rom->n_local = n_local;
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
int rom_allocate_values(Rom *rom) {
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
void rom_reset_values(Rom *rom) {
    memset(rom->values, 0, sizeof(double) * rom->n_values);
    rom_rest(rom);
    rom_evaluate(rom);
}

/* "pressure[12]" or "force[3].y": the scalar variable behind a value reference ("local 3" beyond the outputs) */
const char *rom_variable_name(const Rom *rom, uint32_t vr, char *text, size_t size) {
    int input = vr < (uint32_t)rom->n_in;
    long index = input ? (long)vr : (long)vr - rom->n_in;
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
