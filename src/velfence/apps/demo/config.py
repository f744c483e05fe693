"""Validated configuration of the demo scenario (YAML or JSON file, or built-in defaults).

The demo's own settings (:class:`DemoConfig`, read by :func:`load_config`), built on the library's
strict models (:mod:`velfence.io.config`). Every field has a type, a unit and a range; a bad file
raises :class:`~velfence.errors.InvalidParameter` whose message names the field
(``waypoints.2.speed: Input should be greater than 0``), before any simulation starts.

The reader is deliberately narrow (the format is documented in ``docs/config.md``):

* at most :data:`~velfence.io.config.MAX_FILE_BYTES` of UTF-8 text, nested at most
  :data:`~velfence.io.config.MAX_DEPTH` levels;
* plain YAML only: anchors, aliases, merge keys (``<<``), duplicate keys and the YAML tags that
  build dates, binary data, sets or ordered pairs are refused, each with its line;
* numbers must be written as numbers (``"0.2"`` and ``true`` are not a buffer width), finite
  (``.nan``, ``.inf`` refused) and at most :data:`~velfence.io.config.MAX_VALUE` in magnitude;
* unknown keys are refused; lists are capped (:data:`~velfence.io.config.MAX_CORNERS`,
  :data:`MAX_WAYPOINTS`, :data:`MAX_PUSHES`), and the run length ``duration / dt`` is capped at
  ``max_steps`` (:data:`~velfence.io.defaults.DEFAULT_MAX_STEPS` unless the caller raises it).
"""

from __future__ import annotations

import math
from contextvars import ContextVar
from pathlib import Path
from typing import Annotated, Any, Literal

from velfence._extras import missing

try:
    from pydantic import Field, Strict, ValidationError, field_validator, model_validator
except ModuleNotFoundError as exc:  # an optional dependency: name the extra
    raise missing(exc, what=__name__) from exc

from velfence._deprecate import positional_deprecated
from velfence._docs import document_inits
from velfence._validate import MAX_STEPS, check_positive_int, check_text, step_count
from velfence.errors import InvalidParameter
from velfence.io.config import (
    MAX_CORNERS,
    MAX_VALUE,
    MIN_BUFFER,
    MIN_DT,
    NonNegative,
    Pair,
    Positive,
    StrictModel,
    describe_validation_error,
)
from velfence.io.defaults import DEFAULT_MAX_STEPS
from velfence.io.yaml_reader import file_path, read_yaml

__all__ = [
    "ALL_METHODS",
    "MAX_PUSHES",
    "MAX_SEED",
    "MAX_WAYPOINTS",
    "METHOD_OF",
    "DemoConfig",
    "PushSpec",
    "ShaperSettings",
    "WaypointSpec",
    "check_run_length",
    "load_config",
]

#: Most entries accepted in ``waypoints``.
MAX_WAYPOINTS = 1000
#: Most entries accepted in ``pushes``.
MAX_PUSHES = 100
#: Largest accepted ``seed`` (NumPy seeds are non-negative; 64 bits is plenty).
MAX_SEED = 2**64 - 1

#: The demo's run names. Each is the ``.method`` its shaper reports (``no-limit``, ``hard-stop``,
#: ``axis-limits``, ``edge-scaling``, ``exact``) or a documented alias of one: ``none`` is
#: ``no-limit`` and ``patent`` is ``edge-scaling`` (the names the demo's tables and figures use).
Method = Literal["none", "no-limit", "hard-stop", "axis-limits", "patent", "edge-scaling", "exact"]
ALL_METHODS: tuple[Method, ...] = ("none", "hard-stop", "axis-limits", "patent", "exact")
#: Run name -> the one law it names (the aliases of :data:`Method` to the shaper's ``.method``).
METHOD_OF: dict[str, str] = {"none": "no-limit", "patent": "edge-scaling"}

#: A short label (scenario name, axis name, unit): 1 to 40 characters, no line breaks.
Label = Annotated[str, Strict(), Field(min_length=1, max_length=40, pattern=r"^[^\n\r\t\[\]]+$")]


#: How a config is named in the messages of DemoConfig(...): load_config sets the file's name.
_WHERE: ContextVar[str] = ContextVar("velfence_config_where", default="DemoConfig")


class ShaperSettings(StrictModel):
    """Tuning shared by the shapers of the demo (workspace units are [rad] on the wrist)."""

    buffer: Annotated[
        float,
        Strict(),
        Field(ge=MIN_BUFFER, le=MAX_VALUE, description="buffer width d_max [rad]"),
    ] = 0.08
    spring_gain: Annotated[NonNegative, Field(description="virtual spring gain k [1/s]")] = 8.0
    corner_blend_angle: Annotated[
        float, Strict(), Field(gt=0, lt=math.pi, description="patent θ_max [rad]")
    ] = 0.3
    max_recovery_speed: Annotated[
        Positive | None, Field(description="exact: cap on recovery speed [rad/s]")
    ] = None


class WaypointSpec(StrictModel):
    """From time ``t`` [s] the operator heads for ``target`` [rad] at up to ``speed`` [rad/s]."""

    t: NonNegative
    target: Pair
    speed: Positive


class PushSpec(StrictModel):
    """An external velocity disturbance ``velocity`` [rad/s] during ``[t0, t1)`` [s]."""

    t0: NonNegative
    t1: Positive
    velocity: Pair

    @model_validator(mode="after")
    def _ordered(self) -> PushSpec:
        if self.t1 <= self.t0:
            raise ValueError(f"t1 must be after t0, got t0={self.t0}, t1={self.t1}")
        return self


class DemoConfig(StrictModel):
    """The demo scenario. Fields left out take the built-in defaults (see ``docs/config.md``).

    ``polygon: null`` means the wrist's default polygon; ``start``, ``waypoints`` and ``pushes``
    left null are generated from the polygon's features (longest edge, most acute and most obtuse
    corner) by :func:`velfence.apps.demo.script.default_script`.

    Attributes:
        polygon: Corners of the convex workspace polygon [unit], or None for the wrist's.
        shaper: Tuning shared by the shapers (:class:`ShaperSettings`).
        methods: Shaping laws and baselines to run, in order.
        dt: Control period [s].
        duration: Simulated time [s], or None for the script's own length.
        start: Start position [unit], or None (just outside the longest edge).
        waypoints: The operator's script, or None for the built-in one.
        pushes: External velocity disturbances (an empty list: none), or None for the built-in
            push.
        noise_std: Standard deviation of the position noise [unit].
        seed: Seed of the noise generator.
        saturate: Whether the wrist's actuator saturation applies.
        gif: Whether ``demo.gif`` is written.
        name: The scenario's name in titles, or None ("wrist scenario" / "custom scenario").
        axis_names: The two workspace axis names, or None ((pitch, yaw) / (x, y)).
        unit: The workspace length unit of labels and table columns, or None (rad /
            "workspace units").
    """

    polygon: list[Pair] | None = None
    shaper: ShaperSettings = ShaperSettings()
    methods: list[Method] = Field(default_factory=lambda: list(ALL_METHODS), min_length=1)
    dt: Annotated[
        float,
        Strict(),
        Field(ge=MIN_DT, le=0.1, allow_inf_nan=False, description="control period [s]"),
    ] = 1e-3
    duration: Annotated[Positive | None, Field(description="[s]")] = None
    start: Pair | None = None
    waypoints: list[WaypointSpec] | None = None
    pushes: Annotated[list[PushSpec] | None, Field(max_length=MAX_PUSHES)] = None
    noise_std: Annotated[NonNegative, Field(description="position noise [rad]")] = 0.0
    seed: Annotated[int, Strict(), Field(ge=0, le=MAX_SEED)] = 0
    saturate: Annotated[bool, Strict()] = True
    gif: Annotated[bool, Strict()] = True
    name: Annotated[Label | None, Field(description="scenario name for titles")] = None
    axis_names: tuple[Label, Label] | None = None
    unit: Annotated[Label | None, Field(description="workspace length unit")] = None

    def axis_labels(self) -> tuple[str, str]:
        """The workspace axis labels with their unit, ``("pitch [rad]", "yaw [rad]")``.

        ``axis_names`` and ``unit`` when given; else the wrist's (pitch, yaw) in rad when
        ``polygon`` is null, and (x, y) in "workspace units" for a polygon of your own.

        Returns:
            The x and y axis labels.
        """
        wrist = self.polygon is None
        names = self.axis_names or (("pitch", "yaw") if wrist else ("x", "y"))
        unit = self.unit or ("rad" if wrist else "workspace units")
        return f"{names[0]} [{unit}]", f"{names[1]} [{unit}]"

    def __init__(self, **data: Any) -> None:
        """Build a configuration directly (the fields are documented in ``docs/config.md``).

        Raises:
            InvalidParameter: a field is invalid; the message names it (``dt: ...``).
        """
        try:
            super().__init__(**data)
        except ValidationError as err:
            raise InvalidParameter(
                f"invalid {_WHERE.get()}: {describe_validation_error(err, DemoConfig)}"
            ) from None

    @field_validator("shaper", mode="before")
    @classmethod
    def _shaper_not_empty(cls, value: Any) -> Any:
        if isinstance(value, dict) and not value:
            raise ValueError("shaper must not be empty (leave it out for the defaults)")
        return value

    @field_validator("polygon")
    @classmethod
    def _corner_count(cls, value: list[Pair] | None) -> list[Pair] | None:
        if value is not None and len(value) < 3:
            raise ValueError(f"polygon needs at least 3 corners, got {len(value)}")
        if value is not None and len(value) > MAX_CORNERS:
            raise ValueError(
                f"polygon has {len(value)} corners; at most {MAX_CORNERS} are accepted"
            )
        return value

    @field_validator("methods")
    @classmethod
    def _distinct(cls, value: list[Method]) -> list[Method]:
        laws = [METHOD_OF.get(m, m) for m in value]
        twice = sorted({m for m, law in zip(value, laws, strict=True) if laws.count(law) > 1})
        if twice:
            raise ValueError(
                f"each method may be listed once, got {twice} more than once (none is no-limit, "
                "patent is edge-scaling)"
            )
        return value

    @field_validator("waypoints")
    @classmethod
    def _in_time_order(cls, value: list[WaypointSpec] | None) -> list[WaypointSpec] | None:
        if value is None:
            return value
        if not value:
            raise ValueError("waypoints must not be empty (leave it out for the default)")
        if len(value) > MAX_WAYPOINTS:
            raise ValueError(f"{len(value)} waypoints given; at most {MAX_WAYPOINTS} are accepted")
        ts = [w.t for w in value]
        if ts != sorted(ts):
            raise ValueError(f"waypoints must be in time order, got t = {ts}")
        return value


@positional_deprecated(1, ("duration", "dt"))
def check_run_length(
    duration: float,
    *,
    dt: float,
    max_steps: int = DEFAULT_MAX_STEPS,
    duration_name: str = "duration",
) -> int:
    """The number of steps of one demo run, refused above ``max_steps``.

    Args:
        duration: Simulated time [s].
        dt: Control period [s].
        max_steps: Largest accepted ``duration / dt`` (``1 <= max_steps <= 10⁸``).
        duration_name: How the duration is named in messages.

    Returns:
        The number of steps.

    Raises:
        InvalidParameter: too many steps (the message says how to allow more), or bad values.
    """
    limit = check_positive_int("max_steps", max_steps, maximum=MAX_STEPS, example=DEFAULT_MAX_STEPS)
    duration_name = check_text("duration_name", duration_name)
    try:
        return step_count(duration_name, duration, "dt", dt, max_steps=limit)
    except InvalidParameter as exc:
        raise InvalidParameter(
            f"{exc} (every method runs that many steps; if a longer run is really wanted, "
            f"allow it with --max-steps N on the command line or max_steps=N in Python)"
        ) from None


def load_config(
    path: str | Path | None = None, *, max_steps: int = DEFAULT_MAX_STEPS, **overrides: Any
) -> DemoConfig:
    """Load and validate a demo configuration.

    Args:
        path: A YAML (or JSON) file; None for the built-in defaults. The format, every field and
            its limits are documented in ``docs/config.md``.
        max_steps: Largest accepted number of steps of one run (``duration / dt``); default
            :data:`DEFAULT_MAX_STEPS`, at most 10⁸.
        **overrides: Top-level fields that replace the file's.

    Returns:
        The validated configuration.

    Raises:
        InvalidParameter: the file is missing, too large, not UTF-8, not plain YAML, or a field
            is invalid (named); the run would be longer than ``max_steps``.
    """
    limit = check_positive_int("max_steps", max_steps, maximum=MAX_STEPS, example=DEFAULT_MAX_STEPS)
    data: dict[Any, Any] = {}
    p: Path | None = None
    if path is not None:
        p = file_path(path)
        loaded = read_yaml(p)
        if loaded is None:
            loaded = {}
        if not isinstance(loaded, dict):
            raise InvalidParameter(
                f"config file {p} must hold a mapping of fields, got {type(loaded).__name__}"
            )
        data = loaded
    data.update(overrides)
    where = f"config file {p}" if p is not None else "config"
    odd = [k for k in data if not isinstance(k, str)]
    if odd:  # field names are strings; DemoConfig(**data) could not even be called
        raise InvalidParameter(f"invalid {where}: {odd[0]!r}: Extra inputs are not permitted")
    token = _WHERE.set(where)
    try:
        cfg = DemoConfig.model_validate(data)
    except ValidationError as err:
        # model_validate runs DemoConfig.__init__, whose InvalidParameter (already worded with
        # `where`) pydantic wraps as one top-level error: hand that one on as it is.
        inner = [e.get("ctx", {}).get("error") for e in err.errors()]
        if len(inner) == 1 and isinstance(inner[0], InvalidParameter):
            raise inner[0] from None
        raise InvalidParameter(
            f"invalid {where}: {describe_validation_error(err, DemoConfig)}"
        ) from None
    finally:
        _WHERE.reset(token)
    # The run length is known here unless it comes from the default script; then run_demo
    # checks it once the script is built, still before any step is simulated.
    try:
        if cfg.duration is not None:
            check_run_length(cfg.duration, dt=cfg.dt, max_steps=limit)
        elif cfg.waypoints is not None:
            check_run_length(
                cfg.waypoints[-1].t + 1.5,
                dt=cfg.dt,
                max_steps=limit,
                duration_name="duration (last waypoint t + 1.5 s)",
            )
    except InvalidParameter as exc:
        raise InvalidParameter(f"invalid {where}: {exc}") from None
    return cfg


document_inits(globals())
