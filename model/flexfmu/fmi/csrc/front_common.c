/*
 * front_common.c - the part of the FMU fronts that no FMI version defines (front_common.h says what and why).
 * Compiled inside flexfmu_fmi2.c, which includes it: in its Python variant (loading libpython and the bridge
 * <id>_python.so) or, with FLEXFMU_NATIVE, its native one (the native bridge, flexfmu_native.c, linked in).
 * Nothing is ever dlclose()d or finalised (see native_python.c): the host may unload this library.
 */
#if !defined(_WIN32) && !defined(_GNU_SOURCE)
#define _GNU_SOURCE /* dladdr, RTLD_DEFAULT */
#endif
#include "front_common.h"

#if defined(_WIN32)
#include "native_platform.h" /* pthread mutexes on SRW locks, dladdr on GetModuleHandleEx */
#else
#include <dlfcn.h>
#endif
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* the StateBox layout below, second word of a box: a box of another flexfmu build (whose second word is an FMI
   state, 1 .. 32, in the first layout) is recognised by it before anything beyond it is read */
#define STATE_MAGIC 0x53584c46u /* "FLXS" */
#define STATE_BOX_LAYOUT 0x4c580002u

/* Which runtime an FMU state belongs to: the Python bridge's states are Python objects, the native bridge's C
   snapshots; a state of one must never reach the other. */
#if defined(FLEXFMU_NATIVE)
#define RUNTIME_ID 2u
#define RUNTIME_NAME "native"
#else
#define RUNTIME_ID 1u
#define RUNTIME_NAME "Python"
#endif

#if defined(_WIN32)
static FrontThread this_thread(void) { return GetCurrentThreadId(); }
static int same_thread(FrontThread a, FrontThread b) { return a == b; }
#else
static FrontThread this_thread(void) { return pthread_self(); }
static int same_thread(FrontThread a, FrontThread b) { return pthread_equal(a, b); }
#endif

/* The header (magic, layout, runtime, GUID) comes first and is read before anything else: a state from another
   FMU, another runtime or another flexfmu build is refused before its contents are touched. */
typedef struct {
    uint32_t magic, layout, runtime;
    char guid[128]; /* the FMU's GUID (cut to 127 bytes; the full GUID is compared on deserialising) */
    int fmi_state;  /* the instance's FMI state when it was taken: setting the state restores it too */
    void *python;   /* the runtime's snapshot (flexfmu_native.c) */
} StateBox;

char *front_copy_string(const char *text) {
    size_t n = strlen(text ? text : "") + 1;
    char *copy = malloc(n);
    if (copy) memcpy(copy, text ? text : "", n);
    return copy;
}

/* ---- logging ------------------------------------------------------------------------------------- */

/* Does the host want this message?  Errors always; the rest per its debug-logging settings. */
static int wanted(const FrontInstance *inst, int status, const char *category) {
    if (!inst->logger) return 0;
    if (status >= BRIDGE_DISCARD) return 1;
    if (!inst->logging_on) return 0;
    if (inst->n_categories == 0) return 1;
    for (size_t i = 0; i < inst->n_categories; i++)
        if (strcmp(category, inst->categories[i]) == 0 || strcmp(inst->categories[i], "logAll") == 0) return 1;
    return 0;
}

void front_emit(void *context, int status, const char *category, const char *message) {
    FrontInstance *inst = context;
    if (wanted(inst, status, category)) inst->version->deliver(inst, status, category, message);
}

int front_fail(FrontInstance *inst, const char *function, const char *why) {
    char message[4096];
    snprintf(message, sizeof message, "%s: %s", function, why);
    front_emit(inst, BRIDGE_ERROR, "logStatusError", message);
    return BRIDGE_ERROR;
}

/* ---- entering and leaving a call --------------------------------------------------------------- */

/* A host's logger that calls back into an instance whose call is running (and logging) on the same thread would
   wait forever on the instance's lock: such a call is refused instead (Error), and reported once the running call
   leaves.  `owner` is read without the lock: another thread's id never equals ours, whatever it reads. */
static int called_back(const FrontInstance *inst) { return inst->busy && same_thread(inst->owner, this_thread()); }

void front_unlock(FrontInstance *inst) {
    inst->busy = 0;
    inst->running = NULL;
    pthread_mutex_unlock(&inst->lock);
}

FrontInstance *front_enter(void *instance, const FrontVersion *version, const FrontCall *call) {
    FrontInstance *inst = instance;
    if (!inst || inst->magic != version->magic) return NULL; /* no logger to tell */
    if (called_back(inst)) { /* from the logger of this instance's running call: no logging (it would recurse) */
        if (!inst->reentered) inst->reentered = call->name; /* this thread holds the lock: safe */
        return NULL;
    }
    pthread_mutex_lock(&inst->lock);
    inst->owner = this_thread();
    inst->busy = 1;
    inst->running = call->name;
    char why[256];
    if (call->unsupported) {
        front_fail(inst, call->name, call->unsupported);
    } else if (!(call->states & inst->state)) {
        snprintf(why, sizeof why, "illegal call sequence (state %s)", version->state_name(inst->state));
        front_fail(inst, call->name, why);
    } else {
        return inst;
    }
    front_leave(inst, BRIDGE_ERROR); /* a call its logger made while it was refused is reported too */
    return NULL;
}

int front_leave(FrontInstance *inst, int status) {
    if (inst->reentered) { /* once per call: a logger that calls again while told is refused again, silently */
        char message[512];
        snprintf(message, sizeof message,
                 "%s: called from the logger callback while %s was running on this instance; refused (%s): "
                 "call the FMU after the callback returns",
                 inst->reentered, inst->running ? inst->running : "a call", inst->version->error_name);
        inst->reentered = NULL;
        front_emit(inst, BRIDGE_ERROR, "logStatusError", message);
        inst->reentered = NULL;
    }
    if (inst->version->every_error && status >= BRIDGE_ERROR) inst->state = inst->version->error_state;
    front_unlock(inst);
    return status;
}

/* ---- the instance -------------------------------------------------------------------------------- */

FrontInstance *front_new_instance(const FrontVersion *version, size_t size, int state, const char *name,
                                  const char *guid, int logging_on, FrontLogger logger, void *environment) {
    FrontInstance *inst = calloc(1, size);
    if (!inst) return NULL;
    inst->magic = version->magic;
    inst->version = version;
    inst->logger = logger;
    inst->environment = environment;
    inst->name = front_copy_string(name);
    inst->guid = front_copy_string(guid);
    inst->logging_on = logging_on;
    inst->state = state;
    pthread_mutex_init(&inst->lock, NULL);
    if (!inst->name || !inst->guid) {
        front_free_instance_memory(inst);
        return NULL;
    }
    return inst;
}

static void free_categories(FrontInstance *inst) {
    for (size_t i = 0; i < inst->n_categories; i++) free(inst->categories[i]);
    free(inst->categories);
    inst->categories = NULL;
    inst->n_categories = 0;
}

void front_free_instance_memory(FrontInstance *inst) {
    free_categories(inst);
    free(inst->name);
    free(inst->guid);
    inst->magic = 0;
    pthread_mutex_destroy(&inst->lock);
    free(inst);
}

int front_set_debug_logging(FrontInstance *inst, const char *function, int logging_on, size_t n_categories,
                            const char *const categories[]) {
    if (n_categories > 0 && !categories) return front_fail(inst, function, "categories is NULL");
    free_categories(inst);
    inst->logging_on = logging_on;
    if (n_categories > 0) {
        inst->categories = calloc(n_categories, sizeof *inst->categories);
        for (size_t i = 0; inst->categories && i < n_categories; i++) {
            inst->categories[i] = front_copy_string(categories[i]);
            inst->n_categories = i + 1;
        }
    }
    return BRIDGE_OK;
}

int front_setup_experiment(FrontInstance *inst, const char *function, int tolerance_defined, double tolerance,
                           double start_time, int stop_time_defined, double stop_time) {
    if (!isfinite(start_time))
        return front_fail(inst, function, "startTime is not finite (allowed: a finite time in s)");
    if (stop_time_defined && !(isfinite(stop_time) && stop_time >= start_time))
        return front_fail(inst, function, "stopTime must be finite and >= startTime");
    if (tolerance_defined && !(isfinite(tolerance) && tolerance > 0))
        return front_fail(inst, function, "tolerance must be finite and > 0");
    return inst->bridge->setup_experiment(inst->slave, tolerance_defined, tolerance, start_time, stop_time_defined,
                                          stop_time);
}

/* ---- the resources folder ---------------------------------------------------------------------- */

/* This library's own file name, e.g. /tmp/x/binaries/linux64/FFRBeam.so */
static int own_path(char *path, size_t size) {
    Dl_info info;
    if (!dladdr((void *)&own_path, &info) || !info.dli_fname || strlen(info.dli_fname) + 1 > size) return -1;
    snprintf(path, size, "%s", info.dli_fname);
    return 0;
}

static int is_resources(const char *path) {
    char probe[4200];
    snprintf(probe, sizeof probe, "%s/flexfmu_build.json", path);
    FILE *file = fopen(probe, "r");
    if (file) fclose(file);
    return file != NULL;
}

/* The resources next to this library: <fmu>/binaries/<platform>/<id>.so -> <fmu>/resources. */
static int resources_beside_library(char *path, size_t size) {
    char own[4096];
    if (own_path(own, sizeof own) < 0) return -1;
    for (int up = 0; up < 3; up++) {
        char *slash = strrchr(own, '/');
        if (!slash) return -1;
        *slash = '\0';
    }
    snprintf(path, size, "%s/resources", own);
    return is_resources(path) ? 0 : -1;
}

/* "file:///a%20b/resources", "file:/...", "file://localhost/..." -> "/a b/resources" */
static int uri_path(const char *uri, char *path, size_t size) {
    const char *p = uri + 5;
    if (strncmp(p, "///", 3) == 0)
        p += 2;
    else if (strncmp(p, "//localhost/", 12) == 0)
        p += 11;
    else if (strncmp(p, "//", 2) == 0)
        return -1; /* another host */
    size_t j = 0;
    for (; *p && j + 1 < size; p++) {
        unsigned int byte;
        if (p[0] == '%' && p[1] && p[2] && sscanf(p + 1, "%2x", &byte) == 1) {
            path[j++] = (char)byte;
            p += 2;
        } else {
            path[j++] = *p;
        }
    }
    path[j] = '\0';
    while (j > 1 && path[j - 1] == '/') path[--j] = '\0';
#if defined(_WIN32)
    if (path[0] == '/' && path[1] && path[2] == ':') memmove(path, path + 1, j); /* "/C:/a" -> "C:/a" */
#endif
    return 0;
}

int front_resources_from_uri(const char *uri, char *path, size_t size) {
    if (uri && strncmp(uri, "file:", 5) == 0 && uri_path(uri, path, size) == 0 && is_resources(path)) return 0;
    return resources_beside_library(path, size);
}

int front_resources_from_path(const char *location, char *path, size_t size) {
    if (location && strncmp(location, "file:", 5) == 0) return front_resources_from_uri(location, path, size);
    if (location && *location && strlen(location) < size) {
        size_t j = strlen(location);
        memcpy(path, location, j + 1);
        while (j > 1 && (path[j - 1] == '/' || path[j - 1] == '\\')) path[--j] = '\0';
        if (is_resources(path)) return 0;
    }
    return resources_beside_library(path, size);
}

/* ---- loading Python and the bridge (once per loaded copy of this library) ---------------------- */

static pthread_mutex_t load_lock = PTHREAD_MUTEX_INITIALIZER;
static const BridgeApi *loaded_bridge = NULL;
static char load_error[3072];

#if defined(FLEXFMU_NATIVE)
/* The native bridge is linked in (flexfmu_native.c): no libpython, no second library. */
const BridgeApi *flexfmu_native_api(void);

static const BridgeApi *load_bridge(const char *resources) {
    (void)resources;
    pthread_mutex_lock(&load_lock);
    if (!loaded_bridge && !load_error[0]) {
        const BridgeApi *api = flexfmu_native_api();
        char why[2048] = "";
        if (!api || api->version != FLEXFMU_BRIDGE_VERSION)
            snprintf(load_error, sizeof load_error, "the FMU's native bridge has another version than its front");
        else if (api->start(NULL, why, sizeof why) != 0)
            snprintf(load_error, sizeof load_error, "%s", why);
        else
            loaded_bridge = api;
    }
    pthread_mutex_unlock(&load_lock);
    return loaded_bridge;
}
#else
typedef struct {
    char libpython[4096], python_home[4096], python_version[32], site_dirs[16384];
} RuntimeSettings;

static void read_settings(const char *resources, RuntimeSettings *rs) {
    memset(rs, 0, sizeof *rs);
    char path[4200], line[8192];
    snprintf(path, sizeof path, "%s/flexfmu_runtime.txt", resources);
    FILE *file = fopen(path, "r");
    while (file && fgets(line, sizeof line, file)) {
        line[strcspn(line, "\r\n")] = '\0';
        char *eq = strchr(line, '=');
        if (line[0] == '#' || !eq) continue;
        *eq = '\0';
        const char *key = line, *value = eq + 1;
        if (strcmp(key, "libpython") == 0)
            snprintf(rs->libpython, sizeof rs->libpython, "%s", value);
        else if (strcmp(key, "python_home") == 0)
            snprintf(rs->python_home, sizeof rs->python_home, "%s", value);
        else if (strcmp(key, "python_version") == 0)
            snprintf(rs->python_version, sizeof rs->python_version, "%s", value);
        else if (strcmp(key, "site") == 0) {
            size_t used = strlen(rs->site_dirs);
            snprintf(rs->site_dirs + used, sizeof rs->site_dirs - used, "%s%s", used ? ":" : "", value);
        }
    }
    if (file) fclose(file);
    const char *env;
    if ((env = getenv("FLEXFMU_LIBPYTHON")) && *env) snprintf(rs->libpython, sizeof rs->libpython, "%s", env);
    if ((env = getenv("FLEXFMU_PYTHONHOME")) && *env) snprintf(rs->python_home, sizeof rs->python_home, "%s", env);
    if ((env = getenv("FLEXFMU_SITE_PACKAGES"))) snprintf(rs->site_dirs, sizeof rs->site_dirs, "%s", env);
}

static const BridgeApi *load_bridge(const char *resources) {
    pthread_mutex_lock(&load_lock);
    if (loaded_bridge || load_error[0]) goto done;
    RuntimeSettings rs;
    read_settings(resources, &rs);
    if (!dlsym(RTLD_DEFAULT, "Py_IsInitialized")) { /* not a Python host: bring libpython in, globally */
        if (!rs.libpython[0]) {
            snprintf(load_error, sizeof load_error,
                     "no libpython recorded in %s/flexfmu_runtime.txt; set FLEXFMU_LIBPYTHON to a "
                     "libpython%s.so",
                     resources, rs.python_version);
            goto done;
        }
        if (!dlopen(rs.libpython, RTLD_NOW | RTLD_GLOBAL)) {
            snprintf(load_error, sizeof load_error,
                     "cannot load libpython (%s); set FLEXFMU_LIBPYTHON to the libpython%s.so of a Python %s "
                     "that has the packages in resources/requirements.txt (docs/fmu.md, 'Another machine')",
                     dlerror(), rs.python_version, rs.python_version);
            goto done;
        }
    }
    char own[4096], bridge_path[4200];
    if (own_path(own, sizeof own) < 0 || strlen(own) < 4) {
        snprintf(load_error, sizeof load_error, "the FMU cannot locate its own binary");
        goto done;
    }
    snprintf(bridge_path, sizeof bridge_path, "%.*s_python.so", (int)(strlen(own) - 3), own);
    void *lib = dlopen(bridge_path, RTLD_NOW | RTLD_LOCAL);
    BridgeEntry *entry = lib ? (BridgeEntry *)dlsym(lib, FLEXFMU_BRIDGE_ENTRY) : NULL;
    if (!entry) {
        snprintf(load_error, sizeof load_error, "cannot load the FMU's Python bridge: %s", dlerror());
        goto done;
    }
    const BridgeApi *api = entry();
    if (!api || api->version != FLEXFMU_BRIDGE_VERSION) {
        snprintf(load_error, sizeof load_error, "the FMU's Python bridge has another version than its front");
        goto done;
    }
    BridgeSettings settings = {rs.python_home, rs.site_dirs, rs.python_version};
    char why[2048] = "";
    if (api->start(&settings, why, sizeof why) != 0) {
        snprintf(load_error, sizeof load_error, "%s", why);
        goto done;
    }
    loaded_bridge = api;
done:
    pthread_mutex_unlock(&load_lock);
    return loaded_bridge;
}
#endif /* FLEXFMU_NATIVE */

int front_instantiate_slave(FrontInstance *inst, const char *function, const char *resources, int visible) {
    inst->bridge = load_bridge(resources);
    if (!inst->bridge) {
        front_fail(inst, function, load_error);
        return -1;
    }
    inst->slave = inst->bridge->instantiate(resources, inst->name, inst->guid, visible, front_emit, inst);
    return inst->slave ? 0 : -1; /* the bridge has logged why */
}

/* ---- FMU states ---------------------------------------------------------------------------------- */

/* Serialised (little-endian): "FLEXFMU-STATE\n" (14 bytes), u32 format (2), u32 runtime (1 Python, 2 native),
   u32 FMI state, u64 payload size, u32 CRC-32 of all the bytes after it, u32 GUID length, the GUID, then the
   bridge's payload.  The GUID ties a state to the FMU (and build) that wrote it, the runtime to its bridge, the size
   and the checksum refuse a truncated or damaged state before the bridge reads it. */
static const char STATE_HEADER[] = "FLEXFMU-STATE\n";
#define HEADER_SIZE (sizeof STATE_HEADER - 1)
#define STATE_FORMAT 2u
#define FIXED_HEADER (HEADER_SIZE + 28) /* format, runtime, FMI state, size (8), CRC, GUID length */
#define CRC_AT (HEADER_SIZE + 20)

/* CRC-32 (IEEE 802.3, as zlib's crc32) of n bytes, bit by bit: states are small and this runs per serialisation. */
static uint32_t crc32_of(const unsigned char *bytes, size_t n) {
    uint32_t crc = 0xffffffffu;
    for (size_t i = 0; i < n; i++) {
        crc ^= bytes[i];
        for (int k = 0; k < 8; k++) crc = (crc >> 1) ^ (0xedb88320u & (0u - (crc & 1u)));
    }
    return ~crc;
}

/* The box of a state this instance may use, or NULL (why says what it is): the header is read first. */
static StateBox *box_of_instance(const FrontInstance *inst, void *state, const char **why) {
    StateBox *box = (StateBox *)state;
    *why = "not an FMU state (or it was freed)";
    if (!box || box->magic != STATE_MAGIC) return NULL;
    *why = "a state of another flexfmu build (its layout differs)";
    if (box->layout != STATE_BOX_LAYOUT) return NULL;
    *why = box->runtime == 1u ? "a state of a Python-runtime FMU; this FMU runs the " RUNTIME_NAME " runtime"
                              : "a state of a native-runtime FMU; this FMU runs the " RUNTIME_NAME " runtime";
    if (box->runtime != RUNTIME_ID) return NULL;
    *why = "a state of another FMU (its GUID differs)";
    if (strncmp(box->guid, inst->guid, sizeof box->guid - 1) != 0) return NULL;
    return box;
}

static void label_box(const FrontInstance *inst, StateBox *box) {
    box->magic = STATE_MAGIC;
    box->layout = STATE_BOX_LAYOUT;
    box->runtime = RUNTIME_ID;
    snprintf(box->guid, sizeof box->guid, "%s", inst->guid);
}

int front_get_state(FrontInstance *inst, const char *function, void **state) {
    if (!state) return front_fail(inst, function, "FMUstate is NULL");
    const char *why;
    StateBox *box = *state ? box_of_instance(inst, *state, &why) : NULL;
    if (*state && !box) return front_fail(inst, function, "*FMUstate is not a state of this FMU");
    void *python = NULL;
    int status = inst->bridge->get_state(inst->slave, &python);
    if (status > BRIDGE_WARNING) return status;
    if (box) { /* a given state is overwritten */
        inst->bridge->free_state(box->python);
    } else if (!(box = malloc(sizeof *box))) {
        inst->bridge->free_state(python);
        return front_fail(inst, function, "out of memory");
    }
    label_box(inst, box);
    box->fmi_state = inst->state;
    box->python = python;
    *state = box;
    return status;
}

int front_set_state(FrontInstance *inst, const char *function, void *state) {
    const char *why;
    StateBox *box = box_of_instance(inst, state, &why);
    if (!box) {
        char text[256];
        snprintf(text, sizeof text, "FMUstate is not a state of this FMU: %s", why);
        return front_fail(inst, function, text);
    }
    const FrontVersion *v = inst->version;
    int taken_me = (box->fmi_state & v->me_states) != 0, taken_cs = (box->fmi_state & v->cs_states) != 0;
    if ((taken_me && !inst->model_exchange) || (taken_cs && inst->model_exchange)) {
        char text[256];
        snprintf(text, sizeof text,
                 "FMUstate was taken by a %s instance (in %s); this instance is for %s: set states of the same "
                 "interface type",
                 taken_me ? "model-exchange" : "co-simulation", v->state_name(box->fmi_state),
                 inst->model_exchange ? "model exchange" : "co-simulation");
        return front_fail(inst, function, text);
    }
    int status = inst->bridge->set_state(inst->slave, box->python);
    if (status <= BRIDGE_WARNING)
        inst->state = box->fmi_state;
    else if (status >= BRIDGE_ERROR)
        inst->state = inst->version->error_state;
    return status;
}

int front_free_state(FrontInstance *inst, const char *function, void **state) {
    if (!state) return BRIDGE_OK;
    const char *why;
    /* A host that passes the state where its address belongs (fmusim's --initial-fmu-state-file does) would have
       the state's first bytes taken for a pointer: the address passed is read as a box first (reading its first
       4 bytes is safe either way: a pointer variable is 8) and, if it is one of this instance's, freed as such. */
    if (*(const uint32_t *)(const void *)state == STATE_MAGIC && box_of_instance(inst, (void *)state, &why)) {
        StateBox *given = (StateBox *)(void *)state;
        char text[200];
        snprintf(text, sizeof text,
                 "%s: got the FMU state itself, not its address (FMUstate is a pointer to the "
                 "state); it is freed",
                 function);
        front_emit(inst, BRIDGE_WARNING, "logStatusWarning", text);
        inst->bridge->free_state(given->python);
        given->magic = 0;
        free(given);
        return BRIDGE_OK; /* freed as asked: fmusim stops on a Warning here, and the message says what happened */
    }
    if (!*state) return BRIDGE_OK;
    StateBox *box = box_of_instance(inst, *state, &why);
    if (!box) return front_fail(inst, function, "*FMUstate is not a state of this FMU");
    inst->bridge->free_state(box->python);
    box->magic = 0;
    free(box);
    *state = NULL;
    return BRIDGE_OK;
}

static void put_u32(char *at, uint32_t value) {
    for (int i = 0; i < 4; i++) at[i] = (char)((value >> (8 * i)) & 0xff);
}

static uint32_t get_u32(const char *at) {
    uint32_t value = 0;
    for (int i = 0; i < 4; i++) value |= (uint32_t)(unsigned char)at[i] << (8 * i);
    return value;
}

static void put_u64(char *at, uint64_t value) {
    put_u32(at, (uint32_t)value);
    put_u32(at + 4, (uint32_t)(value >> 32));
}

static uint64_t get_u64(const char *at) { return (uint64_t)get_u32(at) | (uint64_t)get_u32(at + 4) << 32; }

static size_t header_size(const FrontInstance *inst) { return FIXED_HEADER + strlen(inst->guid); }

int front_serialized_state_size(FrontInstance *inst, const char *function, void *state, size_t *size) {
    const char *why;
    StateBox *box = box_of_instance(inst, state, &why);
    if (!box || !size) return front_fail(inst, function, "not a state of this FMU");
    size_t n = 0;
    int status = inst->bridge->serialize_state(inst->slave, box->python, NULL, &n);
    if (status <= BRIDGE_WARNING) *size = header_size(inst) + n;
    return status;
}

int front_serialize_state(FrontInstance *inst, const char *function, void *state, char *bytes, size_t size) {
    const char *why;
    StateBox *box = box_of_instance(inst, state, &why);
    if (!box || !bytes) return front_fail(inst, function, "not a state of this FMU");
    size_t head = header_size(inst), payload = 0;
    int status = inst->bridge->serialize_state(inst->slave, box->python, NULL, &payload);
    if (status > BRIDGE_WARNING) return status;
    if (size < head + payload) {
        char text[256];
        snprintf(text, sizeof text, "size: got %zu bytes, the state needs %zu (%s)", size, head + payload,
                 inst->version->serialized_size_name);
        return front_fail(inst, function, text);
    }
    memcpy(bytes, STATE_HEADER, HEADER_SIZE);
    put_u32(bytes + HEADER_SIZE, STATE_FORMAT);
    put_u32(bytes + HEADER_SIZE + 4, RUNTIME_ID);
    put_u32(bytes + HEADER_SIZE + 8, (uint32_t)box->fmi_state);
    put_u64(bytes + HEADER_SIZE + 12, (uint64_t)payload);
    put_u32(bytes + HEADER_SIZE + 24, (uint32_t)strlen(inst->guid));
    memcpy(bytes + FIXED_HEADER, inst->guid, strlen(inst->guid));
    size_t rest = payload;
    status = inst->bridge->serialize_state(inst->slave, box->python, bytes + head, &rest);
    if (status > BRIDGE_WARNING) return status;
    if (rest != payload) return front_fail(inst, function, "the state changed size while written");
    put_u32(bytes + CRC_AT, crc32_of((const unsigned char *)bytes + CRC_AT + 4, head + payload - CRC_AT - 4));
    return status;
}

int front_deserialize_state(FrontInstance *inst, const char *function, const char *bytes, size_t size, void **state) {
    if (!bytes || !state) return front_fail(inst, function, "serializedState or FMUstate is NULL");
    if (size < HEADER_SIZE + 4 || memcmp(bytes, STATE_HEADER, HEADER_SIZE) != 0)
        return front_fail(inst, function, "the bytes are not a serialized flexfmu FMU state (bad header)");
    uint32_t format = get_u32(bytes + HEADER_SIZE);
    if (format != STATE_FORMAT) {
        char text[160];
        snprintf(text, sizeof text, "the state was serialized in format %u; this FMU reads format %u", (unsigned)format,
                 STATE_FORMAT);
        return front_fail(inst, function, text);
    }
    if (size < FIXED_HEADER) return front_fail(inst, function, "the state is truncated (shorter than its header)");
    uint32_t runtime = get_u32(bytes + HEADER_SIZE + 4);
    uint32_t fmi_state = get_u32(bytes + HEADER_SIZE + 8);
    uint64_t payload = get_u64(bytes + HEADER_SIZE + 12);
    uint32_t guid_length = get_u32(bytes + HEADER_SIZE + 24);
    if (guid_length > size - FIXED_HEADER || payload != size - FIXED_HEADER - guid_length) {
        char text[200];
        snprintf(text, sizeof text, "the state is truncated or extended: %zu bytes, its header says %llu", size,
                 (unsigned long long)(FIXED_HEADER + (uint64_t)guid_length + payload));
        return front_fail(inst, function, text);
    }
    if (get_u32(bytes + CRC_AT) != crc32_of((const unsigned char *)bytes + CRC_AT + 4, size - CRC_AT - 4))
        return front_fail(inst, function, "the state is damaged (its CRC-32 checksum does not match its bytes)");
    if (runtime != RUNTIME_ID)
        return front_fail(inst, function,
                          runtime == 1u
                              ? "the state is of a Python-runtime FMU; this FMU runs the " RUNTIME_NAME " runtime"
                              : "the state is of a native-runtime FMU; this FMU runs the " RUNTIME_NAME " runtime");
    if (guid_length != strlen(inst->guid) || memcmp(bytes + FIXED_HEADER, inst->guid, guid_length) != 0)
        return front_fail(inst, function, "the state is of another FMU or build (its GUID differs)");
    if (!(fmi_state & (uint32_t)inst->version->all_states) || (fmi_state & (fmi_state - 1)))
        return front_fail(inst, function, "the state's FMI state field is invalid");
    const char *why;
    StateBox *box = *state ? box_of_instance(inst, *state, &why) : NULL;
    if (*state && !box) return front_fail(inst, function, "*FMUstate is not a state of this FMU");
    void *python = NULL;
    size_t head = header_size(inst);
    int status = inst->bridge->deserialize_state(inst->slave, bytes + head, size - head, &python);
    if (status > BRIDGE_WARNING) return status;
    if (box) {
        inst->bridge->free_state(box->python);
    } else if (!(box = malloc(sizeof *box))) {
        inst->bridge->free_state(python);
        return front_fail(inst, function, "out of memory");
    }
    label_box(inst, box);
    box->fmi_state = (int)fmi_state;
    box->python = python;
    *state = box;
    return status;
}
