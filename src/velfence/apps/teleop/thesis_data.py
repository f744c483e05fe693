"""Numeric tables of Khokar 2009, transcribed as typed, read-only constants.

Source: K. Khokar, *Laser Assisted Telerobotic Control for Remote Manipulation Activities*,
MSME thesis, University of South Florida, 2009. Every value below was transcribed from the
thesis's text and cross-checked against its own figures and tables; the table and section numbers
are the thesis's own. Where the extracted text was garbled, the repair is stated in a comment next
to the value (``docs/telerobotics.md`` lists the thesis's inconsistencies). Joint angles are in
the implemented kinematic convention (standard DH of Fu, Gonzalez & Lee; see
:class:`velfence.mechanisms.puma560.Puma560`).

Arrays are read-only (``setflags(write=False)``); lengths follow each constant's docstring
(the thesis mixes centimetres, metres and volts, so units are part of every name).
"""

from __future__ import annotations

import numpy as np

from velfence._typing import FloatArray
from velfence._validate import readonly

__all__ = [
    "EQ1_OFFSET_CM",
    "EQ1_SLOPE_CM_PER_V",
    "LASER_OFFSET_M",
    "REPEATABILITY_STATED_MM",
    "SINGULARITY_TRAJ1_Q0_RAD",
    "SINGULARITY_TRAJ1_TARGET_M",
    "SINGULARITY_TRAJ2_Q0_RAD",
    "SINGULARITY_TRAJ2_TARGET_M",
    "TABLE1_DISTANCE_CM",
    "TABLE1_VOLTAGE_V",
    "TABLE3_JOINT_ERROR_MRAD",
    "TABLE3_POSITION_ERROR_MM",
    "TABLE4_SET_A_M",
    "TABLE5_SET_B_M",
    "TABLE6_SET_A_DISTANCES_M",
    "TABLE7_SET_B_DISTANCES_M",
    "TABLE9_ACCURACY_NEW_CM",
    "TABLE9_ACCURACY_OLD_CM",
    "TABLE9_DISTANCE_CM",
    "TABLE9_REPRODUCIBILITY_NEW_CM",
    "TABLE9_REPRODUCIBILITY_OLD_CM",
    "TRAJECTORY_FINAL_Q_RAD",
    "TRAJECTORY_INITIAL_Q_RAD",
    "TRAJECTORY_SET_OF_FINAL",
]


def _ro(rows: object) -> FloatArray:
    a: FloatArray = np.array(rows, dtype=float)
    return readonly(a)


# ---------------------------------------------------------------------------------------------
# Table 1 (§3.3.1.1, thesis p. 47): reference distance (DME2000) vs DT60 output voltage, the
# voltage being the mean of the values that occurred > 100 times in 1000 readings. 21 pairs,
# transcribed verbatim (no OCR repair needed; consistent with the thesis §2.1).
# ---------------------------------------------------------------------------------------------
TABLE1_DISTANCE_CM: FloatArray = _ro(
    [
        *(21.3, 24.3, 25.6, 30.8, 35.7, 40.7, 45.8, 50.5, 55.8, 60.2, 66.0),
        *(71.0, 75.7, 80.9, 85.3, 90.7, 95.8, 100.7, 105.2, 110.6, 115.9),
    ]
)
"""Table 1 reference distances [cm], shape (21,) (DME2000 direct read-out)."""

TABLE1_VOLTAGE_V: FloatArray = _ro(
    [
        *(1.004884, 1.0262515, 1.03663, 1.07326, 1.1129425, 1.152625, 1.194139),
        *(1.229548, 1.271062, 1.30525, 1.351648, 1.3937725, 1.431013, 1.473138),
        *(1.508547, 1.5537245, 1.590965, 1.630037, 1.665446, 1.708181, 1.749695),
    ]
)
"""Table 1 DT60 output voltages [V], shape (21,), paired with :data:`TABLE1_DISTANCE_CM`."""

# Eq. (1), §3.3.1.2: least-squares line of distance on voltage (Matlab ``regress``).
EQ1_SLOPE_CM_PER_V: float = 126.1774
"""Eq. (1) slope [cm/V]: ``distance_cm = 126.1774 * voltage - 104.8980``."""
EQ1_OFFSET_CM: float = -104.8980
"""Eq. (1) intercept [cm]."""

# ---------------------------------------------------------------------------------------------
# Table 9 (§7.3, thesis p. 188): old vs new laser scheme, ~1000 readings at each of 8 distances.
# Accuracy is printed as "min and max" error, e.g. "-1.6 and +1.0"; "0" is read as 0.0. No OCR
# repair needed. Note: §3.3.1.3 quotes the *unfiltered* new-calibration spread (4.2 cm) as the
# "before" reproducibility, Table 9 the old scheme's 2.6 cm (an inconsistency of the thesis, see
# docs/telerobotics.md).
# ---------------------------------------------------------------------------------------------
TABLE9_DISTANCE_CM: FloatArray = _ro([24.7, 29.7, 38.2, 47.4, 57.3, 63.5, 70.8, 77.7])
"""Table 9 true target distances [cm], shape (8,)."""

TABLE9_ACCURACY_OLD_CM: FloatArray = _ro(
    [
        [-1.6, 1.0],
        [-2.3, 0.1],
        [-1.8, 0.4],
        [-2.1, 0.3],
        [-2.7, 0.0],
        [-3.2, 0.0],
        [-3.0, 0.0],
        [-2.9, 0.0],
    ]
)
"""Table 9 accuracy of the old scheme: (min, max) measurement error [cm], shape (8, 2)."""

TABLE9_ACCURACY_NEW_CM: FloatArray = _ro(
    [
        [-0.3, 0.2],
        [-0.2, 0.2],
        [-0.4, 0.0],
        [-0.5, 0.0],
        [-0.6, 0.0],
        [-0.6, 0.0],
        [-0.3, 0.0],
        [-0.3, 0.1],
    ]
)
"""Table 9 accuracy of the new scheme (eq. 1 + 50-sample moving average): (min, max) error
[cm], shape (8, 2)."""

TABLE9_REPRODUCIBILITY_OLD_CM: FloatArray = _ro([2.6, 2.4, 2.2, 2.4, 2.3, 2.3, 2.4, 2.6])
"""Table 9 reproducibility (max - min spread of the readings) of the old scheme [cm], (8,)."""

TABLE9_REPRODUCIBILITY_NEW_CM: FloatArray = _ro([0.5, 0.4, 0.3, 0.5, 0.4, 0.4, 0.3, 0.4])
"""Table 9 reproducibility (max - min spread of the readings) of the new scheme [cm], (8,)."""

# ---------------------------------------------------------------------------------------------
# Laser mounting, eq. (40) item 2 (§6.2.1): frame {L} parallel to frame {6}, offset [m].
# ---------------------------------------------------------------------------------------------
LASER_OFFSET_M: FloatArray = _ro([-0.026, -0.115, 0.115])
"""Laser origin in tool frame {6} of the implemented (FGL) convention [m], shape (3,)."""

# ---------------------------------------------------------------------------------------------
# §7.1 accuracy trajectories (thesis p. ~170): recorded initial and final joint angles [rad],
# theta1..theta6, implemented FGL convention. Trajectories 1-2 share one destination (the set A
# destination of Table 4), 3-5 another (set B, Table 5) — checked against their FK end points.
# ---------------------------------------------------------------------------------------------
TRAJECTORY_INITIAL_Q_RAD: FloatArray = _ro(
    [
        [-1.05628, -2.1085, 0.05893, 0.17227, -0.74605, 0.01345],
        [-1.09191, -2.35503, 0.29164, -0.4043, -0.78129, 0.01054],
        [-1.72401, -2.14383, 0.12948, -0.33586, -0.64322, 0.00296],
        [-0.81073, -2.21201, -0.01081, 0.5445, -0.77945, 0.01955],
        [-1.51358, -2.70128, 0.53898, 0.27469, -0.78304, 0.01727],
    ]
)
"""§7.1 initial joint angles of trajectories 1-5 [rad], shape (5, 6)."""

TRAJECTORY_FINAL_Q_RAD: FloatArray = _ro(
    [
        [-1.68307, -3.10591, 0.79649, -0.51276, -0.58633, 0.09572],
        [-1.68307, -3.10591, 0.79649, -0.51276, -0.58633, 0.09572],
        [-1.18062, -3.11768, 0.56893, 0.99229, -0.48414, -0.42776],
        [-1.18062, -3.11768, 0.56893, 0.99229, -0.48414, -0.42776],
        [-1.18062, -3.11768, 0.56893, 0.99229, -0.48414, -0.42776],
    ]
)
"""§7.1 final joint angles of trajectories 1-5 [rad], shape (5, 6)."""

TRAJECTORY_SET_OF_FINAL: tuple[str, ...] = ("A", "A", "B", "B", "B")
"""Repeatability set (Table 4 = "A", Table 5 = "B") whose destination each trajectory reaches."""

# ---------------------------------------------------------------------------------------------
# Table 3 (§7.1, thesis p. 173): maximum error per trajectory 1-5. Repairs: the unit printed
# "x 10e-3 rad" means x 10^-3 rad (thesis §4.2); trajectory 1's "+/- 8" is stored as its magnitude
# 8 and the printed signs of 3-5 ("-13", "-11", "-11") are kept (sign = direction of the worst
# joint error, which the lost figures would show).
# ---------------------------------------------------------------------------------------------
TABLE3_POSITION_ERROR_MM: FloatArray = _ro([1.4, 1.4, 1.4, 1.2, 1.4])
"""Table 3 maximum error in trajectory points [mm], shape (5,), trajectories 1-5."""

TABLE3_JOINT_ERROR_MRAD: FloatArray = _ro([8.0, 8.0, -13.0, -11.0, -11.0])
"""Table 3 maximum joint-angle error [10^-3 rad], shape (5,), signs as printed."""

# ---------------------------------------------------------------------------------------------
# Tables 4 and 5 (§7.1, thesis p. 174): final points (x, y, z) [m] of the two repeatability sets
# of 10 trajectories (FK on the encoder angles). Printed "-0.291" is -0.2910 (trailing zero
# dropped by the thesis). No other repair.
# ---------------------------------------------------------------------------------------------
TABLE4_SET_A_M: FloatArray = _ro(
    [
        [0.2306, 0.7165, -0.2910],
        [0.2306, 0.7166, -0.2909],
        [0.2314, 0.7166, -0.2913],
        [0.2323, 0.7165, -0.2912],
        [0.2323, 0.7163, -0.2913],
        [0.2316, 0.7167, -0.2912],
        [0.2315, 0.7166, -0.2913],
        [0.2316, 0.7167, -0.2912],
        [0.2315, 0.7167, -0.2912],
        [0.2315, 0.7167, -0.2913],
    ]
)
"""Table 4: final points of set A (x, y, z) in the PUMA base frame [m], shape (10, 3)."""

TABLE5_SET_B_M: FloatArray = _ro(
    [
        [-0.1097, 0.6635, -0.3595],
        [-0.1117, 0.6631, -0.3595],
        [-0.1098, 0.6639, -0.3594],
        [-0.1098, 0.6639, -0.3594],
        [-0.1098, 0.6638, -0.3594],
        [-0.1098, 0.6637, -0.3595],
        [-0.1114, 0.6636, -0.3593],
        [-0.1098, 0.6639, -0.3594],
        [-0.1107, 0.6636, -0.3599],
        [-0.1108, 0.6641, -0.3596],
    ]
)
"""Table 5: final points of set B (x, y, z) in the PUMA base frame [m], shape (10, 3)."""

# ---------------------------------------------------------------------------------------------
# Tables 6 and 7 (§7.1, thesis pp. 175-176): pairwise Euclidean distances [m] between the final
# points of each set, printed to 4 decimals (0.0001 m). Transcribed as the full printed 10 x 10
# matrices (symmetric, zero diagonal). Repair: Table 7's row/column headers are printed
# "A(1)..A(10)" but the entries are the set-B points (an inconsistency of the thesis, see
# docs/telerobotics.md).
# ---------------------------------------------------------------------------------------------
TABLE6_SET_A_DISTANCES_M: FloatArray = _ro(
    [
        [0, 0.0001, 0.0009, 0.0017, 0.0017, 0.001, 0.001, 0.001, 0.0009, 0.001],
        [0.0001, 0, 0.0009, 0.0017, 0.0018, 0.001, 0.001, 0.001, 0.001, 0.001],
        [0.0009, 0.0009, 0, 0.0009, 0.0009, 0.0002, 0.0001, 0.0002, 0.0002, 0.0001],
        [0.0017, 0.0017, 0.0009, 0, 0.0002, 0.0007, 0.0008, 0.0007, 0.0008, 0.0008],
        [0.0017, 0.0018, 0.0009, 0.0002, 0, 0.0008, 0.0009, 0.0008, 0.0009, 0.0009],
        [0.001, 0.001, 0.0002, 0.0007, 0.0008, 0, 0.0002, 0, 0.0001, 0.0001],
        [0.001, 0.001, 0.0001, 0.0008, 0.0009, 0.0002, 0, 0.0002, 0.0001, 0.0001],
        [0.001, 0.001, 0.0002, 0.0007, 0.0008, 0, 0.0002, 0, 0.0001, 0.0001],
        [0.0009, 0.001, 0.0002, 0.0008, 0.0009, 0.0001, 0.0001, 0.0001, 0, 0.0001],
        [0.001, 0.001, 0.0001, 0.0008, 0.0009, 0.0001, 0.0001, 0.0001, 0.0001, 0],
    ]
)
"""Table 6: distances between the set-A final points [m], shape (10, 10), 4-decimal print."""

TABLE7_SET_B_DISTANCES_M: FloatArray = _ro(
    [
        [0, 0.002, 0.0004, 0.0004, 0.0003, 0.0002, 0.0017, 0.0004, 0.0011, 0.0013],
        [0.002, 0, 0.0021, 0.0021, 0.002, 0.002, 0.0006, 0.0021, 0.0012, 0.0013],
        [0.0004, 0.0021, 0, 0, 0.0001, 0.0002, 0.0016, 0, 0.0011, 0.001],
        [0.0004, 0.0021, 0, 0, 0.0001, 0.0002, 0.0016, 0, 0.0011, 0.001],
        [0.0003, 0.002, 0.0001, 0.0001, 0, 0.0001, 0.0016, 0.0001, 0.001, 0.0011],
        [0.0002, 0.002, 0.0002, 0.0002, 0.0001, 0, 0.0016, 0.0002, 0.001, 0.0011],
        [0.0017, 0.0006, 0.0016, 0.0016, 0.0016, 0.0016, 0, 0.0016, 0.0009, 0.0008],
        [0.0004, 0.0021, 0, 0, 0.0001, 0.0002, 0.0016, 0, 0.0011, 0.001],
        [0.0011, 0.0012, 0.0011, 0.0011, 0.001, 0.001, 0.0009, 0.0011, 0, 0.0006],
        [0.0013, 0.0013, 0.001, 0.001, 0.0011, 0.0011, 0.0008, 0.001, 0.0006, 0],
    ]
)
"""Table 7: distances between the set-B final points [m], shape (10, 10), 4-decimal print."""

# The repeatability the thesis states from Tables 6/7 (§7.1 text): 1.8 mm (A), 2.1 mm (B).
REPEATABILITY_STATED_MM: tuple[float, float] = (1.8, 2.1)
"""Stated maximum pairwise distance of set A and set B [mm] (§7.1 text)."""

# ---------------------------------------------------------------------------------------------
# §7.4 singularity trajectories (thesis p. ~190): initial joint angles [rad] and laser target
# distance [m]. Reported times: det J = 0 at ~0.63 s (traj. 1); ~2.1 s and back on path ~2.8 s
# (traj. 2); SR error back to zero ~2.7 s.
# ---------------------------------------------------------------------------------------------
SINGULARITY_TRAJ1_Q0_RAD: FloatArray = _ro(
    [-1.44424, -2.85717, 0.36547, -0.34528, -0.47725, -0.09663]
)
"""§7.4 trajectory 1 (external singularity) initial joint angles [rad], shape (6,)."""
SINGULARITY_TRAJ1_TARGET_M: float = 0.35
"""§7.4 trajectory 1 laser target distance [m]."""
SINGULARITY_TRAJ2_Q0_RAD: FloatArray = _ro(
    [-1.37229, -2.27639, -0.01268, 0.01852, -1.53292, 0.27288]
)
"""§7.4 trajectory 2 (internal then external singularity) initial joint angles [rad], (6,)."""
SINGULARITY_TRAJ2_TARGET_M: float = 1.3
"""§7.4 trajectory 2 laser target distance [m]."""
