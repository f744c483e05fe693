"""Every name renamed in 0.2 still works until 0.3: it warns and gives what the new name gives.

The table of kept and old names is in docs/architecture.md ("Vocabulary"); the renames are in
``velfence._deprecate``'s one place (keywords, attributes, module names).
"""

from __future__ import annotations

import importlib
import subprocess
import sys
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

import velfence as vf
from velfence._deprecate import renamed_args
from velfence.apps.demo.arm_box import arm_box_scene
from velfence.filter import JointLimits, ObstacleRows, SafetyFilter, SphereObstacle, WorkspaceLimit
from velfence.geometry.polytope import ConvexPolytope
from velfence.mechanisms import PAPER_STOPS, Q_AUX, DHChain, PlanarArm
from velfence.redundancy import ConfigurationController
from velfence.shaping import ShapingResultProtocol, StopLimiter, ThreeZoneBraking

WARNS = r"is now '.*'; the old name goes in 0\.3"

ARM = DHChain.seven_dof(link_radius=0.04)
LIM = ARM.joint_limits
Q0 = np.array([0.1, 0.6, 0.0, -1.2, 0.0, 0.8, 0.0])
P0 = np.asarray(ARM.fk(Q0), dtype=float)


def _filter() -> SafetyFilter:
    box = ConvexPolytope.box(P0 - 0.15, P0 + 0.15)
    return SafetyFilter(
        ARM,
        limits=JointLimits(LIM[:, 0], LIM[:, 1], max_speed=1.5),
        workspace=WorkspaceLimit(box, buffer=0.05),
    )


def _old_and_new(
    call: Callable[..., Any], old: dict[str, Any], new: dict[str, Any], **rest: Any
) -> tuple[Any, Any]:
    want = call(**new, **rest)
    with pytest.warns(DeprecationWarning, match=WARNS):
        got = call(**old, **rest)
    return got, want


def _equal(a: Any, b: Any) -> None:
    a = getattr(a, "output", a)
    b = getattr(b, "output", b)
    np.testing.assert_array_equal(a, b)


# ------------------------------------------------------------------ module-level names
@pytest.mark.parametrize(
    ("module", "old", "new"),
    [
        ("velfence.shaping", "ShaperResult", ShapingResultProtocol),
        ("velfence.shaping.base", "ShaperResult", ShapingResultProtocol),
        ("velfence.redundancy", "Obstacle", SphereObstacle),
        ("velfence.redundancy", "InfluenceObstacle", SphereObstacle),
        ("velfence.redundancy.configuration_control", "Obstacle", SphereObstacle),
        ("velfence.redundancy.configuration_control", "InfluenceObstacle", SphereObstacle),
        ("velfence.geometry.projection", "PROJECT_ITERATION_LIMIT", None),
    ],
)
def test_old_module_names_warn_and_are_the_new_objects(module: str, old: str, new: Any) -> None:
    mod = importlib.import_module(module)
    if new is None:  # a constant: the new name is the C enumerator's
        new_name = "PROJECT_STALLED"
        new = mod.PROJECT_STALLED
        assert new == 2  # VF_STALLED in core/include/velfence_status.h
    else:
        new_name = new.__name__
    with pytest.warns(DeprecationWarning, match=rf"'{old}' is now '{new_name}'.*goes in 0\.3"):
        got = getattr(mod, old)
    assert got is new
    assert not hasattr(mod, "NoSuchName")  # other names still raise AttributeError


def test_importing_velfence_does_not_warn() -> None:
    # The facade still re-exports the old names; importing it must not warn.
    code = "import velfence, velfence.shaping, velfence.redundancy"
    run = subprocess.run(
        [sys.executable, "-W", "error", "-c", code], capture_output=True, text=True, check=False
    )
    assert run.returncode == 0, run.stderr
    bad = [sys.executable, "-W", "error", "-c", "import velfence.shaping as s; s.ShaperResult"]
    run = subprocess.run(bad, capture_output=True, text=True, check=False)
    assert run.returncode != 0
    assert "goes in 0.3" in run.stderr


# ------------------------------------------------------------------ max_velocity -> max_speed
def test_joint_limits_max_velocity_keyword_and_attribute() -> None:
    got, want = _old_and_new(
        JointLimits, {"max_velocity": [1.0, 2.0]}, {"max_speed": [1.0, 2.0]},
        lower=[-1.0, -1.0], upper=[1.0, 1.0],
    )  # fmt: skip
    np.testing.assert_array_equal(got.max_speed, want.max_speed)
    with pytest.warns(DeprecationWarning, match=WARNS):
        old = want.max_velocity
    np.testing.assert_array_equal(old, [1.0, 2.0])
    with pytest.raises(vf.InvalidParameter, match="two names of one argument"):
        JointLimits([-1.0], [1.0], max_speed=1.0, max_velocity=1.0)


def test_obstacle_rows_max_velocity_keyword() -> None:
    obs = [SphereObstacle([0.3, 0.0, 0.5], radius=0.05)]
    args = {"buffer": 0.1, "spring_gain": 1.0}
    got, want = _old_and_new(
        lambda **kw: ObstacleRows(obs, np.array([0.04]), **kw),
        {"max_velocity": np.full(7, 1.5)},
        {"max_speed": np.full(7, 1.5)},
        **args,
    )
    np.testing.assert_array_equal(got._vmax, want._vmax)


def test_arm_scene_and_baselines_max_velocity_attribute() -> None:
    scene = arm_box_scene()
    with pytest.warns(DeprecationWarning, match=WARNS):
        old = scene.max_velocity
    np.testing.assert_array_equal(old, scene.max_speed)


# ------------------------------------------------------------------ (position, command)
def test_safety_filter_old_keywords() -> None:
    f = _filter()
    u = np.array([0.3, -0.2, 0.1, 0.0, 0.5, -0.4, 0.2])
    for name in ("filter", "explain", "shape"):
        got, want = _old_and_new(
            getattr(f, name), {"q": Q0, "qd_cmd": u}, {"position": Q0, "command": u}
        )
        _equal(got, want)
    twist = np.array([0.05, 0.0, -0.02])
    for name in ("filter_twist", "explain_twist"):
        got, want = _old_and_new(
            getattr(f, name), {"q": Q0, "twist": twist}, {"position": Q0, "command": twist}
        )
        _equal(got, want)
    Q, U = np.array([Q0, Q0 * 0.5]), np.array([u, -u])
    got, want = _old_and_new(f.shape_batch, {"Q": Q, "QD": U}, {"positions": Q, "commands": U})
    _equal(got, want)
    # Positional callers are untouched (no warning: our pytest config makes one an error).
    _equal(f.filter(Q0, u), want[0])


def test_stop_limiter_old_keywords() -> None:
    profile = ThreeZoneBraking.from_actuator_limits(gain=100, max_speed=2, max_acceleration=20)
    lim = StopLimiter(PAPER_STOPS, profile=profile, transform=Q_AUX)
    x, v = np.full(3, 1.4), np.array([0.5, -0.2, 0.1])
    for name in ("shape", "explain"):
        got, want = _old_and_new(
            getattr(lim, name), {"theta": x, "theta_dot": v}, {"position": x, "command": v}
        )
        _equal(got, want)
    X, V = np.array([x, x * 0.9]), np.array([v, -v])
    got, want = _old_and_new(
        lim.shape_batch, {"Theta": X, "Theta_dot": V}, {"positions": X, "commands": V}
    )
    _equal(got, want)


def test_configuration_controller_old_keywords() -> None:
    ctl = ConfigurationController(
        PlanarArm((1.0, 1.0, 1.0)),
        [SphereObstacle([1.5, -1.4], radius=0.05, influence=0.2)],
    )
    q, v = np.array([0.3, -0.6, -0.4]), np.array([0.1, -0.2])
    for name in ("control", "explain", "shape"):
        got, want = _old_and_new(
            getattr(ctl, name), {"q": q, "ee_velocity": v}, {"position": q, "command": v}
        )
        _equal(got, want)
    Q, V = np.array([q, q * 0.5]), np.array([v, -v])
    got, want = _old_and_new(ctl.shape_batch, {"Q": Q, "V": V}, {"positions": Q, "commands": V})
    _equal(got, want)


def test_renamed_args_refuses_both_names_and_keeps_the_signature() -> None:
    @renamed_args(old="new")
    def f(new: int, other: int = 0) -> int:
        return new * 10 + other

    assert f(3, 1) == 31
    assert f(new=3) == 30
    with pytest.warns(DeprecationWarning, match=r"f\(\) 'old' is now 'new'.*goes in 0\.3"):
        assert f(old=3, other=2) == 32
    with pytest.raises(vf.InvalidParameter, match="two names of one argument"):
        f(old=1, new=2)
    with pytest.raises(vf.InvalidParameter, match="two names of one argument"):
        f(1, old=2)
    import inspect

    assert list(inspect.signature(f).parameters) == ["new", "other"]


def test_resolved_rate_old_keywords() -> None:
    from velfence.apps.teleop.resolved_rate import ResolvedRate
    from velfence.mechanisms.puma560 import Puma560

    rr = ResolvedRate(Puma560())
    q = np.array([0.1, -0.4, 0.3, 0.2, 0.5, -0.1])
    xdot = np.array([0.05, 0.0, -0.02, 0.0, 0.1, 0.0])
    for name in ("step", "explain"):
        got, want = _old_and_new(
            getattr(rr, name), {"q": q, "xdot": xdot}, {"position": q, "command": xdot}
        )
        np.testing.assert_array_equal(getattr(got, "qdot", got), getattr(want, "qdot", want))


def test_line_fixture_radius_of_influence() -> None:
    from velfence.shaping import LineFixture

    p0, u = np.zeros(3), np.array([1.0, 0.0, 0.0])
    got, want = _old_and_new(
        lambda **kw: LineFixture(p0, u, **kw), {"radius_of_influence": 0.03}, {"influence": 0.03}
    )
    assert got.influence == want.influence == 0.03
    with pytest.warns(DeprecationWarning, match=WARNS):
        assert want.radius_of_influence == 0.03
    p, v = np.array([0.1, 0.02, 0.0]), np.array([0.05, 0.01, 0.0])
    _equal(got.shape(p, v), want.shape(p, v))


def test_polytope_names_keyword_is_facet_names() -> None:
    normals, offsets = [[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0]], [0.0, -1.0, 0.0]
    for call, args in (
        (ConvexPolytope, (normals, offsets)),
        (ConvexPolytope.box, ([0.0], [1.0])),
    ):
        n = len(args[1]) if call is ConvexPolytope else 2
        labels = [f"side {i}" for i in range(n)]
        with pytest.warns(DeprecationWarning, match=r"'names' is now 'facet_names'.*goes in 0\.3"):
            old = call(*args, names=labels)
        new = call(*args, facet_names=labels)
        assert old.facet_names == new.facet_names == tuple(labels)
    tri = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]
    with pytest.warns(DeprecationWarning, match=r"'names' is now 'facet_names'"):
        hull = ConvexPolytope.from_vertices(tri, names=["a", "b", "c"])
    assert hull.facet_names == ("a", "b", "c")


# Tuning parameters made keyword-only in 0.2: the old positional call still works until 0.3,
# warns, and gives what the keyword call gives.
POSITIONAL = r"positionally is deprecated; .*goes in 0\.3"


def _positional_cases() -> list[tuple[str, Callable[[], Any], Callable[[], Any]]]:
    from velfence.apps.demo.config import check_run_length
    from velfence.apps.teleop.scene import Box
    from velfence.geometry import points_segments_distances, sphere_capsule_distance
    from velfence.robots import dh_mjcf, mdh_mjcf

    rows = [[0.0, 0.0, 0.5, 0.0], [0.3, 0.0, 0.0, 0.0]]
    lim = [[-1.0, 1.0], [-2.0, 2.0]]
    c, a, b = (0.0, 0.0, 1.0), (1.0, 0.0, 0.0), (1.0, 1.0, 0.0)
    P, A, B = np.zeros((2, 3)), np.ones((1, 3)), np.full((1, 3), 2.0)
    return [
        (
            "JointLimits",
            lambda: JointLimits(LIM[:, 0], LIM[:, 1], 1.5),
            lambda: JointLimits(LIM[:, 0], LIM[:, 1], max_speed=1.5),
        ),
        (
            "check_run_length",
            lambda: check_run_length(2.0, 0.01),
            lambda: check_run_length(2.0, dt=0.01),
        ),
        (
            "dh_mjcf",
            lambda: dh_mjcf(rows, lim, (0.0, 0.0, 0.1), "two"),
            lambda: dh_mjcf(rows, joint_limits=lim, tool=(0.0, 0.0, 0.1), name="two"),
        ),
        ("mdh_mjcf", lambda: mdh_mjcf(rows, lim), lambda: mdh_mjcf(rows, joint_limits=lim)),
        (
            "sphere_capsule_distance",
            lambda: sphere_capsule_distance(c, 0.1, a, b, 0.2),
            lambda: sphere_capsule_distance(c, a, b, sphere_radius=0.1, capsule_radius=0.2),
        ),
        (
            "points_segments_distances",
            lambda: points_segments_distances(P, A, B, 0.1),
            lambda: points_segments_distances(P, A, B, radii=0.1),
        ),
        (
            "Box",
            lambda: Box((0.0, 0.0, 0.0), (1.0, 2.0, 3.0)).half_extents,
            lambda: Box((0.0, 0.0, 0.0), half_extents=(1.0, 2.0, 3.0)).half_extents,
        ),
    ]


def _same(x: Any, y: Any) -> None:
    if isinstance(x, tuple):
        for u, v in zip(x, y, strict=True):
            _same(u, v)
    elif isinstance(x, JointLimits):
        np.testing.assert_array_equal(x.max_speed, y.max_speed)
    elif isinstance(x, str):
        assert x == y
    else:
        np.testing.assert_array_equal(x, y)


@pytest.mark.parametrize("case", _positional_cases(), ids=lambda c: c[0])
def test_old_positional_tuning_parameters_warn_and_agree(case: Any) -> None:
    _, old, new = case
    with pytest.warns(DeprecationWarning, match=POSITIONAL):
        got = old()
    _same(got, new())


def test_positional_deprecation_refuses_a_value_given_twice() -> None:
    from velfence.geometry import points_segments_distances

    with pytest.raises(vf.InvalidParameter, match="positionally and by keyword"):
        points_segments_distances(
            np.zeros((1, 3)), np.ones((1, 3)), np.ones((1, 3)), 0.1, radii=0.1
        )


def test_operator_and_sr_inverse_tolerances_warn_when_positional() -> None:
    from velfence.apps.teleop import sr_inverse

    J = np.diag([1.0, 2.0, 3.0, 1.0, 1.0, 1.0])
    with pytest.warns(DeprecationWarning, match=POSITIONAL):
        old = sr_inverse(J, 0.01)
    np.testing.assert_array_equal(old, sr_inverse(J, k=0.01))


def test_the_changelog_names_every_moved_path_and_every_moved_bridge_name() -> None:
    """CHANGELOG.md lists each old module path with its new one, and each old ``velfence.bridge``
    zone name individually with its new path (read from the code's own tables)."""
    from pathlib import Path

    import velfence.bridge
    from velfence import _moved

    text = (Path(__file__).resolve().parents[1] / "CHANGELOG.md").read_text(encoding="utf-8")
    flat = " ".join(text.split())
    missing = [
        f"{old} → {new}" for old, new in _moved.MOVED.items() if f"`{old}` → `{new}`" not in flat
    ]
    former = velfence.bridge._FORMER
    assert len(former) >= 9
    missing += [
        f"velfence.bridge.{name} → {home}.{name}"
        for name, home in former.items()
        if f"`velfence.bridge.{name}` → `{home}.{name}`" not in flat
    ]
    assert not missing, missing
