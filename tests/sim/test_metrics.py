import json
import math

import numpy as np
import pytest

import velfence as vf
from velfence.sim import (
    HardStop,
    NoLimit,
    Trajectory,
    area_gain,
    chatter_rate,
    corner_escape_time,
    max_output_jump,
    max_penetration,
    sliding_ratio,
    summarize,
    time_outside,
)

SQUARE = vf.ConvexPolygon([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
DT = 0.125


def make(p, v_out=None, v_cmd=None, dt=DT):
    p = np.asarray(p, dtype=float)
    n = len(p)
    zeros = np.zeros((n, 2))
    return Trajectory(
        t=dt * np.arange(n),
        p=p,
        v_cmd=zeros if v_cmd is None else v_cmd,
        v_out=zeros if v_out is None else v_out,
    )


def line_exiting_bottom():
    """From (0.5, 0.5) straight down to (0.5, -0.1) and back up to (0.5, 0.3), step 0.05."""
    down = np.arange(0.5, -0.1 - 1e-9, -0.05)
    up = np.arange(-0.05, 0.3 + 1e-9, 0.05)
    y = np.concatenate([down, up])
    return make(np.stack([np.full_like(y, 0.5), y], axis=1))


def test_max_penetration_straight_line():
    traj = line_exiting_bottom()
    assert max_penetration(traj, SQUARE) == pytest.approx(0.1, abs=1e-12)
    assert max_penetration(make([[0.5, 0.5], [0.5, 0.0]]), SQUARE) == 0.0


def test_max_penetration_is_max_violation_past_a_corner():
    traj = make([[0.5, 0.5], [1.3, -0.2]])
    assert max_penetration(traj, SQUARE) == pytest.approx(0.3)


def test_time_outside_left_rule():
    traj = line_exiting_bottom()
    y = traj.p[:, 1]
    outside_rows = int(np.sum(y[:-1] < -1e-12))
    assert outside_rows == 3  # -0.05, -0.1, -0.05
    assert time_outside(traj, SQUARE) == pytest.approx(3 * DT)
    assert time_outside(make([[0.5, 0.5], [0.5, -0.5]]), SQUARE) == 0.0  # last row not counted


def test_chatter_exact_count_alternating():
    n = 41
    p = np.tile([0.5, 0.01], (n, 1))
    v = np.zeros((n, 2))
    v[:, 1] = np.where(np.arange(n) % 2 == 0, 1.0, -1.0)
    traj = make(p, v_out=v)
    # 40 sign changes over 40 * DT seconds near the bottom edge
    assert chatter_rate(traj, SQUARE, band=0.05) == pytest.approx(40 / (40 * DT))
    # not near: nothing counted
    assert chatter_rate(make(np.tile([0.5, 0.5], (n, 1)), v_out=v), SQUARE, band=0.05) == 0.0


def test_chatter_zeros_are_skipped_and_runs_reset():
    vy = [1.0, 0.0, -1.0, 0.0, 0.0, 1.0, 1e-12, 1.0, -1.0]
    near_y = [0.01] * 9
    v = np.stack([np.zeros(9), vy], axis=1)
    traj = make(np.stack([np.full(9, 0.5), near_y], axis=1), v_out=v)
    assert chatter_rate(traj, SQUARE, band=0.05) == pytest.approx(3 / (8 * DT))
    # leaving the band between rows 4 and 5 splits the run: the change 2 -> 5 is not counted
    far_y = list(near_y)
    far_y[4] = 0.5
    traj = make(np.stack([np.full(9, 0.5), far_y], axis=1), v_out=v)
    assert chatter_rate(traj, SQUARE, band=0.05) == pytest.approx(2 / (6 * DT))


def test_sliding_ratio_hand_made():
    # pressing into the bottom edge (command (1, -1)), moving half the commanded x-speed
    n = 9
    x = 0.2 + 0.5 * DT * np.arange(n)
    p = np.stack([x, np.full(n, 0.02)], axis=1)
    cmd = np.tile([1.0, -1.0], (n, 1))
    assert sliding_ratio(make(p, v_cmd=cmd), SQUARE, band=0.05) == pytest.approx(0.5)
    # command pointing inward: not pressing, undefined
    cmd_in = np.tile([1.0, 1.0], (n, 1))
    assert math.isnan(sliding_ratio(make(p, v_cmd=cmd_in), SQUARE, band=0.05))


def test_corner_escape_time():
    c = SQUARE.corners[2]  # (1, 1)
    d = np.array([0.5, 0.4, 0.1, 0.05, 0.05, 0.1, 0.3, 0.05])  # distance along the diagonal
    p = c - d[:, None] * np.array([1.0, 1.0]) / math.sqrt(2.0)
    traj = make(p)
    # enters at row 2 (0.1 < 0.2), leaves at row 6 (0.3 >= 0.2)
    assert corner_escape_time(traj, SQUARE, 2, radius=0.2) == pytest.approx(4 * DT)
    assert math.isnan(corner_escape_time(traj, SQUARE, 0, radius=0.2))
    assert corner_escape_time(make(p[:6]), SQUARE, 2, radius=0.2) == math.inf
    with pytest.raises(vf.InvalidParameter, match=r"corner_index: expected an int <= 3, got 4"):
        corner_escape_time(traj, SQUARE, 4, radius=0.2)
    with pytest.raises(vf.InvalidParameter, match=r"radius must be finite and > 0"):
        corner_escape_time(traj, SQUARE, 1, radius=0.0)


def test_max_output_jump_continuity():
    cmds = [[1.0, -1.0], [0.0, -1.0], [1.0, 1.0]]
    assert max_output_jump(NoLimit(), SQUARE, spacing=0.05, commands=cmds) == 0.0
    # the hard stop jumps by the full command at the boundary, whatever the spacing
    hs = HardStop(SQUARE, dt=1e-3)
    assert max_output_jump(hs, SQUARE, spacing=0.05, commands=cmds) == pytest.approx(math.sqrt(2))
    exact = vf.PolygonShaper(SQUARE, buffer=0.1, spring_gain=4.0, method="exact", accelerate=False)
    coarse = max_output_jump(exact, SQUARE, spacing=0.04, commands=cmds)
    fine = max_output_jump(exact, SQUARE, spacing=0.01, commands=cmds)
    assert fine < 0.35 * coarse  # shrinks ~linearly with the spacing
    with pytest.raises(vf.InvalidParameter, match=r"more than 4000000 points"):
        max_output_jump(NoLimit(), SQUARE, spacing=1e-4, commands=cmds)
    with pytest.raises(vf.InvalidParameter, match=r"commands must be a non-empty finite"):
        max_output_jump(NoLimit(), SQUARE, spacing=0.1, commands=np.zeros((0, 2)))


def test_area_gain():
    assert area_gain(SQUARE) == pytest.approx(1.0)
    tri = vf.ConvexPolygon([[0, 0], [1, 0], [0, 1]])
    assert area_gain(tri) == pytest.approx(2.0, rel=1e-6)  # best rectangle 1/2 x 1/2


def test_summarize_is_json_serialisable():
    traj = line_exiting_bottom()
    s = summarize(
        traj, SQUARE, band=0.05, corner_index=0, radius=0.1, shaper=NoLimit(), spacing=0.1
    )
    assert set(s) == {
        "duration", "max_penetration", "time_outside", "chatter_rate", "sliding_ratio",
        "area_gain", "corner_escape_time", "max_output_jump",
    }  # fmt: skip
    assert all(type(v) is float for v in s.values())
    assert s["max_penetration"] == pytest.approx(0.1)
    json.loads(json.dumps(s))
    with pytest.raises(vf.InvalidParameter, match=r"corner_index and radius go together"):
        summarize(traj, SQUARE, band=0.05, corner_index=0)
    with pytest.raises(vf.InvalidParameter, match=r"traj must be a velfence.sim.Trajectory"):
        max_penetration(traj.p, SQUARE)  # type: ignore[arg-type]
    with pytest.raises(vf.InvalidParameter, match=r"band must be finite and > 0"):
        chatter_rate(traj, SQUARE, band=-1.0)


def test_chatter_ignores_reversals_the_operator_commanded():
    n = 41
    p = np.tile([0.5, 0.01], (n, 1))
    v = np.zeros((n, 2))
    v[:, 1] = np.where(np.arange(n) % 2 == 0, 1.0, -1.0)
    # The output follows a command that itself alternates: the limiter added no reversal.
    assert chatter_rate(make(p, v_out=v, v_cmd=v), SQUARE, band=0.05) == 0.0
    # Same output against a constant command: every reversal is the limiter's.
    steady = np.tile([0.0, -1.0], (n, 1))
    assert chatter_rate(make(p, v_out=v, v_cmd=steady), SQUARE, band=0.05) > 0.0


def test_chatter_ignores_the_reference_switch_at_a_corner():
    # Moving diagonally through the corner region: the nearest edge switches from bottom to
    # right, the output's normal sign with respect to the nearest edge flips; no chatter.
    p = np.array([[0.9, 0.02], [0.95, 0.03], [0.98, 0.06], [0.985, 0.09]])
    v = np.tile([0.5, 0.5], (4, 1))  # inward for the bottom edge, outward for the right edge
    assert chatter_rate(make(p, v_out=v, v_cmd=v), SQUARE, band=0.2) == 0.0


def test_trajectory_window_selects_half_open_interval():
    traj = line_exiting_bottom()
    part = traj.window(0.25, 0.75)
    assert part.t[0] == pytest.approx(0.25)
    assert part.t[-1] == pytest.approx(0.625)
    np.testing.assert_array_equal(part.p, traj.p[2:6])
    with pytest.raises(vf.InvalidInput, match="no row in the window"):
        traj.window(100.0, 101.0)


def test_summarize_refuses_commands_without_a_shaper():
    traj = make(np.array([[0.5, 0.5], [0.6, 0.5]]))
    with pytest.raises(vf.InvalidParameter, match=r"commands is only used by max_output_jump"):
        summarize(traj, SQUARE, band=0.1, commands=[[1.0, 0.0]])
    with pytest.raises(vf.InvalidParameter, match=r"got corner_index given and radius not given"):
        summarize(traj, SQUARE, band=0.1, corner_index=0)
