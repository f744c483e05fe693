"""The optional dependencies: which extra installs each, and the one message when one is missing.

``pip install velfence`` installs NumPy and SciPy only; everything else comes with an extra
(``pyproject.toml``, ``docs/install.md``). A module of velfence that needs an optional package at
import time calls :func:`require` first, and a function that needs one when called does the same,
so a missing package is always reported the same way: a :class:`~velfence.errors.MissingExtra`
(an :class:`ImportError`, and a :class:`~velfence.errors.VelfenceError`) whose message names the
extra to install, never a bare ``No module named ...``. Standard library only: the console script
uses it before anything else is imported.
"""

from __future__ import annotations

import importlib

from velfence.errors import MissingExtra

TYPE_CHECKING = False  # typing.TYPE_CHECKING without importing typing (start-up time)
if TYPE_CHECKING:
    from types import ModuleType

__all__ = ["EXTRA_OF", "extra_of", "message", "missing", "require"]

#: Top-level module -> the velfence extra that installs it (the one table; ``pyproject.toml``'s
#: ``[project.optional-dependencies]`` lists the distributions).
EXTRA_OF: dict[str, str] = {
    "typer": "app",
    "click": "app",
    "rich": "app",
    "shellingham": "app",
    "pydantic": "app",
    "pydantic_core": "app",
    "yaml": "app",
    "matplotlib": "app",
    "PIL": "app",
    "numba": "fast",
    "qpsolvers": "qp",
    "daqp": "qp",
    "quadprog": "qp",
    "mujoco": "physics",
    "imageio_ffmpeg": "physics",
    "mink": "physics",
    "example_robot_data": "lerobot",
    "cyclonedds": "ros",
    "rosbags": "ros",
    "mcap": "ros",
    "mcap_ros2": "ros",
    "foxglove": "ros",
    "viser": "web",
    "gymnasium": "gym",
    "dask": "cluster",
    "distributed": "cluster",
}


def extra_of(module: str | None) -> str | None:
    """The extra that installs ``module`` (a dotted name: its top level counts), or None.

    Args:
        module: A module name such as ``"yaml.constructor"``; None gives None.

    Returns:
        The extra's name (``"app"``), or None when the module is not an optional dependency.
    """
    return EXTRA_OF.get((module or "").partition(".")[0])


def message(package: str, what: str, extra: str | None = None) -> str:
    """The one sentence that says an optional dependency is missing and how to install it.

    Args:
        package: The missing top-level module (``"pydantic"``).
        what: What needs it (``"velfence.io.config"``, ``"the velfence command"``).
        extra: The extra that installs it; default from :data:`EXTRA_OF`.

    Returns:
        ``"<what> needs the optional '<extra>' dependencies (<package> is not installed);
        install them with: pip install 'velfence[<extra>]'"``.
    """
    extra = extra or extra_of(package) or "all"
    return (
        f"{what} needs the optional '{extra}' dependencies ({package} is not installed); "
        f"install them with: pip install 'velfence[{extra}]'"
    )


def missing(exc: ModuleNotFoundError, *, what: str) -> ImportError:
    """The error to raise for a failed import of an optional dependency at a module's top.

    Used as ``try: import yaml`` / ``except ModuleNotFoundError as exc: raise missing(exc,
    what=__name__) from exc``: a module that belongs to an extra gives a
    :class:`~velfence.errors.MissingExtra` naming the extra, anything else (a bug) is returned
    unchanged so that it surfaces as it is.

    Args:
        exc: The error of the failed import.
        what: What needs the module, for the message (the importing module's ``__name__``).

    Returns:
        The error to raise.
    """
    if isinstance(exc, MissingExtra):
        return exc
    extra = extra_of(exc.name)
    if extra is None:
        return exc
    top = (exc.name or "").partition(".")[0]
    return MissingExtra(message(top, what, extra), name=top)


def require(package: str, *, what: str, extra: str | None = None) -> ModuleType:
    """Import an optional dependency, or raise the one message that names its extra.

    Args:
        package: The module to import (``"pydantic"``, ``"matplotlib.pyplot"``).
        what: What needs it, for the message (a module path, or ``"the 3-D web view"``).
        extra: The extra that installs it; default from :data:`EXTRA_OF`.

    Returns:
        The imported module.

    Raises:
        MissingExtra: the package (or a package it needs) is not installed.
    """
    try:
        return importlib.import_module(package)
    except ModuleNotFoundError as exc:
        # A missing dependency of the package counts as the package missing; a missing module
        # that belongs to no extra is somebody's bug and is not disguised.
        top = package.partition(".")[0]
        if exc.name is not None and exc.name.partition(".")[0] not in (top, *EXTRA_OF):
            raise
        raise MissingExtra(message(top, what, extra), name=top) from exc
