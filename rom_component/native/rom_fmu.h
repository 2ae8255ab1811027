/*
 * The contract between an exported ROM and the FMU skeleton around it.
 *
 * The skeleton is written once: rom_runtime.c holds what every FMI version shares (the resource, the values, the
 * state machine, logging by category, the FMU states and their serialisation, the step), and fmi2_rom.c and
 * fmi3_rom.c translate the FMI 2.0 and FMI 3.0 Co-Simulation entry points onto it. A ROM (solid_rom.c,
 * step_map_rom.c) supplies its kind (ROM_KIND), its arithmetic and its state:
 *
 *   rom_load      sizes and arrays from the resource after its common header (its model struct, which starts with
 *                 the int32 sizes, from rom_model), declares its variables and history (rom_declare), takes its
 *                 working arrays from one block (rom_work); 0 on a bad resource
 *   rom_rest      the history at rest (the values are zero when it is called)
 *   rom_evaluate  outputs and locals from the inputs and the history; the history does not move
 *   rom_commit    the evaluated step joins the history (a step is done)
 *   rom_describe  one line for the instantiation event
 *
 * An instance's values are one block: history (n_history) | inputs (n_in) | outputs (n_out) | locals (n_local) |
 * time. FMI 2.0 numbers the scalars of inputs, outputs and locals in that order; FMI 3.0 has the time (0), the
 * input (1) and the output (2) as array variables, then each group of local_width locals as one (3, 4, ...). The
 * FMU state is a copy of the block; serialised, it is the ROM's state magic, the model's GUID, the number of values
 * and the machine state it was taken in (int64 each), then the values (in the machine's byte order).
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

/* the Co-Simulation state machine, the same in FMI 2.0 and in FMI 3.0 without event mode; bits, so that a call
 * can name the states it is allowed in */
enum { ROM_INSTANTIATED = 1, ROM_INITIALIZATION = 2, ROM_STEP = 4, ROM_TERMINATED = 8, ROM_ERROR = 16 };
#define ROM_ANY (ROM_INSTANTIATED | ROM_INITIALIZATION | ROM_STEP | ROM_TERMINATED | ROM_ERROR)

typedef struct RomState {
    double *values;              /* a copy of the instance's values */
    int machine;                 /* the machine state it was taken in: restoring it leaves an error */
    struct RomState *next;       /* every state an instance hands out, freed with it at the latest */
} RomState;

typedef struct Rom {
    /* the skeleton's: its instance and services */
    void *host;
    void *(*allocate)(void *host, size_t count, size_t size);     /* zero-filled memory */
    void (*free)(void *host, void *pointer);
    void (*report)(void *host, int error, const char *category, const char *message);
    /* the machine, logging (loggingOn and the enabled categories), the states handed out */
    int machine, dirty;          /* dirty: inputs set since the outputs were computed */
    int logging, log_events, log_errors;
    RomState *states;
    /* the resource: read by rom_instantiate, the ROM's arrays point into it */
    char *buffer;
    size_t length;
    char guid[ROM_GUID_LENGTH + 1], input_name[ROM_NAME_LENGTH + 1], output_name[ROM_NAME_LENGTH + 1];
    /* declared by rom_load */
    int32_t n_in, n_out, n_local, local_width, components;
    size_t n_history;
    void *model;                 /* the ROM's own: sizes, arrays (rom_model) */
    double *work;                /* the ROM's working arrays (rom_work) */
    /* the values block and its parts */
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

/* ---- what the runtime offers a ROM (rom_runtime.c) ---- */
void *rom_allocate(Rom *rom, size_t count, size_t size);
void rom_free(Rom *rom, void *pointer);
void rom_error(Rom *rom, const char *format, ...);
void rom_event(Rom *rom, const char *format, ...);
void *rom_model(Rom *rom, size_t bytes);
void rom_declare(Rom *rom, int32_t n_in, int32_t n_out, int32_t n_local, int32_t local_width, int32_t components,
                 size_t n_history);
double *rom_work(Rom *rom, size_t count);
double rom_pairwise_dot(const double *row, const double *v, int32_t n);
void rom_trust(const double *x, int32_t r, const double *low, const double *high, const double *mean,
               const double *precision, double out[2]);
double rom_root(double q);

/* ---- what the runtime offers a skeleton: the instance whatever the FMI version ---- */
int rom_instantiate(Rom *rom, const char *resources, const char *guid);
void rom_release_all(Rom *rom);
int rom_fail(Rom *rom, const char *format, ...);
int rom_allowed(Rom *rom, int allowed, const char *function);
int rom_set_logging(Rom *rom, int on, size_t n, const char *const categories[], const char *function);
int rom_start(Rom *rom, double start, int stop_defined, double stop, const char *function);
int rom_exit_initialization(Rom *rom, const char *function);
int rom_terminate(Rom *rom, const char *function);
void rom_reset(Rom *rom);
void rom_update(Rom *rom);
int rom_step(Rom *rom, double t, double h, const char *function);
RomState *rom_state_get(Rom *rom, RomState *reuse, const char *function);
int rom_state_set(Rom *rom, const RomState *state, const char *function);
int rom_state_free(Rom *rom, RomState *state, const char *function);
int rom_state_owned(const Rom *rom, const RomState *state);
size_t rom_state_bytes(const Rom *rom);
int rom_state_serialize(Rom *rom, const RomState *state, unsigned char *bytes, size_t size, const char *function);
RomState *rom_state_deserialize(Rom *rom, const unsigned char *bytes, size_t size, RomState *reuse,
                                const char *function);
const char *rom_variable_name(const Rom *rom, uint32_t index, char *text, size_t size);
int rom_finite(double v);

/* ---- what a skeleton offers outside FMI (the in-process path) ---- */
void *rom_open(const char *resource_uri, const char *guid);
const char *rom_last_error(void);
void rom_close(void *instance);
Rom *rom_of(void *instance);

#endif
