"""The parts every validated settings model of velfence shares: strict models, numbers, messages.

Internal API of :mod:`velfence.io` and :mod:`velfence.bridge` (the shaper, replay and bridge
configuration files; ``docs/config.md``): :class:`StrictModel` (unknown keys refused, frozen,
non-config values refused), the number types (written as numbers, finite, at most
:data:`MAX_VALUE` in magnitude) and :func:`describe_validation_error` (one line per error, naming
the field). The demo's own configuration (``DemoConfig``, ``load_config``) is an application's:
:mod:`velfence.apps.demo.config`; its old names here still work until 0.3 with a warning.
"""

from __future__ import annotations

from typing import Annotated, Any

import numpy as np

from velfence._extras import missing

try:
    from pydantic import BaseModel, ConfigDict, Field, Strict, ValidationError, field_validator
except ModuleNotFoundError as exc:  # an optional dependency: name the extra
    raise missing(exc, what=__name__) from exc

from velfence import _lazy
from velfence._validate import show
from velfence.io.defaults import DEFAULT_MAX_STEPS
from velfence.io.joint_limits import load_joint_limits
from velfence.io.yaml_reader import MAX_DEPTH, MAX_FILE_BYTES, did_you_mean

__all__ = [
    "DEFAULT_MAX_STEPS",
    "MAX_CORNERS",
    "MAX_DEPTH",
    "MAX_FILE_BYTES",
    "MAX_VALUE",
    "MIN_BUFFER",
    "MIN_DT",
    "NonNegative",
    "Number",
    "Pair",
    "Positive",
    "StrictModel",
    "describe_validation_error",
    "load_joint_limits",
]

#: Most corners accepted in a polygon.
MAX_CORNERS = 1000
#: Largest magnitude of any number in a file, in the field's own unit ([rad], [s], [rad/s],
#: [1/s]): far beyond any scenario, small enough that no product of two fields overflows.
MAX_VALUE = 1e6
#: Smallest accepted buffer width (a micro-radian, below any joint encoder's step).
MIN_BUFFER = 1e-6
#: Smallest accepted ``dt`` [s] (a 1 MHz control loop; no velocity loop runs faster).
MIN_DT = 1e-6

# Numbers written as numbers only (Strict: no "0.2", no true), finite, bounded by MAX_VALUE.
Number = Annotated[float, Strict(), Field(allow_inf_nan=False, ge=-MAX_VALUE, le=MAX_VALUE)]
Positive = Annotated[float, Strict(), Field(allow_inf_nan=False, gt=0, le=MAX_VALUE)]
NonNegative = Annotated[float, Strict(), Field(allow_inf_nan=False, ge=0, le=MAX_VALUE)]
Pair = tuple[Number, Number]

#: Most entries of one list a field value may have before it is even looked at (the largest
#: list field, a polygon, takes :data:`MAX_CORNERS`; a longer one is refused without a walk).
_MAX_ENTRIES = 10 * MAX_CORNERS


def _plain(value: Any, depth: int = 0) -> Any:
    """``value`` with NumPy scalars and arrays turned into plain Python numbers and lists.

    A config file only ever holds numbers, strings, booleans, lists and mappings; objects built
    in Python may hold NumPy types (accepted as the numbers they are) and anything else (sets,
    iterators, complex numbers, Decimals, bytes ...), which is refused here: pydantic would read
    some of them as numbers (``np.True_`` as 1.0, ``0.5+0j`` as 0.5).

    Raises:
        ValueError: a value that is no config value (pydantic reports it with the field's name).
    """
    if value is None or isinstance(value, (str, dict, bool, int, float)):
        return value  # pydantic's own (strict) checks judge these
    if isinstance(value, np.bool_):
        return bool(value)
    if isinstance(value, (np.timedelta64, np.datetime64)):  # np.timedelta64 is an np.integer
        raise ValueError(f"expected a number, got {type(value).__name__} {value}")
    if isinstance(value, (np.integer, np.floating)):
        with np.errstate(all="ignore"):  # a long double beyond float range becomes inf: refused
            return int(value) if isinstance(value, np.integer) else float(value)
    if depth >= MAX_DEPTH:
        raise ValueError(f"nested deeper than {MAX_DEPTH} levels")
    if isinstance(value, np.ndarray):
        if value.dtype.kind not in "biuf":
            raise ValueError(f"expected real numbers, got an array of dtype {value.dtype}")
        if value.size > _MAX_ENTRIES:
            raise ValueError(f"expected at most {_MAX_ENTRIES} numbers, got {value.size}")
        return _plain(np.asarray(value).tolist(), depth + 1)
    if isinstance(value, (list, tuple)):
        if len(value) > _MAX_ENTRIES:
            raise ValueError(f"expected at most {_MAX_ENTRIES} entries, got {len(value)}")
        return [_plain(v, depth + 1) for v in value]
    raise ValueError(
        f"expected a number, a string, a list or a mapping, got {type(value).__name__}"
    )


class StrictModel(BaseModel):
    """Base of the validated settings models of :mod:`velfence.io` and :mod:`velfence.bridge`.

    Internal API (not for users): unknown keys refused, frozen, values that are no config value
    (sets, complex numbers, ...) refused before pydantic converts them.
    """

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    @field_validator("*", mode="before")
    @classmethod
    def _plain_values(cls, value: Any) -> Any:
        return _plain(value)


def describe_validation_error(err: ValidationError, model: type[BaseModel] | None = None) -> str:
    """One line per error, ``field.path: message``, joined by ``"; "``.

    Internal API of :mod:`velfence.io` and :mod:`velfence.bridge` (their config messages). An
    unknown key ("Extra inputs are not permitted") gets "did you mean 'buffer'?" when one of the
    fields allowed at that place is close to it
    (:func:`velfence.io.yaml_reader.did_you_mean`), or else "did you mean 'shaper.buffer'?" when
    a field of a section one level down is (a key written above its section).

    Args:
        err: What pydantic raised on a model of this package.
        model: The model that was validated, for the suggestions (``None``: none).

    Returns:
        The message text.
    """
    lines = []
    for e in err.errors():
        loc = ".".join(str(x) for x in e["loc"]) or "(top level)"
        msg = e["msg"]
        if e["type"] == "value_error":  # our own check: its message stands on its own
            msg = str(e.get("ctx", {}).get("error", msg.removeprefix("Value error, ")))
        elif e["type"].endswith("_type") and "input" in e:  # wrong type: say what was got
            got = e["input"]
            msg += f", got {type(got).__name__} {show(got, 40)}"
            if isinstance(got, str) and _numeric_text(got):
                msg += "; write numbers without quotes"
        elif e["type"] == "extra_forbidden" and model is not None and e["loc"]:
            msg += _suggestion(str(e["loc"][-1]), model, e["loc"][:-1])
        lines.append(f"{loc}: {msg}")
    return "; ".join(lines)


def _models_in(annotation: Any) -> list[type[BaseModel]]:
    """The pydantic models an annotation holds (``X | None``, ``list[X]``, ``dict[str, X]``)."""
    import typing

    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return [annotation]
    return [m for arg in typing.get_args(annotation) for m in _models_in(arg)]


def _fields_at(model: type[BaseModel], path: tuple[int | str, ...]) -> list[str]:
    """The field names (and aliases) allowed at ``path`` inside ``model``."""
    names: list[str] = []
    for cls in _models_at(model, path):
        for name, info in cls.model_fields.items():
            names.append(info.alias or name)
    return names


def _models_at(model: type[BaseModel], path: tuple[int | str, ...]) -> list[type[BaseModel]]:
    """The models that may be at ``path`` inside ``model`` (``[]``: a plain value there)."""
    models = [model]
    for step in path:
        nxt = [
            m
            for cls in models
            if isinstance(step, str) and step in cls.model_fields
            for m in _models_in(cls.model_fields[step].annotation)
        ]
        if nxt:
            models = nxt
        elif isinstance(step, str) and any(step in cls.model_fields for cls in models):
            return []  # a field that holds a plain value, not a section
        else:  # a list index or a union member's tag: narrow to the tagged model if named
            named = [m for m in models if m.__name__ == step]
            models = named or models
    return models


def _suggestion(word: str, model: type[BaseModel], path: tuple[int | str, ...]) -> str:
    """The "did you mean" for an unknown key ``word`` at ``path`` inside ``model``, or ``""``.

    A field of that name in a section one level down comes first (the Python API's ``buffer=``
    written at the top of a demo file, which has it under ``shaper:``: "did you mean
    'shaper.buffer'?"); then the closest field at that place; then the closest one level down.
    """
    import difflib

    below: dict[str, list[str]] = {}
    for section in _fields_at(model, path):
        for name in _fields_at(model, (*path, section)):
            below.setdefault(name, []).append(f"{section}.{name}")
    close = [word] if word in below else difflib.get_close_matches(word, sorted(below), n=1)
    lower = "; did you mean " + " or ".join(repr(d) for d in below[close[0]]) + "?" if close else ""
    if word in below:
        return lower
    return did_you_mean(word, _fields_at(model, path)) or lower


def _numeric_text(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


#: The demo's configuration moved to velfence.apps.demo.config in 0.2 (it is an application's).
_MOVED_TO_APPS = {
    name: "velfence.apps.demo.config"
    for name in (
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
    )
}

__getattr__, _ = _lazy.attach(__name__, {}, globals(), former=_MOVED_TO_APPS)
