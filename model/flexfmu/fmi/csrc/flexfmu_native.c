/*
 * flexfmu_native.c - the one runtime of every flexfmu FMU: BridgeApi (flexfmu_bridge.h) in C99 over a model kind
 * (native_kind.h).  A native FMU links it statically with the front (flexfmu_fmi2.c compiled with -DFLEXFMU_NATIVE,
 * or native_front.c) and the native kinds (native_kinds.c: native_lti.c, native_reframe.c) into its one shared
 * library; a Python FMU's bridge library is it over the Python kind (native_python.c), which calls a simulator
 * written in Python through flexfmu.fmi.plumbing.
 *
 * It holds everything an FMU does that does not depend on the model's equations:
 *  - reads the model from resources/flexfmu_model.bin (format: flexfmu/fmi/model_file.py, docs/fmu.md) on each
 *    fmi2Instantiate (instances share nothing);
 *  - holds the variables: parameters (structural ones fixed at build: their build value is accepted, another
 *    is refused naming the parameter, its build value and the rebuild command; runtime ones settable until
 *    fmi2ExitInitializationMode and range-checked there, String ones too), inputs (held from fmi2DoStep on: outputs
 *    read after new inputs are set are still those of the last step's inputs), outputs (each computed when first
 *    read after a step: a host that reads 3 of 25 outputs pays for 3; a validity flag per output.  An FMU state
 *    holds every output but the deferred ones, the model file's outputs.deferred (a costly search such as
 *    max_elastic_displacement), which it holds only if they were read);
 *  - refuses non-finite values and strings that are not UTF-8 when set, a currentCommunicationPoint that is not the
 *    FMU's clock, a state or output that is not finite or beyond the model's divergence limit (naming the input
 *    behind it, else "state"), each with one message through the front's log (fmi2Error, category
 *    logStatusError; a step a smaller one may take: fmi2Discard, logStatusDiscard); status-OK messages (what the
 *    model holds and chose) go out with category logAll;
 *  - FMU states hold everything: the variables' values, the held inputs, the outputs, the time, the start time,
 *    the clock, the kind's state vector and the kind's own saved state (the Python kind's simulator); serialised as
 *    the layout below (after the front's header);
 *  - model exchange (a kind with `derivatives`): the host sets the time, the continuous states (the kind's x) and
 *    the inputs (which then hold at once: the outputs and derivatives are those of the inputs as set), and reads
 *    the derivatives; the states have the value references after the model file's variables, their derivatives the
 *    next ones;
 *  - directional derivatives (a kind with `directional`): of outputs and state derivatives with respect to inputs
 *    and states, exact, at the current state and the inputs as last set (in co-simulation too, where the outputs
 *    read are still those of the held inputs: the derivatives are those of the output function a master solving
 *    the coupling needs).
 * No globals are written: everything is per instance, so instances in any number and on any threads (one call at a
 * time per instance, which the front ensures) are independent.
 */
#include <float.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "flexfmu_bridge.h"
#include "native_kind.h"

#define MODEL_FILE "flexfmu_model.bin"
/* the model file: magic, then u32 format version (flexfmu/fmi/native.py FORMAT_VERSION) */
static const char FILE_MAGIC[16] = {'f', 'l', 'e', 'x', 'f', 'm', 'u', '-', 'n', 'a', 't', 'i', 'v', 'e', '\n', '\0'};
#define FILE_VERSION 1u
/* the serialised FMU state's content (after the front's header) */
static const char STATE_MAGIC[8] = {'F', 'X', 'N', 'A', 'T', 'I', 'V', 'E'};
#define STATE_VERSION 3u

enum { REAL = 0, INTEGER = 1, BOOLEAN = 2, STRING = 3 };
enum { PARAMETER = 0, INPUT = 1, OUTPUT = 2 };
enum { LO_OPEN = 1, HI_OPEN = 2, IS_INTEGER = 4, HAS_SPECIAL = 8 };

static const char *const TYPE_NAMES[] = {"Real", "Integer", "Boolean", "String"};
static const char *const GET_NAMES[] = {"fmi2GetReal", "fmi2GetInteger", "fmi2GetBoolean", "fmi2GetString"};
static const char *const SET_NAMES[] = {"fmi2SetReal", "fmi2SetInteger", "fmi2SetBoolean", "fmi2SetString"};

/* ---- helpers for the kinds ---------------------------------------------------------------------- */

void native_repr(double v, char *text, size_t size) {
    if (isnan(v)) {
        snprintf(text, size, "nan");
        return;
    }
    if (isinf(v)) {
        snprintf(text, size, v > 0 ? "inf" : "-inf");
        return;
    }
    if (v == 0) {
        snprintf(text, size, signbit(v) ? "-0.0" : "0.0");
        return;
    }
    char buffer[64];
    for (int precision = 1; precision <= 17; precision++) { /* the shortest that reads back */
        snprintf(buffer, sizeof buffer, "%.*e", precision - 1, v);
        if (strtod(buffer, NULL) == v) break;
    }
    /* buffer: [-]d[<point>ddd]e(+|-)XX, the point as the locale writes it */
    char digits[40];
    int n = 0, negative = buffer[0] == '-';
    const char *p = buffer + negative;
    for (; *p && *p != 'e' && *p != 'E'; p++)
        if (*p >= '0' && *p <= '9' && n < 39) digits[n++] = *p;
    int exponent = *p ? atoi(p + 1) : 0;
    while (n > 1 && digits[n - 1] == '0') n--;
    digits[n] = '\0';
    int point = exponent + 1; /* value = 0.digits x 10^point */
    char out[96];
    size_t k = 0;
    if (negative) out[k++] = '-';
    if (point > -4 && point <= 16) { /* Python's repr: fixed notation */
        if (point <= 0) {
            out[k++] = '0';
            out[k++] = '.';
            for (int i = 0; i < -point; i++) out[k++] = '0';
            for (int i = 0; i < n; i++) out[k++] = digits[i];
        } else if (point >= n) {
            for (int i = 0; i < n; i++) out[k++] = digits[i];
            for (int i = n; i < point; i++) out[k++] = '0';
            out[k++] = '.';
            out[k++] = '0';
        } else {
            for (int i = 0; i < point; i++) out[k++] = digits[i];
            out[k++] = '.';
            for (int i = point; i < n; i++) out[k++] = digits[i];
        }
        out[k] = '\0';
    } else {
        out[k++] = digits[0];
        if (n > 1) {
            out[k++] = '.';
            for (int i = 1; i < n; i++) out[k++] = digits[i];
        }
        snprintf(out + k, sizeof out - k, "e%c%02d", exponent < 0 ? '-' : '+', abs(exponent));
    }
    snprintf(text, size, "%s", out);
}

int native_refuse(NativeResult *result, int status, const char *format, ...) {
    va_list args;
    va_start(args, format);
    vsnprintf(result->message, sizeof result->message, format, args);
    va_end(args);
    result->status = status;
    return status;
}

void native_note(NativeResult *result, const char *format, ...) {
    if (!result->note) return;
    char text[2048];
    va_list args;
    va_start(args, format);
    vsnprintf(text, sizeof text, format, args);
    va_end(args);
    result->note(result->note_context, text);
}

/* ---- the model file -------------------------------------------------------------------------------- */

struct NativeFile {
    size_t n;
    NativeEntry *entries;
};

static void free_file(NativeFile *file) {
    if (!file) return;
    for (size_t i = 0; i < file->n; i++) {
        NativeEntry *e = &file->entries[i];
        if (e->type == NATIVE_STR && e->data)
            for (size_t j = 0; j < e->count; j++) free(((char **)e->data)[j]);
        free(e->data);
        free(e->name);
    }
    free(file->entries);
    free(file);
}

typedef struct {
    const unsigned char *at, *end;
} Reader;

static int take(Reader *r, size_t n, const unsigned char **bytes) {
    if ((size_t)(r->end - r->at) < n) return -1;
    *bytes = r->at;
    r->at += n;
    return 0;
}

static uint32_t le32(const unsigned char *b) {
    return (uint32_t)b[0] | (uint32_t)b[1] << 8 | (uint32_t)b[2] << 16 | (uint32_t)b[3] << 24;
}

static uint64_t le64(const unsigned char *b) { return (uint64_t)le32(b) | (uint64_t)le32(b + 4) << 32; }

static double f64_of(const unsigned char *b) {
    uint64_t bits = le64(b);
    double value;
    memcpy(&value, &bits, sizeof value);
    return value;
}

static void put32(unsigned char *b, uint32_t v) {
    for (int i = 0; i < 4; i++) b[i] = (unsigned char)(v >> (8 * i));
}

static void put_f64(unsigned char *b, double value) {
    uint64_t bits;
    memcpy(&bits, &value, sizeof bits);
    for (int i = 0; i < 8; i++) b[i] = (unsigned char)(bits >> (8 * i));
}

/* Parse the bytes of a model file; NULL with why. */
static NativeFile *parse_file(const unsigned char *bytes, size_t size, const char *path, char *why, size_t why_size) {
    Reader r = {bytes, bytes + size};
    const unsigned char *b;
    if (take(&r, 16, &b) < 0 || memcmp(b, FILE_MAGIC, 16) != 0) {
        snprintf(why, why_size, "%s is not a flexfmu native model file (bad magic)", path);
        return NULL;
    }
    if (take(&r, 8, &b) < 0) {
        snprintf(why, why_size, "%s is truncated (no header)", path);
        return NULL;
    }
    uint32_t version = le32(b), n = le32(b + 4);
    if (version != FILE_VERSION) {
        snprintf(why, why_size,
                 "%s has model-file format version %u, but this FMU's runtime reads version %u: its binary and its "
                 "resources come from different flexfmu builds; rebuild the FMU (flexfmu build --runtime native, "
                 "flexfmu export ... --runtime native)",
                 path, (unsigned)version, FILE_VERSION);
        return NULL;
    }
    NativeFile *file = calloc(1, sizeof *file);
    if (!file || n > 100000 || !(file->entries = calloc(n ? n : 1, sizeof *file->entries))) {
        free(file);
        snprintf(why, why_size, "%s: out of memory or too many entries (%u)", path, (unsigned)n);
        return NULL;
    }
    for (uint32_t i = 0; i < n; i++) {
        NativeEntry *e = &file->entries[i];
        file->n = i + 1;
        if (take(&r, 2, &b) < 0) goto truncated;
        size_t name_length = (size_t)b[0] | (size_t)b[1] << 8;
        if (take(&r, name_length, &b) < 0 || !(e->name = malloc(name_length + 1))) goto truncated;
        memcpy(e->name, b, name_length);
        e->name[name_length] = '\0';
        if (take(&r, 2, &b) < 0) goto truncated;
        e->type = b[0];
        e->ndim = b[1];
        if (e->ndim > NATIVE_MAX_DIMS || e->type < NATIVE_F64 || e->type > NATIVE_STR) {
            snprintf(why, why_size, "%s: entry %s has an unknown type %d or %d dimensions", path, e->name, e->type,
                     e->ndim);
            goto fail;
        }
        e->count = 1;
        for (int d = 0; d < e->ndim; d++) {
            if (take(&r, 4, &b) < 0) goto truncated;
            e->shape[d] = le32(b);
            if (e->shape[d] && e->count > ((size_t)1 << 31) / e->shape[d]) {
                snprintf(why, why_size, "%s: entry %s is too large", path, e->name);
                goto fail;
            }
            e->count *= e->shape[d];
        }
        if (e->type == NATIVE_F64) {
            if ((size_t)(r.end - r.at) / 8 < e->count || !(e->data = malloc(8 * (e->count ? e->count : 1))))
                goto truncated;
            double *out = e->data;
            for (size_t j = 0; j < e->count; j++, r.at += 8) out[j] = f64_of(r.at);
        } else if (e->type == NATIVE_I32) {
            if ((size_t)(r.end - r.at) / 4 < e->count || !(e->data = malloc(4 * (e->count ? e->count : 1))))
                goto truncated;
            int32_t *out = e->data;
            for (size_t j = 0; j < e->count; j++, r.at += 4) out[j] = (int32_t)le32(r.at);
        } else {
            char **out = calloc(e->count ? e->count : 1, sizeof *out);
            if (!(e->data = out)) goto truncated;
            for (size_t j = 0; j < e->count; j++) {
                if (take(&r, 4, &b) < 0) goto truncated;
                size_t length = le32(b);
                if (take(&r, length, &b) < 0 || !(out[j] = malloc(length + 1))) goto truncated;
                memcpy(out[j], b, length);
                out[j][length] = '\0';
            }
        }
    }
    if (r.at != r.end) {
        snprintf(why, why_size, "%s: %zu bytes after the last entry (damaged?)", path, (size_t)(r.end - r.at));
        goto fail;
    }
    return file;
truncated:
    snprintf(why, why_size, "%s is truncated or damaged (entry %zu), or memory ran out", path, file->n);
fail:
    free_file(file);
    return NULL;
}

static NativeFile *read_file(const char *path, char *why, size_t why_size) {
    FILE *f = fopen(path, "rb");
    if (!f) {
        snprintf(why, why_size, "cannot open the model file %s (a damaged FMU?)", path);
        return NULL;
    }
    unsigned char *bytes = NULL;
    size_t size = 0, capacity = 0;
    for (;;) {
        if (size == capacity) {
            capacity = capacity ? 2 * capacity : 1 << 16;
            unsigned char *grown = realloc(bytes, capacity);
            if (!grown) {
                free(bytes);
                fclose(f);
                snprintf(why, why_size, "out of memory reading %s", path);
                return NULL;
            }
            bytes = grown;
        }
        size_t got = fread(bytes + size, 1, capacity - size, f);
        size += got;
        if (got == 0) break;
    }
    fclose(f);
    NativeFile *file = parse_file(bytes, size, path, why, why_size);
    free(bytes);
    return file;
}

const NativeEntry *native_entry(const NativeFile *file, const char *name) {
    for (size_t i = 0; i < file->n; i++)
        if (strcmp(file->entries[i].name, name) == 0) return &file->entries[i];
    return NULL;
}

static int typed(const NativeFile *file, const char *name, int type, int ndim, const long *shape, const void **data,
                 uint32_t *found, char *why, size_t why_size) {
    static const char *const names[] = {"", "float64", "int32", "string"};
    const NativeEntry *e = native_entry(file, name);
    if (!e) {
        snprintf(why, why_size, "the model file has no entry %s", name);
        return -1;
    }
    int ok = e->type == type && e->ndim == ndim;
    for (int d = 0; ok && d < ndim; d++) ok = !shape || shape[d] < 0 || (long)e->shape[d] == shape[d];
    if (!ok) {
        char expected[160] = "", got[160] = "";
        for (int d = 0; d < ndim; d++) {
            size_t used = strlen(expected);
            if (shape && shape[d] >= 0)
                snprintf(expected + used, sizeof expected - used, "%s%ld", d ? ", " : "", shape[d]);
            else
                snprintf(expected + used, sizeof expected - used, "%s*", d ? ", " : "");
        }
        for (int d = 0; d < e->ndim; d++) {
            size_t used = strlen(got);
            snprintf(got + used, sizeof got - used, "%s%u", d ? ", " : "", (unsigned)e->shape[d]);
        }
        snprintf(why, why_size, "model file entry %s is %s (%s), expected %s (%s)", name, names[e->type], got,
                 names[type], expected);
        return -1;
    }
    if (found) memcpy(found, e->shape, sizeof e->shape);
    *data = e->data;
    return 0;
}

int native_f64(const NativeFile *file, const char *name, int ndim, const long *shape, const double **data,
               uint32_t *found, char *why, size_t why_size) {
    return typed(file, name, NATIVE_F64, ndim, shape, (const void **)data, found, why, why_size);
}

int native_i32(const NativeFile *file, const char *name, int ndim, const long *shape, const int32_t **data,
               uint32_t *found, char *why, size_t why_size) {
    return typed(file, name, NATIVE_I32, ndim, shape, (const void **)data, found, why, why_size);
}

static const char *file_string(const NativeFile *file, const char *name, char *why, size_t why_size) {
    const void *data;
    if (typed(file, name, NATIVE_STR, 0, NULL, &data, NULL, why, why_size) < 0) return NULL;
    return ((char *const *)data)[0];
}

static char *const *file_strings(const NativeFile *file, const char *name, long n, char *why, size_t why_size) {
    const void *data;
    if (typed(file, name, NATIVE_STR, 1, &n, &data, NULL, why, why_size) < 0) return NULL;
    return (char *const *)data;
}

/* ---- the model: variables and parameter checks (read-only after instantiate) ---------------------- */

typedef struct {
    const char *name;
    int type, causality;
    int index;        /* input / output / runtime-parameter index; -1: a parameter fixed at build */
    double start;     /* start (build) value of a Real, Integer or Boolean variable */
    const char *text; /* start (build) value of a String */
} Variable;

typedef struct {
    double lo, hi, special, replacement;
    int flags;
    const char *allowed;
    int vr;
} ParameterRule;

typedef struct {
    NativeFile *file;
    const NativeKind *kind;
    void *model; /* the kind's */
    NativeLayout layout;
    const char *guid, *name, *rebuild, *divergence_allowed;
    char *resources; /* the FMU's resources folder (the kinds may read more files there) */
    size_t n_vars, nx, n_messages, n_rebuild;
    char *const *rebuild_names, *const *rebuild_values; /* the other fixed settings of the rebuild command */
    Variable *vars;
    ParameterRule *rules; /* per runtime parameter */
    const char **input_names, **output_names, **param_names;
    int *input_vr, *output_vr;
    unsigned char *deferred; /* per output: computed only when read (outputs.deferred) */
    double divergence_limit;
    char *const *messages;
    const double *nominals; /* per continuous state: its typical size (the model file's state.nominal), or NULL: 1 */
    BridgeArrays arrays;    /* FMI 3.0 array variables and structural parameters (the model file's fmi3.*) */
    BridgeArray *array_list;
    BridgeSize *size_list;
} Model;

/* What an FMU state holds; also the instance's own current values.  valid[i]:
   outputs[i] is that of x with held (computed since the last step). */
typedef struct {
    int initialised;
    unsigned char *valid; /* per output */
    double time, start_time;
    double clock;         /* the host's time of the next step's start */
    double *values;       /* per variable: parameters' and inputs' values (outputs, strings: 0) */
    char **texts;         /* per variable: a String parameter's value if it is settable (owned), else NULL */
    size_t n_texts;       /* n_vars */
    unsigned char *saved; /* the kind's own state (NativeKind.save; owned) in an FMU state, else NULL */
    size_t saved_size;
    double *held; /* the inputs the kind got at the last step (or initialisation) */
    double *outputs;
    double *x;
} Snapshot;

typedef struct {
    Model m;
    Snapshot now;
    void *sim;                /* the kind's simulator; NULL before fmi2ExitInitializationMode */
    double *params;           /* the runtime parameters as the simulator got them (special values replaced) */
    const char **param_texts; /* and the String ones' values */
    double *scratch_x, *scratch_y;
    unsigned char *scratch_which; /* per output: asked of the kind, then written by it */
    int me;                       /* model exchange: the host integrates x; inputs hold as they are set */
    double *scratch_dx, *scratch_du, *scratch_dy, *scratch_ddx, *scratch_in;
    double *state_held; /* the inputs the current state's step held (at initialisation: those held then; after a
                             restore: the state's); a refused step leaves it (NativeKind.step_held) */
    BridgeLog *log;
    void *context;
} Slave;

static void free_model(Model *m) {
    if (m->model && m->kind) m->kind->free_model(m->model);
    free(m->vars);
    free(m->rules);
    free(m->input_names);
    free(m->output_names);
    free(m->param_names);
    free(m->input_vr);
    free(m->output_vr);
    free(m->deferred);
    free(m->array_list);
    free(m->size_list);
    free(m->resources);
    free_file(m->file);
    memset(m, 0, sizeof *m);
}

/* FMI 3.0 array variables and structural parameters (optional: none when absent; flexfmu.fmi.fmi3_arrays writes
   them): each array a view of the runtime's own Real values (a variable, continuous state or state derivative) or of
   constants, its value reference above all of the runtime's and below INT32_MAX (the FMI 3.0 front's `time`). */
static int load_arrays(Model *m, char *why, size_t why_size) {
    NativeFile *f = m->file;
    m->arrays.lowest = UINT32_MAX;
    const unsigned int own = (unsigned int)(m->n_vars + 2 * (m->kind->derivatives ? m->nx : 0));
    const NativeEntry *names_entry = native_entry(f, "fmi3.array.name"),
                      *sizes_entry = native_entry(f, "fmi3.size.name");
    long na = names_entry ? (long)names_entry->count : 0, ns = sizes_entry ? (long)sizes_entry->count : 0;
    char *const *names = NULL, *const *size_names = NULL, *const *fixed = NULL;
    const int32_t *reference = NULL, *size = NULL, *input = NULL, *element = NULL, *size_reference = NULL,
                  *size_value = NULL;
    const double *value = NULL;
    uint32_t total[NATIVE_MAX_DIMS] = {0};
    if (na
        && (!(names = file_strings(f, "fmi3.array.name", na, why, why_size))
            || native_i32(f, "fmi3.array.reference", 1, &na, &reference, NULL, why, why_size) < 0
            || native_i32(f, "fmi3.array.size", 1, &na, &size, NULL, why, why_size) < 0
            || native_i32(f, "fmi3.array.input", 1, &na, &input, NULL, why, why_size) < 0
            || native_i32(f, "fmi3.array.element", 1, NULL, &element, total, why, why_size) < 0))
        return -1;
    long n_elements = (long)total[0];
    if (na && native_f64(f, "fmi3.array.value", 1, &n_elements, &value, NULL, why, why_size) < 0) return -1;
    if (ns
        && (!(size_names = file_strings(f, "fmi3.size.name", ns, why, why_size))
            || !(fixed = file_strings(f, "fmi3.size.fixed", ns, why, why_size))
            || native_i32(f, "fmi3.size.reference", 1, &ns, &size_reference, NULL, why, why_size) < 0
            || native_i32(f, "fmi3.size.value", 1, &ns, &size_value, NULL, why, why_size) < 0))
        return -1;
    if (!(m->array_list = calloc((size_t)na + 1, sizeof *m->array_list))
        || !(m->size_list = calloc((size_t)ns + 1, sizeof *m->size_list))) {
        snprintf(why, why_size, "out of memory");
        return -1;
    }
    long at = 0;
    for (long k = 0; k < na + ns; k++) { /* the references: in the block of their own, each once */
        int32_t vr = k < na ? reference[k] : size_reference[k - na];
        const char *name = k < na ? names[k] : size_names[k - na];
        if (vr < 0 || (unsigned int)vr < own || vr == INT32_MAX) {
            snprintf(why, why_size,
                     "model file: FMI 3.0 variable %s has value reference %d (allowed: %u .. %d, above the "
                     "runtime's own)",
                     name, (int)vr, own, INT32_MAX - 1);
            return -1;
        }
        for (long j = 0; j < k; j++)
            if ((j < na ? reference[j] : size_reference[j - na]) == vr) {
                snprintf(why, why_size, "model file: FMI 3.0 variables %s and %s have one value reference %d",
                         j < na ? names[j] : size_names[j - na], name, (int)vr);
                return -1;
            }
        if ((unsigned int)vr < m->arrays.lowest) m->arrays.lowest = (unsigned int)vr;
    }
    for (long k = 0; k < na; k++) {
        if (size[k] < 1 || size[k] > n_elements - at) {
            snprintf(why, why_size, "model file: FMI 3.0 array %s has a bad size %d", names[k], (int)size[k]);
            return -1;
        }
        for (long e = at; e < at + size[k]; e++) {
            int32_t vr = element[e];
            int readable
                = vr == -1 ? isfinite(value[e])
                           : vr >= 0 && (unsigned int)vr < own && ((size_t)vr >= m->n_vars || m->vars[vr].type == REAL);
            if (!readable || (input[k] && (vr < 0 || (size_t)vr >= m->n_vars || m->vars[vr].causality != INPUT))) {
                snprintf(why, why_size, "model file: element %ld of FMI 3.0 array %s is %d (allowed: %s)", e - at,
                         names[k], (int)vr,
                         input[k] ? "a Real input's value reference"
                                  : "-1 (a finite constant) or a Real value's value reference");
                return -1;
            }
        }
        m->array_list[k] = (BridgeArray){
            (unsigned int)reference[k], names[k], (size_t)size[k], element + at, value + at, input[k] != 0};
        at += size[k];
    }
    if (at != n_elements) {
        snprintf(why, why_size, "model file: fmi3.array.element has %ld elements, the arrays %ld", n_elements, at);
        return -1;
    }
    for (long k = 0; k < ns; k++) {
        if (size_value[k] < 0) {
            snprintf(why, why_size, "model file: FMI 3.0 structural parameter %s is %d (allowed: >= 0)", size_names[k],
                     (int)size_value[k]);
            return -1;
        }
        m->size_list[k]
            = (BridgeSize){(unsigned int)size_reference[k], size_names[k], (uint64_t)size_value[k], fixed[k]};
    }
    m->arrays = (BridgeArrays){(size_t)na, (size_t)ns, m->array_list, m->size_list, m->arrays.lowest};
    return 0;
}

static int load_model(Model *m, const char *resources, const char *guid, char *why, size_t why_size) {
    char path[4200];
    snprintf(path, sizeof path, "%s/%s", resources, MODEL_FILE);
    if (!(m->file = read_file(path, why, why_size))) return -1;
    NativeFile *f = m->file;
    const char *kind = file_string(f, "kind", why, why_size);
    if (!kind || !(m->guid = file_string(f, "guid", why, why_size))
        || !(m->name = file_string(f, "model", why, why_size))
        || !(m->rebuild = file_string(f, "rebuild", why, why_size))
        || !(m->divergence_allowed = file_string(f, "divergence_allowed", why, why_size)))
        return -1;
    if (strcmp(guid, m->guid) != 0) {
        snprintf(why, why_size,
                 "fmuGUID '%s' is not this FMU's ('%s'): the host read another modelDescription.xml "
                 "than this binary's",
                 guid, m->guid);
        return -1;
    }
    for (size_t k = 0; k < native_kind_count; k++)
        if (strcmp(native_kinds[k]->name, kind) == 0) m->kind = native_kinds[k];
    if (!m->kind) {
        snprintf(why, why_size,
                 "the model is of kind '%s', which this runtime does not have (rebuild the FMU with "
                 "the flexfmu that wrote it)",
                 kind);
        return -1;
    }
    const void *names_data;
    uint32_t shape[NATIVE_MAX_DIMS];
    if (typed(f, "var.name", NATIVE_STR, 1, NULL, &names_data, shape, why, why_size) < 0) return -1;
    long n = (long)shape[0];
    char *const *names = (char *const *)names_data;
    const int32_t *type, *causality, *index;
    const double *start, *limit;
    char *const *texts;
    if (native_i32(f, "var.type", 1, &n, &type, NULL, why, why_size) < 0
        || native_i32(f, "var.causality", 1, &n, &causality, NULL, why, why_size) < 0
        || native_i32(f, "var.index", 1, &n, &index, NULL, why, why_size) < 0
        || native_f64(f, "var.start", 1, &n, &start, NULL, why, why_size) < 0
        || !(texts = file_strings(f, "var.start_string", n, why, why_size))
        || native_f64(f, "divergence_limit", 0, NULL, &limit, NULL, why, why_size) < 0)
        return -1;
    m->divergence_limit = *limit;
    m->n_vars = (size_t)n;
    if (!(m->vars = calloc(m->n_vars ? m->n_vars : 1, sizeof *m->vars))) goto memory;
    size_t counts[3] = {0, 0, 0};
    for (size_t i = 0; i < m->n_vars; i++) {
        Variable *v = &m->vars[i];
        *v = (Variable){names[i], type[i], causality[i], index[i], start[i], texts[i]};
        if (v->type < REAL || v->type > STRING || v->causality < PARAMETER || v->causality > OUTPUT
            || (v->causality != PARAMETER && v->type == STRING) || ((v->causality != PARAMETER) && v->type != REAL)) {
            snprintf(why, why_size, "model file: variable %s has an unsupported type or causality", v->name);
            return -1;
        }
        if (v->causality != PARAMETER || v->index >= 0) counts[v->causality]++;
    }
    m->layout.n_params = counts[PARAMETER];
    m->layout.n_inputs = counts[INPUT];
    m->layout.n_outputs = counts[OUTPUT];
    m->input_names = calloc(counts[INPUT] + 1, sizeof *m->input_names);
    m->output_names = calloc(counts[OUTPUT] + 1, sizeof *m->output_names);
    m->param_names = calloc(counts[PARAMETER] + 1, sizeof *m->param_names);
    m->input_vr = calloc(counts[INPUT] + 1, sizeof *m->input_vr);
    m->output_vr = calloc(counts[OUTPUT] + 1, sizeof *m->output_vr);
    m->rules = calloc(counts[PARAMETER] + 1, sizeof *m->rules);
    m->deferred = calloc(counts[OUTPUT] + 1, 1);
    if (!m->input_names || !m->output_names || !m->param_names || !m->input_vr || !m->output_vr || !m->rules
        || !m->deferred)
        goto memory;
    for (size_t i = 0; i < m->n_vars; i++) { /* every index used exactly once */
        Variable *v = &m->vars[i];
        if (v->causality == PARAMETER && v->index < 0) continue;
        const char **slot = v->causality == INPUT    ? m->input_names
                            : v->causality == OUTPUT ? m->output_names
                                                     : m->param_names;
        if ((size_t)v->index >= counts[v->causality] || slot[v->index]) {
            snprintf(why, why_size, "model file: variable %s has a bad index %d", v->name, v->index);
            return -1;
        }
        slot[v->index] = v->name;
        if (v->causality == INPUT) m->input_vr[v->index] = (int)i;
        if (v->causality == OUTPUT) m->output_vr[v->index] = (int)i;
        if (v->causality == PARAMETER) m->rules[v->index].vr = (int)i;
    }
    long np = (long)counts[PARAMETER];
    const double *lo, *hi, *special, *replacement;
    const int32_t *flags;
    char *const *allowed;
    if (native_f64(f, "param.lo", 1, &np, &lo, NULL, why, why_size) < 0
        || native_f64(f, "param.hi", 1, &np, &hi, NULL, why, why_size) < 0
        || native_f64(f, "param.special", 1, &np, &special, NULL, why, why_size) < 0
        || native_f64(f, "param.replacement", 1, &np, &replacement, NULL, why, why_size) < 0
        || native_i32(f, "param.flags", 1, &np, &flags, NULL, why, why_size) < 0
        || !(allowed = file_strings(f, "param.allowed", np, why, why_size)))
        return -1;
    for (long k = 0; k < np; k++) {
        ParameterRule *r = &m->rules[k];
        r->lo = lo[k], r->hi = hi[k], r->special = special[k], r->replacement = replacement[k];
        r->flags = flags[k], r->allowed = allowed[k];
    }
    const NativeEntry *names_entry = native_entry(f, "rebuild.names");
    if (names_entry && names_entry->type == NATIVE_STR && names_entry->ndim == 1) {
        m->n_rebuild = names_entry->count;
        m->rebuild_names = names_entry->data;
        if (!(m->rebuild_values = file_strings(f, "rebuild.values", (long)m->n_rebuild, why, why_size))) return -1;
    }
    const NativeEntry *messages = native_entry(f, "messages");
    if (messages && messages->type == NATIVE_STR && messages->ndim == 1) {
        m->messages = messages->data;
        m->n_messages = messages->count;
    }
    if (native_entry(f, "outputs.deferred")) { /* the outputs computed only when read (none if absent) */
        const int32_t *deferred;
        uint32_t nd[1];
        if (native_i32(f, "outputs.deferred", 1, NULL, &deferred, nd, why, why_size) < 0) return -1;
        for (uint32_t k = 0; k < nd[0]; k++) {
            if (deferred[k] < 0 || (size_t)deferred[k] >= counts[OUTPUT] || m->deferred[deferred[k]]) {
                snprintf(why, why_size, "model file: outputs.deferred has a bad output index %d", (int)deferred[k]);
                return -1;
            }
            m->deferred[deferred[k]] = 1;
        }
        m->layout.n_deferred = nd[0];
    }
    if (!(m->resources = malloc(strlen(resources) + 1))) goto memory;
    strcpy(m->resources, resources);
    m->layout.resources = m->resources;
    m->layout.deferred = m->deferred;
    m->layout.input_names = m->input_names;
    m->layout.output_names = m->output_names;
    m->layout.param_names = m->param_names;
    if (!(m->model = m->kind->load(f, &m->layout, why, why_size))) return -1;
    m->nx = m->kind->state_size(m->model);
    if (native_entry(f, "state.nominal")) { /* optional: the continuous states' typical sizes (model exchange) */
        long shape[1] = {(long)m->nx};
        if (native_f64(f, "state.nominal", 1, shape, &m->nominals, NULL, why, why_size) < 0) return -1;
        for (size_t i = 0; i < m->nx; i++)
            if (!(isfinite(m->nominals[i]) && m->nominals[i] > 0)) {
                snprintf(why, why_size, "model file: state.nominal[%zu] is not a finite number > 0", i);
                return -1;
            }
    }
    return load_arrays(m, why, why_size);
memory:
    snprintf(why, why_size, "out of memory");
    return -1;
}

/* ---- snapshots ------------------------------------------------------------------------------------ */

/* A settable String parameter: its value lives in the snapshot's texts. */
static int settable_text(const Variable *v) { return v->type == STRING && v->causality == PARAMETER && v->index >= 0; }

static char *copy_text(const char *text) {
    char *copy = malloc(strlen(text) + 1);
    if (copy) strcpy(copy, text);
    return copy;
}

static int snapshot_alloc(const Model *m, Snapshot *s) {
    memset(s, 0, sizeof *s);
    s->values = calloc(m->n_vars + 1, sizeof *s->values);
    s->texts = calloc(m->n_vars + 1, sizeof *s->texts);
    s->n_texts = m->n_vars;
    s->held = calloc(m->layout.n_inputs + 1, sizeof *s->held);
    s->outputs = calloc(m->layout.n_outputs + 1, sizeof *s->outputs);
    s->x = calloc(m->nx + 1, sizeof *s->x);
    s->valid = calloc(m->layout.n_outputs + 1, 1);
    return s->values && s->texts && s->held && s->outputs && s->x && s->valid ? 0 : -1;
}

static void free_texts(Snapshot *s) {
    for (size_t i = 0; s->texts && i < s->n_texts; i++) free(s->texts[i]), s->texts[i] = NULL;
}

static void snapshot_free(Snapshot *s) {
    free_texts(s);
    free(s->texts);
    free(s->saved);
    free(s->values);
    free(s->held);
    free(s->outputs);
    free(s->x);
    free(s->valid);
    memset(s, 0, sizeof *s);
}

/* Everything but the kind's saved state; -1 when out of memory (`to` then holds no texts). */
static int snapshot_copy(const Model *m, Snapshot *to, const Snapshot *from) {
    free_texts(to);
    for (size_t i = 0; i < m->n_vars; i++)
        if (from->texts[i] && !(to->texts[i] = copy_text(from->texts[i]))) return -1;
    to->initialised = from->initialised;
    memcpy(to->valid, from->valid, m->layout.n_outputs);
    to->time = from->time;
    to->start_time = from->start_time;
    to->clock = from->clock;
    memcpy(to->values, from->values, m->n_vars * sizeof *to->values);
    memcpy(to->held, from->held, m->layout.n_inputs * sizeof *to->held);
    memcpy(to->outputs, from->outputs, m->layout.n_outputs * sizeof *to->outputs);
    memcpy(to->x, from->x, m->nx * sizeof *to->x);
    return 0;
}

/* The state after fmi2Instantiate / fmi2Reset: start values, no simulator; -1 when out of memory. */
static int clear(Slave *s) {
    const Model *m = &s->m;
    Snapshot *now = &s->now;
    free_texts(now);
    for (size_t i = 0; i < m->n_vars; i++) {
        now->values[i] = m->vars[i].type == STRING || m->vars[i].causality == OUTPUT ? 0.0 : m->vars[i].start;
        if (settable_text(&m->vars[i]) && !(now->texts[i] = copy_text(m->vars[i].text))) return -1;
    }
    memset(now->held, 0, m->layout.n_inputs * sizeof *now->held);
    memset(now->outputs, 0, m->layout.n_outputs * sizeof *now->outputs);
    memset(now->x, 0, m->nx * sizeof *now->x);
    memset(now->valid, 0, m->layout.n_outputs);
    now->initialised = 0;
    now->time = now->start_time = now->clock = 0.0;
    if (s->sim) m->kind->free_sim(s->sim);
    s->sim = NULL;
    return 0;
}

/* ---- messages ------------------------------------------------------------------------------------- */

static int refuse(Slave *s, int status, const char *format, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

static int refuse(Slave *s, int status, const char *format, ...) {
    char text[4096];
    va_list args;
    va_start(args, format);
    vsnprintf(text, sizeof text, format, args);
    va_end(args);
    s->log(s->context, status, status == BRIDGE_DISCARD ? "logStatusDiscard" : "logStatusError", text);
    return status;
}

static void note(void *context, const char *text) {
    Slave *s = context;
    s->log(s->context, BRIDGE_OK, "logAll", text);
}

static NativeResult new_result(Slave *s) {
    NativeResult r;
    r.status = BRIDGE_OK;
    r.message[0] = '\0'; /* not the whole buffer: this runs at every step and read */
    r.note = note;
    r.note_context = s;
    return r;
}

/* ---- parameters --------------------------------------------------------------------------------- */

/* The runtime parameters of `values` checked (ranges, in their order) into `params` (special values replaced)
   and, for String ones, `texts` into s->param_texts, or a refusal naming the first one out of range. */
static int check_parameters(Slave *s, const double *values, char *const *texts, double *params) {
    const Model *m = &s->m;
    for (size_t k = 0; k < m->layout.n_params; k++) {
        const ParameterRule *r = &m->rules[k];
        const Variable *v = &m->vars[r->vr];
        double value = values[r->vr];
        params[k] = value;
        s->param_texts[k] = v->type == STRING ? texts[r->vr] : NULL;
        if (v->type == BOOLEAN || v->type == STRING) continue;
        if ((r->flags & HAS_SPECIAL) && value == r->special) {
            params[k] = r->replacement;
            continue;
        }
        int ok = isfinite(value) && ((r->flags & LO_OPEN) ? value > r->lo : value >= r->lo)
                 && ((r->flags & HI_OPEN) ? value < r->hi : value <= r->hi);
        if (!ok) {
            char shown[64];
            if (v->type == INTEGER)
                snprintf(shown, sizeof shown, "%d", (int)value);
            else
                native_repr(value, shown, sizeof shown);
            return refuse(s, BRIDGE_ERROR, "%s: got %s (allowed: %s)", v->name, shown, r->allowed);
        }
    }
    return BRIDGE_OK;
}

/* A simulator of the parameters in `values` and `texts` (checked), its state in x; NULL after logging why. */
static void *make_sim(Slave *s, const double *values, char *const *texts, double *x) {
    if (check_parameters(s, values, texts, s->params) != BRIDGE_OK) return NULL;
    NativeResult r = new_result(s);
    void *sim = s->m.kind->init(s->m.model, s->params, s->param_texts, x, &r);
    if (!sim)
        refuse(s, r.status >= BRIDGE_DISCARD ? r.status : BRIDGE_ERROR, "%s",
               r.message[0] ? r.message : "the model cannot be set up (out of memory?)");
    return sim;
}

/* ---- outputs and validity ------------------------------------------------------------------------- */

static void time_text(double t, char *text, size_t size) { native_repr(t, text, size); }

static void bad_outputs(const Slave *s, const double *y, const unsigned char *which, char *names, size_t size) {
    names[0] = '\0';
    int shown = 0;
    for (size_t i = 0; i < s->m.layout.n_outputs; i++) {
        if (!which[i] || isfinite(y[i])) continue;
        size_t used = strlen(names);
        if (shown++ < 4) snprintf(names + used, size - used, "%s%s", used ? ", " : "", s->m.output_names[i]);
    }
    if (shown > 4) {
        size_t used = strlen(names);
        snprintf(names + used, size - used, " and %d more", shown - 4);
    }
}

/* The culprit j a kind named (NativeKind.culprit): an input's or a runtime parameter's name, value and what is
   allowed of it; 0 when j names none. */
static int culprit_of(const Slave *s, int j, const char **name, double *value, const char **allowed) {
    const Model *m = &s->m;
    if (j >= 0 && (size_t)j < m->layout.n_inputs) {
        *name = m->input_names[j], *value = s->now.held[j], *allowed = "inputs within the model's range";
        return 1;
    }
    if (j >= 0 && (size_t)j - m->layout.n_inputs < m->layout.n_params) {
        size_t k = (size_t)j - m->layout.n_inputs;
        *name = m->param_names[k], *value = s->params[k], *allowed = "parameters within the model's range";
        return 1;
    }
    return 0;
}

/* One computation by the kind of the outputs `which` marks into y (which then marks what it wrote; a refusal when
   one of them is not finite). */
static int compute_outputs(Slave *s, double *y, unsigned char *which) {
    Snapshot *now = &s->now;
    const Model *m = &s->m;
    NativeResult r = new_result(s);
    int status = m->kind->outputs(s->sim, now->x, now->held, y, which, &r);
    if (status == BRIDGE_OK) {
        for (size_t i = 0; i < m->layout.n_outputs; i++)
            if (which[i] && !isfinite(y[i])) status = NATIVE_NOT_FINITE;
    }
    if (status == NATIVE_NOT_FINITE) {
        char names[512], t[64];
        bad_outputs(s, y, which, names, sizeof names);
        const char *name, *allowed;
        double value;
        if (culprit_of(s, m->kind->culprit(s->sim, 1, now->x, now->held, 1e300), &name, &value, &allowed))
            return refuse(s, BRIDGE_ERROR,
                          "outputs: %s: %.6g makes %s overflow (not finite) at t = %.6g s; allowed: %s", name, value,
                          names, now->start_time + now->time, allowed);
        time_text(now->start_time + now->time, t, sizeof t);
        return refuse(s, BRIDGE_ERROR,
                      "%s: not finite at t = %s s (the inputs or parameters drive the model beyond "
                      "its range)",
                      names, t);
    }
    if (status != BRIDGE_OK) return refuse(s, status, "outputs: %s", r.message);
    return BRIDGE_OK;
}

/* Make valid the outputs s->scratch_which marks (the caller fills it, with outputs not valid yet only): computed
   from the current state and held inputs (a refusal when one is not finite). */
static int read_outputs(Slave *s) {
    Snapshot *now = &s->now;
    const Model *m = &s->m;
    unsigned char *which = s->scratch_which;
    if (!s->sim) return BRIDGE_OK; /* before initialisation: the start values */
    double *y = s->scratch_y;      /* the kind writes what it computes here; kept only if all of it is finite */
    int status = compute_outputs(s, y, which);
    if (status != BRIDGE_OK) return status;
    for (size_t i = 0; i < m->layout.n_outputs; i++)
        if (which[i]) now->outputs[i] = y[i], now->valid[i] = 1;
    return BRIDGE_OK;
}

/* read_outputs of every output (with_deferred 1) or of every output but the deferred ones (0) not valid yet. */
static int read_all_outputs(Slave *s, int with_deferred) {
    int any = 0;
    for (size_t i = 0; i < s->m.layout.n_outputs; i++) {
        s->scratch_which[i] = (with_deferred || !s->m.deferred[i]) && !s->now.valid[i];
        any |= s->scratch_which[i];
    }
    return any ? read_outputs(s) : BRIDGE_OK;
}

/* ---- BridgeApi ------------------------------------------------------------------------------------- */

static int start(const BridgeSettings *settings, char *error, size_t error_size) {
    for (size_t k = 0; k < native_kind_count; k++) /* the Python kind: its interpreter; the others: nothing */
        if (native_kinds[k]->start && native_kinds[k]->start(settings, error, error_size) < 0) return -1;
    return 0;
}

static void free_slave(Slave *s) {
    if (!s) return;
    if (s->sim) s->m.kind->free_sim(s->sim);
    snapshot_free(&s->now);
    free(s->params);
    free(s->param_texts);
    free(s->scratch_x);
    free(s->scratch_y);
    free(s->scratch_which);
    free(s->state_held);
    free(s->scratch_dx);
    free(s->scratch_du);
    free(s->scratch_dy);
    free(s->scratch_ddx);
    free(s->scratch_in);
    free_model(&s->m);
    free(s);
}

static void *instantiate(const char *resources_dir, const char *instance_name, const char *guid, int visible,
                         BridgeLog *log, void *context) {
    (void)instance_name, (void)visible;
    Slave *s = calloc(1, sizeof *s);
    char why[3072] = "";
    if (!s) {
        log(context, BRIDGE_ERROR, "logStatusError", "fmi2Instantiate: out of memory");
        return NULL;
    }
    s->log = log;
    s->context = context;
    if (load_model(&s->m, resources_dir, guid ? guid : "", why, sizeof why) < 0) {
        char text[3200];
        snprintf(text, sizeof text, "fmi2Instantiate: %s", why);
        log(context, BRIDGE_ERROR, "logStatusError", text);
        free_slave(s);
        return NULL;
    }
    if (snapshot_alloc(&s->m, &s->now) < 0 || !(s->params = calloc(s->m.layout.n_params + 1, sizeof *s->params))
        || !(s->param_texts = calloc(s->m.layout.n_params + 1, sizeof *s->param_texts))
        || !(s->scratch_x = calloc(s->m.nx + 1, sizeof *s->scratch_x))
        || !(s->scratch_y = calloc(s->m.layout.n_outputs + 1, sizeof *s->scratch_y))
        || !(s->scratch_which = calloc(s->m.layout.n_outputs + 1, 1))
        || !(s->state_held = calloc(s->m.layout.n_inputs + 1, sizeof *s->state_held))
        || !(s->scratch_dx = calloc(s->m.nx + 1, sizeof(double)))
        || !(s->scratch_ddx = calloc(s->m.nx + 1, sizeof(double)))
        || !(s->scratch_du = calloc(s->m.layout.n_inputs + 1, sizeof(double)))
        || !(s->scratch_in = calloc(s->m.layout.n_inputs + 1, sizeof(double)))
        || !(s->scratch_dy = calloc(s->m.layout.n_outputs + 1, sizeof(double)))) {
        log(context, BRIDGE_ERROR, "logStatusError", "fmi2Instantiate: out of memory");
        free_slave(s);
        return NULL;
    }
    if (clear(s) < 0) {
        log(context, BRIDGE_ERROR, "logStatusError", "fmi2Instantiate: out of memory");
        free_slave(s);
        return NULL;
    }
    return s;
}

static void free_instance(void *slave) { free_slave(slave); }

static int setup_experiment(void *slave, int tolerance_defined, double tolerance, double start_time,
                            int stop_time_defined, double stop_time) {
    (void)tolerance_defined, (void)tolerance, (void)stop_time_defined, (void)stop_time;
    ((Slave *)slave)->now.start_time = ((Slave *)slave)->now.clock = start_time;
    return BRIDGE_OK;
}

static int exit_initialization_mode(Slave *s) {
    Snapshot *now = &s->now;
    double *x = s->scratch_x;
    void *sim = make_sim(s, now->values, now->texts, x);
    if (!sim) return BRIDGE_ERROR;
    s->sim = sim;
    memcpy(now->x, x, s->m.nx * sizeof *x);
    now->time = 0.0;
    now->initialised = 1;
    memset(now->valid, 0, s->m.layout.n_outputs);
    for (size_t j = 0; j < s->m.layout.n_inputs; j++) now->held[j] = now->values[s->m.input_vr[j]];
    memcpy(s->state_held, now->held, s->m.layout.n_inputs * sizeof *now->held);
    for (size_t k = 0; k < s->m.n_messages; k++) note(s, s->m.messages[k]);
    return read_all_outputs(s, 1); /* every output once: a problem shows here rather than at a later read */
}

static int simple_call(void *slave, BridgeSimpleCall call) {
    Slave *s = slave;
    switch (call) {
    case CALL_EXIT_INITIALIZATION_MODE: return exit_initialization_mode(s);
    case CALL_RESET: return clear(s) < 0 ? refuse(s, BRIDGE_ERROR, "fmi2Reset: out of memory") : BRIDGE_OK;
    case CALL_TERMINATE:
        if (s->sim && s->m.kind->report) {
            NativeResult r = new_result(s);
            s->m.kind->report(s->sim, &r);
        }
        return BRIDGE_OK;
    default: return BRIDGE_OK;
    }
}

/* currentCommunicationPoint equals the clock within 16 eps |t| (the rounding of one step: the clock is the host's
   last point plus its step, never a sum over the run); a skipped or repeated step differs by a whole step */
#define CLOCK_EPS 16.0

static int do_step(void *slave, double current_time, double h) {
    Slave *s = slave;
    Snapshot *now = &s->now;
    const Model *m = &s->m;
    if (!s->sim) /* the front allows fmi2DoStep in StepComplete only; a crafted state could disagree */
        return refuse(s, BRIDGE_ERROR,
                      "fmi2DoStep: the instance is not initialised (its FMU state was taken before "
                      "fmi2ExitInitializationMode)");
    double t_now = now->clock;
    if (fabs(current_time - t_now) > CLOCK_EPS * DBL_EPSILON * fmax(fabs(current_time), fabs(t_now))) {
        char got[64], expected[64];
        native_repr(current_time, got, sizeof got);
        native_repr(t_now, expected, sizeof expected);
        return refuse(s, BRIDGE_ERROR,
                      "currentCommunicationPoint: got %s s, expected the FMU's time %s s (roll back "
                      "with fmi2SetFMUstate to step from another time)",
                      got, expected);
    }
    for (size_t j = 0; j < m->layout.n_inputs; j++) now->held[j] = now->values[m->input_vr[j]];
    memset(now->valid, 0, m->layout.n_outputs); /* from here on the outputs are those of another state */
    double t = now->time + h;
    if (!isfinite(t)) {
        char at[64];
        native_repr(now->time, at, sizeof at);
        return refuse(s, BRIDGE_ERROR, "step_size: the time t + step_size overflows at t = %s s", at);
    }
    double *x = s->scratch_x;
    memcpy(x, now->x, m->nx * sizeof *x);
    NativeResult r = new_result(s);
    int status = m->kind->step_held ? m->kind->step_held(s->sim, x, s->state_held, now->held, now->time, h, &r)
                                    : m->kind->step(s->sim, x, now->held, now->time, h, &r);
    double size = 0.0;
    if (status == BRIDGE_OK) {
        for (size_t i = 0; i < m->nx; i++) {
            double a = fabs(x[i]);
            if (!(a <= size)) size = a; /* NaN wins */
        }
        if (!isfinite(size)) status = NATIVE_NOT_FINITE;
    }
    /* the culprit of a state beyond the divergence limit: an input that alone moves it beyond (the limit; with
       none, any input: the largest) */
    double threshold = isfinite(m->divergence_limit) ? m->divergence_limit : 0.0;
    if (status == NATIVE_NOT_FINITE) {
        const char *name, *allowed;
        double value;
        if (culprit_of(s, m->kind->culprit(s->sim, 0, now->x, now->held, threshold), &name, &value, &allowed))
            return refuse(
                s, BRIDGE_ERROR,
                "%s: %.6g makes the state overflow (not finite) at t = %.6g s: the state diverged; allowed: %s", name,
                value, t, allowed);
        return refuse(s, BRIDGE_ERROR, "state: the state overflows (not finite) at t = %.6g s: the state diverged", t);
    }
    if (status != BRIDGE_OK) return refuse(s, status, "%s", r.message);
    if (size > m->divergence_limit) {
        const char *name, *allowed;
        double value;
        if (culprit_of(s, m->kind->culprit(s->sim, 0, now->x, now->held, threshold), &name, &value, &allowed))
            return refuse(s, BRIDGE_ERROR,
                          "%s: diverged at t = %.6g s (state norm %.3g): %s = %.6g alone moves it "
                          "beyond %g (allowed: %s)",
                          name, t, size, name, value, m->divergence_limit, m->divergence_allowed);
        return refuse(s, BRIDGE_ERROR, "state: diverged at t = %.6g s (state norm %.3g) (allowed: %s)", t, size,
                      m->divergence_allowed);
    }
    memcpy(now->x, x, m->nx * sizeof *x);
    memcpy(s->state_held, now->held, m->layout.n_inputs * sizeof *now->held);
    now->time = t;
    now->clock = current_time + h; /* the host's next communication point, as the host adds it */
    return BRIDGE_OK;
}

/* ---- values ------------------------------------------------------------------------------------------ */

/* ---- continuous states (model exchange) ----------------------------------------------------------------- */

/* The continuous states of a kind that is an ODE (NativeKind.derivatives), else 0. */
static size_t states_of(const Slave *s) { return s->m.kind->derivatives ? s->m.nx : 0; }

/* 1: vr is a continuous state's, 2: a state derivative's, 0: neither (value references after the variables'). */
static int state_reference(const Slave *s, unsigned int vr) {
    size_t n = states_of(s);
    if (vr < s->m.n_vars || vr >= s->m.n_vars + 2 * n) return 0;
    return vr < s->m.n_vars + n ? 1 : 2;
}

/* The derivatives of the current state with the inputs as set (model exchange) or held (co-simulation) into dx. */
static int compute_derivatives(Slave *s, const char *function, double *dx) {
    NativeResult r = new_result(s);
    int status = s->m.kind->derivatives(s->sim, s->now.x, s->now.held, dx, &r);
    if (status == NATIVE_NOT_FINITE) {
        char t[64];
        time_text(s->now.start_time + s->now.time, t, sizeof t);
        const char *name, *allowed;
        double value;
        if (culprit_of(s, s->m.kind->culprit(s->sim, 1, s->now.x, s->now.held, 1e300), &name, &value, &allowed))
            return refuse(s, BRIDGE_ERROR,
                          "%s: %s: %.6g makes the derivatives overflow (not finite) at t = %s s; "
                          "allowed: %s",
                          function, name, value, t, allowed);
        return refuse(s, BRIDGE_ERROR,
                      "%s: the derivatives are not finite at t = %s s (the states or inputs drive "
                      "the model beyond its range)",
                      function, t);
    }
    if (status != BRIDGE_OK) return refuse(s, status, "%s: %s", function, r.message);
    return BRIDGE_OK;
}

/* The refusal for the first value reference of `vr` that this call cannot take. */
static int refuse_reference(Slave *s, const char *function, BridgeValueType type, const unsigned int *vr, size_t nvr,
                            int setting) {
    for (size_t i = 0; i < nvr; i++) {
        int extra = state_reference(s, vr[i]);
        if (extra && (type != VALUE_REAL || setting))
            return refuse(s, BRIDGE_ERROR, "%s: value reference %u is %s %zu, a Real %s", function, vr[i],
                          extra == 1 ? "continuous state" : "the derivative of continuous state",
                          (size_t)vr[i] - s->m.n_vars - (extra == 1 ? 0 : s->m.nx),
                          extra == 1 ? "set with fmi2SetContinuousStates" : "computed by the model");
        if (extra) continue;
        if (vr[i] >= s->m.n_vars)
            return refuse(s, BRIDGE_ERROR, "%s: unknown value reference %u (this FMU has 0 .. %zu)", function, vr[i],
                          s->m.n_vars - 1); /* the variables every modelDescription declares */
        const Variable *v = &s->m.vars[vr[i]];
        if (v->type != (int)type)
            return refuse(s, BRIDGE_ERROR, "%s: value reference %u is '%s', a %s variable; use fmi2%s%s", function,
                          vr[i], v->name, TYPE_NAMES[v->type], setting ? "Set" : "Get", TYPE_NAMES[v->type]);
        if (setting && v->causality == OUTPUT)
            return refuse(s, BRIDGE_ERROR, "%s: '%s' is an output; outputs cannot be set", function, v->name);
        if (setting && v->causality == PARAMETER && s->sim)
            return refuse(s, BRIDGE_ERROR,
                          "%s: %s: a fixed parameter can be set only before "
                          "fmi2ExitInitializationMode",
                          function, v->name);
    }
    return BRIDGE_OK;
}

static int get_values(void *slave, BridgeValueType type, const unsigned int *vr, size_t nvr, void *values) {
    Slave *s = slave;
    const char *function = GET_NAMES[type];
    if (refuse_reference(s, function, type, vr, nvr, 0) != BRIDGE_OK) return BRIDGE_ERROR;
    if (s->sim) { /* the outputs read: each computed once per step, and only if read */
        int any = 0;
        for (size_t i = 0; i < nvr; i++) {
            if (vr[i] >= s->m.n_vars) continue; /* a state or derivative */
            const Variable *v = &s->m.vars[vr[i]];
            if (v->causality == OUTPUT && !s->now.valid[v->index]) {
                if (!any) memset(s->scratch_which, 0, s->m.layout.n_outputs);
                any = 1, s->scratch_which[v->index] = 1;
            }
        }
        if (any) {
            int status = read_outputs(s);
            if (status != BRIDGE_OK) return status;
        }
    }
    int derivatives_read = 0;
    for (size_t i = 0; i < nvr; i++) {
        int extra = state_reference(s, vr[i]);
        if (extra == 1) {
            ((double *)values)[i] = s->now.x[vr[i] - s->m.n_vars];
            continue;
        }
        if (extra == 2) {
            if (!s->sim) {
                ((double *)values)[i] = 0.0; /* before initialisation: no model yet (as the outputs' start) */
                continue;
            }
            if (!derivatives_read) {
                int status = compute_derivatives(s, function, s->scratch_dx);
                if (status != BRIDGE_OK) return status;
                derivatives_read = 1;
            }
            ((double *)values)[i] = s->scratch_dx[vr[i] - s->m.n_vars - s->m.nx];
            continue;
        }
        const Variable *v = &s->m.vars[vr[i]];
        double value = v->causality == OUTPUT ? s->now.outputs[v->index] : s->now.values[vr[i]];
        switch (type) {
        case VALUE_REAL: ((double *)values)[i] = value; break;
        case VALUE_INTEGER: ((int *)values)[i] = (int)value; break;
        case VALUE_BOOLEAN: ((int *)values)[i] = value != 0.0; break;
        case VALUE_STRING: ((const char **)values)[i] = settable_text(v) ? s->now.texts[vr[i]] : v->text; break;
        }
    }
    return BRIDGE_OK;
}

/* A value as the rebuild command takes it (NAME=VALUE) and as the message shows it. */
static void shown_value(const Variable *v, double value, const char *text, int quoted, char *out, size_t size) {
    switch (v->type) {
    case REAL: native_repr(value, out, size); break;
    case INTEGER: snprintf(out, size, "%d", (int)value); break;
    case BOOLEAN: snprintf(out, size, "%s", value != 0.0 ? "true" : "false"); break;
    default: snprintf(out, size, quoted ? "'%s'" : "%s", text ? text : "");
    }
}

/* A word as a POSIX shell reads it back: quoted unless it is made of safe characters only. */
static void shell_word(const char *word, char *out, size_t size) {
    int safe = *word != '\0';
    for (const char *c = word; *c; c++)
        if (!strchr("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_-+=.,/:@%", *c)) safe = 0;
    if (safe) {
        snprintf(out, size, "%s", word);
        return;
    }
    size_t k = 0;
    if (k + 1 < size) out[k++] = '\'';
    for (const char *c = word; *c && k + 5 < size; c++) {
        if (*c == '\'') { /* ' -> '\'' */
            memcpy(out + k, "'\\''", 4);
            k += 4;
        } else {
            out[k++] = *c;
        }
    }
    if (k + 1 < size) out[k++] = '\'';
    out[k < size ? k : size - 1] = '\0';
}

/* The command that rebuilds this FMU with `name` = `value`: the model file's rebuild command, its other fixed
   settings (rebuild.names / rebuild.values) and the new one. */
static void rebuild_command(const Model *m, const char *name, const char *value, char *out, size_t size) {
    snprintf(out, size, "%s", m->rebuild);
    if (!m->rebuild_names) return;
    for (size_t k = 0; k < m->n_rebuild; k++) {
        if (strcmp(m->rebuild_names[k], name) == 0) continue;
        size_t used = strlen(out);
        snprintf(out + used, size - used, " --set %s=%s", m->rebuild_names[k], m->rebuild_values[k]);
    }
    char word[600], assignment[700];
    snprintf(assignment, sizeof assignment, "%s=%s", name, value);
    shell_word(assignment, word, sizeof word);
    size_t used = strlen(out);
    snprintf(out + used, size - used, " --set %s", word);
}

/* The bytes are UTF-8 (RFC 3629: no overlong forms, no surrogates, at most U+10FFFF). */
static int is_utf8(const char *text) {
    const unsigned char *c = (const unsigned char *)text;
    while (*c) {
        int n = *c < 0x80 ? 0 : (*c & 0xE0) == 0xC0 ? 1 : (*c & 0xF0) == 0xE0 ? 2 : (*c & 0xF8) == 0xF0 ? 3 : -1;
        if (n < 0 || (n == 1 && *c < 0xC2) || (n == 3 && *c > 0xF4)) return 0;
        for (int k = 1; k <= n; k++)
            if ((c[k] & 0xC0) != 0x80) return 0;
        if ((n == 2 && *c == 0xE0 && c[1] < 0xA0) || (n == 2 && *c == 0xED && c[1] >= 0xA0)
            || (n == 3 && *c == 0xF0 && c[1] < 0x90) || (n == 3 && *c == 0xF4 && c[1] >= 0x90))
            return 0;
        c += n + 1;
    }
    return 1;
}

static int set_values(void *slave, BridgeValueType type, const unsigned int *vr, size_t nvr, const void *values) {
    Slave *s = slave;
    const char *function = SET_NAMES[type];
    if (refuse_reference(s, function, type, vr, nvr, 1) != BRIDGE_OK) return BRIDGE_ERROR;
    for (size_t i = 0; i < nvr; i++) { /* all checked before any is set */
        const Variable *v = &s->m.vars[vr[i]];
        double value = 0.0;
        const char *text = NULL;
        switch (type) {
        case VALUE_REAL: value = ((const double *)values)[i]; break;
        case VALUE_INTEGER: value = ((const int *)values)[i]; break;
        case VALUE_BOOLEAN: value = ((const int *)values)[i] != 0; break;
        case VALUE_STRING: text = ((const char *const *)values)[i]; break;
        }
        if (type == VALUE_REAL && !isfinite(value)) {
            char shown[64];
            native_repr(value, shown, sizeof shown);
            return refuse(s, BRIDGE_ERROR, "%s: %s: got %s (allowed: a finite number)", function, v->name, shown);
        }
        if (type == VALUE_STRING && !text)
            return refuse(s, BRIDGE_ERROR, "%s: %s: got NULL (allowed: a UTF-8 string)", function, v->name);
        if (type == VALUE_STRING && !is_utf8(text))
            return refuse(s, BRIDGE_ERROR, "%s: %s: got bytes that are not UTF-8 (allowed: a UTF-8 string)", function,
                          v->name);
        if (v->causality == PARAMETER && v->index < 0) { /* fixed at build: its build value only */
            int same = type == VALUE_STRING ? strcmp(text, v->text) == 0 : value == v->start;
            if (!same) {
                char built[512], got[512], plain[512], command[3000];
                shown_value(v, v->start, v->text, 1, built, sizeof built);
                shown_value(v, value, text, 1, got, sizeof got);
                shown_value(v, value, text, 0, plain, sizeof plain);
                rebuild_command(&s->m, v->name, plain, command, sizeof command);
                return refuse(s, BRIDGE_ERROR,
                              "%s: %s: got %s, but this native FMU was built with %s = %s, fixed at "
                              "build; to use another value rebuild it: %s (or use the Python runtime, "
                              "where it is a parameter)",
                              function, v->name, got, v->name, built, command);
            }
        }
    }
    for (size_t i = 0; i < nvr; i++) {
        const Variable *v = &s->m.vars[vr[i]];
        if (type == VALUE_STRING) { /* fixed strings: equal to the build value, checked above */
            char *copy = settable_text(v) ? copy_text(((const char *const *)values)[i]) : NULL;
            if (settable_text(v) && !copy) return refuse(s, BRIDGE_ERROR, "%s: out of memory", function);
            if (copy) free(s->now.texts[vr[i]]), s->now.texts[vr[i]] = copy;
            continue;
        }
        double value = type == VALUE_REAL      ? ((const double *)values)[i]
                       : type == VALUE_INTEGER ? (double)((const int *)values)[i]
                                               : (double)(((const int *)values)[i] != 0);
        if (v->causality != PARAMETER || v->index >= 0) s->now.values[vr[i]] = value;
        if (s->me && s->sim && v->causality == INPUT && s->now.held[v->index] != value) {
            s->now.held[v->index] = value; /* model exchange: the inputs are functions of time, not held */
            memset(s->now.valid, 0, s->m.layout.n_outputs);
        }
    }
    return BRIDGE_OK;
}

/* ---- FMU states ------------------------------------------------------------------------------------- */

static int get_state(void *slave, void **state) {
    Slave *s = slave;
    const Model *m = &s->m;
    if (s->sim) { /* the state holds every output but the deferred ones, which are computed only when read */
        int status = read_all_outputs(s, 0);
        if (status != BRIDGE_OK) return status;
    }
    Snapshot *copy = malloc(sizeof *copy);
    if (!copy || snapshot_alloc(m, copy) < 0 || snapshot_copy(m, copy, &s->now) < 0) {
        if (copy) snapshot_free(copy);
        free(copy);
        return refuse(s, BRIDGE_ERROR, "fmi2GetFMUstate: out of memory");
    }
    if (s->sim && m->kind->save) { /* the kind's own state beside x (the Python kind's simulator) */
        NativeResult r = new_result(s);
        int status = m->kind->save(s->sim, &copy->saved, &copy->saved_size, &r);
        if (status != BRIDGE_OK) {
            snapshot_free(copy);
            free(copy);
            return refuse(s, status, "fmi2GetFMUstate: %s", r.message);
        }
    }
    *state = copy;
    return BRIDGE_OK;
}

static void free_state(void *state) {
    if (!state) return;
    snapshot_free(state);
    free(state);
}

/* The runtime parameters of two snapshots are equal. */
static int same_parameters(const Model *m, const Snapshot *a, const Snapshot *b) {
    for (size_t k = 0; k < m->layout.n_params; k++) {
        int vr = m->rules[k].vr;
        if (a->values[vr] != b->values[vr]) return 0;
        if (a->texts[vr] && b->texts[vr] && strcmp(a->texts[vr], b->texts[vr]) != 0) return 0;
    }
    return 1;
}

static int set_state(void *slave, void *state) {
    Slave *s = slave;
    const Snapshot *from = state;
    const Model *m = &s->m;
    void *sim = NULL;
    if (from->initialised) {
        if (s->sim && same_parameters(m, from, &s->now)) {
            sim = s->sim;
        } else if (!(sim = make_sim(s, from->values, from->texts, s->scratch_x))) { /* another configuration */
            return BRIDGE_ERROR;
        }
        if (m->kind->restore) {
            NativeResult r = new_result(s);
            int status = from->saved ? m->kind->restore(sim, from->saved, from->saved_size, &r)
                                     : native_refuse(&r, BRIDGE_ERROR, "the state holds no simulator state");
            if (status != BRIDGE_OK) {
                if (sim != s->sim) m->kind->free_sim(sim);
                return refuse(s, status, "fmi2SetFMUstate: %s", r.message);
            }
        }
    }
    if (snapshot_copy(m, &s->now, from) < 0) {
        if (sim != s->sim) m->kind->free_sim(sim);
        return refuse(s, BRIDGE_ERROR, "fmi2SetFMUstate: out of memory");
    }
    if (s->sim && sim != s->sim) m->kind->free_sim(s->sim);
    s->sim = sim;
    memcpy(s->state_held, from->held, m->layout.n_inputs * sizeof *from->held);
    for (size_t i = 0; i < m->layout.n_outputs; i++) /* the outputs of the state's last step, as taken */
        s->now.valid[i] = from->initialised && (!m->deferred[i] || from->valid[i]);
    return BRIDGE_OK;
}

#define STATE_FIXED 56 /* the layout's fixed part: magic, 6 u32, 3 f64 */

static size_t serialized_size(const Model *m, const Snapshot *st) {
    size_t n = STATE_FIXED + 8 * (m->n_vars + m->layout.n_inputs + m->layout.n_outputs + m->nx) + 8 + st->saved_size;
    for (size_t i = 0; i < m->n_vars; i++)
        if (settable_text(&m->vars[i])) n += 4 + strlen(st->texts[i]);
    return n;
}

/* Layout (little-endian): "FXNATIVE", u32 STATE_VERSION, u32 n_vars, u32 n_inputs, u32 n_outputs, u32 nx,
   u32 flags (1: initialised, 2: outputs valid, 4: deferred outputs valid too; a state without 4 has them computed
   when read), f64 time (since the start), f64 start time, f64 clock (the host's time of the next step's start),
   f64 values[n_vars] (parameters, inputs; 0 for outputs and strings), f64 held[n_inputs], f64 outputs[n_outputs],
   f64 x[nx], then each settable String parameter's value (value-reference order: u32 length, UTF-8 bytes), then
   u64 length and the bytes of the kind's own state (NativeKind.save; length 0 for a kind without). */
static int serialize_state(void *slave, void *state, char *bytes, size_t *size) {
    Slave *s = slave;
    const Model *m = &s->m;
    const Snapshot *st = state;
    size_t n = serialized_size(m, st);
    if (!bytes) {
        *size = n;
        return BRIDGE_OK;
    }
    if (*size < n)
        return refuse(s, BRIDGE_ERROR,
                      "fmi2SerializeFMUstate: the buffer is smaller than "
                      "fmi2SerializedFMUstateSize said");
    unsigned char *b = (unsigned char *)bytes;
    memcpy(b, STATE_MAGIC, 8);
    put32(b + 8, STATE_VERSION);
    put32(b + 12, (uint32_t)m->n_vars);
    put32(b + 16, (uint32_t)m->layout.n_inputs);
    put32(b + 20, (uint32_t)m->layout.n_outputs);
    put32(b + 24, (uint32_t)m->nx);
    int cheap_valid = 1, deferred_valid = 1;
    for (size_t i = 0; i < m->layout.n_outputs; i++) *(m->deferred[i] ? &deferred_valid : &cheap_valid) &= st->valid[i];
    put32(b + 28,
          (uint32_t)((st->initialised ? 1 : 0) | (cheap_valid ? 2 : 0) | (cheap_valid && deferred_valid ? 4 : 0)));
    unsigned char *at = b + 32;
    put_f64(at, st->time), at += 8;
    put_f64(at, st->start_time), at += 8;
    put_f64(at, st->clock), at += 8;
    for (size_t i = 0; i < m->n_vars; i++, at += 8) put_f64(at, st->values[i]);
    for (size_t i = 0; i < m->layout.n_inputs; i++, at += 8) put_f64(at, st->held[i]);
    for (size_t i = 0; i < m->layout.n_outputs; i++, at += 8) put_f64(at, st->outputs[i]);
    for (size_t i = 0; i < m->nx; i++, at += 8) put_f64(at, st->x[i]);
    for (size_t i = 0; i < m->n_vars; i++) {
        if (!settable_text(&m->vars[i])) continue;
        size_t length = strlen(st->texts[i]);
        put32(at, (uint32_t)length), at += 4;
        memcpy(at, st->texts[i], length), at += length;
    }
    put32(at, (uint32_t)(st->saved_size & 0xFFFFFFFFu)), put32(at + 4, (uint32_t)((uint64_t)st->saved_size >> 32));
    at += 8;
    if (st->saved_size) memcpy(at, st->saved, st->saved_size);
    *size = n;
    return BRIDGE_OK;
}

/* What a serialised state holds beyond its fixed part, read with bounds checks; NULL, else why not. */
static const char *read_variable_part(const Model *m, const unsigned char *at, const unsigned char *end, Snapshot *st) {
    for (size_t i = 0; i < m->n_vars; i++) {
        if (!settable_text(&m->vars[i])) continue;
        if (end - at < 4) return "truncated";
        uint32_t length = le32(at);
        at += 4;
        if ((size_t)(end - at) < length) return "truncated";
        char *text = malloc((size_t)length + 1);
        if (!text) return "out of memory";
        memcpy(text, at, length);
        text[length] = '\0';
        at += length;
        st->texts[i] = text;
        if (strlen(text) != length || !is_utf8(text)) return "a String parameter is not UTF-8";
    }
    if (end - at < 8) return "truncated";
    uint64_t saved = le64(at);
    at += 8;
    if ((uint64_t)(end - at) != saved) return "truncated or damaged: its size does not add up";
    if (saved && !m->kind->check_saved) return "it holds a simulator state this model has not";
    if (!saved && m->kind->check_saved && st->initialised) return "it holds no simulator state";
    if (saved) {
        if (!(st->saved = malloc((size_t)saved))) return "out of memory";
        memcpy(st->saved, at, (size_t)saved);
        st->saved_size = (size_t)saved;
    }
    return NULL;
}

static int deserialize_state(void *slave, const char *bytes, size_t size, void **state) {
    Slave *s = slave;
    const Model *m = &s->m;
    const unsigned char *b = (const unsigned char *)bytes;
    static const char *prefix = "fmi2DeSerializeFMUstate: the bytes are not a state of this FMU";
    if (size < STATE_FIXED || memcmp(b, STATE_MAGIC, 8) != 0)
        return refuse(s, BRIDGE_ERROR, "%s (not a native flexfmu state)", prefix);
    if (le32(b + 8) != STATE_VERSION)
        return refuse(s, BRIDGE_ERROR, "%s (state layout version %u, this FMU reads %u)", prefix, (unsigned)le32(b + 8),
                      STATE_VERSION);
    if (le32(b + 12) != m->n_vars || le32(b + 16) != m->layout.n_inputs || le32(b + 20) != m->layout.n_outputs
        || le32(b + 24) != m->nx)
        return refuse(s, BRIDGE_ERROR, "%s (its sizes are another model's)", prefix);
    size_t fixed = STATE_FIXED + 8 * (m->n_vars + m->layout.n_inputs + m->layout.n_outputs + m->nx);
    if (size < fixed)
        return refuse(s, BRIDGE_ERROR, "%s (truncated or damaged: %zu bytes, expected at least %zu)", prefix, size,
                      fixed);
    uint32_t flags = le32(b + 28);
    if (flags > 7) return refuse(s, BRIDGE_ERROR, "%s (bad flags)", prefix);
    Snapshot *st = malloc(sizeof *st);
    if (!st || snapshot_alloc(m, st) < 0) {
        if (st) snapshot_free(st);
        free(st);
        return refuse(s, BRIDGE_ERROR, "fmi2DeSerializeFMUstate: out of memory");
    }
    st->initialised = flags & 1;
    for (size_t i = 0; i < m->layout.n_outputs; i++)
        st->valid[i] = (unsigned char)(m->deferred[i] ? (flags & 6) == 6 : (flags & 2) != 0);
    const unsigned char *at = b + 32;
    st->time = f64_of(at), at += 8;
    st->start_time = f64_of(at), at += 8;
    st->clock = f64_of(at), at += 8;
    for (size_t i = 0; i < m->n_vars; i++, at += 8) st->values[i] = f64_of(at);
    for (size_t i = 0; i < m->layout.n_inputs; i++, at += 8) st->held[i] = f64_of(at);
    for (size_t i = 0; i < m->layout.n_outputs; i++, at += 8) st->outputs[i] = f64_of(at);
    for (size_t i = 0; i < m->nx; i++, at += 8) st->x[i] = f64_of(at);
    const char *bad = read_variable_part(m, at, b + size, st);
    if (!bad && (!isfinite(st->time) || !isfinite(st->start_time) || !isfinite(st->clock))) bad = "time not finite";
    for (size_t i = 0; !bad && i < m->n_vars; i++) {
        const Variable *v = &m->vars[i];
        if (!isfinite(st->values[i]))
            bad = "a value is not finite";
        else if (v->causality == PARAMETER && v->index < 0 && v->type != STRING && st->values[i] != v->start)
            bad = "its fixed parameters are another build's";
    }
    for (size_t i = 0; !bad && i < m->layout.n_inputs; i++)
        if (!isfinite(st->held[i])) bad = "held inputs not finite";
    for (size_t i = 0; !bad && i < m->layout.n_outputs; i++)
        if (!isfinite(st->outputs[i])) bad = "outputs not finite";
    for (size_t i = 0; !bad && i < m->nx; i++)
        if (!isfinite(st->x[i]) || !(fabs(st->x[i]) <= m->divergence_limit)) /* the limit may be +inf */
            bad = "the state vector is not finite or beyond the divergence limit";
    if (bad) {
        free_state(st);
        return refuse(s, BRIDGE_ERROR, "%s (%s)", prefix, bad);
    }
    if (st->saved) { /* the kind's own state: its structure, before any instance uses it */
        NativeResult r = new_result(s);
        int status = m->kind->check_saved(m->model, st->saved, st->saved_size, &r);
        if (status != BRIDGE_OK) {
            free_state(st);
            return refuse(s, status, "%s (%s)", prefix, r.message);
        }
    }
    *state = st;
    return BRIDGE_OK;
}

static int last_successful_time(void *slave, double *time) {
    Slave *s = slave;
    *time = s->now.clock;
    return BRIDGE_OK;
}

/* ---- model exchange and directional derivatives (BridgeApi version 2) ------------------------------------ */

static size_t n_states(void *slave) { return states_of(slave); }

static int model_exchange(void *slave, const char *function) {
    Slave *s = slave;
    if (!states_of(s))
        return refuse(s, BRIDGE_ERROR,
                      "%s: this model (kind '%s') is co-simulation only: it is advanced by its own stepping method "
                      "(fmuType/interface: co-simulation)",
                      function, s->m.kind->name);
    s->me = 1;
    return BRIDGE_OK;
}

/* The instance is set up (fmi2ExitInitializationMode made its model), else a refusal naming `function`. */
static int need_model(Slave *s, const char *function) {
    if (s->sim) return BRIDGE_OK;
    return refuse(s, BRIDGE_ERROR,
                  "%s: available from fmi2ExitInitializationMode on (the model is made from the parameters there)",
                  function);
}

static int nominals(void *slave, double *x, size_t nx) {
    Slave *s = slave;
    size_t n = states_of(s);
    if (nx != n)
        return refuse(s, BRIDGE_ERROR,
                      "fmi2GetNominalsOfContinuousStates: nx: got %zu (allowed: this model's %zu "
                      "continuous states)",
                      nx, n);
    for (size_t i = 0; i < n; i++) x[i] = s->m.nominals ? s->m.nominals[i] : 1.0;
    return BRIDGE_OK;
}

static int set_time(void *slave, const char *function, double time) {
    Slave *s = slave;
    if (!isfinite(time)) {
        char shown[64];
        native_repr(time, shown, sizeof shown);
        return refuse(s, BRIDGE_ERROR, "%s: time: got %s (allowed: a finite time in s)", function, shown);
    }
    s->now.time = time - s->now.start_time;
    s->now.clock = time;
    return BRIDGE_OK;
}

static int continuous_states(void *slave, const char *function, int set, double *x, size_t nx) {
    Slave *s = slave;
    size_t n = states_of(s);
    if (nx != n) return refuse(s, BRIDGE_ERROR, "%s: got %zu states (allowed: this model's %zu)", function, nx, n);
    if (!set) {
        memcpy(x, s->now.x, n * sizeof *x);
        return BRIDGE_OK;
    }
    for (size_t i = 0; i < n; i++)
        if (!isfinite(x[i])) {
            char shown[64];
            native_repr(x[i], shown, sizeof shown);
            return refuse(s, BRIDGE_ERROR, "%s: continuous state %zu: got %s (allowed: a finite number)", function, i,
                          shown);
        }
    if (memcmp(s->now.x, x, n * sizeof *x) != 0) {
        memcpy(s->now.x, x, n * sizeof *x);
        memset(s->now.valid, 0, s->m.layout.n_outputs);
    }
    return BRIDGE_OK;
}

static int derivatives(void *slave, const char *function, double *dx, size_t nx) {
    Slave *s = slave;
    size_t n = states_of(s);
    if (nx != n) return refuse(s, BRIDGE_ERROR, "%s: got %zu derivatives (allowed: this model's %zu)", function, nx, n);
    if (need_model(s, function) != BRIDGE_OK) return BRIDGE_ERROR;
    return compute_derivatives(s, function, dx);
}

static int directional(void *slave, const char *function, const unsigned int *unknown, size_t n_unknown,
                       const unsigned int *known, size_t n_known, const double *seed, double *sensitivity) {
    Slave *s = slave;
    const Model *m = &s->m;
    if (!m->kind->directional)
        return refuse(s, BRIDGE_ERROR, "%s: this model (kind '%s') provides no directional derivatives", function,
                      m->kind->name);
    if (need_model(s, function) != BRIDGE_OK) return BRIDGE_ERROR;
    double *du = s->scratch_du, *dx = s->scratch_dx;
    memset(du, 0, m->layout.n_inputs * sizeof *du);
    memset(dx, 0, m->nx * sizeof *dx);
    for (size_t j = 0; j < n_known; j++) {
        unsigned int vr = known[j];
        if (!isfinite(seed[j]))
            return refuse(s, BRIDGE_ERROR, "%s: the seed of value reference %u is not finite", function, vr);
        if (state_reference(s, vr) == 1) {
            dx[vr - m->n_vars] += seed[j];
        } else if (vr < m->n_vars && m->vars[vr].causality == INPUT) {
            du[m->vars[vr].index] += seed[j];
        } else {
            return refuse(s, BRIDGE_ERROR,
                          "%s: known value reference %u%s%s%s is not an input or a continuous state (allowed: "
                          "the inputs%s)",
                          function, vr, vr < m->n_vars ? " ('" : "", vr < m->n_vars ? m->vars[vr].name : "",
                          vr < m->n_vars ? "')" : "", states_of(s) ? " and the continuous states" : "");
        }
    }
    for (size_t i = 0; i < n_unknown; i++) { /* a state: the FMI 3.0 arrays of the states (modal_coordinates) */
        unsigned int vr = unknown[i];
        if (!state_reference(s, vr) && !(vr < m->n_vars && m->vars[vr].causality == OUTPUT))
            return refuse(s, BRIDGE_ERROR,
                          "%s: unknown value reference %u%s%s%s is not an output or a state derivative (allowed: "
                          "the outputs%s)",
                          function, vr, vr < m->n_vars ? " ('" : "", vr < m->n_vars ? m->vars[vr].name : "",
                          vr < m->n_vars ? "')" : "", states_of(s) ? " and the state derivatives" : "");
    }
    /* at the inputs as last set: in co-simulation the held ones until the next step, but a master asks for the
       derivatives of the output function at the inputs it has just set */
    double *in = s->scratch_in;
    for (size_t j = 0; j < m->layout.n_inputs; j++) in[j] = s->now.values[m->input_vr[j]];
    NativeResult r = new_result(s);
    int status
        = m->kind->directional(s->sim, s->now.x, in, dx, du, s->scratch_dy, states_of(s) ? s->scratch_ddx : NULL, &r);
    if (status == NATIVE_NOT_FINITE)
        return refuse(s, BRIDGE_ERROR,
                      "%s: the derivatives are not finite (the state or inputs are beyond the "
                      "model's range)",
                      function);
    if (status != BRIDGE_OK) return refuse(s, status, "%s: %s", function, r.message);
    for (size_t i = 0; i < n_unknown; i++) { /* d x_k along the seed is the seed's x_k */
        unsigned int vr = unknown[i];
        int extra = state_reference(s, vr);
        sensitivity[i] = extra == 1   ? dx[vr - m->n_vars]
                         : extra == 2 ? s->scratch_ddx[vr - m->n_vars - m->nx]
                                      : s->scratch_dy[m->vars[vr].index];
    }
    return BRIDGE_OK;
}

static const BridgeArrays *arrays(void *slave) { return &((Slave *)slave)->m.arrays; }

static const BridgeApi API = {
    FLEXFMU_BRIDGE_VERSION,
    start,
    instantiate,
    free_instance,
    setup_experiment,
    simple_call,
    do_step,
    get_values,
    set_values,
    get_state,
    set_state,
    free_state,
    serialize_state,
    deserialize_state,
    last_successful_time,
    n_states,
    model_exchange,
    set_time,
    continuous_states,
    derivatives,
    directional,
    nominals,
    arrays,
};

/* The front's load_bridge (compiled with FLEXFMU_NATIVE) takes the API from here: nothing is loaded. */
const BridgeApi *flexfmu_native_api(void) { return &API; }
