/*
 * native_moordyn.c - the "moordyn" kind of the native runtime (native_kind.h): the Mooring FMU's three catenary lines
 * (flexfmu.wec.mooring, whose docstring states the equations) simulated by MoorDyn-C, loaded at run time from the
 * FMU's own binaries folder.  It does what flexfmu.wec.mooring.MooringSimulator does, call for call on the same
 * MoorDyn library:
 *
 *   - the fairleads follow the body's motion at the inputs: p_i = pos + R r_i, v_i = vel + omega x (R r_i), R = exp of
 *     the rotation vector rot (Rodrigues; the series below 1e-8 rad), in the simulator's order of operations;
 *   - the lines (one MoorDyn instance) are made when first needed (the outputs at initialisation, or a step) with the
 *     fairleads where the inputs hold them, at rest: MoorDyn_Create of the input file, MoorDyn_Init (its static
 *     initial condition), the forces at that state (MoorDyn_Step of 0 s);
 *   - a communication step h is one MoorDyn_Step over h with the inputs of its start held (MoorDyn moves each
 *     fairlead at its held velocity and takes internal steps of internal_time_step); more than max internal steps
 *     ceil(h / internal_time_step) is refused with fmi2Discard (a smaller step may be taken);
 *   - the outputs are the forces at the step's end about O moved on at vel: F = sum f_i, M = sum (arm_i x f_i) with
 *     arm_i = R r_i + h omega x (R r_i), and the fairlead tensions |f_i|;
 *   - a fairlead under the sea floor or beyond its line's length from its anchor at the step's start or end is
 *     refused (fmi2Error) naming the input that moves it farthest that way, as the simulator's _check_reach;
 *   - a MoorDyn_Step that fails (NaN in the nodes) is refused (fmi2Error) and the instance's MoorDyn state is lost:
 *     every later step or output is refused until an FMU state saved before is restored;
 *   - enabled = false makes no MoorDyn instance: the outputs are zero.
 *
 * The FMU state: the bridge's state vector is empty (nx = 0); the kind's own state (save / restore / check_saved) is
 * MoorDyn's serialised state (MoorDyn_Serialize / MoorDyn_Deserialize) with the time, the outputs, the fairleads
 * MoorDyn was last given and why the state was lost, in this layout (little-endian):
 *
 *   "FXMOORDY", u32 STATE_VERSION, u32 flags (1: MoorDyn's lines, 2: enabled), f64 t, f64 outputs[9] (F, M,
 *   tensions), f64 fairleads[9] (earth frame), u32 n, n bytes (why the state was lost, "" if not), u64 m, m bytes
 *   (MoorDyn_Serialize's; 0 without lines), u64 checksum of every byte before it (FNV-1a 64 over 8-byte words).
 *
 * A state whose checksum differs is refused (a damaged state); MoorDyn_Deserialize reads as many bytes as its system
 * serialises and is given only data of exactly that size.  (The checksum finds damage, not a state crafted to pass.)
 *
 * MoorDyn's shared library: dlopen'ed (RTLD_LOCAL) from the folder of the FMU's binary (dladdr of a function here),
 * the file named by the model file; the build copies it there (flexfmu/fmi/native_mooring.py).  It is built for Linux
 * x86-64 only: on another platform the kind refuses at fmi2Instantiate, saying what a native Mooring there needs.
 *
 * Console output: MoorDyn_SetVerbosity(MOORDYN_NO_OUTPUT) right after MoorDyn_Create silences everything after it;
 * MoorDyn_Create itself prints its banner and set-up to standard output before any verbosity can be set, so standard
 * output (file descriptor 1) is sent to /dev/null for the call (flushed before and after, under a process-wide lock
 * so that two instances never interleave the redirection; another thread's writes to standard output in those few
 * milliseconds are lost too).  The lock is this file's one global: standard output is the process's.  MoorDyn's
 * error messages (standard error) are left alone.
 *
 * The instance's input file is written to a private temporary folder (mkdtemp under TMPDIR, else /tmp), made with the
 * first lines and removed with the instance (the folder and every file in it).
 *
 * Model-file entries (flexfmu/fmi/native_mooring.py writes them):
 *   moordyn.input      string: MoorDyn's input file (flexfmu.wec.mooring.moordyn_input of the build's configuration)
 *   moordyn.library    string: the file name of MoorDyn's shared library beside the FMU's binary
 *   moordyn.fairleads  float64 (3, 3): the fairleads in the body frame, from O (m)
 *   moordyn.anchors    float64 (3, 3): the anchors, earth frame (m)
 *   moordyn.real       float64 (4): line_length (m), depth (m), internal_time_step (s), max internal steps
 *   moordyn.enabled    int32 (2): the runtime parameter (index) enabled is, or -1; its build value (0 / 1)
 */
#if !defined(_WIN32) && !defined(_GNU_SOURCE)
#define _GNU_SOURCE /* dladdr, mkdtemp */
#endif
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "flexfmu_bridge.h"
#include "native_kind.h"

#if defined(__linux__) && defined(__x86_64__)
#define MOORDYN_SUPPORTED 1
#include <dirent.h>
#include <dlfcn.h>
#include <fcntl.h>
#include <pthread.h>
#include <unistd.h>
#else
#define MOORDYN_SUPPORTED 0
#endif

#define N_LINES 3
#define N_INPUTS 12
#define N_OUTPUTS 9
#define MOORDYN_NO_OUTPUT 4096 /* MoorDynAPI.h: no message reaches this level */
#define STATE_VERSION 1u
#define STATE_HEAD (8 + 4 + 4 + 8 + 8 * N_OUTPUTS + 8 * 3 * N_LINES) /* up to the failure text's length */
#define FAILURE_SIZE 1024

static const char STATE_MAGIC[8] = {'F', 'X', 'M', 'O', 'O', 'R', 'D', 'Y'};
/* the simulator's INPUT_NAMES and OUTPUT_NAMES: matched by name against the FMU's */
static const char *const INPUTS[N_INPUTS] = {"pos_x", "pos_y", "pos_z", "rot_x",   "rot_y",   "rot_z",
                                             "vel_x", "vel_y", "vel_z", "omega_x", "omega_y", "omega_z"};
static const char *const OUTPUTS[N_OUTPUTS]
    = {"F_x", "F_y", "F_z", "M_x", "M_y", "M_z", "tension_1", "tension_2", "tension_3"};
enum { POS = 0, ROT = 3, VEL = 6, OMEGA = 9 };

typedef struct {
    NativeLayout layout;
    int in[N_INPUTS];   /* the FMU's input index of each of INPUTS */
    int out[N_OUTPUTS]; /* the FMU's output index of each of OUTPUTS */
    const char *input;  /* MoorDyn's input file */
    double fairleads[N_LINES][3], anchors[N_LINES][3];
    double line_length, depth, dt, max_steps;
    int enabled_role;
    double enabled_fixed;
    void *library; /* dlopen handle */
    void *(*create)(const char *);
    int (*set_verbosity)(void *, int);
    int (*init)(void *, const double *, const double *);
    int (*init_noic)(void *, const double *, const double *);
    int (*step)(void *, const double *, const double *, double *, double *, double *);
    int (*serialize)(void *, size_t *, uint64_t *);
    int (*deserialize)(void *, const uint64_t *);
    int (*close)(void *);
} MoordynModel;

typedef struct {
    const MoordynModel *m;
    int enabled;
    void *system;               /* the lines (a MoorDyn instance); NULL: none yet, disabled, or lost */
    size_t serialized;          /* MoorDyn_Serialize's size of this system (bytes) */
    char folder[4096];          /* the private folder of the input file ("": none yet) */
    double t;                   /* the time since the start of the state the outputs are of (s) */
    double loads[N_OUTPUTS];    /* F (3), M (3) about O, tensions (3): the outputs (OUTPUTS order) */
    double given[3 * N_LINES];  /* the fairleads (earth frame) MoorDyn was last given */
    char failure[FAILURE_SIZE]; /* why MoorDyn's state was lost (a failed step), else "" */
} MoordynSim;

/* The body's motion at the inputs: pos, vel, the arms R r_i and the fairleads' velocities (earth frame). */
typedef struct {
    double pos[3], rot[3], vel[3], omega[3];
    double arms[N_LINES][3], velocities[N_LINES][3];
} Motion;

/* ---- the motion (flexfmu.wec.mooring: rotation, MooringSimulator._motion) -------------------------------------- */

static void cross(const double *a, const double *b, double *c) {
    c[0] = a[1] * b[2] - a[2] * b[1];
    c[1] = a[2] * b[0] - a[0] * b[2];
    c[2] = a[0] * b[1] - a[1] * b[0];
}

/* exp([rot]x) by Rodrigues' formula, as flexfmu.wec.mooring.rotation (the same operations in the same order) */
static void rotation(const double *rot, double R[3][3]) {
    double angle = sqrt(rot[0] * rot[0] + rot[1] * rot[1] + rot[2] * rot[2]);
    double K[3][3] = {{0.0, -rot[2], rot[1]}, {rot[2], 0.0, -rot[0]}, {-rot[1], rot[0], 0.0}};
    double a = 1.0, b = 0.5; /* the series: 1 - angle^2 / 6 and 1/2 - angle^2 / 24 are exact here */
    if (!(angle < 1e-8)) a = sin(angle) / angle, b = (1.0 - cos(angle)) / (angle * angle);
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            double kk = 0.0;
            for (int l = 0; l < 3; l++) kk += (b * K[i][l]) * K[l][j];
            double linear = angle < 1e-8 ? K[i][j] : a * K[i][j];
            R[i][j] = ((i == j ? 1.0 : 0.0) + linear) + kk;
        }
}

static void motion_of(const MoordynModel *m, const double *u, Motion *mo) {
    for (int a = 0; a < 3; a++) {
        mo->pos[a] = u[m->in[POS + a]], mo->rot[a] = u[m->in[ROT + a]];
        mo->vel[a] = u[m->in[VEL + a]], mo->omega[a] = u[m->in[OMEGA + a]];
    }
    double R[3][3];
    rotation(mo->rot, R);
    for (int i = 0; i < N_LINES; i++) {
        double turn[3];
        for (int a = 0; a < 3; a++) /* r_body @ R.T */
            mo->arms[i][a] = m->fairleads[i][0] * R[a][0] + m->fairleads[i][1] * R[a][1] + m->fairleads[i][2] * R[a][2];
        cross(mo->omega, mo->arms[i], turn);
        for (int a = 0; a < 3; a++) mo->velocities[i][a] = mo->vel[a] + turn[a];
    }
}

/* The fairleads pos + arms (earth frame), as MoorDyn is given them. */
static void fairlead_positions(const Motion *mo, double *x) {
    for (int i = 0; i < N_LINES; i++)
        for (int a = 0; a < 3; a++) x[3 * i + a] = mo->pos[a] + mo->arms[i][a];
}

/* MooringSimulator._check_reach: every fairlead above the sea floor and within its line's length of its anchor at the
   step's start (h = 0) or end, else fmi2Error naming the input that moves it farthest that way. */
static int check_reach(const MoordynSim *s, const double *u, const Motion *mo, double t, double h, NativeResult *r) {
    const MoordynModel *m = s->m;
    double points[N_LINES][3], span[N_LINES];
    int reach = 1, floor = 0;
    for (int i = 0; i < N_LINES; i++) {
        double d[3];
        for (int a = 0; a < 3; a++) {
            points[i][a] = (mo->pos[a] + mo->arms[i][a]) + h * mo->velocities[i][a];
            d[a] = points[i][a] - m->anchors[i][a];
        }
        span[i] = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        reach &= span[i] <= m->line_length;
        floor |= !(points[i][2] > -m->depth);
    }
    if (reach && !floor) return BRIDGE_OK;
    int i = 0;
    double direction[3];
    char what[160];
    if (floor) { /* the lowest fairlead */
        for (int k = 1; k < N_LINES; k++)
            if (points[k][2] < points[i][2]) i = k;
        direction[0] = 0.0, direction[1] = 0.0, direction[2] = -1.0;
        snprintf(what, sizeof what, "under the sea floor (z = %.6g m)", points[i][2]);
    } else { /* the farthest from its anchor */
        for (int k = 1; k < N_LINES; k++)
            if (span[k] > span[i]) i = k;
        for (int a = 0; a < 3; a++) direction[a] = (points[i][a] - m->anchors[i][a]) / span[i];
        snprintf(what, sizeof what, "%.6g m from its anchor", span[i]);
    }
    /* each input's share of the fairlead's motion that way (rotations to first order), in the simulator's order */
    double turn[3];
    for (int k = 0; k < 3; k++) {
        double e[3] = {0.0, 0.0, 0.0}, c[3];
        e[k] = 1.0;
        cross(e, mo->arms[i], c);
        turn[k] = direction[0] * c[0] + direction[1] * c[1] + direction[2] * c[2];
    }
    int best = -1;
    double best_share = 0.0;
    for (int k = 0; k < 3; k++) {
        double share[4] = {direction[k] * mo->pos[k], turn[k] * mo->rot[k], h * direction[k] * mo->vel[k],
                           h * turn[k] * mo->omega[k]};
        int group[4] = {POS, ROT, VEL, OMEGA};
        for (int g = 0; g < 4; g++)
            if (best < 0 || share[g] > best_share) best = group[g] + k, best_share = share[g];
    }
    const char *name = m->layout.input_names[m->in[best]];
    char value[64], at[64];
    native_repr(u[m->in[best]], value, sizeof value);
    native_repr(t, at, sizeof at);
    return native_refuse(r, BRIDGE_ERROR,
                         "%s: %s puts fairlead %d %s at the %s of the step from t = %s s (allowed: motions that keep "
                         "every fairlead above the sea floor and within line_length = %g m of its anchor)",
                         name, value, i + 1, what, h != 0.0 ? "end" : "start", at, m->line_length);
}

/* MooringSimulator._set_loads: F, M about O (arms: the arms at the forces' time) and the tensions of the forces f on
   the fairleads; a refusal when they are not finite. */
static int set_loads(MoordynSim *s, const double *f, double arms[N_LINES][3], double t, NativeResult *r) {
    for (int k = 0; k < 3 * N_LINES; k++)
        if (!isfinite(f[k])) {
            char at[64];
            native_repr(t, at, sizeof at);
            return native_refuse(r, BRIDGE_ERROR, "state: MoorDyn's line forces are not finite at t = %s s", at);
        }
    double M[N_LINES][3];
    for (int i = 0; i < N_LINES; i++) cross(arms[i], f + 3 * i, M[i]);
    for (int a = 0; a < 3; a++) {
        s->loads[a] = (f[a] + f[3 + a]) + f[6 + a];
        s->loads[3 + a] = (M[0][a] + M[1][a]) + M[2][a];
    }
    for (int i = 0; i < N_LINES; i++) {
        const double *fi = f + 3 * i;
        s->loads[6 + i] = sqrt((fi[0] * fi[0] + fi[1] * fi[1]) + fi[2] * fi[2]);
    }
    return BRIDGE_OK;
}

/* ---- MoorDyn ------------------------------------------------------------------------------------------------- */

#if MOORDYN_SUPPORTED
/* standard output is the process's: one instance at a time sends it to /dev/null */
static pthread_mutex_t stdout_lock = PTHREAD_MUTEX_INITIALIZER;

/* MoorDyn_Create with its banner and set-up (printed to standard output before any verbosity can be set) sent to
   /dev/null, then no output at all (MoorDyn_SetVerbosity). */
static void *quiet_create(const MoordynModel *m, const char *path) {
    pthread_mutex_lock(&stdout_lock);
    fflush(stdout); /* what the host wrote before goes where it belongs */
    int saved = dup(1), devnull = saved >= 0 ? open("/dev/null", O_WRONLY) : -1;
    int redirected = devnull >= 0 && dup2(devnull, 1) >= 0;
    void *system = m->create(path);
    if (system) m->set_verbosity(system, MOORDYN_NO_OUTPUT);
    fflush(stdout); /* std::cout writes through C's stdout (synchronised): its buffer, before fd 1 returns */
    if (redirected) dup2(saved, 1);
    if (devnull >= 0) close(devnull);
    if (saved >= 0) close(saved);
    pthread_mutex_unlock(&stdout_lock);
    return system;
}

static void remove_folder(char *folder) {
    if (!folder[0]) return;
    DIR *dir = opendir(folder);
    if (dir) {
        struct dirent *entry;
        char path[4400];
        while ((entry = readdir(dir)) != NULL) {
            if (strcmp(entry->d_name, ".") == 0 || strcmp(entry->d_name, "..") == 0) continue;
            snprintf(path, sizeof path, "%s/%s", folder, entry->d_name);
            unlink(path);
        }
        closedir(dir);
    }
    rmdir(folder);
    folder[0] = '\0';
}

/* The instance's folder with MoorDyn's input file; its path in `path`. */
static int write_input(MoordynSim *s, char *path, size_t size, NativeResult *r) {
    if (!s->folder[0]) {
        const char *tmp = getenv("TMPDIR");
        if (!tmp || !*tmp) tmp = "/tmp";
        snprintf(s->folder, sizeof s->folder, "%s/flexfmu_mooring_XXXXXX", tmp);
        if (!mkdtemp(s->folder)) {
            s->folder[0] = '\0';
            return native_refuse(r, BRIDGE_ERROR,
                                 "enabled: cannot make a temporary folder for MoorDyn's input file under %s (allowed: "
                                 "a writable TMPDIR, or enabled = false)",
                                 tmp);
        }
    }
    snprintf(path, size, "%s/lines.txt", s->folder);
    FILE *file = fopen(path, "wb");
    size_t n = strlen(s->m->input);
    int ok = file && fwrite(s->m->input, 1, n, file) == n;
    if (file) ok &= fclose(file) == 0;
    if (!ok)
        return native_refuse(r, BRIDGE_ERROR,
                             "enabled: cannot write MoorDyn's input file %s (allowed: a writable "
                             "TMPDIR, or enabled = false)",
                             path);
    return BRIDGE_OK;
}
#else
/* Another platform: the kind refuses at load (MoorDyn's library is linux64's), so none of these runs. */
static void *quiet_create(const MoordynModel *m, const char *path) { return (void)m, (void)path, NULL; }
static void remove_folder(char *folder) { folder[0] = '\0'; }
static int write_input(MoordynSim *s, char *path, size_t size, NativeResult *r) {
    (void)s, (void)path, (void)size;
    return native_refuse(r, BRIDGE_ERROR, "MoorDyn: not available on this platform");
}
#endif

static void close_lines(MoordynSim *s) {
    if (s->system) s->m->close(s->system);
    s->system = NULL;
    s->serialized = 0;
}

/* _Lines: the lines with the fairleads at x, at rest: MoorDyn's static initial condition (restoring: none, the state
   comes next). */
static int make_lines(MoordynSim *s, const double *x, int restoring, NativeResult *r) {
    const MoordynModel *m = s->m;
    char path[4200];
    if (write_input(s, path, sizeof path, r) != BRIDGE_OK) return r->status;
    void *system = quiet_create(m, path);
    if (!system)
        return native_refuse(r, BRIDGE_ERROR,
                             "MoorDyn: could not read the lines' input file (allowed: parameters within their ranges "
                             "(VARIABLE_INFO))");
    double v[3 * N_LINES] = {0.0};
    int status = (restoring ? m->init_noic : m->init)(system, x, v);
    size_t size = 0;
    if (status == 0) status = m->serialize(system, &size, NULL);
    if (status != 0) {
        m->close(system);
        return native_refuse(r, BRIDGE_ERROR,
                             "MoorDyn: could not set the lines up (its error code %d) (allowed: parameters within "
                             "their ranges (VARIABLE_INFO))",
                             status);
    }
    s->system = system;
    s->serialized = size;
    memcpy(s->given, x, sizeof s->given);
    return BRIDGE_OK;
}

static int lost(const MoordynSim *s, NativeResult *r) {
    return native_refuse(r, BRIDGE_ERROR, "state: %s (allowed: restore an FMU state saved before, or a new instance)",
                         s->failure);
}

/* MooringSimulator._ensure_lines: the lines at the inputs u when there are none yet (enabled), their forces the
   outputs. */
static int ensure_lines(MoordynSim *s, const double *u, NativeResult *r) {
    if (s->failure[0]) return lost(s, r);
    if (s->system || !s->enabled) return BRIDGE_OK;
    Motion mo;
    motion_of(s->m, u, &mo);
    if (check_reach(s, u, &mo, s->t, 0.0, r) != BRIDGE_OK) return r->status;
    double x[3 * N_LINES], v[3 * N_LINES] = {0.0}, f[3 * N_LINES] = {0.0}, t = s->t, dt = 0.0;
    fairlead_positions(&mo, x);
    if (make_lines(s, x, 0, r) != BRIDGE_OK) return r->status;
    int status = s->m->step(s->system, x, v, f, &t, &dt); /* dt = 0: the forces of the state, no step */
    if (status != 0) {
        close_lines(s);
        return native_refuse(r, BRIDGE_ERROR, "MoorDyn: could not give the lines' forces (its error code %d)", status);
    }
    return set_loads(s, f, mo.arms, s->t, r);
}

/* ---- the kind -------------------------------------------------------------------------------------------------- */

static void free_model(void *model) {
    MoordynModel *m = model;
    if (!m) return;
#if MOORDYN_SUPPORTED
    if (m->library) dlclose(m->library);
#endif
    free(m);
}

#if MOORDYN_SUPPORTED
/* MoorDyn's library from the folder of this FMU's binary. */
static int open_library(MoordynModel *m, const char *name, char *why, size_t why_size) {
    Dl_info info;
    char path[4400];
    if (!dladdr((void *)&open_library, &info) || !info.dli_fname) {
        snprintf(why, why_size, "MoorDyn: cannot find the folder of this FMU's binary (dladdr)");
        return -1;
    }
    const char *slash = strrchr(info.dli_fname, '/');
    int folder = slash ? (int)(slash - info.dli_fname) : 1;
    snprintf(path, sizeof path, "%.*s/%s", folder, slash ? info.dli_fname : ".", name);
    if (!(m->library = dlopen(path, RTLD_NOW | RTLD_LOCAL))) {
        const char *error = dlerror();
        snprintf(why, why_size,
                 "MoorDyn: cannot load its shared library %s (%s): the FMU's build copies it beside the FMU's "
                 "binary (rebuild with flexfmu build --runtime native --fmu Mooring; it needs libstdc++.so.6)",
                 path, error ? error : "?");
        return -1;
    }
    struct {
        const char *name;
        void *slot; /* a function pointer's storage: dlsym's address copied into it (POSIX: same representation) */
    } symbols[] = {{"MoorDyn_Create", &m->create},
                   {"MoorDyn_SetVerbosity", &m->set_verbosity},
                   {"MoorDyn_Init", &m->init},
                   {"MoorDyn_Init_NoIC", &m->init_noic},
                   {"MoorDyn_Step", &m->step},
                   {"MoorDyn_Serialize", &m->serialize},
                   {"MoorDyn_Deserialize", &m->deserialize},
                   {"MoorDyn_Close", &m->close}};
    for (size_t k = 0; k < sizeof symbols / sizeof *symbols; k++) {
        void *address = dlsym(m->library, symbols[k].name);
        if (!address) {
            snprintf(why, why_size, "MoorDyn: its library %s has no %s (allowed: MoorDyn-C 2.3 or later)", path,
                     symbols[k].name);
            return -1;
        }
        memcpy(symbols[k].slot, &address, sizeof address);
    }
    return 0;
}
#endif

static int find_name(const char *const *names, size_t n, const char *name) {
    for (size_t k = 0; k < n; k++)
        if (strcmp(names[k], name) == 0) return (int)k;
    return -1;
}

static void *load(const NativeFile *file, const NativeLayout *layout, char *why, size_t why_size) {
    MoordynModel *m = calloc(1, sizeof *m);
    if (!m) {
        snprintf(why, why_size, "out of memory");
        return NULL;
    }
    m->layout = *layout;
    if (layout->n_inputs != N_INPUTS || layout->n_outputs != N_OUTPUTS) {
        snprintf(why, why_size, "the model file's Mooring has %zu inputs and %zu outputs (expected %d and %d)",
                 layout->n_inputs, layout->n_outputs, N_INPUTS, N_OUTPUTS);
        goto fail;
    }
    for (int k = 0; k < N_INPUTS; k++)
        if ((m->in[k] = find_name(layout->input_names, layout->n_inputs, INPUTS[k])) < 0) {
            snprintf(why, why_size, "the model file's Mooring has no input %s", INPUTS[k]);
            goto fail;
        }
    for (int k = 0; k < N_OUTPUTS; k++)
        if ((m->out[k] = find_name(layout->output_names, layout->n_outputs, OUTPUTS[k])) < 0) {
            snprintf(why, why_size, "the model file's Mooring has no output %s", OUTPUTS[k]);
            goto fail;
        }
    const NativeEntry *input = native_entry(file, "moordyn.input"), *library = native_entry(file, "moordyn.library");
    const double *fairleads, *anchors, *real;
    const int32_t *enabled;
    long s33[2] = {N_LINES, 3}, four[1] = {4}, two[1] = {2};
    if (!input || input->type != NATIVE_STR || input->ndim != 0 || !library || library->type != NATIVE_STR
        || library->ndim != 0) {
        snprintf(why, why_size, "the model file has no strings moordyn.input and moordyn.library");
        goto fail;
    }
    if (native_f64(file, "moordyn.fairleads", 2, s33, &fairleads, NULL, why, why_size) < 0
        || native_f64(file, "moordyn.anchors", 2, s33, &anchors, NULL, why, why_size) < 0
        || native_f64(file, "moordyn.real", 1, four, &real, NULL, why, why_size) < 0
        || native_i32(file, "moordyn.enabled", 1, two, &enabled, NULL, why, why_size) < 0)
        goto fail;
    m->input = ((char *const *)input->data)[0];
    memcpy(m->fairleads, fairleads, sizeof m->fairleads);
    memcpy(m->anchors, anchors, sizeof m->anchors);
    m->line_length = real[0], m->depth = real[1], m->dt = real[2], m->max_steps = real[3];
    m->enabled_role = enabled[0], m->enabled_fixed = enabled[1];
    if (!(m->line_length > 0 && m->depth > 0 && m->dt > 0 && m->max_steps >= 1)
        || m->enabled_role >= (int)layout->n_params) {
        snprintf(why, why_size, "the model file's moordyn entries are inconsistent");
        goto fail;
    }
#if MOORDYN_SUPPORTED
    if (open_library(m, ((char *const *)library->data)[0], why, why_size) < 0) goto fail;
    return m;
#else
    snprintf(why, why_size,
             "the native Mooring loads MoorDyn's shared library, which this FMU carries for linux64 only: a native "
             "Mooring on this platform would need MoorDyn (C++) built for it; use the FMU on Linux x86-64, or the "
             "Python runtime's Mooring");
#endif
fail:
    free_model(m);
    return NULL;
}

static size_t state_size(const void *model) {
    (void)model;
    return 0; /* the state is MoorDyn's and the outputs (save / restore) */
}

static void free_sim(void *sim) {
    MoordynSim *s = sim;
    if (!s) return;
    close_lines(s);
    remove_folder(s->folder);
    free(s);
}

static void *init(const void *model, const double *params, const char *const *texts, double *x, NativeResult *r) {
    (void)texts, (void)x; /* no String parameters; no state vector */
    const MoordynModel *m = model;
    MoordynSim *s = calloc(1, sizeof *s);
    if (!s) {
        native_refuse(r, BRIDGE_ERROR, "out of memory");
        return NULL;
    }
    s->m = m;
    s->enabled = (m->enabled_role >= 0 ? params[m->enabled_role] : m->enabled_fixed) != 0.0;
    return s;
}

static int step(void *sim, double *x, const double *u, double t, double h, NativeResult *r) {
    (void)x;
    MoordynSim *s = sim;
    const MoordynModel *m = s->m;
    if (s->enabled) {
        double n = ceil(h / m->dt);
        if (n > m->max_steps) {
            char shown[64];
            native_repr(h, shown, sizeof shown);
            return native_refuse(r, BRIDGE_DISCARD,
                                 "step_size: %s s needs %.0f internal steps of internal_time_step = %g s, more than "
                                 "%.0f: take smaller communication steps",
                                 shown, n, m->dt, m->max_steps);
        }
        Motion mo;
        motion_of(m, u, &mo);
        s->t = t; /* the refusals name the step's start */
        if (check_reach(s, u, &mo, t, 0.0, r) != BRIDGE_OK || check_reach(s, u, &mo, t, h, r) != BRIDGE_OK
            || ensure_lines(s, u, r) != BRIDGE_OK)
            return r->status;
        double xs[3 * N_LINES], vs[3 * N_LINES], f[3 * N_LINES] = {0.0}, tm = t, dt = h;
        fairlead_positions(&mo, xs);
        for (int i = 0; i < N_LINES; i++)
            for (int a = 0; a < 3; a++) vs[3 * i + a] = mo.velocities[i][a];
        int status = m->step(s->system, xs, vs, f, &tm, &dt);
        if (status != 0) { /* NaN in MoorDyn's nodes: its state is lost */
            char at[64];
            native_repr(t, at, sizeof at);
            close_lines(s);
            snprintf(s->failure, sizeof s->failure,
                     "MoorDyn's integration failed in the step from t = %s s (MoorDyn_Step's error code %d): the "
                     "lines diverged (internal_time_step = %g s, the motion at the inputs)",
                     at, status, m->dt);
            return native_refuse(r, BRIDGE_ERROR,
                                 "state: %s (allowed: a smaller internal_time_step or gentler motions)", s->failure);
        }
        memcpy(s->given, xs, sizeof s->given);
        double arms[N_LINES][3]; /* at the step's end */
        for (int i = 0; i < N_LINES; i++)
            for (int a = 0; a < 3; a++) arms[i][a] = mo.arms[i][a] + h * (mo.velocities[i][a] - mo.vel[a]);
        if (set_loads(s, f, arms, t, r) != BRIDGE_OK) { /* MoorDyn stepped, the outputs cannot: lost too */
            close_lines(s);
            snprintf(s->failure, sizeof s->failure, "%.1000s", r->message);
            return r->status;
        }
    }
    s->t = t + h;
    return BRIDGE_OK;
}

static int outputs(void *sim, const double *x, const double *u, double *y, unsigned char *which, NativeResult *r) {
    (void)x;
    MoordynSim *s = sim;
    if (ensure_lines(s, u, r) != BRIDGE_OK) return r->status;
    for (int k = 0; k < N_OUTPUTS; k++) {
        y[s->m->out[k]] = s->enabled ? s->loads[k] : 0.0;
        which[s->m->out[k]] = 1;
    }
    return BRIDGE_OK;
}

static int culprit(void *sim, int what, const double *x, const double *u, double threshold) {
    (void)sim, (void)what, (void)x, (void)u, (void)threshold;
    return -1; /* the kind names its own culprits (check_reach); a non-finite force is the state's */
}

/* ---- FMU states ------------------------------------------------------------------------------------------------ */

/* FNV-1a over 8-byte little-endian words (then the bytes left): each step is a bijection of the hash, so any one
   damaged word changes it; 8 times fewer multiplications than byte-wise FNV-1a (a state is ~43 kB). */
static uint64_t checksum(const unsigned char *bytes, size_t n) {
    uint64_t h = 14695981039346656037ull;
    size_t k = 0;
    for (; k + 8 <= n; k += 8) {
        uint64_t word = 0;
        for (int b = 0; b < 8; b++) word |= (uint64_t)bytes[k + b] << (8 * b);
        h = (h ^ word) * 1099511628211ull;
    }
    for (; k < n; k++) h = (h ^ bytes[k]) * 1099511628211ull;
    return h;
}

static void put32(unsigned char *at, uint32_t v) {
    for (int k = 0; k < 4; k++) at[k] = (unsigned char)(v >> (8 * k));
}
static void put64(unsigned char *at, uint64_t v) {
    for (int k = 0; k < 8; k++) at[k] = (unsigned char)(v >> (8 * k));
}
static uint32_t get32(const unsigned char *at) {
    uint32_t v = 0;
    for (int k = 0; k < 4; k++) v |= (uint32_t)at[k] << (8 * k);
    return v;
}
static uint64_t get64(const unsigned char *at) {
    uint64_t v = 0;
    for (int k = 0; k < 8; k++) v |= (uint64_t)at[k] << (8 * k);
    return v;
}
static void put_f64(unsigned char *at, double d) {
    uint64_t v;
    memcpy(&v, &d, 8);
    put64(at, v);
}
static double get_f64(const unsigned char *at) {
    uint64_t v = get64(at);
    double d;
    memcpy(&d, &v, 8);
    return d;
}

static int save(void *sim, unsigned char **bytes, size_t *size, NativeResult *r) {
    MoordynSim *s = sim;
    size_t failure = strlen(s->failure), lines = s->system ? s->serialized : 0;
    size_t n = STATE_HEAD + 4 + failure + 8 + lines + 8;
    unsigned char *b = malloc(n);
    if (!b) return native_refuse(r, BRIDGE_ERROR, "out of memory");
    unsigned char *at = b;
    memcpy(at, STATE_MAGIC, 8), at += 8;
    put32(at, STATE_VERSION), at += 4;
    put32(at, (s->system ? 1u : 0u) | (s->enabled ? 2u : 0u)), at += 4;
    put_f64(at, s->t), at += 8;
    for (int k = 0; k < N_OUTPUTS; k++) put_f64(at, s->loads[k]), at += 8;
    for (int k = 0; k < 3 * N_LINES; k++) put_f64(at, s->given[k]), at += 8;
    put32(at, (uint32_t)failure), at += 4;
    memcpy(at, s->failure, failure), at += failure;
    put64(at, (uint64_t)lines), at += 8;
    if (lines) {
        uint64_t *data = malloc(lines);
        size_t got = 0;
        int status = data ? s->m->serialize(s->system, &got, data) : -5;
        if (status != 0 || got != lines) {
            free(data), free(b);
            return native_refuse(r, BRIDGE_ERROR, "MoorDyn: could not serialise the lines (its error code %d)", status);
        }
        memcpy(at, data, lines), at += lines;
        free(data);
    }
    put64(at, checksum(b, (size_t)(at - b)));
    *bytes = b, *size = n;
    return BRIDGE_OK;
}

/* The parts of a saved state, or a refusal naming what is wrong with it. */
typedef struct {
    uint32_t flags;
    double t, loads[N_OUTPUTS], given[3 * N_LINES];
    const unsigned char *failure, *lines;
    size_t failure_size, lines_size;
} Saved;

/* verify: the checksum too (check_saved, which the bridge runs on every deserialised state before any instance sees
   it; restore then takes it as checked, or from this FMU's own save) */
static int parse(const unsigned char *bytes, size_t size, int verify, Saved *p, NativeResult *r) {
    const char *damaged = "the Mooring's saved state is damaged";
    if (size < STATE_HEAD + 4 + 8 + 8 || memcmp(bytes, STATE_MAGIC, 8) != 0)
        return native_refuse(r, BRIDGE_ERROR, "%s: it is not a native Mooring state (allowed: a state this FMU saved)",
                             damaged);
    if (get32(bytes + 8) != STATE_VERSION)
        return native_refuse(r, BRIDGE_ERROR, "%s: format version %u (allowed: %u, a state this FMU saved)", damaged,
                             (unsigned)get32(bytes + 8), STATE_VERSION);
    if (verify && checksum(bytes, size - 8) != get64(bytes + size - 8))
        return native_refuse(r, BRIDGE_ERROR, "%s: its checksum differs (allowed: a state this FMU saved)", damaged);
    const unsigned char *at = bytes + 12;
    p->flags = get32(at), at += 4;
    p->t = get_f64(at), at += 8;
    for (int k = 0; k < N_OUTPUTS; k++) p->loads[k] = get_f64(at), at += 8;
    for (int k = 0; k < 3 * N_LINES; k++) p->given[k] = get_f64(at), at += 8;
    p->failure_size = get32(at), at += 4;
    size_t left = size - (size_t)(at - bytes) - 8;
    if (p->failure_size >= FAILURE_SIZE || p->failure_size + 8 > left)
        return native_refuse(r, BRIDGE_ERROR, "%s: its sizes do not add up (allowed: a state this FMU saved)", damaged);
    p->failure = at, at += p->failure_size, left -= p->failure_size + 8;
    p->lines_size = (size_t)get64(at), at += 8;
    p->lines = at;
    int has_lines = (p->flags & 1u) != 0;
    if (p->lines_size != left || (p->flags & ~3u) || has_lines != (p->lines_size > 0) || p->lines_size % 8
        || (has_lines && p->failure_size))
        return native_refuse(r, BRIDGE_ERROR, "%s: its sizes do not add up (allowed: a state this FMU saved)", damaged);
    return BRIDGE_OK;
}

static int check_saved(const void *model, const unsigned char *bytes, size_t size, NativeResult *r) {
    (void)model;
    Saved p;
    return parse(bytes, size, 1, &p, r);
}

static int restore(void *sim, const unsigned char *bytes, size_t size, NativeResult *r) {
    MoordynSim *s = sim;
    Saved p;
    if (parse(bytes, size, 0, &p, r) != BRIDGE_OK) return r->status;
    int enabled = (p.flags & 2u) != 0;
    if (enabled != s->enabled)
        return native_refuse(r, BRIDGE_ERROR,
                             "FMUstate: was taken with enabled = %s (allowed: a state of this "
                             "instance's configuration)",
                             enabled ? "true" : "false");
    if (p.lines_size) {
        int made = 0;
        if (!s->system) { /* a restored instance skips the static solution: Deserialize sets every line node */
            if (make_lines(s, p.given, 1, r) != BRIDGE_OK) return r->status;
            made = 1;
        }
        if (p.lines_size != s->serialized) {
            if (made) close_lines(s);
            return native_refuse(r, BRIDGE_ERROR,
                                 "FMUstate: its MoorDyn part has %zu bytes, this instance's lines %zu (allowed: a "
                                 "state this FMU saved)",
                                 p.lines_size, s->serialized);
        }
        uint64_t *data = malloc(p.lines_size); /* aligned, as MoorDyn reads it */
        if (!data) {
            if (made) close_lines(s);
            return native_refuse(r, BRIDGE_ERROR, "out of memory");
        }
        memcpy(data, p.lines, p.lines_size);
        int status = s->m->deserialize(s->system, data);
        free(data);
        if (status != 0) { /* the lines may be half restored: lost */
            close_lines(s);
            snprintf(s->failure, sizeof s->failure, "MoorDyn could not restore the lines (its error code %d)", status);
            return native_refuse(r, BRIDGE_ERROR, "FMUstate: %s", s->failure);
        }
    } else {
        close_lines(s);
    }
    s->t = p.t;
    memcpy(s->loads, p.loads, sizeof s->loads);
    memcpy(s->given, p.given, sizeof s->given);
    memcpy(s->failure, p.failure, p.failure_size);
    s->failure[p.failure_size] = '\0';
    return BRIDGE_OK;
}

const NativeKind native_moordyn_kind = {.name = "moordyn",
                                        .load = load,
                                        .free_model = free_model,
                                        .state_size = state_size,
                                        .init = init,
                                        .free_sim = free_sim,
                                        .step = step,
                                        .outputs = outputs,
                                        .culprit = culprit,
                                        .save = save,
                                        .restore = restore,
                                        .check_saved = check_saved};
