/*
 * native_python.c - the Python kind (native_kind.h): a model whose equations are a Python simulator, called through
 * the embedded interpreter.  With flexfmu_native.c (variables, checks, time, FMU states, messages: the same runtime
 * as the native FMUs') it makes the Python runtime's bridge library (flexfmu_bridge.h), which the front loads once
 * libpython's symbols are global.
 *
 * Compiled against the build interpreter's Python.h and linked against nothing: its Python symbols are resolved
 * from libpython, which the front library has loaded with RTLD_GLOBAL (C hosts) or which the host process already
 * has (Python hosts).  It
 *  - starts an embedded interpreter when the process has none (home and site folders recorded at build time),
 *    releases the GIL and never finalises it: finalising an interpreter that has loaded numpy and scipy (and their
 *    BLAS threads) is what crashes at exit, and CPython cannot start a second one;
 *  - loads resources/flexfmu_loader.py into a fresh namespace (never through sys.modules, which would keep a module
 *    of an earlier, possibly deleted, extraction) and asks it for the model (flexfmu.fmi.plumbing.PythonModel);
 *  - calls the model and its instances through one narrow bridge, vectors in and out: make(parameters),
 *    give_inputs(inputs), step(h), outputs(level), save(), restore(bytes), and the model's check_state(bytes);
 *  - turns an exception into a status and one message: an exception with an integer attribute ``fmi_status``
 *    gives that status and its text; any other is an internal error, named with its type, and fmi2Error.
 * Every function takes the GIL with PyGILState_Ensure, so any host thread may call.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>

#include <stdio.h>
#include <string.h>

#include "native_kind.h"

#define EXPORT __attribute__((visibility("default")))

typedef struct {
    PyObject *model; /* flexfmu.fmi.plumbing.PythonModel */
    const NativeLayout *layout;
} PyModel;

typedef struct {
    PyObject *instance; /* flexfmu.fmi.plumbing.PythonInstance */
    PyObject *messages; /* its list of status-OK texts, drained after every call */
    const PyModel *model;
    double *given; /* the inputs the instance holds (valid if inputs_given) */
    int inputs_given;
} PySim;

/* ---- exceptions and messages (GIL held) ------------------------------------------------------------ */

/* The pending exception as the result's status and message.  `what` names the call for internal errors. */
static int failed(NativeResult *result, const char *what) {
    PyObject *type, *value, *traceback;
    PyErr_Fetch(&type, &value, &traceback);
    PyErr_NormalizeException(&type, &value, &traceback);
    PyObject *text = value ? PyObject_Str(value) : NULL;
    PyErr_Clear();
    const char *message = text ? PyUnicode_AsUTF8(text) : NULL;
    PyErr_Clear();
    PyObject *fmi_status = value ? PyObject_GetAttrString(value, "fmi_status") : NULL;
    PyErr_Clear();
    int status;
    if (fmi_status && PyLong_Check(fmi_status)) {
        long s = PyLong_AsLong(fmi_status);
        status = (s >= BRIDGE_DISCARD && s <= BRIDGE_ERROR) ? (int)s : BRIDGE_ERROR;
        native_refuse(result, status, "%s", message ? message : "(no message)");
    } else {
        const char *name = type ? ((PyTypeObject *)type)->tp_name : "unknown exception";
        status
            = native_refuse(result, BRIDGE_ERROR, "%s: internal error: %s: %s (please report this with the FMU's log)",
                            what, name, message ? message : "");
    }
    Py_XDECREF(fmi_status);
    Py_XDECREF(text);
    Py_XDECREF(type);
    Py_XDECREF(value);
    Py_XDECREF(traceback);
    return status;
}

/* Log (status OK) and clear the instance's messages: what the simulator chose and why. */
static void drain(PySim *sim, NativeResult *result) {
    Py_ssize_t n = PyList_Size(sim->messages);
    for (Py_ssize_t i = 0; i < n; i++) {
        const char *text = PyUnicode_AsUTF8(PyList_GET_ITEM(sim->messages, i));
        if (text) native_note(result, "%s", text);
        PyErr_Clear();
    }
    if (n > 0) PyList_SetSlice(sim->messages, 0, n, NULL);
    PyErr_Clear();
}

/* The status of a finished call (its result dropped) after draining the messages. */
static int finish(PySim *sim, PyObject *called, NativeResult *result, const char *what) {
    int status = called ? BRIDGE_OK : failed(result, what);
    Py_XDECREF(called);
    drain(sim, result);
    return status;
}

static PyObject *float_list(const double *values, size_t n) {
    PyObject *list = PyList_New((Py_ssize_t)n);
    for (size_t i = 0; list && i < n; i++) {
        PyObject *item = PyFloat_FromDouble(values[i]);
        if (!item) {
            Py_CLEAR(list);
            break;
        }
        PyList_SET_ITEM(list, (Py_ssize_t)i, item);
    }
    return list;
}

/* ---- start ------------------------------------------------------------------------------------------- */

static int add_site_dirs(const char *site_dirs, char *error, size_t error_size) {
    if (!site_dirs || !*site_dirs) return 0;
    PyObject *site = PyImport_ImportModule("site");
    if (!site) {
        PyErr_Clear();
        snprintf(error, error_size, "the embedded Python cannot import its module 'site'");
        return -1;
    }
    const char *start = site_dirs;
    while (*start) {
        const char *end = strchr(start, ':');
        size_t n = end ? (size_t)(end - start) : strlen(start);
        if (n > 0) {
            PyObject *r = PyObject_CallMethod(site, "addsitedir", "s#", start, (Py_ssize_t)n);
            if (!r) PyErr_Clear();
            Py_XDECREF(r);
        }
        start += n + (end ? 1 : 0);
    }
    Py_DECREF(site);
    return 0;
}

static int start(const BridgeSettings *settings, char *error, size_t error_size) {
    char compiled[16];
    snprintf(compiled, sizeof compiled, "%d.%d", PY_MAJOR_VERSION, PY_MINOR_VERSION);
    const char *running = Py_GetVersion(); /* callable before initialisation */
    size_t n = strlen(compiled);
    if (strncmp(running, compiled, n) != 0 || (running[n] != '.' && running[n] != ' ' && running[n] != '+')) {
        snprintf(error, error_size,
                 "this FMU's Python bridge was built for Python %s, but the process runs Python %.20s; "
                 "rebuild the FMU with that Python, or point FLEXFMU_LIBPYTHON at a libpython %s",
                 compiled, running, compiled);
        return -1;
    }
    if (Py_IsInitialized()) return 0; /* a Python host, or another FMU started it */

    PyConfig config;
    PyConfig_InitPythonConfig(&config);
    config.install_signal_handlers = 0; /* Ctrl-C and other signals stay the host's */
    config.parse_argv = 0;
    PyStatus status = PyConfig_SetString(&config, &config.program_name, L"flexfmu-fmu");
    if (!PyStatus_Exception(status) && settings->python_home && *settings->python_home)
        status = PyConfig_SetBytesString(&config, &config.home, settings->python_home);
    if (!PyStatus_Exception(status)) status = Py_InitializeFromConfig(&config);
    PyConfig_Clear(&config);
    if (PyStatus_Exception(status)) {
        snprintf(error, error_size,
                 "cannot start the embedded Python (home %s): %s; set FLEXFMU_PYTHONHOME to the prefix of a "
                 "Python %s installation",
                 settings->python_home ? settings->python_home : "(none)", status.err_msg ? status.err_msg : "?",
                 compiled);
        return -1;
    }
    int result = add_site_dirs(settings->site_dirs, error, error_size);
    PyEval_SaveThread(); /* release the GIL: every call takes it with PyGILState_Ensure */
    return result;
}

/* ---- the model ------------------------------------------------------------------------------------------ */

/* The model of one extraction, made by resources/flexfmu_loader.py; kept for the process (the GIL guards it). */
static PyObject *loaded_model = NULL;
static char loaded_dir[4096];

static PyObject *load_model(const char *resources_dir) {
    if (loaded_model && strcmp(loaded_dir, resources_dir) == 0) return Py_NewRef(loaded_model);
    char path[4200];
    snprintf(path, sizeof path, "%s/flexfmu_loader.py", resources_dir);
    FILE *file = fopen(path, "rb");
    if (!file) {
        PyErr_Format(PyExc_FileNotFoundError, "the FMU's loader %s is missing (a damaged or foreign FMU?)", path);
        return NULL;
    }
    fseek(file, 0, SEEK_END);
    long size = ftell(file);
    fseek(file, 0, SEEK_SET);
    char *source = size >= 0 ? PyMem_Malloc((size_t)size + 1) : NULL;
    size_t got = source ? fread(source, 1, (size_t)size, file) : 0;
    fclose(file);
    if (!source) return PyErr_NoMemory();
    source[got] = '\0';
    PyObject *code = Py_CompileString(source, path, Py_file_input);
    PyMem_Free(source);
    if (!code) return NULL;
    PyObject *globals = PyDict_New();
    PyObject *builtins = PyEval_GetBuiltins(); /* borrowed */
    PyObject *result = NULL;
    PyObject *module_name = PyUnicode_FromString("flexfmu_fmu_loader");
    PyObject *file_name = PyUnicode_FromString(path);
    if (globals && module_name && file_name && PyDict_SetItemString(globals, "__builtins__", builtins) == 0
        && PyDict_SetItemString(globals, "__name__", module_name) == 0
        && PyDict_SetItemString(globals, "__file__", file_name) == 0)
        result = PyEval_EvalCode(code, globals, globals);
    Py_XDECREF(module_name);
    Py_XDECREF(file_name);
    Py_XDECREF(result);
    PyObject *load = globals ? PyDict_GetItemString(globals, "load") : NULL; /* borrowed */
    PyObject *model = NULL;
    if (!PyErr_Occurred() && load)
        model = PyObject_CallFunction(load, "s", resources_dir);
    else if (!PyErr_Occurred())
        PyErr_SetString(PyExc_RuntimeError, "flexfmu_loader.py defines no load()");
    Py_DECREF(code);
    Py_XDECREF(globals);
    if (!model) return NULL;
    Py_XDECREF(loaded_model); /* another extraction's: its instances keep their own references */
    loaded_model = Py_NewRef(model);
    snprintf(loaded_dir, sizeof loaded_dir, "%s", resources_dir);
    return model;
}

static void *load(const NativeFile *file, const NativeLayout *layout, char *why, size_t why_size) {
    (void)file; /* the Python model reads what it needs itself (its spec, in resources/) */
    PyGILState_STATE gil = PyGILState_Ensure();
    PyModel *m = NULL;
    PyObject *model = load_model(layout->resources);
    if (model && (m = PyMem_RawCalloc(1, sizeof *m))) {
        m->model = model;
        m->layout = layout;
    } else {
        NativeResult r = {0};
        if (!model) {
            failed(&r, "fmi2Instantiate");
        } else {
            Py_DECREF(model);
            snprintf(r.message, sizeof r.message, "out of memory");
        }
        snprintf(why, why_size, "%s", r.message);
    }
    PyGILState_Release(gil);
    return m;
}

static void free_model(void *model) {
    PyModel *m = model;
    if (!m) return;
    PyGILState_STATE gil = PyGILState_Ensure();
    Py_XDECREF(m->model);
    PyMem_RawFree(m);
    PyGILState_Release(gil);
}

static size_t state_size(const void *model) {
    (void)model;
    return 0; /* the state is the simulator's (save / restore) */
}

/* ---- simulators ---------------------------------------------------------------------------------------- */

static void free_sim(void *simulator) {
    PySim *sim = simulator;
    if (!sim) return;
    PyGILState_STATE gil = PyGILState_Ensure();
    Py_XDECREF(sim->messages);
    Py_XDECREF(sim->instance);
    PyMem_RawFree(sim->given);
    PyMem_RawFree(sim);
    PyGILState_Release(gil);
}

static void *init(const void *model, const double *params, const char *const *texts, double *x, NativeResult *r) {
    (void)x;
    const PyModel *m = model;
    size_t n = m->layout->n_params;
    PyGILState_STATE gil = PyGILState_Ensure();
    PySim *sim = PyMem_RawCalloc(1, sizeof *sim);
    if (sim) sim->given = PyMem_RawCalloc(m->layout->n_inputs + 1, sizeof *sim->given);
    if (!sim || !sim->given) {
        PyMem_RawFree(sim);
        native_refuse(r, BRIDGE_ERROR, "fmi2ExitInitializationMode: out of memory");
        PyGILState_Release(gil);
        return NULL;
    }
    sim->model = m;
    PyObject *values = PyList_New((Py_ssize_t)n);
    for (size_t k = 0; values && k < n; k++) {
        PyObject *item = texts[k] ? PyUnicode_DecodeUTF8(texts[k], (Py_ssize_t)strlen(texts[k]), "strict")
                                  : PyFloat_FromDouble(params[k]);
        if (!item) {
            Py_CLEAR(values);
            break;
        }
        PyList_SET_ITEM(values, (Py_ssize_t)k, item);
    }
    if (values) sim->instance = PyObject_CallMethod(m->model, "make", "O", values);
    Py_XDECREF(values);
    if (sim->instance) sim->messages = PyObject_GetAttrString(sim->instance, "messages");
    if (sim->messages && !PyList_Check(sim->messages)) {
        PyErr_SetString(PyExc_TypeError, "the instance's messages is not a list");
        Py_CLEAR(sim->messages);
    }
    if (!sim->messages) {
        failed(r, "fmi2ExitInitializationMode");
        Py_XDECREF(sim->instance);
        PyMem_RawFree(sim->given);
        PyMem_RawFree(sim);
        sim = NULL;
    } else {
        drain(sim, r);
    }
    PyGILState_Release(gil);
    return sim;
}

/* Give the instance the inputs u if it holds others (it holds its inputs until they are given again). */
static int give_inputs(PySim *sim, const double *u, NativeResult *r) {
    size_t n = sim->model->layout->n_inputs;
    if (sim->inputs_given) {
        size_t j = 0;
        while (j < n && sim->given[j] == u[j]) j++;
        if (j == n) return BRIDGE_OK;
    }
    PyObject *list = float_list(u, n);
    int status = finish(sim, list ? PyObject_CallMethod(sim->instance, "give_inputs", "O", list) : NULL, r, "inputs");
    Py_XDECREF(list);
    if (status == BRIDGE_OK) {
        memcpy(sim->given, u, n * sizeof *u);
        sim->inputs_given = 1;
    }
    return status;
}

static int step(void *simulator, double *x, const double *u, double t, double h, NativeResult *r) {
    (void)x, (void)t;
    PySim *sim = simulator;
    PyGILState_STATE gil = PyGILState_Ensure();
    int status = give_inputs(sim, u, r);
    if (status == BRIDGE_OK) status = finish(sim, PyObject_CallMethod(sim->instance, "step", "d", h), r, "fmi2DoStep");
    PyGILState_Release(gil);
    return status;
}

/* Levels of PythonInstance.outputs: every output but the deferred ones, all, the deferred ones only. */
enum { PLAIN = 1, ALL = 2, DEFERRED_ONLY = 3 };

static int outputs(void *simulator, const double *x, const double *u, double *y, unsigned char *which,
                   NativeResult *r) {
    (void)x;
    PySim *sim = simulator;
    const NativeLayout *layout = sim->model->layout;
    size_t n = layout->n_outputs;
    int plain = 0, deferred = 0;
    for (size_t i = 0; i < n; i++)
        if (which[i]) *(layout->deferred[i] ? &deferred : &plain) = 1;
    int level = plain && deferred ? ALL : plain ? PLAIN : DEFERRED_ONLY;
    PyGILState_STATE gil = PyGILState_Ensure();
    int status = give_inputs(sim, u, r);
    PyObject *values = status == BRIDGE_OK ? PyObject_CallMethod(sim->instance, "outputs", "i", level) : NULL;
    if (values && (!PyList_Check(values) || (size_t)PyList_GET_SIZE(values) != n)) {
        PyErr_Format(PyExc_TypeError, "the instance's outputs are not a list of %zu numbers", n);
        Py_CLEAR(values);
    }
    for (size_t i = 0; values && i < n; i++) {
        int computed = layout->deferred[i] ? level != PLAIN : level != DEFERRED_ONLY;
        if (!computed) continue;
        y[i] = PyFloat_AsDouble(PyList_GET_ITEM(values, (Py_ssize_t)i));
        which[i] = 1;
        if (PyErr_Occurred()) Py_CLEAR(values);
    }
    if (status == BRIDGE_OK) status = finish(sim, values ? Py_NewRef(values) : NULL, r, "the simulator");
    Py_XDECREF(values);
    PyGILState_Release(gil);
    return status;
}

static int culprit(void *sim, int what, const double *x, const double *u, double threshold) {
    (void)sim, (void)what, (void)x, (void)u, (void)threshold;
    return -1; /* the simulator names the input behind a problem itself */
}

/* ---- the simulator's state ------------------------------------------------------------------------------ */

static int save(void *simulator, unsigned char **bytes, size_t *size, NativeResult *r) {
    PySim *sim = simulator;
    PyGILState_STATE gil = PyGILState_Ensure();
    PyObject *data = PyObject_CallMethod(sim->instance, "save", NULL);
    if (data && !PyBytes_Check(data)) {
        PyErr_SetString(PyExc_TypeError, "the instance's save() did not return bytes");
        Py_CLEAR(data);
    }
    if (data) {
        size_t n = (size_t)PyBytes_GET_SIZE(data);
        if ((*bytes = malloc(n ? n : 1))) {
            memcpy(*bytes, PyBytes_AS_STRING(data), n);
            *size = n;
        } else {
            Py_CLEAR(data);
            PyErr_NoMemory();
        }
    }
    int status = finish(sim, data, r, "fmi2GetFMUstate");
    PyGILState_Release(gil);
    return status;
}

static int restore(void *simulator, const unsigned char *bytes, size_t size, NativeResult *r) {
    PySim *sim = simulator;
    PyGILState_STATE gil = PyGILState_Ensure();
    PyObject *data = PyBytes_FromStringAndSize((const char *)bytes, (Py_ssize_t)size);
    int status
        = finish(sim, data ? PyObject_CallMethod(sim->instance, "restore", "O", data) : NULL, r, "fmi2SetFMUstate");
    Py_XDECREF(data);
    sim->inputs_given = 0; /* the simulator's inputs are those of the state's last step: give the held ones */
    PyGILState_Release(gil);
    return status;
}

static int check_saved(const void *model, const unsigned char *bytes, size_t size, NativeResult *r) {
    const PyModel *m = model;
    PyGILState_STATE gil = PyGILState_Ensure();
    PyObject *data = PyBytes_FromStringAndSize((const char *)bytes, (Py_ssize_t)size);
    PyObject *checked = data ? PyObject_CallMethod(m->model, "check_state", "O", data) : NULL;
    int status = checked ? BRIDGE_OK : failed(r, "fmi2DeSerializeFMUstate");
    Py_XDECREF(checked);
    Py_XDECREF(data);
    PyGILState_Release(gil);
    return status;
}

const NativeKind native_python_kind = {.name = "python",
                                       .load = load,
                                       .free_model = free_model,
                                       .state_size = state_size,
                                       .init = init,
                                       .free_sim = free_sim,
                                       .step = step,
                                       .outputs = outputs,
                                       .culprit = culprit,
                                       .start = start,
                                       .save = save,
                                       .restore = restore,
                                       .check_saved = check_saved};

/* The one kind of the Python runtime's library. */
const NativeKind *const native_kinds[] = {&native_python_kind};
const size_t native_kind_count = 1;

/* The bridge library's one exported symbol (flexfmu_bridge.h): the runtime of flexfmu_native.c over this kind. */
const BridgeApi *flexfmu_native_api(void);
EXPORT const BridgeApi *flexfmu_bridge_api(void) { return flexfmu_native_api(); }
