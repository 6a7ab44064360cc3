/* An FMI 2.0 co-simulation host that builds for Linux (x86-64, aarch64) and Windows (MinGW-w64): it runs one
 * native FMU's binary for one platform on a recorded input, so the binaries of every platform can be compared with
 * the linux64 one bit for bit (tests/test_fmu_platforms.py runs it natively, under qemu-aarch64 and under Wine).
 * Built with -DFMI_VERSION=3 it is the same host for FMI 3.0 co-simulation (the same calls in FMI 3.0's names).
 *
 *   fmi2_platform_host PLATFORM UNZIPPED_DIR MODEL_IDENTIFIER GUID STEP N_STEPS INPUTS OUTPUTS
 *                      [--set real|int|bool|string VR VALUE]... [--input VR]... [--output VR]... [--x87-control HEX]
 *
 * Loads UNZIPPED_DIR/binaries/PLATFORM/MODEL_IDENTIFIER.{so,dll}; instantiates it with the resources of
 * UNZIPPED_DIR (FMI 2.0: a file:/// URI; FMI 3.0: the folder's path ending in a separator); sets the start values
 * in initialization mode; then N_STEPS communication steps of STEP seconds from t = 0, each after setting the
 * --input values of that step from the file INPUTS.  It writes to the file OUTPUTS the --output values after
 * initialisation and after every step: (N_STEPS + 1) x outputs doubles.  GUID is FMI 3.0's instantiation token.
 *
 * --x87-control HEX (x86 only) loads the x87 control word once the library is loaded: MinGW-w64's libm computes sin, cos,
 * atan2, pow and log2 with x87 instructions, which round to the control word's precision.  A MinGW program starts
 * at 0x37f (64-bit precision), a Windows x64 process built otherwise at the ABI's 0x27f (53-bit, double).
 *
 * Numbers cross the process boundary as IEEE-754 binary64 bit patterns, never as decimal text: a real start value
 * and STEP are 16 hex digits (the bits, e.g. 3f50624dd2f1a9fc for 1e-3), INPUTS holds N_STEPS x inputs doubles and
 * OUTPUTS gets doubles, both little-endian as every platform here.  So no C library's decimal conversion (msvcrt's,
 * glibc's) enters the comparison.
 *
 * Every status is checked; the FMU's log goes to stderr.  Exit status: 0 all good, 2 usage, 3 loading failed,
 * 4 an FMI call failed, 5 a file could not be read or written.
 */
#if defined(_WIN32)
#define WIN32_LEAN_AND_MEAN
#include <windows.h>
#define LIBRARY_SUFFIX ".dll"
#define SEPARATOR "\\"
typedef HMODULE Library;
static Library open_library(const char *path) { return LoadLibraryA(path); }
static void *library_symbol(Library lib, const char *name) { return (void *)(INT_PTR)GetProcAddress(lib, name); }
static int close_library(Library lib) { return FreeLibrary(lib) ? 0 : -1; }
static void native_separators(char *path) {
    for (; *path; path++)
        if (*path == '/') *path = '\\';
}
#else
#include <dlfcn.h>
#define LIBRARY_SUFFIX ".so"
#define SEPARATOR "/"
typedef void *Library;
static Library open_library(const char *path) { return dlopen(path, RTLD_NOW | RTLD_LOCAL); }
static void *library_symbol(Library lib, const char *name) { return dlsym(lib, name); }
static int close_library(Library lib) { return dlclose(lib); }
static void native_separators(char *path) { (void)path; }
#endif

#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifndef FMI_VERSION
#define FMI_VERSION 2
#endif

enum { OK = 0, USAGE = 2, LOAD_FAILED = 3, CALL_FAILED = 4, FILE_FAILED = 5 };

/* The calls this host makes, each a small function over that version's FMI function (instantiate,
   enter_initialization: FMI 2.0's fmi2SetupExperiment and fmi2EnterInitializationMode, set_reals, ..., do_step),
   the types they take (Status: OK, Warning, Discard, Error, Fatal in both versions' order), and the FMI functions
   looked up in the library (look_up_functions). */
/* p_NAME: the library's function NAME */
#define FUNCTION(name) static name##TYPE *p_##name
#define LOOK_UP(name)                                                                                                  \
    if (!(p_##name = (name##TYPE *)library_symbol(lib, #name))) return #name

#if FMI_VERSION == 3
#include "fmi3Functions.h"
typedef fmi3Status Status;
typedef fmi3Instance Instance;
typedef fmi3ValueReference VR;
typedef fmi3Int32 Integer;
typedef fmi3Boolean Boolean;
#define STATUS_PREFIX "fmi3"
FUNCTION(fmi3InstantiateCoSimulation);
FUNCTION(fmi3EnterInitializationMode);
FUNCTION(fmi3ExitInitializationMode);
FUNCTION(fmi3SetFloat64);
FUNCTION(fmi3SetInt32);
FUNCTION(fmi3SetBoolean);
FUNCTION(fmi3SetString);
FUNCTION(fmi3GetFloat64);
FUNCTION(fmi3DoStep);
FUNCTION(fmi3Terminate);
FUNCTION(fmi3FreeInstance);
static const char *look_up_functions(Library lib) {
    LOOK_UP(fmi3InstantiateCoSimulation);
    LOOK_UP(fmi3EnterInitializationMode);
    LOOK_UP(fmi3ExitInitializationMode);
    LOOK_UP(fmi3SetFloat64);
    LOOK_UP(fmi3SetInt32);
    LOOK_UP(fmi3SetBoolean);
    LOOK_UP(fmi3SetString);
    LOOK_UP(fmi3GetFloat64);
    LOOK_UP(fmi3DoStep);
    LOOK_UP(fmi3Terminate);
    LOOK_UP(fmi3FreeInstance);
    return NULL;
}

static void log_message(fmi3InstanceEnvironment env, fmi3Status status, fmi3String category, fmi3String message);
static Instance instantiate(const char *id, const char *token, const char *dir) {
    char resources[4200];
    snprintf(resources, sizeof resources, "%s" SEPARATOR "resources" SEPARATOR, dir);
    Instance c = p_fmi3InstantiateCoSimulation(id, token, resources, false, false, false, false, NULL, 0, NULL,
                                               log_message, NULL);
    if (!c) fprintf(stderr, "fmi3InstantiateCoSimulation returned NULL (resources %s)\n", resources);
    return c;
}
static Status enter_initialization(Instance c) { return p_fmi3EnterInitializationMode(c, false, 0.0, 0.0, false, 0.0); }
static Status exit_initialization(Instance c) { return p_fmi3ExitInitializationMode(c); }
static Status set_reals(Instance c, const VR *vr, size_t n, const double *v) {
    return p_fmi3SetFloat64(c, vr, n, v, n);
}
static Status set_integer(Instance c, const VR *vr, Integer v) { return p_fmi3SetInt32(c, vr, 1, &v, 1); }
static Status set_boolean(Instance c, const VR *vr, Boolean v) { return p_fmi3SetBoolean(c, vr, 1, &v, 1); }
static Status set_string(Instance c, const VR *vr, const char *v) { return p_fmi3SetString(c, vr, 1, &v, 1); }
static Status get_reals(Instance c, const VR *vr, size_t n, double *v) { return p_fmi3GetFloat64(c, vr, n, v, n); }
static Status do_step(Instance c, double t, double h) {
    fmi3Boolean event_handling_needed, terminate, early_return;
    fmi3Float64 last_successful_time;
    return p_fmi3DoStep(c, t, h, true, &event_handling_needed, &terminate, &early_return, &last_successful_time);
}
static Status terminate(Instance c) { return p_fmi3Terminate(c); }
static void free_instance(Instance c) { p_fmi3FreeInstance(c); }
#else
#include "fmi2Functions.h"
typedef fmi2Status Status;
typedef fmi2Component Instance;
typedef fmi2ValueReference VR;
typedef fmi2Integer Integer;
typedef fmi2Boolean Boolean;
#define STATUS_PREFIX "fmi2"
FUNCTION(fmi2Instantiate);
FUNCTION(fmi2SetupExperiment);
FUNCTION(fmi2EnterInitializationMode);
FUNCTION(fmi2ExitInitializationMode);
FUNCTION(fmi2SetReal);
FUNCTION(fmi2SetInteger);
FUNCTION(fmi2SetBoolean);
FUNCTION(fmi2SetString);
FUNCTION(fmi2GetReal);
FUNCTION(fmi2DoStep);
FUNCTION(fmi2Terminate);
FUNCTION(fmi2FreeInstance);
static const char *look_up_functions(Library lib) {
    LOOK_UP(fmi2Instantiate);
    LOOK_UP(fmi2SetupExperiment);
    LOOK_UP(fmi2EnterInitializationMode);
    LOOK_UP(fmi2ExitInitializationMode);
    LOOK_UP(fmi2SetReal);
    LOOK_UP(fmi2SetInteger);
    LOOK_UP(fmi2SetBoolean);
    LOOK_UP(fmi2SetString);
    LOOK_UP(fmi2GetReal);
    LOOK_UP(fmi2DoStep);
    LOOK_UP(fmi2Terminate);
    LOOK_UP(fmi2FreeInstance);
    return NULL;
}

static void logger(fmi2ComponentEnvironment env, fmi2String instance, fmi2Status status, fmi2String category,
                   fmi2String message, ...);
static Instance instantiate(const char *id, const char *guid, const char *dir) {
    static fmi2CallbackFunctions callbacks = {logger, calloc, free, NULL, NULL};
    char resources[4200];
    /* file:///C:/a/resources on Windows, file:///a/resources elsewhere */
    snprintf(resources, sizeof resources, "file://%s%s/resources", dir[0] == '/' ? "" : "/", dir);
    for (char *c = resources; *c; c++)
        if (*c == '\\') *c = '/';
    Instance c = p_fmi2Instantiate(id, fmi2CoSimulation, guid, resources, &callbacks, fmi2False, fmi2False);
    if (!c) fprintf(stderr, "fmi2Instantiate returned NULL (resources %s)\n", resources);
    return c;
}
static Status enter_initialization(Instance c) {
    Status s = p_fmi2SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0);
    return s > fmi2Warning ? s : p_fmi2EnterInitializationMode(c);
}
static Status exit_initialization(Instance c) { return p_fmi2ExitInitializationMode(c); }
static Status set_reals(Instance c, const VR *vr, size_t n, const double *v) { return p_fmi2SetReal(c, vr, n, v); }
static Status set_integer(Instance c, const VR *vr, Integer v) { return p_fmi2SetInteger(c, vr, 1, &v); }
static Status set_boolean(Instance c, const VR *vr, Boolean v) { return p_fmi2SetBoolean(c, vr, 1, &v); }
static Status set_string(Instance c, const VR *vr, const char *v) { return p_fmi2SetString(c, vr, 1, &v); }
static Status get_reals(Instance c, const VR *vr, size_t n, double *v) { return p_fmi2GetReal(c, vr, n, v); }
static Status do_step(Instance c, double t, double h) { return p_fmi2DoStep(c, t, h, fmi2True); }
static Status terminate(Instance c) { return p_fmi2Terminate(c); }
static void free_instance(Instance c) { p_fmi2FreeInstance(c); }
#endif

static double from_bits(const char *hex) {
    uint64_t bits = (uint64_t)strtoull(hex, NULL, 16);
    double value;
    memcpy(&value, &bits, sizeof value);
    return value;
}

static const char *status_name(int s) {
    static const char *names[] = {"OK", "Warning", "Discard", "Error", "Fatal", "Pending"};
    return (unsigned)s < 6 ? names[s] : "?";
}

#if FMI_VERSION == 3
static void log_message(fmi3InstanceEnvironment env, fmi3Status status, fmi3String category, fmi3String message) {
    (void)env;
    fprintf(stderr, "[%s|%s] %s\n", status_name(status), category ? category : "", message ? message : "");
    fflush(stderr);
}
#else
static void logger(fmi2ComponentEnvironment env, fmi2String instance, fmi2Status status, fmi2String category,
                   fmi2String message, ...) {
    char text[4096] = "";
    va_list args;
    (void)env;
    if (message) {
        va_start(args, message);
        vsnprintf(text, sizeof text, message, args);
        va_end(args);
    }
    fprintf(stderr, "[%s|%s|%s] %s\n", instance ? instance : "", status_name(status), category ? category : "", text);
    fflush(stderr);
}
#endif

/* 0 if the x87 control word is now `control`, -1 where there is no x87 */
static int load_x87_control(unsigned short control) {
#if defined(__x86_64__) || defined(__i386__)
    unsigned short now = 0;
    __asm__ volatile("fldcw %0" : : "m"(control));
    __asm__ volatile("fnstcw %0" : "=m"(now));
    return now == control ? 0 : -1;
#else
    (void)control;
    return -1;
#endif
}

static int failed(Status s, const char *call) {
    if ((int)s <= 1) return 0; /* OK, Warning */
    fprintf(stderr, "%s returned " STATUS_PREFIX "%s\n", call, status_name((int)s));
    return 1;
}

#define CHECK(call)                                                                                                    \
    if (failed((call), #call)) return CALL_FAILED

int main(int argc, char **argv) {
    if (argc < 9) {
        fprintf(stderr,
                "usage: %s PLATFORM UNZIPPED_DIR MODEL_IDENTIFIER GUID STEP N_STEPS INPUTS OUTPUTS "
                "[--set real|int|bool|string VR VALUE]... [--input VR]... [--output VR]... [--x87-control HEX]\n",
                argv[0]);
        return USAGE;
    }
    const char *platform = argv[1], *dir = argv[2], *id = argv[3], *guid = argv[4];
    const double step = from_bits(argv[5]);
    const int n_steps = atoi(argv[6]);
    const char *inputs_file = argv[7], *outputs_file = argv[8];
    /* each list has at most as many entries as there are arguments */
    char *kinds = calloc((size_t)argc, 1);
    const char **values = calloc((size_t)argc, sizeof *values);
    VR *set_vr = calloc((size_t)argc, sizeof *set_vr), *in_vr = calloc((size_t)argc, sizeof *in_vr),
       *out_vr = calloc((size_t)argc, sizeof *out_vr);
    size_t n_set = 0, n_in = 0, n_out = 0;
    const char *x87_control = NULL;
    for (int a = 9; a < argc; a++) {
        if (strcmp(argv[a], "--set") == 0 && a + 3 < argc && strchr("ribs", argv[a + 1][0])) {
            kinds[n_set] = argv[a + 1][0];
            set_vr[n_set] = (VR)strtoul(argv[a + 2], NULL, 10);
            values[n_set++] = argv[a + 3];
            a += 3;
        } else if (strcmp(argv[a], "--input") == 0 && a + 1 < argc) {
            in_vr[n_in++] = (VR)strtoul(argv[++a], NULL, 10);
        } else if (strcmp(argv[a], "--output") == 0 && a + 1 < argc) {
            out_vr[n_out++] = (VR)strtoul(argv[++a], NULL, 10);
        } else if (strcmp(argv[a], "--x87-control") == 0 && a + 1 < argc) {
            x87_control = argv[++a];
        } else {
            fprintf(stderr, "bad argument %s\n", argv[a]);
            return USAGE;
        }
    }

    double *inputs = calloc((size_t)n_steps * n_in + 1, sizeof *inputs);
    double *outputs = calloc(((size_t)n_steps + 1) * n_out + 1, sizeof *outputs);
    FILE *file = fopen(inputs_file, "rb");
    if (!file || fread(inputs, sizeof *inputs, (size_t)n_steps * n_in, file) != (size_t)n_steps * n_in) {
        fprintf(stderr, "%s: cannot read %d x %u doubles\n", inputs_file, n_steps, (unsigned)n_in);
        return FILE_FAILED;
    }
    fclose(file);

    char path[4096];
    snprintf(path, sizeof path, "%s/binaries/%s/%s%s", dir, platform, id, LIBRARY_SUFFIX);
    native_separators(path);
    Library lib = open_library(path);
    if (!lib) {
        fprintf(stderr, "cannot load %s\n", path);
        return LOAD_FAILED;
    }
    const char *missing = look_up_functions(lib);
    if (missing) {
        fprintf(stderr, "%s: missing symbol %s\n", path, missing);
        return LOAD_FAILED;
    }
    /* after loading: a library's start-up code may reset the control word */
    if (x87_control && load_x87_control((unsigned short)strtoul(x87_control, NULL, 16)) != 0) {
        fprintf(stderr, "--x87-control %s: no x87 control word here\n", x87_control);
        return USAGE;
    }

    Instance c = instantiate(id, guid, dir);
    if (!c) return CALL_FAILED;
    CHECK(enter_initialization(c));
    for (size_t i = 0; i < n_set; i++) {
        if (kinds[i] == 'r') {
            double v = from_bits(values[i]);
            CHECK(set_reals(c, &set_vr[i], 1, &v));
        } else if (kinds[i] == 'i') {
            CHECK(set_integer(c, &set_vr[i], (Integer)atoi(values[i])));
        } else if (kinds[i] == 'b') {
            CHECK(set_boolean(c, &set_vr[i], strcmp(values[i], "true") == 0 || strcmp(values[i], "1") == 0));
        } else {
            CHECK(set_string(c, &set_vr[i], values[i]));
        }
    }
    CHECK(exit_initialization(c));
    if (n_out) CHECK(get_reals(c, out_vr, n_out, outputs));
    for (int k = 0; k < n_steps; k++) {
        if (n_in) CHECK(set_reals(c, in_vr, n_in, &inputs[(size_t)k * n_in]));
        CHECK(do_step(c, k * step, step));
        if (n_out) CHECK(get_reals(c, out_vr, n_out, &outputs[((size_t)k + 1) * n_out]));
    }
    CHECK(terminate(c));
    free_instance(c);
    if (close_library(lib) != 0) {
        fprintf(stderr, "unloading %s failed\n", path);
        return LOAD_FAILED;
    }

    file = fopen(outputs_file, "wb");
    size_t n_values = ((size_t)n_steps + 1) * n_out;
    if (!file || fwrite(outputs, sizeof *outputs, n_values, file) != n_values || fclose(file) != 0) {
        fprintf(stderr, "%s: cannot write the outputs\n", outputs_file);
        return FILE_FAILED;
    }
    free(inputs);
    free(outputs);
    free(kinds);
    free(values);
    free(set_vr);
    free(in_vr);
    free(out_vr);
    return OK;
}
