/*
 * One macro step of a group of FMI 2.0 and FMI 3.0 co-simulation FMUs, in execution order.
 * (The file keeps the name of its first version, which stepped FMI 2 only.)
 *
 * The in-process master (fmionnx/runtime/native/) calls fx_group_step once per
 * communication point instead of making several ctypes calls per FMU from Python. For each
 * member it does exactly what the Python path does (transfer.py, kinds/fmu/runner.py):
 *   1. every incoming connection, in the master's order: stop if any source value is NaN or
 *      infinite, else convert it as numpy's unsafe cast does, or compute factor * x, then + offset
 *      (two roundings, as numpy does: in float32 for a float32 source, whose multiply numpy
 *      does in float32, else in float64), then convert;
 *   2. the member's set calls, one per value type (fmi2SetReal/Integer/Boolean, or
 *      fmi3SetFloat64/Float32/Int8.../Boolean with the number of values), in the runner's order;
 *   3. fmi2DoStep(t, h, fmi2True), or fmi3DoStep(t, h, true, &eventHandlingNeeded,
 *      &terminateSimulation, &earlyReturn, &lastSuccessfulTime) into the runner's own flags;
 *   4. the member's get calls, in the runner's order.
 * A status above Warning stops the step; the group records where, and Python builds the
 * same RunError the Python path raises. An FMI 3 member whose fmi3DoStep sets
 * terminateSimulation stops the step too (FX_TERMINATE): Python then gets its outputs and ends
 * the run as the Python path does. Compiled with -ffp-contract=off so that no compiler fuses
 * the multiply and add of a connection into one FMA (which would round differently).
 * The FMI functions come from the libraries fmpy already loaded, as plain pointers.
 *
 * A float source never feeds an integer destination here (grouping.py keeps such members in
 * Python: numpy's result for a float outside the integer's range depends on the platform).
 *
 * fx_group_run runs many communication points in one call when one group is the whole
 * schedule (a lone FMU, a chain of FMUs of one rate): after each successful group step it
 * appends the recorder's rows itself (recorder.py Track.sample: row, then the published
 * count) and stores the step's time where the run's marker keeps it, so the Python loop is
 * entered only between chunks (progress, checkpoints, stop requests, a track to grow).
 *
 * Python mirrors the structs below in ctypes (kernel.py) and checks, before it uses the
 * library, that fx_abi_version() and fx_abi_layout() agree with its mirrors. Bump
 * FX_ABI_VERSION on any change of a struct, of fx_group_step's signature, of its return
 * codes or of the element type codes, together with ABI_VERSION in kernel.py.
 */
#define _POSIX_C_SOURCE 199309L /* clock_gettime under -std=c99 */
#include <math.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <time.h>

#define FX_ABI_VERSION 3u

/* Element types of value buffers (kernel.py ELEMENT_TYPES, in this order). */
enum {
    FX_F64, FX_F32, FX_I8, FX_U8, FX_I16, FX_U16, FX_I32, FX_U32, FX_I64, FX_U64, FX_BOOL
};

/* Any function; cast back to its real type before it is called. */
typedef void (*fx_function)(void);

typedef int (*fx_fmi2_do_step)(void *, double, double, int);
typedef int (*fx_fmi3_do_step)(void *, double, double, bool, bool *, bool *, bool *, double *);

/* One get or set call: one value type of one member, as the Python runner prepared it. */
typedef struct {
    fx_function function;
    const unsigned int *vrs;
    size_t n_vrs;
    void *values;
    size_t n_values; /* FMI 3 only: the number of values (arrays have one vr for many) */
    int type;        /* FX_* of values */
    int setter;
} fx_call;

typedef struct {
    const void *src;
    void *dst;
    size_t count;
    double factor;
    double offset;
    int identity;
    int src_type;
    int dst_type;
} fx_transfer;

typedef struct {
    void *instance;
    fx_function do_step;
    int fmi3;
    /* fmi3DoStep's output arguments: the runner's own flags (FMI 3 only). */
    bool *event_handling_needed;
    bool *terminate_simulation;
    bool *early_return;
    double *last_successful_time;
    size_t first_set;
    size_t n_set;
    size_t first_get;
    size_t n_get;
    size_t first_transfer;
    size_t n_transfers;
} fx_member;

typedef struct {
    size_t n_members;
    const fx_member *members;
    const fx_transfer *transfers;
    const fx_call *calls;
    /* Where the last step stopped (valid when fx_group_step returned non-zero). */
    size_t failed_member;
    size_t failed_transfer;
    size_t failed_call;
    int failed_status;
} fx_group;

/* One recorded track (recorder.py Track): `capacity` rows of `width` float64 columns, of which
 * `count` are written; its views are views[first_view .. first_view + n_views). */
typedef struct {
    double *rows;
    int64_t *published; /* NULL, or where the count is published after each row (guardian) */
    size_t capacity;
    size_t count;
    size_t width;
    size_t first_view;
    size_t n_views;
} fx_track;

/* One recorded buffer: `count` elements of type `type` into columns column.. of a row. */
typedef struct {
    const void *src;
    size_t count;
    size_t column;
    int type;
} fx_view;

/* A run of communication points of one group (fx_group_run). */
typedef struct {
    double start;
    double step;
    double h;
    size_t n_tracks;
    fx_track *tracks;
    const fx_view *views;
    double *marker_t; /* NULL, or where the time of the step under way is stored before it */
    double budget;    /* seconds of wall time after which a call returns between two steps */
    size_t next;      /* out: the first step not completed (the failed one after a fault) */
} fx_run;

enum {
    FX_OK = 0, FX_NONFINITE = 1, FX_SET = 2, FX_DO_STEP = 3, FX_GET = 4, FX_TERMINATE = 5,
    FX_FULL = 6 /* fx_group_run: a track has no room for the next row */
};

/* OK and Warning let the run go on, as in the Python path (FMI 2 and 3 number them alike). */
#define FX_FAULT(status) ((status) > 1)

/* ---- connections ------------------------------------------------------------------------- */

/* NaN or +-inf in a float source: the Python path's `not isfinite(value)`. */
static int transfer_has_nonfinite(const fx_transfer *tr) {
    if (tr->src_type == FX_F64) {
        const double *src = tr->src;
        for (size_t i = 0; i < tr->count; ++i) {
            if (!isfinite(src[i])) return 1;
        }
    } else if (tr->src_type == FX_F32) {
        const float *src = tr->src;
        for (size_t i = 0; i < tr->count; ++i) {
            if (!isfinite(src[i])) return 1;
        }
    }
    return 0;
}

/* Writes element i of dst from a value held exactly in V (double, int64_t or uint64_t): a C
 * conversion straight to the destination type, as numpy's cast loops do. An integer source
 * is widened first, which changes no value, so every conversion still rounds once. */
#define FX_STORE(dst, type, i, v)                                       \
    switch (type) {                                                     \
    case FX_F64: ((double *)(dst))[i] = (double)(v); break;             \
    case FX_F32: ((float *)(dst))[i] = (float)(v); break;               \
    case FX_I8: ((int8_t *)(dst))[i] = (int8_t)(v); break;              \
    case FX_U8: ((uint8_t *)(dst))[i] = (uint8_t)(v); break;            \
    case FX_I16: ((int16_t *)(dst))[i] = (int16_t)(v); break;           \
    case FX_U16: ((uint16_t *)(dst))[i] = (uint16_t)(v); break;         \
    case FX_I32: ((int32_t *)(dst))[i] = (int32_t)(v); break;           \
    case FX_U32: ((uint32_t *)(dst))[i] = (uint32_t)(v); break;         \
    case FX_I64: ((int64_t *)(dst))[i] = (int64_t)(v); break;           \
    case FX_U64: ((uint64_t *)(dst))[i] = (uint64_t)(v); break;         \
    case FX_BOOL: ((bool *)(dst))[i] = (v) != 0; break;                 \
    default: break;                                                     \
    }

static void store_double(void *dst, int type, size_t i, double v) { FX_STORE(dst, type, i, v) }
static void store_signed(void *dst, int type, size_t i, int64_t v) { FX_STORE(dst, type, i, v) }
static void store_unsigned(void *dst, int type, size_t i, uint64_t v) { FX_STORE(dst, type, i, v) }

/* Reads element i of src into *d (floats), *s (signed integers, bool) or *u (unsigned);
 * returns which: 0, 1 or 2. */
static int load(const void *src, int type, size_t i, double *d, int64_t *s, uint64_t *u) {
    switch (type) {
    case FX_F64: *d = ((const double *)src)[i]; return 0;
    case FX_F32: *d = ((const float *)src)[i]; return 0;
    case FX_I8: *s = ((const int8_t *)src)[i]; return 1;
    case FX_I16: *s = ((const int16_t *)src)[i]; return 1;
    case FX_I32: *s = ((const int32_t *)src)[i]; return 1;
    case FX_I64: *s = ((const int64_t *)src)[i]; return 1;
    case FX_BOOL: *s = ((const bool *)src)[i] ? 1 : 0; return 1;
    case FX_U8: *u = ((const uint8_t *)src)[i]; return 2;
    case FX_U16: *u = ((const uint16_t *)src)[i]; return 2;
    case FX_U32: *u = ((const uint32_t *)src)[i]; return 2;
    default: *u = ((const uint64_t *)src)[i]; return 2;
    }
}

/* factor * x + offset in float64 as numpy computes it: x converted to float64, except that a
 * float32 source is multiplied in float32 (numpy's loop for float32 times a Python float). */
static double scaled(const fx_transfer *tr, size_t i) {
    double x;
    int64_t s;
    uint64_t u;
    if (tr->src_type == FX_F32) {
        float product = (float)tr->factor * ((const float *)tr->src)[i];
        x = (double)product;
    } else {
        int kind = load(tr->src, tr->src_type, i, &x, &s, &u);
        if (kind == 1) x = (double)s;
        if (kind == 2) x = (double)u;
        x = tr->factor * x;
    }
    return x + tr->offset;
}

static void transfer_copy(const fx_transfer *tr) {
    if (tr->src_type == FX_F64 && tr->dst_type == FX_F64) { /* the common case */
        const double *src = tr->src;
        double *dst = tr->dst;
        if (tr->identity) {
            for (size_t i = 0; i < tr->count; ++i) dst[i] = src[i];
        } else {
            for (size_t i = 0; i < tr->count; ++i) {
                double product = tr->factor * src[i];
                dst[i] = product + tr->offset;
            }
        }
        return;
    }
    for (size_t i = 0; i < tr->count; ++i) {
        if (!tr->identity) {
            store_double(tr->dst, tr->dst_type, i, scaled(tr, i));
            continue;
        }
        double d;
        int64_t s;
        uint64_t u;
        switch (load(tr->src, tr->src_type, i, &d, &s, &u)) {
        case 0: store_double(tr->dst, tr->dst_type, i, d); break;
        case 1: store_signed(tr->dst, tr->dst_type, i, s); break;
        default: store_unsigned(tr->dst, tr->dst_type, i, u); break;
        }
    }
}

/* ---- FMI calls --------------------------------------------------------------------------- */

/* One get/set call through the function's real type: FMI 2 (instance, vr[], nvr, values[])
 * or FMI 3 (..., values[], nValues); setters take const values. */
#define FX_VALUES_CALL(T)                                                                      \
    if (fmi3) {                                                                                \
        if (c->setter)                                                                         \
            return ((int (*)(void *, const unsigned int *, size_t, const T *, size_t))        \
                        c->function)(instance, c->vrs, c->n_vrs, (const T *)c->values,         \
                                     c->n_values);                                             \
        return ((int (*)(void *, const unsigned int *, size_t, T *, size_t))c->function)(     \
            instance, c->vrs, c->n_vrs, (T *)c->values, c->n_values);                          \
    }                                                                                          \
    if (c->setter)                                                                             \
        return ((int (*)(void *, const unsigned int *, size_t, const T *))c->function)(       \
            instance, c->vrs, c->n_vrs, (const T *)c->values);                                 \
    return ((int (*)(void *, const unsigned int *, size_t, T *))c->function)(                 \
        instance, c->vrs, c->n_vrs, (T *)c->values);

static int call_other_values(const fx_call *c, void *instance, int fmi3) {
    switch (c->type) {
    case FX_F32: FX_VALUES_CALL(float)
    case FX_I8: FX_VALUES_CALL(int8_t)
    case FX_U8: FX_VALUES_CALL(uint8_t)
    case FX_I16: FX_VALUES_CALL(int16_t)
    case FX_U16: FX_VALUES_CALL(uint16_t)
    case FX_I32: FX_VALUES_CALL(int32_t)
    case FX_U32: FX_VALUES_CALL(uint32_t)
    case FX_I64: FX_VALUES_CALL(int64_t)
    case FX_U64: FX_VALUES_CALL(uint64_t)
    case FX_BOOL: FX_VALUES_CALL(bool)
    default: return 4; /* never prepared by grouping.py: treated as Fatal */
    }
}

/* float64, the common case, is called right here (small enough to be inlined into the step
 * loop, which keeps a group of real-valued FMUs as fast as a kernel for reals only); the
 * other types go through call_other_values. */
static inline int call_values(const fx_call *c, void *instance, int fmi3) {
    if (c->type == FX_F64) {
        FX_VALUES_CALL(double)
    }
    return call_other_values(c, instance, fmi3);
}

static int do_step(const fx_member *member, double t, double h) {
    if (member->fmi3) {
        return ((fx_fmi3_do_step)member->do_step)(
            member->instance, t, h, true, member->event_handling_needed,
            member->terminate_simulation, member->early_return, member->last_successful_time);
    }
    return ((fx_fmi2_do_step)member->do_step)(member->instance, t, h, 1);
}

/* Runs calls [first, first + n) of the group; on a fault records which and returns it. */
static inline int call_all(fx_group *group, const fx_member *member, size_t first, size_t n) {
    for (size_t k = 0; k < n; ++k) {
        int status = call_values(&group->calls[first + k], member->instance, member->fmi3);
        if (FX_FAULT(status)) {
            group->failed_call = k;
            group->failed_status = status;
            return 1;
        }
    }
    return 0;
}

int fx_group_step(fx_group *group, double t, double h) {
    for (size_t m = 0; m < group->n_members; ++m) {
        const fx_member *member = &group->members[m];
        group->failed_member = m;
        for (size_t k = 0; k < member->n_transfers; ++k) {
            const fx_transfer *tr = &group->transfers[member->first_transfer + k];
            if (transfer_has_nonfinite(tr)) {
                group->failed_transfer = k;
                return FX_NONFINITE;
            }
            transfer_copy(tr);
        }
        if (call_all(group, member, member->first_set, member->n_set)) return FX_SET;
        int status = do_step(member, t, h);
        if (FX_FAULT(status)) {
            group->failed_status = status;
            return FX_DO_STEP;
        }
        if (member->fmi3 && *member->terminate_simulation) return FX_TERMINATE;
        if (call_all(group, member, member->first_get, member->n_get)) return FX_GET;
    }
    return FX_OK;
}

/* ---- many steps -------------------------------------------------------------------------- */

static double seconds(void) {
    struct timespec now;
    clock_gettime(CLOCK_MONOTONIC, &now);
    return (double)now.tv_sec + 1e-9 * (double)now.tv_nsec;
}

/* Appends one row to the track (Track.sample): each view converted to float64 as numpy's
 * assignment does, then the count, published after the row (a reader in another process reads
 * only rows below the count it sees). */
static void sample(fx_track *track, const fx_view *views) {
    double *row = track->rows + track->count * track->width;
    for (size_t v = 0; v < track->n_views; ++v) {
        const fx_view *view = &views[track->first_view + v];
        double *out = row + view->column;
        for (size_t i = 0; i < view->count; ++i) {
            double d;
            int64_t s;
            uint64_t u;
            switch (load(view->src, view->type, i, &d, &s, &u)) {
            case 0: out[i] = d; break;
            case 1: out[i] = (double)s; break;
            default: out[i] = (double)u; break;
            }
        }
    }
    track->count += 1;
    if (track->published != NULL) {
        __atomic_store_n(track->published, (int64_t)track->count, __ATOMIC_RELEASE);
    }
}

/* Steps first .. last - 1, each at t = start + n * step (computed as Python computes it) by
 * h, sampling every track after each completed step. Returns FX_OK with run->next == last
 * when all are done, FX_OK with run->next < last when the budget of wall time ran out,
 * FX_FULL when a track has no room for the row of step run->next (not performed), or a
 * fault code of fx_group_step for step run->next (the group says where). */
int fx_group_run(fx_group *group, fx_run *run, size_t first, size_t last) {
    double deadline = seconds() + run->budget;
    for (size_t n = first; n < last; ++n) {
        run->next = n;
        for (size_t k = 0; k < run->n_tracks; ++k) {
            if (run->tracks[k].count >= run->tracks[k].capacity) return FX_FULL;
        }
        if (n > first && seconds() >= deadline) return FX_OK;
        double t = run->start + (double)n * run->step;
        if (run->marker_t != NULL) *run->marker_t = t;
        int code = fx_group_step(group, t, run->h);
        if (code != FX_OK) return code;
        for (size_t k = 0; k < run->n_tracks; ++k) sample(&run->tracks[k], run->views);
    }
    run->next = last;
    return FX_OK;
}

/* The struct layouts Python must mirror: for fx_group, fx_member, fx_transfer, fx_call,
 * fx_track, fx_view and fx_run in turn, sizeof the struct, then offsetof each field in
 * declaration order. */
static const size_t fx_layout[] = {
    sizeof(fx_group),
    offsetof(fx_group, n_members),
    offsetof(fx_group, members),
    offsetof(fx_group, transfers),
    offsetof(fx_group, calls),
    offsetof(fx_group, failed_member),
    offsetof(fx_group, failed_transfer),
    offsetof(fx_group, failed_call),
    offsetof(fx_group, failed_status),
    sizeof(fx_member),
    offsetof(fx_member, instance),
    offsetof(fx_member, do_step),
    offsetof(fx_member, fmi3),
    offsetof(fx_member, event_handling_needed),
    offsetof(fx_member, terminate_simulation),
    offsetof(fx_member, early_return),
    offsetof(fx_member, last_successful_time),
    offsetof(fx_member, first_set),
    offsetof(fx_member, n_set),
    offsetof(fx_member, first_get),
    offsetof(fx_member, n_get),
    offsetof(fx_member, first_transfer),
    offsetof(fx_member, n_transfers),
    sizeof(fx_transfer),
    offsetof(fx_transfer, src),
    offsetof(fx_transfer, dst),
    offsetof(fx_transfer, count),
    offsetof(fx_transfer, factor),
    offsetof(fx_transfer, offset),
    offsetof(fx_transfer, identity),
    offsetof(fx_transfer, src_type),
    offsetof(fx_transfer, dst_type),
    sizeof(fx_call),
    offsetof(fx_call, function),
    offsetof(fx_call, vrs),
    offsetof(fx_call, n_vrs),
    offsetof(fx_call, values),
    offsetof(fx_call, n_values),
    offsetof(fx_call, type),
    offsetof(fx_call, setter),
    sizeof(fx_track),
    offsetof(fx_track, rows),
    offsetof(fx_track, published),
    offsetof(fx_track, capacity),
    offsetof(fx_track, count),
    offsetof(fx_track, width),
    offsetof(fx_track, first_view),
    offsetof(fx_track, n_views),
    sizeof(fx_view),
    offsetof(fx_view, src),
    offsetof(fx_view, count),
    offsetof(fx_view, column),
    offsetof(fx_view, type),
    sizeof(fx_run),
    offsetof(fx_run, start),
    offsetof(fx_run, step),
    offsetof(fx_run, h),
    offsetof(fx_run, n_tracks),
    offsetof(fx_run, tracks),
    offsetof(fx_run, views),
    offsetof(fx_run, marker_t),
    offsetof(fx_run, budget),
    offsetof(fx_run, next),
    /* the element types' sizes, in FX_* order: a platform whose C types differ from the
     * ctypes ones Python uses for the buffers is refused */
    sizeof(double), sizeof(float), sizeof(int8_t), sizeof(uint8_t), sizeof(int16_t),
    sizeof(uint16_t), sizeof(int32_t), sizeof(uint32_t), sizeof(int64_t), sizeof(uint64_t),
    sizeof(bool),
};

unsigned int fx_abi_version(void) { return FX_ABI_VERSION; }

/* Copies at most capacity entries of fx_layout into out; returns how many it has. */
size_t fx_abi_layout(size_t *out, size_t capacity) {
    size_t n = sizeof(fx_layout) / sizeof(fx_layout[0]);
    for (size_t i = 0; i < n && i < capacity; ++i) {
        out[i] = fx_layout[i];
    }
    return n;
}
