"""The campaign file of ``velfence verify``: validated, normalised, hashed.

A campaign names a robot, the safety filter's settings, families of randomised cases and the
properties every step must keep (``docs/config.md``, ``docs/verify.md``). It is read by velfence's
narrow YAML reader and validated with the strict settings models of :mod:`velfence.io.config`:
unknown keys are refused with a "did you mean", ranges are ``[low, high]`` pairs with
``low <= high``, and every message names the file and the field.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path
from typing import Annotated, Any, Literal

from velfence._extras import missing
from velfence._validate import check_text

try:
    from pydantic import Field, Strict, ValidationError, field_validator, model_validator
except ModuleNotFoundError as exc:  # an optional dependency: name the extra
    raise missing(exc, what=__name__) from exc

from velfence.errors import InvalidParameter
from velfence.io.config import (
    NonNegative,
    Positive,
    StrictModel,
    describe_validation_error,
)
from velfence.io.shaper_config import load_yaml

__all__ = [
    "OPERATORS",
    "PLANTS",
    "PROPERTIES",
    "ROBOTS",
    "Campaign",
    "Family",
    "campaign_hash",
    "load_campaign",
    "parse_campaign",
]

#: The robots a campaign may name: the Denavit-Hartenberg chains of ``velfence.mechanisms``
#: (``DHChain.seven_dof``, ``.ur5e``, ``.puma560``), whose filter cycle runs whole in C.
ROBOTS: tuple[str, ...] = ("seven_dof", "ur5e", "puma560")
#: The plants a family's cases run on: ``kinematic`` (``q <- q + dt a``) or ``mujoco`` (the
#: robot simulated by MuJoCo, :mod:`velfence.apps.verify.plants`; the ``physics`` extra).
PLANTS: tuple[str, ...] = ("kinematic", "mujoco")
#: The operators of a family (``docs/verify.md``).
OPERATORS: tuple[str, ...] = ("wander", "push", "wild", "scripted")
#: The properties a campaign checks, in report order.
PROPERTIES: tuple[str, ...] = (
    "containment",
    "joint_limits",
    "finite",
    "deadline",
    "jerk",
    "progress",
)
#: Most cases of one family, most steps of one case, most families.
MAX_CASES = 10**7
MAX_STEPS = 10**7
MAX_FAMILIES = 100


_Pair = Field(min_length=2, max_length=2)
_Unit = Annotated[float, Strict(), Field(allow_inf_nan=False, ge=0.0, le=1.0)]
_Length = Annotated[float, Strict(), Field(allow_inf_nan=False, ge=0.0, le=10.0)]
_Speed = Annotated[float, Strict(), Field(allow_inf_nan=False, ge=0.0, le=100.0)]

Fraction = _Unit
#: ``[low, high]`` ranges (checked ``low <= high``): lengths [m] or angles [rad] up to 10, times
#: [s] up to 10, speeds up to 100.
LengthRange = Annotated[list[_Length], _Pair]
LagRange = LengthRange
SpeedRange = Annotated[list[_Speed], _Pair]
CountRange = Annotated[
    list[Annotated[int, Strict(), Field(ge=0, le=64)]], Field(min_length=2, max_length=2)
]


def _ordered(model: StrictModel) -> None:
    """Every ``[low, high]`` field of ``model`` has ``low <= high``."""
    for name in type(model).model_fields:
        v = getattr(model, name)
        pair = isinstance(v, list) and len(v) == 2
        if pair and all(isinstance(x, int | float) for x in v) and v[0] > v[1]:
            raise ValueError(f"{name}: expected [low, high] with low <= high, got {v}")


class _Ranges(StrictModel):
    @model_validator(mode="after")
    def _check_order(self) -> Any:
        _ordered(self)
        return self


class FilterSettings(StrictModel):
    """The safety filter's settings (``SafetyFilter`` arguments of the same names)."""

    # The period given to the filter [s]: "control" (1 / rate), a number, or null (unset: the
    # continuous-time bounds, a known way to escape at coarse rates).
    dt: Annotated[float, Strict(), Field(ge=1e-6, le=1.0)] | Literal["control"] | None = "control"
    joint_buffer: Annotated[float, Strict(), Field(ge=1e-6, le=10.0)] = 0.1
    obstacle_buffer: Annotated[float, Strict(), Field(ge=1e-6, le=10.0)] = 0.05
    workspace_buffer: Annotated[float, Strict(), Field(ge=1e-6, le=10.0)] = 0.03
    spring_gain: NonNegative = 1.0
    max_speed: Positive | None = None
    max_acceleration: Positive | None = None
    max_jerk: Positive | None = None
    max_iterations: Annotated[int, Strict(), Field(ge=1, le=100_000)] | None = None
    link_radius: Annotated[float, Strict(), Field(ge=0.0, le=1.0)] = 0.05


class Workspace(_Ranges):
    """The workspace box of a family: half sizes drawn around the start's TCP [m]."""

    box: bool = True
    half_size: LengthRange = Field(default_factory=lambda: [0.1, 0.3])
    touching: Fraction = 0.2  # share of cases whose start lies on a box face


class Obstacles(_Ranges):
    """Sphere obstacles near the links, clear of them at the start."""

    count: CountRange = Field(default_factory=lambda: [0, 5])
    radius: LengthRange = Field(default_factory=lambda: [0.02, 0.1])
    gap: LengthRange = Field(default_factory=lambda: [0.02, 0.25])


class Pushes(_Ranges):
    """External joint-velocity pushes (a disturbance the filter cannot veto)."""

    probability: Fraction = 0.0
    speed: SpeedRange = Field(default_factory=lambda: [0.0, 0.2])
    duration: LagRange = Field(default_factory=lambda: [0.02, 0.2])


class Family(_Ranges):
    """One family of randomised cases (``docs/config.md``)."""

    name: Annotated[str, Field(min_length=1, max_length=80, pattern=r"^[A-Za-z0-9_.-]+$")]
    cases: Annotated[int, Strict(), Field(ge=1, le=MAX_CASES)] = 10
    steps: Annotated[int, Strict(), Field(ge=1, le=MAX_STEPS)] = 500
    operator: Literal["wander", "push", "wild", "scripted"] = "wander"
    mode: Literal["twist", "joint", "mixed"] = "twist"
    start_margin: LengthRange = Field(default_factory=lambda: [0.1, 2.0])
    at_limit: Fraction = 0.2
    workspace: Workspace = Field(default_factory=Workspace)
    obstacles: Obstacles = Field(default_factory=Obstacles)
    lag: LagRange = Field(default_factory=lambda: [0.0, 0.0])
    latency: CountRange = Field(default_factory=lambda: [0, 0])
    noise: LengthRange = Field(default_factory=lambda: [0.0, 0.0])
    pushes: Pushes = Field(default_factory=Pushes)
    plant: str = "kinematic"

    @field_validator("plant")
    @classmethod
    def _check_plant(cls, plant: str) -> str:
        if plant not in PLANTS:
            from velfence.io.yaml_reader import did_you_mean

            raise ValueError(
                f"unknown plant {plant!r}; expected one of {list(PLANTS)}"
                + did_you_mean(plant, PLANTS)
            )
        return plant


class Tolerance(StrictModel):
    """A property checked with a tolerance (a step violates it when its margin < -tolerance)."""

    tolerance: NonNegative = 1e-9


class Jerk(StrictModel):
    """Bound on the filter output's jerk ``|x_k - 2 x_{k-1} + x_{k-2}| / dt²`` [rad/s³]."""

    max: Annotated[float, Strict(), Field(allow_inf_nan=False, gt=0.0, le=1e12)]


class ProgressCheck(StrictModel):
    """No deadlock: along a held twist command, the TCP makes progress."""

    min_fraction: Fraction = 0.01
    window: Annotated[float, Strict(), Field(gt=0.0, le=100.0)] = 0.1


class Properties(StrictModel):
    """The properties checked at every step (``null`` or absent: not checked)."""

    containment: Tolerance | None = Field(default_factory=Tolerance)
    joint_limits: Tolerance | None = Field(default_factory=Tolerance)
    finite: Tolerance | None = Field(default_factory=lambda: Tolerance(tolerance=0.0))
    deadline: Tolerance | None = Field(default_factory=lambda: Tolerance(tolerance=0.0))
    jerk: Jerk | None = None
    progress: ProgressCheck | None = None


class Campaign(StrictModel):
    """A ``velfence verify`` campaign (``docs/config.md``).

    Args:
        robot: One of :data:`ROBOTS`.
        rate: Control rate [Hz].
        seed: The campaign's seed (every case's seed derives from it).
        shard_size: Cases per shard.
        filter: The safety filter's settings.
        families: The families of randomised cases (distinct names).
        properties: The properties checked at every step.
        shrink: Most failing cases shrunk to counterexamples.
    """

    robot: str
    rate: Annotated[float, Strict(), Field(ge=1.0, le=1e5)] = 1000.0
    seed: Annotated[int, Strict(), Field(ge=0, le=2**63 - 1)] = 0
    shard_size: Annotated[int, Strict(), Field(ge=1, le=10**6)] = 16
    filter: FilterSettings = Field(default_factory=FilterSettings)
    families: Annotated[list[Family], Field(min_length=1, max_length=MAX_FAMILIES)]
    properties: Properties = Field(default_factory=Properties)
    shrink: Annotated[int, Strict(), Field(ge=0, le=100)] = 3

    @model_validator(mode="after")
    def _check(self) -> Campaign:
        if self.robot not in ROBOTS:
            from velfence.io.yaml_reader import did_you_mean

            raise ValueError(
                f"robot: unknown robot {self.robot!r}; expected one of {list(ROBOTS)}"
                + did_you_mean(self.robot, ROBOTS)
            )
        names = [f.name for f in self.families]
        if len(set(names)) != len(names):
            raise ValueError(f"families: names must be distinct, got {names}")
        return self

    @property
    def control_dt(self) -> float:
        """The control period ``1 / rate`` [s]."""
        return 1.0 / self.rate

    @property
    def filter_dt(self) -> float | None:
        """The period given to the filter [s]: ``1 / rate``, ``filter.dt``, or None (unset)."""
        if self.filter.dt == "control":
            return self.control_dt
        return None if self.filter.dt is None else float(self.filter.dt)

    def normalised(self) -> dict[str, Any]:
        """The campaign as plain data with every default filled in (what the hash covers)."""
        return self.model_dump(mode="json")


def parse_campaign(data: Any, *, where: str = "data") -> Campaign:
    """Validate a campaign mapping.

    Args:
        data: The campaign (a mapping, as read from the file).
        where: How messages name it (the file's path).

    Returns:
        The validated :class:`Campaign`.

    Raises:
        InvalidParameter: an unknown field (with a "did you mean"), a value of the wrong type or
            range, ``[low, high]`` with low > high, an unknown robot; the message names
            ``where`` and the field.
    """
    where = check_text("where", where, max_length=4096)
    if isinstance(data, Campaign):
        return data
    if not isinstance(data, dict):
        raise InvalidParameter(f"{where}: expected a mapping of fields, got {type(data).__name__}")
    try:
        return Campaign.model_validate(data)
    except ValidationError as err:
        raise InvalidParameter(f"{where}: {describe_validation_error(err, Campaign)}") from None


def load_campaign(path: str | Path) -> Campaign:
    """Read and validate a campaign file (``docs/config.md``).

    Args:
        path: The YAML file.

    Returns:
        The validated :class:`Campaign`.

    Raises:
        InvalidParameter: the file is missing or no plain YAML, or the campaign is invalid
            (the message names the file and the field).
    """
    return parse_campaign(load_yaml(path), where=str(path))


def campaign_hash(campaign: Campaign) -> str:
    """SHA-256 of the normalised campaign (sorted JSON): equal campaigns, equal hashes.

    Args:
        campaign: The campaign.

    Returns:
        64 hexadecimal digits.
    """
    text = json.dumps(campaign.normalised(), sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()
