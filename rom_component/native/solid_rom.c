/*
 * Solid ROM as an exported FMU: the online interface path of a trained non-intrusive ROM (rom_component), with
 * no Python at run time. The FMI skeleton around it is fmi2_rom.c (rom_fmu.h has the contract).
 *
 *   x   = E f - e                     encoder (r_f), input scaling folded in
 *   z   = [phi(|x - c_i|^2), x, 1]    thin-plate-spline kernel values (RBF), or
 *       = [x_qi * x_qj (* x_qk), x, 1]  unique quadratic and cubic terms (sparse polynomial)
 *   u~  = H z                         reduced displacements (r_u)
 *   u_G = base + A u~ [+ B q(u~)]     interface displacements (linear or quadratic manifold decoder)
 *
 * Every array and size is read at instantiation from resources/rom.bin (little-endian), after the common header
 * (magic "CSROM04", GUID, input and output names):
 *   int32 n_in, n_out, r_f, r_u, m, regressor (0 rbf, 1 poly), decoder (0 linear, 1 quadratic),
 *         components per node;
 *   float64 E[r_f][n_in], e[r_f];
 *   rbf: float64 centres[m][r_f]   |   poly: int32 qi[m], qj[m], qk[m] (qk -1: a quadratic term);
 *   float64 H[r_u][m + r_f + 1], At[r_u][n_out] (A transposed), base[n_out];
 *   quadratic decoder: float64 Bt[r_u (r_u + 1) / 2][n_out] (B transposed).
 * Value references: inputs 0 .. n_in-1, outputs n_in .. n_in+n_out-1.
 * Every sum runs in the order of OnlineRom(arithmetic="reproducible") (numpy's pairwise row
 * sums, sequential short sums, the logarithm rom_log below), so results are bit-identical to
 * the Python ROM whatever the compiler flags (rom_arithmetic.h), and the binary needs no libm. With GCC or clang
 * the long sums run on vector types (four rows of the encoder at once, sixteen outputs of the decoder at once);
 * each lane does the scalar code's operations in its order, so -DSOLID_ROM_SCALAR builds give the same bits.
 * The ROM is stateless: it has no history, an FMU state holds its inputs, outputs and time.
 */
#include "rom_arithmetic.h"

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "rom_fmu.h"

const RomKind ROM_KIND = {"solid_rom", "solid ROM", {'C', 'S', 'R', 'O', 'M', '0', '4', 0},
                          {'C', 'S', 'R', 'O', 'M', 'S', 'T', '3'}, 8};

typedef struct {
    int32_t n_in, n_out, r_f, r_u, m, regressor, decoder, components;
    double *E, *e, *centres, *H, *At, *base, *Bt;
    int32_t *qi, *qj, *qk;
    int32_t n_quad;           /* r_u (r_u + 1) / 2 */
    double *panels;           /* with vector sums: the decoder's coefficients in read order (fill_panels) */
    double *x, *z, *reduced, *quad, *scratch;   /* working arrays; scratch: n_out */
} Model;

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
        for (k = 0; k < 4; k++) out[k] = rom_pairwise_dot(row + k * stride, v, n);
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

/* out[k] = rom_pairwise_dot(rows[k], v) for count rows of length n, stride apart */
HOT static void pairwise_dots(const double *rows, size_t stride, const double *v, int32_t n, int32_t count,
                              double *out) {
    int32_t k = 0;
#ifdef VECTOR_SUMS
    for (; k + 4 <= count; k += 4) pairwise_dot4(rows + (size_t)k * stride, stride, v, n, out + k);
#endif
    for (; k < count; k++) out[k] = rom_pairwise_dot(rows + (size_t)k * stride, v, n);
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
HOT void rom_evaluate(Rom *rom) {
    Model *m = (Model *)rom->model;
    const int32_t width = m->m + m->r_f + 1;
    int32_t i, k, a;
    pairwise_dots(m->E, (size_t)m->n_in, rom->inputs, m->n_in, m->r_f, m->x);
    for (k = 0; k < m->r_f; k++) m->x[k] = m->x[k] - m->e[k];
    if (m->regressor == 0) {
        for (i = 0; i < m->m; i++) {
            const double *c = m->centres + (size_t)i * m->r_f;
            double d = m->x[0] - c[0], d2 = d * d;
            for (k = 1; k < m->r_f; k++) { d = m->x[k] - c[k]; d2 = d2 + d * d; }
            m->z[i] = d2 == 0.0 ? 0.0 : d2 * rom_log(d2);   /* 0.5 of the kernel is folded into H */
        }
    } else {
        for (i = 0; i < m->m; i++) {
            double t = m->x[m->qi[i]] * m->x[m->qj[i]];
            if (m->qk[i] >= 0) t = t * m->x[m->qk[i]];
            m->z[i] = t;
        }
    }
    for (k = 0; k < m->r_f; k++) m->z[m->m + k] = m->x[k];
    m->z[m->m + m->r_f] = 1.0;
    pairwise_dots(m->H, (size_t)width, m->z, width, m->r_u, m->reduced);
    if (m->decoder == 1) {
        int32_t q = 0, b;
        for (a = 0; a < m->r_u; a++)
            for (b = a; b < m->r_u; b++) m->quad[q++] = m->reduced[a] * m->reduced[b];
    }
    decode(m, m->reduced, m->quad, rom->outputs, m->scratch);
}

int rom_load(Rom *rom, const char *file) {
    size_t offset = ROM_HEADER_BYTES + 8 * sizeof(int32_t), need;
    const size_t length = rom->length;
    Model *m = (Model *)rom_model(rom, sizeof(Model));
    if (m == NULL) return 0;
    if (m->n_in <= 0 || m->n_out <= 0 || m->r_f <= 0 || m->r_u <= 0 || m->m <= 0 || m->components < 1 ||
        m->components > 3 || m->n_in % m->components || m->n_out % m->components ||
        (m->regressor != 0 && m->regressor != 1) || (m->decoder != 0 && m->decoder != 1)) {
        rom_error(rom, "resource '%s' has invalid sizes", file);
        return 0;
    }
    m->n_quad = m->r_u * (m->r_u + 1) / 2;
    need = offset + sizeof(double) * ((size_t)m->r_f * m->n_in + m->r_f + (size_t)m->r_u * (m->m + m->r_f + 1) +
                                      (size_t)m->n_out * m->r_u + m->n_out)
         + (m->regressor == 0 ? sizeof(double) * (size_t)m->m * m->r_f : 3 * sizeof(int32_t) * (size_t)m->m)
         + (m->decoder == 1 ? sizeof(double) * (size_t)m->n_out * m->n_quad : 0);
    if (length != need) {
        rom_error(rom, "resource '%s' has %lu bytes, the sizes in its header need %lu", file, (unsigned long)length,
                  (unsigned long)need);
        return 0;
    }
#define TAKE(target, type, count) do { target = (type *)(rom->buffer + offset); offset += sizeof(type) * (size_t)(count); } while (0)
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
                rom_error(rom, "resource '%s': bad term index", file);
                return 0;
            }
    }
    {   /* the working arrays: x, z, reduced, quad, scratch (n_out, at least a panel), the decoder's panels */
        const size_t nx = (size_t)m->r_f, nz = (size_t)(m->m + m->r_f + 1), nr = (size_t)m->r_u,
                     nq = (size_t)m->n_quad, ns = (size_t)(m->n_out > 16 ? m->n_out : 16);
#ifdef VECTOR_SUMS
        const size_t np = (size_t)panel_count(m) * panel_width(m);
#else
        const size_t np = 0;
#endif
        double *w = rom_work(rom, nx + nz + nr + nq + ns + np);
        if (w == NULL) return 0;
        m->x = w; m->z = m->x + nx; m->reduced = m->z + nz; m->quad = m->reduced + nr; m->scratch = m->quad + nq;
        m->panels = m->scratch + ns;
    }
#ifdef VECTOR_SUMS
    fill_panels(m);
#endif
    rom_declare(rom, m->n_in, m->n_out, 0, 1, m->components, 0);
    return 1;
}

void rom_rest(Rom *rom) { (void)rom; }      /* no history */

void rom_commit(Rom *rom) { (void)rom; }

void rom_describe(const Rom *rom, char *text, size_t size) {
    const Model *m = (const Model *)rom->model;
    snprintf(text, size, "%d inputs (%s), %d outputs (%s), %d force and %d displacement modes, %s regression, "
             "%s decoder", m->n_in, rom->input_name, m->n_out, rom->output_name, m->r_f, m->r_u,
             m->regressor ? "sparse polynomial" : "RBF", m->decoder ? "quadratic" : "linear");
}

/* ---- in-process use (rom_component.static.compiled; not part of FMI) ---- */
/* The caller opens an instance with rom_open and calls the interface path on its own arrays, with no FMI state
 * machine and no value references in between. */

/* u = ROM(f) for n_in forces; the reduced forces x (r_f) and reduced displacements (r_u) are copied out too */
void solid_rom_evaluate(void *c, const double *f, double *u, double *x, double *reduced) {
    Rom *rom = rom_of(c);
    const Model *m = (const Model *)rom->model;
    memcpy(rom->inputs, f, sizeof(double) * (size_t)m->n_in);
    rom_evaluate(rom);
    memcpy(u, rom->outputs, sizeof(double) * (size_t)m->n_out);
    memcpy(x, m->x, sizeof(double) * (size_t)m->r_f);
    memcpy(reduced, m->reduced, sizeof(double) * (size_t)m->r_u);
}

/* trust of the last evaluation against a training envelope of r_f modes (rom_trust) */
void solid_rom_trust(void *c, const double *low, const double *high, const double *mean, const double *precision,
                     double *out) {
    const Model *m = (const Model *)rom_of(c)->model;
    rom_trust(m->x, m->r_f, low, high, mean, precision, out);
}

/* solid_rom_evaluate, then solid_rom_trust of that evaluation: one call from the caller's language */
void solid_rom_evaluate_trust(void *c, const double *f, double *u, double *x, double *reduced, const double *low,
                              const double *high, const double *mean, const double *precision, double *out) {
    solid_rom_evaluate(c, f, u, x, reduced);
    solid_rom_trust(c, low, high, mean, precision, out);
}

/* The served call of the in-process ROM, bound once to the caller's buffers so that a call converts a single
 * argument (the margin) in the caller's language: f (n_in) in; u (n_out), x (r_f), reduced (r_u) out; with an
 * envelope (low not NULL) trust gets (excess, distance = sqrt(quadratic) / max_distance, 1.0 if excess > margin
 * else 0.0), without one trust is left as it is. */
typedef struct {
    void *instance;
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
    s->instance = c;
    s->f = f; s->u = u; s->x = x; s->reduced = reduced; s->trust = trust;
    s->low = low; s->high = high; s->mean = mean; s->precision = precision; s->max_distance = max_distance;
    return s;
}

/* one served call on the bound buffers, its input f (n_in) first copied into the bound input buffer (if f is not
 * NULL); returns 1 if the call is out of range (excess beyond margin) */
int solid_rom_serve(void *served, double margin, const double *f) {
    const Served *s = (const Served *)served;
    double out[2];
    if (f != NULL) memcpy(s->f, f, sizeof(double) * (size_t)rom_of(s->instance)->n_in);
    solid_rom_evaluate(s->instance, s->f, s->u, s->x, s->reduced);
    if (s->low == NULL) return 0;
    solid_rom_trust(s->instance, s->low, s->high, s->mean, s->precision, out);
    s->trust[0] = out[0];
    s->trust[1] = rom_root(out[1]) / s->max_distance;
    s->trust[2] = out[0] > margin ? 1.0 : 0.0;
    return out[0] > margin;
}

void solid_rom_unbind(void *served) { free(served); }
