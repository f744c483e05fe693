"""The one place for renamed names: old keywords, old attributes and old module-level names.

Release 0.2 gave every idea of velfence one name (the table in docs/architecture.md,
"Vocabulary"). A name that changed keeps working until 0.3 and warns with a
:class:`DeprecationWarning` naming the new one:

* :func:`renamed_args` — a callable's old keyword arguments (``SafetyFilter.filter(q=...,
  qd_cmd=...)`` is ``filter(position=..., command=...)``); positional callers are unaffected;
* :func:`module_getattr` — a module's old names (``velfence.shaping.ShaperResult`` is
  ``ShapingResultProtocol``), for the module's ``__getattr__``;
* :func:`positional_deprecated` — a tuning parameter made keyword-only: a positional call in
  the old order still works and warns;
* :func:`method_name` — a controller's ``.method`` string given as input (``methods=``, the
  CLI's ``--methods``) in its spelling before 0.2 (:data:`FORMER_METHODS`);
* :func:`warn_renamed` — anything else (an old YAML key or value, an old attribute).

Every message contains "goes in 0.3".
"""

from __future__ import annotations

import functools
import warnings

from velfence.errors import InvalidParameter

TYPE_CHECKING = False  # typing.TYPE_CHECKING without importing typing: `import velfence` uses
if TYPE_CHECKING:  # warn_renamed through velfence._lazy and must stay cheap
    from collections.abc import Callable, Mapping
    from typing import Any, TypeVar

    F = TypeVar("F", bound=Callable[..., Any])

__all__ = [
    "FORMER_METHODS",
    "REMOVED_IN",
    "method_name",
    "module_getattr",
    "positional_deprecated",
    "renamed_args",
    "renamed_attribute",
    "warn_renamed",
]

#: The release that removes the old names.
REMOVED_IN = "0.3"

#: ``.method`` values and run names before 0.2 -> the vocabulary's kebab-case name
#: (docs/architecture.md): the arm baselines, the safety filter's twist mode, configuration
#: control, and the variants the MuJoCo scenarios compare.
FORMER_METHODS: dict[str, str] = {
    "no limit": "no-limit",
    "per-joint clamp": "per-joint-clamp",
    "scalar scale": "scalar-scale",
    "damper QP": "velocity-damper-qp",
    "velfence": "safety-filter",
    "configuration control": "configuration-control",
    "no avoidance": "no-avoidance",
    "velfence + look-ahead": "safety-filter-look-ahead",
    "velfence + jerk rows": "safety-filter-jerk-rows",
    "velfence, no jerk rows": "safety-filter-no-jerk-rows",
}


def warn_renamed(what: str, old: str, new: str, *, stacklevel: int = 3) -> None:
    """Warn that ``old`` is now called ``new``.

    Args:
        what: What was renamed, for the message ("keyword argument of SafetyFilter.filter").
        old: The old name.
        new: The name to use.
        stacklevel: Passed to :func:`warnings.warn` (3: the caller of the caller).
    """
    warnings.warn(
        f"{what} {old!r} is now {new!r}; the old name goes in {REMOVED_IN}",
        DeprecationWarning,
        stacklevel=stacklevel,
    )


def method_name(name: object, *, what: str = "method name", stacklevel: int = 4) -> object:
    """``name``, or its vocabulary name with a warning when it is a ``.method`` before 0.2.

    Anything that is not a former name passes through unchanged (the caller validates it).

    Args:
        name: A method name as given by a user.
        what: What it is, for the message ("arm-box method name").
        stacklevel: Passed to :func:`warnings.warn` (4: the caller of the caller's caller).

    Returns:
        The name to use.
    """
    if isinstance(name, str) and name in FORMER_METHODS:
        warn_renamed(what, name, FORMER_METHODS[name], stacklevel=stacklevel)
        return FORMER_METHODS[name]
    return name


def renamed_args(**renames: str) -> Callable[[F], F]:
    """Accept a callable's old keyword arguments, with a warning, under their new names.

    ``@renamed_args(q="position", qd_cmd="command")`` lets ``f(q=..., qd_cmd=...)`` run as
    ``f(position=..., command=...)`` and warn; positional calls and the new keywords pass
    straight through. Giving both the old and the new name of one argument raises
    :class:`~velfence.errors.InvalidParameter`.

    Args:
        **renames: Old keyword name -> new keyword name.

    Returns:
        The decorator.
    """

    def decorate(func: F) -> F:
        import inspect  # only where a rename is declared (start-up time of `import velfence`)

        qualname = func.__qualname__
        params = list(inspect.signature(func).parameters)
        # How many positional arguments reach each new name (it was given positionally then).
        position = {new: params.index(new) for new in renames.values()}

        @functools.wraps(func)
        def wrapper(*args: Any, **kwargs: Any) -> Any:
            if kwargs:
                for old in renames.keys() & kwargs.keys():
                    new = renames[old]
                    if new in kwargs or len(args) > position[new]:
                        raise InvalidParameter(
                            f"{qualname}() got {old!r} and {new!r}, two names of one argument; "
                            f"pass {new!r} only"
                        )
                    warn_renamed(f"keyword argument of {qualname}()", old, new)
                    kwargs[new] = kwargs.pop(old)
            return func(*args, **kwargs)

        wrapper.__renamed_args__ = dict(renames)  # type: ignore[attr-defined]
        return wrapper  # type: ignore[return-value]

    return decorate


def positional_deprecated(n_positional: int, old_order: tuple[str, ...]) -> Callable[[F], F]:
    """Accept, with a warning, positional calls of parameters that became keyword-only.

    ``@positional_deprecated(1, ("center", "half_extents"))`` on ``f(center, *, half_extents)``
    lets the old call ``f(c, h)`` run as ``f(c, half_extents=h)`` and warn. A call with more
    than ``n_positional`` positional arguments is read in the old order ``old_order`` (the
    parameters' old positional order, which may differ from the new one); calls within
    ``n_positional`` pass straight through.

    Args:
        n_positional: How many positional arguments the new signature takes (counting ``self``
            for a method).
        old_order: The names the positional arguments had, in their old order (``self`` first
            for a method).

    Returns:
        The decorator.
    """

    def decorate(func: F) -> F:
        qualname = func.__qualname__
        moved = ", ".join(old_order[n_positional:])

        @functools.wraps(func)
        def wrapper(*args: Any, **kwargs: Any) -> Any:
            if len(args) <= n_positional:
                return func(*args, **kwargs)
            if len(args) > len(old_order):
                raise InvalidParameter(
                    f"{qualname}() takes at most {len(old_order)} positional arguments, got "
                    f"{len(args)}; pass {moved} by keyword"
                )
            named = dict(zip(old_order, args, strict=False))
            twice = sorted(named.keys() & kwargs.keys())
            if twice:
                raise InvalidParameter(f"{qualname}() got {twice} positionally and by keyword")
            late = [n for n in old_order[: len(args)] if n in old_order[n_positional:]]
            warnings.warn(
                f"{qualname}(): passing {', '.join(late)} positionally is deprecated; pass "
                f"{', '.join(f'{n}=...' for n in late)} (positional use goes in {REMOVED_IN})",
                DeprecationWarning,
                stacklevel=2,
            )
            return func(**named, **kwargs)  # every argument by name: the new order is moot

        wrapper.__positional_deprecated__ = old_order[n_positional:]  # type: ignore[attr-defined]
        return wrapper  # type: ignore[return-value]

    return decorate


def module_getattr(
    module: str, renames: Mapping[str, str], namespace: Mapping[str, Any]
) -> Callable[[str], Any]:
    """A module ``__getattr__`` that serves old names with a warning.

    Use as ``__getattr__ = module_getattr(__name__, {"Old": "New"}, globals())``.

    Args:
        module: The module's name, for messages.
        renames: Old name -> new name (the new one a global of the module).
        namespace: The module's globals.

    Returns:
        The ``__getattr__`` function.
    """

    def __getattr__(name: str) -> Any:  # noqa: N807 (the module hook's own name)
        new = renames.get(name)
        if new is None:
            raise AttributeError(f"module {module!r} has no attribute {name!r}")
        warn_renamed(f"name in {module}", name, new)
        return namespace[new]

    return __getattr__


def renamed_attribute(old: str, new: str) -> Any:
    """A read-only property serving attribute ``new`` under its old name ``old``, with a warning.

    Use in a class body: ``max_velocity = renamed_attribute("max_velocity", "max_speed")``.

    Args:
        old: The old attribute name.
        new: The attribute to read.

    Returns:
        The property.
    """

    def get(self: Any) -> Any:
        warn_renamed(f"attribute of {type(self).__name__}", old, new)
        return getattr(self, new)

    return property(get, doc=f"Deprecated name of :attr:`{new}` (goes in {REMOVED_IN}).")
