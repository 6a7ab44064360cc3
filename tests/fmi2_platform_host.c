/* An FMI 2.0 co-simulation host that builds for Linux (x86-64, aarch64) and Windows (MinGW-w64): it runs one
 * native FMU's binary for one platform on a recorded input, so the binaries of every platform can be compared with
 * the linux64 one bit for bit (tests/test_fmu_platforms.py runs it natively, under qemu-aarch64 and under Wine).
 *
 *   fmi2_platform_host PLATFORM UNZIPPED_DIR MODEL_IDENTIFIER GUID STEP N_STEPS INPUTS OUTPUTS
 *                      [--set real|int|bool|string VR VALUE]... [--input VR]... [--output VR]...
 *
 * Loads UNZIPPED_DIR/binaries/PLATFORM/MODEL_IDENTIFIER.{so,dll}; instantiates it with the resources of
 * UNZIPPED_DIR (a file:/// URI); sets the start values in initialization mode; then N_STEPS communication steps of
 * STEP seconds from t = 0, each after setting the --input values of that step from the file INPUTS.  It writes to
 * the file OUTPUTS the --output values after initialisation and after every step: (N_STEPS + 1) x outputs doubles.
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

#include "fmi2Functions.h"

enum { OK = 0, USAGE = 2, LOAD_FAILED = 3, CALL_FAILED = 4, FILE_FAILED = 5 };

static double from_bits(const char *hex) {
    uint64_t bits = (uint64_t)strtoull(hex, NULL, 16);
    double value;
    memcpy(&value, &bits, sizeof value);
    return value;
}

static const char *status_name(fmi2Status s) {
    static const char *names[] = {"OK", "Warning", "Discard", "Error", "Fatal", "Pending"};
    return (unsigned)s < 6 ? names[s] : "?";
}

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

static int failed(fmi2Status s, const char *call) {
    if (s <= fmi2Warning) return 0;
    fprintf(stderr, "%s returned fmi2%s\n", call, status_name(s));
    return 1;
}

#define SYMBOL(type, name)                                                                                             \
    type *name = (type *)library_symbol(lib, #name);                                                                   \
    if (!name) {                                                                                                       \
        fprintf(stderr, "%s: missing symbol %s\n", path, #name);                                                       \
        return LOAD_FAILED;                                                                                            \
    }
#define CHECK(call)                                                                                                    \
    if (failed((call), #call)) return CALL_FAILED

int main(int argc, char **argv) {
    if (argc < 9) {
        fprintf(stderr,
                "usage: %s PLATFORM UNZIPPED_DIR MODEL_IDENTIFIER GUID STEP N_STEPS INPUTS OUTPUTS "
                "[--set real|int|bool|string VR VALUE]... [--input VR]... [--output VR]...\n",
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
    fmi2ValueReference *set_vr = calloc((size_t)argc, sizeof *set_vr), *in_vr = calloc((size_t)argc, sizeof *in_vr),
                       *out_vr = calloc((size_t)argc, sizeof *out_vr);
    size_t n_set = 0, n_in = 0, n_out = 0;
    for (int a = 9; a < argc; a++) {
        if (strcmp(argv[a], "--set") == 0 && a + 3 < argc && strchr("ribs", argv[a + 1][0])) {
            kinds[n_set] = argv[a + 1][0];
            set_vr[n_set] = (fmi2ValueReference)strtoul(argv[a + 2], NULL, 10);
            values[n_set++] = argv[a + 3];
            a += 3;
        } else if (strcmp(argv[a], "--input") == 0 && a + 1 < argc) {
            in_vr[n_in++] = (fmi2ValueReference)strtoul(argv[++a], NULL, 10);
        } else if (strcmp(argv[a], "--output") == 0 && a + 1 < argc) {
            out_vr[n_out++] = (fmi2ValueReference)strtoul(argv[++a], NULL, 10);
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

    char path[4096], resources[4200];
    snprintf(path, sizeof path, "%s/binaries/%s/%s%s", dir, platform, id, LIBRARY_SUFFIX);
    native_separators(path);
    /* file:///C:/a/resources on Windows, file:///a/resources elsewhere */
    snprintf(resources, sizeof resources, "file://%s%s/resources", dir[0] == '/' ? "" : "/", dir);
    for (char *c = resources; *c; c++)
        if (*c == '\\') *c = '/';
    Library lib = open_library(path);
    if (!lib) {
        fprintf(stderr, "cannot load %s\n", path);
        return LOAD_FAILED;
    }
    SYMBOL(fmi2InstantiateTYPE, fmi2Instantiate)
    SYMBOL(fmi2SetupExperimentTYPE, fmi2SetupExperiment)
    SYMBOL(fmi2EnterInitializationModeTYPE, fmi2EnterInitializationMode)
    SYMBOL(fmi2ExitInitializationModeTYPE, fmi2ExitInitializationMode)
    SYMBOL(fmi2SetRealTYPE, fmi2SetReal)
    SYMBOL(fmi2SetIntegerTYPE, fmi2SetInteger)
    SYMBOL(fmi2SetBooleanTYPE, fmi2SetBoolean)
    SYMBOL(fmi2SetStringTYPE, fmi2SetString)
    SYMBOL(fmi2GetRealTYPE, fmi2GetReal)
    SYMBOL(fmi2DoStepTYPE, fmi2DoStep)
    SYMBOL(fmi2TerminateTYPE, fmi2Terminate)
    SYMBOL(fmi2FreeInstanceTYPE, fmi2FreeInstance)

    fmi2CallbackFunctions callbacks = {logger, calloc, free, NULL, NULL};
    fmi2Component c = fmi2Instantiate(id, fmi2CoSimulation, guid, resources, &callbacks, fmi2False, fmi2False);
    if (!c) {
        fprintf(stderr, "fmi2Instantiate returned NULL (resources %s)\n", resources);
        return CALL_FAILED;
    }
    CHECK(fmi2SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0));
    CHECK(fmi2EnterInitializationMode(c));
    for (size_t i = 0; i < n_set; i++) {
        if (kinds[i] == 'r') {
            fmi2Real v = from_bits(values[i]);
            CHECK(fmi2SetReal(c, &set_vr[i], 1, &v));
        } else if (kinds[i] == 'i') {
            fmi2Integer v = atoi(values[i]);
            CHECK(fmi2SetInteger(c, &set_vr[i], 1, &v));
        } else if (kinds[i] == 'b') {
            fmi2Boolean v = strcmp(values[i], "true") == 0 || strcmp(values[i], "1") == 0;
            CHECK(fmi2SetBoolean(c, &set_vr[i], 1, &v));
        } else {
            fmi2String v = values[i];
            CHECK(fmi2SetString(c, &set_vr[i], 1, &v));
        }
    }
    CHECK(fmi2ExitInitializationMode(c));
    if (n_out) CHECK(fmi2GetReal(c, out_vr, n_out, outputs));
    for (int k = 0; k < n_steps; k++) {
        if (n_in) CHECK(fmi2SetReal(c, in_vr, n_in, &inputs[(size_t)k * n_in]));
        CHECK(fmi2DoStep(c, k * step, step, fmi2True));
        if (n_out) CHECK(fmi2GetReal(c, out_vr, n_out, &outputs[((size_t)k + 1) * n_out]));
    }
    CHECK(fmi2Terminate(c));
    fmi2FreeInstance(c);
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
