"""Every public cobot input goes through velfence._validate: library errors naming the argument."""

from __future__ import annotations

import datetime
import math
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

from bad_inputs import HugeLen, RaisingArray
from velfence.cobot import (
    Cobot,
    Coupling,
    IdentityKinematics,
    PathFollower,
    RThetaKinematics,
    SteeredWheel,
    TetrahedralCVT,
    gains_from_poles,
    generalised_cross,
    r_theta_cobot,
    unicycle,
)
from velfence.errors import InvalidInput, InvalidParameter, VelfenceError
from velfence.geometry.paths import Line
from velfence.sim.cobot import constant_speed, follow_in_ee, pushing, simulate_cobot

BAD_VECTORS: list[Any] = [
    "12",
    "abc",
    b"12",
    {"a": 1},
    None,
    True,
    np.array([1j, 1j]),
    np.array(["a", 1], dtype=object),
    datetime.datetime(2020, 1, 1),
    [[1.0, 2.0], [3.0]],
    np.zeros(0),
    [math.nan, 0.0],
    [math.inf, 0.0],
    [10**400, 0.0],
    np.zeros((2, 2, 2)),
]
BAD_SCALARS: list[Any] = [
    "12",
    b"12",
    {"a": 1},
    None,
    True,
    1j,
    datetime.datetime(2020, 1, 1),
    math.nan,
    math.inf,
    -math.inf,
    1e308,
    10**400,
    np.zeros(2),
]
LINE = Line((0.0, 0.0), (1.0, 0.0))


def _follower() -> PathFollower:
    f = PathFollower(LINE)
    f.reset([0.0, 0.1])
    return f


VECTOR_CALLS: list[tuple[str, Callable[[Any], object]]] = [
    ("t", lambda x: SteeredWheel().steering_angle(x)),
    ("t", lambda x: TetrahedralCVT().steering_angle(x)),
    ("R", lambda x: RThetaKinematics().joints(x)),
    ("q", lambda x: RThetaKinematics().position(x)),
    ("R", lambda x: RThetaKinematics().jacobian(x)),
    ("R", lambda x: IdentityKinematics(n=2).joints(x)),
    ("q", lambda x: IdentityKinematics(n=2).position(x)),
    ("Omega", generalised_cross),
    ("R", lambda x: _follower().evaluate(x, [1.0, 0.0])),
    ("T", lambda x: _follower().step([0.0, 0.1], x, 0.01)),
    ("phi", lambda x: r_theta_cobot().heading([0.5, 0.2], x)),
    ("q", lambda x: r_theta_cobot().heading(x, [0.3])),
    ("R", lambda x: r_theta_cobot().steering_angles(x, [1.0, 0.0])),
    ("kN", lambda x: r_theta_cobot().steering_rates([0.5, 0.2], [0.3], [1.0, 0.0], x, 0.1)),
    ("R0", lambda x: follow_in_ee(_follower(), x, [1.0, 0.0], length=0.02, ds=0.01)),
    ("T0", lambda x: follow_in_ee(_follower(), [0.0, 0.1], x, length=0.02, ds=0.01)),
    (
        "q0",
        lambda x: simulate_cobot(
            unicycle(), _follower(), x, [0.0], speed=constant_speed(0.1), duration=0.02, dt=0.01
        ),
    ),
    ("selection", lambda x: Coupling(SteeredWheel(), selection=x)),
]


@pytest.mark.parametrize("bad", BAD_VECTORS, ids=repr)
@pytest.mark.parametrize(("name", "call"), VECTOR_CALLS, ids=[n for n, _ in VECTOR_CALLS])
def test_bad_vectors_raise_library_errors_naming_the_argument(
    name: str, call: Callable[[Any], object], bad: Any
) -> None:
    if name == "Omega" and isinstance(bad, np.ndarray) and bad.shape == (2, 2, 2):
        bad = np.zeros((2, 2, 2, 2))
    if name == "selection" and bad is None:
        pytest.skip("selection=None means 'not given' (the jacobian form)")
    with pytest.raises(VelfenceError, match=rf"^{name}\b"):
        call(bad)


SCALAR_CALLS: list[tuple[str, Callable[[Any], object]]] = [
    ("phi", lambda x: SteeredWheel().direction(x)),
    ("phi", lambda x: SteeredWheel().angle_rate(x)),
    ("curvature", lambda x: SteeredWheel().steering_rate(0.1, x, 1.0)),
    ("speed", lambda x: TetrahedralCVT().steering_rate(0.1, 0.5, x)),
    ("p1", lambda x: gains_from_poles(x, -2.0)),
    ("p2", lambda x: gains_from_poles(-2.0, x)),
    ("ds", lambda x: _follower().step([0.0, 0.1], [1.0, 0.0], x)),
    ("t", lambda x: _follower().step([0.0, 0.1], [1.0, 0.0], 0.01, x)),
    ("speed", lambda x: r_theta_cobot().steering_rates([0.5, 0.2], [0.3], [1, 0], [0, 1], x)),
    ("ds", lambda x: follow_in_ee(_follower(), [0.0, 0.1], [1.0, 0.0], length=0.02, ds=x)),
    (
        "dt",
        lambda x: simulate_cobot(
            unicycle(), _follower(), [0, 0.1], [0.0], speed=constant_speed(0.1), duration=0.02, dt=x
        ),
    ),
]


@pytest.mark.parametrize("bad", BAD_SCALARS, ids=repr)
@pytest.mark.parametrize(("name", "call"), SCALAR_CALLS, ids=[n for n, _ in SCALAR_CALLS])
def test_bad_scalars_raise_library_errors_naming_the_argument(
    name: str, call: Callable[[Any], object], bad: Any
) -> None:
    if name in ("p1", "p2") and isinstance(bad, complex):
        bad = complex(1.0, 1.0)  # a complex pole is valid; an unstable one is not
    if name == "t" and bad is None:
        pytest.skip("t=None is the documented default")
    with pytest.raises(VelfenceError, match=rf"{name}\b"):
        call(bad)


@pytest.mark.parametrize(
    ("call", "name"),
    [
        (
            lambda: follow_in_ee(_follower(), [0.0, 0.1], [1.0, 0.0], length=1.0, ds=1e-308),
            "length",
        ),
        (
            lambda: follow_in_ee(_follower(), [0.0, 0.1], [1.0, 0.0], length=1e308, ds=1e-3),
            "length",
        ),
        (
            lambda: simulate_cobot(
                unicycle(),
                _follower(),
                [0, 0.1],
                [0.0],
                speed=constant_speed(0.1),
                duration=1.0,
                dt=1e-308,
            ),
            "duration",
        ),
        (
            lambda: simulate_cobot(
                unicycle(),
                _follower(),
                [0, 0.1],
                [0.0],
                speed=constant_speed(0.1),
                duration=1e149,
                dt=1e-3,
            ),
            "duration",
        ),
    ],
)
def test_step_counts_are_refused_before_any_work(call: Callable[[], object], name: str) -> None:
    with pytest.raises(InvalidParameter, match=rf"{name}(=.* steps; at most| must be <=)"):
        call()


def test_controllers_humans_and_labels_are_checked() -> None:
    with pytest.raises(InvalidParameter, match="controller: expected a heading controller"):
        follow_in_ee(object(), [0.0, 0.1], [1.0, 0.0], length=0.02)  # type: ignore[arg-type]
    with pytest.raises(InvalidParameter, match="cobot: expected a Cobot"):
        simulate_cobot(
            "unicycle",  # type: ignore[arg-type]
            _follower(),
            [0, 0.1],
            [0.0],
            speed=constant_speed(0.1),
            duration=0.02,
        )
    with pytest.raises(InvalidParameter, match="intent: expected a function"):
        pushing(3.0)  # type: ignore[arg-type]
    human = pushing(lambda t, R: "fast")
    with pytest.raises(InvalidInput, match=r"intent\(t, R\): expected a velocity"):
        human(0.0, np.zeros(2), np.array([1.0, 0.0]))
    with pytest.raises(InvalidInput, match=r"speed\(t, R, T\): expected a finite speed"):
        simulate_cobot(
            unicycle(), _follower(), [0, 0.1], [0.0], speed=lambda t, R, T: math.nan, duration=0.02
        )
    with pytest.raises(InvalidParameter, match="name: expected a str label"):
        Cobot(IdentityKinematics(n=2), [Coupling(SteeredWheel(), selection=np.eye(2))], name=3)  # type: ignore[arg-type]
    with pytest.raises(InvalidParameter, match="couplings: expected a sequence"):
        Cobot(IdentityKinematics(n=2), 5)  # type: ignore[arg-type]
    with pytest.raises(InvalidParameter, match="gains: expected"):
        PathFollower(LINE, gains=b"12")  # type: ignore[arg-type]
    with pytest.raises(InvalidParameter, match="convention"):
        TetrahedralCVT(convention=np.array([1, -1]))  # type: ignore[arg-type]


def test_huge_python_ints_are_refused_not_overflowing() -> None:
    with pytest.raises(InvalidInput, match=r"^R: expected .*magnitude <= 1e\+150"):
        RThetaKinematics().joints([10**400, 0])


@pytest.mark.parametrize(
    "make",
    [
        lambda: IdentityKinematics(2),  # type: ignore[misc]
        lambda: Coupling(SteeredWheel(), np.eye(2)),  # type: ignore[misc]
    ],
)
def test_tuning_parameters_are_keyword_only(make: Callable[[], object]) -> None:
    with pytest.raises(TypeError, match="positional"):
        make()


@pytest.mark.parametrize("bad", [HugeLen(), RaisingArray(), range(2), iter([1.0, 2.0])])
def test_odd_sequences_are_refused_by_name(bad: Any) -> None:
    with pytest.raises(InvalidInput, match=r"^phi: expected"):
        r_theta_cobot().directions(bad)


def test_coupling_maps_validates_its_inputs() -> None:
    c = Coupling(TetrahedralCVT(), selection=np.diag([2.0, 1.0]))
    J_i, H_i = c.maps([0.8, 0.3], np.eye(2), np.zeros((2, 2, 2)))
    np.testing.assert_array_equal(J_i, np.diag([2.0, 1.0]))
    assert H_i.shape == (2, 2, 2)
    with pytest.raises(InvalidInput, match=r"^J: expected shape \(2, 2\)"):
        c.maps([0.8, 0.3], np.eye(3), np.zeros((2, 2, 2)))
    with pytest.raises(InvalidInput, match=r"^H: expected finite"):
        c.maps([0.8, 0.3], np.eye(2), np.full((2, 2, 2), math.nan))
    with pytest.raises(InvalidInput, match=r"^R: expected shape \(2,\)"):
        c.maps([0.8, 0.3, 0.1], np.eye(2), np.zeros((2, 2, 2)))


def test_r_theta_near_the_pivot_is_finite_or_refused_by_name() -> None:
    kin = RThetaKinematics()
    J = kin.jacobian([1e-50, 0.0])
    H = kin.hessian([1e-50, 0.0])
    assert np.all(np.isfinite(J))
    assert np.all(np.isfinite(H))
    assert J[1, 1] == pytest.approx(1e50)
    with pytest.raises(InvalidInput, match=r"^R: .*singular at the pivot"):
        kin.jacobian([5e-324, 5e-324])
    with pytest.raises(InvalidInput, match=r"^q: .*singular at the pivot"):
        r_theta_cobot().heading([5e-324, 0.3], [0.3])


def test_convention_is_a_sign_of_any_real_type() -> None:
    assert TetrahedralCVT(convention=np.float64(-1.0)).convention == -1
    assert type(TetrahedralCVT(convention=np.int64(1)).convention) is int
    with pytest.raises(InvalidParameter, match=r"convention: expected \+1 or -1"):
        TetrahedralCVT(convention=np.timedelta64(1, "s"))  # type: ignore[arg-type]


def test_transform_shape_mismatch_names_both_arguments() -> None:
    from velfence.cobot import coupling_from_joint, normalised_derivative

    with pytest.raises(InvalidInput, match=r"^S: .*n = len\(T_J\) = 3.*S and T_J must agree"):
        coupling_from_joint(np.eye(2), [1.0, 0.0, 0.0], [0.0, 0.0, 0.0])
    with pytest.raises(InvalidInput, match=r"^x_prime: expected the shape of x"):
        normalised_derivative([1.0, 0.0], [0.0, 1.0, 2.0])
    with pytest.raises(InvalidInput, match=r"^x: .*too small"):
        normalised_derivative([5e-324, 0.0], [0.0, 1.0])


def test_wall_steering_step_inputs() -> None:
    from velfence.cobot import CasterWall, WallSteering
    from velfence.geometry.polygon import ConvexPolygon

    square = ConvexPolygon([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]])
    ws = WallSteering(CasterWall(square, buffer=0.2), lambda t, R: np.array([1.0, 0.2]))
    out = ws.step([0.5, 0.2], [1.0, 0.0], 0.0)
    assert np.all(np.isfinite(out.kN))
    with pytest.raises(InvalidInput, match=r"^R: expected"):
        ws.step("12", [1.0, 0.0], 0.01)
    with pytest.raises(InvalidInput, match=r"^t: expected a time >= 0"):
        ws.step([0.5, 0.2], [1.0, 0.0], 0.01, -1.0)
    with pytest.raises(InvalidInput, match=r"^ds: expected"):
        ws.step([0.5, 0.2], [1.0, 0.0], -0.01)
    with pytest.raises(InvalidParameter, match=r"^intent: expected a function"):
        WallSteering(CasterWall(square, buffer=0.2), float)  # type: ignore[arg-type]
    with pytest.raises(InvalidParameter, match=r"lookahead/gain"):
        WallSteering(CasterWall(square, buffer=0.2), lambda t, R: R, gain=1e-300, lookahead=1.0)
