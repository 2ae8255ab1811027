/*
 * A step-map ROM of a structure with inertia (rom_component.dynamic.model) as an exported FMU whose state is the
 * structure's reduced history; the FMI skeleton around it is fmi2_rom.c (rom_fmu.h has the contract). One step
 * advances one window:
 *
 *   x   = E f - e                                      reduced force (r_f)
 *   s   = (x + 2 x_1) + x_2                            Newmark's weighted sum with the last two windows' forces
 *   z   = ((W s + A [z_1 ... z_p]) + c) [+ Q q(z_1)]   reduced displacement (r_u); q: products of the leading k
 *   u   = At^T z + base,  probes = Pt^T z + p0         interface displacement and probe points
 *
 * after which z and x join the history (z_1 <- z, x_1 <- x). An importer repeats a window (a coupling iteration)
 * the FMI way: it saves the FMU state before the window and restores it before each repeat.
 *
 * resources/rom.bin (little-endian), after the common header (magic "CSSTEP1", GUID, input and output names):
 *   int32 n_in, n_out, n_probe, r_f, r_u, p, k, components;
 *   float64 E[r_f][n_in], e[r_f], W[r_u][r_f], A[r_u][p r_u], Q[r_u][k (k + 1) / 2], c[r_u],
 *           At[r_u][n_out], base[n_out], Pt[r_u][n_probe], p0[n_probe], Ap[r_u][n_out] (pseudo-inverse of At^T),
 *           z_rest[r_u], x_rest[r_f] (the history at rest).
 * Value references: inputs 0 .. n_in-1, outputs n_in .. n_in+n_out-1, probes (locals) after them.
 * The history is zh[p][r_u] then xh[2][r_f], ahead of the inputs in the values.
 * Every sum runs in the order of the Python component's reproducible arithmetic (numpy's pairwise row sums,
 * sequential sums over r_u), with no fused multiply-add (rom_arithmetic.h): results are bit-identical to it.
 *
 * Outside FMI (rom_component.dynamic.compiled, on an instance of rom_open): step_map_evaluate (a window's call,
 * from the history, without moving it), step_map_commit (the window's last call joins the history),
 * step_map_history (read or write the history), step_map_take_over (a history from a full-order run's converged
 * windows), step_map_bind and step_map_serve (the served call with its trust), step_map_view.
 */
#include "rom_arithmetic.h"

#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "rom_fmu.h"

const RomKind ROM_KIND = {"step_map_rom", "step-map ROM", {'C', 'S', 'S', 'T', 'E', 'P', '1', 0},
                          {'C', 'S', 'S', 'T', 'P', 'S', 'T', '3'}, 8};

typedef struct {
    int32_t n_in, n_out, n_probe, r_f, r_u, p, k, components;
    int32_t n_quad;
    double *E, *e, *W, *A, *Q, *c, *At, *base, *Pt, *p0, *Ap, *z_rest, *x_rest;
    double *zh, *xh;                                /* the history, in the instance's values */
    double *x, *s, *z, *quad, *d;                   /* working arrays */
    const double *low, *high, *mean, *precision;   /* the training envelope of the served path (step_map_serve) */
    double max_distance, *trust;
} Model;

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
    for (i = 0; i < m->r_f; i++) x[i] = rom_pairwise_dot(m->E + (size_t)i * m->n_in, f, m->n_in) - m->e[i];
}

/* the window's call from the history: x, z, outputs and probes (the history does not move) */
void rom_evaluate(Rom *rom) {
    Model *m = (Model *)rom->model;
    int32_t i, a, b, q = 0;
    encode(m, rom->inputs, m->x);
    for (i = 0; i < m->r_f; i++) m->s[i] = (m->x[i] + 2.0 * m->xh[i]) + m->xh[m->r_f + i];
    for (a = 0; a < m->k; a++)
        for (b = a; b < m->k; b++) m->quad[q++] = m->zh[a] * m->zh[b];
    for (i = 0; i < m->r_u; i++) {
        double z = rom_pairwise_dot(m->W + (size_t)i * m->r_f, m->s, m->r_f)
                 + rom_pairwise_dot(m->A + (size_t)i * m->p * m->r_u, m->zh, m->p * m->r_u);
        z += m->c[i];
        if (m->n_quad) z += rom_pairwise_dot(m->Q + (size_t)i * m->n_quad, m->quad, m->n_quad);
        m->z[i] = z;
    }
    combine(m->At, m->z, m->r_u, m->n_out, m->base, rom->outputs);
    if (m->n_probe) combine(m->Pt, m->z, m->r_u, m->n_probe, m->p0, rom->outputs + m->n_out);
}

/* the last call's z and x join the history */
void rom_commit(Rom *rom) {
    Model *m = (Model *)rom->model;
    memmove(m->zh + m->r_u, m->zh, sizeof(double) * (size_t)(m->p - 1) * m->r_u);
    memcpy(m->zh, m->z, sizeof(double) * (size_t)m->r_u);
    memcpy(m->xh + m->r_f, m->xh, sizeof(double) * (size_t)m->r_f);
    memcpy(m->xh, m->x, sizeof(double) * (size_t)m->r_f);
}

void rom_rest(Rom *rom) {
    Model *m = (Model *)rom->model;
    int32_t i;
    m->zh = rom->history;
    m->xh = rom->history + (size_t)m->p * m->r_u;
    for (i = 0; i < m->p; i++) memcpy(m->zh + (size_t)i * m->r_u, m->z_rest, sizeof(double) * (size_t)m->r_u);
    for (i = 0; i < 2; i++) memcpy(m->xh + (size_t)i * m->r_f, m->x_rest, sizeof(double) * (size_t)m->r_f);
}

int rom_load(Rom *rom, const char *file) {
    size_t offset = ROM_HEADER_BYTES + 8 * sizeof(int32_t), need;
    Model *m = (Model *)rom_model(rom, sizeof(Model));
    if (m == NULL) return 0;
    if (m->n_in <= 0 || m->n_out <= 0 || m->n_probe < 0 || m->r_f <= 0 || m->r_u <= 0 || m->p <= 0 || m->k < 0 ||
        m->k > m->r_u || m->components < 1 || m->components > 3 || m->n_in % m->components ||
        m->n_out % m->components) {
        rom_error(rom, "resource '%s' has invalid sizes", file);
        return 0;
    }
    m->n_quad = m->k * (m->k + 1) / 2;
    need = offset + sizeof(double) * ((size_t)m->r_f * m->n_in + m->r_f + (size_t)m->r_u * m->r_f
                                      + (size_t)m->r_u * m->p * m->r_u + (size_t)m->r_u * m->n_quad + m->r_u
                                      + 2 * (size_t)m->r_u * m->n_out + m->n_out + (size_t)m->r_u * m->n_probe
                                      + m->n_probe + m->r_u + m->r_f);
    if (rom->length != need) {
        rom_error(rom, "resource '%s' has %lu bytes, its sizes need %lu", file, (unsigned long)rom->length,
                  (unsigned long)need);
        return 0;
    }
#define TAKE(target, count) do { target = (double *)(rom->buffer + offset); offset += sizeof(double) * (size_t)(count); } while (0)
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
    {   /* the working arrays: x, s, z, quad, d */
        double *w = rom_work(rom, 2 * (size_t)m->r_f + (size_t)m->r_u + (size_t)m->n_quad + (size_t)m->n_out);
        if (w == NULL) return 0;
        m->x = w; m->s = m->x + m->r_f; m->z = m->s + m->r_f; m->quad = m->z + m->r_u; m->d = m->quad + m->n_quad;
    }
    rom_declare(rom, m->n_in, m->n_out, m->n_probe, 2, m->components, (size_t)m->p * m->r_u + 2 * (size_t)m->r_f);   /* a probe: a point (x, y) */
    return 1;
}

void rom_describe(const Rom *rom, char *text, size_t size) {
    const Model *m = (const Model *)rom->model;
    snprintf(text, size, "%d inputs (%s), %d outputs (%s), %d probe values, %d force and %d displacement modes, "
             "a history of %d windows", m->n_in, rom->input_name, m->n_out, rom->output_name, m->n_probe, m->r_f,
             m->r_u, m->p);
}

/* ---- outside FMI: the in-process path and the take-over ---- */

/* a window's call: f (n_in) in; u (n_out), probes (n_probe), x (r_f), z (r_u) out; the history stays */
void step_map_evaluate(void *c, const double *f, double *u, double *probes, double *x, double *z) {
    Rom *rom = rom_of(c);
    const Model *m = (const Model *)rom->model;
    memcpy(rom->inputs, f, sizeof(double) * (size_t)m->n_in);
    rom_evaluate(rom);
    /* the caller's arrays may be the instance's own buffers (step_map_view): then there is nothing to copy */
    if (u != rom->outputs) memcpy(u, rom->outputs, sizeof(double) * (size_t)m->n_out);
    if (probes != rom->outputs + m->n_out) memcpy(probes, rom->outputs + m->n_out, sizeof(double) * (size_t)m->n_probe);
    if (x != m->x) memcpy(x, m->x, sizeof(double) * (size_t)m->r_f);
    if (z != m->z) memcpy(z, m->z, sizeof(double) * (size_t)m->r_u);
}

/* the last call's z and x join the history (a window closed) */
void step_map_commit(void *c) { rom_commit(rom_of(c)); }

/* write == 0: copy the history out into zh (p r_u) and xh (2 r_f); otherwise set it from them */
void step_map_history(void *c, double *zh, double *xh, int write) {
    Model *m = (Model *)rom_of(c)->model;
    const size_t nz = sizeof(double) * (size_t)m->p * m->r_u, nx = sizeof(double) * 2 * (size_t)m->r_f;
    if (write) { memcpy(m->zh, zh, nz); memcpy(m->xh, xh, nx); }
    else { memcpy(zh, m->zh, nz); memcpy(xh, m->xh, nx); }
}

/* the history from n converged windows of a full-order run, oldest first: forces (n x n_in) encoded, interface
 * displacements (n x n_out) projected, z = Ap (u - base); each joins the history as a committed window would */
int step_map_take_over(void *c, int32_t n, const double *forces, const double *displacements) {
    Rom *rom;
    Model *m;
    int32_t w, i, j;
    if (c == NULL || n < 0) return 0;
    rom = rom_of(c);
    m = (Model *)rom->model;
    for (w = 0; w < n; w++) {
        const double *u = displacements + (size_t)w * m->n_out;
        encode(m, forces + (size_t)w * m->n_in, m->x);
        for (j = 0; j < m->n_out; j++) m->d[j] = u[j] - m->base[j];
        for (i = 0; i < m->r_u; i++) m->z[i] = rom_pairwise_dot(m->Ap + (size_t)i * m->n_out, m->d, m->n_out);
        rom_commit(rom);
    }
    return 1;
}

/* the served path's envelope (r_f bounds, mean, precision r_f x r_f) and where its trust goes (3 values) */
void step_map_bind(void *c, const double *low, const double *high, const double *mean, const double *precision,
                   double max_distance, double *trust) {
    Model *m = (Model *)rom_of(c)->model;
    m->low = low; m->high = high; m->mean = mean; m->precision = precision;
    m->max_distance = max_distance; m->trust = trust;
}

/* a served call: the window's call on f (n_in, or NULL for the inputs already held), then its trust
 * (excess beyond the envelope in range widths, Mahalanobis distance over the largest training one, 1.0 if the
 * excess passes margin); outputs, x and z stay in the instance (step_map_view); returns 1 if out of range */
int step_map_serve(void *c, const double *f, double margin) {
    Rom *rom = rom_of(c);
    Model *m = (Model *)rom->model;
    double out[2];
    if (f != NULL) memcpy(rom->inputs, f, sizeof(double) * (size_t)m->n_in);
    rom_evaluate(rom);
    if (m->trust == NULL) return 0;
    rom_trust(m->x, m->r_f, m->low, m->high, m->mean, m->precision, out);
    m->trust[0] = out[0];
    m->trust[1] = rom_root(out[1]) / m->max_distance;
    m->trust[2] = out[0] > margin ? 1.0 : 0.0;
    return out[0] > margin;
}

/* the instance's own buffers: 0 the outputs then the probes (n_out + n_probe), 1 x (r_f), 2 z (r_u) */
double *step_map_view(void *c, int which) {
    Rom *rom = rom_of(c);
    const Model *m = (const Model *)rom->model;
    return which == 0 ? rom->outputs : which == 1 ? m->x : m->z;
}
