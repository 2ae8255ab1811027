/*
 * The contract between an exported ROM and the FMU skeleton around it.
 *
 * The skeleton (fmi2_rom.c, with rom_runtime.c) writes the FMI entry points, the state machine, logging, instance
 * handling and the FMU state with its serialisation once. A ROM (solid_rom.c, step_map_rom.c) supplies its kind
 * (ROM_KIND), its arithmetic and its state:
 *
 *   rom_load      sizes and arrays from the resource after its common header (its model struct, which starts with
 *                 the int32 sizes, from rom_model), declares its variables and
 *                 history (rom_declare), takes its working arrays from one block (rom_work); 0 on a bad resource
 *   rom_rest      the history at rest (the values are zero when it is called)
 *   rom_evaluate  outputs and locals from the inputs and the history; the history does not move
 *   rom_commit    the evaluated step joins the history (a step is done)
 *   rom_describe  one line for the instantiation event
 *
 * An instance's values are one block: history (n_history) | inputs (n_in) | outputs (n_out) | locals (n_local) |
 * time. Value references number the inputs, outputs and locals in that order. The FMU state is a copy of the
 * block; serialised, it is the ROM's state magic, the model's GUID, the number of values and the FMI state it
 * was taken in (int64 each), then the values (in the machine's byte order).
 *
 * resources/rom.bin starts with a common header: char magic[8]; char guid[40]; char input_name[32],
 * output_name[32]; then the ROM's int32 sizes (ROM_KIND.header_ints) and its float64 arrays.
 */
#ifndef ROM_FMU_H
#define ROM_FMU_H

#include <stddef.h>
#include <stdint.h>

#define ROM_GUID_LENGTH 40
#define ROM_NAME_LENGTH 32
#define ROM_HEADER_BYTES (8 + ROM_GUID_LENGTH + 2 * ROM_NAME_LENGTH)

typedef struct {
    const char *identifier;      /* the model identifier: the default instance name */
    const char *what;            /* what its resource holds, for messages ("solid ROM") */
    char resource_magic[8];      /* the first bytes of resources/rom.bin */
    char state_magic[8];         /* the first bytes of a serialised FMU state */
    int32_t header_ints;         /* int32 sizes after the common header */
} RomKind;

typedef struct Rom {
    /* the skeleton's: its instance and services */
    void *host;
    void *(*allocate)(void *host, size_t count, size_t size);     /* zero-filled memory */
    void (*free)(void *host, void *pointer);
    void (*report)(void *host, int error, const char *category, const char *message);
    /* the resource: read by rom_read_resource, the ROM's arrays point into it */
    char *buffer;
    size_t length;
    char guid[ROM_GUID_LENGTH + 1], input_name[ROM_NAME_LENGTH + 1], output_name[ROM_NAME_LENGTH + 1];
    /* set by rom_load */
    int32_t n_in, n_out, n_local, components;
    size_t n_history;
    void *model;                 /* the ROM's own: sizes, arrays, working arrays (rom_allocate; freed with it) */
    double *work;                /* the ROM's working arrays (rom_work; freed with it) */
    /* the values block (allocated by the skeleton after rom_load) and its parts */
    double *values, *history, *inputs, *outputs, *time;
    size_t n_values;
} Rom;

/* ---- what a ROM supplies ---- */
extern const RomKind ROM_KIND;
int rom_load(Rom *rom, const char *file);
void rom_rest(Rom *rom);
void rom_evaluate(Rom *rom);
void rom_commit(Rom *rom);
void rom_describe(const Rom *rom, char *text, size_t size);

/* ---- what the runtime offers (rom_runtime.c) ---- */
void *rom_allocate(Rom *rom, size_t count, size_t size);
void rom_free(Rom *rom, void *pointer);
void rom_error(Rom *rom, const char *format, ...);
void rom_event(Rom *rom, const char *format, ...);
int rom_read_resource(Rom *rom, const char *resource_uri, const char *guid);
void *rom_model(Rom *rom, size_t bytes);
void rom_declare(Rom *rom, int32_t n_in, int32_t n_out, int32_t n_local, int32_t components, size_t n_history);
double *rom_work(Rom *rom, size_t count);
int rom_allocate_values(Rom *rom);
void rom_reset_values(Rom *rom);
const char *rom_variable_name(const Rom *rom, uint32_t vr, char *text, size_t size);
int rom_finite(double v);
double rom_pairwise_dot(const double *row, const double *v, int32_t n);
void rom_trust(const double *x, int32_t r, const double *low, const double *high, const double *mean,
               const double *precision, double out[2]);
double rom_root(double q);

/* ---- what the skeleton offers outside FMI (the in-process path) ---- */
void *rom_open(const char *resource_uri, const char *guid);
const char *rom_last_error(void);
void rom_close(void *instance);
Rom *rom_of(void *instance);

#endif
