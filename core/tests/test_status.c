/*
 * test_status.c -- the one status enum (velfence_status.h) and constants header
 * (velfence_constants.h): every vf_status value, its name from vf_status_name (distinct, never
 * NULL, "VF_UNKNOWN" for any other int), the documented numbers (docs/core.md), and every deprecated per-header
 * alias equal to its shared name (velfence_core.h, velfence_nd.h, velfence_cc.h, velfence_rr.h).
 * Prints "ok <count>".
 */
#include "velfence_cc.h"
#include "velfence_constants.h"
#include "velfence_core.h"
#include "velfence_nd.h"
#include "velfence_rr.h"
#include "velfence_status.h"
#include "vf_test.h"

#include <string.h>

/* The constants stay preprocessor numbers (usable in #if). */
#if VF_ZONE_INVALID != 5 || VF_STAGE_SCALED != 512 || VF_STAGE_PERIOD != 256                      \
    || VF_PROFILE_PARAMS != 6 || VF_LEVEL_RATE != 3 || VF_VERSION_MAJOR != 0
#error "velfence_constants.h: a constant moved"
#endif

int main(void)
{
    static const struct {
        int code;
        const char *name;
    } table[] = {
        {VF_OK, "VF_OK"},
        {VF_ERR_NULL, "VF_ERR_NULL"},
        {VF_ERR_ARGUMENT, "VF_ERR_ARGUMENT"},
        {VF_ERR_NONFINITE, "VF_ERR_NONFINITE"},
        {VF_ERR_OVERFLOW, "VF_ERR_OVERFLOW"},
        {VF_ERR_SINGULAR, "VF_ERR_SINGULAR"},
        {VF_INFEASIBLE, "VF_INFEASIBLE"},
        {VF_STALLED, "VF_STALLED"},
        {VF_ITERATION_CAP, "VF_ITERATION_CAP"},
        {VF_DEADLINE, "VF_DEADLINE"},
    };
    const int n = (int)(sizeof table / sizeof table[0]);
    char version[32];
    int i, j, c;

    /* the numbers of the shared spec (errors negative, solve outcomes positive) */
    CHECK(VF_OK == 0 && VF_ERR_NULL == -1 && VF_ERR_ARGUMENT == -2 && VF_ERR_NONFINITE == -3
              && VF_ERR_OVERFLOW == -4 && VF_ERR_SINGULAR == -5,
          "error codes");
    CHECK(VF_INFEASIBLE == 1 && VF_STALLED == 2 && VF_ITERATION_CAP == 3 && VF_DEADLINE == 4,
          "solve outcomes");
    /* names: each value its own, all distinct; any other int "VF_UNKNOWN", never NULL */
    for (i = 0; i < n; i++) {
        const char *s = vf_status_name(table[i].code);
        CHECK(s != NULL && strcmp(s, table[i].name) == 0, "name of %d: %s", table[i].code,
              s ? s : "(null)");
        for (j = 0; j < i; j++) {
            CHECK(table[i].code != table[j].code, "%s and %s share a value", table[i].name,
                  table[j].name);
        }
    }
    for (c = -1000; c <= 1000; c++) {
        int known = 0;
        for (i = 0; i < n; i++) {
            known |= table[i].code == c;
        }
        if (!known) {
            const char *s = vf_status_name(c);
            CHECK(s != NULL && strcmp(s, "VF_UNKNOWN") == 0, "unknown %d", c);
        }
    }
    CHECK(strcmp(vf_status_name(-2147483647 - 1), "VF_UNKNOWN") == 0, "INT_MIN");
    CHECK(strcmp(vf_status_name(2147483647), "VF_UNKNOWN") == 0, "INT_MAX");
    /* the version string and its numbers agree */
    snprintf(version, sizeof version, "%d.%d.%d", VF_VERSION_MAJOR, VF_VERSION_MINOR,
             VF_VERSION_PATCH);
    CHECK(strcmp(version, VF_VERSION) == 0, "VF_VERSION %s vs %s", VF_VERSION, version);
    CHECK(strcmp(VF_CORE_VERSION, VF_VERSION) == 0 && strcmp(VF_ND_VERSION, VF_VERSION) == 0,
          "version aliases");

    /* deprecated aliases (removed in 0.3): the same values as the shared names */
    CHECK(VF_ND_OK == VF_OK && VF_ND_ERR_NULL == VF_ERR_NULL
              && VF_ND_ERR_ARGUMENT == VF_ERR_ARGUMENT && VF_ND_ERR_NONFINITE == VF_ERR_NONFINITE
              && VF_ND_ERR_OVERFLOW == VF_ERR_OVERFLOW,
          "n-D codes");
    CHECK(VF_ND_PROJECT_OPTIMAL == VF_OK && VF_ND_PROJECT_INFEASIBLE == VF_INFEASIBLE
              && VF_ND_PROJECT_ITERATION_LIMIT == VF_STALLED,
          "projection outcomes");
    CHECK(VF_CC_OK == VF_OK && VF_CC_ERR_NULL == VF_ERR_NULL
              && VF_CC_ERR_ARGUMENT == VF_ERR_ARGUMENT && VF_CC_ERR_NONFINITE == VF_ERR_NONFINITE
              && VF_CC_ERR_OVERFLOW == VF_ERR_OVERFLOW,
          "cc codes");
    CHECK(VF_RR_OK == VF_OK && VF_RR_ERR_NULL == VF_ERR_NULL
              && VF_RR_ERR_ARGUMENT == VF_ERR_ARGUMENT && VF_RR_ERR_NONFINITE == VF_ERR_NONFINITE
              && VF_RR_ERR_OVERFLOW == VF_ERR_OVERFLOW && VF_RR_ERR_SINGULAR == VF_ERR_SINGULAR
              && VF_RR_ERR_FACTOR == VF_ERR_SINGULAR,
          "rr codes");
    CHECK(VF_RR_ERR_SINGULAR == -5 && VF_RR_ERR_OVERFLOW == -4, "rr: the values that moved");
    CHECK(VF_ND_ZONE_FREE == VF_ZONE_FREE && VF_ND_ZONE_BUFFER == VF_ZONE_BUFFER
              && VF_ND_ZONE_CORNER == VF_ZONE_CORNER && VF_ND_ZONE_OUTSIDE == VF_ZONE_OUTSIDE
              && VF_ND_ZONE_OUTSIDE_CORNER == VF_ZONE_OUTSIDE_CORNER
              && VF_ND_ZONE_INVALID == VF_ZONE_INVALID,
          "zones");
    CHECK(VF_ND_STAGE_SPRING == VF_STAGE_SPRING && VF_ND_STAGE_PROJECT == VF_STAGE_PROJECT
              && VF_ND_STAGE_RELAXED == VF_STAGE_RELAXED && VF_ND_STAGE_STOP == VF_STAGE_STOP
              && VF_ND_STAGE_SCALED == VF_STAGE_SCALED,
          "stages");
    CHECK(VF_ND_PROFILE_LINEAR == VF_PROFILE_LINEAR
              && VF_ND_PROFILE_THREE_ZONE == VF_PROFILE_THREE_ZONE
              && VF_ND_PROFILE_PARAMS == VF_PROFILE_PARAMS,
          "profiles");
    CHECK(VF_ND_LEVEL_JOINT == VF_LEVEL_JOINT && VF_ND_LEVEL_WORKSPACE == VF_LEVEL_WORKSPACE
              && VF_ND_LEVEL_OBSTACLE == VF_LEVEL_OBSTACLE && VF_ND_LEVEL_RATE == VF_LEVEL_RATE,
          "levels");
    /* stage bits: distinct single bits */
    {
        static const int bits[] = {VF_STAGE_SECONDARY, VF_STAGE_PRIMARY, VF_STAGE_ZERO_OUTWARD,
                                   VF_STAGE_SPRING,    VF_STAGE_BLEND,   VF_STAGE_PROJECT,
                                   VF_STAGE_RELAXED,   VF_STAGE_STOP,    VF_STAGE_PERIOD,
                                   VF_STAGE_SCALED};
        int all = 0;
        for (i = 0; i < 10; i++) {
            CHECK(bits[i] == 1 << i, "stage bit %d is %d", i, bits[i]);
            CHECK((all & bits[i]) == 0, "stage bit %d repeated", i);
            all |= bits[i];
        }
    }
    return finish();
}
