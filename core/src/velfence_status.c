/*
 * velfence_status.c -- vf_status_name (see include/velfence_status.h).
 */
#include "velfence_status.h"

const char *vf_status_name(int status)
{
    switch (status) {
    case VF_OK:
        return "VF_OK";
    case VF_ERR_NULL:
        return "VF_ERR_NULL";
    case VF_ERR_ARGUMENT:
        return "VF_ERR_ARGUMENT";
    case VF_ERR_NONFINITE:
        return "VF_ERR_NONFINITE";
    case VF_ERR_OVERFLOW:
        return "VF_ERR_OVERFLOW";
    case VF_ERR_SINGULAR:
        return "VF_ERR_SINGULAR";
    case VF_INFEASIBLE:
        return "VF_INFEASIBLE";
    case VF_STALLED:
        return "VF_STALLED";
    case VF_ITERATION_CAP:
        return "VF_ITERATION_CAP";
    case VF_DEADLINE:
        return "VF_DEADLINE";
    default:
        return "VF_UNKNOWN";
    }
}
