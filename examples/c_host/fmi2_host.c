/* A minimal FMI 2.0 co-simulation host in C: what a non-Python FMI tool does with our FMUs.
 *
 *   fmi2_host UNZIPPED_FMU_DIR MODEL_IDENTIFIER GUID STEP N_STEPS [INPUT_VR VALUE] OUTPUT_VR...
 *
 * dlopen()s binaries/linux64/<id>.so, instantiates, initialises, holds one real input (optional,
 * "-" to skip), takes N_STEPS communication steps of STEP seconds and prints one CSV line per step:
 * time, then the requested real outputs.  Run it with libpython preloaded and PYTHONPATH pointing
 * at a site-packages with numpy, scipy (see docs/fmu.md).  It ends with _exit(): an embedded
 * interpreter that has loaded scipy may crash while finalising, after all results are written.
 */
#include <dlfcn.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "fmi2Functions.h"

static void logger(fmi2ComponentEnvironment env, fmi2String instance, fmi2Status status, fmi2String category,
                   fmi2String message, ...) {
    (void)env;
    fprintf(stderr, "[%s|%d|%s] %s\n", instance ? instance : "", (int)status, category ? category : "",
            message ? message : "");
}

#define LOAD(name)                                                                      \
    name##TYPE *name = (name##TYPE *)dlsym(lib, #name);                                 \
    if (!name) { fprintf(stderr, "missing symbol %s\n", #name); return 3; }

#define CHECK(call)                                                                     \
    do { fmi2Status s_ = (call); if (s_ > fmi2Warning) {                                \
        fprintf(stderr, "%s failed with status %d\n", #call, (int)s_); fflush(stdout); _exit(4); } } while (0)

int main(int argc, char **argv) {
    if (argc < 8) {
        fprintf(stderr, "usage: %s DIR ID GUID STEP N INPUT_VR|- [VALUE] OUTPUT_VR...\n", argv[0]);
        return 2;
    }
    const char *dir = argv[1], *id = argv[2], *guid = argv[3];
    double step = atof(argv[4]);
    int n_steps = atoi(argv[5]);
    int arg = 6;
    int has_input = strcmp(argv[arg], "-") != 0;
    fmi2ValueReference input_vr = 0;
    fmi2Real input_value = 0.0;
    if (has_input) {
        input_vr = (fmi2ValueReference)atoi(argv[arg++]);
        input_value = atof(argv[arg++]);
    } else {
        arg++;
    }
    int n_out = argc - arg;
    fmi2ValueReference *out_vr = calloc((size_t)n_out, sizeof *out_vr);
    fmi2Real *out = calloc((size_t)n_out, sizeof *out);
    for (int i = 0; i < n_out; i++) out_vr[i] = (fmi2ValueReference)atoi(argv[arg + i]);

    char path[4096], resources[4096];
    snprintf(path, sizeof path, "%s/binaries/linux64/%s.so", dir, id);
    snprintf(resources, sizeof resources, "file://%s/resources", dir);
    void *lib = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (!lib) { fprintf(stderr, "dlopen: %s\n", dlerror()); return 3; }
    LOAD(fmi2Instantiate) LOAD(fmi2SetupExperiment) LOAD(fmi2EnterInitializationMode)
    LOAD(fmi2ExitInitializationMode) LOAD(fmi2SetReal) LOAD(fmi2GetReal) LOAD(fmi2DoStep)
    LOAD(fmi2Terminate) LOAD(fmi2FreeInstance)

    fmi2CallbackFunctions callbacks = {logger, calloc, free, NULL, NULL};
    fmi2Component c = fmi2Instantiate("c_host", fmi2CoSimulation, guid, resources, &callbacks, fmi2False, fmi2False);
    if (!c) { fprintf(stderr, "fmi2Instantiate failed\n"); return 4; }
    CHECK(fmi2SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0));
    CHECK(fmi2EnterInitializationMode(c));
    CHECK(fmi2ExitInitializationMode(c));
    double t = 0.0;
    for (int k = 0; k < n_steps; k++) {
        if (has_input) CHECK(fmi2SetReal(c, &input_vr, 1, &input_value));
        CHECK(fmi2DoStep(c, t, step, fmi2True));
        t = (k + 1) * step;
        CHECK(fmi2GetReal(c, out_vr, (size_t)n_out, out));
        printf("%.17g", t);
        for (int i = 0; i < n_out; i++) printf(",%.17g", out[i]);
        printf("\n");
    }
    CHECK(fmi2Terminate(c));
    fmi2FreeInstance(c);
    fflush(stdout);
    _exit(0);
}
