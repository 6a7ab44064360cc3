/* A minimal FMI 2.0 co-simulation host in C: what a non-Python FMI tool does with our FMUs.
 *
 *   fmi2_host [--runs N] [--reload] [--quiet] [--clock-steps] STEP N_STEPS FMU [FMU...]
 *   FMU := --fmu UNZIPPED_DIR MODEL_IDENTIFIER GUID
 *          [--set real|int|bool|string VR VALUE]... [--input VR VALUE]... [--pulse VR VALUE DURATION]...
 *          [--output VR]...
 *
 * Each --fmu is dlopen()ed from UNZIPPED_DIR/binaries/linux64/<id>.so (two --fmu may name two
 * different FMUs, or the same one twice).  A run instantiates every FMU, sets the --set start
 * values in initialization mode, holds the real --input values and takes N_STEPS communication
 * steps of STEP seconds (the FMUs one after the other, not coupled), printing one CSV line per
 * FMU and step:  run, fmu index, time, the --output values.  Then fmi2Terminate and
 * fmi2FreeInstance for every instance.  --runs N does N runs in sequence, each with new instances;
 * the libraries stay loaded between runs unless --reload (dlclose and dlopen again).  --pulse holds VALUE on
 * input VR for the steps that start before DURATION s, then 0 (a hammer blow).  --quiet prints only each
 * FMU's last line per run.  --clock-steps passes each step as h = t(k+1) - t(k) with t(k) = k STEP, as
 * fmpy.simulate_fmu, libcosim and fmusim do: steps that differ from STEP in their last bits.  The stepping loop of each run (fmi2SetReal, fmi2DoStep, fmi2GetReal and the
 * printing) is timed with CLOCK_MONOTONIC and reported on stderr as "fmi2_host: run R: N steps x M FMUs in
 * S s (C us per cycle)".
 *
 * Every fmi2 status is checked and the FMUs' log messages go to stderr.  The libraries are
 * dlclose()d and main returns normally, so a crash while unloading or at process exit shows as a
 * non-zero exit status.  Exit status: 0 all good, 2 usage, 3 loading or unloading failed, 4 an FMI
 * call failed.  What the process environment must provide for our FMUs: docs/fmu.md.
 */
#ifndef _GNU_SOURCE
#define _GNU_SOURCE /* realpath */
#endif
#include <dlfcn.h>
#include <limits.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "fmi2Functions.h"

#define MAX_FMUS 8

enum { OK = 0, USAGE = 2, LOAD_FAILED = 3, CALL_FAILED = 4 };

typedef struct {
    char kind; /* 'r', 'i', 'b', 's' */
    fmi2ValueReference vr;
    const char *value;
} StartValue;

typedef struct {
    const char *dir, *id, *guid;
    char resources[PATH_MAX + 32];
    StartValue *starts;
    int n_starts;
    fmi2ValueReference *in_vr;
    fmi2Real *in_value;
    int n_in;
    fmi2ValueReference *out_vr;
    fmi2Real *out;
    int n_out;
    fmi2ValueReference *pulse_vr;
    fmi2Real *pulse_value, *pulse_until, *pulse_now;
    int n_pulse;
    void *lib;
    fmi2Component c;
    fmi2Status worst; /* of the current instance: after fmi2Error no fmi2Terminate, after fmi2Fatal no call */
    fmi2InstantiateTYPE *fmi2Instantiate;
    fmi2SetupExperimentTYPE *fmi2SetupExperiment;
    fmi2EnterInitializationModeTYPE *fmi2EnterInitializationMode;
    fmi2ExitInitializationModeTYPE *fmi2ExitInitializationMode;
    fmi2SetRealTYPE *fmi2SetReal;
    fmi2SetIntegerTYPE *fmi2SetInteger;
    fmi2SetBooleanTYPE *fmi2SetBoolean;
    fmi2SetStringTYPE *fmi2SetString;
    fmi2GetRealTYPE *fmi2GetReal;
    fmi2DoStepTYPE *fmi2DoStep;
    fmi2TerminateTYPE *fmi2Terminate;
    fmi2FreeInstanceTYPE *fmi2FreeInstance;
} Fmu;

static const char *status_name(fmi2Status s) {
    switch (s) {
    case fmi2OK: return "OK";
    case fmi2Warning: return "Warning";
    case fmi2Discard: return "Discard";
    case fmi2Error: return "Error";
    case fmi2Fatal: return "Fatal";
    case fmi2Pending: return "Pending";
    }
    return "?";
}

/* The FMI logger: the message is a printf format for the variadic arguments (FMI 2.0, 2.1.5). */
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

/* A failed call is reported with the FMU and the call; the worst status decides what may follow. */
static int check(Fmu *f, fmi2Status s, const char *call) {
    if (s > f->worst) f->worst = s;
    if (s <= fmi2Warning) return 1;
    fprintf(stderr, "%s: %s returned fmi2%s\n", f->id, call, status_name(s));
    return 0;
}
#define CALL(f, name, ...) check((f), (f)->name((f)->c, __VA_ARGS__), #name)
#define CALL0(f, name) check((f), (f)->name((f)->c), #name)

static int load(Fmu *f) {
    char path[PATH_MAX + 64];
    snprintf(path, sizeof path, "%s/binaries/linux64/%s.so", f->dir, f->id);
    f->lib = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (!f->lib) {
        fprintf(stderr, "dlopen: %s\n", dlerror());
        return 0;
    }
#define SYMBOL(name)                                                                                                   \
    do {                                                                                                               \
        *(void **)(&f->name) = dlsym(f->lib, #name);                                                                   \
        if (!f->name) {                                                                                                \
            fprintf(stderr, "%s: missing symbol %s\n", path, #name);                                                   \
            return 0;                                                                                                  \
        }                                                                                                              \
    } while (0)
    SYMBOL(fmi2Instantiate);
    SYMBOL(fmi2SetupExperiment);
    SYMBOL(fmi2EnterInitializationMode);
    SYMBOL(fmi2ExitInitializationMode);
    SYMBOL(fmi2SetReal);
    SYMBOL(fmi2SetInteger);
    SYMBOL(fmi2SetBoolean);
    SYMBOL(fmi2SetString);
    SYMBOL(fmi2GetReal);
    SYMBOL(fmi2DoStep);
    SYMBOL(fmi2Terminate);
    SYMBOL(fmi2FreeInstance);
#undef SYMBOL
    return 1;
}

static int unload(Fmu *f) {
    if (f->lib && dlclose(f->lib) != 0) {
        fprintf(stderr, "dlclose %s: %s\n", f->id, dlerror());
        f->lib = NULL;
        return 0;
    }
    f->lib = NULL;
    return 1;
}

static int set_start_values(Fmu *f) {
    for (int i = 0; i < f->n_starts; i++) {
        const StartValue *s = &f->starts[i];
        int ok;
        if (s->kind == 'r') {
            fmi2Real v = strtod(s->value, NULL);
            ok = CALL(f, fmi2SetReal, &s->vr, 1, &v);
        } else if (s->kind == 'i') {
            fmi2Integer v = atoi(s->value);
            ok = CALL(f, fmi2SetInteger, &s->vr, 1, &v);
        } else if (s->kind == 'b') {
            fmi2Boolean v = strcmp(s->value, "true") == 0 || strcmp(s->value, "1") == 0;
            ok = CALL(f, fmi2SetBoolean, &s->vr, 1, &v);
        } else {
            fmi2String v = s->value;
            ok = CALL(f, fmi2SetString, &s->vr, 1, &v);
        }
        if (!ok) return 0;
    }
    return 1;
}

/* One run: instantiate all, initialise, step, terminate, free.  Returns an exit status. */
static double now_s(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static int run_once(Fmu *fmus, int n_fmus, int run, double step, int n_steps, int quiet, int clock_steps) {
    fmi2CallbackFunctions callbacks = {logger, calloc, free, NULL, NULL};
    int status = OK, started = 0;
    for (int i = 0; i < n_fmus; i++) {
        Fmu *f = &fmus[i];
        char name[64];
        snprintf(name, sizeof name, "%s_%d_run%d", f->id, i, run);
        f->worst = fmi2OK;
        f->c = f->fmi2Instantiate(name, fmi2CoSimulation, f->guid, f->resources, &callbacks, fmi2False, fmi2True);
        if (!f->c) {
            fprintf(stderr, "%s: fmi2Instantiate returned NULL\n", f->id);
            status = CALL_FAILED;
            goto cleanup;
        }
        started = i + 1;
        if (!CALL(f, fmi2SetupExperiment, fmi2False, 0.0, 0.0, fmi2False, 0.0) || !CALL0(f, fmi2EnterInitializationMode)
            || !set_start_values(f) || !CALL0(f, fmi2ExitInitializationMode)) {
            status = CALL_FAILED;
            goto cleanup;
        }
    }
    double start = now_s();
    for (int k = 0; k < n_steps; k++) {
        double t = k * step;
        /* --clock-steps: each step as the difference of the host's clock, as fmpy.simulate_fmu, libcosim and
           fmusim compute it; it differs from STEP in its last bits */
        double h = clock_steps ? (k + 1) * step - t : step;
        for (int i = 0; i < n_fmus; i++) {
            Fmu *f = &fmus[i];
            for (int j = 0; j < f->n_pulse; j++) f->pulse_now[j] = t < f->pulse_until[j] ? f->pulse_value[j] : 0.0;
            if ((f->n_in && !CALL(f, fmi2SetReal, f->in_vr, (size_t)f->n_in, f->in_value))
                || (f->n_pulse && !CALL(f, fmi2SetReal, f->pulse_vr, (size_t)f->n_pulse, f->pulse_now))
                || !CALL(f, fmi2DoStep, t, h, fmi2True)) {
                status = CALL_FAILED;
                goto cleanup;
            }
        }
        for (int i = 0; i < n_fmus; i++) {
            Fmu *f = &fmus[i];
            if (f->n_out && !CALL(f, fmi2GetReal, f->out_vr, (size_t)f->n_out, f->out)) {
                status = CALL_FAILED;
                goto cleanup;
            }
            if (quiet && k + 1 < n_steps) continue;
            printf("%d,%d,%.17g", run, i, (k + 1) * step);
            for (int j = 0; j < f->n_out; j++) printf(",%.17g", f->out[j]);
            printf("\n");
        }
    }
    double elapsed = now_s() - start;
    fprintf(stderr, "fmi2_host: run %d: %d steps x %d FMUs in %.6f s (%.4f us per cycle)\n", run, n_steps, n_fmus,
            elapsed, n_steps > 0 ? 1e6 * elapsed / ((double)n_steps * n_fmus) : 0.0);
    for (int i = 0; i < n_fmus; i++)
        if (!CALL0(&fmus[i], fmi2Terminate)) status = CALL_FAILED;
cleanup:
    fflush(stdout);
    for (int i = 0; i < started; i++) {
        Fmu *f = &fmus[i];
        if (f->worst == fmi2Fatal) { /* FMI 2.0: no call after fmi2Fatal, not even fmi2FreeInstance */
            fprintf(stderr, "%s: instance leaked after fmi2Fatal\n", f->id);
        } else {
            f->fmi2FreeInstance(f->c);
        }
        f->c = NULL;
    }
    return status;
}

static int usage(const char *program, const char *problem) {
    fprintf(stderr,
            "%s\nusage: %s [--runs N] [--reload] [--quiet] [--clock-steps] STEP N_STEPS --fmu DIR ID GUID "
            "[--set real|int|bool|string VR VALUE]... [--input VR VALUE]... [--pulse VR VALUE DURATION]... "
            "[--output VR]... [--fmu ...]\n",
            problem, program);
    return USAGE;
}

int main(int argc, char **argv) {
    Fmu fmus[MAX_FMUS];
    int n_fmus = 0, runs = 1, reload = 0, quiet = 0, clock_steps = 0, arg = 1;
    memset(fmus, 0, sizeof fmus);
    for (; arg < argc && strncmp(argv[arg], "--", 2) == 0 && strcmp(argv[arg], "--fmu") != 0; arg++) {
        if (strcmp(argv[arg], "--runs") == 0 && arg + 1 < argc)
            runs = atoi(argv[++arg]);
        else if (strcmp(argv[arg], "--reload") == 0)
            reload = 1;
        else if (strcmp(argv[arg], "--quiet") == 0)
            quiet = 1;
        else if (strcmp(argv[arg], "--clock-steps") == 0)
            clock_steps = 1;
        else
            return usage(argv[0], "unknown option");
    }
    if (argc - arg < 2 || runs < 1) return usage(argv[0], "missing STEP N_STEPS");
    double step = strtod(argv[arg], NULL);
    int n_steps = atoi(argv[arg + 1]);
    arg += 2;
    /* Each FMU's lists have at most as many entries as there are arguments. */
    size_t cap = (size_t)argc;
    for (; arg < argc; arg++) {
        Fmu *f = n_fmus ? &fmus[n_fmus - 1] : NULL;
        if (strcmp(argv[arg], "--fmu") == 0 && arg + 3 < argc) {
            if (n_fmus == MAX_FMUS) return usage(argv[0], "too many --fmu");
            f = &fmus[n_fmus++];
            f->dir = argv[arg + 1];
            f->id = argv[arg + 2];
            f->guid = argv[arg + 3];
            f->starts = calloc(cap, sizeof *f->starts);
            f->in_vr = calloc(cap, sizeof *f->in_vr);
            f->in_value = calloc(cap, sizeof *f->in_value);
            f->out_vr = calloc(cap, sizeof *f->out_vr);
            f->out = calloc(cap, sizeof *f->out);
            f->pulse_vr = calloc(cap, sizeof *f->pulse_vr);
            f->pulse_value = calloc(cap, sizeof *f->pulse_value);
            f->pulse_until = calloc(cap, sizeof *f->pulse_until);
            f->pulse_now = calloc(cap, sizeof *f->pulse_now);
            char absolute[PATH_MAX];
            if (!realpath(f->dir, absolute)) return usage(argv[0], "no such UNZIPPED_DIR");
            snprintf(f->resources, sizeof f->resources, "file://%s/resources", absolute);
            arg += 3;
        } else if (f && strcmp(argv[arg], "--set") == 0 && arg + 3 < argc) {
            StartValue *s = &f->starts[f->n_starts++];
            s->kind = argv[arg + 1][0];
            if (!strchr("ribs", s->kind)) return usage(argv[0], "--set type is real, int, bool or string");
            s->vr = (fmi2ValueReference)strtoul(argv[arg + 2], NULL, 10);
            s->value = argv[arg + 3];
            arg += 3;
        } else if (f && strcmp(argv[arg], "--input") == 0 && arg + 2 < argc) {
            f->in_vr[f->n_in] = (fmi2ValueReference)strtoul(argv[arg + 1], NULL, 10);
            f->in_value[f->n_in++] = strtod(argv[arg + 2], NULL);
            arg += 2;
        } else if (f && strcmp(argv[arg], "--pulse") == 0 && arg + 3 < argc) {
            f->pulse_vr[f->n_pulse] = (fmi2ValueReference)strtoul(argv[arg + 1], NULL, 10);
            f->pulse_value[f->n_pulse] = strtod(argv[arg + 2], NULL);
            f->pulse_until[f->n_pulse++] = strtod(argv[arg + 3], NULL);
            arg += 3;
        } else if (f && strcmp(argv[arg], "--output") == 0 && arg + 1 < argc) {
            f->out_vr[f->n_out++] = (fmi2ValueReference)strtoul(argv[arg + 1], NULL, 10);
            arg += 1;
        } else {
            return usage(argv[0], "bad FMU arguments");
        }
    }
    if (!n_fmus) return usage(argv[0], "no --fmu");

    int status = OK;
    for (int i = 0; i < n_fmus; i++)
        if (!load(&fmus[i])) {
            status = LOAD_FAILED;
            goto unload;
        }
    for (int run = 0; run < runs && status == OK; run++) {
        if (run > 0 && reload) {
            for (int i = 0; i < n_fmus; i++)
                if (!unload(&fmus[i]) || !load(&fmus[i])) {
                    status = LOAD_FAILED;
                    goto unload;
                }
        }
        status = run_once(fmus, n_fmus, run, step, n_steps, quiet, clock_steps);
    }
unload:
    for (int i = 0; i < n_fmus; i++)
        if (!unload(&fmus[i]) && status == OK) status = LOAD_FAILED;
    for (int i = 0; i < n_fmus; i++) {
        free(fmus[i].starts);
        free(fmus[i].in_vr);
        free(fmus[i].in_value);
        free(fmus[i].out_vr);
        free(fmus[i].out);
        free(fmus[i].pulse_vr);
        free(fmus[i].pulse_value);
        free(fmus[i].pulse_until);
        free(fmus[i].pulse_now);
    }
    fprintf(stderr, "fmi2_host: done, exit status %d\n", status);
    return status;
}
