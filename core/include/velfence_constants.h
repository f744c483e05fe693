/*
 * velfence_constants.h -- the constants shared by velfence's C APIs (velfence_core.h,
 * velfence_nd.h, velfence_cc.h, velfence_rr.h and the filter), defined once.
 *
 * Plain macros (usable in #if), each equal to its Python mirror named in the comments. The older
 * per-header names (VF_ND_ZONE_*, VF_ND_STAGE_*, VF_ND_PROFILE_*, VF_ND_LEVEL_*, VF_ND_VERSION,
 * VF_CORE_VERSION) are deprecated aliases of these, removed in 0.3.
 */
#ifndef VELFENCE_CONSTANTS_H
#define VELFENCE_CONSTANTS_H

/* The version of the C library (the velfence-core package, core/CMakeLists.txt). */
#define VF_VERSION "0.1.0"
#define VF_VERSION_MAJOR 0
#define VF_VERSION_MINOR 1
#define VF_VERSION_PATCH 0

/* Zones (ShapingResult.zone; velfence.shaping._kernels.ZONE_*). */
#define VF_ZONE_FREE 0           /* no edge or facet within the buffer */
#define VF_ZONE_BUFFER 1         /* inside, one edge within the buffer */
#define VF_ZONE_CORNER 2         /* inside, two or more within the buffer */
#define VF_ZONE_OUTSIDE 3        /* outside one edge (at most one nearby) */
#define VF_ZONE_OUTSIDE_CORNER 4 /* outside, two or more nearby */
#define VF_ZONE_INVALID 5        /* refused input: the stop result */

/* Stage bits (a bit mask; velfence.shaping._kernels.STAGE_*). */
#define VF_STAGE_SECONDARY 1    /* patent: secondary-edge projection applied */
#define VF_STAGE_PRIMARY 2      /* patent: primary-edge projection applied */
#define VF_STAGE_ZERO_OUTWARD 4 /* outward normal component removed (outside) */
#define VF_STAGE_SPRING 8       /* virtual spring / recovery bound applied */
#define VF_STAGE_BLEND 16       /* patent: spring blended between two normals near a corner */
#define VF_STAGE_PROJECT 32     /* exact: minimum-change projection onto the active bounds */
#define VF_STAGE_RELAXED 64     /* exact: bounds infeasible together, some relaxed */
#define VF_STAGE_STOP 128       /* invalid input answered with zero velocity */
#define VF_STAGE_PERIOD 256     /* discrete time: output scaled so one period reaches no edge */
#define VF_STAGE_SCALED 512     /* n-D exact: command shortened (direction kept) for the solve */

/* Approach-profile kinds of the exact law (velfence.shaping._kernels.PROFILE_*). */
#define VF_PROFILE_LINEAR 0     /* prm = (d_max, k, r_max, 0, 0, 0) */
#define VF_PROFILE_THREE_ZONE 1 /* prm = (K, max_speed, max_acceleration, d_int, d_f, d_phi) */
#define VF_PROFILE_PARAMS 6     /* doubles of a profile's parameters */

/* Row levels of the safety filter, in the ladder's order (velfence's filter LEVEL_*). */
#define VF_LEVEL_JOINT 0     /* joint position (braking profile) and velocity rows */
#define VF_LEVEL_WORKSPACE 1 /* a point of the chain kept in a polytope */
#define VF_LEVEL_OBSTACLE 2  /* sphere obstacles against link capsules */
#define VF_LEVEL_RATE 3      /* joint acceleration rows */

#endif /* VELFENCE_CONSTANTS_H */
