"""Bad inputs to the mechanisms raise library errors that name the public argument."""

import datetime
import inspect
import math

import numpy as np
import pytest

from velfence.errors import InvalidGeometry, InvalidInput, InvalidParameter
from velfence.mechanisms import (
    CoSPM,
    CoSPMDesign,
    DHChain,
    PlanarArm,
    Puma560,
    Wrist,
    WristGeometry,
    singular_curves,
    stops_polygon,
    validate_region,
    workspace_map,
)

BAD = {
    "str": "12",
    "bytes": b"12",
    "dict": {"x": 1.0},
    "bool": True,
    "complex": 1j,
    "object": np.array([object()], dtype=object),
    "datetime": datetime.datetime(2020, 1, 1),
    "ragged": [[1.0, 2.0], [3.0]],
    "huge-int": 10**400,
    "nan": math.nan,
    "inf": math.inf,
}
KINDS = sorted(BAD)


def _vec(kind: str, n: int) -> object:
    """A length-n "vector" of the bad kind (numbers in it where that makes sense)."""
    if kind in ("huge-int", "nan", "inf"):
        return [BAD[kind]] + [0.0] * (n - 1)
    if kind == "complex":
        return np.full(n, 1j)
    return BAD[kind]


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("field", ["lengths", "base", "joint_limits", "link_radius"])
def test_planar_arm_constructor(kind: str, field: str):
    ok: dict[str, object] = {"lengths": (1.0, 1.0)}
    shapes = {"lengths": 2, "base": 2, "joint_limits": 2, "link_radius": 2}
    ok[field] = _vec(kind, shapes[field])
    if field == "joint_limits" and kind in ("huge-int", "nan", "inf"):
        ok[field] = [[-1.0, BAD[kind]], [-1.0, 1.0]]
    if field == "link_radius" and kind in ("nan", "inf", "huge-int"):
        ok[field] = BAD[kind]
    with pytest.raises((InvalidGeometry, InvalidParameter), match=rf"^{field}"):
        PlanarArm(**ok)  # type: ignore[arg-type]


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("field", ["dh", "tool"])
def test_dh_chain_constructor(kind: str, field: str):
    ok: dict[str, object] = {"dh": [[0.0, 0.0, 1.0, 0.0]]}
    ok[field] = [_vec(kind, 4)] if field == "dh" and kind in ("huge-int", "nan", "inf") else None
    if ok[field] is None:
        ok[field] = _vec(kind, 3)
    with pytest.raises(InvalidGeometry, match=rf"^{field}: "):
        DHChain(**ok)  # type: ignore[arg-type]


@pytest.mark.parametrize("kind", KINDS)
def test_chain_methods_name_q_and_t(kind: str):
    arm = PlanarArm((1.0, 1.0, 1.0))
    with pytest.raises(InvalidInput, match=r"^q: "):
        arm.end_effector(_vec(kind, 3))  # type: ignore[arg-type]
    if kind != "inf":  # t = inf is "not in [0, 1]", named too
        with pytest.raises(InvalidInput, match=r"^t: "):
            arm.point_jacobian(np.zeros(3), 0, BAD[kind])  # type: ignore[arg-type]


@pytest.mark.parametrize("kind", KINDS)
def test_puma_ik_nearest_names_q_ref(kind: str):
    robot = Puma560()
    T = robot.fk(np.array([0.1, -0.5, 0.4, 0.2, -0.6, 0.3]))
    with pytest.raises(InvalidInput, match=r"^q_ref: "):
        robot.ik_nearest(T, _vec(kind, 6))  # type: ignore[arg-type]


@pytest.mark.parametrize("bad", [np.array(["fu"]), 1, None, b"fu", ["fu"]])
def test_puma_labels_refuse_non_strings(bad: object):
    with pytest.raises(InvalidParameter, match=r"^convention must be one of"):
        Puma560(convention=bad)  # type: ignore[arg-type]
    with pytest.raises(InvalidParameter, match=r"^shoulder must be one of"):
        Puma560().ik(np.eye(4), shoulder=bad)  # type: ignore[arg-type]


@pytest.mark.parametrize("bad", ["yes", 1, None, np.array([True])])
def test_puma_respect_limits_is_a_bool(bad: object):
    robot = Puma560()
    T = robot.fk(np.array([0.1, -0.5, 0.4, 0.2, -0.6, 0.3]))
    with pytest.raises(InvalidParameter, match=r"^respect_limits: expected True or False"):
        robot.ik_all(T, respect_limits=bad)  # type: ignore[arg-type]


@pytest.mark.parametrize("kind", KINDS)
def test_puma_tool(kind: str):
    with pytest.raises(InvalidGeometry, match=r"^tool: "):
        Puma560(tool=_vec(kind, 3))  # type: ignore[arg-type]


@pytest.mark.parametrize("kind", [k for k in KINDS if k != "bool"])
@pytest.mark.parametrize("field", ["anchor_setback", "max_actuator_speed", "wire_azimuth"])
def test_wrist_geometry_fields(kind: str, field: str):
    with pytest.raises((InvalidGeometry, InvalidParameter), match=rf"^WristGeometry\.{field}: "):
        WristGeometry(**{field: BAD[kind]})  # type: ignore[arg-type]


@pytest.mark.parametrize("cls", [Wrist, CoSPM])
@pytest.mark.parametrize("value", [10**6, 10**400, 2.5, True])
def test_fk_max_iter_is_bounded(cls: type, value: object):
    with pytest.raises(InvalidParameter, match=r"^fk_max_iter: "):
        cls(fk_max_iter=value)


@pytest.mark.parametrize("kind", KINDS)
def test_wrist_methods(kind: str):
    wrist = Wrist()
    with pytest.raises(InvalidInput, match=r"^q: "):
        wrist.actuator_lengths(_vec(kind, 2))  # type: ignore[arg-type]
    with pytest.raises(InvalidInput, match=r"^pitch: "):
        wrist.feasible_grid(_vec(kind, 2), [0.0])  # type: ignore[arg-type]


def test_constructors_with_defaults_are_keyword_only():
    for cls in (Wrist, CoSPM, PlanarArm, DHChain, Puma560):
        for p in inspect.signature(cls).parameters.values():
            if p.default is not inspect.Parameter.empty:
                assert p.kind is inspect.Parameter.KEYWORD_ONLY, (cls.__name__, p.name)
    with pytest.raises(TypeError):
        Wrist(WristGeometry())  # type: ignore[misc]
    with pytest.raises(TypeError):
        CoSPM(CoSPMDesign.table1())  # type: ignore[misc]


@pytest.mark.parametrize("kind", [k for k in KINDS if k not in ("bool",)])
@pytest.mark.parametrize("field", ["alpha1", "beta2"])
def test_cospm_design_fields(kind: str, field: str):
    d = CoSPMDesign.table1()
    args = {"alpha1": d.alpha1, "alpha2": d.alpha2, "eta": d.eta, "beta1": 0.0, "beta2": 1.5}
    args[field] = _vec(kind, 3) if field == "alpha1" else BAD[kind]
    with pytest.raises(InvalidGeometry, match=rf"^CoSPMDesign\.{field}: "):
        CoSPMDesign(**args)  # type: ignore[arg-type]


@pytest.mark.parametrize("kind", KINDS)
def test_cospm_methods(kind: str):
    m = CoSPM()
    theta, chi = m.home()
    with pytest.raises(InvalidInput, match=r"^chi: "):
        m.jacobian(theta, _vec(kind, 3))  # type: ignore[arg-type]
    with pytest.raises(InvalidInput, match=r"^eps: "):
        m.bearing_shift(theta, chi, BAD[kind])  # type: ignore[arg-type]
    with pytest.raises(InvalidParameter, match=r"^modes: "):
        m.inverse_kinematics(chi, modes=_vec(kind, 3))  # type: ignore[arg-type]
    with pytest.raises(InvalidGeometry, match=r"^stops: "):
        stops_polygon(
            _vec(kind, 3) if kind not in ("nan", "inf", "huge-int") else [[BAD[kind]] * 3] * 3
        )


@pytest.mark.parametrize("theta", [[1e100, 0.0, 0.0], [1e4, 0.0, 0.0]])
def test_cospm_far_continuation_is_refused_before_the_loop(theta: list[float]):
    with pytest.raises(InvalidInput, match=r"^theta: expected joint angles within 100,000"):
        CoSPM().forward_kinematics(theta)


def test_cospm_tiny_fk_step_is_refused_at_the_call():
    m = CoSPM(fk_step=5e-324)
    theta, _ = m.home()
    with pytest.raises(InvalidInput, match=r"^theta: .*fk_step = 4.94066e-324 rad"):
        m.forward_kinematics(theta + np.array([0.1, 0.0, 0.0]))


@pytest.mark.parametrize(
    ("call", "name"),
    [(lambda: validate_region(step=5e-324), "step"),
     (lambda: validate_region(step=0.2, workspace_step=1e-300), "workspace_step"),
     (lambda: singular_curves(step=1e-300), "step"),
     (lambda: workspace_map(step=5e-324), "step")],
)  # fmt: skip
def test_region_grids_are_bounded_before_allocation(call, name: str):
    with pytest.raises(InvalidParameter, match=rf"^{name}: expected a grid of at most 1,000,000"):
        call()


@pytest.mark.parametrize("kind", KINDS)
def test_region_tool_options(kind: str):
    with pytest.raises(InvalidParameter, match=r"^theta3: "):
        singular_curves(step=0.5, theta3=BAD[kind])
    with pytest.raises(InvalidParameter, match=r"^window: "):
        singular_curves(step=0.5, window=_vec(kind, 4))  # type: ignore[arg-type]
    with pytest.raises(InvalidParameter, match=r"^bank: "):
        workspace_map(step=0.5, bank=_vec(kind, 2))  # type: ignore[arg-type]
    with pytest.raises(InvalidParameter, match=r"^(workspace|banks): "):
        validate_region(step=0.5, workspace=_vec(kind, 4), banks=_vec(kind, 1))  # type: ignore[arg-type]
