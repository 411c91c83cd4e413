/*
 * Runs an FMU in OSP's libcosim through its C API (libcosimc.so, as shipped in the libcosimpy
 * wheel), as a native host would.
 *
 *   cosim_host FMU STEPS STEP_NS REAL_VRS INTEGER_VRS BOOLEAN_VRS [r:VR=VALUE | i:VR=VALUE]...
 *
 * *_VRS are comma-separated value references to print ("-" for none). Sets the given initial
 * values, steps STEPS steps of STEP_NS nanoseconds and prints, after every step, the time and the
 * last values of the listed variables as CSV (%.17g). libcosim's console log is on at its
 * default level. Exit 0 on success, 3 when libcosim reports an error (its message on stderr).
 *
 * Only the few functions used are declared (libcosim's cosim.h).
 */
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct cosim_execution_s cosim_execution;
typedef struct cosim_slave_s cosim_slave;
typedef struct cosim_observer_s cosim_observer;
typedef uint32_t cosim_value_reference;

cosim_execution *cosim_execution_create(int64_t start_time, int64_t step_size);
int cosim_execution_destroy(cosim_execution *execution);
cosim_slave *cosim_local_slave_create(const char *fmu_path, const char *instance_name);
int cosim_local_slave_destroy(cosim_slave *slave);
int cosim_execution_add_slave(cosim_execution *execution, cosim_slave *slave);
int cosim_execution_set_real_initial_value(cosim_execution *execution, int slave_index,
                                           cosim_value_reference vr, double value);
int cosim_execution_set_integer_initial_value(cosim_execution *execution, int slave_index,
                                              cosim_value_reference vr, int value);
cosim_observer *cosim_last_value_observer_create(void);
int cosim_observer_destroy(cosim_observer *observer);
int cosim_execution_add_observer(cosim_execution *execution, cosim_observer *observer);
int cosim_execution_step(cosim_execution *execution, int64_t steps);
int cosim_observer_slave_get_real(cosim_observer *observer, int slave_index,
                                  const cosim_value_reference vr[], size_t nv, double values[]);
int cosim_observer_slave_get_integer(cosim_observer *observer, int slave_index,
                                     const cosim_value_reference vr[], size_t nv, int values[]);
int cosim_observer_slave_get_boolean(cosim_observer *observer, int slave_index,
                                     const cosim_value_reference vr[], size_t nv, bool values[]);
const char *cosim_last_error_message(void);
int cosim_log_setup_simple_console_logging(void);

#define MAX_VARS 64

static size_t parse_vrs(const char *list, cosim_value_reference *vrs) {
    size_t n = 0;
    if (strcmp(list, "-") == 0) return 0;
    for (const char *p = list; *p && n < MAX_VARS; n++) {
        char *end;
        vrs[n] = (cosim_value_reference)strtoul(p, &end, 10);
        p = *end == ',' ? end + 1 : end;
    }
    return n;
}

static int fail(const char *what) {
    fprintf(stderr, "cosim_host: %s failed: %s\n", what, cosim_last_error_message());
    return 3;
}

int main(int argc, char **argv) {
    if (argc < 7) {
        fprintf(stderr, "usage: %s FMU STEPS STEP_NS REAL_VRS INTEGER_VRS BOOLEAN_VRS "
                        "[r:VR=VALUE | i:VR=VALUE]...\n", argv[0]);
        return 2;
    }
    long steps = strtol(argv[2], NULL, 10);
    int64_t step_ns = strtoll(argv[3], NULL, 10);
    cosim_value_reference reals[MAX_VARS], integers[MAX_VARS], booleans[MAX_VARS];
    size_t n_reals = parse_vrs(argv[4], reals);
    size_t n_integers = parse_vrs(argv[5], integers);
    size_t n_booleans = parse_vrs(argv[6], booleans);

    cosim_log_setup_simple_console_logging();
    cosim_execution *execution = cosim_execution_create(0, step_ns);
    if (!execution) return fail("cosim_execution_create");
    cosim_slave *slave = cosim_local_slave_create(argv[1], "ice");
    if (!slave) return fail("cosim_local_slave_create");
    int index = cosim_execution_add_slave(execution, slave);
    if (index < 0) return fail("cosim_execution_add_slave");
    for (int i = 7; i < argc; i++) {
        unsigned vr;
        double value;
        if (sscanf(argv[i] + 2, "%u=%lf", &vr, &value) != 2) {
            fprintf(stderr, "cosim_host: bad initial value %s\n", argv[i]);
            return 2;
        }
        int rc = argv[i][0] == 'i'
                     ? cosim_execution_set_integer_initial_value(execution, index, vr, (int)value)
                     : cosim_execution_set_real_initial_value(execution, index, vr, value);
        if (rc < 0) return fail("setting an initial value");
    }
    cosim_observer *observer = cosim_last_value_observer_create();
    if (!observer || cosim_execution_add_observer(execution, observer) < 0)
        return fail("cosim_execution_add_observer");

    int status = 0;
    for (long k = 1; k <= steps && !status; k++) {
        if (cosim_execution_step(execution, 1) < 0) {
            status = fail("cosim_execution_step");
            break;
        }
        double r[MAX_VARS];
        int i_values[MAX_VARS];
        bool b[MAX_VARS];
        if ((n_reals && cosim_observer_slave_get_real(observer, index, reals, n_reals, r) < 0) ||
            (n_integers &&
             cosim_observer_slave_get_integer(observer, index, integers, n_integers,
                                              i_values) < 0) ||
            (n_booleans &&
             cosim_observer_slave_get_boolean(observer, index, booleans, n_booleans, b) < 0)) {
            status = fail("reading the outputs");
            break;
        }
        printf("%.17g", (double)(k * step_ns) * 1e-9);
        for (size_t j = 0; j < n_reals; j++) printf(",%.17g", r[j]);
        for (size_t j = 0; j < n_integers; j++) printf(",%d", i_values[j]);
        for (size_t j = 0; j < n_booleans; j++) printf(",%d", b[j] ? 1 : 0);
        printf("\n");
    }
    fflush(stdout);
    cosim_execution_destroy(execution);
    cosim_observer_destroy(observer);
    return status;
}
