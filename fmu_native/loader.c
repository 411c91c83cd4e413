/*
 * binaries/linux64/IceImpact.so: the FMI 2.0 library of IceImpact.fmu, compiled by build_fmu.py.
 *
 * PythonFMU 0.7.0's library (shipped beside this one as binaries/linux64/pythonfmu/IceImpact.so)
 * calls the Python C API but has no NEEDED entry for libpython, so a host that is not itself a
 * Python process fails to load it ("undefined symbol: _Py_NoneStruct"), and it forwards log
 * messages to the host only when the host turned debug logging on, errors included. This library
 * sits in front of it:
 *
 *  1. At the first fmi2Instantiate, if the process has no Python yet, it loads a libpython with
 *     RTLD_GLOBAL, so that PythonFMU's library and every extension module (numpy, scipy) find
 *     the Python symbols; then it loads PythonFMU's library. PythonFMU's library is built on
 *     Python's stable ABI (Py_LIMITED_API), so any CPython 3 runs it: the loader takes the first
 *     Python of PYTHON_VERSIONS (the build's first: LIBPYTHON_PATH, then LIBPYTHON_SONAME; then
 *     libpython3.X.so.1.0 of the others from the library search path) whose site-packages
 *     folders hold numpy and scipy (for the build's version also the folders recorded in
 *     resources/iceimpact_fmu/python.json), else the first one found, which then says what it
 *     lacks (the boot module checks the versions). What is missing is reported through the
 *     host's logger (and stderr), naming what was looked for, and fmi2Instantiate returns NULL.
 *  2. It instantiates PythonFMU's component with debug logging on and its own logger, which
 *     forwards every message of status fmi2Warning or worse to the host always (FMI 2.0: errors
 *     are reported whatever loggingOn says) and fmi2OK messages only while the host asked for
 *     debug logging (fmi2Instantiate's loggingOn, fmi2SetDebugLogging and its categories).
 *  3. A Python slave can only make PythonFMU return fmi2OK, fmi2Discard (do_step returning
 *     False) or fmi2Fatal (an exception, which also releases PythonFMU's references to the
 *     instance, so that fmi2FreeInstance releases them twice). To fail a call cleanly the slave
 *     logs a message with the category FAIL_CATEGORY ("fmi2Error"; iceimpact_fmu_boot.fail_call
 *     does it): the message reaches the host as an error (category logStatusError) and the call
 *     returns fmi2Error where PythonFMU would have returned fmi2OK, fmi2Warning or fmi2Discard.
 *     It is opt-in, per call: libcosim terminates the process on an fmi2Error from
 *     fmi2ExitInitializationMode, so the slave reports bad parameters there by an error message
 *     only, and fails the next fmi2DoStep.
 *
 *  4. Every host's failure path ends in a status, never a crash: a NULL component (ECOS calls
 *     fmi2SetupExperiment on the NULL a failed fmi2Instantiate returned) gets fmi2Error and is
 *     not dereferenced; a NULL category or instance name from PythonFMU is replaced before it
 *     reaches the host's logger (OMSimulator builds a std::string from it); once the Python of
 *     the process is finalized (OMSimulator terminates leftover instances from a static
 *     destructor, after the host's Python exited) no call touches Python; and the reason for a
 *     failed fmi2Instantiate also goes to stderr, since some hosts show no FMU log by default.
 *  5. Built with BUNDLED_PYTHON (build_fmu.py --standalone), the FMU carries its own CPython under
 *     binaries/linux64/python (a prefix: lib/libpython, lib/python3.X with the standard library,
 *     lib-dynload and site-packages). In a process without Python the loader starts that runtime
 *     itself, isolated: its home and module path are set here from the FMU's own location, the
 *     host's environment (PYTHONHOME, PYTHONPATH, ...) is ignored, no signal handler is
 *     installed. A process that already runs Python keeps its interpreter (docs/explanation/fmu-loader.md).
 *  6. PythonFMU 0.7.0 frees its interpreter state twice at exit: the C++ static destructor of its
 *     `pyState` (an exit handler) frees the block, then its ELF destructor (onLibraryUnload, run
 *     by _dl_fini) assigns to the destroyed pointer and decrements a count inside the freed block,
 *     which corrupts the heap (an abort at exit, "free(): corrupted unsorted chunks"). Right
 *     after loading PythonFMU's library the loader registers the library's
 *     finalizePythonInterpreter as an exit handler of its own: registered later, it runs first
 *     and releases the state while the pointer is alive; both destructors then find it empty.
 *     This covers a failed fmi2Instantiate too, where the slave (whose guard_native_exit does
 *     the same) never ran.
 *
 * Every other call is passed through unchanged.
 */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <limits.h>
#include <link.h>
#include <pthread.h>
#include <pwd.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

/* glibc's registration of an exit handler (what atexit and C++ static destructors use); with no
   DSO handle it runs at exit only, whatever is unloaded before. */
extern int __cxa_atexit(void (*function)(void *), void *argument, void *dso_handle);

#ifndef LIBPYTHON_PATH
#define LIBPYTHON_PATH ""
#endif
#ifndef LIBPYTHON_SONAME
#define LIBPYTHON_SONAME "libpython3.so"
#endif
#ifndef PYTHON_VERSION
#define PYTHON_VERSION "3"
#endif
#ifndef PYTHON_VERSIONS /* the Pythons a native host may run the FMU with, the build's first */
#define PYTHON_VERSIONS PYTHON_VERSION
#endif
#ifndef PYTHONFMU_LIBRARY
#define PYTHONFMU_LIBRARY "pythonfmu/IceImpact.so"
#endif
#ifndef MODEL_IDENTIFIER
#define MODEL_IDENTIFIER "IceImpact"
#endif

#ifdef BUNDLED_PYTHON
/* Only the types and the layout of PyConfig: every function is looked up in the bundled libpython
   at run time, since this library is loaded before it. */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#define BUNDLED_HOME "python" /* relative to binaries/linux64 */
#endif

#ifndef EXPORT /* fmi3.c compiles this file with its fmi2 entry points internal */
#define EXPORT __attribute__((visibility("default")))
#endif

/* Log category with which the slave fails the current call with fmi2Error (see 3. above). */
#define FAIL_CATEGORY "fmi2Error"

/* The types of fmi2TypesPlatform.h / fmi2FunctionTypes.h (FMI 2.0) used here. */
typedef void *fmi2Component;
typedef void *fmi2ComponentEnvironment;
typedef void *fmi2FMUstate;
typedef unsigned int fmi2ValueReference;
typedef double fmi2Real;
typedef int fmi2Integer;
typedef int fmi2Boolean;
typedef char fmi2Char;
typedef const fmi2Char *fmi2String;
typedef char fmi2Byte;
typedef enum { fmi2OK, fmi2Warning, fmi2Discard, fmi2Error, fmi2Fatal, fmi2Pending } fmi2Status;
typedef enum { fmi2ModelExchange, fmi2CoSimulation } fmi2Type;
typedef enum {
    fmi2DoStepStatus, fmi2PendingStatus, fmi2LastSuccessfulTime, fmi2Terminated
} fmi2StatusKind;

typedef void (*fmi2CallbackLogger)(fmi2ComponentEnvironment, fmi2String, fmi2Status, fmi2String,
                                   fmi2String, ...);
typedef struct {
    fmi2CallbackLogger logger;
    void *(*allocateMemory)(size_t, size_t);
    void (*freeMemory)(void *);
    void (*stepFinished)(fmi2ComponentEnvironment, fmi2Status);
    fmi2ComponentEnvironment componentEnvironment;
} fmi2CallbackFunctions;

/* PythonFMU's functions, resolved once. */
static struct {
    fmi2Component (*Instantiate)(fmi2String, fmi2Type, fmi2String, fmi2String,
                                 const fmi2CallbackFunctions *, fmi2Boolean, fmi2Boolean);
    void (*FreeInstance)(fmi2Component);
    fmi2Status (*SetupExperiment)(fmi2Component, fmi2Boolean, fmi2Real, fmi2Real, fmi2Boolean,
                                  fmi2Real);
    fmi2Status (*EnterInitializationMode)(fmi2Component);
    fmi2Status (*ExitInitializationMode)(fmi2Component);
    fmi2Status (*Terminate)(fmi2Component);
    fmi2Status (*Reset)(fmi2Component);
    fmi2Status (*GetReal)(fmi2Component, const fmi2ValueReference *, size_t, fmi2Real *);
    fmi2Status (*GetInteger)(fmi2Component, const fmi2ValueReference *, size_t, fmi2Integer *);
    fmi2Status (*GetBoolean)(fmi2Component, const fmi2ValueReference *, size_t, fmi2Boolean *);
    fmi2Status (*GetString)(fmi2Component, const fmi2ValueReference *, size_t, fmi2String *);
    fmi2Status (*SetReal)(fmi2Component, const fmi2ValueReference *, size_t, const fmi2Real *);
    fmi2Status (*SetInteger)(fmi2Component, const fmi2ValueReference *, size_t,
                             const fmi2Integer *);
    fmi2Status (*SetBoolean)(fmi2Component, const fmi2ValueReference *, size_t,
                             const fmi2Boolean *);
    fmi2Status (*SetString)(fmi2Component, const fmi2ValueReference *, size_t,
                            const fmi2String *);
    fmi2Status (*GetFMUstate)(fmi2Component, fmi2FMUstate *);
    fmi2Status (*SetFMUstate)(fmi2Component, fmi2FMUstate);
    fmi2Status (*FreeFMUstate)(fmi2Component, fmi2FMUstate *);
    fmi2Status (*SerializedFMUstateSize)(fmi2Component, fmi2FMUstate, size_t *);
    fmi2Status (*SerializeFMUstate)(fmi2Component, fmi2FMUstate, fmi2Byte *, size_t);
    fmi2Status (*DeSerializeFMUstate)(fmi2Component, const fmi2Byte *, size_t, fmi2FMUstate *);
    fmi2Status (*GetDirectionalDerivative)(fmi2Component, const fmi2ValueReference *, size_t,
                                           const fmi2ValueReference *, size_t, const fmi2Real *,
                                           fmi2Real *);
    fmi2Status (*SetRealInputDerivatives)(fmi2Component, const fmi2ValueReference *, size_t,
                                          const fmi2Integer *, const fmi2Real *);
    fmi2Status (*GetRealOutputDerivatives)(fmi2Component, const fmi2ValueReference *, size_t,
                                           const fmi2Integer *, fmi2Real *);
    fmi2Status (*DoStep)(fmi2Component, fmi2Real, fmi2Real, fmi2Boolean);
    fmi2Status (*CancelStep)(fmi2Component);
    fmi2Status (*GetStatus)(fmi2Component, fmi2StatusKind, fmi2Status *);
    fmi2Status (*GetRealStatus)(fmi2Component, fmi2StatusKind, fmi2Real *);
    fmi2Status (*GetIntegerStatus)(fmi2Component, fmi2StatusKind, fmi2Integer *);
    fmi2Status (*GetBooleanStatus)(fmi2Component, fmi2StatusKind, fmi2Boolean *);
    fmi2Status (*GetStringStatus)(fmi2Component, fmi2StatusKind, fmi2String *);
} real;

static const char *const function_names[] = {
    "fmi2Instantiate", "fmi2FreeInstance", "fmi2SetupExperiment",
    "fmi2EnterInitializationMode", "fmi2ExitInitializationMode", "fmi2Terminate", "fmi2Reset",
    "fmi2GetReal", "fmi2GetInteger", "fmi2GetBoolean", "fmi2GetString", "fmi2SetReal",
    "fmi2SetInteger", "fmi2SetBoolean", "fmi2SetString", "fmi2GetFMUstate", "fmi2SetFMUstate",
    "fmi2FreeFMUstate", "fmi2SerializedFMUstateSize", "fmi2SerializeFMUstate",
    "fmi2DeSerializeFMUstate", "fmi2GetDirectionalDerivative", "fmi2SetRealInputDerivatives",
    "fmi2GetRealOutputDerivatives", "fmi2DoStep", "fmi2CancelStep", "fmi2GetStatus",
    "fmi2GetRealStatus", "fmi2GetIntegerStatus", "fmi2GetBooleanStatus", "fmi2GetStringStatus",
};

_Static_assert(sizeof real == sizeof function_names / sizeof *function_names * sizeof(void *),
               "one name per function pointer of `real`");

static pthread_mutex_t load_lock = PTHREAD_MUTEX_INITIALIZER;
static int loaded = 0;

/* Py_IsInitialized of the process's Python: 0 once the host finalized it. */
static int (*py_is_initialized)(void) = NULL;

static int python_alive(void) { return py_is_initialized && py_is_initialized(); }

/* An instance was made: from then on, Python not alive means finalized. */
static int python_seen = 0;

/* The Python this library chose and started in a native host ("Python 3.12
   (/usr/lib/.../libpython3.12.so.1.0)"), said once to a host that turned debug logging on. */
static char python_started[PATH_MAX + 64] = "";

/* One instance: PythonFMU's component and what the host gave us. */
typedef struct {
    fmi2Component component;
    fmi2CallbackFunctions host;     /* the host's callbacks */
    fmi2CallbackFunctions ours;     /* given to PythonFMU: our logger, environment = this */
    char *name;
    int logging_on;                 /* the host's debug logging switch */
    size_t n_categories;
    char **categories;              /* the host's categories (none: all) */
    int failed;                     /* the slave failed the current call (FAIL_CATEGORY) */
    int instantiating;              /* inside PythonFMU's fmi2Instantiate: errors to stderr too */
    fmi2FMUstate *states;           /* the FMU states handed out and not freed (state_add) */
    size_t n_states, cap_states;
} Instance;

static char *copy_string(const char *s) {
    size_t n = strlen(s ? s : "") + 1;
    char *copy = malloc(n);
    if (copy) memcpy(copy, s ? s : "", n);
    return copy;
}

static void clear_categories(Instance *inst) {
    for (size_t i = 0; i < inst->n_categories; i++) free(inst->categories[i]);
    free(inst->categories);
    inst->categories = NULL;
    inst->n_categories = 0;
}

/* Report a failure to load: through the host's logger and on stderr. */
static void report(const fmi2CallbackFunctions *f, fmi2String name, const char *fmt, ...) {
    char text[4096];
    va_list args;
    va_start(args, fmt);
    vsnprintf(text, sizeof text, fmt, args);
    va_end(args);
    fprintf(stderr, MODEL_IDENTIFIER ".fmu: %s\n", text);
    if (f && f->logger)
        f->logger(f->componentEnvironment, name ? name : MODEL_IDENTIFIER, fmi2Fatal,
                  "logStatusFatal", "%s", text);
}

/* The directory of this library (binaries/linux64), without a trailing slash; 1 on success. */
static int own_directory(char *out, size_t n) {
    Dl_info self;
    if (!dladdr((void *)&own_directory, &self) || !self.dli_fname) return 0;
    const char *slash = strrchr(self.dli_fname, '/');
    if (!slash) return snprintf(out, n, ".") < (int)n;
    return snprintf(out, n, "%.*s", (int)(slash - self.dli_fname), self.dli_fname) < (int)n;
}


#ifdef BUNDLED_PYTHON
/* A function of the bundled libpython (its prototype from Python.h), or a report naming it. */
#define PY_FUNCTION(handle, fn) \
    __typeof__(&fn) fn##_ = (__typeof__(&fn))dlsym(handle, #fn); \
    if (!fn##_) { \
        report(f, name, "the bundled Python lacks %s", #fn); \
        return 0; \
    }

static int config_failed(const fmi2CallbackFunctions *f, fmi2String name, PyStatus status,
                         const char *what) {
    report(f, name, "cannot start the bundled Python (%s): %s%s%s", what,
           status.func ? status.func : "", status.func ? ": " : "",
           status.err_msg ? status.err_msg : "unknown error");
    return 0;
}

/* Load the libraries listed in python/lib/preload.list (the non-glibc libraries that the
   bundled extension modules need, such as libffi for ctypes), then libpython, all RTLD_GLOBAL. */
static void *load_bundled_libraries(const fmi2CallbackFunctions *f, fmi2String name,
                                    const char *home) {
    char path[4800], list_path[4300];
    snprintf(list_path, sizeof list_path, "%s/lib/preload.list", home);
    FILE *list = fopen(list_path, "r");
    if (list) {
        char line[512];
        while (fgets(line, sizeof line, list)) {
            line[strcspn(line, "\r\n")] = '\0';
            if (!line[0]) continue;
            if (strchr(line, '/')) { /* a file name in lib/, nothing outside the FMU */
                report(f, name, "refuses the entry '%s' of %s: a library name, not a path", line,
                       list_path);
                fclose(list);
                return NULL;
            }
            snprintf(path, sizeof path, "%s/lib/%s", home, line);
            if (!dlopen(path, RTLD_NOW | RTLD_GLOBAL)) {
                report(f, name, "cannot load the bundled library %s: %s", path, dlerror());
                fclose(list);
                return NULL;
            }
        }
        fclose(list);
    }
    snprintf(path, sizeof path, "%s/lib/%s", home, LIBPYTHON_SONAME);
    void *py = dlopen(path, RTLD_NOW | RTLD_GLOBAL);
    if (!py) report(f, name, "cannot load the bundled Python %s: %s", path, dlerror());
    return py;
}

/* Start the bundled CPython, isolated, with its home and module path under binaries/linux64. */
static int start_bundled_python(const fmi2CallbackFunctions *f, fmi2String name,
                                const char *dir) {
    char home[4200];
    snprintf(home, sizeof home, "%s/" BUNDLED_HOME, dir);
    void *py = load_bundled_libraries(f, name, home);
    if (!py) return 0;
    PY_FUNCTION(py, PyConfig_InitIsolatedConfig)
    PY_FUNCTION(py, PyConfig_Clear)
    PY_FUNCTION(py, PyConfig_SetBytesString)
    PY_FUNCTION(py, PyWideStringList_Append)
    PY_FUNCTION(py, Py_InitializeFromConfig)
    PY_FUNCTION(py, PyStatus_Exception)
    PY_FUNCTION(py, Py_DecodeLocale)
    PY_FUNCTION(py, PyMem_RawFree)
    PY_FUNCTION(py, PyEval_SaveThread)
    PY_FUNCTION(py, Py_IsInitialized)

    PyConfig config;
    PyConfig_InitIsolatedConfig_(&config);
    config.install_signal_handlers = 0; /* the host's signals stay the host's */
    config.site_import = 0;             /* the module path below is the whole path */
    config.write_bytecode = 0;          /* the FMU's folder may be read-only */
    config.module_search_paths_set = 1;
    PyStatus status = PyConfig_SetBytesString_(&config, &config.home, home);
    if (PyStatus_Exception_(status)) {
        PyConfig_Clear_(&config);
        return config_failed(f, name, status, "home");
    }
    static const char *const folders[] = {
        "lib/python" PYTHON_VERSION, "lib/python" PYTHON_VERSION "/lib-dynload",
        "lib/python" PYTHON_VERSION "/site-packages"};
    for (size_t i = 0; i < sizeof folders / sizeof *folders; i++) {
        char folder[4300];
        snprintf(folder, sizeof folder, "%s/%s", home, folders[i]);
        wchar_t *wide = Py_DecodeLocale_(folder, NULL);
        if (!wide) {
            PyConfig_Clear_(&config);
            report(f, name, "cannot start the bundled Python: cannot decode the path %s", folder);
            return 0;
        }
        status = PyWideStringList_Append_(&config.module_search_paths, wide);
        PyMem_RawFree_(wide);
        if (PyStatus_Exception_(status)) {
            PyConfig_Clear_(&config);
            return config_failed(f, name, status, "module path");
        }
    }
    status = Py_InitializeFromConfig_(&config);
    PyConfig_Clear_(&config);
    if (PyStatus_Exception_(status)) return config_failed(f, name, status, "initialization");
    PyEval_SaveThread_(); /* PythonFMU takes the GIL with PyGILState_Ensure in every call */
    py_is_initialized = Py_IsInitialized_;
    return 1;
}
#endif

#ifndef BUNDLED_PYTHON
/* Finding a Python in a native host (1. above) ------------------------------------------------ */

#define MAX_CANDIDATES 8
#define MAX_FOLDERS 16
#define FOLDER_SIZE 1024
/* The build's environment, relative to binaries/linux64 (build_fmu.py writes it). */
#define CONFIG_FILE "../../resources/iceimpact_fmu/python.json"

/* Text that grows up to a fixed size, cut short beyond it. */
typedef struct {
    char text[8192];
    size_t used;
} Text;

static void add_text(Text *t, const char *fmt, ...) {
    if (t->used + 1 >= sizeof t->text) return;
    va_list args;
    va_start(args, fmt);
    int n = vsnprintf(t->text + t->used, sizeof t->text - t->used, fmt, args);
    va_end(args);
    if (n > 0) t->used += (size_t)n < sizeof t->text - t->used ? (size_t)n
                                                                : sizeof t->text - t->used - 1;
}

/* A Python found: its library and where its numpy and scipy would be. */
typedef struct {
    const char *version;              /* "3.12" */
    char library[PATH_MAX];           /* the file, symbolic links resolved */
    void *handle;                     /* dlopen'ed RTLD_LOCAL while the choice is made */
    int numpy, scipy;                 /* found in one of its folders */
    Text folders;                     /* its site folders that exist, for a message */
} Candidate;

static int has_package(const char *folder, const char *package) {
    char path[FOLDER_SIZE + 64];
    snprintf(path, sizeof path, "%.*s/%.32s/__init__.py", FOLDER_SIZE, folder, package);
    return access(path, R_OK) == 0;
}

/* The strings of the JSON array `key` of the JSON text `json` (python.json: the escapes
   json.dumps writes, \uXXXX included), at most `max`; their number. */
static size_t json_strings(const char *json, const char *key, char out[][FOLDER_SIZE],
                           size_t max) {
    char quoted[64];
    snprintf(quoted, sizeof quoted, "\"%s\"", key);
    const char *p = strstr(json, quoted);
    if (!p) return 0;
    p += strlen(quoted);
    while (*p == ' ' || *p == '\n' || *p == '\r' || *p == '\t') p++;
    if (*p++ != ':') return 0;
    while (*p == ' ' || *p == '\n' || *p == '\r' || *p == '\t') p++;
    if (*p++ != '[') return 0;
    size_t n = 0;
    while (n < max) {
        while (*p == ' ' || *p == '\n' || *p == '\r' || *p == '\t' || *p == ',') p++;
        if (*p++ != '"') break; /* ']' ends the array */
        char *s = out[n];
        size_t k = 0;
        while (*p && *p != '"' && k + 4 < FOLDER_SIZE) {
            if (*p != '\\') {
                s[k++] = *p++;
                continue;
            }
            p++;
            unsigned long cp;
            switch (*p) {
            case 'b': cp = '\b'; break;
            case 'f': cp = '\f'; break;
            case 'n': cp = '\n'; break;
            case 'r': cp = '\r'; break;
            case 't': cp = '\t'; break;
            case 'u': {
                char hex[5] = {0};
                memcpy(hex, p + 1, 4);
                cp = strtoul(hex, NULL, 16);
                p += 4;
                if (cp >= 0xD800 && cp < 0xDC00 && p[1] == '\\' && p[2] == 'u') {
                    memcpy(hex, p + 3, 4);
                    unsigned long low = strtoul(hex, NULL, 16);
                    if (low >= 0xDC00 && low < 0xE000) {
                        cp = 0x10000 + ((cp - 0xD800) << 10) + (low - 0xDC00);
                        p += 6;
                    }
                }
                break;
            }
            case '\0': return n;
            default: cp = (unsigned char)*p; /* \" \\ \/ */
            }
            p++;
            if (cp < 0x80) {
                s[k++] = (char)cp;
            } else if (cp < 0x800) {
                s[k++] = (char)(0xC0 | (cp >> 6));
                s[k++] = (char)(0x80 | (cp & 0x3F));
            } else if (cp < 0x10000) {
                s[k++] = (char)(0xE0 | (cp >> 12));
                s[k++] = (char)(0x80 | ((cp >> 6) & 0x3F));
                s[k++] = (char)(0x80 | (cp & 0x3F));
            } else {
                s[k++] = (char)(0xF0 | (cp >> 18));
                s[k++] = (char)(0x80 | ((cp >> 12) & 0x3F));
                s[k++] = (char)(0x80 | ((cp >> 6) & 0x3F));
                s[k++] = (char)(0x80 | (cp & 0x3F));
            }
        }
        if (*p != '"') break; /* cut short or malformed: not used */
        p++;
        s[k] = '\0';
        n++;
    }
    return n;
}

/* The site-packages folders recorded at build time (python.json's "site"; relative ones are the
   FMU's own, relative to resources/), at most `max`; their number. */
static size_t recorded_folders(const char *dir, char out[][FOLDER_SIZE], size_t max) {
    char path[4200];
    snprintf(path, sizeof path, "%s/" CONFIG_FILE, dir);
    FILE *file = fopen(path, "rb");
    if (!file) return 0;
    char *json = calloc(1, 1 << 20);
    size_t n = 0;
    if (json) {
        size_t size = fread(json, 1, (1 << 20) - 1, file);
        json[size] = '\0';
        n = json_strings(json, "site", out, max);
        for (size_t i = 0; i < n; i++) {
            if (out[i][0] == '/') continue;
            char relative[FOLDER_SIZE];
            memcpy(relative, out[i], FOLDER_SIZE);
            snprintf(out[i], FOLDER_SIZE, "%.*s/../../resources/%.*s", FOLDER_SIZE / 2, dir,
                     FOLDER_SIZE / 3, relative);
        }
    }
    free(json);
    fclose(file);
    return n;
}

/* The installation prefix of a libpython: /usr for /usr/lib/x86_64-linux-gnu/libpython3.12.so.1.0
   or /usr/lib64/..., /opt/py for /opt/py/lib/libpython3.12.so.1.0. */
static void library_prefix(const char *library, char *prefix, size_t n) {
    snprintf(prefix, n, "%s", library);
    char *slash = strrchr(prefix, '/');
    if (!slash || slash == prefix) {
        snprintf(prefix, n, "/usr");
        return;
    }
    *slash = '\0'; /* its folder */
    for (int up = 0; up < 2; up++) {
        slash = strrchr(prefix, '/');
        if (!slash || slash == prefix) break;
        int lib = strcmp(slash, "/lib") == 0 || strcmp(slash, "/lib64") == 0;
        *slash = '\0';
        if (lib) return;
    }
    /* no lib folder: the folder above the library's */
    snprintf(prefix, n, "%s", library);
    *strrchr(prefix, '/') = '\0';
    slash = strrchr(prefix, '/');
    if (slash && slash != prefix) *slash = '\0';
}

/* Where the Python of `c` looks for packages (site.py's folders for its prefix: pyenv's and
   python.org's lib/python3.X/site-packages, Debian's dist-packages, Fedora's lib64, the user's
   site) and the recorded folders for the build's version: which hold numpy and scipy. */
static void look_for_packages(Candidate *c, char recorded[][FOLDER_SIZE], size_t n_recorded) {
    static const char *const layouts[] = {
        "%s/lib/python%s/site-packages",       "%s/lib64/python%s/site-packages",
        "%s/lib/python%s/dist-packages",       "%s/lib/python3/dist-packages",
        "%s/local/lib/python%s/dist-packages", "%s/local/lib/python%s/site-packages",
        "%s/local/lib64/python%s/site-packages"};
    char prefix[PATH_MAX];
    library_prefix(c->library, prefix, sizeof prefix);
    char folders[MAX_FOLDERS + 16][FOLDER_SIZE];
    size_t n = 0;
    for (size_t i = 0; i < sizeof layouts / sizeof *layouts; i++)
        snprintf(folders[n++], FOLDER_SIZE, layouts[i], prefix, c->version);
    const char *home = getenv("HOME");
    struct passwd *user = home ? NULL : getpwuid(getuid());
    if (!home && user) home = user->pw_dir;
    if (home) snprintf(folders[n++], FOLDER_SIZE, "%s/.local/lib/python%s/site-packages", home,
                       c->version);
    if (strcmp(c->version, PYTHON_VERSION) == 0)
        for (size_t i = 0; i < n_recorded && n < sizeof folders / sizeof *folders; i++)
            memcpy(folders[n++], recorded[i], FOLDER_SIZE);
    for (size_t i = 0; i < n; i++) {
        struct stat info;
        if (stat(folders[i], &info) != 0 || !S_ISDIR(info.st_mode)) continue;
        int numpy = has_package(folders[i], "numpy"), scipy = has_package(folders[i], "scipy");
        c->numpy |= numpy;
        c->scipy |= scipy;
        add_text(&c->folders, "%s%s%s", c->folders.used ? ", " : "", folders[i],
                 numpy && scipy ? " (numpy, scipy)" : numpy ? " (numpy)" : scipy ? " (scipy)"
                                                                           : "");
    }
}

/* "3.11, 3.12 or 3.13" */
static void versions_text(Text *t, const char *const *versions, size_t n) {
    for (size_t i = 0; i < n; i++)
        add_text(t, "%s%s", i == 0 ? "" : i + 1 == n ? " or " : ", ", versions[i]);
}

/* Why a started Python could not run the FMU may lie in the choice: said with its failure. */
static Text python_choice;

/* Load the libpython of the Python chosen as described in 1. above, RTLD_GLOBAL; NULL after a
   report naming what was looked for. */
static void *open_python(const fmi2CallbackFunctions *f, fmi2String name, const char *dir) {
    /* the versions, the build's first */
    static char list[256];
    snprintf(list, sizeof list, "%s", PYTHON_VERSIONS);
    const char *versions[MAX_CANDIDATES];
    size_t n_versions = 0;
    versions[n_versions++] = PYTHON_VERSION;
    for (char *save = NULL, *v = strtok_r(list, " ", &save); v && n_versions < MAX_CANDIDATES;
         v = strtok_r(NULL, " ", &save))
        if (strcmp(v, PYTHON_VERSION) != 0) versions[n_versions++] = v;
    /* the files to try: the build's libpython, then each version's soname */
    static struct { const char *version; char file[PATH_MAX]; } tries[MAX_CANDIDATES + 2];
    size_t n_tries = 0;
    if (LIBPYTHON_PATH[0]) {
        tries[n_tries].version = PYTHON_VERSION;
        snprintf(tries[n_tries++].file, PATH_MAX, "%s", LIBPYTHON_PATH);
    }
    tries[n_tries].version = PYTHON_VERSION;
    snprintf(tries[n_tries++].file, PATH_MAX, "%s", LIBPYTHON_SONAME);
    for (size_t i = 1; i < n_versions; i++) { /* LIBPYTHON_SONAME is the build's version's */
        char soname[64];
        snprintf(soname, sizeof soname, "libpython%s.so.1.0", versions[i]);
        tries[n_tries].version = versions[i];
        snprintf(tries[n_tries++].file, PATH_MAX, "%s", soname);
    }

    static char recorded[MAX_FOLDERS][FOLDER_SIZE];
    size_t n_recorded = recorded_folders(dir, recorded, MAX_FOLDERS);
    static Candidate found[MAX_CANDIDATES + 2];
    size_t n_found = 0;
    Text missing = {0};
    int chosen = -1;
    for (size_t i = 0; i < n_tries && chosen < 0; i++) {
        void *handle = dlopen(tries[i].file, RTLD_NOW | RTLD_LOCAL);
        if (!handle) {
            add_text(&missing, "%s%s", missing.used ? "; " : "", dlerror());
            continue;
        }
        Candidate *c = &found[n_found];
        memset(c, 0, sizeof *c);
        struct link_map *map = NULL;
        if (dlinfo(handle, RTLD_DI_LINKMAP, &map) != 0 || !map || !map->l_name ||
            !realpath(map->l_name, c->library))
            snprintf(c->library, sizeof c->library, "%s", tries[i].file);
        int again = 0; /* the same file under another name */
        for (size_t j = 0; j < n_found; j++) again |= strcmp(found[j].library, c->library) == 0;
        if (again) {
            dlclose(handle);
            continue;
        }
        c->version = tries[i].version;
        c->handle = handle;
        look_for_packages(c, recorded, n_recorded);
        if (c->numpy && c->scipy) chosen = (int)n_found;
        n_found++;
    }
    if (n_found == 0) {
        Text wanted = {0};
        versions_text(&wanted, versions, n_versions);
        report(f, name,
               "needs the shared library of Python %s (libpython3.X.so.1.0), which this "
               "process has not loaded and which was not found: %s. Install one of them as a "
               "shared library, with numpy and scipy (Debian/Ubuntu: apt-get install "
               "libpython3.X python3-numpy python3-scipy, 3.X the version of python3), or use "
               "the standalone FMU, which carries its own Python (docs/how-to/hand-over-the-fmu.md).",
               wanted.text, missing.text);
        return NULL;
    }
    if (chosen < 0) { /* none has both: the first found says what it lacks */
        chosen = 0;
        Text wanted = {0};
        versions_text(&wanted, versions, n_versions);
        add_text(&python_choice, "looked for a Python %s whose site-packages hold numpy and "
                 "scipy, found none: ", wanted.text);
        for (size_t i = 0; i < n_found; i++)
            add_text(&python_choice, "%sPython %s (%s): %s; site-packages: %s",
                     i ? "; " : "", found[i].version, found[i].library,
                     found[i].numpy ? "numpy, no scipy" : found[i].scipy ? "scipy, no numpy"
                                                                           : "no numpy or scipy",
                     found[i].folders.used ? found[i].folders.text : "none exists");
        if (missing.used) add_text(&python_choice, "; not found: %s", missing.text);
        add_text(&python_choice, ". Started Python %s (%s)", found[0].version, found[0].library);
    }
    void *py = dlopen(found[chosen].library, RTLD_NOW | RTLD_GLOBAL);
    if (!py) report(f, name, "cannot load %s: %s", found[chosen].library, dlerror());
    snprintf(python_started, sizeof python_started, "Python %s (%s)", found[chosen].version,
             found[chosen].library);
    for (size_t i = 0; i < n_found; i++) dlclose(found[i].handle); /* the others go */
    return py;
}
#endif

/* PythonFMU's finalizePythonInterpreter, run at exit before its own destructors (6. above). */
static void (*pythonfmu_finalize)(void) = NULL;

static void finalize_pythonfmu(void *unused) {
    (void)unused;
    pythonfmu_finalize();
}

/* Load Python (if the process has none) and PythonFMU's library; 1 on success. */
static int load(const fmi2CallbackFunctions *f, fmi2String name) {
    pthread_mutex_lock(&load_lock);
    if (loaded) {
        pthread_mutex_unlock(&load_lock);
        return 1;
    }
    int ok = 0;
    char dir[4096];
    if (!own_directory(dir, sizeof dir)) {
        report(f, name, "cannot locate its own library (dladdr failed)");
        goto done;
    }
    py_is_initialized = (int (*)(void))dlsym(RTLD_DEFAULT, "Py_IsInitialized");
    if (!py_is_initialized) {
        /* No Python symbols in the global scope: a native host. RTLD_GLOBAL, because numpy's
           and scipy's extension modules do not link libpython either. */
#ifdef BUNDLED_PYTHON
        if (!start_bundled_python(f, name, dir)) goto done;
#else
        void *py = open_python(f, name, dir);
        if (!py) goto done;
        py_is_initialized = (int (*)(void))dlsym(py, "Py_IsInitialized");
#endif
    }
    char path[4200];
    snprintf(path, sizeof path, "%s/%s", dir, PYTHONFMU_LIBRARY);
    void *lib = dlopen(path, RTLD_NOW | RTLD_LOCAL | RTLD_NODELETE);
    if (!lib) {
        report(f, name, "cannot load PythonFMU's library %s: %s", path, dlerror());
        goto done;
    }
    /* 6. above: finalize PythonFMU's interpreter state before its static destructor frees it */
    pythonfmu_finalize = (void (*)(void))dlsym(lib, "finalizePythonInterpreter");
    if (pythonfmu_finalize) __cxa_atexit(finalize_pythonfmu, NULL, NULL);
    void **slots = (void **)&real;
    for (size_t i = 0; i < sizeof function_names / sizeof *function_names; i++) {
        slots[i] = dlsym(lib, function_names[i]);
        if (!slots[i]) {
            report(f, name, "%s lacks the FMI function %s", path, function_names[i]);
            goto done;
        }
    }
    loaded = ok = 1;
done:
    pthread_mutex_unlock(&load_lock);
    return ok;
}

static int category_enabled(const Instance *inst, fmi2String category) {
    if (!inst->logging_on) return 0;
    if (inst->n_categories == 0) return 1;
    for (size_t i = 0; i < inst->n_categories; i++)
        if (category && strcmp(category, inst->categories[i]) == 0) return 1;
    return 0;
}

/* A category of modelDescription.xml's LogCategories for a message that came without one. */
static fmi2String status_category(fmi2Status status) {
    switch (status) {
    case fmi2OK: return "logAll";
    case fmi2Warning: return "logStatusWarning";
    case fmi2Discard: return "logStatusDiscard";
    case fmi2Error: return "logStatusError";
    default: return "logStatusFatal";
    }
}

/* A printf-style message as text: in `small` (n bytes) if it fits, else in a buffer of its own
   (free it when it is not `small`; `small`, cut, if that allocation fails). */
static char *format_text(char *small, size_t n, const char *fmt, va_list args) {
    va_list again;
    va_copy(again, args);
    int needed = vsnprintf(small, n, fmt ? fmt : "", args);
    char *text = small;
    if (needed >= (int)n && (text = malloc((size_t)needed + 1)))
        vsnprintf(text, (size_t)needed + 1, fmt, again);
    va_end(again);
    return text ? text : small;
}

/* The logger PythonFMU calls: note a failed call, forward what the host should see. */
static void forward_log(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status,
                        fmi2String category, fmi2String message, ...) {
    Instance *inst = env;
    if (category && strcmp(category, FAIL_CATEGORY) == 0) {
        inst->failed = 1;
        category = "logStatusError";
        if (status < fmi2Error) status = fmi2Error;
    }
    if (!category) category = status_category(status); /* PythonFMU's exceptions have none */
    if (!name) name = inst->name;
    int to_stderr = inst->instantiating && status >= fmi2Warning;
    if (!to_stderr && (!inst->host.logger ||
                       (status == fmi2OK && !category_enabled(inst, category))))
        return;
    char small[1024];
    va_list args;
    va_start(args, message);
    char *text = format_text(small, sizeof small, message, args);
    va_end(args);
    /* The reason a start failed reaches the user even where the host shows no FMU log. */
    if (to_stderr) fprintf(stderr, MODEL_IDENTIFIER ".fmu: %s\n", text);
    if (inst->host.logger && (status != fmi2OK || category_enabled(inst, category)))
        inst->host.logger(inst->host.componentEnvironment, name, status, category, "%s", text);
    if (text != small) free(text);
}

/* Said once per process, on stderr, for each kind of call the loader refuses to pass on. */
static void refused_once(int *said, const char *function, const char *why) {
    if (*said) return;
    *said = 1;
    fprintf(stderr, MODEL_IDENTIFIER ".fmu: %s %s\n", function, why);
}

/* The instance of a call that may reach Python, or NULL when it must not: a NULL component, or
   the process's Python already finalized. */
static Instance *begin(fmi2Component c, const char *function) {
    static int said_null = 0;
    if (!c) {
        refused_once(&said_null, function,
                     "was called with a NULL instance (did fmi2Instantiate fail?): fmi2Error");
        return NULL;
    }
    if (!python_alive()) return NULL; /* after the host's Python exited: nothing to reach */
    Instance *inst = c;
    inst->failed = 0;
    return inst;
}

static fmi2Status finish(Instance *inst, fmi2Status status) {
    return (inst->failed && status < fmi2Error) ? fmi2Error : status;
}

/* The FMU states an instance handed out (fmi2GetFMUstate, fmi2DeSerializeFMUstate) and has not
   freed. PythonFMU dereferences the state arguments it is given, so each is checked against
   these first: a state the instance never handed out, or freed already, is refused with
   fmi2Error and a message, never passed on (a host's slip must not crash it). */
static long state_index(const Instance *inst, const void *state) {
    for (size_t i = 0; i < inst->n_states; i++)
        if (inst->states[i] == state) return (long)i;
    return -1;
}

static int state_add(Instance *inst, fmi2FMUstate state) {
    if (!state || state_index(inst, state) >= 0) return 1;
    if (inst->n_states == inst->cap_states) {
        size_t cap = inst->cap_states ? 2 * inst->cap_states : 8;
        fmi2FMUstate *grown = realloc(inst->states, cap * sizeof *grown);
        if (!grown) return 0;
        inst->states = grown;
        inst->cap_states = cap;
    }
    inst->states[inst->n_states++] = state;
    return 1;
}

static void state_remove(Instance *inst, long i) {
    inst->states[i] = inst->states[--inst->n_states];
}

/* A message of the loader's own to the host's logger (stderr where it has none). */
static void say(Instance *inst, fmi2Status status, const char *fmt, ...) {
    char text[1024];
    va_list args;
    va_start(args, fmt);
    vsnprintf(text, sizeof text, fmt, args);
    va_end(args);
    if (inst->host.logger)
        inst->host.logger(inst->host.componentEnvironment, inst->name, status,
                          status_category(status), "%s", text);
    else
        fprintf(stderr, MODEL_IDENTIFIER ".fmu: %s\n", text);
}

/* A state argument passed by value: one this instance handed out, else a message and 0. */
static int known_state(Instance *inst, fmi2FMUstate state, const char *function) {
    if (state && state_index(inst, state) >= 0) return 1;
    say(inst, fmi2Error, "%s: the FMU state %p is not one this instance handed out and still "
        "holds (freed already, or never got from fmi2GetFMUstate or fmi2DeSerializeFMUstate): "
        "refused", function, (void *)state);
    return 0;
}

EXPORT const char *fmi2GetTypesPlatform(void) { return "default"; }

EXPORT const char *fmi2GetVersion(void) { return "2.0"; }

EXPORT fmi2Component fmi2Instantiate(fmi2String name, fmi2Type type, fmi2String guid,
                                     fmi2String resources, const fmi2CallbackFunctions *functions,
                                     fmi2Boolean visible, fmi2Boolean loggingOn) {
    if (!load(functions, name)) return NULL;
    if (python_seen && !python_alive()) {
        report(functions, name, "cannot start: the Python of this process has been finalized");
        return NULL;
    }
    Instance *inst = calloc(1, sizeof *inst);
    if (!inst) return NULL;
    if (functions) inst->host = *functions;
    inst->ours = inst->host;
    inst->ours.logger = forward_log;
    inst->ours.componentEnvironment = inst;
    inst->name = copy_string(name ? name : MODEL_IDENTIFIER);
    if (!inst->name) {
        free(inst);
        return NULL;
    }
    inst->logging_on = loggingOn;
    inst->instantiating = 1;
    inst->component = real.Instantiate(inst->name, type, guid, resources, &inst->ours, visible,
                                       1);
    inst->instantiating = 0;
    if (!inst->component) {
#ifndef BUNDLED_PYTHON
        if (python_choice.used) report(functions, inst->name, "%s", python_choice.text);
#endif
        report(functions, inst->name, "fmi2Instantiate of instance '%s' failed (the reason is "
               "above)", inst->name);
        free(inst->name);
        free(inst);
        return NULL;
    }
    python_seen = 1;
    static int said_python = 0;
    if (python_started[0] && !said_python && loggingOn && functions && functions->logger) {
        said_python = 1;
        functions->logger(functions->componentEnvironment, inst->name, fmi2OK, "logAll",
                          "started %s", python_started);
    }
    return inst;
}

EXPORT void fmi2FreeInstance(fmi2Component c) {
    if (!c) return;
    Instance *inst = c;
    /* After the host's Python exited, PythonFMU's objects went with it: free only ours. */
    if (python_alive()) real.FreeInstance(inst->component);
    clear_categories(inst);
    free(inst->states);
    free(inst->name);
    free(inst);
}

EXPORT fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t n,
                                      const fmi2String categories[]) {
    static int said_null = 0;
    if (!c) {
        refused_once(&said_null, "fmi2SetDebugLogging",
                     "was called with a NULL instance (did fmi2Instantiate fail?): fmi2Error");
        return fmi2Error;
    }
    Instance *inst = c;
    clear_categories(inst);
    inst->logging_on = loggingOn;
    if (loggingOn && n > 0 && categories) {
        inst->categories = calloc(n, sizeof *inst->categories);
        if (!inst->categories) return fmi2Error;
        for (size_t i = 0; i < n; i++) inst->categories[i] = copy_string(categories[i]);
        inst->n_categories = n;
    }
    return fmi2OK;
}

/* Pass-through functions: C is PythonFMU's component, status upgraded by finish(). A call that
   cannot reach Python returns fmi2Error, but fmi2Terminate after the host's Python exited has
   nothing left to end: fmi2OK. */
#define C (inst->component)
#define PASS(call) \
    Instance *inst = begin(c, __func__); \
    if (!inst) return fmi2Error; \
    return finish(inst, real.call)

EXPORT fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined,
                                      fmi2Real tolerance, fmi2Real startTime,
                                      fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    PASS(SetupExperiment(C, toleranceDefined, tolerance, startTime, stopTimeDefined, stopTime));
}
EXPORT fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    PASS(EnterInitializationMode(C));
}
EXPORT fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    PASS(ExitInitializationMode(C));
}
EXPORT fmi2Status fmi2Terminate(fmi2Component c) {
    if (c && !python_alive()) return fmi2OK;
    PASS(Terminate(C));
}
EXPORT fmi2Status fmi2Reset(fmi2Component c) { PASS(Reset(C)); }
EXPORT fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                              fmi2Real value[]) {
    PASS(GetReal(C, vr, nvr, value));
}
EXPORT fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                 fmi2Integer value[]) {
    PASS(GetInteger(C, vr, nvr, value));
}
EXPORT fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                 fmi2Boolean value[]) {
    PASS(GetBoolean(C, vr, nvr, value));
}
EXPORT fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                fmi2String value[]) {
    PASS(GetString(C, vr, nvr, value));
}
EXPORT fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                              const fmi2Real value[]) {
    PASS(SetReal(C, vr, nvr, value));
}
EXPORT fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                 const fmi2Integer value[]) {
    PASS(SetInteger(C, vr, nvr, value));
}
EXPORT fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                 const fmi2Boolean value[]) {
    PASS(SetBoolean(C, vr, nvr, value));
}
EXPORT fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                const fmi2String value[]) {
    PASS(SetString(C, vr, nvr, value));
}
/* The state functions check their state arguments against the states handed out first
   (state_index): PythonFMU dereferences what it is given. */
#define STATE_CALL(check, call) \
    Instance *inst = begin(c, __func__); \
    if (!inst) return fmi2Error; \
    if (!(check)) return fmi2Error; \
    return finish(inst, real.call)

/* *state: NULL for a new state, or one handed out to be overwritten. */
static int new_or_known(Instance *inst, fmi2FMUstate *state, const char *function) {
    if (!state) {
        say(inst, fmi2Error, "%s: the pointer to the FMU state is NULL: refused", function);
        return 0;
    }
    return !*state || known_state(inst, *state, function);
}

EXPORT fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *state) {
    Instance *inst = begin(c, __func__);
    if (!inst) return fmi2Error;
    if (!new_or_known(inst, state, __func__)) return fmi2Error;
    fmi2FMUstate before = *state;
    fmi2Status status = finish(inst, real.GetFMUstate(C, state));
    if (status <= fmi2Warning && *state != before && before) /* replaced, not overwritten */
        state_remove(inst, state_index(inst, before));
    if (status <= fmi2Warning && !state_add(inst, *state)) return fmi2Error;
    return status;
}
EXPORT fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate state) {
    STATE_CALL(known_state(inst, state, __func__), SetFMUstate(C, state));
}
EXPORT fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *state) {
    Instance *inst = begin(c, __func__);
    if (!inst) return fmi2Error;
    if (!state) {
        say(inst, fmi2Error, "%s: the pointer to the FMU state is NULL: refused", __func__);
        return fmi2Error;
    }
    /* A host that passes the state itself, not a pointer to it (fmusim's slip when it saves a
       state to a file): unambiguous, since a state is an object of this FMU's, never a host's
       variable. That state is freed, with a warning in the log, and the call succeeds, so that
       the host's save completes (fmusim stops with an error on any status but fmi2OK). */
    long i = state_index(inst, state);
    if (i >= 0) {
        fmi2FMUstate handle = (fmi2FMUstate)state;
        say(inst, fmi2Warning, "%s was given the FMU state %p itself, not a pointer to it (a "
            "slip of the host's, fmusim's among them): that state is freed", __func__,
            (void *)state);
        fmi2Status status = finish(inst, real.FreeFMUstate(C, &handle));
        state_remove(inst, i);
        return status;
    }
    if (!*state) return fmi2OK; /* nothing to free (FMI 2.0) */
    i = state_index(inst, *state);
    if (i < 0) {
        known_state(inst, *state, __func__); /* the message */
        return fmi2Error;
    }
    fmi2Status status = finish(inst, real.FreeFMUstate(C, state));
    state_remove(inst, i);
    *state = NULL;
    return status;
}
EXPORT fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate state, size_t *size) {
    STATE_CALL(known_state(inst, state, __func__), SerializedFMUstateSize(C, state, size));
}
EXPORT fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate state, fmi2Byte bytes[],
                                        size_t size) {
    STATE_CALL(known_state(inst, state, __func__), SerializeFMUstate(C, state, bytes, size));
}
EXPORT fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte bytes[], size_t size,
                                          fmi2FMUstate *state) {
    Instance *inst = begin(c, __func__);
    if (!inst) return fmi2Error;
    if (!new_or_known(inst, state, __func__)) return fmi2Error;
    fmi2Status status = finish(inst, real.DeSerializeFMUstate(C, bytes, size, state));
    if (status <= fmi2Warning && !state_add(inst, *state)) return fmi2Error;
    return status;
}
EXPORT fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference u[],
                                               size_t nu, const fmi2ValueReference z[], size_t nz,
                                               const fmi2Real dv[], fmi2Real dz[]) {
    PASS(GetDirectionalDerivative(C, u, nu, z, nz, dv, dz));
}
EXPORT fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[],
                                              size_t nvr, const fmi2Integer order[],
                                              const fmi2Real value[]) {
    PASS(SetRealInputDerivatives(C, vr, nvr, order, value));
}
EXPORT fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[],
                                               size_t nvr, const fmi2Integer order[],
                                               fmi2Real value[]) {
    PASS(GetRealOutputDerivatives(C, vr, nvr, order, value));
}
EXPORT fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean noSetPrior) {
    PASS(DoStep(C, t, h, noSetPrior));
}
EXPORT fmi2Status fmi2CancelStep(fmi2Component c) { PASS(CancelStep(C)); }
EXPORT fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value) {
    PASS(GetStatus(C, s, value));
}
EXPORT fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value) {
    PASS(GetRealStatus(C, s, value));
}
EXPORT fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s,
                                       fmi2Integer *value) {
    PASS(GetIntegerStatus(C, s, value));
}
EXPORT fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s,
                                       fmi2Boolean *value) {
    PASS(GetBooleanStatus(C, s, value));
}
EXPORT fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s,
                                      fmi2String *value) {
    PASS(GetStringStatus(C, s, value));
}
