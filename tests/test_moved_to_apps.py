"""The demo's code left the library in 0.2: old paths warn and give the new objects; the library
keeps what users build on (TwistMode, TcpJog, the arm baselines), with kebab-case ``.method``."""

from __future__ import annotations

import importlib

import numpy as np
import pytest

from velfence.errors import InvalidInput, InvalidParameter

pytest.importorskip("pydantic", reason="the demo configuration needs the [app] extra")

MOVED = [
    ("velfence.sim.arm", "ArmScene", "velfence.apps.demo.arm_box", "ArmScene"),
    ("velfence.sim.arm", "arm_box_scene", "velfence.apps.demo.arm_box", "arm_box_scene"),
    ("velfence.sim.arm", "ARM_METHODS", "velfence.apps.demo.arm_box", "ARM_METHODS"),
    ("velfence.sim.arm", "run_arm", "velfence.apps.demo.arm_box", "run_arm"),
    ("velfence.sim.arm", "TcpJog", "velfence.apps.demo.arm_box", "arm_jog"),
    ("velfence.sim.arm", "TwistMode", "velfence.filter", "TwistMode"),
    ("velfence.sim.scenarios", "default_script", "velfence.apps.demo.script", "default_script"),
    ("velfence.io.config", "DemoConfig", "velfence.apps.demo.config", "DemoConfig"),
    ("velfence.io.config", "load_config", "velfence.apps.demo.config", "load_config"),
    ("velfence.io", "DemoConfig", "velfence.apps.demo", "DemoConfig"),
    ("velfence.io", "check_run_length", "velfence.apps.demo", "check_run_length"),
]


@pytest.mark.parametrize(("old", "name", "new", "new_name"), MOVED)
def test_old_paths_warn_and_give_the_new_object(old: str, name: str, new: str, new_name: str):
    module = importlib.import_module(old)
    with pytest.warns(DeprecationWarning, match=rf"'{name}' is now '{new}.*goes in 0\.3"):
        value = getattr(module, name)
    assert value is getattr(importlib.import_module(new), new_name)


def test_unknown_names_are_still_attribute_errors():
    import velfence.io.config
    import velfence.sim.arm

    for module in (velfence.sim.arm, velfence.io.config):
        with pytest.raises(AttributeError):
            module.no_such_name  # noqa: B018


def test_the_library_keeps_its_own_names_without_warning():
    from velfence.io.config import StrictModel, describe_validation_error  # noqa: F401
    from velfence.sim.scenarios import Script, TcpJog, Waypoint, WaypointOperator  # noqa: F401


def test_arm_controllers_report_vocabulary_methods():
    from velfence.apps.demo.arm_box import ARM_METHODS, arm_box_scene, build_arm_controllers
    from velfence.apps.labels import method_label

    pytest.importorskip("qpsolvers")
    ctrl = build_arm_controllers(arm_box_scene())
    assert [c.method for c in ctrl.values()] == list(ARM_METHODS) == list(ctrl)
    assert all(m == m.lower() and " " not in m for m in ARM_METHODS)
    assert [method_label(m) for m in ARM_METHODS] == [
        "no limit",
        "per-joint clamp",
        "scalar scale",
        "damper QP",
        "velfence",
    ]
    assert method_label("exact") == "exact"


@pytest.mark.parametrize(
    ("old", "new"),
    [
        ("no limit", "no-limit"),
        ("per-joint clamp", "per-joint-clamp"),
        ("scalar scale", "scalar-scale"),
        ("damper QP", "velocity-damper-qp"),
        ("velfence", "safety-filter"),
    ],
)
def test_old_method_names_are_accepted_with_a_warning(old: str, new: str):
    from velfence.apps.demo.arm_box import arm_box_scene, arm_methods, build_arm_controllers

    with pytest.warns(DeprecationWarning, match=rf"'{old}' is now '{new}'.*goes in 0\.3"):
        assert arm_methods([old]) == (new,)
    if new == "velocity-damper-qp":
        pytest.importorskip("qpsolvers")
    with pytest.warns(DeprecationWarning, match=rf"'{old}' is now '{new}'"):
        ctrl = build_arm_controllers(arm_box_scene(), methods=[old])
    assert list(ctrl) == [new]
    assert ctrl[new].method == new
    with pytest.raises(InvalidParameter, match="expected names from"):
        arm_methods(["no such method"])


def test_tcp_jog_is_the_arm_box_operator_on_any_kinematics():
    from velfence.apps.demo.arm_box import arm_box_scene, arm_jog, arm_script
    from velfence.sim.scenarios import TcpJog

    scene = arm_box_scene()
    script = arm_script(scene, 0.25)
    jog = arm_jog(scene.robot, script)
    assert isinstance(jog, TcpJog)
    for ph in script.phases:
        np.testing.assert_array_equal(jog.target(ph.t1 - 1e-6), ph.target)
    np.testing.assert_array_equal(jog.target(1e9), script.phases[-1].target)
    # Far from the target: the jog speed along the error; near it: gain * distance.
    v = jog(0.0, scene.q0)
    e = script.phases[0].target - scene.robot.end_effector(scene.q0)
    assert np.linalg.norm(v) == pytest.approx(0.25)
    np.testing.assert_allclose(v / np.linalg.norm(v), e / np.linalg.norm(e))
    near = TcpJog(lambda q: np.zeros(3), [(1.0, (0.01, 0.0, 0.0))], speed=1.0, gain=8.0)
    np.testing.assert_allclose(near(0.0, np.zeros(2)), [0.08, 0.0, 0.0])


@pytest.mark.parametrize(
    ("args", "kwargs"),
    [
        ((None, [(1.0, (0, 0, 0))]), {"speed": 1.0}),
        ((np.zeros, []), {"speed": 1.0}),
        ((np.zeros, [(2.0, (0, 0, 0)), (1.0, (0, 0, 0))]), {"speed": 1.0}),
        ((np.zeros, [(1.0, (0, 0))]), {"speed": 1.0}),
        ((np.zeros, [(float("nan"), (0, 0, 0))]), {"speed": 1.0}),
        ((np.zeros, [(1.0, (0, 0, 0))]), {"speed": 0.0}),
        ((np.zeros, "abc"), {"speed": 1.0}),
    ],
)
def test_tcp_jog_refuses_bad_arguments(args: tuple[object, ...], kwargs: dict[str, object]):
    from velfence.sim.scenarios import TcpJog

    with pytest.raises(InvalidParameter):
        TcpJog(*args, **kwargs)  # type: ignore[arg-type]


def test_tcp_jog_refuses_a_bad_time():
    from velfence.sim.scenarios import TcpJog

    jog = TcpJog(lambda q: np.zeros(3), [(1.0, (0, 0, 0))], speed=1.0)
    with pytest.raises(InvalidInput):
        jog.target(float("inf"))
