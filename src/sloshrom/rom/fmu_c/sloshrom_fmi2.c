/* sloshrom sloshing ROM: FMI 2.0 for Co-Simulation around the kernels of sloshrom_model.h.
 *
 * Value references (the modelDescription.xml that sloshrom writes beside these sources; it
 * declares the one input the model reads, velocity or acceleration):
 *   Real     0 velocity (input, m/s)   1 acceleration (input, m/s2)   2 dynamic_force (output, N)
 *            10 time_step (s)  11 sample_rate (Hz)  12 input_min  13 input_max
 *            14 acceleration_max (m/s2)  15 frequency_min (Hz)  16 frequency_max (Hz)
 *            17 fill_min (1)  18 fill_max (1)   (read-only: calculated parameters)
 *   Boolean  3 outside_envelope (output): the input read at this communication point lies
 *            outside the training range [input_min, input_max]
 *   Integer  4 samples_outside_envelope (output): communication points so far with that flag,
 *            counted as each step is taken
 *   Boolean  19 reads_acceleration (read-only): the model reads the acceleration input, not
 *            the velocity
 *
 * Semantics at a communication point t_k = t_0 + k dt: the inputs are the tank's signals at t_k;
 * dynamic_force is the model's force at sample k (NFIR, NOE, a strictly proper NSS: from the
 * past inputs only; an NSS with feed-through, an LSS: also from the input at t_k; GREY: from
 * its state only); fmi2DoStep(t_k, dt) moves the state (a grey box's column with it) to
 * t_{k+1}. A feed-through model exported strictly proper (SL_MODEL.strictly_proper) gives at
 * t_k the model's force of t_{k-1}, held from the last step: no output reads an input of its own
 * point, so a master that reads the outputs before it sets the inputs gets the model's force,
 * one step late. The state starts at rest. The only communication
 * step is the model's dt (fmi2DoStep refuses any other). The next communication point is the
 * last one plus its step (FMI 2.0), within half a step: a master that adds up its clock
 * (t += h) runs for ever, a skipped or repeated step is refused.
 *
 * The calls follow the FMI 2.0 co-simulation state machine (instantiated, initialization mode,
 * stepping, terminated, error); a call its state does not allow is an fmi2Error with a logged
 * message. In initialization mode fmi2GetReal answers the inputs too (their current values, as
 * the FMI reference FMUs do: a master's observer reads every variable there). Log categories: logStatusError, logStatusWarning and logAll (both), all on unless
 * fmi2SetDebugLogging switches them off.
 *
 * This file is part of the sources that sloshrom writes into every FMU it exports.
 */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#include "fmi2Functions.h"
#include "sloshrom_model.h"

#define VR_VELOCITY 0
#define VR_ACCELERATION 1
#define VR_FORCE 2
#define VR_OUTSIDE 3
#define VR_N_OUTSIDE 4
#define VR_TIME_STEP 10
#define VR_SAMPLE_RATE 11
#define VR_INPUT_MIN 12
#define VR_INPUT_MAX 13
#define VR_ACCELERATION_MAX 14
#define VR_FREQUENCY_MIN 15
#define VR_FREQUENCY_MAX 16
#define VR_FILL_MIN 17
#define VR_FILL_MAX 18
#define VR_READS_ACCELERATION 19

/* relative tolerance on the communication step (the rounding of a master's step) */
#define STEP_RTOL 1e-6
/* a communication point within this fraction of the step of the next one is that one (a master's
 * clock t += h carries rounding that grows with the steps; a skipped or repeated step is off by
 * a whole step) */
#define POINT_TOL 0.5

/* the serialized FMU state: magic number, format version, the model's GUID, then the Snapshot */
#define STATE_MAGIC 0x534c5354u /* "SLST" */
#define STATE_VERSION 1u
#define GUID_SIZE 64

enum { MODE_INSTANTIATED, MODE_INIT, MODE_STEP, MODE_TERMINATED, MODE_ERROR, N_MODES };

/* log categories (modelDescription.xml, LogCategories) */
enum { LOG_ERROR = 1, LOG_WARNING = 2 };

typedef struct {
    fmi2CallbackFunctions cb;
    char name[128];
    int log_on;               /* LOG_ERROR | LOG_WARNING: the categories logged */
    int mode;
    double t0;
    double t_next;            /* s: the next communication point (the last one + its step) */
    long long k;              /* samples since t0 */
    double velocity, acceleration;
    int outputs_valid;
    double force;
    int warned_envelope;
    long long n_outside;
    double *mem;              /* state, rest terms, scaled outputs, scratch of every member */
    size_t n_mem, n_state;    /* all doubles; the first n_state are the FMU state */
} Instance;

/* the part of the instance fmi2GetFMUstate saves, followed by the n_state doubles */
typedef struct {
    unsigned int magic, version;
    char guid[GUID_SIZE];
    unsigned long long n_state;
    double t0, t_next;
    long long k;
    double velocity, acceleration;
    long long n_outside;
    int mode;
    int warned_envelope;
} Snapshot;

static void logmsg(Instance *c, fmi2Status status, const char *category, const char *fmt, ...) {
    char buf[1024];
    va_list ap;
    if (c == NULL || c->cb.logger == NULL) return;
    if (!(c->log_on & (status == fmi2Warning ? LOG_WARNING : LOG_ERROR))) return;
    va_start(ap, fmt);
    vsnprintf(buf, sizeof buf, fmt, ap);
    va_end(ap);
    c->cb.logger(c->cb.componentEnvironment, c->name, status, category, "%s", buf);
}

static fmi2Status fail(Instance *c, const char *fmt, const char *detail) {
    logmsg(c, fmi2Error, "logStatusError", fmt, detail);
    return fmi2Error;
}

/* layout of mem: [states of all members][rest terms][scratch of the largest member] */
static double *member_state(Instance *c, int j) {
    size_t off = 0;
    int i;
    for (i = 0; i < j; i++) off += sl_state_size(&SL_MODEL.members[i]);
    return c->mem + off;
}

static double *member_rest(Instance *c, int j) {
    size_t off = c->n_state;
    int i;
    for (i = 0; i < j; i++) off += sl_rest_size(&SL_MODEL.members[i]);
    return c->mem + off;
}

static double *scratch_of(Instance *c, int j) {
    /* one scratch block per member: the NSS keeps F(z_k) there from output to advance */
    size_t off = c->n_state;
    int i;
    for (i = 0; i < SL_MODEL.n_members; i++) off += sl_rest_size(&SL_MODEL.members[i]);
    for (i = 0; i < j; i++) off += sl_scratch_size(&SL_MODEL.members[i]) + 1;
    return c->mem + off;
}

static double input_read(const Instance *c) {
    return SL_MODEL.reads_acceleration ? c->acceleration : c->velocity;
}

static int outside(const Instance *c) {
    double u = input_read(c);
    return SL_MODEL.has_envelope && (u < SL_MODEL.input_min || u > SL_MODEL.input_max);
}

static const char *const MODE_NAMES[N_MODES] = {
    "instantiated (before fmi2EnterInitializationMode)", "initialization mode",
    "stepping (after fmi2ExitInitializationMode)", "terminated", "error"};

/* fmi2Error unless the instance is in one of the modes of the bit mask `allowed` (the FMI 2.0
 * co-simulation state table) */
#define IN(mode) (1 << (mode))
static fmi2Status check_mode(Instance *c, int allowed, const char *function) {
    char d[200];
    if (allowed & IN(c->mode)) return fmi2OK;
    snprintf(d, sizeof d, "%s is not allowed when the FMU is %s", function, MODE_NAMES[c->mode]);
    return fail(c, "%s (FMI 2.0 co-simulation state machine)", d);
}

/* a strictly proper export's output, held from the last step: the last double of the state */
static double *held_force(Instance *c) { return c->mem + c->n_state - 1; }

static fmi2Status compute_outputs(Instance *c);

static void reset_state(Instance *c) {
    int j;
    for (j = 0; j < SL_MODEL.n_members; j++)
        sl_rest(&SL_MODEL.members[j], member_state(c, j), member_rest(c, j), scratch_of(c, j));
    c->k = 0;
    c->t_next = c->t0;
    c->velocity = 0.0;
    c->acceleration = 0.0;
    c->outputs_valid = 0;
    c->n_outside = 0;
    c->warned_envelope = 0;
    if (SL_MODEL.strictly_proper) {
        /* the force of t_{-1}: the model at rest with the tank at rest (finite at rest) */
        *held_force(c) = compute_outputs(c) == fmi2OK ? c->force : 0.0;
        c->outputs_valid = 0;
    }
}

/* the force at the current communication point (each member's scaled output is kept as the
 * last double of its scratch block for the step that follows) */
static fmi2Status compute_outputs(Instance *c) {
    double u = input_read(c), sum = 0.0;
    int j;
    if (c->outputs_valid) return fmi2OK;
    for (j = 0; j < SL_MODEL.n_members; j++) {
        const SlMember *m = &SL_MODEL.members[j];
        double *s = scratch_of(c, j);
        double y_s = sl_output(m, member_state(c, j), member_rest(c, j), u, s);
        /* a closed loop (NOE, NSS) can run away; a feed-forward NFIR cannot: its output is
         * bounded by its weights, however large the input (as the model's predict) */
        if (!isfinite(y_s) || (m->arch != SL_NFIR && !(fabs(y_s) <= m->unstable_bound))) {
            char d[160];
            snprintf(d, sizeof d, "member %d at t = %.6g s: scaled output %.6g", j, c->t_next,
                     y_s);
            c->mode = MODE_ERROR;
            return fail(c, "simulation unstable: output non-finite or beyond the member's "
                           "stability bound (%s)", d);
        }
        s[sl_scratch_size(m)] = y_s;
        sum += sl_unscale(m, y_s);
    }
    c->force = sum / SL_MODEL.n_members;
    c->outputs_valid = 1;
    return fmi2OK;
}

/* ---------------------------------------------------------------------------------------------
 * Common functions
 * ------------------------------------------------------------------------------------------- */
const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component comp, fmi2Boolean loggingOn, size_t n,
                               const fmi2String categories[]) {
    Instance *c = (Instance *)comp;
    int mask = 0;
    size_t i;
    if (c == NULL) return fmi2Error;
    if (n > 0 && categories == NULL) return fail(c, "%s", "fmi2SetDebugLogging: no categories");
    for (i = 0; i < n; i++) {
        const char *cat = categories[i];
        if (cat != NULL && strcmp(cat, "logStatusError") == 0) mask |= LOG_ERROR;
        else if (cat != NULL && strcmp(cat, "logStatusWarning") == 0) mask |= LOG_WARNING;
        else if (cat != NULL && strcmp(cat, "logAll") == 0) mask |= LOG_ERROR | LOG_WARNING;
        else
            return fail(c, "fmi2SetDebugLogging: unknown log category '%s' (this FMU has "
                           "logStatusError, logStatusWarning and logAll)",
                        cat != NULL ? cat : "(null)");
    }
    if (n == 0) mask = LOG_ERROR | LOG_WARNING;  /* no categories: all of them */
    c->log_on = loggingOn ? (c->log_on | mask) : (c->log_on & ~mask);
    return fmi2OK;
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String guid,
                              fmi2String resourceLocation,
                              const fmi2CallbackFunctions *functions, fmi2Boolean visible,
                              fmi2Boolean loggingOn) {
    Instance *c;
    size_t n_state = 0, n_rest = 0, n_scratch = 0;
    int j;
    (void)resourceLocation;
    (void)visible;
    if (functions == NULL || functions->allocateMemory == NULL || functions->freeMemory == NULL)
        return NULL;
    if (fmuType != fmi2CoSimulation || guid == NULL || strcmp(guid, SL_MODEL.guid) != 0) {
        if (functions->logger != NULL)
            functions->logger(functions->componentEnvironment, instanceName, fmi2Error,
                              "logStatusError",
                              fmuType != fmi2CoSimulation
                                  ? "this FMU implements co-simulation only"
                                  : "GUID %s does not match this binary's model (%s): the "
                                    "modelDescription.xml and the binary are from different "
                                    "exports", guid ? guid : "(null)", SL_MODEL.guid);
        return NULL;
    }
    c = (Instance *)functions->allocateMemory(1, sizeof(Instance));
    if (c == NULL) return NULL;
    memset(c, 0, sizeof(Instance));
    c->cb = *functions;
    snprintf(c->name, sizeof c->name, "%s", instanceName ? instanceName : "sloshrom");
    /* errors and warnings are what a master needs to see: logged unless switched off */
    (void)loggingOn;
    c->log_on = LOG_ERROR | LOG_WARNING;
    for (j = 0; j < SL_MODEL.n_members; j++) {
        n_state += sl_state_size(&SL_MODEL.members[j]);
        n_rest += sl_rest_size(&SL_MODEL.members[j]);
        n_scratch += sl_scratch_size(&SL_MODEL.members[j]) + 1;
    }
    if (SL_MODEL.strictly_proper) n_state += 1;  /* the held force: saved with the state */
    c->n_state = n_state;
    c->n_mem = n_state + n_rest + n_scratch;
    c->mem = (double *)functions->allocateMemory(c->n_mem, sizeof(double));
    if (c->mem == NULL) {
        functions->freeMemory(c);
        return NULL;
    }
    c->mode = MODE_INSTANTIATED;
    reset_state(c);
    return c;
}

void fmi2FreeInstance(fmi2Component comp) {
    Instance *c = (Instance *)comp;
    if (c == NULL) return;
    c->cb.freeMemory(c->mem);
    c->cb.freeMemory(c);
}

fmi2Status fmi2SetupExperiment(fmi2Component comp, fmi2Boolean toleranceDefined,
                               fmi2Real tolerance, fmi2Real startTime,
                               fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    Instance *c = (Instance *)comp;
    (void)toleranceDefined;
    (void)tolerance;
    (void)stopTimeDefined;
    (void)stopTime;
    if (c == NULL) return fmi2Error;
    if (check_mode(c, IN(MODE_INSTANTIATED), "fmi2SetupExperiment") != fmi2OK) return fmi2Error;
    c->t0 = startTime;
    c->t_next = startTime;
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component comp) {
    Instance *c = (Instance *)comp;
    if (c == NULL) return fmi2Error;
    if (check_mode(c, IN(MODE_INSTANTIATED), "fmi2EnterInitializationMode") != fmi2OK)
        return fmi2Error;
    c->mode = MODE_INIT;
    return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component comp) {
    Instance *c = (Instance *)comp;
    if (c == NULL) return fmi2Error;
    if (check_mode(c, IN(MODE_INIT), "fmi2ExitInitializationMode") != fmi2OK) return fmi2Error;
    c->mode = MODE_STEP;
    return fmi2OK;
}

fmi2Status fmi2Terminate(fmi2Component comp) {
    Instance *c = (Instance *)comp;
    if (c == NULL) return fmi2Error;
    if (check_mode(c, IN(MODE_STEP), "fmi2Terminate") != fmi2OK) return fmi2Error;
    c->mode = MODE_TERMINATED;
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component comp) {
    Instance *c = (Instance *)comp;
    if (c == NULL) return fmi2Error;
    c->t0 = 0.0;
    reset_state(c);
    c->mode = MODE_INSTANTIATED;
    return fmi2OK;
}

/* ---------------------------------------------------------------------------------------------
 * Variables
 * ------------------------------------------------------------------------------------------- */
/* the modes fmi2Get* is allowed in (in initialization mode: the initial unknowns and the inputs) */
#define GETTABLE (IN(MODE_INIT) | IN(MODE_STEP) | IN(MODE_TERMINATED) | IN(MODE_ERROR))

static int known_parameter(fmi2ValueReference vr, double *value) {
    switch (vr) {
    case VR_TIME_STEP: *value = SL_MODEL.dt; return 1;
    case VR_SAMPLE_RATE: *value = 1.0 / SL_MODEL.dt; return 1;
    case VR_INPUT_MIN: *value = SL_MODEL.input_min; return SL_MODEL.has_envelope;
    case VR_INPUT_MAX: *value = SL_MODEL.input_max; return SL_MODEL.has_envelope;
    case VR_ACCELERATION_MAX: *value = SL_MODEL.acceleration_max; break;
    case VR_FREQUENCY_MIN: *value = SL_MODEL.frequency_min; break;
    case VR_FREQUENCY_MAX: *value = SL_MODEL.frequency_max; break;
    case VR_FILL_MIN: *value = SL_MODEL.fill_min; break;
    case VR_FILL_MAX: *value = SL_MODEL.fill_max; break;
    default: return 0;
    }
    return !isnan(*value);
}

fmi2Status fmi2GetReal(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr,
                       fmi2Real value[]) {
    Instance *c = (Instance *)comp;
    size_t i;
    if (c == NULL) return fmi2Error;
    if (check_mode(c, GETTABLE, "fmi2GetReal") != fmi2OK) return fmi2Error;
    for (i = 0; i < nvr; i++) {
        switch (vr[i]) {
        case VR_VELOCITY:
        case VR_ACCELERATION:
            /* the input's current value in every mode fmi2Get* is allowed in, initialization
             * mode included (as the FMI reference FMUs: a master's observer reads them there) */
            value[i] = vr[i] == VR_VELOCITY ? c->velocity : c->acceleration;
            break;
        case VR_FORCE:
            if (SL_MODEL.strictly_proper) {
                value[i] = *held_force(c);
                break;
            }
            if (compute_outputs(c) != fmi2OK) return fmi2Error;
            value[i] = c->force;
            break;
        default:
            if (!known_parameter(vr[i], &value[i])) {
                char d[32];
                snprintf(d, sizeof d, "%u", (unsigned)vr[i]);
                return fail(c, "no Real variable has the value reference %s", d);
            }
        }
    }
    return fmi2OK;
}

fmi2Status fmi2GetInteger(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr,
                          fmi2Integer value[]) {
    Instance *c = (Instance *)comp;
    size_t i;
    if (c == NULL) return fmi2Error;
    if (check_mode(c, GETTABLE, "fmi2GetInteger") != fmi2OK) return fmi2Error;
    for (i = 0; i < nvr; i++) {
        if (vr[i] != VR_N_OUTSIDE) return fail(c, "%s", "no such Integer variable");
        value[i] = (fmi2Integer)(c->n_outside > 2147483647LL ? 2147483647LL : c->n_outside);
    }
    return fmi2OK;
}

fmi2Status fmi2GetBoolean(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr,
                          fmi2Boolean value[]) {
    Instance *c = (Instance *)comp;
    size_t i;
    if (c == NULL) return fmi2Error;
    if (check_mode(c, GETTABLE, "fmi2GetBoolean") != fmi2OK) return fmi2Error;
    for (i = 0; i < nvr; i++) {
        if (vr[i] == VR_READS_ACCELERATION)
            value[i] = SL_MODEL.reads_acceleration ? fmi2True : fmi2False;
        else if (vr[i] == VR_OUTSIDE)
            value[i] = outside(c) ? fmi2True : fmi2False;
        else
            return fail(c, "%s", "no such Boolean variable");
    }
    return fmi2OK;
}

fmi2Status fmi2GetString(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr,
                         fmi2String value[]) {
    (void)vr;
    (void)value;
    return nvr == 0 ? fmi2OK : fail((Instance *)comp, "%s", "this FMU has no String variable");
}

fmi2Status fmi2SetReal(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr,
                       const fmi2Real value[]) {
    Instance *c = (Instance *)comp;
    size_t i;
    if (c == NULL) return fmi2Error;
    if (check_mode(c, IN(MODE_INSTANTIATED) | IN(MODE_INIT) | IN(MODE_STEP), "fmi2SetReal")
        != fmi2OK)
        return fmi2Error;
    for (i = 0; i < nvr; i++) {
        if (vr[i] != VR_VELOCITY && vr[i] != VR_ACCELERATION)
            return fail(c, "%s", "only the inputs velocity and acceleration can be set (the "
                                 "parameters are read-only)");
        if (!isfinite(value[i]))
            return fail(c, "%s", vr[i] == VR_VELOCITY ? "velocity is not finite (NaN or inf)"
                                                      : "acceleration is not finite (NaN or "
                                                        "inf)");
    }
    for (i = 0; i < nvr; i++) {
        if (vr[i] == VR_VELOCITY) c->velocity = value[i];
        else c->acceleration = value[i];
    }
    c->outputs_valid = 0;
    return fmi2OK;
}

fmi2Status fmi2SetInteger(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Integer value[]) {
    (void)vr;
    (void)value;
    return nvr == 0 ? fmi2OK : fail((Instance *)comp, "%s", "no Integer variable can be set");
}

fmi2Status fmi2SetBoolean(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Boolean value[]) {
    (void)vr;
    (void)value;
    return nvr == 0 ? fmi2OK : fail((Instance *)comp, "%s", "no Boolean variable can be set");
}

fmi2Status fmi2SetString(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr,
                         const fmi2String value[]) {
    (void)vr;
    (void)value;
    return nvr == 0 ? fmi2OK : fail((Instance *)comp, "%s", "this FMU has no String variable");
}

/* ---------------------------------------------------------------------------------------------
 * FMU state
 * ------------------------------------------------------------------------------------------- */
static size_t state_size(const Instance *c) {
    return sizeof(Snapshot) + c->n_state * sizeof(double);
}

/* NULL if `s` (of `size` bytes) is a state of this model, else why not */
static const char *foreign_state(const Instance *c, const Snapshot *s, size_t size) {
    const double *x = (const double *)(const void *)(s + 1);
    size_t i;
    if (size < sizeof(Snapshot) || s->magic != STATE_MAGIC)
        return "not an FMU state of a sloshrom FMU (no header: corrupt or truncated)";
    if (s->version != STATE_VERSION) return "an FMU state of another format version";
    if (memchr(s->guid, 0, GUID_SIZE) == NULL || strcmp(s->guid, SL_MODEL.guid) != 0)
        return "an FMU state of another model (its GUID differs)";
    if (s->n_state != c->n_state || size != state_size(c))
        return "an FMU state of the wrong size (corrupt or truncated)";
    if (s->mode < 0 || s->mode >= N_MODES || s->k < 0 || s->n_outside < 0
        || !isfinite(s->t0) || !isfinite(s->t_next) || !isfinite(s->velocity)
        || !isfinite(s->acceleration))
        return "a corrupt FMU state (values out of range)";
    for (i = 0; i < c->n_state; i++)
        if (!isfinite(x[i])) return "a corrupt FMU state (a non-finite state value)";
    return NULL;
}

fmi2Status fmi2GetFMUstate(fmi2Component comp, fmi2FMUstate *state) {
    Instance *c = (Instance *)comp;
    Snapshot *s;
    if (c == NULL || state == NULL) return fmi2Error;
    s = (Snapshot *)*state;
    if (s == NULL) {
        s = (Snapshot *)c->cb.allocateMemory(1, state_size(c));
        if (s == NULL) return fail(c, "%s", "out of memory");
    }
    memset(s, 0, sizeof(Snapshot));
    s->magic = STATE_MAGIC;
    s->version = STATE_VERSION;
    snprintf(s->guid, GUID_SIZE, "%s", SL_MODEL.guid);
    s->n_state = c->n_state;
    s->t0 = c->t0;
    s->t_next = c->t_next;
    s->k = c->k;
    s->velocity = c->velocity;
    s->acceleration = c->acceleration;
    s->n_outside = c->n_outside;
    s->mode = c->mode;
    s->warned_envelope = c->warned_envelope;
    memcpy(s + 1, c->mem, c->n_state * sizeof(double));
    *state = s;
    return fmi2OK;
}

fmi2Status fmi2SetFMUstate(fmi2Component comp, fmi2FMUstate state) {
    Instance *c = (Instance *)comp;
    const Snapshot *s = (const Snapshot *)state;
    const char *why;
    if (c == NULL) return fmi2Error;
    if (s == NULL) return fail(c, "%s", "fmi2SetFMUstate: no state (NULL)");
    why = foreign_state(c, s, state_size(c));
    if (why != NULL) return fail(c, "fmi2SetFMUstate refuses %s", why);
    c->t0 = s->t0;
    c->t_next = s->t_next;
    c->k = s->k;
    c->velocity = s->velocity;
    c->acceleration = s->acceleration;
    c->n_outside = s->n_outside;
    c->mode = s->mode;
    c->warned_envelope = s->warned_envelope;
    memcpy(c->mem, s + 1, c->n_state * sizeof(double));
    c->outputs_valid = 0;
    return fmi2OK;
}

fmi2Status fmi2FreeFMUstate(fmi2Component comp, fmi2FMUstate *state) {
    Instance *c = (Instance *)comp;
    if (c == NULL || state == NULL) return fmi2Error;
    if (*state != NULL) c->cb.freeMemory(*state);
    *state = NULL;
    return fmi2OK;
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component comp, fmi2FMUstate state, size_t *size) {
    Instance *c = (Instance *)comp;
    (void)state;
    if (c == NULL || size == NULL) return fmi2Error;
    *size = state_size(c);
    return fmi2OK;
}

/* the serialized state is the snapshot itself, header first (magic number, format version,
 * GUID): the bytes of this platform's doubles */
fmi2Status fmi2SerializeFMUstate(fmi2Component comp, fmi2FMUstate state, fmi2Byte bytes[],
                                 size_t size) {
    Instance *c = (Instance *)comp;
    const char *why;
    if (c == NULL) return fmi2Error;
    if (state == NULL || bytes == NULL)
        return fail(c, "%s", "fmi2SerializeFMUstate: no state or no buffer (NULL)");
    if (size != state_size(c))
        return fail(c, "%s", "fmi2SerializeFMUstate: a buffer of the wrong size (ask "
                             "fmi2SerializedFMUstateSize)");
    why = foreign_state(c, (const Snapshot *)state, size);
    if (why != NULL) return fail(c, "fmi2SerializeFMUstate refuses %s", why);
    memcpy(bytes, state, size);
    return fmi2OK;
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component comp, const fmi2Byte bytes[], size_t size,
                                   fmi2FMUstate *state) {
    Instance *c = (Instance *)comp;
    const char *why;
    void *copy;
    if (c == NULL) return fmi2Error;
    if (state == NULL || bytes == NULL)
        return fail(c, "%s", "fmi2DeSerializeFMUstate: no bytes or no state (NULL)");
    if (size < sizeof(Snapshot))
        return fail(c, "fmi2DeSerializeFMUstate refuses %s", "a truncated FMU state (shorter "
                    "than its header)");
    copy = c->cb.allocateMemory(1, size);  /* aligned for the doubles, unlike `bytes` */
    if (copy == NULL) return fail(c, "%s", "out of memory");
    memcpy(copy, bytes, size);
    why = foreign_state(c, (const Snapshot *)copy, size);
    if (why != NULL) {
        c->cb.freeMemory(copy);
        return fail(c, "fmi2DeSerializeFMUstate refuses %s", why);
    }
    if (*state != NULL) c->cb.freeMemory(*state);
    *state = copy;
    return fmi2OK;
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component comp,
                                        const fmi2ValueReference vUnknown_ref[], size_t nUnknown,
                                        const fmi2ValueReference vKnown_ref[], size_t nKnown,
                                        const fmi2Real dvKnown[], fmi2Real dvUnknown[]) {
    (void)vUnknown_ref;
    (void)nUnknown;
    (void)vKnown_ref;
    (void)nKnown;
    (void)dvKnown;
    (void)dvUnknown;
    return fail((Instance *)comp, "%s", "directional derivatives are not provided");
}

/* ---------------------------------------------------------------------------------------------
 * Co-simulation
 * ------------------------------------------------------------------------------------------- */
fmi2Status fmi2SetRealInputDerivatives(fmi2Component comp, const fmi2ValueReference vr[],
                                       size_t nvr, const fmi2Integer order[],
                                       const fmi2Real value[]) {
    (void)vr;
    (void)nvr;
    (void)order;
    (void)value;
    return fail((Instance *)comp, "%s", "the model samples its inputs: no input derivatives");
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component comp, const fmi2ValueReference vr[],
                                        size_t nvr, const fmi2Integer order[],
                                        fmi2Real value[]) {
    (void)vr;
    (void)nvr;
    (void)order;
    (void)value;
    return fail((Instance *)comp, "%s", "the model samples its outputs: no output derivatives");
}

fmi2Status fmi2DoStep(fmi2Component comp, fmi2Real t, fmi2Real h,
                      fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
    Instance *c = (Instance *)comp;
    double u;
    char d[256];
    int j;
    fmi2Status status = fmi2OK;
    (void)noSetFMUStatePriorToCurrentPoint;
    if (c == NULL) return fmi2Error;
    if (c->mode == MODE_ERROR)
        return fail(c, "%s", "fmi2DoStep: the FMU is in an error state (see the earlier "
                             "message; fmi2Reset or fmi2SetFMUstate to go on)");
    if (check_mode(c, IN(MODE_STEP), "fmi2DoStep") != fmi2OK) return fmi2Error;
    if (!(fabs(h - SL_MODEL.dt) <= STEP_RTOL * SL_MODEL.dt)) {
        snprintf(d, sizeof d, "%.17g s is not the model's step %.17g s (%.10g Hz)", h,
                 SL_MODEL.dt, 1.0 / SL_MODEL.dt);
        return fail(c, "communication step %s: the network was identified at that sample "
                       "rate; use it as the communication step (a rate transition in front of "
                       "and behind the FMU if the rest of the model runs at another rate)", d);
    }
    /* the next point is the last one plus its step (FMI 2.0): compared with the FMU's own
     * clock, the rounding of a master's t += h would grow with the steps taken */
    if (!(fabs(t - c->t_next) < POINT_TOL * SL_MODEL.dt)) {
        snprintf(d, sizeof d, "%.17g s, but the FMU is at %.17g s", t, c->t_next);
        return fail(c, "communication point %s: steps must follow one another (restore a "
                       "saved FMU state to go back)", d);
    }
    if (compute_outputs(c) != fmi2OK) return fmi2Error;
    u = input_read(c);
    if (outside(c)) {
        c->n_outside++;
        if (!c->warned_envelope) {
            snprintf(d, sizeof d, "%s %.6g %s at t = %.6g s outside [%.6g, %.6g]",
                     SL_MODEL.reads_acceleration ? "acceleration" : "velocity", u,
                     SL_MODEL.reads_acceleration ? "m/s2" : "m/s", t, SL_MODEL.input_min,
                     SL_MODEL.input_max);
            logmsg(c, fmi2Warning, "logStatusWarning",
                   "input left the training envelope (%s): the model extrapolates; "
                   "samples_outside_envelope counts such samples", d);
            c->warned_envelope = 1;
        }
        status = fmi2Warning;  /* the step is taken; its force is an extrapolation */
    }
    for (j = 0; j < SL_MODEL.n_members; j++) {
        const SlMember *m = &SL_MODEL.members[j];
        double *s = scratch_of(c, j);
        sl_advance(m, member_state(c, j), member_rest(c, j), u, s[sl_scratch_size(m)], s);
    }
    if (SL_MODEL.strictly_proper) *held_force(c) = c->force;  /* the output of t_{k+1} */
    c->k++;
    c->t_next = t + h;
    c->outputs_valid = 0;
    return status;
}

fmi2Status fmi2CancelStep(fmi2Component comp) {
    return fail((Instance *)comp, "%s", "fmi2DoStep never runs asynchronously");
}

fmi2Status fmi2GetStatus(fmi2Component comp, const fmi2StatusKind s, fmi2Status *value) {
    (void)s;
    (void)value;
    return fail((Instance *)comp, "%s", "fmi2DoStep never returns fmi2Pending");
}

fmi2Status fmi2GetRealStatus(fmi2Component comp, const fmi2StatusKind s, fmi2Real *value) {
    Instance *c = (Instance *)comp;
    if (c != NULL && s == fmi2LastSuccessfulTime && value != NULL) {
        *value = c->t_next;
        return fmi2OK;
    }
    return fail(c, "%s", "no such status");
}

fmi2Status fmi2GetIntegerStatus(fmi2Component comp, const fmi2StatusKind s,
                                fmi2Integer *value) {
    (void)s;
    (void)value;
    return fail((Instance *)comp, "%s", "no such status");
}

fmi2Status fmi2GetBooleanStatus(fmi2Component comp, const fmi2StatusKind s,
                                fmi2Boolean *value) {
    (void)s;
    (void)value;
    return fail((Instance *)comp, "%s", "no such status");
}

fmi2Status fmi2GetStringStatus(fmi2Component comp, const fmi2StatusKind s, fmi2String *value) {
    (void)s;
    (void)value;
    return fail((Instance *)comp, "%s", "no such status");
}
