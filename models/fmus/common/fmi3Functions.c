/* Shared FMI 3.0 glue (co-simulation and model exchange) for the models in models/fmus.
 *
 * Why a second glue: the same model.c (equations behind the model.h contract) is offered as
 * an FMI 3 FMU too, without a second copy of the equations. This file maps FMI 3 onto the flat
 * ModelData of model.h exactly as fmi2Functions.c maps FMI 2 onto it:
 *
 *   Float64  <-> reals     (value references 0..N_REALS-1)
 *   Int32    <-> integers  (INTEGER_VR_BASE..)
 *   Boolean  <-> booleans  (BOOLEAN_VR_BASE..)
 *   Float64 TIME_VR        the independent variable `time`, which FMI 3 requires to be declared
 *
 * FMI 3 arrays: an array variable has ONE value reference and its elements travel together
 * (fmi3GetFloat64's nValues counts elements, not variables). A model whose FMI 3 build declares
 * Float64 arrays defines MODEL_HAS_FMI3_ARRAYS (a PreprocessorDefinition of its
 * buildDescription.xml) and ships fmi3Arrays.h with MODEL_FMI3_ARRAYS, a table of
 * {value reference, first index in reals, element count}; the array's elements are that many
 * consecutive reals. Every other Float64 value reference is a scalar, reals[vr], as in FMI 2.
 * The FMI 2 glue never sees the table, so the FMI 2 build keeps its indexed scalars.
 *
 * Models have no continuous states and no events, so model exchange only keeps the outputs
 * current and co-simulation steps call model_do_step. What FMI 3 adds beyond that (clocks,
 * scheduled execution, configuration mode, other integer widths, strings, binaries,
 * derivatives) is refused with fmi3Error and a log message. Written against the FMI 3 headers
 * shipped by fmpy (c-code/), which the build puts on the include path.
 */
#include <stdlib.h>
#include <string.h>

#include "fmi3Functions.h"
#include "model.h"

#if defined(MODEL_HAS_FMI3_ARRAYS) && MODEL_HAS_FMI3_ARRAYS
#include "fmi3Arrays.h"
#endif

/* Value reference of `time`: above every per-type range of model.h. */
#define TIME_VR 1000u

#define UNUSED(x) (void)(x)

typedef enum {
    MODE_INSTANTIATED,
    MODE_INITIALIZATION,
    MODE_RUNNING, /* co-simulation: step mode; model exchange: event or continuous-time mode */
    MODE_TERMINATED
} Mode;

typedef struct {
    ModelData data;
    Mode mode;
    int model_exchange;
    char *name;
    fmi3InstanceEnvironment environment;
    fmi3LogMessageCallback logger;
} Instance;

static fmi3Status fail(fmi3Instance instance, const char *message) {
    Instance *inst = (Instance *)instance;
    if (inst && inst->logger) inst->logger(inst->environment, fmi3Error, "logStatusError", message);
    return fmi3Error;
}

static void refresh(Instance *inst) {
    if (inst->data.dirty) {
        model_evaluate(&inst->data);
        inst->data.dirty = 0;
    }
}

/* Whether vr lies in [base, base + count): one range per FMI base type. */
static int in_range(fmi3ValueReference vr, unsigned base, int count) {
    return vr >= base && (long)vr - (long)base < (long)count;
}

/* A Float64 variable backed by `count` consecutive reals from `first` (an FMI 3 array). */
typedef struct {
    fmi3ValueReference vr;
    int first;
    int count;
} RealSpan;

#ifdef MODEL_FMI3_ARRAYS
static const RealSpan ARRAYS[] = MODEL_FMI3_ARRAYS;
static const size_t N_ARRAYS = sizeof(ARRAYS) / sizeof(ARRAYS[0]);
#else
static const RealSpan ARRAYS[1] = {{0u, 0, 0}};
static const size_t N_ARRAYS = 0; /* the model has no arrays */
#endif

/* The reals behind the Float64 value reference vr (not `time`): sets *first and returns the
 * element count, or 0 when vr names no variable. A real inside an array is reachable only
 * through the array's value reference, so that it is never mistaken for a scalar. */
static int real_span(fmi3ValueReference vr, int *first) {
    for (size_t a = 0; a < N_ARRAYS; a++) {
        if (ARRAYS[a].vr == vr) {
            *first = ARRAYS[a].first;
            return ARRAYS[a].count;
        }
    }
    if (!in_range(vr, 0u, N_REALS)) return 0;
    for (size_t a = 0; a < N_ARRAYS; a++) {
        if (in_range(vr, (unsigned)ARRAYS[a].first, ARRAYS[a].count)) return 0;
    }
    *first = (int)vr;
    return 1;
}

/* Sum of the element counts of the Float64 value references, or 0 when one is unknown (or
 * `time` while it may not be set). Checked before any value is touched, so that a bad call
 * changes nothing. */
static size_t float64_values(const fmi3ValueReference valueReferences[],
                             size_t nValueReferences, int allow_time, int *unknown) {
    size_t total = 0;
    *unknown = 0;
    for (size_t k = 0; k < nValueReferences; k++) {
        int first = 0;
        if (allow_time && valueReferences[k] == TIME_VR) {
            total += 1;
            continue;
        }
        const int count = real_span(valueReferences[k], &first);
        if (count <= 0) {
            *unknown = 1;
            return 0;
        }
        total += (size_t)count;
    }
    return total;
}

/* Every Int32 and Boolean variable is a scalar: one value per value reference. */
#define CHECK_SCALARS(function)                                                    \
    if (nValues != nValueReferences) {                                             \
        return fail(instance, function ": nValues differs from nValueReferences"); \
    }

/* ---- version, logging, instances ------------------------------------------------------ */

const char *fmi3GetVersion(void) { return fmi3Version; }

fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean loggingOn, size_t nCategories,
                               const fmi3String categories[]) {
    UNUSED(instance);
    UNUSED(loggingOn);
    UNUSED(nCategories);
    UNUSED(categories);
    return fmi3OK;
}

static Instance *instantiate(fmi3String instanceName, fmi3String instantiationToken,
                             fmi3InstanceEnvironment environment,
                             fmi3LogMessageCallback logMessage, int model_exchange) {
    if (!instanceName) return NULL;
    if (!instantiationToken || strcmp(instantiationToken, MODEL_GUID) != 0) {
        if (logMessage) {
            logMessage(environment, fmi3Error, "logStatusError",
                       "instantiationToken does not match " MODEL_GUID);
        }
        return NULL;
    }
    Instance *inst = (Instance *)calloc(1, sizeof(Instance));
    if (!inst) return NULL;
    inst->name = (char *)malloc(strlen(instanceName) + 1);
    if (!inst->name) {
        free(inst);
        return NULL;
    }
    strcpy(inst->name, instanceName);
    inst->environment = environment;
    inst->logger = logMessage;
    inst->model_exchange = model_exchange;
    inst->mode = MODE_INSTANTIATED;
    model_set_start_values(&inst->data);
    inst->data.dirty = 1;
    return inst;
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName,
                                          fmi3String instantiationToken,
                                          fmi3String resourcePath, fmi3Boolean visible,
                                          fmi3Boolean loggingOn,
                                          fmi3InstanceEnvironment instanceEnvironment,
                                          fmi3LogMessageCallback logMessage) {
    UNUSED(resourcePath);
    UNUSED(visible);
    UNUSED(loggingOn);
#if MODEL_HAS_MODEL_EXCHANGE
    return instantiate(instanceName, instantiationToken, instanceEnvironment, logMessage, 1);
#else
    UNUSED(instanceName);
    UNUSED(instantiationToken);
    UNUSED(instanceEnvironment);
    UNUSED(logMessage);
    return NULL;
#endif
}

fmi3Instance fmi3InstantiateCoSimulation(
    fmi3String instanceName, fmi3String instantiationToken, fmi3String resourcePath,
    fmi3Boolean visible, fmi3Boolean loggingOn, fmi3Boolean eventModeUsed,
    fmi3Boolean earlyReturnAllowed, const fmi3ValueReference requiredIntermediateVariables[],
    size_t nRequiredIntermediateVariables, fmi3InstanceEnvironment instanceEnvironment,
    fmi3LogMessageCallback logMessage, fmi3IntermediateUpdateCallback intermediateUpdate) {
    UNUSED(resourcePath);
    UNUSED(visible);
    UNUSED(loggingOn);
    UNUSED(earlyReturnAllowed);
    UNUSED(requiredIntermediateVariables);
    UNUSED(nRequiredIntermediateVariables);
    UNUSED(intermediateUpdate);
    if (eventModeUsed) {
        /* hasEventMode="false": the models have no events to hand to the importer */
        if (logMessage) {
            logMessage(instanceEnvironment, fmi3Error, "logStatusError",
                       "eventModeUsed: this FMU has no event mode");
        }
        return NULL;
    }
    return instantiate(instanceName, instantiationToken, instanceEnvironment, logMessage, 0);
}

fmi3Instance fmi3InstantiateScheduledExecution(
    fmi3String instanceName, fmi3String instantiationToken, fmi3String resourcePath,
    fmi3Boolean visible, fmi3Boolean loggingOn, fmi3InstanceEnvironment instanceEnvironment,
    fmi3LogMessageCallback logMessage, fmi3ClockUpdateCallback clockUpdate,
    fmi3LockPreemptionCallback lockPreemption, fmi3UnlockPreemptionCallback unlockPreemption) {
    UNUSED(instanceName);
    UNUSED(instantiationToken);
    UNUSED(resourcePath);
    UNUSED(visible);
    UNUSED(loggingOn);
    UNUSED(instanceEnvironment);
    UNUSED(logMessage);
    UNUSED(clockUpdate);
    UNUSED(lockPreemption);
    UNUSED(unlockPreemption);
    return NULL;
}

void fmi3FreeInstance(fmi3Instance instance) {
    Instance *inst = (Instance *)instance;
    if (!inst) return;
    free(inst->name);
    free(inst);
}

/* ---- initialization, termination ------------------------------------------------------ */

fmi3Status fmi3EnterInitializationMode(fmi3Instance instance, fmi3Boolean toleranceDefined,
                                       fmi3Float64 tolerance, fmi3Float64 startTime,
                                       fmi3Boolean stopTimeDefined, fmi3Float64 stopTime) {
    Instance *inst = (Instance *)instance;
    UNUSED(toleranceDefined);
    UNUSED(tolerance);
    UNUSED(stopTimeDefined);
    UNUSED(stopTime);
    if (inst->mode != MODE_INSTANTIATED) {
        return fail(instance, "fmi3EnterInitializationMode: wrong mode");
    }
    inst->data.time = startTime;
    inst->mode = MODE_INITIALIZATION;
    return fmi3OK;
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance instance) {
    Instance *inst = (Instance *)instance;
    if (inst->mode != MODE_INITIALIZATION) {
        return fail(instance, "fmi3ExitInitializationMode: wrong mode");
    }
    model_initialize(&inst->data);
    inst->data.dirty = 1;
    inst->mode = MODE_RUNNING;
    return fmi3OK;
}

fmi3Status fmi3EnterEventMode(fmi3Instance instance) {
    Instance *inst = (Instance *)instance;
    if (!inst->model_exchange) return fail(instance, "fmi3EnterEventMode: no event mode");
    return fmi3OK;
}

fmi3Status fmi3Terminate(fmi3Instance instance) {
    Instance *inst = (Instance *)instance;
    if (inst->mode != MODE_RUNNING) return fail(instance, "fmi3Terminate: wrong mode");
    inst->mode = MODE_TERMINATED;
    return fmi3OK;
}

fmi3Status fmi3Reset(fmi3Instance instance) {
    Instance *inst = (Instance *)instance;
    memset(&inst->data, 0, sizeof(inst->data));
    model_set_start_values(&inst->data);
    inst->data.dirty = 1;
    inst->mode = MODE_INSTANTIATED;
    return fmi3OK;
}

/* ---- get and set ---------------------------------------------------------------------- */

fmi3Status fmi3GetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                          size_t nValueReferences, fmi3Float64 values[], size_t nValues) {
    Instance *inst = (Instance *)instance;
    int unknown = 0;
    const size_t total = float64_values(valueReferences, nValueReferences, 1, &unknown);
    if (unknown) return fail(instance, "fmi3GetFloat64: unknown value reference");
    if (total != nValues) {
        return fail(instance, "fmi3GetFloat64: nValues differs from the variables' element count");
    }
    if (nValueReferences > 0) refresh(inst);
    size_t at = 0;
    for (size_t k = 0; k < nValueReferences; k++) {
        const fmi3ValueReference vr = valueReferences[k];
        if (vr == TIME_VR) {
            values[at++] = inst->data.time;
            continue;
        }
        int first = 0;
        const int count = real_span(vr, &first);
        for (int e = 0; e < count; e++) values[at++] = inst->data.reals[first + e];
    }
    return fmi3OK;
}

fmi3Status fmi3SetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                          size_t nValueReferences, const fmi3Float64 values[], size_t nValues) {
    Instance *inst = (Instance *)instance;
    int unknown = 0;
    const size_t total = float64_values(valueReferences, nValueReferences, 0, &unknown);
    if (unknown) return fail(instance, "fmi3SetFloat64: value reference cannot be set");
    if (total != nValues) {
        return fail(instance, "fmi3SetFloat64: nValues differs from the variables' element count");
    }
    size_t at = 0;
    for (size_t k = 0; k < nValueReferences; k++) {
        int first = 0;
        const int count = real_span(valueReferences[k], &first);
        for (int e = 0; e < count; e++) inst->data.reals[first + e] = values[at++];
    }
    inst->data.dirty = 1;
    return fmi3OK;
}

fmi3Status fmi3GetInt32(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                        size_t nValueReferences, fmi3Int32 values[], size_t nValues) {
    Instance *inst = (Instance *)instance;
    CHECK_SCALARS("fmi3GetInt32")
    if (nValueReferences > 0) refresh(inst);
    for (size_t k = 0; k < nValueReferences; k++) {
        if (!in_range(valueReferences[k], INTEGER_VR_BASE, N_INTEGERS)) {
            return fail(instance, "fmi3GetInt32: unknown value reference");
        }
        values[k] = inst->data.integers[valueReferences[k] - INTEGER_VR_BASE];
    }
    return fmi3OK;
}

fmi3Status fmi3SetInt32(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                        size_t nValueReferences, const fmi3Int32 values[], size_t nValues) {
    Instance *inst = (Instance *)instance;
    CHECK_SCALARS("fmi3SetInt32")
    for (size_t k = 0; k < nValueReferences; k++) {
        if (!in_range(valueReferences[k], INTEGER_VR_BASE, N_INTEGERS)) {
            return fail(instance, "fmi3SetInt32: unknown value reference");
        }
        inst->data.integers[valueReferences[k] - INTEGER_VR_BASE] = values[k];
    }
    inst->data.dirty = 1;
    return fmi3OK;
}

fmi3Status fmi3GetBoolean(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                          size_t nValueReferences, fmi3Boolean values[], size_t nValues) {
    Instance *inst = (Instance *)instance;
    CHECK_SCALARS("fmi3GetBoolean")
    if (nValueReferences > 0) refresh(inst);
    for (size_t k = 0; k < nValueReferences; k++) {
        if (!in_range(valueReferences[k], BOOLEAN_VR_BASE, N_BOOLEANS)) {
            return fail(instance, "fmi3GetBoolean: unknown value reference");
        }
        values[k] = inst->data.booleans[valueReferences[k] - BOOLEAN_VR_BASE] != 0;
    }
    return fmi3OK;
}

fmi3Status fmi3SetBoolean(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                          size_t nValueReferences, const fmi3Boolean values[], size_t nValues) {
    Instance *inst = (Instance *)instance;
    CHECK_SCALARS("fmi3SetBoolean")
    for (size_t k = 0; k < nValueReferences; k++) {
        if (!in_range(valueReferences[k], BOOLEAN_VR_BASE, N_BOOLEANS)) {
            return fail(instance, "fmi3SetBoolean: unknown value reference");
        }
        inst->data.booleans[valueReferences[k] - BOOLEAN_VR_BASE] = values[k] ? 1 : 0;
    }
    inst->data.dirty = 1;
    return fmi3OK;
}

/* The models declare no variables of the remaining types: an empty call is fine. */
static fmi3Status no_variables(fmi3Instance instance, size_t nValueReferences) {
    return nValueReferences == 0 ? fmi3OK : fail(instance, "no variable of this type");
}

#define NO_GET(NAME, T)                                                                 \
    fmi3Status NAME(fmi3Instance instance, const fmi3ValueReference valueReferences[],  \
                    size_t nValueReferences, T values[], size_t nValues) {              \
        UNUSED(valueReferences);                                                        \
        UNUSED(values);                                                                 \
        UNUSED(nValues);                                                                \
        return no_variables(instance, nValueReferences);                                \
    }

#define NO_SET(NAME, T)                                                                 \
    fmi3Status NAME(fmi3Instance instance, const fmi3ValueReference valueReferences[],  \
                    size_t nValueReferences, const T values[], size_t nValues) {        \
        UNUSED(valueReferences);                                                        \
        UNUSED(values);                                                                 \
        UNUSED(nValues);                                                                \
        return no_variables(instance, nValueReferences);                                \
    }

NO_GET(fmi3GetFloat32, fmi3Float32)
NO_GET(fmi3GetInt8, fmi3Int8)
NO_GET(fmi3GetUInt8, fmi3UInt8)
NO_GET(fmi3GetInt16, fmi3Int16)
NO_GET(fmi3GetUInt16, fmi3UInt16)
NO_GET(fmi3GetUInt32, fmi3UInt32)
NO_GET(fmi3GetInt64, fmi3Int64)
NO_GET(fmi3GetUInt64, fmi3UInt64)
NO_GET(fmi3GetString, fmi3String)
NO_SET(fmi3SetFloat32, fmi3Float32)
NO_SET(fmi3SetInt8, fmi3Int8)
NO_SET(fmi3SetUInt8, fmi3UInt8)
NO_SET(fmi3SetInt16, fmi3Int16)
NO_SET(fmi3SetUInt16, fmi3UInt16)
NO_SET(fmi3SetUInt32, fmi3UInt32)
NO_SET(fmi3SetInt64, fmi3Int64)
NO_SET(fmi3SetUInt64, fmi3UInt64)
NO_SET(fmi3SetString, fmi3String)

fmi3Status fmi3GetBinary(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                         size_t nValueReferences, size_t valueSizes[], fmi3Binary values[],
                         size_t nValues) {
    UNUSED(valueReferences);
    UNUSED(valueSizes);
    UNUSED(values);
    UNUSED(nValues);
    return no_variables(instance, nValueReferences);
}

fmi3Status fmi3SetBinary(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                         size_t nValueReferences, const size_t valueSizes[],
                         const fmi3Binary values[], size_t nValues) {
    UNUSED(valueReferences);
    UNUSED(valueSizes);
    UNUSED(values);
    UNUSED(nValues);
    return no_variables(instance, nValueReferences);
}

fmi3Status fmi3GetClock(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                        size_t nValueReferences, fmi3Clock values[]) {
    UNUSED(valueReferences);
    UNUSED(values);
    return no_variables(instance, nValueReferences);
}

fmi3Status fmi3SetClock(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                        size_t nValueReferences, const fmi3Clock values[]) {
    UNUSED(valueReferences);
    UNUSED(values);
    return no_variables(instance, nValueReferences);
}

/* ---- dependencies and derivatives: the model description states the dependencies ------- */

fmi3Status fmi3GetNumberOfVariableDependencies(fmi3Instance instance,
                                               fmi3ValueReference valueReference,
                                               size_t *nDependencies) {
    UNUSED(valueReference);
    UNUSED(nDependencies);
    return fail(instance, "fmi3GetNumberOfVariableDependencies: see <ModelStructure>");
}

fmi3Status fmi3GetVariableDependencies(fmi3Instance instance, fmi3ValueReference dependent,
                                       size_t elementIndicesOfDependent[],
                                       fmi3ValueReference independents[],
                                       size_t elementIndicesOfIndependents[],
                                       fmi3DependencyKind dependencyKinds[],
                                       size_t nDependencies) {
    UNUSED(dependent);
    UNUSED(elementIndicesOfDependent);
    UNUSED(independents);
    UNUSED(elementIndicesOfIndependents);
    UNUSED(dependencyKinds);
    UNUSED(nDependencies);
    return fail(instance, "fmi3GetVariableDependencies: see <ModelStructure>");
}

fmi3Status fmi3GetDirectionalDerivative(fmi3Instance instance,
                                        const fmi3ValueReference unknowns[], size_t nUnknowns,
                                        const fmi3ValueReference knowns[], size_t nKnowns,
                                        const fmi3Float64 seed[], size_t nSeed,
                                        fmi3Float64 sensitivity[], size_t nSensitivity) {
    UNUSED(unknowns);
    UNUSED(nUnknowns);
    UNUSED(knowns);
    UNUSED(nKnowns);
    UNUSED(seed);
    UNUSED(nSeed);
    UNUSED(sensitivity);
    UNUSED(nSensitivity);
    return fail(instance, "directional derivatives are not provided");
}

fmi3Status fmi3GetAdjointDerivative(fmi3Instance instance, const fmi3ValueReference unknowns[],
                                    size_t nUnknowns, const fmi3ValueReference knowns[],
                                    size_t nKnowns, const fmi3Float64 seed[], size_t nSeed,
                                    fmi3Float64 sensitivity[], size_t nSensitivity) {
    UNUSED(unknowns);
    UNUSED(nUnknowns);
    UNUSED(knowns);
    UNUSED(nKnowns);
    UNUSED(seed);
    UNUSED(nSeed);
    UNUSED(sensitivity);
    UNUSED(nSensitivity);
    return fail(instance, "adjoint derivatives are not provided");
}

/* ---- FMU state: ModelData is plain data, so a state is a copy of it -------------------- */

fmi3Status fmi3GetFMUState(fmi3Instance instance, fmi3FMUState *FMUState) {
    Instance *inst = (Instance *)instance;
    ModelData *copy = (ModelData *)(*FMUState ? *FMUState : malloc(sizeof(ModelData)));
    if (!copy) return fail(instance, "out of memory");
    *copy = inst->data;
    *FMUState = copy;
    return fmi3OK;
}

fmi3Status fmi3SetFMUState(fmi3Instance instance, fmi3FMUState FMUState) {
    Instance *inst = (Instance *)instance;
    if (!FMUState) return fail(instance, "fmi3SetFMUState: null state");
    inst->data = *(ModelData *)FMUState;
    return fmi3OK;
}

fmi3Status fmi3FreeFMUState(fmi3Instance instance, fmi3FMUState *FMUState) {
    UNUSED(instance);
    if (FMUState) {
        free(*FMUState);
        *FMUState = NULL;
    }
    return fmi3OK;
}

fmi3Status fmi3SerializedFMUStateSize(fmi3Instance instance, fmi3FMUState FMUState,
                                      size_t *size) {
    UNUSED(instance);
    UNUSED(FMUState);
    *size = sizeof(ModelData);
    return fmi3OK;
}

fmi3Status fmi3SerializeFMUState(fmi3Instance instance, fmi3FMUState FMUState,
                                 fmi3Byte serializedState[], size_t size) {
    if (size != sizeof(ModelData)) return fail(instance, "serialized state has the wrong size");
    memcpy(serializedState, FMUState, sizeof(ModelData));
    return fmi3OK;
}

fmi3Status fmi3DeserializeFMUState(fmi3Instance instance, const fmi3Byte serializedState[],
                                   size_t size, fmi3FMUState *FMUState) {
    if (size != sizeof(ModelData)) return fail(instance, "serialized state has the wrong size");
    ModelData *copy = (ModelData *)(*FMUState ? *FMUState : malloc(sizeof(ModelData)));
    if (!copy) return fail(instance, "out of memory");
    memcpy(copy, serializedState, sizeof(ModelData));
    *FMUState = copy;
    return fmi3OK;
}

/* ---- configuration mode and clocks (not offered) --------------------------------------- */

fmi3Status fmi3EnterConfigurationMode(fmi3Instance instance) {
    return fail(instance, "the model has no structural parameters");
}

fmi3Status fmi3ExitConfigurationMode(fmi3Instance instance) {
    return fail(instance, "the model has no structural parameters");
}

fmi3Status fmi3GetIntervalDecimal(fmi3Instance instance,
                                  const fmi3ValueReference valueReferences[],
                                  size_t nValueReferences, fmi3Float64 intervals[],
                                  fmi3IntervalQualifier qualifiers[]) {
    UNUSED(valueReferences);
    UNUSED(intervals);
    UNUSED(qualifiers);
    return no_variables(instance, nValueReferences);
}

fmi3Status fmi3GetIntervalFraction(fmi3Instance instance,
                                   const fmi3ValueReference valueReferences[],
                                   size_t nValueReferences, fmi3UInt64 counters[],
                                   fmi3UInt64 resolutions[], fmi3IntervalQualifier qualifiers[]) {
    UNUSED(valueReferences);
    UNUSED(counters);
    UNUSED(resolutions);
    UNUSED(qualifiers);
    return no_variables(instance, nValueReferences);
}

fmi3Status fmi3GetShiftDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                               size_t nValueReferences, fmi3Float64 shifts[]) {
    UNUSED(valueReferences);
    UNUSED(shifts);
    return no_variables(instance, nValueReferences);
}

fmi3Status fmi3GetShiftFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                size_t nValueReferences, fmi3UInt64 counters[],
                                fmi3UInt64 resolutions[]) {
    UNUSED(valueReferences);
    UNUSED(counters);
    UNUSED(resolutions);
    return no_variables(instance, nValueReferences);
}

fmi3Status fmi3SetIntervalDecimal(fmi3Instance instance,
                                  const fmi3ValueReference valueReferences[],
                                  size_t nValueReferences, const fmi3Float64 intervals[]) {
    UNUSED(valueReferences);
    UNUSED(intervals);
    return no_variables(instance, nValueReferences);
}

fmi3Status fmi3SetIntervalFraction(fmi3Instance instance,
                                   const fmi3ValueReference valueReferences[],
                                   size_t nValueReferences, const fmi3UInt64 counters[],
                                   const fmi3UInt64 resolutions[]) {
    UNUSED(valueReferences);
    UNUSED(counters);
    UNUSED(resolutions);
    return no_variables(instance, nValueReferences);
}

fmi3Status fmi3SetShiftDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                               size_t nValueReferences, const fmi3Float64 shifts[]) {
    UNUSED(valueReferences);
    UNUSED(shifts);
    return no_variables(instance, nValueReferences);
}

fmi3Status fmi3SetShiftFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                size_t nValueReferences, const fmi3UInt64 counters[],
                                const fmi3UInt64 resolutions[]) {
    UNUSED(valueReferences);
    UNUSED(counters);
    UNUSED(resolutions);
    return no_variables(instance, nValueReferences);
}

fmi3Status fmi3EvaluateDiscreteStates(fmi3Instance instance) {
    refresh((Instance *)instance);
    return fmi3OK;
}

fmi3Status fmi3UpdateDiscreteStates(fmi3Instance instance, fmi3Boolean *discreteStatesNeedUpdate,
                                    fmi3Boolean *terminateSimulation,
                                    fmi3Boolean *nominalsOfContinuousStatesChanged,
                                    fmi3Boolean *valuesOfContinuousStatesChanged,
                                    fmi3Boolean *nextEventTimeDefined,
                                    fmi3Float64 *nextEventTime) {
    refresh((Instance *)instance);
    *discreteStatesNeedUpdate = fmi3False;
    *terminateSimulation = fmi3False;
    *nominalsOfContinuousStatesChanged = fmi3False;
    *valuesOfContinuousStatesChanged = fmi3False;
    *nextEventTimeDefined = fmi3False;
    *nextEventTime = 0.0;
    return fmi3OK;
}

/* ---- model exchange (no continuous states, no event indicators) ------------------------ */

fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance instance) {
    UNUSED(instance);
    return fmi3OK;
}

fmi3Status fmi3CompletedIntegratorStep(fmi3Instance instance,
                                       fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi3Boolean *enterEventMode,
                                       fmi3Boolean *terminateSimulation) {
    UNUSED(instance);
    UNUSED(noSetFMUStatePriorToCurrentPoint);
    *enterEventMode = fmi3False;
    *terminateSimulation = fmi3False;
    return fmi3OK;
}

fmi3Status fmi3SetTime(fmi3Instance instance, fmi3Float64 time) {
    Instance *inst = (Instance *)instance;
    inst->data.time = time;
    inst->data.dirty = 1;
    return fmi3OK;
}

fmi3Status fmi3SetContinuousStates(fmi3Instance instance, const fmi3Float64 continuousStates[],
                                   size_t nContinuousStates) {
    UNUSED(continuousStates);
    return nContinuousStates == 0 ? fmi3OK : fail(instance, "the model has no continuous states");
}

fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance instance, fmi3Float64 derivatives[],
                                             size_t nContinuousStates) {
    UNUSED(derivatives);
    return nContinuousStates == 0 ? fmi3OK : fail(instance, "the model has no continuous states");
}

fmi3Status fmi3GetEventIndicators(fmi3Instance instance, fmi3Float64 eventIndicators[],
                                  size_t nEventIndicators) {
    UNUSED(eventIndicators);
    return nEventIndicators == 0 ? fmi3OK : fail(instance, "the model has no event indicators");
}

fmi3Status fmi3GetContinuousStates(fmi3Instance instance, fmi3Float64 continuousStates[],
                                   size_t nContinuousStates) {
    UNUSED(continuousStates);
    return nContinuousStates == 0 ? fmi3OK : fail(instance, "the model has no continuous states");
}

fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance instance, fmi3Float64 nominals[],
                                             size_t nContinuousStates) {
    UNUSED(nominals);
    return nContinuousStates == 0 ? fmi3OK : fail(instance, "the model has no continuous states");
}

fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance instance, size_t *nEventIndicators) {
    UNUSED(instance);
    *nEventIndicators = 0;
    return fmi3OK;
}

fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance instance, size_t *nContinuousStates) {
    UNUSED(instance);
    *nContinuousStates = 0;
    return fmi3OK;
}

/* ---- co-simulation -------------------------------------------------------------------- */

fmi3Status fmi3EnterStepMode(fmi3Instance instance) {
    Instance *inst = (Instance *)instance;
    if (inst->model_exchange) return fail(instance, "fmi3EnterStepMode: model exchange");
    return fmi3OK;
}

fmi3Status fmi3GetOutputDerivatives(fmi3Instance instance,
                                    const fmi3ValueReference valueReferences[],
                                    size_t nValueReferences, const fmi3Int32 orders[],
                                    fmi3Float64 values[], size_t nValues) {
    UNUSED(valueReferences);
    UNUSED(orders);
    UNUSED(values);
    UNUSED(nValues);
    return nValueReferences == 0 ? fmi3OK
                                 : fail(instance, "output derivatives are not provided");
}

fmi3Status fmi3DoStep(fmi3Instance instance, fmi3Float64 currentCommunicationPoint,
                      fmi3Float64 communicationStepSize,
                      fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                      fmi3Boolean *eventHandlingNeeded, fmi3Boolean *terminateSimulation,
                      fmi3Boolean *earlyReturn, fmi3Float64 *lastSuccessfulTime) {
    Instance *inst = (Instance *)instance;
    UNUSED(noSetFMUStatePriorToCurrentPoint);
    if (inst->mode != MODE_RUNNING || inst->model_exchange) {
        return fail(instance, "fmi3DoStep: wrong mode");
    }
    if (communicationStepSize <= 0.0) return fail(instance, "fmi3DoStep: step size must be > 0");
    inst->data.time = currentCommunicationPoint;
    model_do_step(&inst->data, communicationStepSize);
    inst->data.time = currentCommunicationPoint + communicationStepSize;
    inst->data.dirty = 1;
    *eventHandlingNeeded = fmi3False;
    *terminateSimulation = fmi3False;
    *earlyReturn = fmi3False;
    *lastSuccessfulTime = inst->data.time;
    return fmi3OK;
}

/* ---- scheduled execution (not offered) ------------------------------------------------- */

fmi3Status fmi3ActivateModelPartition(fmi3Instance instance, fmi3ValueReference clockReference,
                                      fmi3Float64 activationTime) {
    UNUSED(clockReference);
    UNUSED(activationTime);
    return fail(instance, "scheduled execution is not offered");
}
