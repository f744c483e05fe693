"""Old module paths of the applications, kept importable for one release with a warning.

Release 0.2 put the applications (the CLI, the reproductions, the demo, the soak campaigns, the
benchmark runner, the physics scenarios, the viewers, the plots and the telerobotics study) under
:mod:`velfence.apps`, and the cobot simulator beside the other simulators in :mod:`velfence.sim`
(docs/architecture.md, "Library and applications"). Code that imports an old path — ``import
velfence.teleop``, ``from velfence.viz import plot_quiver`` — still works until 0.3: the finder
below imports the module under its new path, registers it under the old one too, and warns with a
:class:`DeprecationWarning` that names the new path. Nothing in velfence imports an old path.
"""

from __future__ import annotations

import importlib
import importlib.machinery
import sys
import warnings

TYPE_CHECKING = False  # typing.TYPE_CHECKING without importing typing (start-up time)
if TYPE_CHECKING:
    from types import ModuleType

__all__ = ["MOVED", "install", "new_name"]

#: Old module path -> new module path (a package's submodules follow their package).
MOVED: dict[str, str] = {
    "velfence.cli": "velfence.apps.cli",
    "velfence._entry": "velfence.apps._entry",
    "velfence.bench": "velfence.apps.bench",
    "velfence.demo": "velfence.apps.demo",
    "velfence.soak": "velfence.apps.soak",
    "velfence.soak_filter": "velfence.apps.soak_filter",
    "velfence.reproduce": "velfence.apps.reproduce",
    "velfence.robot_sim": "velfence.apps.scenarios",
    "velfence.teleop.viewer": "velfence.apps.viewer.server",
    "velfence.teleop": "velfence.apps.teleop",
    "velfence.viz.web": "velfence.apps.viewer.web",
    "velfence.viz": "velfence.apps.viz",
    "velfence.view": "velfence.apps.viewer.view",
    "velfence.cobot.sim": "velfence.sim.cobot",
    "velfence.bridge.zones": "velfence.io.zones",
}


def new_name(old: str) -> str | None:
    """The new path of a moved module, or ``None`` when ``old`` did not move.

    Args:
        old: A dotted module path such as ``"velfence.teleop.laser"``.

    Returns:
        The path it moved to (``"velfence.apps.teleop.laser"``), longest old prefix first.
    """
    for prefix in sorted(MOVED, key=len, reverse=True):
        if old == prefix or old.startswith(prefix + "."):
            return MOVED[prefix] + old[len(prefix) :]
    return None


class _AliasLoader:
    """Loads an old path as the module of its new path (importlib's Loader protocol)."""

    def __init__(self, new: str) -> None:
        self._new = new

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> ModuleType:
        warnings.warn(
            f"{spec.name} moved to {self._new}; the old path goes in velfence 0.3",
            DeprecationWarning,
            stacklevel=2,
        )
        return importlib.import_module(self._new)

    def exec_module(self, module: ModuleType) -> None:
        """The module is the new one, already executed."""


class _MovedFinder:
    """Finds the old paths of :data:`MOVED` (importlib's MetaPathFinder protocol)."""

    def find_spec(
        self, fullname: str, path: object = None, target: object = None
    ) -> importlib.machinery.ModuleSpec | None:
        new = new_name(fullname)
        if new is None:
            return None
        return importlib.machinery.ModuleSpec(fullname, _AliasLoader(new))  # type: ignore[arg-type]


_FINDER = _MovedFinder()


def install() -> None:
    """Put the finder of the old paths first on :data:`sys.meta_path` (once).

    First, so that a submodule of a moved package (``velfence.teleop.laser``) is the new module
    itself and never a second copy loaded from the package's path.
    """
    if _FINDER not in sys.meta_path:
        sys.meta_path.insert(0, _FINDER)
