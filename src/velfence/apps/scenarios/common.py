"""What every physics scenario returns: its runs, metrics and named checks."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from velfence._deprecate import method_name
from velfence._typing import FloatArray
from velfence._validate import describe
from velfence.apps.reproduce.base import Report
from velfence.errors import InvalidParameter
from velfence.sim.physics import PhysicsRecord
from velfence.sim.runner import Trajectory

__all__ = ["SCENARIOS", "PhysicsRun", "ScenarioResult", "scenario_methods"]

#: The scenarios of ``velfence sim --scenario NAME``.
SCENARIOS: tuple[str, ...] = ("fence-box", "wrist-push", "redundant-obstacle", "person-cell")


@dataclass(frozen=True, eq=False)
class PhysicsRun:
    """One controller's run in MuJoCo.

    Attributes:
        method: The controller's name (``"safety-filter"``, ``"no-limit"``, ...).
        trajectory: The runner's record (``p`` = state joints, ``v_out`` = references).
        record: What the physics did (qpos for rendering, contacts, efforts).
        model: The plant's ``mujoco.MjModel`` (obstacle geoms included), for rendering.
        point: The tracked point (TCP, or the wrist's (pitch, yaw)), shape (N, k).
        extra: Scenario-specific series (e.g. ``"y_d"``, the reference path, shape (N, 3)).
    """

    method: str
    trajectory: Trajectory
    record: PhysicsRecord
    model: Any
    point: FloatArray
    extra: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True, eq=False)
class ScenarioResult:
    """A scenario's runs, metrics and named checks.

    Attributes:
        name: Scenario name (one of :data:`SCENARIOS`).
        runs: Method -> run, in table order.
        metrics: Method -> metric name -> value (units in ``units``).
        units: Metric name -> unit.
        report: The named checks (``velfence reproduce``'s JSON format).
        scene: What the figures and videos draw: ``"polytope"`` (a ConvexPolytope),
            ``"spheres"`` (list of (centre, radius)), ``"polygon"`` (a ConvexPolygon) as present;
            ``"camera"``: keyword arguments of :func:`velfence.apps.viz.video.render_frames`
            (``lookat``, ``distance``, ``azimuth``, ``elevation``) for the video; ``"figures"``:
            file name -> ``(result, path) -> path``, the scenario's own figures;
            ``"person"``: ``times -> (axes (N, K, 2, 3), radii (K,))``, moving capsules the
            video draws (a person's body parts).
    """

    name: str
    runs: Mapping[str, PhysicsRun]
    metrics: Mapping[str, Mapping[str, float]]
    units: Mapping[str, str]
    report: Report
    scene: Mapping[str, Any]


def scenario_methods(methods: object, known: tuple[str, ...]) -> tuple[str, ...]:
    """Names from ``known``, at least one; a run name before 0.2 warns and is translated.

    Args:
        methods: A list or tuple of run names (``"safety-filter"``, ...; the former
            ``"velfence"``, ``"no limit"``, ... warn until 0.3).
        known: The scenario's run names.

    Returns:
        The names, in the given order.

    Raises:
        InvalidParameter: not a list of known names, or an empty one.
    """
    if isinstance(methods, (str, bytes)) or not isinstance(methods, (list, tuple)) or not methods:
        raise InvalidParameter(
            f"methods: expected a non-empty list of names from {list(known)}, got "
            f"{describe(methods)}"
        )
    out = [method_name(m, what="scenario method name", stacklevel=5) for m in methods]
    unknown = [m for m in out if not isinstance(m, str) or m not in known]
    if unknown:
        raise InvalidParameter(
            f"methods: expected names from {list(known)}, got {describe(unknown)}"
        )
    return tuple(str(m) for m in out)
