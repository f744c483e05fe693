"""The public API: every exported name resolves, is velfence's own and is documented.

"Documented" is checked against the Google docstring sections the rest of the project uses: a
non-empty docstring; every parameter of an exported function (and of an exported class's
constructor) named under ``Args:`` (or ``Attributes:`` for records); ``Returns:`` (or
``Yields:``) when the function returns something. Exported classes' keyword-only rule is
checked by ``tests/hostile/test_hostile.py::test_constructor_keyword_only_rule``.
"""

from __future__ import annotations

import enum
import importlib
import inspect
import pkgutil
import re
import subprocess
import sys
from types import ModuleType
from typing import Any

import pytest

import velfence as vf
import velfence.apps

#: ``velfence`` and its public modules (a leading underscore marks a private one).
_SUBMODULES = [
    f"{package.__name__}.{m.name}"
    for package in (vf, vf.apps)
    for m in pkgutil.iter_modules(package.__path__)
    if not m.name.startswith("_") and m.name != "apps"
]
MODULES = ["velfence", *sorted(_SUBMODULES)]

#: Exported names whose docstrings miss a section, as ``module.name: problem``. Open defects:
#: a new one fails :func:`test_exported_callables_are_documented`, and so does a listed one that
#: is fixed (remove it from here; the list may only shrink).
UNDOCUMENTED: set[str] = set()


def _import(name: str) -> ModuleType:
    """The module, or a skip when an optional dependency (an extra) is not installed."""
    try:
        return importlib.import_module(name)
    except ModuleNotFoundError as exc:
        if exc.name is None or exc.name.split(".")[0] == "velfence":
            raise  # a broken module of ours is a failure, not a skip
        pytest.skip(f"{name} needs {exc.name} (an optional extra)")


# ------------------------------------------------------------------------------- names resolve


@pytest.mark.parametrize("module", MODULES)
def test_every_exported_name_resolves_to_velfence_s_own_object(module: str) -> None:
    """``from module import name`` works for every name, and no class or function is another
    project's (instances such as the typer ``app`` are velfence's own objects)."""
    mod = _import(module)
    exported = getattr(mod, "__all__", None)
    assert exported is not None, f"{module} has no __all__"
    assert len(set(exported)) == len(exported), "duplicates in __all__"
    foreign = []
    for name in exported:
        ns: dict[str, Any] = {}
        exec(f"from {module} import {name}", ns)  # what a user writes; AttributeError -> fails
        obj = ns[name]
        defined = inspect.isfunction(obj) or inspect.isclass(obj)
        owner = getattr(obj, "__module__", None) if defined else None
        if owner is not None and not owner.startswith("velfence"):
            foreign.append(f"{name} (from {owner})")
    assert not foreign, f"{module} re-exports other projects' objects: {foreign}"


def test_top_level_reexports_are_the_subpackage_objects() -> None:
    """``velfence.X`` is the very object of the sub-package that defines it (no second copy)."""
    for name in vf.__all__:
        obj = getattr(vf, name)
        home = getattr(obj, "__module__", "")
        if not callable(obj) or not home.startswith("velfence."):
            continue
        defining = importlib.import_module(home)
        # A name renamed in 0.2 (velfence.Obstacle, velfence.ShaperResult) is the object under
        # its new name there; asking the module for the old name would warn.
        assert getattr(defining, getattr(obj, "__name__", name), obj) is obj, name


# ------------------------------------------------------------------------------- documentation

_SECTION = re.compile(r"^(Args|Attributes):[ \t]*\n((?:[ \t]+\S.*\n?|[ \t]*\n)*)", re.M)
_RETURNS = re.compile(r"^(Returns|Yields):", re.M)


def _documented_names(doc: str) -> set[str]:
    """Names listed under the ``Args:`` / ``Attributes:`` sections of a docstring."""
    out = set()
    for section in _SECTION.finditer(doc):
        body = section.group(2)
        indent = min(len(line) - len(line.lstrip()) for line in body.splitlines() if line.strip())
        entry = re.compile(rf"^[ \t]{{{indent}}}\**(\w+)\b[^:\n]*:", re.M)
        out |= {m.group(1) for m in entry.finditer(body)}
    return out


def _parameters(obj: Any) -> tuple[inspect.Signature | None, list[str]]:
    try:
        sig = inspect.signature(obj)
    except (TypeError, ValueError):  # a builtin without a signature
        return None, []
    named = [
        p.name
        for p in sig.parameters.values()
        if p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD) and p.name not in ("self", "cls")
    ]
    return sig, named


def doc_problems(key: str, obj: Any) -> list[str]:
    """What the docstring of one exported function or class lacks (empty: nothing)."""
    doc = inspect.getdoc(obj) or ""
    if not doc.strip():
        return [f"{key}: no docstring"]
    if inspect.isclass(obj):
        if issubclass(obj, BaseException) or getattr(obj, "_is_protocol", False):
            return []
        if issubclass(obj, enum.Enum):  # looked up by value (``SafetyMode("stop")``): no Args
            return []
        init = obj.__dict__.get("__init__")
        doc += "\n" + inspect.cleandoc(getattr(init, "__doc__", None) or "")
    sig, params = _parameters(obj)
    problems = []
    missing = sorted(set(params) - _documented_names(doc))
    if missing:
        problems.append(f"{key}: parameters not under Args: {', '.join(missing)}")
    returns = None if sig is None else sig.return_annotation
    if (
        inspect.isfunction(obj)
        and returns not in (None, "None", inspect.Signature.empty)
        and not _RETURNS.search(doc)
    ):
        problems.append(f"{key}: no Returns section")
    return problems


def _exported_callables() -> tuple[dict[str, Any], list[str]]:
    """``module.name`` -> object for every exported function and class (first exporter wins,
    sub-modules before ``velfence`` itself), and the modules that could not be imported."""
    found: dict[int, tuple[str, Any]] = {}
    skipped = []
    for module in [*MODULES[1:], MODULES[0]]:
        try:
            mod = importlib.import_module(module)
        except ModuleNotFoundError as exc:
            if exc.name is None or exc.name.split(".")[0] == "velfence":
                raise
            skipped.append(f"{module} (needs {exc.name})")
            continue
        for name in getattr(mod, "__all__", ()):
            obj = getattr(mod, name)
            if inspect.isfunction(obj) or inspect.isclass(obj):
                found.setdefault(id(obj), (f"{module}.{name}", obj))
    return dict(found.values()), skipped


def test_doc_problems_finds_what_it_claims() -> None:
    def bare(x: float) -> float:
        """Twice x."""
        return 2 * x

    def good(x: float, *, y: int = 0) -> float:
        """Twice x.

        Args:
            x: A number.
            y: Another.

        Returns:
            2 x.
        """
        return 2 * x

    class Rec:
        """A record.

        Attributes:
            a: First.
        """

        def __init__(self, a: int, b: int) -> None:
            self.a, self.b = a, b

    assert doc_problems("bare", bare) == [
        "bare: parameters not under Args: x",
        "bare: no Returns section",
    ]
    assert doc_problems("good", good) == []
    assert doc_problems("Rec", Rec) == ["Rec: parameters not under Args: b"]
    assert doc_problems("none", lambda: None) == ["none: no docstring"]


def test_exported_callables_are_documented() -> None:
    exported, skipped = _exported_callables()
    assert len(exported) > 150  # the enumeration found the API, not nothing
    problems = {p for key, obj in exported.items() for p in doc_problems(key, obj)}
    unavailable = tuple(s.split(" ")[0] + "." for s in skipped)
    known = {k for k in UNDOCUMENTED if not k.startswith(unavailable)}
    new = sorted(problems - known)
    fixed = sorted(known - problems)
    msg = []
    if new:
        msg.append("undocumented public names:\n  " + "\n  ".join(new))
    if fixed:
        msg.append("fixed, remove from UNDOCUMENTED:\n  " + "\n  ".join(fixed))
    assert not msg, "\n".join(msg)


# ------------------------------------------------------------------------------- packaging


def test_version_is_single_sourced() -> None:
    from importlib.metadata import PackageNotFoundError, version

    try:
        installed = version("velfence")
    except PackageNotFoundError:
        pytest.skip("velfence is not installed (no metadata to compare with)")
    assert vf.__version__ == installed


def test_core_import_is_light() -> None:
    code = (
        "import sys, velfence; "
        "heavy = [m for m in ('matplotlib', 'mujoco', 'numba', 'qpsolvers', 'pydantic', 'typer', "
        "'yaml', 'mink', 'imageio_ffmpeg', 'cyclonedds', 'rosbags', 'mcap', 'foxglove') "
        "if m in sys.modules]; print(','.join(heavy))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == ""
