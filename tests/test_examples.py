"""Every example runs, and what it prints is what it claims (they are documentation).

Each example's output is parsed and checked against facts computed here independently: closed
forms (distances to an edge, the spring's recovery speed, the arc length the human pushed), the
properties the example states in its docstring (the link stays off the obstacle, the error
converges, the joints brake before the stop), never against a pasted copy of the output.
"""

from __future__ import annotations

import math
import re
import runpy
from pathlib import Path
from typing import Any

import numpy as np
import pytest

EXAMPLES_DIR = Path(__file__).parent.parent / "examples"
EXAMPLES = sorted(EXAMPLES_DIR.glob("*.py"))
NUMBER = r"[-+]?\d+(?:\.\d*)?(?:e[-+]?\d+)?"


def run_example(name: str, capsys: pytest.CaptureFixture[str]) -> list[str]:
    """Run ``examples/<name>.py`` as a script; its stdout lines."""
    runpy.run_path(str(EXAMPLES_DIR / f"{name}.py"), run_name="__main__")
    return capsys.readouterr().out.strip().splitlines()


def numbers(text: str) -> list[float]:
    return [float(x) for x in re.findall(NUMBER, text)]


def vector(text: str) -> np.ndarray:
    """The numbers between the first ``[`` and the next ``]``."""
    return np.array(numbers(text[text.index("[") : text.index("]") + 1]))


def test_every_example_is_checked() -> None:
    assert {p.stem for p in EXAMPLES} == {
        name.removeprefix("test_") for name in globals() if name.startswith("test_")
    } - {"every_example_is_checked"}


# ------------------------------------------------------------------------------------ examples


def test_quickstart(capsys: pytest.CaptureFixture[str]) -> None:
    exact_line, patent_line, why, outside = run_example("quickstart", capsys)
    v = np.array([1.0, -1.0])
    exact, patent = vector(exact_line), vector(patent_line)
    assert exact_line.startswith("exact :")
    assert patent_line.startswith("patent:")
    # Inside the workspace neither law is faster than the command, and both slow the push out
    # of the corner (its outward normal components shrink).
    for out in (exact, patent):
        assert np.linalg.norm(out) <= np.linalg.norm(v) + 1e-9
        assert out[1] > v[1]  # less speed toward the bottom edge y = 0
    assert not np.allclose(exact, patent, atol=1e-3)  # the two laws differ here
    # "corner edges 0 1 d = 0.1 0.134": p = (1.9, 0.1) is 0.1 above edge 0 (y = 0) and
    # |(2.5 - 2)·0.1 - (1 - 0)·(1.9 - 2)| / √(0.5² + 1²) from edge 1, (2, 0) -> (2.5, 1).
    zone, *rest = why.split()
    assert zone == "corner"
    primary, secondary, d1, d2 = numbers(" ".join(rest))
    assert (primary, secondary) == (0, 1)
    assert d1 == pytest.approx(0.1, abs=5e-4)
    assert d2 == pytest.approx(abs(0.5 * 0.1 - 1.0 * (1.9 - 2.0)) / math.hypot(0.5, 1.0), abs=5e-4)
    # Outside by 0.05 below edge 0 with no command: the spring pushes back at k·depth = 4·0.05.
    assert outside.startswith("outside, zero command:")
    np.testing.assert_allclose(vector(outside), [0.0, 4.0 * 0.05], atol=1e-8)


def test_joint_stops(capsys: pytest.CaptureFixture[str]) -> None:
    *ticks, final = run_example("joint_stops", capsys)
    rows = []
    for line in ticks:
        m = re.fullmatch(
            rf"t=({NUMBER}) s  stop d(\d)  zone (\d) \(([a-z-]+)\)  delta ({NUMBER})", line
        )
        assert m, line
        # the profile's zone number, and the shaper's zone name (a bound active or not)
        assert m[4] in ("free", "buffer", "corner"), line
        assert m[4] == "free" or int(m[3]) < 3, line  # no bound is active in the nominal zone
        rows.append((float(m[1]), int(m[2]), int(m[3]), float(m[5])))
    assert [r[0] for r in rows] == pytest.approx([0.0, 0.25, 0.5, 0.75, 1.0, 1.25])
    zones = [r[2] for r in rows]
    deltas = [r[3] for r in rows]
    assert zones == sorted(zones, reverse=True)  # braking zones only get nearer the stop
    assert zones[0] == 3
    assert zones[-1] == 1
    assert all(d >= 0.0 for d in deltas)  # never past a stop
    assert rows[-1][1] == 4  # it brakes before d4, the stop the command heads for
    d4 = [d for _, stop, _, d in rows if stop == 4]
    assert d4 == sorted(d4, reverse=True)
    theta, velocity = final.split("velocity")
    theta, velocity = vector(theta), vector(velocity)
    # The command (-0.5, 0.5, 0) from home (π/2, π/2, π/2): elevation moved the first two joints
    # apart; the run ends stopped at the stop (every joint speed below 2 mrad/s, from 0.5 rad/s).
    home = np.pi / 2
    assert theta[0] < home - 0.3
    assert theta[1] > home + 0.3
    assert np.abs(velocity).max() < 2e-3


@pytest.mark.slow
def test_obstacle_avoidance(capsys: pytest.CaptureFixture[str]) -> None:
    lines = run_example("obstacle_avoidance", capsys)
    assert len(lines) == 10
    zones, clearance, error = [], [], []
    for k, line in enumerate(lines):
        m = re.fullmatch(
            rf"t=\s*({NUMBER}) s  (\w+)\s+clearance d-rho\s+({NUMBER}) mm  ee error ({NUMBER}) mm"
            rf"(?:  \(({NUMBER}) mm inside the sphere of influence, "
            rf"({NUMBER}) mm from the body\))?",
            line,
        )
        assert m, line
        assert float(m[1]) == pytest.approx(k)
        assert line.index("clearance") == lines[0].index("clearance")  # the zone column aligns
        if float(m[3]) < 0:  # inside the sphere: the line says by how much, and the body distance
            assert float(m[5]) == pytest.approx(-float(m[3]), abs=0.051)
            assert float(m[6]) == pytest.approx(150.0 + float(m[3]), abs=0.51)
        else:
            assert m[5] is None
        zones.append(m[2])
        clearance.append(float(m[3]) / 1e3)
        error.append(float(m[4]))
    # The docstring: without the controller the link would pass 0.07 m from the obstacle, inside
    # its 0.2 m sphere (d - ρ = 0.07 - 0.2 < 0). With it the link is held at the sphere...
    assert "recovering" in zones or "active" in zones  # the controller did engage
    assert -1e-3 <= min(clearance) < 1e-2  # held at the sphere (not kept far off by luck)
    # ... while the end effector still tracks the line (within a millimetre).
    assert max(error) < 1.0
    assert zones[0] == zones[-1] == "free"  # far from the obstacle at both ends of the line


@pytest.mark.slow
def test_cobot_path_following(capsys: pytest.CaptureFixture[str]) -> None:
    lines = run_example("cobot_path_following", capsys)
    ticks, walls = lines[:6], lines[6:]
    s_printed, err = [], []
    for k, line in enumerate(ticks):
        m = re.fullmatch(
            rf"t =\s*({NUMBER}) s  s =\s*({NUMBER}) m  \|ΔR\| = ({NUMBER}) m", line.strip()
        )
        assert m, line
        assert float(m[1]) == pytest.approx(k)
        s_printed.append(float(m[2]))
        err.append(float(m[3]))

    # The human's speed u(t) = 0.5 + 0.3 sin t, paused on [2, 2.5) s: s(t) = ∫ u dt.
    def arc(t: float) -> float:
        def integral(a: float, b: float) -> float:
            return 0.5 * (b - a) + 0.3 * (math.cos(a) - math.cos(b))

        return integral(0.0, min(t, 2.0)) + (integral(2.5, t) if t > 2.5 else 0.0)

    for k, s in enumerate(s_printed):
        assert s == pytest.approx(arc(k), abs=0.006)  # printed to 0.01 m, Euler steps of 1 ms
    # Start (1, -0.5) is 0.1 m below the square's bottom edge y = -0.4; the error then
    # converges (double spatial pole at -3 /m) to under a millimetre.
    assert err[0] == pytest.approx(0.1, rel=1e-6)
    assert err == sorted(err, reverse=True)
    assert err[-1] < 1e-3
    # The caster wall at x = 1.5 with a 0.1 buffer: the push (1, 0.2) passes untouched inside,
    # loses part of its outward x speed in the buffer, and all of it on the wall, where only the
    # tangential 0.2 is left.
    outs = []
    for line, p in zip(walls, ([1.0, 0.0], [1.45, 0.0], [1.5, 0.0]), strict=True):
        at, out = line.split("->")
        np.testing.assert_allclose(vector(at), p)
        outs.append(vector(out))
    np.testing.assert_allclose(outs[0], [1.0, 0.2], atol=1e-12)
    assert 0.0 < outs[1][0] < 1.0
    # at the wall the outward push is removed; the wall asks for an inward creep of 1e-9 of the
    # push speed so that round-off never points out
    np.testing.assert_allclose(outs[2], [0.0, 0.2], atol=1e-8)
    assert outs[2][0] <= 0.0


def test_teleop_session(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    from velfence.apps import teleop

    sessions: list[Any] = []

    class Recorded(teleop.Session):
        def __init__(self, *args: Any, **kwargs: Any) -> None:
            super().__init__(*args, **kwargs)
            sessions.append(self)

    monkeypatch.setattr(teleop, "Session", Recorded)  # the example's session, to look inside
    start, spot, after, tool = run_example("teleop_session", capsys)
    assert start == "start: teleop clutch engaged: False"
    assert spot.startswith("laser spot:")
    spot_p = vector(spot)
    assert after.startswith("after 'A': teleop - autonomous approach done in")
    assert "back to teleoperation" in after
    end_error_mm, end_error_deg = numbers(after.split("end error")[1])[:2]
    assert end_error_mm <= 1.0
    assert end_error_deg <= 0.1
    # The claim: the arm drove along the beam and stopped 20 cm short of the spot.
    (session,) = sessions
    snap = session.snapshot()
    origin = np.array(snap["laser"]["origin"])
    assert np.linalg.norm(spot_p - origin) == pytest.approx(0.20, abs=0.003)  # spot printed to mm
    np.testing.assert_allclose(vector(tool), np.array(snap["tool"])[:3, 3], atol=6e-4)
    assert snap["mode"] == "teleop"


def _inside_fence(p: np.ndarray, corners: list[list[float]]) -> float:
    """Smallest signed distance to the CCW fence's edges by cross products (positive inside)."""
    c = np.asarray(corners, dtype=float)
    e = np.roll(c, -1, axis=0) - c
    cross = e[:, 0] * (p[1] - c[:, 1]) - e[:, 1] * (p[0] - c[:, 0])
    return float((cross / np.hypot(e[:, 0], e[:, 1])).min())


def test_mobile_base_fence(capsys: pytest.CaptureFixture[str]) -> None:
    unshaped, closest, final = run_example("mobile_base_fence", capsys)
    ns = runpy.run_path(str(EXAMPLES_DIR / "mobile_base_fence.py"))
    fence = ns["FENCE"]
    # Independent route for the unshaped drive: integrate (P, θ) with the example's commands,
    # P' = (v cos θ - l ω sin θ, v sin θ + l ω cos θ), and find the first step outside.
    p, theta, left = np.array([1.0, 1.0]), 0.3, math.inf
    for k in range(ns["STEPS"]):
        v, w = ns["operator"](k)
        pdot = np.array(
            [v * math.cos(theta) - ns["L"] * w * math.sin(theta),
             v * math.sin(theta) + ns["L"] * w * math.cos(theta)]
        )  # fmt: skip
        p, theta = p + ns["DT"] * pdot, theta + ns["DT"] * w
        if _inside_fence(p, fence) < 0.0:
            left = (k + 1) * ns["DT"]
            break
    assert unshaped.startswith("unshaped: P leaves the fence at t =")
    assert numbers(unshaped)[0] == pytest.approx(left, abs=1e-9)
    # Shaped: the printed closest approach is non-negative and within the 0.4 m buffer (the
    # fence was really approached), and the end point is inside by the cross-product test.
    (d_min,) = numbers(closest.split("fence")[1].split("m")[0])
    assert 0.0 <= d_min < 0.4
    assert final.endswith("inside at every step: True")
    assert _inside_fence(vector(final), fence) >= 0.0


@pytest.mark.slow
def test_ur5e_safety_planes(capsys: pytest.CaptureFixture[str]) -> None:
    start_line, planes_line, closest, final = run_example("ur5e_safety_planes", capsys)
    start = vector(start_line)
    twist = vector(start_line.split("command")[1])
    normals = np.array(numbers(planes_line.split("offsets")[0])).reshape(2, 3)
    offsets = vector(planes_line.split("offsets")[1])
    # The planes as the docstring says: unit normals, 15° and 10° from the axes.
    np.testing.assert_allclose(np.linalg.norm(normals, axis=1), 1.0, atol=1e-5)
    assert math.degrees(math.asin(normals[0, 2])) == pytest.approx(15.0, abs=1e-3)
    assert math.degrees(math.asin(normals[1, 1])) == pytest.approx(10.0, abs=1e-3)
    # Unfiltered, the constant command would cross both planes within the 3 s (closed form).
    ahead = normals @ (start + 3.0 * twist) - offsets
    assert np.all(ahead < -0.1)
    # Filtered: never on the wrong side, and the TCP ends resting on both planes.
    wall, floor = numbers(closest.split("wall")[1])[0], numbers(closest.split("floor")[1])[0]
    assert wall >= -1e-9
    assert floor >= -1e-9
    d_end = normals @ vector(final) - offsets
    assert np.all(d_end >= -1e-6)
    assert np.all(d_end < 5e-3)


@pytest.mark.slow
def test_physics_lag(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    pytest.importorskip("mujoco")
    figure = tmp_path / "lag.png"
    monkeypatch.setattr("sys.argv", ["physics_lag.py", str(figure)])
    lines = run_example("physics_lag", capsys)
    rows = [numbers(line) for line in lines[1:] if line.count("|") == 4]
    assert len(rows) == 12
    for bandwidth, speed, ratio, plain, ahead in rows:
        # The lag ratio u T / b with T = 1 / bandwidth and the 50 mm buffer of the study.
        assert ratio == pytest.approx(speed / (bandwidth * 0.05), abs=0.005)
        # The linear analysis: an overshoot exactly when u T / b > 1/4 ...
        assert (plain > 0.0) == (ratio > 0.25), (bandwidth, speed, plain)
        # ... and none with the look-ahead and its guard.
        assert ahead == 0.0
    assert figure.stat().st_size > 10_000
    assert lines[-1] == f"wrote {figure}"


def test_custom_row_provider(capsys: pytest.CaptureFixture[str]) -> None:
    height, speed = run_example("custom_row_provider", capsys)
    z, table = numbers(height)[1], numbers(height)[2]
    assert height.startswith("elbow height after")
    # the user's row holds: the elbow came down to the table top and no further
    assert table - 1e-9 <= z <= table + 2e-3
    assert abs(numbers(speed)[0]) <= 1e-6  # resting on the table: no further approach
    assert "elbow z" in speed


@pytest.mark.slow  # about 20 s: two Pusher runs and their video
def test_policy_shield(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    pytest.importorskip("gymnasium")
    pytest.importorskip("mujoco")
    pytest.importorskip("matplotlib")
    import importlib.util

    spec = importlib.util.spec_from_file_location(
        "figure_checks", Path(__file__).parent / "apps" / "viz" / "figure_checks.py"
    )
    assert spec is not None
    assert spec.loader is not None
    checks = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(checks)
    monkeypatch.setattr("sys.argv", ["policy_shield.py", str(tmp_path), "--steps", "60"])
    with checks.record_figures(monkeypatch) as figures:
        lines = run_example("policy_shield", capsys)
    checks.check_all(figures, {"policy_shield.png"})
    raw, safe = (numbers(line) for line in lines[:2])
    assert lines[0].startswith("without shield")
    assert lines[1].startswith("with shield")
    # (outside steps, of steps, depth [mm], joint steps, joint depth [mrad], interventions)
    assert raw[1] == safe[1] == 60
    assert raw[0] >= 30  # the wild policy leaves the box ...
    assert safe[0] <= raw[0] / 3  # ... the shielded one hardly (lag of the 2 N·m servo) ...
    assert safe[2] < 5.0  # ... by less than 5 mm, where the unshielded one goes decimetres
    assert raw[2] > 100.0
    assert safe[3] == 0  # no joint 1 mrad past its limit
    assert safe[5] > 0
    assert raw[5] == 0
    assert (tmp_path / "policy_shield.png").stat().st_size > 20_000
    assert (tmp_path / "policy_shield.mp4").stat().st_size > 5_000
    assert lines[-1] == f"wrote {tmp_path / 'policy_shield.mp4'}"


def test_tool_and_self_collision(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    pytest.importorskip("matplotlib")
    import importlib.util

    spec = importlib.util.spec_from_file_location(
        "figure_checks", Path(__file__).parent / "apps" / "viz" / "figure_checks.py"
    )
    assert spec is not None
    assert spec.loader is not None
    checks = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(checks)
    monkeypatch.setattr("sys.argv", ["tool_and_self_collision.py", str(tmp_path)])
    with checks.record_figures(monkeypatch) as figures:
        lines = run_example("tool_and_self_collision", capsys)
    checks.check_all(figures, {"tool_self_collision.png"})
    assert numbers(lines[0])[0] == 0.0  # touching ...
    assert lines[0].endswith("True)")  # ... never penetrating
    assert numbers(lines[1])[0] > 0.0  # the tool stays in the box
    assert "link 1 and link 3" in lines[2]
    assert numbers(lines[2])[0] < 3.0  # the elbow stopped before its limit (pi)
    assert (tmp_path / "tool_self_collision.png").stat().st_size > 10_000


def test_jerk_fence_box(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    pytest.importorskip("mujoco")
    pytest.importorskip("matplotlib")
    figure = tmp_path / "jerk.png"
    # the start of the script (0.12 s): the operator's step in speed, where the runs differ
    monkeypatch.setattr("sys.argv", ["jerk_fence_box.py", str(figure), "--duration", "0.12"])
    lines = run_example("jerk_fence_box", capsys)
    assert lines[0].startswith("method")
    rows = {line.split("|")[0].strip(): numbers(line.split("|", 1)[1]) for line in lines[1:4]}
    assert set(rows) == {"velfence + jerk rows", "velfence, no jerk rows", "per-joint clamp"}
    # (max ratio, unflagged max, flagged, over, cycles, outside [mm], joint [mrad], contacts)
    jr, raw, clamp = (
        rows[m] for m in ("velfence + jerk rows", "velfence, no jerk rows", "per-joint clamp")
    )
    assert jr[4] == raw[4] == clamp[4] == 61  # 0.12 s at 500 Hz, both ends
    assert jr[1] <= 1.0 + 1e-3  # every unflagged cycle within the limit (3 decimals printed)
    assert jr[3] == 0
    assert raw[0] > 1.5  # without jerk rows the acceleration rows allow twice the limit
    assert raw[3] > 0
    assert clamp[0] > 10.0  # the clamp steps the speed in one period
    assert figure.stat().st_size > 10_000
    assert lines[-1] == f"wrote {figure}"


@pytest.mark.slow
def test_panda_collision_fit(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    pytest.importorskip("mujoco")
    pytest.importorskip("matplotlib")
    from importlib import metadata

    try:
        metadata.distribution("example-robot-data")
    except metadata.PackageNotFoundError:
        pytest.skip("example-robot-data is not installed")
    figure = tmp_path / "fit.png"
    monkeypatch.setattr("sys.argv", ["panda_collision_fit.py", str(figure)])
    lines = run_example("panda_collision_fit", capsys)
    bodies = [ln for ln in lines if ln.startswith("| panda_link")]
    links = [ln for ln in lines if re.match(r"\| \d \| panda_link", ln)]
    assert len(bodies) == 8  # panda_link0 … panda_link7
    assert len(links) == 7
    for row in bodies:
        _length, radius, geometry, capsule, added, gap = numbers(row.split("|", 3)[3])
        # a capsule contains its geometry: more volume, and a gap below its radius
        assert capsule > geometry > 0.0
        assert added == pytest.approx(capsule - geometry, abs=0.011)
        assert 0.0 < gap < radius
    shipped = vector(next(ln for ln in lines if ln.startswith("shipped radii")).split("[m]")[1])
    for k, row in enumerate(links):
        cells = row.split("|")
        radius = float(cells[4])
        assert 1e3 * shipped[k] >= radius - 0.05  # the shipped radius covers the fit (mm)
        joint_capsule, added = float(cells[7]), float(cells[8])
        assert joint_capsule >= float(cells[5])  # at least the geometry's volume
        assert added == pytest.approx(joint_capsule - float(cells[5]), abs=0.011)
    assert numbers(next(ln for ln in lines if ln.startswith("frame error")))[0] < 1e-9
    assert figure.stat().st_size > 10_000
    assert lines[-1] == f"wrote {figure}"
