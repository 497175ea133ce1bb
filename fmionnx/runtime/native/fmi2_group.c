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
 * fx_link_step and fx_serve are the two ends of an isolated FMU's step hand-over
 * (fmionnx/runtime/isolated/handover.py): the supervisor writes one byte and waits for one
 * byte back, the child reads it, steps its FMU as fx_group_step steps a group of one and
 * answers, both as the Python code of runtime/isolated does (proxy.py, server.py, channel.py),
 * without a Python instruction on the way. Anything else (another command, a fault, a closed
 * pipe, a signal) goes back to that Python code, which decides.
 *
 * Python mirrors the structs below in ctypes (kernel.py) and checks, before it uses the
 * library, that fx_abi_version() and fx_abi_layout() agree with its mirrors. Bump
 * FX_ABI_VERSION on any change of a struct, of fx_group_step's signature, of its return
 * codes or of the element type codes, together with ABI_VERSION in kernel.py.
 */
#define _POSIX_C_SOURCE 200809L /* clock_gettime, poll under -std=c99 */
#include <errno.h>
#include <math.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>
#include <time.h>
#ifndef _WIN32 /* the hand-over is POSIX (isolation is too); its functions refuse elsewhere */
#include <poll.h>
#include <sched.h>
#include <unistd.h>
#endif

#define FX_ABI_VERSION 4u

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

/* ---- an isolated FMU's step hand-over ------------------------------------------------------
 * The pipes and the control block of runtime/isolated/channel.py: a step is the byte 'S' from
 * the supervisor and the byte 'k' back; each side stores, after a whole message, how many it
 * has written so far in its counter of the shared block, and the other side may spin on that
 * counter before it blocks on its pipe (channel.Spinner, whose rules fx_spin follows). The
 * counter is only a hint a hostile model can forge: a wait always ends by reading the pipe. */

enum { FX_STEP_COMMAND = 'S', FX_OK_REPLY = 'k' };

/* channel.Spinner: spin for at most budget_ns; a miss makes the next 2**backoff - 1 waits skip
 * their spin (backoff at most max_backoff), a hit resets it. */
typedef struct {
    int64_t budget_ns;
    int polite; /* sched_yield at every turn */
    int max_backoff;
    int backoff;
    int skip;
    uint64_t spins; /* waits that spun */
    uint64_t hits;  /* and whose counter moved within the budget */
} fx_spin;

static int64_t nanoseconds(void) {
    struct timespec now;
    clock_gettime(CLOCK_MONOTONIC, &now);
    return (int64_t)now.tv_sec * 1000000000 + (int64_t)now.tv_nsec;
}

#ifndef _WIN32
static void spin_wait(fx_spin *spin, const uint32_t *counter, uint32_t seen) {
    if (spin->budget_ns <= 0) return;
    if (spin->skip > 0) {
        spin->skip -= 1;
        return;
    }
    spin->spins += 1;
    int64_t deadline = nanoseconds() + spin->budget_ns;
    while (__atomic_load_n(counter, __ATOMIC_ACQUIRE) == seen) {
        if (spin->polite) sched_yield();
        if (nanoseconds() >= deadline) {
            spin->backoff = spin->backoff < spin->max_backoff ? spin->backoff + 1 : spin->max_backoff;
            spin->skip = (1 << spin->backoff) - 1;
            return;
        }
    }
    spin->backoff = 0;
    spin->hits += 1;
}
#endif

/* Return codes of fx_link_step and fx_serve. */
enum {
    FX_LINK_REPLY = 0,       /* a reply's first byte was read: link->tag */
    FX_LINK_BROKEN = 1,      /* the command could not be written: the child is gone */
    FX_LINK_TIMEOUT = 2,     /* no reply within timeout_ms */
    FX_LINK_CLOSED = 3,      /* the reply pipe closed */
    FX_LINK_INTERRUPTED = 4, /* a signal came, or FX_LINK_SLICE_MS passed: Python goes on */
    FX_LINK_ERRNO = 5,       /* another error: link->error */
    FX_SERVE_COMMAND = 6,    /* a command that is not a step: server->op (consumed) */
    FX_SERVE_FAULT = 7       /* the step failed: server->code, the group says where */
};

/* The longest the supervisor waits here for a reply before Python waits on: a stop signal
 * that came just before the poll (which it then does not interrupt) is acted on soon. */
#define FX_LINK_SLICE_MS 20

#ifndef _WIN32
/* 0, or errno (EINTR too: the caller returns to Python, whose signal handler may stop). */
static int write_byte(int fd, unsigned char byte) {
    ssize_t n = write(fd, &byte, 1);
    if (n == 1) return 0;
    return n < 0 ? errno : EIO;
}
#endif

/* The supervisor's end (proxy.py IsolatedRunner.step): the step's times are in the control
 * block already. */
typedef struct {
    int commands;
    int replies;
    uint32_t *requests;      /* the control block's counter of commands (this side writes it) */
    const uint32_t *answers; /* the child's counter of replies */
    uint32_t sent;           /* commands written so far */
    uint32_t answered;       /* replies read so far */
    int timeout_ms;          /* -1: wait for ever */
    int tag;                 /* out: the reply's first byte */
    int error;               /* out: errno of FX_LINK_ERRNO */
    fx_spin spin;
} fx_link;

/* Writes a step command, spins (if asked) and waits for the reply's first byte, at most
 * FX_LINK_SLICE_MS: a longer step is waited for in Python (FX_LINK_INTERRUPTED). A command
 * interrupted before it was written is not written (link->sent unchanged). */
int fx_link_step(fx_link *link, int spin) {
#ifdef _WIN32
    (void)spin;
    link->error = ENOSYS;
    return FX_LINK_ERRNO;
#else
    int error = write_byte(link->commands, FX_STEP_COMMAND);
    if (error == EINTR) return FX_LINK_INTERRUPTED;
    if (error == EPIPE) return FX_LINK_BROKEN;
    if (error != 0) {
        link->error = error;
        return FX_LINK_ERRNO;
    }
    link->sent += 1;
    __atomic_store_n(link->requests, link->sent, __ATOMIC_RELEASE);
    if (spin) spin_wait(&link->spin, link->answers, link->answered);
    int sliced = link->timeout_ms < 0 || link->timeout_ms > FX_LINK_SLICE_MS;
    struct pollfd wanted = {link->replies, POLLIN | POLLHUP, 0};
    int ready = poll(&wanted, 1, sliced ? FX_LINK_SLICE_MS : link->timeout_ms);
    if (ready < 0) {
        if (errno == EINTR) return FX_LINK_INTERRUPTED;
        link->error = errno;
        return FX_LINK_ERRNO;
    }
    if (ready == 0) return sliced ? FX_LINK_INTERRUPTED : FX_LINK_TIMEOUT;
    unsigned char tag;
    for (;;) {
        ssize_t n = read(link->replies, &tag, 1);
        if (n == 1) break;
        if (n == 0) return FX_LINK_CLOSED;
        if (errno != EINTR) {
            link->error = errno;
            return FX_LINK_ERRNO;
        }
    }
    link->answered += 1;
    link->tag = tag;
    return FX_LINK_REPLY;
#endif
}

/* size bytes from src to dst: a port's slot in the shared block and the runner's buffer. */
typedef struct {
    void *dst;
    const void *src;
    size_t size;
} fx_copy;

/* The child's end (server.py Child.serve): steps of one FMU, the group's only member. */
typedef struct {
    int commands;
    int replies;
    const uint32_t *requests; /* the supervisor's counter of commands */
    uint32_t *answers;        /* the control block's counter of replies (this side writes it) */
    int32_t *phase;           /* the control block's phase */
    const double *times;      /* the control block's t and h */
    uint32_t consumed;        /* commands read so far */
    uint32_t written;         /* replies written so far */
    int first_phase;          /* the phase of setting inputs; doStep + 1, getting outputs + 2 */
    int op;                   /* out: the command that is not a step (FX_SERVE_COMMAND) */
    int code;                 /* out: fx_group_step's code (FX_SERVE_FAULT) */
    int error;                /* out: errno of FX_LINK_ERRNO */
    fx_group *group;
    const fx_copy *inputs;
    size_t n_inputs;
    const fx_copy *outputs;
    size_t n_outputs;
    fx_spin spin;
} fx_server;

#ifndef _WIN32
/* One step as server.py Child.step does it through the runner's three step phases. */
static int serve_step(fx_server *server) {
    double t = server->times[0], h = server->times[1];
    for (size_t k = 0; k < server->n_inputs; ++k) {
        memcpy(server->inputs[k].dst, server->inputs[k].src, server->inputs[k].size);
    }
    fx_group *group = server->group;
    const fx_member *member = &group->members[0];
    group->failed_member = 0;
    __atomic_store_n(server->phase, server->first_phase, __ATOMIC_RELAXED);
    if (call_all(group, member, member->first_set, member->n_set)) return FX_SET;
    __atomic_store_n(server->phase, server->first_phase + 1, __ATOMIC_RELAXED);
    int status = do_step(member, t, h);
    if (FX_FAULT(status)) {
        group->failed_status = status;
        return FX_DO_STEP;
    }
    if (member->fmi3 && *member->terminate_simulation) return FX_TERMINATE;
    __atomic_store_n(server->phase, server->first_phase + 2, __ATOMIC_RELAXED);
    if (call_all(group, member, member->first_get, member->n_get)) return FX_GET;
    for (size_t k = 0; k < server->n_outputs; ++k) {
        memcpy(server->outputs[k].dst, server->outputs[k].src, server->outputs[k].size);
    }
    return FX_OK;
}
#endif

/* Serves step commands until another command comes (FX_SERVE_COMMAND), a step fails
 * (FX_SERVE_FAULT: nothing was answered), the command pipe closes (FX_LINK_CLOSED) or a
 * signal interrupts a read (FX_LINK_INTERRUPTED). */
int fx_serve(fx_server *server) {
#ifdef _WIN32
    server->error = ENOSYS;
    return FX_LINK_ERRNO;
#else
    for (;;) {
        spin_wait(&server->spin, server->requests, server->consumed);
        unsigned char op;
        ssize_t n = read(server->commands, &op, 1);
        if (n == 0) return FX_LINK_CLOSED;
        if (n < 0) {
            if (errno == EINTR) return FX_LINK_INTERRUPTED;
            server->error = errno;
            return FX_LINK_ERRNO;
        }
        server->consumed += 1;
        if (op != FX_STEP_COMMAND) {
            server->op = op;
            return FX_SERVE_COMMAND;
        }
        int code = serve_step(server);
        if (code != FX_OK) {
            server->code = code;
            return FX_SERVE_FAULT;
        }
        int error;
        do {
            error = write_byte(server->replies, FX_OK_REPLY);
        } while (error == EINTR); /* the child's signals stop nothing: answer */
        if (error != 0) {
            if (error == EPIPE) return FX_LINK_CLOSED;
            server->error = error;
            return FX_LINK_ERRNO;
        }
        server->written += 1;
        __atomic_store_n(server->answers, server->written, __ATOMIC_RELEASE);
    }
#endif
}

/* The struct layouts Python must mirror: for fx_group, fx_member, fx_transfer, fx_call,
 * fx_track, fx_view, fx_run, fx_spin, fx_link, fx_copy and fx_server in turn, sizeof the struct, then offsetof each field in
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
    sizeof(fx_spin),
    offsetof(fx_spin, budget_ns),
    offsetof(fx_spin, polite),
    offsetof(fx_spin, max_backoff),
    offsetof(fx_spin, backoff),
    offsetof(fx_spin, skip),
    offsetof(fx_spin, spins),
    offsetof(fx_spin, hits),
    sizeof(fx_link),
    offsetof(fx_link, commands),
    offsetof(fx_link, replies),
    offsetof(fx_link, requests),
    offsetof(fx_link, answers),
    offsetof(fx_link, sent),
    offsetof(fx_link, answered),
    offsetof(fx_link, timeout_ms),
    offsetof(fx_link, tag),
    offsetof(fx_link, error),
    offsetof(fx_link, spin),
    sizeof(fx_copy),
    offsetof(fx_copy, dst),
    offsetof(fx_copy, src),
    offsetof(fx_copy, size),
    sizeof(fx_server),
    offsetof(fx_server, commands),
    offsetof(fx_server, replies),
    offsetof(fx_server, requests),
    offsetof(fx_server, answers),
    offsetof(fx_server, phase),
    offsetof(fx_server, times),
    offsetof(fx_server, consumed),
    offsetof(fx_server, written),
    offsetof(fx_server, first_phase),
    offsetof(fx_server, op),
    offsetof(fx_server, code),
    offsetof(fx_server, error),
    offsetof(fx_server, group),
    offsetof(fx_server, inputs),
    offsetof(fx_server, n_inputs),
    offsetof(fx_server, outputs),
    offsetof(fx_server, n_outputs),
    offsetof(fx_server, spin),
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
