"""Bad inputs to the redundancy controllers raise library errors that name the argument."""

import inspect
import math

import numpy as np
import pytest

from bad_inputs import BAD_VECTORS
from velfence.errors import InvalidInput, InvalidParameter
from velfence.filter import SphereObstacle
from velfence.mechanisms import PlanarArm
from velfence.redundancy import ConfigurationController, ControlResult

BAD = {
    **BAD_VECTORS,
    "wrong-shape": np.zeros((2, 2, 2)),
}


@pytest.mark.parametrize("kind", sorted(BAD))
def test_obstacle_center(kind: str):
    with pytest.raises(InvalidParameter, match=r"^center: "):
        SphereObstacle(BAD[kind], radius=0.1, influence=0.3)


@pytest.mark.parametrize("value", ["0.1", True, 1j, math.nan, 10**400, None])
@pytest.mark.parametrize("field", ["radius", "influence"])
def test_obstacle_sizes(value: object, field: str):
    if field == "influence" and value is None:
        pytest.skip("influence=None is valid: an obstacle without a sphere of influence")
    args: dict[str, object] = {"radius": 0.1, "influence": 0.3, field: value}
    with pytest.raises(InvalidParameter, match=rf"^{field}"):
        SphereObstacle([0.0, 0.0], **args)  # type: ignore[arg-type]


def test_obstacle_and_result_are_keyword_only():
    with pytest.raises(TypeError):
        SphereObstacle([0.0, 0.0], 0.1, 0.3)  # type: ignore[misc]
    for cls in (SphereObstacle, ControlResult):
        params = list(inspect.signature(cls).parameters.values())
        for p in params[1:] if cls is SphereObstacle else params:
            assert p.kind is inspect.Parameter.KEYWORD_ONLY, (cls.__name__, p.name)


@pytest.mark.parametrize("kind", sorted(BAD))
@pytest.mark.parametrize("arg", ["position", "command", "ee_target"])
def test_control_names_the_argument(kind: str, arg: str):
    ctl = ConfigurationController(PlanarArm((1.0, 1.0, 1.0)), [])
    args: dict[str, object] = {"position": np.zeros(3), "command": np.zeros(2), arg: BAD[kind]}
    if kind == "None" and arg == "ee_target":
        return  # ee_target=None is "no target"
    with pytest.raises(InvalidInput, match=rf"^{arg}: "):
        ctl.control(**args)  # type: ignore[arg-type]


@pytest.mark.parametrize("kind", ["str", "dict", "complex", "ragged", "huge-int"])
def test_shape_batch_names_positions_and_commands(kind: str):
    ctl = ConfigurationController(PlanarArm((1.0, 1.0, 1.0)), [])
    with pytest.raises(InvalidInput, match=r"^positions: "):
        ctl.shape_batch(BAD[kind], np.zeros((1, 2)))
    with pytest.raises(InvalidInput, match=r"^commands: "):
        ctl.shape_batch(np.zeros((1, 3)), BAD[kind])


def test_obstacles_refuse_a_string_and_name_the_bad_entries():
    with pytest.raises(
        InvalidParameter, match=r"obstacles must be a sequence of SphereObstacle, got str"
    ):
        ConfigurationController(PlanarArm([1.0, 1.0, 1.0]), "")
    with pytest.raises(InvalidParameter, match=r"got list containing float"):
        ConfigurationController(PlanarArm([1.0, 1.0, 1.0]), [1.0])


def test_obstacle_center_must_be_one_point():
    with pytest.raises(InvalidParameter, match=r"center: .*got shape \(1, 2\)"):
        SphereObstacle(center=np.array([[1.0, 1.0]]), radius=0.1, influence=0.3)


def test_shape_batch_names_the_row():
    c = ConfigurationController(PlanarArm([1.0, 1.0, 1.0]), [])
    Q = np.array([[0.3, 0.4, -0.2], [np.nan, 0.4, -0.2]])
    with pytest.raises(InvalidInput, match=r"positions, commands row 1: "):
        c.shape_batch(Q, np.zeros((2, 2)))


def test_one_obstacle_class_serves_the_filter_and_configuration_control():
    from velfence.filter import ObstacleRows

    ob = SphereObstacle([1.5, -1.4], radius=0.05, influence=0.2, name="post")
    # The filter reads the body only (its own obstacle_buffer sets the margin) ...
    rows = ObstacleRows(
        [ob], np.array([0.0, 0.0, 0.0]), buffer=0.05, spring_gain=1.0, max_speed=1.0
    )
    assert rows.obstacles[0] is ob
    # ... and configuration control reads the sphere of influence.
    ctl = ConfigurationController(PlanarArm([1.0, 1.0, 1.0]), [ob])
    assert ctl.obstacles == (ob,)


def test_configuration_control_refuses_an_obstacle_without_influence():
    bare = SphereObstacle([1.5, -1.4], radius=0.05)
    with pytest.raises(InvalidParameter, match=r"obstacles \[1\]: .*sphere of influence"):
        ConfigurationController(
            PlanarArm([1.0, 1.0, 1.0]),
            [SphereObstacle([0.0, 2.0], radius=0.0, influence=0.1), bare],
        )


def test_influence_must_surround_the_body():
    with pytest.raises(InvalidParameter, match=r"influence must exceed radius"):
        SphereObstacle([0.0, 0.0], radius=0.3, influence=0.3)
