"""Package attributes loaded on first use (PEP 562), so importing a package stays cheap.

A package lists ``name -> defining module`` and gets a module ``__getattr__`` and ``__dir__``;
the first access imports the defining module and caches the value in the package's namespace, and
a subpackage's name (``vf.geometry`` after ``import velfence as vf``) imports that subpackage.
Names the package once exported and now only lists elsewhere resolve with a
:class:`DeprecationWarning` that names their home, until the release the message gives. Type
checkers see the names through an ``if TYPE_CHECKING:`` block of ordinary imports in the package.
"""

from __future__ import annotations

import importlib

from velfence._deprecate import warn_renamed

TYPE_CHECKING = False  # typing.TYPE_CHECKING without importing typing (start-up time)
if TYPE_CHECKING:
    from collections.abc import Callable
    from typing import Any

__all__ = ["attach"]


def attach(
    package: str,
    exports: dict[str, str],
    namespace: dict[str, Any],
    former: dict[str, str] | None = None,
) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """The ``__getattr__`` and ``__dir__`` of a package whose names load on first use.

    Args:
        package: The package's dotted name (for messages).
        exports: Public name -> the module that defines it.
        namespace: The package's ``globals()``; a loaded name is stored there, so later lookups
            never reach ``__getattr__`` again.
        former: Name the package no longer exports -> where it lives now, ``"module"`` or
            ``"module:new_name"`` when it was renamed too; each access warns
            (``DeprecationWarning``; the old name goes in 0.3).

    Returns:
        ``(__getattr__, __dir__)`` to bind at the package's top level.
    """
    moved = dict(former or {})

    def get_attribute(name: str) -> Any:
        module = exports.get(name)
        if module is not None:
            value = getattr(importlib.import_module(module), name)
            namespace[name] = value
            return value
        home = moved.get(name)
        if home is not None:
            module, _, new = home.partition(":")
            new = new or name
            warn_renamed(f"name in {package}", name, f"{module}.{new}")
            return getattr(importlib.import_module(module), new)
        if not name.startswith("_"):  # a subpackage, as ``import velfence as vf; vf.geometry``
            try:
                return importlib.import_module(f"{package}.{name}")
            except ModuleNotFoundError as exc:
                if exc.name != f"{package}.{name}":
                    raise
        raise AttributeError(f"module {package!r} has no attribute {name!r}")

    def list_names() -> list[str]:
        return sorted(set(namespace) | set(exports))

    return get_attribute, list_names
