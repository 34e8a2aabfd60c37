/* sloshrom sloshing ROM: FMI 2.0 for Co-Simulation around the kernels of sloshrom_model.h.
 *
 * Value references (the modelDescription.xml that sloshrom writes beside these sources):
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
 * dynamic_force is the model's force at sample k (NFIR, NOE: from the past inputs only; NSS:
 * also from the input at t_k); fmi2DoStep(t_k, dt) moves the state to t_{k+1}. The state starts
 * at rest. The only communication step is the model's dt (fmi2DoStep refuses any other).
 *
 * This file is part of the sources that sloshrom writes into every FMU it exports.
 */
#include <float.h>
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

/* relative tolerance on the communication step and on the communication point (the master's
 * time may be accumulated with rounding; a skipped or repeated step is off by a whole dt) */
#define STEP_RTOL 1e-6

enum { MODE_INSTANTIATED, MODE_INIT, MODE_STEP, MODE_TERMINATED, MODE_ERROR };

typedef struct {
    fmi2CallbackFunctions cb;
    char name[128];
    int logging_on;
    int mode;
    double t0;
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
    double t0;
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
    if (status == fmi2OK && !c->logging_on) return;
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

static void reset_state(Instance *c) {
    int j;
    for (j = 0; j < SL_MODEL.n_members; j++)
        sl_rest(&SL_MODEL.members[j], member_state(c, j), member_rest(c, j), scratch_of(c, j));
    c->k = 0;
    c->velocity = 0.0;
    c->acceleration = 0.0;
    c->outputs_valid = 0;
    c->n_outside = 0;
    c->warned_envelope = 0;
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
        if (!(fabs(y_s) <= m->unstable_bound)) {
            char d[160];
            snprintf(d, sizeof d, "member %d at t = %.6g s: scaled output %.6g", j,
                     c->t0 + (double)c->k * SL_MODEL.dt, y_s);
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
    (void)n;
    (void)categories;
    if (c == NULL) return fmi2Error;
    c->logging_on = loggingOn ? 1 : 0;
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
    c->logging_on = loggingOn ? 1 : 0;
    for (j = 0; j < SL_MODEL.n_members; j++) {
        n_state += sl_state_size(&SL_MODEL.members[j]);
        n_rest += sl_rest_size(&SL_MODEL.members[j]);
        n_scratch += sl_scratch_size(&SL_MODEL.members[j]) + 1;
    }
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
    if (c->mode != MODE_INSTANTIATED)
        return fail(c, "%s", "fmi2SetupExperiment is allowed only after fmi2Instantiate");
    c->t0 = startTime;
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component comp) {
    Instance *c = (Instance *)comp;
    if (c == NULL) return fmi2Error;
    if (c->mode != MODE_INSTANTIATED)
        return fail(c, "%s", "fmi2EnterInitializationMode is allowed only after "
                             "fmi2Instantiate");
    c->mode = MODE_INIT;
    return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component comp) {
    Instance *c = (Instance *)comp;
    if (c == NULL) return fmi2Error;
    if (c->mode != MODE_INIT)
        return fail(c, "%s", "fmi2ExitInitializationMode is allowed only in initialization "
                             "mode");
    c->mode = MODE_STEP;
    return fmi2OK;
}

fmi2Status fmi2Terminate(fmi2Component comp) {
    Instance *c = (Instance *)comp;
    if (c == NULL) return fmi2Error;
    c->mode = MODE_TERMINATED;
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component comp) {
    Instance *c = (Instance *)comp;
    if (c == NULL) return fmi2Error;
    reset_state(c);
    c->t0 = 0.0;
    c->mode = MODE_INSTANTIATED;
    return fmi2OK;
}

/* ---------------------------------------------------------------------------------------------
 * Variables
 * ------------------------------------------------------------------------------------------- */
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
    for (i = 0; i < nvr; i++) {
        switch (vr[i]) {
        case VR_VELOCITY: value[i] = c->velocity; break;
        case VR_ACCELERATION: value[i] = c->acceleration; break;
        case VR_FORCE:
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
fmi2Status fmi2GetFMUstate(fmi2Component comp, fmi2FMUstate *state) {
    Instance *c = (Instance *)comp;
    Snapshot *s;
    if (c == NULL || state == NULL) return fmi2Error;
    s = (Snapshot *)*state;
    if (s == NULL) {
        s = (Snapshot *)c->cb.allocateMemory(1, sizeof(Snapshot) + c->n_state * sizeof(double));
        if (s == NULL) return fail(c, "%s", "out of memory");
    }
    s->t0 = c->t0;
    s->k = c->k;
    s->velocity = c->velocity;
    s->acceleration = c->acceleration;
    s->n_outside = c->n_outside;
    s->mode = c->mode;
    s->warned_envelope = c->warned_envelope;
    memcpy((char *)s + sizeof(Snapshot), c->mem, c->n_state * sizeof(double));
    *state = s;
    return fmi2OK;
}

fmi2Status fmi2SetFMUstate(fmi2Component comp, fmi2FMUstate state) {
    Instance *c = (Instance *)comp;
    const Snapshot *s = (const Snapshot *)state;
    if (c == NULL || s == NULL) return fmi2Error;
    c->t0 = s->t0;
    c->k = s->k;
    c->velocity = s->velocity;
    c->acceleration = s->acceleration;
    c->n_outside = s->n_outside;
    c->mode = s->mode;
    c->warned_envelope = s->warned_envelope;
    memcpy(c->mem, (const char *)s + sizeof(Snapshot), c->n_state * sizeof(double));
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
    *size = sizeof(Snapshot) + c->n_state * sizeof(double);
    return fmi2OK;
}

fmi2Status fmi2SerializeFMUstate(fmi2Component comp, fmi2FMUstate state, fmi2Byte bytes[],
                                 size_t size) {
    Instance *c = (Instance *)comp;
    if (c == NULL || state == NULL) return fmi2Error;
    if (size != sizeof(Snapshot) + c->n_state * sizeof(double))
        return fail(c, "%s", "serialized FMU state of the wrong size");
    memcpy(bytes, state, size);
    return fmi2OK;
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component comp, const fmi2Byte bytes[], size_t size,
                                   fmi2FMUstate *state) {
    Instance *c = (Instance *)comp;
    if (c == NULL || state == NULL) return fmi2Error;
    if (size != sizeof(Snapshot) + c->n_state * sizeof(double))
        return fail(c, "%s", "serialized FMU state of the wrong size (another model?)");
    if (*state == NULL) {
        *state = c->cb.allocateMemory(1, size);
        if (*state == NULL) return fail(c, "%s", "out of memory");
    }
    memcpy(*state, bytes, size);
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
    double expected, u;
    char d[256];
    int j;
    (void)noSetFMUStatePriorToCurrentPoint;
    if (c == NULL) return fmi2Error;
    if (c->mode != MODE_STEP)
        return fail(c, "%s", c->mode == MODE_ERROR
                                 ? "the FMU is in an error state (see the earlier message)"
                                 : "fmi2DoStep is allowed only after initialization");
    if (!(fabs(h - SL_MODEL.dt) <= STEP_RTOL * SL_MODEL.dt)) {
        snprintf(d, sizeof d, "%.17g s is not the model's step %.17g s (%.10g Hz)", h,
                 SL_MODEL.dt, 1.0 / SL_MODEL.dt);
        return fail(c, "communication step %s: the network was identified at that sample "
                       "rate; use it as the communication step (a rate transition in front of "
                       "and behind the FMU if the rest of the model runs at another rate)", d);
    }
    expected = c->t0 + (double)c->k * SL_MODEL.dt;
    if (!(fabs(t - expected) <= STEP_RTOL * SL_MODEL.dt + 4.0 * DBL_EPSILON * fabs(expected))) {
        snprintf(d, sizeof d, "%.17g s, but the FMU is at %.17g s", t, expected);
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
    }
    for (j = 0; j < SL_MODEL.n_members; j++) {
        const SlMember *m = &SL_MODEL.members[j];
        double *s = scratch_of(c, j);
        sl_advance(m, member_state(c, j), member_rest(c, j), u, s[sl_scratch_size(m)], s);
    }
    c->k++;
    c->outputs_valid = 0;
    return fmi2OK;
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
        *value = c->t0 + (double)c->k * SL_MODEL.dt;
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
