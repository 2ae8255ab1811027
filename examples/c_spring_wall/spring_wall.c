/*
 * The spring wall of examples/spring_wall, written in C against the wire protocol alone (docs/contract.md,
 * "A component in another language"): libzmq for the socket, msgpack-c for the headers.
 *
 *   cc -O2 -o spring_wall spring_wall.c -lzmq -lmsgpackc -lm
 *   ./spring_wall tcp://127.0.0.1:5555
 *
 * It binds a ROUTER socket, prints {"endpoint": ..., "pid": ...} on one line, and answers the coupler's requests
 * until "shutdown". Each node of the wall is a spring on the radius: r = r0 + p r0^2 / E, a = pi r^2. It serves
 * the first client that drives it (anyone may ping it until then), as `cosim serve` does.
 */
#include <math.h>
#include <msgpack.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <zmq.h>

#define PROTOCOL_VERSION 1
#define MAX_FRAMES 16

typedef struct {
    int n;                /* nodes: the tube's cells + 1 */
    double length, r0, E;
    double *pressure, *section;
} Wall;

/* --- reading a request --------------------------------------------------------------------------------------- */

static const msgpack_object *lookup(const msgpack_object *map, const char *key) {
    uint32_t i;
    size_t length = strlen(key);
    if (map == NULL || map->type != MSGPACK_OBJECT_MAP) return NULL;
    for (i = 0; i < map->via.map.size; i++) {
        const msgpack_object *k = &map->via.map.ptr[i].key;
        if (k->type == MSGPACK_OBJECT_STR && k->via.str.size == length && memcmp(k->via.str.ptr, key, length) == 0)
            return &map->via.map.ptr[i].val;
    }
    return NULL;
}

static int is(const msgpack_object *o, const char *text) {
    return o != NULL && o->type == MSGPACK_OBJECT_STR && o->via.str.size == strlen(text)
           && memcmp(o->via.str.ptr, text, o->via.str.size) == 0;
}

static double number(const msgpack_object *o, double otherwise) {
    if (o == NULL) return otherwise;
    if (o->type == MSGPACK_OBJECT_FLOAT64 || o->type == MSGPACK_OBJECT_FLOAT32) return o->via.f64;
    if (o->type == MSGPACK_OBJECT_POSITIVE_INTEGER) return (double)o->via.u64;
    if (o->type == MSGPACK_OBJECT_NEGATIVE_INTEGER) return (double)o->via.i64;
    return otherwise;
}

/* --- writing a reply ----------------------------------------------------------------------------------------- */

static void key(msgpack_packer *pk, const char *text) {
    msgpack_pack_str(pk, strlen(text));
    msgpack_pack_str_body(pk, text, strlen(text));
}

static void array_spec(msgpack_packer *pk, const char *name, int rows, int columns) {
    msgpack_pack_map(pk, 3);
    key(pk, "name"); key(pk, name);
    key(pk, "dtype"); key(pk, "float64");
    key(pk, "shape");
    msgpack_pack_array(pk, columns ? 2 : 1);
    msgpack_pack_int(pk, rows);
    if (columns) msgpack_pack_int(pk, columns);
}

/* the reply's header: {v, id, ok, result, arrays} with `fill` writing the result map's `entries` entries */
typedef void (*Filler)(msgpack_packer *, const Wall *);

static void send_reply(void *socket, zmq_msg_t *identity, const msgpack_object *id, int entries, Filler fill,
                       const Wall *wall, int n_arrays, const char *const *names, double *const *arrays, int rows,
                       int columns) {
    msgpack_sbuffer buffer;
    msgpack_packer pk;
    int a;
    msgpack_sbuffer_init(&buffer);
    msgpack_packer_init(&pk, &buffer, msgpack_sbuffer_write);
    msgpack_pack_map(&pk, 5);
    key(&pk, "v"); msgpack_pack_int(&pk, PROTOCOL_VERSION);
    key(&pk, "id"); msgpack_pack_object(&pk, *id);
    key(&pk, "ok"); msgpack_pack_true(&pk);
    key(&pk, "result"); msgpack_pack_map(&pk, entries);
    if (fill) fill(&pk, wall);
    key(&pk, "arrays");
    msgpack_pack_array(&pk, n_arrays);
    for (a = 0; a < n_arrays; a++) array_spec(&pk, names[a], rows, columns);
    zmq_msg_send(identity, socket, ZMQ_SNDMORE);
    zmq_send(socket, buffer.data, buffer.size, n_arrays ? ZMQ_SNDMORE : 0);
    for (a = 0; a < n_arrays; a++)
        zmq_send(socket, arrays[a], sizeof(double) * (size_t)rows * (size_t)(columns ? columns : 1),
                 a + 1 < n_arrays ? ZMQ_SNDMORE : 0);
    msgpack_sbuffer_destroy(&buffer);
}

static void send_error(void *socket, zmq_msg_t *identity, const msgpack_object *id, const char *message) {
    msgpack_sbuffer buffer;
    msgpack_packer pk;
    msgpack_sbuffer_init(&buffer);
    msgpack_packer_init(&pk, &buffer, msgpack_sbuffer_write);
    msgpack_pack_map(&pk, 5);
    key(&pk, "v"); msgpack_pack_int(&pk, PROTOCOL_VERSION);
    key(&pk, "id"); if (id) msgpack_pack_object(&pk, *id); else msgpack_pack_nil(&pk);
    key(&pk, "ok"); msgpack_pack_false(&pk);
    key(&pk, "error"); msgpack_pack_map(&pk, 3);
    key(&pk, "type"); key(&pk, "ComponentError");
    key(&pk, "message"); key(&pk, message);
    key(&pk, "component"); key(&pk, "c_spring_wall");
    key(&pk, "arrays"); msgpack_pack_array(&pk, 0);
    zmq_msg_send(identity, socket, ZMQ_SNDMORE);
    zmq_send(socket, buffer.data, buffer.size, 0);
    msgpack_sbuffer_destroy(&buffer);
}

static void ping_result(msgpack_packer *pk, const Wall *wall) {
    (void)wall;
    key(pk, "pid"); msgpack_pack_int(pk, (int)getpid());
}

static void variable(msgpack_packer *pk, const char *name, const char *causality, int size) {
    msgpack_pack_map(pk, 7);
    key(pk, "name"); key(pk, name);
    key(pk, "causality"); key(pk, causality);
    key(pk, "size"); msgpack_pack_int(pk, size);
    key(pk, "unit"); key(pk, "");
    key(pk, "mesh"); key(pk, "axis");
    key(pk, "components"); msgpack_pack_int(pk, 1);
    key(pk, "precision"); msgpack_pack_double(pk, 0.0);
}

static void describe_result(msgpack_packer *pk, const Wall *wall) {
    key(pk, "name"); key(pk, "c_spring_wall");
    key(pk, "variables");
    msgpack_pack_array(pk, 2);
    variable(pk, "pressure", "input", wall->n);
    variable(pk, "section", "output", wall->n);
    key(pk, "can_get_and_set_state"); msgpack_pack_false(pk);
    key(pk, "can_checkpoint"); msgpack_pack_false(pk);
    key(pk, "repeats_steps"); msgpack_pack_false(pk);
    key(pk, "stateless"); msgpack_pack_true(pk);        /* the section follows the pressure of the call alone */
    key(pk, "history_windows"); msgpack_pack_int(pk, 0);
}

/* --- the component ------------------------------------------------------------------------------------------- */

static const char *instantiate(Wall *wall, const msgpack_object *args) {
    const msgpack_object *parameters = lookup(args, "parameters"), *tube = lookup(parameters, "tube");
    int i, cells = (int)number(lookup(tube, "cells"), 100);
    if (cells < 2 || cells > 1000000) return "parameter tube.cells must be from 2 to 1000000";
    wall->n = cells + 1;
    wall->length = number(lookup(tube, "length"), 10.0);
    wall->r0 = sqrt(number(lookup(tube, "a0"), 1.0) / M_PI);
    wall->E = number(lookup(parameters, "E"), 12500.0);
    if (!(wall->E > 0.0)) return "parameter E must be > 0";
    free(wall->pressure);
    free(wall->section);
    wall->pressure = calloc((size_t)wall->n, sizeof(double));
    wall->section = calloc((size_t)wall->n, sizeof(double));
    if (wall->pressure == NULL || wall->section == NULL) return "out of memory";
    for (i = 0; i < wall->n; i++) wall->section[i] = M_PI * (wall->r0 * wall->r0);
    return NULL;
}

static const char *step(Wall *wall, const msgpack_object *header, zmq_msg_t *frames, int n_frames) {
    const msgpack_object *arrays = lookup(header, "arrays");
    uint32_t a;
    int i;
    if (arrays == NULL || arrays->type != MSGPACK_OBJECT_ARRAY || (int)arrays->via.array.size != n_frames - 1)
        return "the step's arrays do not match its frames";
    for (a = 0; a < arrays->via.array.size; a++) {
        const msgpack_object *spec = &arrays->via.array.ptr[a];
        if (!is(lookup(spec, "name"), "pressure")) return "the step's input is not 'pressure'";
        if (!is(lookup(spec, "dtype"), "float64") || zmq_msg_size(&frames[a + 1]) != sizeof(double) * (size_t)wall->n)
            return "input 'pressure' must be float64 of one value per node";
        memcpy(wall->pressure, zmq_msg_data(&frames[a + 1]), sizeof(double) * (size_t)wall->n);
    }
    for (i = 0; i < wall->n; i++) {
        double radius = wall->r0 + wall->pressure[i] * (wall->r0 * wall->r0) / wall->E;   /* as the Python wall */
        wall->section[i] = M_PI * (radius * radius);
    }
    return NULL;
}

int main(int argc, char **argv) {
    void *context = zmq_ctx_new(), *socket = zmq_socket(context, ZMQ_ROUTER);
    char endpoint[256];
    size_t length = sizeof endpoint;
    Wall wall = {0, 10.0, 0.0, 12500.0, NULL, NULL};
    zmq_msg_t owner;
    int owned = 0, done = 0;
    if (argc != 2 || zmq_bind(socket, argv[1]) != 0) {
        fprintf(stderr, "usage: %s tcp://127.0.0.1:PORT (bind failed: %s)\n", argv[0], zmq_strerror(zmq_errno()));
        return 2;
    }
    zmq_getsockopt(socket, ZMQ_LAST_ENDPOINT, endpoint, &length);
    printf("{\"endpoint\": \"%s\", \"pid\": %d, \"name\": \"c_spring_wall\", \"curve\": false}\n", endpoint,
           (int)getpid());
    fflush(stdout);
    zmq_msg_init(&owner);
    while (!done) {
        zmq_msg_t frames[MAX_FRAMES + 1];
        int n = 0, more = 1;
        msgpack_unpacked unpacked;
        const msgpack_object *header, *id, *op;
        const char *error = NULL;
        while (more && n <= MAX_FRAMES) {            /* identity, header, one frame per array */
            zmq_msg_init(&frames[n]);
            if (zmq_msg_recv(&frames[n], socket, 0) < 0) return 1;
            more = zmq_msg_more(&frames[n]);
            n++;
        }
        msgpack_unpacked_init(&unpacked);
        if (n < 2 || msgpack_unpack_next(&unpacked, zmq_msg_data(&frames[1]), zmq_msg_size(&frames[1]), NULL)
                         != MSGPACK_UNPACK_SUCCESS) {
            send_error(socket, &frames[0], NULL, "header is not valid msgpack");
        } else {
            header = &unpacked.data;
            id = lookup(header, "id");
            op = lookup(header, "op");
            if (number(lookup(header, "v"), -1) != PROTOCOL_VERSION || id == NULL || op == NULL) {
                send_error(socket, &frames[0], id, "protocol version 1 with an id and an op is expected");
            } else if (owned && (zmq_msg_size(&owner) != zmq_msg_size(&frames[0])
                                 || memcmp(zmq_msg_data(&owner), zmq_msg_data(&frames[0]), zmq_msg_size(&owner)))) {
                send_error(socket, &frames[0], id, "refused: this component serves another client");
            } else if (is(op, "ping")) {
                send_reply(socket, &frames[0], id, 1, ping_result, &wall, 0, NULL, NULL, 0, 0);
            } else {
                if (!owned) { zmq_msg_copy(&owner, &frames[0]); owned = 1; }   /* the client that drives it */
                if (is(op, "instantiate")) {
                    error = instantiate(&wall, lookup(header, "args"));
                    if (!error) send_reply(socket, &frames[0], id, 0, NULL, &wall, 0, NULL, NULL, 0, 0);
                } else if (is(op, "describe") && wall.n) {
                    const char *name = "mesh:axis";
                    double *axis = malloc(sizeof(double) * (size_t)wall.n);
                    int i;
                    for (i = 0; i < wall.n; i++) axis[i] = wall.length * i / (wall.n - 1);
                    send_reply(socket, &frames[0], id, 7, describe_result, &wall, 1, &name, &axis, wall.n, 1);
                    free(axis);
                } else if (is(op, "step") && wall.n) {
                    const char *name = "section";
                    error = step(&wall, header, &frames[1], n - 1);
                    if (!error) send_reply(socket, &frames[0], id, 0, NULL, &wall, 1, &name, &wall.section, wall.n, 0);
                } else if (is(op, "get_values") && wall.n) {          /* the initial values, before window 1 */
                    const msgpack_object *asked = lookup(lookup(header, "args"), "names");
                    const char *names[2];
                    double *values[2];
                    int count = 0;
                    uint32_t k;
                    for (k = 0; asked && asked->type == MSGPACK_OBJECT_ARRAY && k < asked->via.array.size; k++) {
                        const msgpack_object *wanted = &asked->via.array.ptr[k];
                        if (count < 2 && (is(wanted, "section") || is(wanted, "pressure"))) {
                            names[count] = is(wanted, "section") ? "section" : "pressure";
                            values[count++] = is(wanted, "section") ? wall.section : wall.pressure;
                        } else {
                            error = "get_values: it has the variables 'pressure' and 'section'";
                        }
                    }
                    if (!error) send_reply(socket, &frames[0], id, 0, NULL, &wall, count, names, values, wall.n, 0);
                } else if (is(op, "enter_initialization_mode") || is(op, "exit_initialization_mode")
                           || is(op, "terminate") || is(op, "shutdown")) {
                    send_reply(socket, &frames[0], id, 0, NULL, &wall, 0, NULL, NULL, 0, 0);
                    done = is(op, "shutdown");
                } else {
                    error = "this component does not serve that operation";
                }
                if (error) send_error(socket, &frames[0], id, error);
            }
        }
        msgpack_unpacked_destroy(&unpacked);
        while (n > 0) zmq_msg_close(&frames[--n]);
    }
    zmq_msg_close(&owner);
    free(wall.pressure);
    free(wall.section);
    zmq_close(socket);
    zmq_ctx_term(context);
    return 0;
}
