"""Kinematics checks of Khokar 2009 (velfence.apps.reproduce._telerobotics_kinematics) and its
tables.

Expected values are the thesis's own statements (text, eq. 1, Table 9 summary) or the numbers
it implies (docs/telerobotics.md §8), recomputed here by independent numpy code, not read back from
the implementation.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from velfence.apps.reproduce._telerobotics_kinematics import (
    FK_TOL_MM,
    recorded_fk_errors_mm,
)
from velfence.apps.reproduce.base import Check
from velfence.apps.teleop import thesis_data as data

PNG = b"\x89PNG\r\n\x1a\n"
A3 = 0.0203  # [m], |a3| of the PUMA 560 (Khokar 2009 Table 2, eq. 7)


@pytest.fixture(scope="module")
def result(telerobotics_run: Any) -> tuple[list[Check], list[Path]]:
    """kinematics_checks(out) as the shared reproduction ran it (its conftest.py)."""
    return telerobotics_run.parts["kinematics_checks"]


def by_name(checks: list[Check]) -> dict[str, Check]:
    return {c.name: c for c in checks}


def find(checks: list[Check], fragment: str) -> Check:
    hits = [c for c in checks if fragment in c.name]
    assert len(hits) == 1, (fragment, [c.name for c in checks])
    return hits[0]


# --------------------------------------------------------------------------------------------
# The checks
# --------------------------------------------------------------------------------------------
def test_names_unique_and_all_pass_except_the_source_defect(
    result: tuple[list[Check], list[Path]],
) -> None:
    checks, _ = result
    names = [c.name for c in checks]
    assert len(names) == len(set(names)) >= 10
    defects = [c for c in checks if c.source_defect]
    assert [c.name for c in defects] == [
        "FK with the printed a3 = +0.0203 m vs Tables 4/5 means [mm]"
    ]
    assert not defects[0].passed
    failed = [c.name for c in checks if not c.passed and not c.source_defect]
    assert failed == []
    for c in checks:
        assert c.to_dict()["source"].startswith("Khokar 2009")


def test_fk_vs_tables_4_5_numbers(result: tuple[list[Check], list[Path]]) -> None:
    checks, _ = result
    # FK of the recorded joints vs Tables 4/5: 0.2 mm (set A) and about 1.3 mm (set B).
    a = find(checks, "set-A destination")
    b = find(checks, "set-B destination")
    assert a.tolerance == FK_TOL_MM == 1.5
    assert 0.1 < a.measured < 0.4
    assert 1.2 < b.measured < 1.4
    # Independent: FK by the printed position formulas of eqs. 20-22 (d6 = 0).
    for q, P, check in (
        (data.TRAJECTORY_FINAL_Q_RAD[0], data.TABLE4_SET_A_M, a),
        (data.TRAJECTORY_FINAL_Q_RAD[2], data.TABLE5_SET_B_M, b),
    ):
        c1, s1 = math.cos(q[0]), math.sin(q[0])
        c2, s2 = math.cos(q[1]), math.sin(q[1])
        c23, s23 = math.cos(q[1] + q[2]), math.sin(q[1] + q[2])
        reach = s23 * 0.4331 - c23 * A3 + c2 * 0.4318
        p = np.array(
            [c1 * reach - s1 * 0.15, s1 * reach + c1 * 0.15, c23 * 0.4331 + s23 * A3 - s2 * 0.4318]
        )
        err = np.linalg.norm(p - P.mean(axis=0)) * 1e3
        assert check.measured == pytest.approx(err, abs=1e-3)


def test_per_point_errors_bounded_by_repeatability(result: tuple[list[Check], list[Path]]) -> None:
    checks, _ = result
    ea, eb = recorded_fk_errors_mm()
    assert ea.shape == eb.shape == (10,)
    c = find(checks, "every Table 4/5 point")
    assert c.measured == pytest.approx(max(ea.max(), eb.max()), abs=1e-3)
    assert c.tolerance == 2.1
    assert 1.5 < c.measured < 2.1  # the set-B points scatter beyond the mean tolerance


def test_tables_6_7_and_repeatability(result: tuple[list[Check], list[Path]]) -> None:
    checks, _ = result
    for table, stated, expected_mm in (("Table 6", "set A", 1.77), ("Table 7", "set B", 2.06)):
        c = find(checks, f"{table} recomputed")
        assert c.passed
        assert c.measured <= 0.5e-4
        assert "0 mismatches" in c.note
        r = find(checks, f"repeatability of {stated}")
        assert r.measured == pytest.approx(expected_mm, abs=0.005)  # Tables 6/7 recomputed


def test_printed_a3_sign_misses_by_twice_a3(result: tuple[list[Check], list[Path]]) -> None:
    # Flipping a3 moves the wrist centre by 2·a3 along (c1 c23, s1 c23, -s23), a unit vector.
    c = find(checks=result[0], fragment="printed a3")
    assert c.measured == pytest.approx(2 * A3 * 1e3, abs=1.5)


def test_craig_relation_and_ik_checks(result: tuple[list[Check], list[Path]]) -> None:
    checks, _ = result
    assert find(checks, "Table 2 (Craig)").measured < 1e-12
    ik = find(checks, "IK of FK of the recorded")
    assert ik.measured < 1e-9
    assert "('right', 'up', 'noflip')" in ik.note
    rt = find(checks, "IK round trip")
    assert rt.passed
    assert "1600 solutions" in rt.note


def test_plot_written(result: tuple[list[Check], list[Path]]) -> None:
    _, paths = result
    assert len(paths) == 1
    assert paths[0].name == "telerobotics_fk_error.png"
    assert paths[0].read_bytes()[:8] == PNG


# --------------------------------------------------------------------------------------------
# The transcribed tables, against the thesis's own statements
# --------------------------------------------------------------------------------------------
def test_table1_gives_eq1() -> None:
    assert data.TABLE1_DISTANCE_CM.shape == data.TABLE1_VOLTAGE_V.shape == (21,)
    V = np.column_stack([data.TABLE1_VOLTAGE_V, np.ones(21)])
    (slope, offset), *_ = np.linalg.lstsq(V, data.TABLE1_DISTANCE_CM, rcond=None)
    assert slope == pytest.approx(data.EQ1_SLOPE_CM_PER_V, abs=1e-4)
    assert offset == pytest.approx(data.EQ1_OFFSET_CM, abs=1e-4)
    assert data.EQ1_SLOPE_CM_PER_V == 126.1774
    assert data.EQ1_OFFSET_CM == -104.8980
    assert np.all(np.diff(data.TABLE1_DISTANCE_CM) > 0)
    assert np.all(np.diff(data.TABLE1_VOLTAGE_V) > 0)


def test_table9_matches_the_thesis_summary() -> None:
    # §7.3 text: old accuracy -3.2/+1.0 cm, new -0.6/+0.2 cm; reproducibility 2.6 and 0.5 cm.
    assert data.TABLE9_DISTANCE_CM.shape == (8,)
    assert data.TABLE9_ACCURACY_OLD_CM[:, 0].min() == -3.2
    assert data.TABLE9_ACCURACY_OLD_CM[:, 1].max() == 1.0
    assert data.TABLE9_ACCURACY_NEW_CM[:, 0].min() == -0.6
    assert data.TABLE9_ACCURACY_NEW_CM[:, 1].max() == 0.2
    assert data.TABLE9_REPRODUCIBILITY_OLD_CM.max() == 2.6
    assert data.TABLE9_REPRODUCIBILITY_NEW_CM.max() == 0.5
    for acc in (data.TABLE9_ACCURACY_OLD_CM, data.TABLE9_ACCURACY_NEW_CM):
        assert acc.shape == (8, 2)
        assert np.all(acc[:, 0] <= 0.0)
        assert np.all(acc[:, 1] >= 0.0)


def test_tables_4_to_7_shapes_and_structure() -> None:
    assert data.TABLE4_SET_A_M.shape == data.TABLE5_SET_B_M.shape == (10, 3)
    for T in (data.TABLE6_SET_A_DISTANCES_M, data.TABLE7_SET_B_DISTANCES_M):
        assert T.shape == (10, 10)
        np.testing.assert_array_equal(T, T.T)
        np.testing.assert_array_equal(np.diag(T), 0.0)
    # §7.1 text: max distance 1.8 mm (set A) and 2.1 mm (set B), read from Tables 6/7.
    assert data.TABLE6_SET_A_DISTANCES_M.max() == pytest.approx(0.0018)
    assert data.TABLE7_SET_B_DISTANCES_M.max() == pytest.approx(0.0021)
    assert data.REPEATABILITY_STATED_MM == (1.8, 2.1)


def test_recorded_joint_angles_and_table3() -> None:
    assert data.TRAJECTORY_INITIAL_Q_RAD.shape == data.TRAJECTORY_FINAL_Q_RAD.shape == (5, 6)
    np.testing.assert_array_equal(data.TRAJECTORY_FINAL_Q_RAD[0], data.TRAJECTORY_FINAL_Q_RAD[1])
    np.testing.assert_array_equal(data.TRAJECTORY_FINAL_Q_RAD[2], data.TRAJECTORY_FINAL_Q_RAD[4])
    assert data.TRAJECTORY_SET_OF_FINAL == ("A", "A", "B", "B", "B")
    assert data.TABLE3_POSITION_ERROR_MM.max() == 1.4
    assert np.abs(data.TABLE3_JOINT_ERROR_MRAD).max() == 13.0
    assert data.SINGULARITY_TRAJ1_Q0_RAD.shape == data.SINGULARITY_TRAJ2_Q0_RAD.shape == (6,)
    np.testing.assert_array_equal(data.LASER_OFFSET_M, (-0.026, -0.115, 0.115))


@pytest.mark.parametrize(
    "name",
    [n for n in data.__all__ if isinstance(getattr(data, n), np.ndarray)],
)
def test_arrays_are_read_only(name: str) -> None:
    arr = getattr(data, name)
    with pytest.raises(ValueError, match="read-only"):
        arr.flat[0] = 1.0
