/*
 * Minimal FMI 3.0 Co-Simulation master in C, to run IceImpact3.fmu outside Python: the FMI 3.0
 * port of host.c, with the same options and output.
 *
 *   host3 FMU_DIR [-n STEPS] [-h STEP] [-s NAME=VALUE]... [-o NAME]... [-k] [-R] [-N] [-S] [-E]
 *         [-T] [-P LIBPYTHON]
 *
 * FMU_DIR is the extracted FMU (modelDescription.xml, binaries/x86_64-linux/<id>.so,
 * resources/). Sets the given parameters, steps STEPS communication steps of STEP seconds
 * (default 2000 x 1 ms) and prints time plus the outputs (all outputs, or those given with -o) as
 * CSV on stdout after the initialization and after every step: on the same grid, the same text as
 * host.c prints for the FMI 2.0 FMU. -k keeps the library loaded (no dlclose) at exit.
 *
 *   -R  instantiates with earlyReturnAllowed: a step that returns early (earlyReturn) prints a
 *       row at lastSuccessfulTime, and the next step goes from there to the same grid point
 *       (communication points: the grid's n * h and the early returns' times).
 *
 * The failure paths of real hosts, each on request (as host.c's):
 *   -N  calls every FMI 3.0 function that takes an instance with NULL first, and prints
 *       "null <function> <status>" for each on stdout; it goes on after a failed
 *       fmi3InstantiateCoSimulation too, calling fmi3EnterInitializationMode on the NULL it
 *       returned (exit status 3 then);
 *   -S  a logger that aborts on a NULL category or message;
 *   -E  exits without fmi3Terminate and fmi3FreeInstance (static destructors still run);
 *   -T  prints "instantiate_seconds <s>": the time from the start of main to the return of the
 *       first fmi3InstantiateCoSimulation (dlopen included), then frees the instance and exits;
 *   -P  embeds Python first (LIBPYTHON, RTLD_GLOBAL, Py_InitializeEx), as a Python host does,
 *       finalizes it after the last step, and then calls fmi3Terminate and fmi3FreeInstance;
 *       prints "after finalize: terminate <status>" on stdout.
 *
 * Exit status: 0, 2 (usage, unreadable FMU), 3 (a failed call), 4 (a step not fmi3OK).
 * Compiled with the FMI 3.0 standard's headers: cc -I fmu_native/fmi3 host3.c -ldl
 */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "fmi3FunctionTypes.h"

#define MAX_VARS 256

typedef struct {
    char name[128];
    char causality[32];
    char type[16]; /* Float64, Int32, Boolean, String, ... (the element's name) */
    fmi3ValueReference vr;
} Variable;

static Variable vars[MAX_VARS];
static int n_vars = 0;

static int strict_logger = 0;

/* The instance environment is the instance name: messages print as host.c prints them. */
static void logger(fmi3InstanceEnvironment env, fmi3Status status, fmi3String category,
                   fmi3String message) {
    if (strict_logger && (!category || !message)) {
        fprintf(stderr, "host: the FMU logged with a NULL %s\n",
                !category ? "category" : "message");
        abort();
    }
    fprintf(stderr, "[%s] status %d [%s] %s\n", env ? (const char *)env : "?", (int)status,
            category ? category : "", message ? message : "");
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

/* The instantiation token and the variables of an FMI 3.0 modelDescription.xml: the elements
   of ModelVariables named by a type (their children, <Start/> and the like, are skipped). */
static int parse_model_description(const char *xml, char *token, size_t token_size) {
    static const char *const types[] = {"Float32", "Float64", "Int8",   "UInt8",  "Int16",
                                        "UInt16",  "Int32",   "UInt32", "Int64",  "UInt64",
                                        "Boolean", "String",  "Binary", "Clock",  "Enumeration"};
    const char *root_end = strchr(strstr(xml, "<fmiModelDescription") ?: xml, '>');
    if (!root_end || !attribute(xml, root_end, "instantiationToken", token, token_size)) return 0;
    const char *p = strstr(xml, "<ModelVariables");
    const char *end = p ? strstr(p, "</ModelVariables>") : NULL;
    if (!p || !end) return 0;
    while ((p = strchr(p + 1, '<')) && p < end && n_vars < MAX_VARS) {
        const char *tag_end = strchr(p, '>');
        if (!tag_end) return 0;
        size_t len = strcspn(p + 1, " \t\r\n/>");
        const char *type = NULL;
        for (size_t i = 0; i < sizeof types / sizeof *types; i++)
            if (strlen(types[i]) == len && !strncmp(p + 1, types[i], len)) type = types[i];
        if (!type) continue;
        Variable *v = &vars[n_vars];
        char vr[32];
        if (!attribute(p, tag_end, "name", v->name, sizeof v->name) ||
            !attribute(p, tag_end, "valueReference", vr, sizeof vr))
            return 0;
        v->vr = (fmi3ValueReference)strtoul(vr, NULL, 10);
        if (!attribute(p, tag_end, "causality", v->causality, sizeof v->causality))
            strcpy(v->causality, "local");
        snprintf(v->type, sizeof v->type, "%s", type);
        n_vars++;
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

/* Call an FMI 3.0 function on a NULL instance and print its status. */
#define NULL_CALL(name, ...)                                                     \
    printf("null " #name " %d\n",                                                \
           (int)((name##TYPE *)symbol(lib, #name))(NULL, ##__VA_ARGS__))

/* Every FMI 3.0 function that takes an instance, called with NULL (fmi3FreeInstance last). */
static void null_calls(void *lib) {
    fmi3ValueReference vr = 0;
    fmi3Float64 f64 = 0.0;
    fmi3Float32 f32 = 0.0f;
    fmi3Int8 i8 = 0;
    fmi3UInt8 u8 = 0;
    fmi3Int16 i16 = 0;
    fmi3UInt16 u16 = 0;
    fmi3Int32 i32 = 0;
    fmi3UInt32 u32 = 0;
    fmi3Int64 i64 = 0;
    fmi3UInt64 u64 = 0, u64b = 1;
    fmi3Boolean b = fmi3False, b2 = fmi3False, b3 = fmi3False, b4 = fmi3False, b5 = fmi3False;
    fmi3String s = "";
    fmi3Byte byte = 0;
    fmi3Binary binary = &byte;
    size_t binary_size = 1, n = 0, index = 0;
    fmi3Clock clock = fmi3ClockInactive;
    fmi3FMUState state = NULL;
    fmi3DependencyKind kind = fmi3Independent;
    fmi3IntervalQualifier qualifier = fmi3IntervalNotYetKnown;
    fmi3Int32 order = 1;

    NULL_CALL(fmi3SetDebugLogging, fmi3True, 0, NULL);
    NULL_CALL(fmi3EnterInitializationMode, fmi3False, 0.0, 0.0, fmi3False, 0.0);
    NULL_CALL(fmi3ExitInitializationMode);
    NULL_CALL(fmi3EnterEventMode);
    NULL_CALL(fmi3Terminate);
    NULL_CALL(fmi3Reset);
    NULL_CALL(fmi3GetFloat32, &vr, 1, &f32, 1);
    NULL_CALL(fmi3GetFloat64, &vr, 1, &f64, 1);
    NULL_CALL(fmi3GetInt8, &vr, 1, &i8, 1);
    NULL_CALL(fmi3GetUInt8, &vr, 1, &u8, 1);
    NULL_CALL(fmi3GetInt16, &vr, 1, &i16, 1);
    NULL_CALL(fmi3GetUInt16, &vr, 1, &u16, 1);
    NULL_CALL(fmi3GetInt32, &vr, 1, &i32, 1);
    NULL_CALL(fmi3GetUInt32, &vr, 1, &u32, 1);
    NULL_CALL(fmi3GetInt64, &vr, 1, &i64, 1);
    NULL_CALL(fmi3GetUInt64, &vr, 1, &u64, 1);
    NULL_CALL(fmi3GetBoolean, &vr, 1, &b, 1);
    NULL_CALL(fmi3GetString, &vr, 1, &s, 1);
    NULL_CALL(fmi3GetBinary, &vr, 1, &binary_size, &binary, 1);
    NULL_CALL(fmi3GetClock, &vr, 1, &clock);
    NULL_CALL(fmi3SetFloat32, &vr, 1, &f32, 1);
    NULL_CALL(fmi3SetFloat64, &vr, 1, &f64, 1);
    NULL_CALL(fmi3SetInt8, &vr, 1, &i8, 1);
    NULL_CALL(fmi3SetUInt8, &vr, 1, &u8, 1);
    NULL_CALL(fmi3SetInt16, &vr, 1, &i16, 1);
    NULL_CALL(fmi3SetUInt16, &vr, 1, &u16, 1);
    NULL_CALL(fmi3SetInt32, &vr, 1, &i32, 1);
    NULL_CALL(fmi3SetUInt32, &vr, 1, &u32, 1);
    NULL_CALL(fmi3SetInt64, &vr, 1, &i64, 1);
    NULL_CALL(fmi3SetUInt64, &vr, 1, &u64, 1);
    NULL_CALL(fmi3SetBoolean, &vr, 1, &b, 1);
    NULL_CALL(fmi3SetString, &vr, 1, &s, 1);
    NULL_CALL(fmi3SetBinary, &vr, 1, &binary_size, &binary, 1);
    NULL_CALL(fmi3SetClock, &vr, 1, &clock);
    NULL_CALL(fmi3GetNumberOfVariableDependencies, vr, &n);
    NULL_CALL(fmi3GetVariableDependencies, vr, &index, &vr, &index, &kind, 1);
    NULL_CALL(fmi3GetFMUState, &state);
    NULL_CALL(fmi3SetFMUState, state);
    NULL_CALL(fmi3FreeFMUState, &state);
    NULL_CALL(fmi3SerializedFMUStateSize, state, &n);
    NULL_CALL(fmi3SerializeFMUState, state, &byte, 1);
    NULL_CALL(fmi3DeserializeFMUState, &byte, 1, &state);
    NULL_CALL(fmi3GetDirectionalDerivative, &vr, 1, &vr, 1, &f64, 1, &f64, 1);
    NULL_CALL(fmi3GetAdjointDerivative, &vr, 1, &vr, 1, &f64, 1, &f64, 1);
    NULL_CALL(fmi3EnterConfigurationMode);
    NULL_CALL(fmi3ExitConfigurationMode);
    NULL_CALL(fmi3GetIntervalDecimal, &vr, 1, &f64, &qualifier);
    NULL_CALL(fmi3GetIntervalFraction, &vr, 1, &u64, &u64b, &qualifier);
    NULL_CALL(fmi3GetShiftDecimal, &vr, 1, &f64);
    NULL_CALL(fmi3GetShiftFraction, &vr, 1, &u64, &u64b);
    NULL_CALL(fmi3SetIntervalDecimal, &vr, 1, &f64);
    NULL_CALL(fmi3SetIntervalFraction, &vr, 1, &u64, &u64b);
    NULL_CALL(fmi3SetShiftDecimal, &vr, 1, &f64);
    NULL_CALL(fmi3SetShiftFraction, &vr, 1, &u64, &u64b);
    NULL_CALL(fmi3EvaluateDiscreteStates);
    NULL_CALL(fmi3UpdateDiscreteStates, &b, &b2, &b3, &b4, &b5, &f64);
    NULL_CALL(fmi3EnterContinuousTimeMode);
    NULL_CALL(fmi3CompletedIntegratorStep, fmi3True, &b, &b2);
    NULL_CALL(fmi3SetTime, 0.0);
    NULL_CALL(fmi3SetContinuousStates, &f64, 1);
    NULL_CALL(fmi3GetContinuousStateDerivatives, &f64, 1);
    NULL_CALL(fmi3GetEventIndicators, &f64, 1);
    NULL_CALL(fmi3GetContinuousStates, &f64, 1);
    NULL_CALL(fmi3GetNominalsOfContinuousStates, &f64, 1);
    NULL_CALL(fmi3GetNumberOfEventIndicators, &n);
    NULL_CALL(fmi3GetNumberOfContinuousStates, &n);
    NULL_CALL(fmi3EnterStepMode);
    NULL_CALL(fmi3GetOutputDerivatives, &vr, 1, &order, &f64, 1);
    NULL_CALL(fmi3DoStep, 0.0, 1e-3, fmi3True, &b, &b2, &b3, &f64);
    NULL_CALL(fmi3ActivateModelPartition, vr, 0.0);
    ((fmi3FreeInstanceTYPE *)symbol(lib, "fmi3FreeInstance"))(NULL);
    printf("null fmi3FreeInstance done\n");
    fflush(stdout);
}

int main(int argc, char **argv) {
    if (argc < 2) {
        fprintf(stderr, "usage: %s FMU_DIR [-n STEPS] [-h STEP] [-s NAME=VALUE]... [-o NAME]... "
                        "[-k] [-R] [-N] [-S] [-E] [-T] [-P LIBPYTHON]\n", argv[0]);
        return 2;
    }
    const char *dir = argv[1];
    long n_steps = 2000;
    double h = 1e-3;
    struct timespec started;
    clock_gettime(CLOCK_MONOTONIC, &started);
    int keep_loaded = 0, call_null = 0, exit_early = 0, time_instantiate = 0, early_return = 0;
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
        else if (!strcmp(argv[i], "-R")) early_return = 1;
        else if (!strcmp(argv[i], "-N")) call_null = 1;
        else if (!strcmp(argv[i], "-S")) strict_logger = 1;
        else if (!strcmp(argv[i], "-E")) exit_early = 1;
        else if (!strcmp(argv[i], "-T")) time_instantiate = 1;
        else if (!strcmp(argv[i], "-P") && i + 1 < argc) embed_python = argv[++i];
        else {
            fprintf(stderr, "host: unknown argument %s\n", argv[i]);
            return 2;
        }
    }

    char path[PATH_MAX + 256];
    snprintf(path, sizeof path, "%s/modelDescription.xml", dir);
    char *xml = read_file(path);
    char token[128], identifier[128];
    const char *cs = xml ? strstr(xml, "<CoSimulation") : NULL;
    if (!xml || !cs || !parse_model_description(xml, token, sizeof token) ||
        !attribute(cs, strchr(cs, '>'), "modelIdentifier", identifier, sizeof identifier)) {
        fprintf(stderr, "host: cannot read %s (an FMI 3.0 Co-Simulation FMU)\n", path);
        return 2;
    }
    free(xml);

    /* Outputs to print: those given with -o, else every output in the model description's order. */
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
    for (int i = 0; i < n_print; i++) {
        const char *t = print[i]->type;
        if (strcmp(t, "Float64") && strcmp(t, "Int32") && strcmp(t, "Boolean")) {
            fprintf(stderr, "host: cannot print %s (%s)\n", print[i]->name, t);
            return 2;
        }
    }

    snprintf(path, sizeof path, "%s/binaries/x86_64-linux/%s.so", dir, identifier);
    void *lib = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (!lib) {
        fprintf(stderr, "host: dlopen failed: %s\n", dlerror());
        return 2;
    }
    fmi3InstantiateCoSimulationTYPE *instantiate =
        (fmi3InstantiateCoSimulationTYPE *)symbol(lib, "fmi3InstantiateCoSimulation");
    fmi3FreeInstanceTYPE *free_instance = (fmi3FreeInstanceTYPE *)symbol(lib, "fmi3FreeInstance");
    fmi3EnterInitializationModeTYPE *enter_init =
        (fmi3EnterInitializationModeTYPE *)symbol(lib, "fmi3EnterInitializationMode");
    fmi3ExitInitializationModeTYPE *exit_init =
        (fmi3ExitInitializationModeTYPE *)symbol(lib, "fmi3ExitInitializationMode");
    fmi3TerminateTYPE *terminate = (fmi3TerminateTYPE *)symbol(lib, "fmi3Terminate");
    fmi3GetFloat64TYPE *get_float64 = (fmi3GetFloat64TYPE *)symbol(lib, "fmi3GetFloat64");
    fmi3GetInt32TYPE *get_int32 = (fmi3GetInt32TYPE *)symbol(lib, "fmi3GetInt32");
    fmi3GetBooleanTYPE *get_boolean = (fmi3GetBooleanTYPE *)symbol(lib, "fmi3GetBoolean");
    fmi3SetFloat64TYPE *set_float64 = (fmi3SetFloat64TYPE *)symbol(lib, "fmi3SetFloat64");
    fmi3SetInt32TYPE *set_int32 = (fmi3SetInt32TYPE *)symbol(lib, "fmi3SetInt32");
    fmi3SetBooleanTYPE *set_boolean = (fmi3SetBooleanTYPE *)symbol(lib, "fmi3SetBoolean");
    fmi3DoStepTYPE *do_step = (fmi3DoStepTYPE *)symbol(lib, "fmi3DoStep");

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

    if (call_null) null_calls(lib);

    /* resourcePath: the absolute path of resources/, with a trailing slash (FMI 3.0) */
    char resources[PATH_MAX + 16], absolute[PATH_MAX];
    snprintf(resources, sizeof resources, "%s/resources/", realpath(dir, absolute) ? absolute : dir);
    static char instance_name[] = "host";
    fmi3Instance c = instantiate(instance_name, token, resources, fmi3False, fmi3True,
                                 fmi3False, early_return ? fmi3True : fmi3False, NULL, 0,
                                 instance_name, logger, NULL);
    if (!c) {
        fprintf(stderr, "host: fmi3InstantiateCoSimulation failed\n");
        if (call_null) /* what a host that goes on regardless does next */
            printf("null-after-failure fmi3EnterInitializationMode %d\n",
                   (int)enter_init(c, fmi3False, 0.0, 0.0, fmi3False, 0.0));
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
        fmi3Status s;
        if (!strcmp(v->type, "Int32")) {
            fmi3Int32 value = (fmi3Int32)strtol(eq + 1, NULL, 10);
            s = set_int32(c, &v->vr, 1, &value, 1);
        } else if (!strcmp(v->type, "Boolean")) {
            fmi3Boolean value = strtol(eq + 1, NULL, 10) != 0 || !strcmp(eq + 1, "true");
            s = set_boolean(c, &v->vr, 1, &value, 1);
        } else {
            fmi3Float64 value = strtod(eq + 1, NULL);
            s = set_float64(c, &v->vr, 1, &value, 1);
        }
        if (s > fmi3Warning) status = 3;
    }
    if (!status && enter_init(c, fmi3False, 0.0, 0.0, fmi3False, 0.0) > fmi3Warning) status = 3;
    if (!status && exit_init(c) > fmi3Warning) status = 3;

    printf("time");
    for (int i = 0; i < n_print; i++) printf(",%s", print[i]->name);
    printf("\n");

    double now = 0.0;  /* the instance's time: the last communication point reached */
    long row_limit = 1000000;
    for (long step = 0; step <= n_steps && !status; step++) {
        double t = step * h; /* communication points as n * h, like FMPy and host.c */
        if (step > 0) {
            if (!early_return) now = (step - 1) * h;
            fmi3Boolean event = fmi3False, terminate_simulation = fmi3False, early = fmi3False;
            fmi3Float64 reached = now;
            fmi3Status s = do_step(c, now, t - now, fmi3True, &event, &terminate_simulation,
                                   &early, &reached);
            if (s != fmi3OK) {
                fprintf(stderr, "host: fmi3DoStep at t = %.17g returned %d\n", now, (int)s);
                status = 4;
                break;
            }
            if (early) {
                if (!early_return || !(reached > now && reached < t) || --row_limit < 0) {
                    fprintf(stderr, "host: fmi3DoStep at t = %.17g returned early at %.17g\n", now,
                            reached);
                    status = 4;
                    break;
                }
                now = reached;
                t = reached; /* print this row, then step again to the same grid point */
                step--;
            } else {
                now = t;
            }
        }
        printf("%.17g", t);
        for (int i = 0; i < n_print; i++) {
            Variable *v = print[i];
            if (!strcmp(v->type, "Float64")) {
                fmi3Float64 value;
                if (get_float64(c, &v->vr, 1, &value, 1) > fmi3Warning) status = 3;
                printf(",%.17g", value);
            } else if (!strcmp(v->type, "Int32")) {
                fmi3Int32 value;
                if (get_int32(c, &v->vr, 1, &value, 1) > fmi3Warning) status = 3;
                printf(",%d", value);
            } else {
                fmi3Boolean value;
                if (get_boolean(c, &v->vr, 1, &value, 1) > fmi3Warning) status = 3;
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
    if (terminate(c) > fmi3Warning && !status) status = 3;
    free_instance(c);
    if (!keep_loaded) dlclose(lib);
    return status;
}
