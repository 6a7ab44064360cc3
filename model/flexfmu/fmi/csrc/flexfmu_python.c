/*
 * flexfmu_python.c - the Python bridge of the flexfmu FMUs (see flexfmu_bridge.h).
 *
 * Compiled against the build interpreter's Python.h and linked against nothing: its Python symbols
 * are resolved from libpython, which the front library has loaded with RTLD_GLOBAL (C hosts) or which
 * the host process already has (Python hosts).  It
 *  - starts an embedded interpreter when the process has none (home and site folders recorded at
 *    build time), releases the GIL and never finalises it: finalising an interpreter that has loaded
 *    numpy and scipy (and their BLAS threads) is what crashes at exit, and CPython cannot start a second one;
 *  - loads resources/flexfmu_loader.py into a fresh namespace (never through sys.modules, which would
 *    keep a module of an earlier, possibly deleted, extraction) and asks it for the slave factory;
 *  - calls the plumbing's methods, logs its queued messages, and turns an exception into a status:
 *    an exception with an integer attribute ``fmi_status`` gives that status and its text; any other
 *    is an internal error, logged once with its type, and fmi2Error.
 * Every entry takes the GIL with PyGILState_Ensure, so any host thread may call.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>

#include <stdio.h>
#include <string.h>

#include "flexfmu_bridge.h"

#define EXPORT __attribute__((visibility("default")))

typedef struct {
    PyObject *plumbing; /* flexfmu.fmi.plumbing.Plumbing */
    PyObject *messages; /* its message queue: a list of (status, category, text) */
    PyObject *strings;  /* keeps the bytes behind get_string's pointers until the next call */
    BridgeLog *log;
    void *context;
} Slave;

/* ---- messages and exceptions (GIL held) -------------------------------------------------------- */

static void drain_messages(Slave *s) {
    Py_ssize_t n = PyList_Size(s->messages);
    for (Py_ssize_t i = 0; i < n; i++) {
        PyObject *item = PyList_GetItem(s->messages, i); /* borrowed */
        int status = BRIDGE_OK;
        const char *category = "logAll", *text = "";
        if (PyTuple_Check(item) && PyTuple_Size(item) == 3) {
            status = (int)PyLong_AsLong(PyTuple_GetItem(item, 0));
            const char *c = PyUnicode_AsUTF8(PyTuple_GetItem(item, 1));
            const char *t = PyUnicode_AsUTF8(PyTuple_GetItem(item, 2));
            if (c) category = c;
            if (t) text = t;
            PyErr_Clear();
        }
        s->log(s->context, status, category, text);
    }
    if (n > 0) PyList_SetSlice(s->messages, 0, n, NULL);
}

/* The pending exception as a status, logged once.  `what` names the call for internal errors. */
static int report_exception(BridgeLog *log, void *context, const char *what) {
    PyObject *type, *value, *traceback;
    PyErr_Fetch(&type, &value, &traceback);
    PyErr_NormalizeException(&type, &value, &traceback);
    int status = BRIDGE_ERROR;
    PyObject *text = value ? PyObject_Str(value) : NULL;
    PyErr_Clear();
    const char *message = text ? PyUnicode_AsUTF8(text) : NULL;
    PyErr_Clear();
    PyObject *fmi_status = value ? PyObject_GetAttrString(value, "fmi_status") : NULL;
    PyErr_Clear();
    char buffer[2048];
    if (fmi_status && PyLong_Check(fmi_status)) {
        long s = PyLong_AsLong(fmi_status);
        status = (s >= BRIDGE_OK && s <= BRIDGE_FATAL) ? (int)s : BRIDGE_ERROR;
        snprintf(buffer, sizeof buffer, "%s", message ? message : "(no message)");
    } else {
        const char *name = type ? ((PyTypeObject *)type)->tp_name : "unknown exception";
        snprintf(buffer, sizeof buffer, "%s: internal error: %s: %s (please report this with the FMU's log)", what,
                 name, message ? message : "");
    }
    log(context, status, status == BRIDGE_DISCARD ? "logStatusDiscard" : "logStatusError", buffer);
    Py_XDECREF(fmi_status);
    Py_XDECREF(text);
    Py_XDECREF(type);
    Py_XDECREF(value);
    Py_XDECREF(traceback);
    return status;
}

/* The status of a finished method call (its result is dropped); GIL held. */
static int finish(Slave *s, PyObject *result, const char *what) {
    int status = BRIDGE_OK;
    if (!result) status = report_exception(s->log, s->context, what);
    Py_XDECREF(result);
    drain_messages(s);
    return status;
}

/* ---- start ------------------------------------------------------------------------------------- */

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

/* ---- instances --------------------------------------------------------------------------------- */

/* The slave factory of one extraction, made by resources/flexfmu_loader.py; kept for the process. */
static PyObject *factory = NULL;
static char factory_dir[4096];

static PyObject *load_factory(const char *resources_dir) {
    if (factory && strcmp(factory_dir, resources_dir) == 0) return factory;
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
    char *source = PyMem_Malloc((size_t)size + 1);
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
    PyObject *made_factory = NULL;
    if (!PyErr_Occurred() && load)
        made_factory = PyObject_CallFunction(load, "s", resources_dir);
    else if (!PyErr_Occurred())
        PyErr_SetString(PyExc_RuntimeError, "flexfmu_loader.py defines no load()");
    Py_DECREF(code);
    Py_XDECREF(globals);
    if (!made_factory) return NULL;
    Py_XDECREF(factory); /* another extraction's: its instances keep their own references */
    factory = made_factory;
    snprintf(factory_dir, sizeof factory_dir, "%s", resources_dir);
    return factory;
}

static void *instantiate(const char *resources_dir, const char *instance_name, const char *guid, int visible,
                         BridgeLog *log, void *context) {
    PyGILState_STATE gil = PyGILState_Ensure();
    Slave *s = NULL;
    PyObject *plumbing = NULL, *messages = NULL;
    PyObject *make = load_factory(resources_dir);
    if (make) plumbing = PyObject_CallFunction(make, "ssi", instance_name, guid, visible);
    if (plumbing) messages = PyObject_GetAttrString(plumbing, "messages");
    if (messages && !PyList_Check(messages)) {
        PyErr_SetString(PyExc_TypeError, "the plumbing's messages is not a list");
        Py_CLEAR(messages);
    }
    if (messages) s = PyMem_RawCalloc(1, sizeof *s);
    if (s) {
        s->plumbing = plumbing;
        s->messages = messages;
        s->strings = PyList_New(0);
        s->log = log;
        s->context = context;
        drain_messages(s);
    } else {
        if (!PyErr_Occurred()) PyErr_NoMemory();
        report_exception(log, context, "fmi2Instantiate");
        Py_XDECREF(plumbing);
        Py_XDECREF(messages);
    }
    PyGILState_Release(gil);
    return s;
}

static void free_instance(void *slave) {
    Slave *s = slave;
    if (!s) return;
    PyGILState_STATE gil = PyGILState_Ensure();
    PyObject *r = PyObject_CallMethod(s->plumbing, "free", NULL);
    if (!r) PyErr_Clear();
    Py_XDECREF(r);
    Py_XDECREF(s->strings);
    Py_XDECREF(s->messages);
    Py_XDECREF(s->plumbing);
    PyMem_RawFree(s);
    PyGILState_Release(gil);
}

/* ---- calls ------------------------------------------------------------------------------------- */

static int setup_experiment(void *slave, int tolerance_defined, double tolerance, double start_time,
                            int stop_time_defined, double stop_time) {
    Slave *s = slave;
    PyGILState_STATE gil = PyGILState_Ensure();
    PyObject *stop = stop_time_defined ? PyFloat_FromDouble(stop_time) : Py_NewRef(Py_None);
    PyObject *tol = tolerance_defined ? PyFloat_FromDouble(tolerance) : Py_NewRef(Py_None);
    PyObject *r = PyObject_CallMethod(s->plumbing, "setup_experiment", "dOO", start_time, stop, tol);
    Py_XDECREF(stop);
    Py_XDECREF(tol);
    int status = finish(s, r, "fmi2SetupExperiment");
    PyGILState_Release(gil);
    return status;
}

static int simple_call(void *slave, BridgeSimpleCall call) {
    static const char *methods[] = {"enter_initialization_mode", "exit_initialization_mode", "terminate", "reset"};
    static const char *names[]
        = {"fmi2EnterInitializationMode", "fmi2ExitInitializationMode", "fmi2Terminate", "fmi2Reset"};
    Slave *s = slave;
    PyGILState_STATE gil = PyGILState_Ensure();
    int status = finish(s, PyObject_CallMethod(s->plumbing, methods[call], NULL), names[call]);
    PyGILState_Release(gil);
    return status;
}

static int do_step(void *slave, double current_time, double step_size) {
    Slave *s = slave;
    PyGILState_STATE gil = PyGILState_Ensure();
    int status = finish(s, PyObject_CallMethod(s->plumbing, "do_step", "dd", current_time, step_size), "fmi2DoStep");
    PyGILState_Release(gil);
    return status;
}

static PyObject *reference_list(const unsigned int *vr, size_t nvr) {
    PyObject *list = PyList_New((Py_ssize_t)nvr);
    for (size_t i = 0; list && i < nvr; i++) {
        PyObject *item = PyLong_FromUnsignedLong(vr[i]);
        if (!item) {
            Py_CLEAR(list);
            break;
        }
        PyList_SET_ITEM(list, (Py_ssize_t)i, item);
    }
    return list;
}

static const char *GET_METHODS[] = {"get_real", "get_integer", "get_boolean", "get_string"};
static const char *SET_METHODS[] = {"set_real", "set_integer", "set_boolean", "set_string"};
static const char *GET_NAMES[] = {"fmi2GetReal", "fmi2GetInteger", "fmi2GetBoolean", "fmi2GetString"};
static const char *SET_NAMES[] = {"fmi2SetReal", "fmi2SetInteger", "fmi2SetBoolean", "fmi2SetString"};

/* Copy the plumbing's list of values into the caller's array (the plumbing has checked the types). */
static int store_values(Slave *s, BridgeValueType type, PyObject *list, size_t nvr, void *values) {
    if (!PyList_Check(list) || (size_t)PyList_Size(list) != nvr) {
        PyErr_SetString(PyExc_TypeError, "the plumbing returned a wrong number of values");
        return -1;
    }
    if (type == VALUE_STRING && PyList_SetSlice(s->strings, 0, PyList_Size(s->strings), NULL) < 0) return -1;
    for (size_t i = 0; i < nvr; i++) {
        PyObject *item = PyList_GET_ITEM(list, (Py_ssize_t)i);
        switch (type) {
        case VALUE_REAL: ((double *)values)[i] = PyFloat_AsDouble(item); break;
        case VALUE_INTEGER:
        case VALUE_BOOLEAN: ((int *)values)[i] = (int)PyLong_AsLong(item); break;
        case VALUE_STRING: {
            PyObject *bytes = PyUnicode_AsUTF8String(item);
            if (!bytes) return -1;
            if (PyList_Append(s->strings, bytes) < 0) {
                Py_DECREF(bytes);
                return -1;
            }
            ((const char **)values)[i] = PyBytes_AS_STRING(bytes);
            Py_DECREF(bytes); /* s->strings keeps it */
            break;
        }
        }
        if (PyErr_Occurred()) return -1;
    }
    return 0;
}

static int get_values(void *slave, BridgeValueType type, const unsigned int *vr, size_t nvr, void *values) {
    Slave *s = slave;
    PyGILState_STATE gil = PyGILState_Ensure();
    PyObject *refs = reference_list(vr, nvr);
    PyObject *result = refs ? PyObject_CallMethod(s->plumbing, GET_METHODS[type], "O", refs) : NULL;
    Py_XDECREF(refs);
    if (result && store_values(s, type, result, nvr, values) < 0) Py_CLEAR(result);
    int status = finish(s, result, GET_NAMES[type]);
    PyGILState_Release(gil);
    return status;
}

static int set_values(void *slave, BridgeValueType type, const unsigned int *vr, size_t nvr, const void *values) {
    Slave *s = slave;
    PyGILState_STATE gil = PyGILState_Ensure();
    PyObject *refs = reference_list(vr, nvr);
    PyObject *list = PyList_New((Py_ssize_t)nvr);
    for (size_t i = 0; list && i < nvr; i++) {
        PyObject *item = NULL;
        switch (type) {
        case VALUE_REAL: item = PyFloat_FromDouble(((const double *)values)[i]); break;
        case VALUE_INTEGER: item = PyLong_FromLong(((const int *)values)[i]); break;
        case VALUE_BOOLEAN: item = PyBool_FromLong(((const int *)values)[i]); break;
        case VALUE_STRING: {
            const char *text = ((const char *const *)values)[i];
            item = text ? PyUnicode_DecodeUTF8(text, (Py_ssize_t)strlen(text), "strict") : Py_NewRef(Py_None);
            break;
        }
        }
        if (!item) {
            Py_CLEAR(list);
            break;
        }
        PyList_SET_ITEM(list, (Py_ssize_t)i, item);
    }
    PyObject *result = (refs && list) ? PyObject_CallMethod(s->plumbing, SET_METHODS[type], "OO", refs, list) : NULL;
    Py_XDECREF(refs);
    Py_XDECREF(list);
    int status = finish(s, result, SET_NAMES[type]);
    PyGILState_Release(gil);
    return status;
}

/* ---- FMU states -------------------------------------------------------------------------------- */

static int get_state(void *slave, void **state) {
    Slave *s = slave;
    PyGILState_STATE gil = PyGILState_Ensure();
    PyObject *result = PyObject_CallMethod(s->plumbing, "get_fmu_state", NULL);
    *state = result;
    int status = finish(s, Py_XNewRef(result), "fmi2GetFMUstate");
    PyGILState_Release(gil);
    return status;
}

static int set_state(void *slave, void *state) {
    Slave *s = slave;
    PyGILState_STATE gil = PyGILState_Ensure();
    int status
        = finish(s, PyObject_CallMethod(s->plumbing, "set_fmu_state", "O", (PyObject *)state), "fmi2SetFMUstate");
    PyGILState_Release(gil);
    return status;
}

static void free_state(void *state) {
    if (!state) return;
    PyGILState_STATE gil = PyGILState_Ensure();
    Py_DECREF((PyObject *)state);
    PyGILState_Release(gil);
}

static int serialize_state(void *slave, void *state, char *bytes, size_t *size) {
    Slave *s = slave;
    PyGILState_STATE gil = PyGILState_Ensure();
    PyObject *result = PyObject_CallMethod(s->plumbing, "serialize_fmu_state", "O", (PyObject *)state);
    if (result && !PyBytes_Check(result)) {
        PyErr_SetString(PyExc_TypeError, "serialize_fmu_state did not return bytes");
        Py_CLEAR(result);
    }
    if (result) {
        size_t n = (size_t)PyBytes_GET_SIZE(result);
        if (bytes && *size < n) {
            PyErr_SetString(PyExc_ValueError, "the buffer is smaller than fmi2SerializedFMUstateSize said");
            Py_CLEAR(result);
        } else {
            if (bytes) memcpy(bytes, PyBytes_AS_STRING(result), n);
            *size = n;
        }
    }
    int status = finish(s, result, bytes ? "fmi2SerializeFMUstate" : "fmi2SerializedFMUstateSize");
    PyGILState_Release(gil);
    return status;
}

static int deserialize_state(void *slave, const char *bytes, size_t size, void **state) {
    Slave *s = slave;
    PyGILState_STATE gil = PyGILState_Ensure();
    PyObject *data = PyBytes_FromStringAndSize(bytes, (Py_ssize_t)size);
    PyObject *result = data ? PyObject_CallMethod(s->plumbing, "deserialize_fmu_state", "O", data) : NULL;
    Py_XDECREF(data);
    *state = result;
    int status = finish(s, Py_XNewRef(result), "fmi2DeSerializeFMUstate");
    PyGILState_Release(gil);
    return status;
}

static int last_successful_time(void *slave, double *time) {
    Slave *s = slave;
    PyGILState_STATE gil = PyGILState_Ensure();
    PyObject *result = PyObject_CallMethod(s->plumbing, "last_successful_time", NULL);
    if (result) *time = PyFloat_AsDouble(result);
    int status = finish(s, result, "fmi2GetRealStatus");
    PyGILState_Release(gil);
    return status;
}

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
};

EXPORT const BridgeApi *flexfmu_bridge_api(void) { return &API; }
