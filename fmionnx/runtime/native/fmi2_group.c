/*
 * One macro step of a group of FMI 2.0 co-simulation FMUs, in execution order.
 *
 * The in-process master (fmionnx/runtime/native/) calls fx_group_step once per
 * communication point instead of making three ctypes calls per FMU from Python. For each
 * member it does exactly what the Python path does (transfer.py, runners/fmu.py):
 *   1. every incoming connection, in the master's order: stop if any source value is NaN,
 *      else copy it, or compute factor * x, then + offset (two roundings, as numpy does);
 *   2. fmi2SetReal of the member's whole real input buffer (skipped when it has none);
 *   3. fmi2DoStep(t, h, fmi2True);
 *   4. fmi2GetReal of its whole real output buffer (skipped when it has none).
 * A status above fmi2Warning stops the step; the group records where, and Python builds the
 * same RunError the Python path raises. Compiled with -ffp-contract=off so that no compiler
 * fuses the multiply and add of a connection into one FMA (which would round differently).
 * The FMI functions come from the libraries fmpy already loaded, as plain pointers.
 *
 * Python mirrors the structs below in ctypes (kernel.py) and checks, before it uses the
 * library, that fx_abi_version() and fx_abi_layout() agree with its mirrors. Bump
 * FX_ABI_VERSION on any change of a struct, of fx_group_step's signature or of its return
 * codes, together with ABI_VERSION in kernel.py.
 */
#include <math.h>
#include <stddef.h>

#define FX_ABI_VERSION 1u

typedef int (*fx_set_real)(void *, const unsigned int *, size_t, const double *);
typedef int (*fx_get_real)(void *, const unsigned int *, size_t, double *);
typedef int (*fx_do_step)(void *, double, double, int);

typedef struct {
    const double *src;
    double *dst;
    size_t count;
    double factor;
    double offset;
    int identity;
} fx_transfer;

typedef struct {
    void *instance;
    fx_set_real set_real;
    fx_do_step do_step;
    fx_get_real get_real;
    const unsigned int *in_vrs;
    size_t n_in;
    const double *in_values;
    const unsigned int *out_vrs;
    size_t n_out;
    double *out_values;
    size_t first_transfer;
    size_t n_transfers;
} fx_member;

typedef struct {
    size_t n_members;
    const fx_member *members;
    const fx_transfer *transfers;
    /* Where the last step stopped (valid when fx_group_step returned non-zero). */
    size_t failed_member;
    size_t failed_transfer;
    int failed_status;
} fx_group;

enum { FX_OK = 0, FX_NAN = 1, FX_SET = 2, FX_DO_STEP = 3, FX_GET = 4 };

/* fmi2OK and fmi2Warning let the run go on, as in the Python path. */
#define FX_FAULT(status) ((status) > 1)

static int transfer_has_nan(const fx_transfer *tr) {
    for (size_t i = 0; i < tr->count; ++i) {
        if (isnan(tr->src[i])) {
            return 1;
        }
    }
    return 0;
}

static void transfer_copy(const fx_transfer *tr) {
    if (tr->identity) {
        for (size_t i = 0; i < tr->count; ++i) {
            tr->dst[i] = tr->src[i];
        }
        return;
    }
    for (size_t i = 0; i < tr->count; ++i) {
        double scaled = tr->factor * tr->src[i];
        tr->dst[i] = scaled + tr->offset;
    }
}

int fx_group_step(fx_group *group, double t, double h) {
    for (size_t m = 0; m < group->n_members; ++m) {
        const fx_member *member = &group->members[m];
        group->failed_member = m;
        for (size_t k = 0; k < member->n_transfers; ++k) {
            const fx_transfer *tr = &group->transfers[member->first_transfer + k];
            if (transfer_has_nan(tr)) {
                group->failed_transfer = k;
                return FX_NAN;
            }
            transfer_copy(tr);
        }
        int status;
        if (member->n_in > 0) {
            status = member->set_real(member->instance, member->in_vrs, member->n_in,
                                      member->in_values);
            if (FX_FAULT(status)) {
                group->failed_status = status;
                return FX_SET;
            }
        }
        status = member->do_step(member->instance, t, h, 1);
        if (FX_FAULT(status)) {
            group->failed_status = status;
            return FX_DO_STEP;
        }
        if (member->n_out > 0) {
            status = member->get_real(member->instance, member->out_vrs, member->n_out,
                                      member->out_values);
            if (FX_FAULT(status)) {
                group->failed_status = status;
                return FX_GET;
            }
        }
    }
    return FX_OK;
}

/* The struct layouts Python must mirror: for fx_group, fx_member and fx_transfer in turn,
 * sizeof the struct, then offsetof each field in declaration order. */
static const size_t fx_layout[] = {
    sizeof(fx_group),
    offsetof(fx_group, n_members),
    offsetof(fx_group, members),
    offsetof(fx_group, transfers),
    offsetof(fx_group, failed_member),
    offsetof(fx_group, failed_transfer),
    offsetof(fx_group, failed_status),
    sizeof(fx_member),
    offsetof(fx_member, instance),
    offsetof(fx_member, set_real),
    offsetof(fx_member, do_step),
    offsetof(fx_member, get_real),
    offsetof(fx_member, in_vrs),
    offsetof(fx_member, n_in),
    offsetof(fx_member, in_values),
    offsetof(fx_member, out_vrs),
    offsetof(fx_member, n_out),
    offsetof(fx_member, out_values),
    offsetof(fx_member, first_transfer),
    offsetof(fx_member, n_transfers),
    sizeof(fx_transfer),
    offsetof(fx_transfer, src),
    offsetof(fx_transfer, dst),
    offsetof(fx_transfer, count),
    offsetof(fx_transfer, factor),
    offsetof(fx_transfer, offset),
    offsetof(fx_transfer, identity),
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
