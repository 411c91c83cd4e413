/*
 * Minimal FMI 2.0 Co-Simulation master in C, to run IceImpact.fmu outside Python.
 *
 *   host FMU_DIR [-n STEPS] [-h STEP] [-s NAME=VALUE]... [-o NAME]... [-k] [-N] [-S] [-E]
 *        [-T] [-P LIBPYTHON]
 *
 * FMU_DIR is the extracted FMU (modelDescription.xml, binaries/linux64/<id>.so, resources/).
 * Sets the given parameters, steps STEPS communication steps of STEP seconds (default 2000 x 1 ms)
 * and prints time plus the outputs (all outputs, or those given with -o) as CSV on stdout after the
 * initialization and after every step. -k keeps the library loaded (no dlclose) at exit.
 *
 * The failure paths of real hosts, each on request:
 *   -N  calls every FMI function that takes an instance with NULL first, as ECOS calls
 *       fmi2SetupExperiment on the NULL a failed fmi2Instantiate returned, and prints
 *       "null <function> <status>" for each on stdout; it goes on after a failed fmi2Instantiate
 *       too (exit status 3 then);
 *   -S  a logger that aborts on a NULL instance name or category, as OMSimulator's does (it
 *       builds a std::string from each);
 *   -E  exits without fmi2Terminate and fmi2FreeInstance (static destructors still run);
 *   -T  prints "instantiate_seconds <s>": the time from the start of main to the return of the
 *       first fmi2Instantiate (dlopen included), then frees the instance and exits;
 *   -P  embeds Python first (LIBPYTHON, RTLD_GLOBAL, Py_InitializeEx), as a Python host does,
 *       finalizes it after the last step, and then calls fmi2Terminate and fmi2FreeInstance, as
 *       OMSimulator's static destructor does after the host's Python exited; prints
 *       "after finalize: terminate <status>" on stdout.
 *
 * A PythonFMU FMU needs libpython in the process and numpy/scipy on the module path:
 *   LD_PRELOAD=$LIBDIR/libpython3.11.so PYTHONPATH=<site-packages> ./host FMU_DIR
 *
 * Only the few FMI types and functions used here are declared (fmi2TypesPlatform.h and
 * fmi2FunctionTypes.h of the FMI 2.0 standard).
 */
#include <dlfcn.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

typedef void *fmi2Component;
typedef void *fmi2ComponentEnvironment;
typedef unsigned int fmi2ValueReference;
typedef double fmi2Real;
typedef int fmi2Integer;
typedef int fmi2Boolean;
typedef const char *fmi2String;
typedef enum { fmi2OK, fmi2Warning, fmi2Discard, fmi2Error, fmi2Fatal, fmi2Pending } fmi2Status;
typedef enum { fmi2ModelExchange, fmi2CoSimulation } fmi2Type;
#define fmi2True 1
#define fmi2False 0

typedef struct {
    void (*logger)(fmi2ComponentEnvironment, fmi2String, fmi2Status, fmi2String, fmi2String, ...);
    void *(*allocateMemory)(size_t, size_t);
    void (*freeMemory)(void *);
    void (*stepFinished)(fmi2ComponentEnvironment, fmi2Status);
    fmi2ComponentEnvironment componentEnvironment;
} fmi2CallbackFunctions;

typedef fmi2Component (*fmi2InstantiateTYPE)(fmi2String, fmi2Type, fmi2String, fmi2String,
                                              const fmi2CallbackFunctions *, fmi2Boolean,
                                              fmi2Boolean);
typedef void (*fmi2FreeInstanceTYPE)(fmi2Component);
typedef fmi2Status (*fmi2SetupExperimentTYPE)(fmi2Component, fmi2Boolean, fmi2Real, fmi2Real,
                                              fmi2Boolean, fmi2Real);
typedef fmi2Status (*fmi2ComponentFunctionTYPE)(fmi2Component);
typedef fmi2Status (*fmi2GetRealTYPE)(fmi2Component, const fmi2ValueReference *, size_t,
                                      fmi2Real *);
typedef fmi2Status (*fmi2GetIntegerTYPE)(fmi2Component, const fmi2ValueReference *, size_t,
                                         fmi2Integer *);
typedef fmi2Status (*fmi2GetBooleanTYPE)(fmi2Component, const fmi2ValueReference *, size_t,
                                         fmi2Boolean *);
typedef fmi2Status (*fmi2SetRealTYPE)(fmi2Component, const fmi2ValueReference *, size_t,
                                      const fmi2Real *);
typedef fmi2Status (*fmi2SetIntegerTYPE)(fmi2Component, const fmi2ValueReference *, size_t,
                                         const fmi2Integer *);
typedef fmi2Status (*fmi2DoStepTYPE)(fmi2Component, fmi2Real, fmi2Real, fmi2Boolean);

#define MAX_VARS 256

typedef struct {
    char name[128];
    char causality[32];
    char type[16]; /* Real, Integer, Boolean, String */
    fmi2ValueReference vr;
} Variable;

static Variable vars[MAX_VARS];
static int n_vars = 0;

static int strict_logger = 0;

static void logger(fmi2ComponentEnvironment env, fmi2String instance, fmi2Status status,
                   fmi2String category, fmi2String message, ...) {
    (void)env;
    if (strict_logger && (!instance || !category || !message)) {
        fprintf(stderr, "host: the FMU logged with a NULL %s\n",
                !instance ? "instance name" : !category ? "category" : "message");
        abort();
    }
    va_list args;
    va_start(args, message);
    fprintf(stderr, "[%s] status %d [%s] ", instance ? instance : "?", (int)status,
            category ? category : "");
    vfprintf(stderr, message, args);
    fputc('\n', stderr);
    va_end(args);
}

static char *read_file(const char *path) {
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    fseek(f, 0, SEEK_END);
    long size = ftell(f);
    fseek(f, 0, SEEK_SET);
    char *text = malloc((size_t)size + 1);
    if (fread(text, 1, (size_t)size, f) != (size_t)size) {
        fclose(f);
        free(text);
        return NULL;
    }
    text[size] = '\0';
    fclose(f);
    return text;
}

/* Copy the value of attribute `attr` found in [start, end) into out; 0 if absent. */
static int attribute(const char *start, const char *end, const char *attr, char *out, size_t n) {
    char key[64];
    snprintf(key, sizeof key, " %s=\"", attr);
    const char *p = strstr(start, key);
    if (!p || p >= end) return 0;
    p += strlen(key);
    const char *q = strchr(p, '"');
    if (!q || q >= end || (size_t)(q - p) >= n) return 0;
    memcpy(out, p, (size_t)(q - p));
    out[q - p] = '\0';
    return 1;
}

/* The guid and the ScalarVariables of modelDescription.xml (enough of a parser for PythonFMU). */
static int parse_model_description(const char *xml, char *guid, size_t guid_size) {
    if (!attribute(xml, xml + strlen(xml), "guid", guid, guid_size)) return 0;
    const char *p = xml;
    while ((p = strstr(p, "<ScalarVariable")) && n_vars < MAX_VARS) {
        const char *tag_end = strchr(p, '>');
        const char *var_end = strstr(p, "</ScalarVariable>");
        if (!tag_end || !var_end) return 0;
        Variable *v = &vars[n_vars];
        char vr[32];
        if (!attribute(p, tag_end, "name", v->name, sizeof v->name) ||
            !attribute(p, tag_end, "valueReference", vr, sizeof vr))
            return 0;
        v->vr = (fmi2ValueReference)strtoul(vr, NULL, 10);
        if (!attribute(p, tag_end, "causality", v->causality, sizeof v->causality))
            strcpy(v->causality, "local");
        const char *types[] = {"Real", "Integer", "Boolean", "String"};
        v->type[0] = '\0';
        for (int i = 0; i < 4; i++) {
            char open[16];
            snprintf(open, sizeof open, "<%s", types[i]);
            const char *t = strstr(tag_end, open);
            if (t && t < var_end) strcpy(v->type, types[i]);
        }
        n_vars++;
        p = var_end;
    }
    return n_vars > 0;
}

static Variable *find_variable(const char *name) {
    for (int i = 0; i < n_vars; i++)
        if (strcmp(vars[i].name, name) == 0) return &vars[i];
    return NULL;
}

static void *symbol(void *lib, const char *name) {
    void *f = dlsym(lib, name);
    if (!f) {
        fprintf(stderr, "host: missing FMI function %s\n", name);
        exit(2);
    }
    return f;
}

int main(int argc, char **argv) {
    if (argc < 2) {
        fprintf(stderr, "usage: %s FMU_DIR [-n STEPS] [-h STEP] [-s NAME=VALUE]... [-o NAME]... "
                        "[-k]\n", argv[0]);
        return 2;
    }
    const char *dir = argv[1];
    long n_steps = 2000;
    double h = 1e-3;
    struct timespec started;
    clock_gettime(CLOCK_MONOTONIC, &started);
    int keep_loaded = 0, null_calls = 0, exit_early = 0, time_instantiate = 0;
    const char *embed_python = NULL;
    const char *sets[MAX_VARS];
    int n_sets = 0;
    const char *outs[MAX_VARS];
    int n_outs = 0;
    for (int i = 2; i < argc; i++) {
        if (!strcmp(argv[i], "-n") && i + 1 < argc) n_steps = strtol(argv[++i], NULL, 10);
        else if (!strcmp(argv[i], "-h") && i + 1 < argc) h = strtod(argv[++i], NULL);
        else if (!strcmp(argv[i], "-s") && i + 1 < argc && n_sets < MAX_VARS) sets[n_sets++] = argv[++i];
        else if (!strcmp(argv[i], "-o") && i + 1 < argc && n_outs < MAX_VARS) outs[n_outs++] = argv[++i];
        else if (!strcmp(argv[i], "-k")) keep_loaded = 1;
        else if (!strcmp(argv[i], "-N")) null_calls = 1;
        else if (!strcmp(argv[i], "-S")) strict_logger = 1;
        else if (!strcmp(argv[i], "-E")) exit_early = 1;
        else if (!strcmp(argv[i], "-T")) time_instantiate = 1;
        else if (!strcmp(argv[i], "-P") && i + 1 < argc) embed_python = argv[++i];
        else {
            fprintf(stderr, "host: unknown argument %s\n", argv[i]);
            return 2;
        }
    }

    char path[4096];
    snprintf(path, sizeof path, "%s/modelDescription.xml", dir);
    char *xml = read_file(path);
    char guid[128], identifier[128];
    if (!xml || !parse_model_description(xml, guid, sizeof guid) ||
        !attribute(xml, xml + strlen(xml), "modelIdentifier", identifier, sizeof identifier)) {
        fprintf(stderr, "host: cannot read %s\n", path);
        return 2;
    }
    free(xml);

    /* Outputs to print: those given with -o, else every output in valueReference order. */
    Variable *print[MAX_VARS];
    int n_print = 0;
    if (n_outs) {
        for (int i = 0; i < n_outs; i++) {
            if (!(print[n_print++] = find_variable(outs[i]))) {
                fprintf(stderr, "host: no variable %s\n", outs[i]);
                return 2;
            }
        }
    } else {
        for (int i = 0; i < n_vars; i++)
            if (!strcmp(vars[i].causality, "output")) print[n_print++] = &vars[i];
    }

    snprintf(path, sizeof path, "%s/binaries/linux64/%s.so", dir, identifier);
    void *lib = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (!lib) {
        fprintf(stderr, "host: dlopen failed: %s\n", dlerror());
        return 2;
    }
    fmi2InstantiateTYPE instantiate = (fmi2InstantiateTYPE)symbol(lib, "fmi2Instantiate");
    fmi2FreeInstanceTYPE free_instance = (fmi2FreeInstanceTYPE)symbol(lib, "fmi2FreeInstance");
    fmi2SetupExperimentTYPE setup = (fmi2SetupExperimentTYPE)symbol(lib, "fmi2SetupExperiment");
    fmi2ComponentFunctionTYPE enter_init =
        (fmi2ComponentFunctionTYPE)symbol(lib, "fmi2EnterInitializationMode");
    fmi2ComponentFunctionTYPE exit_init =
        (fmi2ComponentFunctionTYPE)symbol(lib, "fmi2ExitInitializationMode");
    fmi2ComponentFunctionTYPE terminate = (fmi2ComponentFunctionTYPE)symbol(lib, "fmi2Terminate");
    fmi2GetRealTYPE get_real = (fmi2GetRealTYPE)symbol(lib, "fmi2GetReal");
    fmi2GetIntegerTYPE get_integer = (fmi2GetIntegerTYPE)symbol(lib, "fmi2GetInteger");
    fmi2GetBooleanTYPE get_boolean = (fmi2GetBooleanTYPE)symbol(lib, "fmi2GetBoolean");
    fmi2SetRealTYPE set_real = (fmi2SetRealTYPE)symbol(lib, "fmi2SetReal");
    fmi2SetIntegerTYPE set_integer = (fmi2SetIntegerTYPE)symbol(lib, "fmi2SetInteger");
    fmi2DoStepTYPE do_step = (fmi2DoStepTYPE)symbol(lib, "fmi2DoStep");

    void (*py_finalize)(void) = NULL;
    if (embed_python) {
        void *py = dlopen(embed_python, RTLD_NOW | RTLD_GLOBAL);
        if (!py) {
            fprintf(stderr, "host: cannot load %s: %s\n", embed_python, dlerror());
            return 2;
        }
        void (*initialize)(int) = (void (*)(int))symbol(py, "Py_InitializeEx");
        py_finalize = (void (*)(void))symbol(py, "Py_Finalize");
        initialize(0);
    }

    if (null_calls) {
        fmi2ValueReference vr = 0;
        fmi2Real real_value = 0.0;
        fmi2Integer integer_value = 0;
        fmi2Boolean boolean_value = 0;
        printf("null fmi2SetupExperiment %d\n", (int)setup(NULL, fmi2False, 0.0, 0.0, fmi2False,
                                                             0.0));
        printf("null fmi2EnterInitializationMode %d\n", (int)enter_init(NULL));
        printf("null fmi2ExitInitializationMode %d\n", (int)exit_init(NULL));
        printf("null fmi2GetReal %d\n", (int)get_real(NULL, &vr, 1, &real_value));
        printf("null fmi2GetInteger %d\n", (int)get_integer(NULL, &vr, 1, &integer_value));
        printf("null fmi2GetBoolean %d\n", (int)get_boolean(NULL, &vr, 1, &boolean_value));
        printf("null fmi2SetReal %d\n", (int)set_real(NULL, &vr, 1, &real_value));
        printf("null fmi2SetInteger %d\n", (int)set_integer(NULL, &vr, 1, &integer_value));
        printf("null fmi2DoStep %d\n", (int)do_step(NULL, 0.0, 1e-3, fmi2True));
        printf("null fmi2Terminate %d\n", (int)terminate(NULL));
        const char *names[] = {"fmi2Reset", "fmi2CancelStep"};
        for (int i = 0; i < 2; i++) {
            fmi2ComponentFunctionTYPE f = (fmi2ComponentFunctionTYPE)symbol(lib, names[i]);
            printf("null %s %d\n", names[i], (int)f(NULL));
        }
        fmi2Status (*debug)(fmi2Component, fmi2Boolean, size_t, const fmi2String *) =
            (fmi2Status(*)(fmi2Component, fmi2Boolean, size_t, const fmi2String *))symbol(
                lib, "fmi2SetDebugLogging");
        printf("null fmi2SetDebugLogging %d\n", (int)debug(NULL, fmi2True, 0, NULL));
        free_instance(NULL);
        printf("null fmi2FreeInstance done\n");
        fflush(stdout);
    }

    char resources[4200];
    snprintf(resources, sizeof resources, "file://%s/resources", dir);
    fmi2CallbackFunctions callbacks = {logger, calloc, free, NULL, NULL};
    fmi2Component c = instantiate("host", fmi2CoSimulation, guid, resources, &callbacks, fmi2False,
                                  fmi2True);
    if (!c) {
        fprintf(stderr, "host: fmi2Instantiate failed\n");
        if (null_calls) /* what ECOS does next */
            printf("null-after-failure fmi2SetupExperiment %d\n",
                   (int)setup(c, fmi2False, 0.0, 0.0, fmi2False, 0.0));
        return 3;
    }
    if (time_instantiate) {
        struct timespec now;
        clock_gettime(CLOCK_MONOTONIC, &now);
        printf("instantiate_seconds %.6f\n",
               (double)(now.tv_sec - started.tv_sec) + 1e-9 * (double)(now.tv_nsec - started.tv_nsec));
        free_instance(c);
        return 0;
    }

    int status = 0;
    if (setup(c, fmi2False, 0.0, 0.0, fmi2False, 0.0) > fmi2Warning) status = 3;
    for (int i = 0; i < n_sets && !status; i++) {
        char name[128];
        const char *eq = strchr(sets[i], '=');
        if (!eq || (size_t)(eq - sets[i]) >= sizeof name) {
            fprintf(stderr, "host: bad -s %s\n", sets[i]);
            return 2;
        }
        memcpy(name, sets[i], (size_t)(eq - sets[i]));
        name[eq - sets[i]] = '\0';
        Variable *v = find_variable(name);
        if (!v) {
            fprintf(stderr, "host: no variable %s\n", name);
            return 2;
        }
        fmi2Status s;
        if (!strcmp(v->type, "Integer")) {
            fmi2Integer value = (fmi2Integer)strtol(eq + 1, NULL, 10);
            s = set_integer(c, &v->vr, 1, &value);
        } else {
            fmi2Real value = strtod(eq + 1, NULL);
            s = set_real(c, &v->vr, 1, &value);
        }
        if (s > fmi2Warning) status = 3;
    }
    if (!status && enter_init(c) > fmi2Warning) status = 3;
    if (!status && exit_init(c) > fmi2Warning) status = 3;

    printf("time");
    for (int i = 0; i < n_print; i++) printf(",%s", print[i]->name);
    printf("\n");

    for (long step = 0; step <= n_steps && !status; step++) {
        double t = step * h; /* communication points as n * h, like FMPy */
        if (step > 0) {
            double t_prev = (step - 1) * h;
            fmi2Status s = do_step(c, t_prev, t - t_prev, fmi2True);
            if (s != fmi2OK) {
                fprintf(stderr, "host: fmi2DoStep at t = %.17g returned %d\n", t_prev, (int)s);
                status = 4;
                break;
            }
        }
        printf("%.17g", t);
        for (int i = 0; i < n_print; i++) {
            Variable *v = print[i];
            if (!strcmp(v->type, "Real")) {
                fmi2Real value;
                if (get_real(c, &v->vr, 1, &value) > fmi2Warning) status = 3;
                printf(",%.17g", value);
            } else if (!strcmp(v->type, "Integer")) {
                fmi2Integer value;
                if (get_integer(c, &v->vr, 1, &value) > fmi2Warning) status = 3;
                printf(",%d", value);
            } else {
                fmi2Boolean value;
                if (get_boolean(c, &v->vr, 1, &value) > fmi2Warning) status = 3;
                printf(",%d", value ? 1 : 0);
            }
        }
        printf("\n");
    }
    fflush(stdout);

    if (exit_early) exit(status);
    if (py_finalize) {
        py_finalize();
        printf("after finalize: terminate %d\n", (int)terminate(c));
        free_instance(c);
        fflush(stdout);
        return status;
    }
    if (terminate(c) > fmi2Warning && !status) status = 3;
    free_instance(c);
    if (!keep_loaded) dlclose(lib);
    return status;
}
