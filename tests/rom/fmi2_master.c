/* A minimal FMI 2.0 co-simulation master for tests/rom/test_fmu.py, written against the FMI 2.0
 * headers (the FMU's sources/ on the include path): the documented call sequence
 * (fmi2Instantiate, fmi2SetupExperiment, fmi2EnterInitializationMode,
 * fmi2ExitInitializationMode, then fmi2SetReal / fmi2GetReal / fmi2DoStep per communication
 * point, fmi2Terminate, fmi2FreeInstance).
 *
 *   master clock SO GUID T0 N
 *       one FMU, its clock added up as FMI 2.0 defines it (t += h) over N steps from T0;
 *       prints "passed N" (or "failed K T" at the first step not fmi2OK), then the status of a
 *       skipped ("skip S") and of a repeated ("repeat S") communication point (0 OK, 3 error)
 *   master pair SO_A GUID_A SO_B GUID_B N
 *       two FMUs dlopen'ed with RTLD_GLOBAL into this process, stepped side by side on the N
 *       velocities read from stdin; prints their forces, one line per sample
 *   (compiled with -DSTATIC_PAIR, the two FMUs' sources linked in with FMI2_FUNCTION_PREFIX
 *    a_ and b_: "pair - GUID_A - GUID_B N" runs them the same way)
 *   master state SO GUID VR N
 *       one FMU on the N values of its input VR read from stdin, every output and parameter
 *       read at each point (as an observer does, in initialisation mode too); after N/2 steps
 *       its FMU state is saved, serialised and read back, the run goes on to N, then the
 *       state is restored and the second half run again: prints the forces of the run, then
 *       "repeat ok" if the second half came out the same bit for bit (under valgrind: every
 *       call of the FMI 2.0 co-simulation API an FMU of sloshrom implements for a master)
 */
#include <dlfcn.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2FunctionTypes.h"

#define VR_VELOCITY 0u
#define VR_FORCE 2u
#define VR_TIME_STEP 10u
#define VR_OUTSIDE 3u
#define VR_N_OUTSIDE 4u

typedef struct {
    fmi2InstantiateTYPE *instantiate;
    fmi2SetupExperimentTYPE *setup;
    fmi2EnterInitializationModeTYPE *enter;
    fmi2ExitInitializationModeTYPE *exit_init;
    fmi2SetRealTYPE *set_real;
    fmi2GetRealTYPE *get_real;
    fmi2DoStepTYPE *do_step;
    fmi2TerminateTYPE *terminate;
    fmi2FreeInstanceTYPE *free_instance;
} Fmu;

static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status,
                   fmi2String category, fmi2String message, ...) {
    va_list ap;
    (void)env;
    fprintf(stderr, "[%s %d %s] ", name, (int)status, category);
    va_start(ap, message);
    vfprintf(stderr, message, ap);
    va_end(ap);
    fputc('\n', stderr);
}

static const fmi2CallbackFunctions CALLBACKS = {logger, calloc, free, NULL, NULL};

static void *symbol(void *lib, const char *name) {
    void *f = dlsym(lib, name);
    if (f == NULL) {
        fprintf(stderr, "no %s: %s\n", name, dlerror());
        exit(2);
    }
    return f;
}

static Fmu load(const char *so) {
    Fmu f;
    void *lib = dlopen(so, RTLD_NOW | RTLD_GLOBAL);
    if (lib == NULL) {
        fprintf(stderr, "dlopen %s: %s\n", so, dlerror());
        exit(2);
    }
    f.instantiate = (fmi2InstantiateTYPE *)symbol(lib, "fmi2Instantiate");
    f.setup = (fmi2SetupExperimentTYPE *)symbol(lib, "fmi2SetupExperiment");
    f.enter = (fmi2EnterInitializationModeTYPE *)symbol(lib, "fmi2EnterInitializationMode");
    f.exit_init = (fmi2ExitInitializationModeTYPE *)symbol(lib, "fmi2ExitInitializationMode");
    f.set_real = (fmi2SetRealTYPE *)symbol(lib, "fmi2SetReal");
    f.get_real = (fmi2GetRealTYPE *)symbol(lib, "fmi2GetReal");
    f.do_step = (fmi2DoStepTYPE *)symbol(lib, "fmi2DoStep");
    f.terminate = (fmi2TerminateTYPE *)symbol(lib, "fmi2Terminate");
    f.free_instance = (fmi2FreeInstanceTYPE *)symbol(lib, "fmi2FreeInstance");
    return f;
}

#ifdef STATIC_PAIR
#define DECLARE(p)                                                                            \
    extern fmi2InstantiateTYPE p##fmi2Instantiate;                                            \
    extern fmi2SetupExperimentTYPE p##fmi2SetupExperiment;                                    \
    extern fmi2EnterInitializationModeTYPE p##fmi2EnterInitializationMode;                    \
    extern fmi2ExitInitializationModeTYPE p##fmi2ExitInitializationMode;                      \
    extern fmi2SetRealTYPE p##fmi2SetReal;                                                    \
    extern fmi2GetRealTYPE p##fmi2GetReal;                                                    \
    extern fmi2DoStepTYPE p##fmi2DoStep;                                                      \
    extern fmi2TerminateTYPE p##fmi2Terminate;                                                \
    extern fmi2FreeInstanceTYPE p##fmi2FreeInstance;
#define TABLE(p)                                                                              \
    {p##fmi2Instantiate, p##fmi2SetupExperiment, p##fmi2EnterInitializationMode,              \
     p##fmi2ExitInitializationMode, p##fmi2SetReal, p##fmi2GetReal, p##fmi2DoStep,           \
     p##fmi2Terminate, p##fmi2FreeInstance}
DECLARE(a_)
DECLARE(b_)
static Fmu linked(int which) {
    static const Fmu a = TABLE(a_), b = TABLE(b_);
    return which == 0 ? a : b;
}
#endif

static int state_run(const char *so, const char *guid, unsigned vr_in, long n) {
    void *lib = dlopen(so, RTLD_NOW | RTLD_LOCAL);
    const Fmu f = load(so);
    fmi2GetFMUstateTYPE *get_state;
    fmi2SetFMUstateTYPE *set_state;
    fmi2FreeFMUstateTYPE *free_state;
    fmi2SerializedFMUstateSizeTYPE *ser_size;
    fmi2SerializeFMUstateTYPE *serialize;
    fmi2DeSerializeFMUstateTYPE *deserialize;
    fmi2GetBooleanTYPE *get_bool;
    fmi2GetIntegerTYPE *get_int;
    const fmi2ValueReference vin = vr_in, vf = VR_FORCE, vo = VR_OUTSIDE, vn = VR_N_OUTSIDE;
    const fmi2ValueReference all[] = {vin, VR_FORCE, VR_TIME_STEP};
    fmi2Component c;
    fmi2FMUstate saved = NULL, back = NULL;
    fmi2Byte *bytes;
    size_t size = 0;
    double *u = calloc((size_t)n, sizeof(double)), *y = calloc((size_t)n, sizeof(double));
    double h, v[3], again;
    fmi2Boolean out;
    fmi2Integer count;
    long k, half = n / 2, same = 1;
    if (lib == NULL || u == NULL || y == NULL) return 2;
    get_state = (fmi2GetFMUstateTYPE *)symbol(lib, "fmi2GetFMUstate");
    set_state = (fmi2SetFMUstateTYPE *)symbol(lib, "fmi2SetFMUstate");
    free_state = (fmi2FreeFMUstateTYPE *)symbol(lib, "fmi2FreeFMUstate");
    ser_size = (fmi2SerializedFMUstateSizeTYPE *)symbol(lib, "fmi2SerializedFMUstateSize");
    serialize = (fmi2SerializeFMUstateTYPE *)symbol(lib, "fmi2SerializeFMUstate");
    deserialize = (fmi2DeSerializeFMUstateTYPE *)symbol(lib, "fmi2DeSerializeFMUstate");
    get_bool = (fmi2GetBooleanTYPE *)symbol(lib, "fmi2GetBoolean");
    get_int = (fmi2GetIntegerTYPE *)symbol(lib, "fmi2GetInteger");
    for (k = 0; k < n; k++)
        if (scanf("%lf", &u[k]) != 1) return 2;
    c = f.instantiate("state", fmi2CoSimulation, guid, "", &CALLBACKS, fmi2False, fmi2False);
    if (c == NULL || f.setup(c, fmi2False, 0.0, 0.0, fmi2False, 0.0) != fmi2OK
        || f.enter(c) != fmi2OK || f.get_real(c, all, 3, v) != fmi2OK  /* the observer's read */
        || f.exit_init(c) != fmi2OK)
        return 3;
    h = v[2];
    for (k = 0; k < n; k++) {
        if (k == half) {
            if (get_state(c, &saved) != fmi2OK || ser_size(c, saved, &size) != fmi2OK) return 4;
            bytes = malloc(size);
            if (bytes == NULL || serialize(c, saved, bytes, size) != fmi2OK
                || deserialize(c, bytes, size, &back) != fmi2OK)
                return 4;
            free(bytes);
        }
        if (f.set_real(c, &vin, 1, &u[k]) > fmi2Warning || f.get_real(c, all, 3, v) != fmi2OK
            || get_bool(c, &vo, 1, &out) != fmi2OK || get_int(c, &vn, 1, &count) != fmi2OK
            || f.do_step(c, (double)k * h, h, fmi2True) > fmi2Warning)
            return 5;
        y[k] = v[1];
        printf("%.17g\n", y[k]);
    }
    if (set_state(c, back) != fmi2OK) return 6;  /* the deserialised copy of the saved state */
    for (k = half; k < n; k++) {
        if (f.set_real(c, &vin, 1, &u[k]) > fmi2Warning || f.get_real(c, &vf, 1, &again) != fmi2OK
            || f.do_step(c, (double)k * h, h, fmi2True) > fmi2Warning)
            return 7;
        same = same && again == y[k];
    }
    printf(same ? "repeat ok\n" : "repeat differs\n");
    free_state(c, &saved);
    free_state(c, &back);
    f.terminate(c);
    f.free_instance(c);
    free(u);
    free(y);
    dlclose(lib);
    return 0;
}

static fmi2Component start(const Fmu *f, const char *name, const char *guid, double t0) {
    fmi2Component c = f->instantiate(name, fmi2CoSimulation, guid, "", &CALLBACKS, fmi2False,
                                     fmi2False);
    if (c == NULL || f->setup(c, fmi2False, 0.0, t0, fmi2False, 0.0) != fmi2OK
        || f->enter(c) != fmi2OK || f->exit_init(c) != fmi2OK) {
        fprintf(stderr, "%s: initialisation failed\n", name);
        exit(2);
    }
    return c;
}

static double time_step(const Fmu *f, fmi2Component c) {
    const fmi2ValueReference vr = VR_TIME_STEP;
    double h = 0.0;
    if (f->get_real(c, &vr, 1, &h) != fmi2OK) exit(2);
    return h;
}

static int clock_run(const char *so, const char *guid, double t0, long n) {
    const Fmu f = load(so);
    const fmi2ValueReference vr = VR_VELOCITY;
    const double zero = 0.0;
    fmi2Component c = start(&f, "clock", guid, t0);
    double t = t0, h = time_step(&f, c);
    long k;
    for (k = 0; k < n; k++) {
        if (f.set_real(c, &vr, 1, &zero) != fmi2OK || f.do_step(c, t, h, fmi2True) != fmi2OK) {
            printf("failed %ld %.17g\n", k, t);
            return 1;
        }
        t += h;
    }
    printf("passed %ld\n", k);
    printf("skip %d\n", (int)f.do_step(c, t + h, h, fmi2True));
    printf("repeat %d\n", (int)f.do_step(c, t - h, h, fmi2True));
    f.terminate(c);
    f.free_instance(c);
    return 0;
}

static int pair_run(const Fmu *fa, const char *guid_a, const Fmu *fb, const char *guid_b,
                    long n) {
    const fmi2ValueReference vu = VR_VELOCITY, vf = VR_FORCE;
    fmi2Component a = start(fa, "a", guid_a, 0.0), b = start(fb, "b", guid_b, 0.0);
    double ha = time_step(fa, a), hb = time_step(fb, b), u, ya, yb;
    long k;
    for (k = 0; k < n; k++) {
        if (scanf("%lf", &u) != 1) return 2;
        if (fa->set_real(a, &vu, 1, &u) > fmi2Warning || fb->set_real(b, &vu, 1, &u) > fmi2Warning
            || fa->get_real(a, &vf, 1, &ya) != fmi2OK || fb->get_real(b, &vf, 1, &yb) != fmi2OK
            || fa->do_step(a, (double)k * ha, ha, fmi2True) > fmi2Warning
            || fb->do_step(b, (double)k * hb, hb, fmi2True) > fmi2Warning)
            return 1;
        printf("%.17g %.17g\n", ya, yb);
    }
    fa->terminate(a);
    fb->terminate(b);
    fa->free_instance(a);
    fb->free_instance(b);
    return 0;
}

int main(int argc, char **argv) {
    if (argc == 6 && strcmp(argv[1], "clock") == 0)
        return clock_run(argv[2], argv[3], atof(argv[4]), atol(argv[5]));
    if (argc == 7 && strcmp(argv[1], "pair") == 0) {
        Fmu fa, fb;
#ifdef STATIC_PAIR
        fa = linked(0);
        fb = linked(1);
#else
        fa = load(argv[2]);
        fb = load(argv[4]);
#endif
        return pair_run(&fa, argv[3], &fb, argv[5], atol(argv[6]));
    }
    if (argc == 6 && strcmp(argv[1], "state") == 0)
        return state_run(argv[2], argv[3], (unsigned)atol(argv[4]), atol(argv[5]));
    fprintf(stderr, "usage: master clock SO GUID T0 N | master pair SO_A GUID_A SO_B GUID_B N | "
                    "master state SO GUID VR N\n");
    return 2;
}
