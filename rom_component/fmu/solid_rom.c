/*
 * Solid ROM as an FMI 2.0 Co-Simulation FMU: the online interface path of a trained
 * non-intrusive ROM (rom_component), with no Python at run time.
 *
 *   x   = E f - e                     encoder (r_f), input scaling folded in
 *   z   = [phi(|x - c_i|^2), x, 1]    thin-plate-spline kernel values (RBF), or
 *       = [x_qi * x_qj (* x_qk), x, 1]  unique quadratic and cubic terms (sparse polynomial)
 *   u~  = H z                         reduced displacements (r_u)
 *   u_G = base + A u~ [+ B q(u~)]     interface displacements (linear or quadratic manifold decoder)
 *
 * Every array and size is read at fmi2Instantiate from resources/rom.bin (little-endian):
 *   char magic[8] = "CSROM04"; char guid[40]; char input_name[32], output_name[32];
 *   int32 n_in, n_out, r_f, r_u, m, regressor (0 rbf, 1 poly), decoder (0 linear, 1 quadratic),
 *         components per node;
 *   float64 E[r_f][n_in], e[r_f];
 *   rbf: float64 centres[m][r_f]   |   poly: int32 qi[m], qj[m], qk[m] (qk -1: a quadratic term);
 *   float64 H[r_u][m + r_f + 1], At[r_u][n_out] (A transposed), base[n_out];
 *   quadratic decoder: float64 Bt[r_u (r_u + 1) / 2][n_out] (B transposed).
 * Value references: inputs 0 .. n_in-1, outputs n_in .. n_in+n_out-1.
 * Every sum runs in the order of OnlineRom(arithmetic="reproducible") (numpy's pairwise row
 * sums, sequential short sums, the logarithm rom_log below), so results are bit-identical to
 * the Python ROM whatever the compiler flags: the pragmas forbid contracting a * b + c into a
 * fused multiply-add, and the binary needs no libm. With GCC or clang the long sums run on vector
 * types (four rows of the encoder at once, sixteen outputs of the decoder at once); each lane does
 * the scalar code's operations in its order, so -DSOLID_ROM_SCALAR builds give the same bits.
 * The ROM is stateless; an FMU state is a copy of inputs, outputs and time, and serialises to bytes. The FMI 2.0
 * Co-Simulation state machine is enforced; a call out of turn returns fmi2Error with a message.
 */
#if defined(__clang__)
#pragma STDC FP_CONTRACT OFF
#elif defined(__GNUC__)
#pragma GCC optimize("fp-contract=off")
#elif defined(_MSC_VER)
#pragma fp_contract(off)
#else
#pragma STDC FP_CONTRACT OFF
#endif
#if defined(__FAST_MATH__)
#error "solid_rom.c must not be built with -ffast-math: its results are defined bit for bit"
#endif
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "fmi2Functions.h"

#define MAGIC "CSROM04"
#define GUID_LENGTH 40
#define NAME_LENGTH 32
#define MAX_PATH_LENGTH 4096

typedef struct {
    int32_t n_in, n_out, r_f, r_u, m, regressor, decoder, components;
    double *E, *e, *centres, *H, *At, *base, *Bt, *c2;
    int32_t *qi, *qj, *qk;
    int32_t n_quad;           /* r_u (r_u + 1) / 2 */
    double *panels;           /* with vector sums: the decoder's coefficients in read order (fill_panels) */
    char guid[GUID_LENGTH + 1];
    char input_name[NAME_LENGTH + 1], output_name[NAME_LENGTH + 1];
} Model;

typedef struct State {
    double *inputs, *outputs;
    double time;
    int machine;              /* the instance's FMI state when it was taken: restoring it leaves an error */
    struct State *next;       /* every state an instance hands out, freed with it at the latest */
} State;

/* FMI 2.0 Co-Simulation states, as bits so that a function can name the states it is allowed in */
enum { INSTANTIATED = 1, INITIALIZATION = 2, STEP_COMPLETE = 4, TERMINATED = 8, ERROR = 16 };
#define ANY (INSTANTIATED | INITIALIZATION | STEP_COMPLETE | TERMINATED | ERROR)

typedef struct {
    fmi2CallbackFunctions callbacks;
    char *name;
    int logging, log_events, log_errors;   /* loggingOn and the enabled categories */
    int state;
    int dirty;                /* inputs set since the outputs were computed */
    Model model;
    double *inputs, *outputs, *x, *z, *reduced, *quad, *scratch;   /* scratch: n_out */
    double time;
    State *states;
    char *buffer;             /* the resource file, all arrays point into it */
} Instance;

static const char *const CATEGORIES[] = {"logEvents", "logStatusError"};

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

/* an error: always reported unless the importer switched logStatusError off; the FMU enters its error state */
#define FAIL(inst, ...) do { if ((inst)->log_errors) log_message(&(inst)->callbacks, (inst)->name, fmi2Error, \
                                 "logStatusError", __VA_ARGS__); (inst)->state = ERROR; return fmi2Error; } while (0)
/* an event: reported only with loggingOn and logEvents enabled */
#define EVENT(inst, ...) do { if ((inst)->logging && (inst)->log_events) log_message(&(inst)->callbacks, \
                                  (inst)->name, fmi2OK, "logEvents", __VA_ARGS__); } while (0)
/* refuse a call in a state the FMI 2.0 state machine does not allow it in */
#define REQUIRE(inst, allowed, function) do { if (!((inst)->state & (allowed))) \
    FAIL(inst, "%s is not allowed in %s", function, state_name((inst)->state)); } while (0)

static const char *state_name(int state) {
    switch (state) {
    case INSTANTIATED: return "the instantiated state (before fmi2EnterInitializationMode)";
    case INITIALIZATION: return "Initialization Mode";
    case STEP_COMPLETE: return "Step Mode";
    case TERMINATED: return "the terminated state";
    default: return "the error state (only fmi2Reset and fmi2FreeInstance lead out)";
    }
}

static int finite(double v) { return v - v == 0.0; }   /* false for NaN and +-Inf, without libm */

/* "pressure[12]" or "force[3].y": the scalar variable behind a value reference */
static const char *variable_name(const Instance *inst, fmi2ValueReference vr, char *text, size_t size) {
    const Model *m = &inst->model;
    int input = vr < (fmi2ValueReference)m->n_in;
    long index = input ? (long)vr : (long)vr - m->n_in;
    int c = m->components > 1 ? m->components : 1;
    if (c == 1) snprintf(text, size, "%s[%ld]", input ? m->input_name : m->output_name, index + 1);
    else snprintf(text, size, "%s[%ld].%c", input ? m->input_name : m->output_name, index / c + 1, "xyz"[index % c]);
    return text;
}

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
    if (length < (long)(8 + GUID_LENGTH + 2 * NAME_LENGTH + 8 * sizeof(int32_t))) {
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
    memcpy(m->input_name, inst->buffer + offset, NAME_LENGTH);
    m->input_name[NAME_LENGTH] = 0;
    offset += NAME_LENGTH;
    memcpy(m->output_name, inst->buffer + offset, NAME_LENGTH);
    m->output_name[NAME_LENGTH] = 0;
    offset += NAME_LENGTH;
    memcpy(&m->n_in, inst->buffer + offset, 8 * sizeof(int32_t));
    offset += 8 * sizeof(int32_t);
    if (m->n_in <= 0 || m->n_out <= 0 || m->r_f <= 0 || m->r_u <= 0 || m->m <= 0 || m->components < 1 ||
        m->components > 3 || m->n_in % m->components || m->n_out % m->components ||
        (m->regressor != 0 && m->regressor != 1) || (m->decoder != 0 && m->decoder != 1)) {
        log_message(&inst->callbacks, inst->name, fmi2Error, "logStatusError", "resource '%s' has invalid sizes", file);
        return 0;
    }
    m->n_quad = m->r_u * (m->r_u + 1) / 2;
    need = offset + sizeof(double) * ((size_t)m->r_f * m->n_in + m->r_f + (size_t)m->r_u * (m->m + m->r_f + 1) +
                                      (size_t)m->n_out * m->r_u + m->n_out)
         + (m->regressor == 0 ? sizeof(double) * (size_t)m->m * m->r_f : 3 * sizeof(int32_t) * (size_t)m->m)
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
        TAKE(m->qk, int32_t, m->m);
    }
    TAKE(m->H, double, (size_t)m->r_u * (m->m + m->r_f + 1));
    TAKE(m->At, double, (size_t)m->r_u * m->n_out);
    TAKE(m->base, double, m->n_out);
    if (m->decoder == 1) TAKE(m->Bt, double, (size_t)m->n_quad * m->n_out);
#undef TAKE
    if (m->regressor == 1) {
        int32_t i;
        for (i = 0; i < m->m; i++)
            if (m->qi[i] < 0 || m->qi[i] >= m->r_f || m->qj[i] < 0 || m->qj[i] >= m->r_f || m->qk[i] < -1 ||
                m->qk[i] >= m->r_f) {
                log_message(&inst->callbacks, inst->name, fmi2Error, "logStatusError", "resource '%s': bad term index", file);
                return 0;
            }
    }
    return 1;
}

/* natural logarithm of a positive finite x (normal or subnormal): musl's log (FreeBSD msun e_log.c),
 * < 1 ulp, with + - * / only; rom_component/static/portable_log.py repeats it operation for operation */
static double rom_log(double x) {
    static const double ln2_hi = 6.93147180369123816490e-01, ln2_lo = 1.90821492927058770002e-10,
        Lg1 = 6.666666666666735130e-01, Lg2 = 3.999999999940941908e-01, Lg3 = 2.857142874366239149e-01,
        Lg4 = 2.222219843214978396e-01, Lg5 = 1.818357216161805012e-01, Lg6 = 1.531383769920937332e-01,
        Lg7 = 1.479819860511658591e-01;
    union { double f; uint64_t i; } u;
    uint32_t hx;
    int k = 0;
    double f, hfsq, s, z, w, t1, t2, dk;
    u.f = x;
    hx = (uint32_t)(u.i >> 32);
    if (hx < 0x00100000) {                    /* subnormal: scale into the normal range */
        k -= 54;
        u.f = x * 18014398509481984.0;        /* 2^54 */
        hx = (uint32_t)(u.i >> 32);
    }
    hx += 0x3ff00000 - 0x3fe6a09e;            /* reduce x into [sqrt(2)/2, sqrt(2)) */
    k += (int)(hx >> 20) - 0x3ff;
    hx = (hx & 0x000fffff) + 0x3fe6a09e;
    u.i = (uint64_t)hx << 32 | (u.i & 0xffffffff);
    f = u.f - 1.0;
    hfsq = 0.5 * f * f;
    s = f / (2.0 + f);
    z = s * s;
    w = z * z;
    t1 = w * (Lg2 + w * (Lg4 + w * Lg6));
    t2 = z * (Lg1 + w * (Lg3 + w * (Lg5 + w * Lg7)));
    dk = k;
    return s * (hfsq + (t2 + t1)) + dk * ln2_lo - hfsq + f + dk * ln2_hi;
}

/* the hot loops are compiled twice on x86-64 with GCC, for AVX2 and for the baseline, and the loader picks one
 * for the CPU it runs on; both do the same operations in the same order (no contraction), so the same results */
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__)
#define HOT __attribute__((target_clones("avx2", "default")))
#else
#define HOT
#endif

/* sum_i row[i] * v[i], each product rounded, then summed in numpy's pairwise order (the order of
 * ndarray.sum along a contiguous axis: 8 running sums over blocks of at most 128 values, halving
 * recursively above that), without a scratch row */
HOT static double pairwise_dot(const double *row, const double *v, int32_t n) {
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

/* Vector forms of the hot sums, with GCC's and clang's vector types where available: each lane does the
 * scalar code's operations in the scalar code's order (IEEE products and sums, no contraction), so the
 * results are the same bits; the vectors only keep the partial sums in registers. */
#if defined(__GNUC__) && !defined(SOLID_ROM_SCALAR)
typedef double vec4 __attribute__((vector_size(32), aligned(8), may_alias));
#define VECTOR_SUMS 1
#endif

#ifdef VECTOR_SUMS
/* pairwise_dot of four rows (stride apart) with one v: per row the same operations in the same order, the four
 * rows interleaved so that their independent sums overlap in the pipeline instead of waiting on each other */
HOT static void pairwise_dot4(const double *row, size_t stride, const double *v, int32_t n, double out[4]) {
    int32_t k;
    if (n < 8) {
        for (k = 0; k < 4; k++) out[k] = pairwise_dot(row + k * stride, v, n);
    } else if (n <= 128) {
        int32_t i, j;
        vec4 lo[4], hi[4];
        const vec4 v_lo = *(const vec4 *)v, v_hi = *(const vec4 *)(v + 4);
        for (k = 0; k < 4; k++) {
            lo[k] = *(const vec4 *)(row + k * stride) * v_lo;
            hi[k] = *(const vec4 *)(row + k * stride + 4) * v_hi;
        }
        for (i = 8; i < n - (n % 8); i += 8) {
            const vec4 a = *(const vec4 *)(v + i), b = *(const vec4 *)(v + i + 4);
            for (k = 0; k < 4; k++) {
                lo[k] += *(const vec4 *)(row + k * stride + i) * a;
                hi[k] += *(const vec4 *)(row + k * stride + i + 4) * b;
            }
        }
        for (k = 0; k < 4; k++) {
            const double *rk = row + k * stride;
            double res = ((lo[k][0] + lo[k][1]) + (lo[k][2] + lo[k][3])) + ((hi[k][0] + hi[k][1]) + (hi[k][2] + hi[k][3]));
            for (j = i; j < n; j++) res += rk[j] * v[j];
            out[k] = res;
        }
    } else {
        int32_t n2 = n / 2;
        double first[4], second[4];
        n2 -= n2 % 8;
        pairwise_dot4(row, stride, v, n2, first);
        pairwise_dot4(row + n2, stride, v + n2, n - n2, second);
        for (k = 0; k < 4; k++) out[k] = first[k] + second[k];
    }
}

#endif

/* out[k] = pairwise_dot(rows[k], v) for count rows of length n, stride apart */
HOT static void pairwise_dots(const double *rows, size_t stride, const double *v, int32_t n, int32_t count,
                              double *out) {
    int32_t k = 0;
#ifdef VECTOR_SUMS
    for (; k + 4 <= count; k += 4) pairwise_dot4(rows + (size_t)k * stride, stride, v, n, out + k);
#endif
    for (; k < count; k++) out[k] = pairwise_dot(rows + (size_t)k * stride, v, n);
}

#ifdef VECTOR_SUMS
/* The decoder's coefficients in panels of PANEL outputs, in the order decode reads them: per panel the r_u
 * columns of A, base, then (quadratic decoder) the n_quad columns of B, PANEL values each, the last panel padded
 * with zeros. decode then reads one forward stream instead of r_u + n_quad strided ones: after the other solver's
 * turn the caches are cold, and a single stream is what the hardware fetches ahead. */
#define PANEL 16
static size_t panel_width(const Model *m) { return (size_t)(m->r_u + 1 + (m->decoder == 1 ? m->n_quad : 0)) * PANEL; }
static int32_t panel_count(const Model *m) { return (m->n_out + PANEL - 1) / PANEL; }

static void fill_panels(Model *m) {
    const size_t width = panel_width(m);
    int32_t b, o, a, q;
    for (b = 0; b < panel_count(m); b++)
        for (o = 0; o < PANEL; o++) {
            const int32_t out = b * PANEL + o, valid = out < m->n_out;
            double *p = m->panels + (size_t)b * width + o;
            for (a = 0; a < m->r_u; a++) p[(size_t)a * PANEL] = valid ? m->At[(size_t)a * m->n_out + out] : 0.0;
            p[(size_t)m->r_u * PANEL] = valid ? m->base[out] : 0.0;
            if (m->decoder == 1)
                for (q = 0; q < m->n_quad; q++)
                    p[(size_t)(m->r_u + 1 + q) * PANEL] = valid ? m->Bt[(size_t)q * m->n_out + out] : 0.0;
        }
}
#endif

/* the decoder, u = A u~ summed sequentially over r_u, + base, + (B q(u~) summed sequentially over the quadratic
 * terms), as OnlineRom sums them; with vector sums, a panel of 16 outputs at a time keeps its partial sums in
 * registers while its coefficients stream past (the last panel's padded lanes are computed and dropped) */
HOT static void decode(const Model *m, const double *reduced, const double *quad, double *out, double *scratch) {
    int32_t a, q, o;
#ifdef VECTOR_SUMS
    const size_t width = panel_width(m);
    int32_t b, j;
    (void)o;
    for (b = 0; b < panel_count(m); b++) {
        vec4 s[4], t[4];
        const double *p = m->panels + (size_t)b * width, *col;
        double *target = (b + 1) * PANEL <= m->n_out ? out + (size_t)b * PANEL : scratch;
        for (j = 0; j < 4; j++) s[j] = *(const vec4 *)(p + 4 * j) * reduced[0];
        for (a = 1; a < m->r_u; a++) {
            const double r = reduced[a];
            col = p + (size_t)a * PANEL;
            for (j = 0; j < 4; j++) s[j] += *(const vec4 *)(col + 4 * j) * r;
        }
        col = p + (size_t)m->r_u * PANEL;
        for (j = 0; j < 4; j++) s[j] += *(const vec4 *)(col + 4 * j);
        if (m->decoder == 1) {
            col += PANEL;
            for (j = 0; j < 4; j++) t[j] = *(const vec4 *)(col + 4 * j) * quad[0];
            for (q = 1; q < m->n_quad; q++) {
                const double w = quad[q];
                col += PANEL;
                for (j = 0; j < 4; j++) t[j] += *(const vec4 *)(col + 4 * j) * w;
            }
            for (j = 0; j < 4; j++) s[j] += t[j];
        }
        for (j = 0; j < 4; j++) *(vec4 *)(target + 4 * j) = s[j];
        if (target == scratch) memcpy(out + (size_t)b * PANEL, scratch, sizeof(double) * (size_t)(m->n_out - b * PANEL));
    }
#else
    /* outputs in the inner loop, so that the compiler vectorises across them without changing any sum */
    const double *col = m->At;
    for (o = 0; o < m->n_out; o++) out[o] = col[o] * reduced[0];
    for (a = 1; a < m->r_u; a++) {
        const double r = reduced[a];
        col = m->At + (size_t)a * m->n_out;
        for (o = 0; o < m->n_out; o++) out[o] = out[o] + col[o] * r;
    }
    for (o = 0; o < m->n_out; o++) out[o] = out[o] + m->base[o];
    if (m->decoder == 1) {
        for (o = 0; o < m->n_out; o++) scratch[o] = m->Bt[o] * quad[0];
        for (q = 1; q < m->n_quad; q++) {
            const double w = quad[q];
            col = m->Bt + (size_t)q * m->n_out;
            for (o = 0; o < m->n_out; o++) scratch[o] = scratch[o] + col[o] * w;
        }
        for (o = 0; o < m->n_out; o++) out[o] = out[o] + scratch[o];
    }
#endif
}

/* the interface path, operation for operation as OnlineRom(arithmetic="reproducible") */
HOT static void evaluate(Instance *inst) {
    const Model *m = &inst->model;
    const int32_t width = m->m + m->r_f + 1;
    int32_t i, k, a;
    pairwise_dots(m->E, (size_t)m->n_in, inst->inputs, m->n_in, m->r_f, inst->x);
    for (k = 0; k < m->r_f; k++) inst->x[k] = inst->x[k] - m->e[k];
    if (m->regressor == 0) {
        for (i = 0; i < m->m; i++) {
            const double *c = m->centres + (size_t)i * m->r_f;
            double d = inst->x[0] - c[0], d2 = d * d;
            for (k = 1; k < m->r_f; k++) { d = inst->x[k] - c[k]; d2 = d2 + d * d; }
            inst->z[i] = d2 == 0.0 ? 0.0 : d2 * rom_log(d2);   /* 0.5 of the kernel is folded into H */
        }
    } else {
        for (i = 0; i < m->m; i++) {
            double t = inst->x[m->qi[i]] * inst->x[m->qj[i]];
            if (m->qk[i] >= 0) t = t * inst->x[m->qk[i]];
            inst->z[i] = t;
        }
    }
    for (k = 0; k < m->r_f; k++) inst->z[m->m + k] = inst->x[k];
    inst->z[m->m + m->r_f] = 1.0;
    pairwise_dots(m->H, (size_t)width, inst->z, width, m->r_u, inst->reduced);
    if (m->decoder == 1) {
        int32_t q = 0, b;
        for (a = 0; a < m->r_u; a++)
            for (b = a; b < m->r_u; b++) inst->quad[q++] = inst->reduced[a] * inst->reduced[b];
    }
    decode(m, inst->reduced, inst->quad, inst->outputs, inst->scratch);
    inst->dirty = 0;
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
        if (!writable_outputs && vr[i] >= (fmi2ValueReference)inst->model.n_in) {
            char name[96];
            FAIL(inst, "%s: %s (value reference %u) is an output and cannot be set", function,
                 variable_name(inst, vr[i], name, sizeof(name)), vr[i]);
        }
    }
    return fmi2OK;
}

#define INSTANCE(c) Instance *inst = (Instance *)(c); if (inst == NULL) return fmi2Error

/* ---- FMI 2.0 functions ---------------------------------------------------------- */

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
    char path[MAX_PATH_LENGTH];
    const Model *m;
    (void)visible;
    if (functions == NULL || functions->logger == NULL) return NULL;
    if (fmuType != fmi2CoSimulation) {
        log_message(functions, instanceName, fmi2Error, "logStatusError", "only Co-Simulation is supported");
        return NULL;
    }
    inst = (Instance *)allocate(functions, 1, sizeof(Instance));
    if (inst == NULL) return NULL;
    memset(inst, 0, sizeof(Instance));
    inst->callbacks = *functions;
    inst->logging = loggingOn;
    inst->log_events = 1;
    inst->log_errors = 1;
    inst->state = INSTANTIATED;
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
    inst->scratch = (double *)allocate(functions, (size_t)(m->n_out > 16 ? m->n_out : 16), sizeof(double));
#ifdef VECTOR_SUMS
    inst->model.panels = (double *)allocate(functions, (size_t)panel_count(m) * panel_width(m), sizeof(double));
    if (inst->model.panels) fill_panels(&inst->model);
#else
    inst->model.panels = inst->scratch;   /* not used */
#endif
    if (!inst->inputs || !inst->outputs || !inst->x || !inst->z || !inst->reduced || !inst->quad || !inst->scratch ||
        !m->panels) {
        log_message(functions, instanceName, fmi2Error, "logStatusError", "out of memory");
        fmi2FreeInstance(inst);
        return NULL;
    }
    memset(inst->inputs, 0, sizeof(double) * (size_t)m->n_in);
    evaluate(inst);
    EVENT(inst, "instantiated: %d inputs (%s), %d outputs (%s), %d force and %d displacement modes, %s regression, "
          "%s decoder", m->n_in, m->input_name, m->n_out, m->output_name, m->r_f, m->r_u,
          m->regressor ? "sparse polynomial" : "RBF", m->decoder ? "quadratic" : "linear");
    return inst;
}

static void free_state_list(Instance *inst) {
    while (inst->states != NULL) {
        State *next = inst->states->next;
        release(&inst->callbacks, inst->states->inputs);
        release(&inst->callbacks, inst->states->outputs);
        release(&inst->callbacks, inst->states);
        inst->states = next;
    }
}

void fmi2FreeInstance(fmi2Component c) {
    Instance *inst = (Instance *)c;
    fmi2CallbackFunctions cb;
    if (inst == NULL) return;
    cb = inst->callbacks;
    free_state_list(inst);
    release(&cb, inst->inputs);
    release(&cb, inst->outputs);
    release(&cb, inst->x);
    release(&cb, inst->z);
    release(&cb, inst->reduced);
    release(&cb, inst->quad);
#ifdef VECTOR_SUMS
    release(&cb, inst->model.panels);
#endif
    release(&cb, inst->scratch);
    release(&cb, inst->buffer);
    release(&cb, inst->name);
    release(&cb, inst);
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    INSTANCE(c);
    (void)toleranceDefined; (void)tolerance;
    REQUIRE(inst, INSTANTIATED, "fmi2SetupExperiment");
    if (!finite(startTime)) FAIL(inst, "fmi2SetupExperiment: start time %g is not finite", startTime);
    if (stopTimeDefined && !(stopTime >= startTime))
        FAIL(inst, "fmi2SetupExperiment: stop time %g is before the start time %g", stopTime, startTime);
    inst->time = startTime;
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
    EVENT(inst, "terminated at t = %g", inst->time);
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component c) {
    INSTANCE(c);
    memset(inst->inputs, 0, sizeof(double) * (size_t)inst->model.n_in);
    inst->time = 0.0;
    evaluate(inst);
    inst->state = INSTANTIATED;
    return fmi2OK;
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[]) {
    size_t i;
    INSTANCE(c);
    REQUIRE(inst, INITIALIZATION | STEP_COMPLETE | TERMINATED | ERROR, "fmi2GetReal");
    if (check_references(inst, "fmi2GetReal", vr, nvr, value, 1) != fmi2OK) return fmi2Error;
    if (inst->state == INITIALIZATION && inst->dirty) evaluate(inst);   /* outputs follow the inputs set there */
    for (i = 0; i < nvr; i++)
        value[i] = vr[i] < (fmi2ValueReference)inst->model.n_in ? inst->inputs[vr[i]]
                                                                : inst->outputs[vr[i] - inst->model.n_in];
    return fmi2OK;
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[]) {
    size_t i;
    INSTANCE(c);
    REQUIRE(inst, INSTANTIATED | INITIALIZATION | STEP_COMPLETE, "fmi2SetReal");
    if (check_references(inst, "fmi2SetReal", vr, nvr, value, 0) != fmi2OK) return fmi2Error;
    for (i = 0; i < nvr; i++)
        if (!finite(value[i])) {
            char name[96];
            FAIL(inst, "fmi2SetReal: %s = %g is not finite", variable_name(inst, vr[i], name, sizeof(name)), value[i]);
        }
    for (i = 0; i < nvr; i++) inst->inputs[vr[i]] = value[i];
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

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    State *state;
    INSTANCE(c);
    REQUIRE(inst, ANY, "fmi2GetFMUstate");
    if (FMUstate == NULL) FAIL(inst, "fmi2GetFMUstate: NULL state pointer");
    state = (State *)*FMUstate;
    if (state == NULL) {
        state = (State *)allocate(&inst->callbacks, 1, sizeof(State));
        if (state == NULL) FAIL(inst, "fmi2GetFMUstate: out of memory");
        state->inputs = (double *)allocate(&inst->callbacks, (size_t)inst->model.n_in, sizeof(double));
        state->outputs = (double *)allocate(&inst->callbacks, (size_t)inst->model.n_out, sizeof(double));
        if (!state->inputs || !state->outputs) {
            release(&inst->callbacks, state->inputs);
            release(&inst->callbacks, state->outputs);
            release(&inst->callbacks, state);
            FAIL(inst, "fmi2GetFMUstate: out of memory");
        }
        state->next = inst->states;
        inst->states = state;
    }
    memcpy(state->inputs, inst->inputs, sizeof(double) * (size_t)inst->model.n_in);
    memcpy(state->outputs, inst->outputs, sizeof(double) * (size_t)inst->model.n_out);
    state->time = inst->time;
    state->machine = inst->state;
    *FMUstate = state;
    return fmi2OK;
}

static int owns_state(const Instance *inst, const State *state) {
    const State *s;
    for (s = inst->states; s != NULL; s = s->next)
        if (s == state) return 1;
    return 0;
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate) {
    const State *state = (const State *)FMUstate;
    INSTANCE(c);
    REQUIRE(inst, ANY, "fmi2SetFMUstate");
    if (state == NULL || !owns_state(inst, state)) FAIL(inst, "fmi2SetFMUstate: not a state of this instance");
    memcpy(inst->inputs, state->inputs, sizeof(double) * (size_t)inst->model.n_in);
    memcpy(inst->outputs, state->outputs, sizeof(double) * (size_t)inst->model.n_out);
    inst->time = state->time;
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
    release(&inst->callbacks, state->inputs);
    release(&inst->callbacks, state->outputs);
    release(&inst->callbacks, state);
    *FMUstate = NULL;
    return fmi2OK;
}

static fmi2Status unsupported(fmi2Component c, const char *function) {
    INSTANCE(c);
    FAIL(inst, "%s is not supported by this FMU", function);
}

/* A serialised state: "CSROMST2", the model's GUID (40 characters, a digest of its arrays), n_in, n_out and the
 * FMI state it was taken in (int32), the time and the inputs and outputs (doubles), in the machine's byte order: a
 * checkpoint is read back by the same FMU on the same kind of machine. */
static const char STATE_MAGIC[8] = {'C', 'S', 'R', 'O', 'M', 'S', 'T', '2'};
#define STATE_HEADER (sizeof STATE_MAGIC + GUID_LENGTH + 3 * sizeof(int32_t))

static size_t serialized_size(const Instance *inst) {
    return STATE_HEADER + sizeof(double) * (1 + (size_t)inst->model.n_in + (size_t)inst->model.n_out);
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate s, size_t *size) {
    INSTANCE(c);
    REQUIRE(inst, ANY, "fmi2SerializedFMUstateSize");
    if (s == NULL || !owns_state(inst, (const State *)s)) FAIL(inst, "fmi2SerializedFMUstateSize: not a state of this instance");
    if (size == NULL) FAIL(inst, "fmi2SerializedFMUstateSize: NULL size pointer");
    *size = serialized_size(inst);
    return fmi2OK;
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate s, fmi2Byte bytes[], size_t size) {
    const State *state = (const State *)s;
    char *out = (char *)bytes;
    int32_t sizes[3];
    INSTANCE(c);
    REQUIRE(inst, ANY, "fmi2SerializeFMUstate");
    if (state == NULL || !owns_state(inst, state)) FAIL(inst, "fmi2SerializeFMUstate: not a state of this instance");
    if (bytes == NULL || size != serialized_size(inst))
        FAIL(inst, "fmi2SerializeFMUstate: a buffer of %zu bytes is needed", serialized_size(inst));
    sizes[0] = inst->model.n_in;
    sizes[1] = inst->model.n_out;
    sizes[2] = state->machine;
    memcpy(out, STATE_MAGIC, sizeof STATE_MAGIC);
    out += sizeof STATE_MAGIC;
    memcpy(out, inst->model.guid, GUID_LENGTH);
    out += GUID_LENGTH;
    memcpy(out, sizes, sizeof sizes);
    out += sizeof sizes;
    memcpy(out, &state->time, sizeof(double));
    out += sizeof(double);
    memcpy(out, state->inputs, sizeof(double) * (size_t)inst->model.n_in);
    out += sizeof(double) * (size_t)inst->model.n_in;
    memcpy(out, state->outputs, sizeof(double) * (size_t)inst->model.n_out);
    return fmi2OK;
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte bytes[], size_t size, fmi2FMUstate *s) {
    const char *in = (const char *)bytes;
    int32_t sizes[3];
    size_t i, n_values;
    double value;
    State *state;
    fmi2FMUstate handle = NULL;
    INSTANCE(c);
    REQUIRE(inst, ANY, "fmi2DeSerializeFMUstate");
    if (bytes == NULL || s == NULL) FAIL(inst, "fmi2DeSerializeFMUstate: NULL argument");
    if (size < STATE_HEADER || memcmp(in, STATE_MAGIC, sizeof STATE_MAGIC) != 0)
        FAIL(inst, "fmi2DeSerializeFMUstate: not a serialised state of this FMU (%zu bytes)", size);
    if (memcmp(in + sizeof STATE_MAGIC, inst->model.guid, GUID_LENGTH) != 0)
        FAIL(inst, "fmi2DeSerializeFMUstate: a state of another model (GUID %.40s, this FMU's is %s)",
             in + sizeof STATE_MAGIC, inst->model.guid);
    memcpy(sizes, in + sizeof STATE_MAGIC + GUID_LENGTH, sizeof sizes);
    if (sizes[0] != inst->model.n_in || sizes[1] != inst->model.n_out || size != serialized_size(inst))
        FAIL(inst, "fmi2DeSerializeFMUstate: a state of %d inputs and %d outputs, this FMU has %d and %d",
             (int)sizes[0], (int)sizes[1], (int)inst->model.n_in, (int)inst->model.n_out);
    if (sizes[2] != INSTANTIATED && sizes[2] != INITIALIZATION && sizes[2] != STEP_COMPLETE && sizes[2] != TERMINATED)
        FAIL(inst, "fmi2DeSerializeFMUstate: the state was taken in no valid FMI state (%d)", (int)sizes[2]);
    n_values = 1 + (size_t)inst->model.n_in + (size_t)inst->model.n_out;
    for (i = 0; i < n_values; i++) {
        memcpy(&value, in + STATE_HEADER + i * sizeof(double), sizeof value);
        if (!finite(value)) FAIL(inst, "fmi2DeSerializeFMUstate: value %zu of the state is %g, not finite", i, value);
    }
    handle = (*s != NULL && owns_state(inst, (const State *)*s)) ? *s : NULL;
    if (fmi2GetFMUstate(c, &handle) != fmi2OK) return fmi2Error;    /* a state of this instance to fill */
    state = (State *)handle;
    state->machine = sizes[2];
    in += STATE_HEADER;
    memcpy(&state->time, in, sizeof(double));
    in += sizeof(double);
    memcpy(state->inputs, in, sizeof(double) * (size_t)inst->model.n_in);
    in += sizeof(double) * (size_t)inst->model.n_in;
    memcpy(state->outputs, in, sizeof(double) * (size_t)inst->model.n_out);
    *s = handle;
    return fmi2OK;
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
    if (!finite(currentCommunicationPoint))
        FAIL(inst, "fmi2DoStep: communication point %g is not finite", currentCommunicationPoint);
    if (!(communicationStepSize > 0.0) || !finite(communicationStepSize))
        FAIL(inst, "fmi2DoStep: step size %g is not a positive finite number", communicationStepSize);
    evaluate(inst);
    inst->time = currentCommunicationPoint + communicationStepSize;
    return fmi2OK;
}

fmi2Status fmi2CancelStep(fmi2Component c) { return unsupported(c, "fmi2CancelStep"); }

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value) {
    (void)s; (void)value; return unsupported(c, "fmi2GetStatus");
}
fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value) {
    INSTANCE(c);
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

/* ---- in-process use (rom_component.static.compiled; not part of FMI) ------------------------ */
/* The same binary serves a Python process directly: open an instance on a resource folder with plain
 * calloc/free and a logger that keeps the last message, then evaluate the interface path on the caller's
 * arrays, with no FMI state machine and no value references in between. */

static char last_message[1024];

static void keep_message(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status, fmi2String category,
                         fmi2String message, ...) {
    (void)env; (void)name; (void)status; (void)category;
    snprintf(last_message, sizeof(last_message), "%s", message);   /* sent with '%' doubled: undo it */
    {
        char *r = last_message, *w = last_message;
        for (; *r; r++, w++) { *w = *r; if (r[0] == '%' && r[1] == '%') r++; }
        *w = 0;
    }
}

static void *plain_allocate(size_t count, size_t size) { return calloc(count, size); }
static void plain_free(void *pointer) { free(pointer); }

/* the last error message of solid_rom_open (empty if none) */
const char *solid_rom_last_error(void) { return last_message; }

/* an instance reading resource_uri/rom.bin, or NULL (reason in solid_rom_last_error) */
void *solid_rom_open(const char *resource_uri, const char *guid) {
    static const fmi2CallbackFunctions plain = {keep_message, plain_allocate, plain_free, NULL, NULL};
    last_message[0] = 0;
    return fmi2Instantiate("solid_rom", fmi2CoSimulation, guid, resource_uri, &plain, fmi2False, fmi2False);
}

/* u = ROM(f) for n_in forces; the reduced forces x (r_f) and reduced displacements (r_u) are copied out too */
void solid_rom_evaluate(void *c, const double *f, double *u, double *x, double *reduced) {
    Instance *inst = (Instance *)c;
    const Model *m = &inst->model;
    memcpy(inst->inputs, f, sizeof(double) * (size_t)m->n_in);
    evaluate(inst);
    memcpy(u, inst->outputs, sizeof(double) * (size_t)m->n_out);
    memcpy(x, inst->x, sizeof(double) * (size_t)m->r_f);
    memcpy(reduced, inst->reduced, sizeof(double) * (size_t)m->r_u);
}

/* trust of the last evaluation against a training envelope of r_f modes (rom_component.envelope.trust):
 * out[0] the largest excess beyond [low, high] in range widths (0 inside, NaN if a reduced force is NaN),
 * out[1] the squared Mahalanobis distance to mean (precision: r_f x r_f, row-major); no libm, so no root */
void solid_rom_trust(void *c, const double *low, const double *high, const double *mean, const double *precision,
                     double *out) {
    const Instance *inst = (const Instance *)c;
    const int32_t r = inst->model.r_f;
    double excess = 0.0, quadratic = 0.0;
    int32_t i, j;
    for (i = 0; i < r; i++) {
        const double x = inst->x[i], below = low[i] - x, above = x - high[i];
        double width = high[i] - low[i], e = below > above ? below : above;
        if (x != x) excess = x;
        if (excess != excess) continue;
        if (!(width > 1e-300)) width = 1e-300;
        e = e > 0.0 ? e / width : 0.0;
        if (e > excess) excess = e;
    }
    for (i = 0; i < r; i++) {
        const double *row = precision + (size_t)i * r;
        double s = 0.0;
        for (j = 0; j < r; j++) s += row[j] * (inst->x[j] - mean[j]);
        quadratic += (inst->x[i] - mean[i]) * s;
    }
    out[0] = excess;
    out[1] = quadratic > 0.0 ? quadratic : 0.0;
}

/* solid_rom_evaluate, then solid_rom_trust of that evaluation: one call from the caller's language */
void solid_rom_evaluate_trust(void *c, const double *f, double *u, double *x, double *reduced, const double *low,
                              const double *high, const double *mean, const double *precision, double *out) {
    solid_rom_evaluate(c, f, u, x, reduced);
    solid_rom_trust(c, low, high, mean, precision, out);
}

/* square root of q >= 0 without libm: the SSE2 instruction (IEEE, correctly rounded, as Python's math.sqrt),
 * else Newton's method from q (the last bit may differ) */
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

/* The served call of the in-process ROM, bound once to the caller's buffers so that a call converts a single
 * argument (the margin) in the caller's language: f (n_in) in; u (n_out), x (r_f), reduced (r_u) out; with an
 * envelope (low not NULL) trust gets (excess, distance = sqrt(quadratic) / max_distance, 1.0 if excess > margin
 * else 0.0), without one trust is left as it is. */
typedef struct {
    Instance *inst;
    double *f;
    const double *low, *high, *mean, *precision;
    double *u, *x, *reduced, *trust;
    double max_distance;
} Served;

void *solid_rom_bind(void *c, double *f, double *u, double *x, double *reduced, const double *low,
                     const double *high, const double *mean, const double *precision, double max_distance,
                     double *trust) {
    Served *s = (Served *)calloc(1, sizeof(Served));
    if (s == NULL) return NULL;
    s->inst = (Instance *)c;
    s->f = f; s->u = u; s->x = x; s->reduced = reduced; s->trust = trust;
    s->low = low; s->high = high; s->mean = mean; s->precision = precision; s->max_distance = max_distance;
    return s;
}

/* one served call on the bound buffers, its input f (n_in) first copied into the bound input buffer (if f is not
 * NULL); returns 1 if the call is out of range (excess beyond margin) */
int solid_rom_serve(void *served, double margin, const double *f) {
    const Served *s = (const Served *)served;
    double out[2];
    if (f != NULL) memcpy(s->f, f, sizeof(double) * (size_t)s->inst->model.n_in);
    solid_rom_evaluate(s->inst, s->f, s->u, s->x, s->reduced);
    if (s->low == NULL) return 0;
    solid_rom_trust(s->inst, s->low, s->high, s->mean, s->precision, out);
    s->trust[0] = out[0];
    s->trust[1] = root(out[1]) / s->max_distance;
    s->trust[2] = out[0] > margin ? 1.0 : 0.0;
    return out[0] > margin;
}

void solid_rom_unbind(void *served) { free(served); }

void solid_rom_close(void *c) { fmi2FreeInstance((fmi2Component)c); }
