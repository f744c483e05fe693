/*
 * velfence_status.h -- the one status code of every velfence C API (2-D laws, n-D projection and
 * law, configuration control, resolved rate, the safety filter), in plain C99.
 *
 * Every checked entry point returns an int holding one vf_status: VF_OK (0), a negative VF_ERR_*
 * code (the call was refused or its answer overflowed; every output is then the documented stop
 * result) or, for solves, a positive outcome (the output is still written, finite and safe where
 * the function's header says so). The older per-header names (VF_ND_ERR_*, VF_CC_ERR_*,
 * VF_RR_ERR_*, VF_ND_PROJECT_*) are deprecated aliases of these values, removed in 0.3.
 *
 * Python mirrors: velfence.geometry.projection.PROJECT_OPTIMAL (VF_OK), PROJECT_INFEASIBLE,
 * PROJECT_STALLED (VF_STALLED), PROJECT_ITERATION_CAP, PROJECT_DEADLINE.
 */
#ifndef VELFENCE_STATUS_H
#define VELFENCE_STATUS_H

#ifdef __cplusplus
extern "C" {
#endif

typedef enum vf_status {
    VF_OK = 0,              /* success: the answer is the function's exact result */
    VF_ERR_NULL = -1,       /* a required pointer is NULL */
    VF_ERR_ARGUMENT = -2,   /* bad sizes or data (checked once, outside the control loop) */
    VF_ERR_NONFINITE = -3,  /* a per-call input is NaN or +-inf */
    VF_ERR_OVERFLOW = -4,   /* finite input so large that the answer overflowed */
    VF_ERR_SINGULAR = -5,   /* a matrix the method must invert is (numerically) singular */
    VF_INFEASIBLE = 1,      /* the constraints contradict each other: no point meets them all */
    VF_STALLED = 2,         /* round-off stalled the method before it finished */
    VF_ITERATION_CAP = 3,   /* the caller's iteration cap was hit */
    VF_DEADLINE = 4         /* the caller's time budget was hit */
} vf_status;

/* The enumerator's name ("VF_OK", "VF_ERR_SINGULAR", ...) of a status, or "VF_UNKNOWN" for any
 * other value. Never NULL; a static string (reentrant, allocation-free). */
const char *vf_status_name(int status);

#ifdef __cplusplus
}
#endif

#endif /* VELFENCE_STATUS_H */
