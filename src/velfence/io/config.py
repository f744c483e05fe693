"""Validated configuration of the demo scenario (YAML or JSON file, or built-in defaults).

Every field has a unit and a range; a bad file raises :class:`~velfence.errors.InvalidParameter`
whose message names the field (``waypoints.2.speed: Input should be greater than 0``).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from velfence.errors import InvalidParameter

__all__ = ["DemoConfig", "PushSpec", "ShaperSettings", "WaypointSpec", "load_config"]

Pair = tuple[float, float]
Method = Literal["none", "hard-stop", "axis-limits", "patent", "exact"]
ALL_METHODS: tuple[Method, ...] = ("none", "hard-stop", "axis-limits", "patent", "exact")


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class ShaperSettings(_Strict):
    """Tuning shared by the shapers of the demo (workspace units are [rad] on the wrist)."""

    buffer: Annotated[float, Field(gt=0, description="buffer width d_max [rad]")] = 0.08
    spring_gain: Annotated[float, Field(ge=0, description="virtual spring gain k [1/s]")] = 8.0
    corner_blend_angle: Annotated[
        float, Field(gt=0, lt=math.pi, description="patent θ_max [rad]")
    ] = 0.3
    max_recovery_speed: Annotated[
        float | None, Field(gt=0, description="exact: cap on recovery speed [rad/s]")
    ] = None


class WaypointSpec(_Strict):
    """From time ``t`` [s] the operator heads for ``target`` [rad] at up to ``speed`` [rad/s]."""

    t: Annotated[float, Field(ge=0)]
    target: Pair
    speed: Annotated[float, Field(gt=0)]


class PushSpec(_Strict):
    """An external velocity disturbance ``velocity`` [rad/s] during ``[t0, t1)`` [s]."""

    t0: Annotated[float, Field(ge=0)]
    t1: Annotated[float, Field(gt=0)]
    velocity: Pair

    @model_validator(mode="after")
    def _ordered(self) -> PushSpec:
        if self.t1 <= self.t0:
            raise ValueError(f"t1 must be after t0, got t0={self.t0}, t1={self.t1}")
        return self


class DemoConfig(_Strict):
    """The demo scenario. Fields left out take the built-in defaults.

    ``polygon: null`` means the wrist's default polygon; ``start``, ``waypoints`` and ``pushes``
    left null are generated from the polygon's features (longest edge, most acute and most obtuse
    corner) by :func:`velfence.sim.scenarios.default_script`.
    """

    polygon: list[Pair] | None = None
    shaper: ShaperSettings = ShaperSettings()
    methods: list[Method] = Field(default_factory=lambda: list(ALL_METHODS), min_length=1)
    dt: Annotated[float, Field(gt=0, le=0.1, description="control period [s]")] = 1e-3
    duration: Annotated[float | None, Field(gt=0, description="[s]")] = None
    start: Pair | None = None
    waypoints: list[WaypointSpec] | None = None
    pushes: list[PushSpec] | None = None
    noise_std: Annotated[float, Field(ge=0, description="position noise [rad]")] = 0.0
    seed: int = 0
    saturate: bool = True
    gif: bool = True

    @model_validator(mode="after")
    def _check(self) -> DemoConfig:
        if self.polygon is not None and len(self.polygon) < 3:
            raise ValueError(f"polygon needs at least 3 corners, got {len(self.polygon)}")
        if self.waypoints is not None:
            if not self.waypoints:
                raise ValueError("waypoints must not be empty (leave it out for the default)")
            ts = [w.t for w in self.waypoints]
            if ts != sorted(ts):
                raise ValueError(f"waypoints must be in time order, got t = {ts}")
        return self


def _describe(err: ValidationError) -> str:
    lines = []
    for e in err.errors():
        loc = ".".join(str(x) for x in e["loc"]) or "(top level)"
        lines.append(f"{loc}: {e['msg']}")
    return "; ".join(lines)


def load_config(path: str | Path | None = None, **overrides: Any) -> DemoConfig:
    """Load and validate a demo configuration.

    Args:
        path: A YAML (or JSON) file; None for the built-in defaults.
        **overrides: Top-level fields that replace the file's.

    Raises:
        InvalidParameter: the file is missing, not YAML, or a field is invalid (named).
    """
    data: dict[str, Any] = {}
    if path is not None:
        import yaml

        p = Path(path)
        try:
            text = p.read_text()
        except OSError as exc:
            raise InvalidParameter(f"cannot read config file {p}: {exc.strerror}") from None
        try:
            loaded = yaml.safe_load(text)
        except yaml.YAMLError as exc:
            raise InvalidParameter(f"config file {p} is not valid YAML: {exc}") from None
        if loaded is None:
            loaded = {}
        if not isinstance(loaded, dict):
            raise InvalidParameter(
                f"config file {p} must hold a mapping of fields, got {type(loaded).__name__}"
            )
        data = loaded
    data.update(overrides)
    try:
        return DemoConfig.model_validate(data)
    except ValidationError as err:
        where = f"config file {path}" if path is not None else "config"
        raise InvalidParameter(f"invalid {where}: {_describe(err)}") from None
