/* Shared FMI 2.0 glue (co-simulation and model exchange) for the models in models/fmus.
 *
 * It implements every fmi2 entry point over the flat ModelData of model.h: mode checks,
 * get/set by value reference, lazy output evaluation, FMU state copy and serialization. A
 * model has no continuous states, so the model-exchange calls only have to keep the outputs
 * current; co-simulation steps call model_do_step. Written against the FMI 2 headers shipped
 * by fmpy (c-code/), which the build puts on the include path.
 */
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"
#include "model.h"

typedef enum {
    MODE_INSTANTIATED,
    MODE_INITIALIZATION,
    MODE_STEP,        /* co-simulation: stepping; model exchange: event or continuous time */
    MODE_TERMINATED,
    MODE_ERROR
} Mode;

typedef struct {
    ModelData data;
    Mode mode;
    fmi2Type type;
    fmi2CallbackFunctions callbacks;
    char *name;
    fmi2Boolean logging;
} Instance;

static void log_error(Instance *inst, const char *message) {
    if (inst->callbacks.logger) {
        inst->callbacks.logger(inst->callbacks.componentEnvironment, inst->name, fmi2Error,
                               "logError", "%s", message);
    }
}

static fmi2Status fail(Instance *inst, const char *message) {
    log_error(inst, message);
    return fmi2Error;
}

static void refresh(Instance *inst) {
    if (inst->data.dirty) {
        model_evaluate(&inst->data);
        inst->data.dirty = 0;
    }
}

/* ---- common functions ---------------------------------------------------------------- */

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }

const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[]) {
    (void)nCategories;
    (void)categories;
    ((Instance *)c)->logging = loggingOn;
    return fmi2OK;
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation,
                              const fmi2CallbackFunctions *functions, fmi2Boolean visible,
                              fmi2Boolean loggingOn) {
    (void)fmuResourceLocation;
    (void)visible;
    if (!functions || !instanceName || !fmuGUID) return NULL;
    if (strcmp(fmuGUID, MODEL_GUID) != 0) {
        if (functions->logger) {
            functions->logger(functions->componentEnvironment, instanceName, fmi2Error,
                              "logError", "GUID %s does not match " MODEL_GUID, fmuGUID);
        }
        return NULL;
    }
#if !MODEL_HAS_MODEL_EXCHANGE
    if (fmuType == fmi2ModelExchange) return NULL;
#endif
    Instance *inst = (Instance *)calloc(1, sizeof(Instance));
    if (!inst) return NULL;
    inst->name = (char *)malloc(strlen(instanceName) + 1);
    if (!inst->name) {
        free(inst);
        return NULL;
    }
    strcpy(inst->name, instanceName);
    inst->callbacks = *functions;
    inst->type = fmuType;
    inst->logging = loggingOn;
    inst->mode = MODE_INSTANTIATED;
    model_set_start_values(&inst->data);
    inst->data.dirty = 1;
    return inst;
}

void fmi2FreeInstance(fmi2Component c) {
    Instance *inst = (Instance *)c;
    if (!inst) return;
    free(inst->name);
    free(inst);
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined,
                               fmi2Real tolerance, fmi2Real startTime,
                               fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    Instance *inst = (Instance *)c;
    (void)toleranceDefined;
    (void)tolerance;
    (void)stopTimeDefined;
    (void)stopTime;
    if (inst->mode != MODE_INSTANTIATED) return fail(inst, "fmi2SetupExperiment: wrong mode");
    inst->data.time = startTime;
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    Instance *inst = (Instance *)c;
    if (inst->mode != MODE_INSTANTIATED) {
        return fail(inst, "fmi2EnterInitializationMode: wrong mode");
    }
    inst->mode = MODE_INITIALIZATION;
    return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    Instance *inst = (Instance *)c;
    if (inst->mode != MODE_INITIALIZATION) {
        return fail(inst, "fmi2ExitInitializationMode: wrong mode");
    }
    model_initialize(&inst->data);
    inst->data.dirty = 1;
    inst->mode = MODE_STEP;
    return fmi2OK;
}

fmi2Status fmi2Terminate(fmi2Component c) {
    Instance *inst = (Instance *)c;
    if (inst->mode != MODE_STEP) return fail(inst, "fmi2Terminate: wrong mode");
    inst->mode = MODE_TERMINATED;
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component c) {
    Instance *inst = (Instance *)c;
    memset(&inst->data, 0, sizeof(inst->data));
    model_set_start_values(&inst->data);
    inst->data.dirty = 1;
    inst->mode = MODE_INSTANTIATED;
    return fmi2OK;
}

/* ---- get and set --------------------------------------------------------------------- */

/* Whether vr lies in [base, base + count): one range per FMI base type. */
static int in_range(fmi2ValueReference vr, unsigned base, int count) {
    return vr >= base && (long)vr - (long)base < (long)count;
}

#define CHECK_VR(base, count)                                                \
    if (!in_range(vr[k], (base), (count))) {                                 \
        return fail(inst, "unknown value reference");                        \
    }

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       fmi2Real value[]) {
    Instance *inst = (Instance *)c;
    if (nvr > 0) refresh(inst);
    for (size_t k = 0; k < nvr; k++) {
        CHECK_VR(0u, N_REALS)
        value[k] = inst->data.reals[vr[k]];
    }
    return fmi2OK;
}

fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          fmi2Integer value[]) {
    Instance *inst = (Instance *)c;
    if (nvr > 0) refresh(inst);
    for (size_t k = 0; k < nvr; k++) {
        CHECK_VR(INTEGER_VR_BASE, N_INTEGERS)
        value[k] = inst->data.integers[vr[k] - INTEGER_VR_BASE];
    }
    return fmi2OK;
}

fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          fmi2Boolean value[]) {
    Instance *inst = (Instance *)c;
    if (nvr > 0) refresh(inst);
    for (size_t k = 0; k < nvr; k++) {
        CHECK_VR(BOOLEAN_VR_BASE, N_BOOLEANS)
        value[k] = inst->data.booleans[vr[k] - BOOLEAN_VR_BASE];
    }
    return fmi2OK;
}

fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                         fmi2String value[]) {
    (void)vr;
    (void)value;
    return nvr == 0 ? fmi2OK : fail((Instance *)c, "the model has no String variables");
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       const fmi2Real value[]) {
    Instance *inst = (Instance *)c;
    for (size_t k = 0; k < nvr; k++) {
        CHECK_VR(0u, N_REALS)
        inst->data.reals[vr[k]] = value[k];
    }
    inst->data.dirty = 1;
    return fmi2OK;
}

fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Integer value[]) {
    Instance *inst = (Instance *)c;
    for (size_t k = 0; k < nvr; k++) {
        CHECK_VR(INTEGER_VR_BASE, N_INTEGERS)
        inst->data.integers[vr[k] - INTEGER_VR_BASE] = value[k];
    }
    inst->data.dirty = 1;
    return fmi2OK;
}

fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Boolean value[]) {
    Instance *inst = (Instance *)c;
    for (size_t k = 0; k < nvr; k++) {
        CHECK_VR(BOOLEAN_VR_BASE, N_BOOLEANS)
        inst->data.booleans[vr[k] - BOOLEAN_VR_BASE] = value[k] ? fmi2True : fmi2False;
    }
    inst->data.dirty = 1;
    return fmi2OK;
}

fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                         const fmi2String value[]) {
    (void)vr;
    (void)value;
    return nvr == 0 ? fmi2OK : fail((Instance *)c, "the model has no String variables");
}

/* ---- FMU state: ModelData is plain data, so a state is a copy of it -------------------- */

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *state) {
    Instance *inst = (Instance *)c;
    ModelData *copy = (ModelData *)(*state ? *state : malloc(sizeof(ModelData)));
    if (!copy) return fail(inst, "out of memory");
    *copy = inst->data;
    *state = copy;
    return fmi2OK;
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate state) {
    Instance *inst = (Instance *)c;
    if (!state) return fail(inst, "fmi2SetFMUstate: null state");
    inst->data = *(ModelData *)state;
    return fmi2OK;
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *state) {
    (void)c;
    if (state) {
        free(*state);
        *state = NULL;
    }
    return fmi2OK;
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate state, size_t *size) {
    (void)c;
    (void)state;
    *size = sizeof(ModelData);
    return fmi2OK;
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate state, fmi2Byte bytes[],
                                 size_t size) {
    Instance *inst = (Instance *)c;
    if (size != sizeof(ModelData)) return fail(inst, "serialized state has the wrong size");
    memcpy(bytes, state, sizeof(ModelData));
    return fmi2OK;
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte bytes[], size_t size,
                                   fmi2FMUstate *state) {
    Instance *inst = (Instance *)c;
    if (size != sizeof(ModelData)) return fail(inst, "serialized state has the wrong size");
    ModelData *copy = (ModelData *)(*state ? *state : malloc(sizeof(ModelData)));
    if (!copy) return fail(inst, "out of memory");
    memcpy(copy, bytes, sizeof(ModelData));
    *state = copy;
    return fmi2OK;
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown[],
                                        size_t nUnknown, const fmi2ValueReference vKnown[],
                                        size_t nKnown, const fmi2Real dvKnown[],
                                        fmi2Real dvUnknown[]) {
    (void)vUnknown;
    (void)nUnknown;
    (void)vKnown;
    (void)nKnown;
    (void)dvKnown;
    (void)dvUnknown;
    return fail((Instance *)c, "directional derivatives are not provided");
}

/* ---- model exchange (no continuous states) ------------------------------------------- */

fmi2Status fmi2EnterEventMode(fmi2Component c) {
    (void)c;
    return fmi2OK;
}

fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo *info) {
    (void)c;
    info->newDiscreteStatesNeeded = fmi2False;
    info->terminateSimulation = fmi2False;
    info->nominalsOfContinuousStatesChanged = fmi2False;
    info->valuesOfContinuousStatesChanged = fmi2False;
    info->nextEventTimeDefined = fmi2False;
    info->nextEventTime = 0.0;
    return fmi2OK;
}

fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c) {
    (void)c;
    return fmi2OK;
}

fmi2Status fmi2CompletedIntegratorStep(fmi2Component c, fmi2Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi2Boolean *enterEventMode,
                                       fmi2Boolean *terminateSimulation) {
    (void)c;
    (void)noSetFMUStatePriorToCurrentPoint;
    *enterEventMode = fmi2False;
    *terminateSimulation = fmi2False;
    return fmi2OK;
}

fmi2Status fmi2SetTime(fmi2Component c, fmi2Real time) {
    Instance *inst = (Instance *)c;
    inst->data.time = time;
    inst->data.dirty = 1;
    return fmi2OK;
}

fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real x[], size_t nx) {
    (void)x;
    return nx == 0 ? fmi2OK : fail((Instance *)c, "the model has no continuous states");
}

fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real derivatives[], size_t nx) {
    (void)derivatives;
    return nx == 0 ? fmi2OK : fail((Instance *)c, "the model has no continuous states");
}

fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real eventIndicators[], size_t ni) {
    (void)eventIndicators;
    return ni == 0 ? fmi2OK : fail((Instance *)c, "the model has no event indicators");
}

fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real x[], size_t nx) {
    (void)x;
    return nx == 0 ? fmi2OK : fail((Instance *)c, "the model has no continuous states");
}

fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real x_nominal[], size_t nx) {
    (void)x_nominal;
    return nx == 0 ? fmi2OK : fail((Instance *)c, "the model has no continuous states");
}

/* ---- co-simulation ------------------------------------------------------------------- */

fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[],
                                       size_t nvr, const fmi2Integer order[],
                                       const fmi2Real value[]) {
    (void)vr;
    (void)order;
    (void)value;
    return nvr == 0 ? fmi2OK : fail((Instance *)c, "input derivatives are not supported");
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[],
                                        size_t nvr, const fmi2Integer order[],
                                        fmi2Real value[]) {
    (void)vr;
    (void)order;
    (void)value;
    return nvr == 0 ? fmi2OK : fail((Instance *)c, "output derivatives are not supported");
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint,
                      fmi2Real communicationStepSize, fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
    Instance *inst = (Instance *)c;
    (void)noSetFMUStatePriorToCurrentPoint;
    if (inst->mode != MODE_STEP) return fail(inst, "fmi2DoStep: wrong mode");
    if (communicationStepSize <= 0.0) return fail(inst, "fmi2DoStep: step size must be > 0");
    inst->data.time = currentCommunicationPoint;
    model_do_step(&inst->data, communicationStepSize);
    inst->data.time = currentCommunicationPoint + communicationStepSize;
    inst->data.dirty = 1;
    return fmi2OK;
}

fmi2Status fmi2CancelStep(fmi2Component c) {
    return fail((Instance *)c, "fmi2CancelStep: steps complete synchronously");
}

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value) {
    (void)s;
    (void)value;
    return fail((Instance *)c, "fmi2GetStatus: steps complete synchronously");
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value) {
    Instance *inst = (Instance *)c;
    if (s == fmi2LastSuccessfulTime) {
        *value = inst->data.time;
        return fmi2OK;
    }
    return fail(inst, "fmi2GetRealStatus: unsupported status kind");
}

fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value) {
    (void)s;
    (void)value;
    return fail((Instance *)c, "fmi2GetIntegerStatus: unsupported status kind");
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value) {
    (void)s;
    (void)value;
    return fail((Instance *)c, "fmi2GetBooleanStatus: unsupported status kind");
}

fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value) {
    (void)s;
    (void)value;
    return fail((Instance *)c, "fmi2GetStringStatus: unsupported status kind");
}
