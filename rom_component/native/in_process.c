/*
 * The in-process entry points of every ROM, outside FMI: an instance of rom_runtime.c on a resource folder, with
 * plain calloc/free and a report that keeps the last message, for a Python process through ctypes
 * (rom_component.static.compiled, rom_component.dynamic.compiled). The ROM's own functions act on rom_of(instance).
 * An exported FMU's binary has the same four functions from its FMI entry points (fmi2_rom.c, fmi3_rom.c).
 */
#include <stdio.h>
#include <stdlib.h>

#include "rom_fmu.h"

static char last_message[1024];

static void *plain_allocate(void *host, size_t count, size_t size) { (void)host; return calloc(count, size); }
static void plain_free(void *host, void *pointer) { (void)host; free(pointer); }

static void keep_message(void *host, int error, const char *category, const char *message) {
    (void)host; (void)error; (void)category;
    snprintf(last_message, sizeof(last_message), "%s", message);
}

/* an instance reading resource_uri/rom.bin, or NULL (the reason in rom_last_error) */
void *rom_open(const char *resource_uri, const char *guid) {
    Rom *rom = (Rom *)calloc(1, sizeof(Rom));
    last_message[0] = 0;
    if (rom == NULL) return NULL;
    rom->host = rom;
    rom->allocate = plain_allocate;
    rom->free = plain_free;
    rom->report = keep_message;
    if (!rom_instantiate(rom, resource_uri, guid)) {
        rom_close(rom);
        return NULL;
    }
    return rom;
}

/* the last error message of rom_open (empty if none) */
const char *rom_last_error(void) { return last_message; }

void rom_close(void *instance) {
    if (instance == NULL) return;
    rom_release_all((Rom *)instance);
    free(instance);
}

Rom *rom_of(void *instance) { return (Rom *)instance; }
