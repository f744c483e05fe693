"""The one backend picker: Python route or the compiled C core (``velfence_core``).

Every class with a ``backend`` argument (:class:`~velfence.shaping.PolygonShaper`,
:class:`~velfence.shaping.PolytopeShaper`, :class:`~velfence.filter.SafetyFilter`,
:class:`~velfence.redundancy.ConfigurationControl`, the teleoperation's ``ResolvedRate``) chooses
its implementation with :func:`pick_backend`: one vocabulary (:data:`BACKENDS`), one rule and one
error message. This module is also the only place in velfence that names the compiled core's
binding modules (the loaders :func:`compiled_core`, :func:`compiled_nd`, :func:`compiled_filter`).

The core is a separate distribution (``core/`` in velfence's source, ``pip install ./core``), so
that velfence installs and imports without a compiler; without it every ``"auto"`` runs Python.
"""

from __future__ import annotations

import importlib
from functools import cache
from typing import Any, Literal

from velfence._validate import check_choice
from velfence.errors import InvalidParameter

__all__ = [
    "BACKENDS",
    "Backend",
    "compiled_core",
    "compiled_filter",
    "compiled_nd",
    "pick_backend",
]

#: A ``backend`` argument: ``"auto"`` (the compiled core when it is importable and can run the
#: caller's configuration, else Python), ``"python"`` (the reference route) or ``"c"`` (the core,
#: required: :class:`~velfence.errors.InvalidParameter` when it cannot run).
Backend = Literal["auto", "python", "c"]
#: Every accepted spelling of a ``backend`` argument.
BACKENDS: tuple[str, ...] = ("auto", "python", "c")

#: The binding each caller needs: the 2-D laws (``"core"``), the n-D laws, projection,
#: configuration control and resolved rate (``"nd"``), the safety filter's whole cycle
#: (``"filter"``).
Binding = Literal["core", "nd", "filter"]
_MODULES: dict[str, str] = {
    "core": "velfence_core._core",
    "nd": "velfence_core._nd",
    "filter": "velfence_core._filter",
}


def _load(binding: str) -> Any:
    try:
        return importlib.import_module(_MODULES[binding])
    except ImportError:
        return None


@cache
def compiled_core() -> Any:
    """The compiled core's 2-D binding, or None when the core is not installed.

    Its ``ExactLaw`` / ``PatentLaw`` take a shaper's kernel data and compute the reference
    kernels bit for bit; ``ShapeCall`` is the shapers' frameless ``shape``.

    Returns:
        The binding module, or None.
    """
    return _load("core")


@cache
def compiled_nd() -> Any:
    """The compiled core's n-D binding, or None when the core is not installed.

    ``project(u, G, b)``, ``PolytopeLaw``, ``FilterRows``, ``ConfigControl`` and the resolved-rate
    step: the Python kernels in C99, bit for bit (tests/core).

    Returns:
        The binding module, or None.
    """
    return _load("nd")


@cache
def compiled_filter() -> Any:
    """The compiled core's safety-filter cycle binding, or None when the core is not installed.

    Returns:
        The binding module (``FilterCycle``), or None.
    """
    return _load("filter")


_LOADERS = {"core": "compiled_core", "nd": "compiled_nd", "filter": "compiled_filter"}


def pick_backend(
    backend: object,
    usable: bool = True,
    refusal: str | None = None,
    *,
    binding: Binding = "nd",
) -> tuple[Any, Literal["python", "c"]]:
    """The compiled binding to run (or None) and the name of the backend in use.

    ``"python"`` runs Python; ``"auto"`` runs C when ``usable`` and the binding is importable,
    else Python; ``"c"`` runs C or refuses.

    Args:
        backend: The caller's ``backend`` argument (:data:`Backend`).
        usable: Whether the caller's configuration can run in C at all (a profile the kernels
            do not know cannot).
        refusal: What ``backend='c'`` runs and what it got instead, for the message when
            ``usable`` is False (default: the shapers' profiles).
        binding: Which binding the caller runs (``"core"``, ``"nd"`` or ``"filter"``).

    Returns:
        ``(module, "c")`` with the binding module, or ``(None, "python")``.

    Raises:
        InvalidParameter: ``backend`` is not one of :data:`BACKENDS`; ``backend="c"`` with
            ``usable`` False or without the compiled core.
    """
    choice = check_choice("backend", backend, BACKENDS)
    if binding not in _MODULES:
        raise InvalidParameter(f"binding must be one of {list(_MODULES)}, got {binding!r}")
    if choice == "python":
        return None, "python"
    if not usable:
        if choice == "c":
            why = refusal or (
                "runs the kernels' own profiles (LinearBuffer, ThreeZoneBraking), got another "
                "profile"
            )
            raise InvalidParameter(f"backend='c' {why}; use backend='auto' or 'python'")
        return None, "python"
    module = globals()[_LOADERS[binding]]()  # looked up here: tests replace the loaders
    if module is None:
        if choice == "c":
            raise InvalidParameter(
                f"backend='c' needs the compiled core (its module {_MODULES[binding]}: the "
                "velfence_core distribution, `pip install ./core` from velfence's source), "
                "which is not importable; use backend='auto' or 'python'"
            )
        return None, "python"
    return module, "c"
