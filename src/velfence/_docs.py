"""The one mechanism that gives every public class's ``__init__`` a docstring.

velfence documents a class's arguments once, in the class docstring (Google style: an ``Args:``
section, or ``Attributes:`` for a dataclass whose fields are its arguments). Python's
``help(Class.__init__)`` and :func:`inspect.getdoc` read the docstring of ``__init__`` itself,
which is empty for a dataclass and for most hand-written constructors, so they showed only
"Initialize self". :func:`document_inits`, called once at the end of every module with public
classes, gives each of the module's public classes (its ``__all__``) whose ``__init__`` has no
docstring one made from the class docstring: a first line naming the class, then the entries
of the class's ``Args:`` / ``Attributes:`` sections for the constructor's parameters, in the
constructor's order. The class docstring stays the one source; nothing is copied by hand.

``tests/test_init_docs.py`` walks every public class of the library and checks that its
``__init__`` docstring names each of its parameters.
"""

from __future__ import annotations

import contextlib

TYPE_CHECKING = False  # typing.TYPE_CHECKING without importing typing (start-up time)
if TYPE_CHECKING:
    from collections.abc import Mapping
    from typing import Any

__all__ = ["document_inits", "init_parameters"]

_SECTIONS = ("Args:", "Arguments:", "Attributes:", "Parameters:")


def init_parameters(cls: type) -> list[str]:
    """The names of the parameters of ``cls.__init__`` after ``self`` (no ``*args``/``**kw``).

    Args:
        cls: A class.

    Returns:
        The parameter names in order, positional ones first; ``[]`` for ``object.__init__``.
    """
    func: Any = cls.__init__  # type: ignore[misc]
    while hasattr(func, "__wrapped__"):  # through velfence._deprecate.renamed_args
        func = func.__wrapped__
    code = getattr(func, "__code__", None)
    if code is None:  # object.__init__ or a C slot wrapper: no parameters of its own
        return []
    n = code.co_argcount + code.co_kwonlyargcount
    return [name for name in code.co_varnames[1:n] if name != "_"]


def _entries(doc: str) -> dict[str, list[str]]:
    """The ``name: text`` entries of the docstring's argument and attribute sections."""
    lines = doc.expandtabs().splitlines()
    out: dict[str, list[str]] = {}
    i = 0
    while i < len(lines):
        head = lines[i].strip()
        indent = len(lines[i]) - len(lines[i].lstrip())
        i += 1
        if head not in _SECTIONS:
            continue
        name: str | None = None
        entry_depth = 0
        while i < len(lines):
            line = lines[i]
            if line.strip() and len(line) - len(line.lstrip()) <= indent:
                break  # the section ended
            text = line.strip()
            depth = len(line) - len(line.lstrip())
            key, sep, _ = text.partition(":")
            key = key.strip("*").split(" ", 1)[0]
            if sep and key.isidentifier() and (name is None or depth <= entry_depth):
                name, entry_depth = key, depth
                out.setdefault(name, [line[depth:]])
            elif name is not None and text:
                out[name].append("    " + text)
            i += 1
    return out


def _cleandoc(doc: str) -> str:
    """:func:`inspect.cleandoc` without importing inspect (start-up time)."""
    lines = doc.expandtabs().splitlines()
    rest = [len(x) - len(x.lstrip()) for x in lines[1:] if x.strip()]
    margin = min(rest, default=0)
    return "\n".join([lines[0].strip(), *(x[margin:] for x in lines[1:])]) if lines else ""


def init_doc(cls: type) -> str | None:
    """A docstring for ``cls.__init__`` made from the class docstring, or ``None`` (no doc).

    Args:
        cls: A class with an argument or attribute section in its docstring.

    Returns:
        The docstring; parameters the class docstring does not describe are left out.
    """
    doc = cls.__doc__
    if not doc:
        return None
    entries = _entries(_cleandoc(doc))
    params = init_parameters(cls)
    lines = [
        f"Create a {cls.__name__}; the class docstring describes it "
        f"(help({cls.__module__}.{cls.__qualname__}))."
    ]
    args = [line for p in params if p in entries for line in entries[p]]
    if args:
        lines += ["", "Args:", *("    " + a for a in args)]
    return "\n".join(lines)


def document_inits(namespace: Mapping[str, Any]) -> None:
    """Give the public classes of a module an ``__init__`` docstring made from their own.

    Call as ``document_inits(globals())`` at the end of the module. Only classes defined in the
    module and named in its ``__all__`` are touched, and only when their ``__init__`` is their
    own (not inherited) and has no docstring.

    Args:
        namespace: The module's globals.
    """
    module = namespace.get("__name__")
    for name in namespace.get("__all__", ()):
        cls = namespace.get(name)
        if not isinstance(cls, type) or cls.__module__ != module:
            continue
        init = cls.__dict__.get("__init__")
        if init is None or getattr(init, "__doc__", None):
            continue
        doc = init_doc(cls)
        if doc is not None:
            with contextlib.suppress(AttributeError, TypeError):  # a C-level __init__
                init.__doc__ = doc
