"""The vocabulary tables of docs/architecture.md name only what exists.

Every Python name the tables list (a class, a constant, ``Class(keyword=)``, a dotted
``velfence.…`` path, a kept name or an old one after "was") must resolve: a public name of
``velfence`` or of one of its library subpackages (an old name may warn, it must still resolve),
and a keyword must be a parameter of its class. Every C name (``vf_*`` / ``VF_*``, a
continuation such as ``_WORKSPACE`` after ``VF_FILTER_LEVEL_JOINT``, a ``VF_ERR_*`` wildcard, a
struct field such as ``jmax``) must appear in ``core/include/*.h``, and every binding class
(``ExactLaw``) in the compiled core's extension modules. So the table cannot drift from the code.
The parser is checked on a planted table.
"""

from __future__ import annotations

import importlib
import inspect
import pkgutil
import re
import warnings
from pathlib import Path
from typing import Any

import pytest

import velfence

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "architecture.md"
HEADER = "| Idea | Python (kept; was) | YAML key / value | CLI | C |"
PARAMS_HEADER = "| Idea | Name | Where (source symbol) |"
CODE = re.compile(r"`([^`]+)`")
CLASS = re.compile(r"^[A-Z][A-Za-z0-9]*[a-z][A-Za-z0-9]*$")
CONSTANT = re.compile(r"^[A-Z][A-Z0-9]*(?:_[A-Z0-9]+)+$")
CALL_KW = re.compile(r"^([A-Z]\w*)\((\w+)=\)$")
C_NAME = re.compile(r"^(?:vf|VF)_\w+\*?$")
C_CONT = re.compile(r"^_[A-Z][A-Z0-9_]*$")
C_FIELD = re.compile(r"^[a-z][a-z0-9_]*$")
BINDING = ("velfence_core._core", "velfence_core._nd", "velfence_core._filter")


def table(markdown: str, header: str) -> list[list[str]]:
    """The cells of the Markdown table under ``header`` (header and rule rows left out)."""
    body = markdown.split(header, 1)[1].split("\n\n", 1)[0]
    rows = []
    for line in body.strip("\n").splitlines()[1:]:
        cells = re.split(r"(?<!\\)\|", line.strip())[1:-1]
        rows.append([c.strip() for c in cells])
    return rows


def python_names(cell: str) -> list[str]:
    """The Python names a cell lists: classes, constants, ``Class(kw=)``, ``velfence.…`` paths."""
    out = []
    for code in CODE.findall(cell):
        if ", " in code:  # an argument list: (position, command), (Theta, Theta_dot)
            continue
        for piece in re.split(r"/\s*|\s+", code.strip()):
            piece = piece.strip()
            if any(
                (piece.startswith("velfence."), CALL_KW.match(piece), CLASS.match(piece))
            ) or CONSTANT.match(piece):
                out.append(piece)
    return out


def c_names(cell: str) -> list[str]:
    """The C names a cell lists, continuations expanded (``_JERK`` after ``VF_FILTER_LEVEL_JOINT``
    is ``VF_FILTER_LEVEL_JERK``); wildcards keep their ``*``; fields and binding classes as is."""
    out: list[str] = []
    last = ""
    for code in CODE.findall(cell):
        for piece in re.split(r"[,/().…\s]+", code):
            if not piece or piece == "velfence_core":
                continue
            if C_NAME.match(piece):
                if not piece.endswith("*"):
                    last = piece
                out.append(piece)
            elif C_CONT.match(piece):
                assert last, f"{piece} continues no name"
                prefix = last[: last.rindex("_")]  # VF_FILTER_LEVEL of VF_FILTER_LEVEL_JOINT
                candidates = [prefix + piece]
                while "_" in prefix[3:]:  # and shorter: VF_ZONE of VF_ZONE_OUTSIDE_CORNER
                    prefix = prefix[: prefix.rindex("_")]
                    candidates.append(prefix + piece)
                out.append("|".join(candidates))
            elif CLASS.match(piece) or C_FIELD.match(piece):
                out.append(piece)
    return out


MODULES: list[Any] = []


def _public() -> dict[str, list[Any]]:
    """Every public name of velfence's public modules (``__all__``, and the former names a
    package still resolves) -> the objects it names. A module whose extra is missing is left out.
    The modules are kept in :data:`MODULES` (old names a module serves with a warning)."""
    found: dict[str, list[Any]] = {}
    modules = ["velfence"] + [
        m.name
        for m in pkgutil.walk_packages(velfence.__path__, "velfence.", onerror=lambda _: None)
        if not any(p.startswith("_") for p in m.name.split("."))
        and (not m.name.startswith("velfence.apps.") or m.name.count(".") == 2)  # apps: packages
    ]
    for name in modules:
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", DeprecationWarning)
                mod = importlib.import_module(name)
        except ImportError:  # MissingExtra is an ImportError
            continue
        MODULES.append(mod)
        for attr in (*getattr(mod, "__all__", ()), *getattr(mod, "_FORMER", {})):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", DeprecationWarning)
                try:
                    found.setdefault(attr, []).append(getattr(mod, attr))
                except (AttributeError, ImportError):
                    continue
    return found


def python_problems(names: list[str], public: dict[str, list[Any]]) -> list[str]:
    bad = []
    for name in names:
        m = CALL_KW.match(name)
        if name.startswith("velfence."):
            module, _, attr = name.rpartition(".")
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", DeprecationWarning)
                    importlib.import_module(name)
                continue
            except ImportError:
                pass
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", DeprecationWarning)
                    getattr(importlib.import_module(module), attr)
            except (ImportError, AttributeError):
                bad.append(f"{name} does not import")
        elif m:
            owners = public.get(m[1], [])
            if not any(m[2] in inspect.signature(o).parameters for o in owners if callable(o)):
                bad.append(f"{name}: no public {m[1]} takes {m[2]}=")
        elif name not in public and not _old_name(name):
            bad.append(f"{name} is no public name of velfence or a subpackage")
    return bad


def _old_name(name: str) -> bool:
    """Whether a module of velfence still serves ``name`` (a renamed name, with a warning)."""
    for mod in MODULES:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DeprecationWarning)
            try:
                getattr(mod, name)
            except (AttributeError, ImportError):
                continue
        return True
    return False


def _header_text() -> str:
    return "".join(p.read_text(encoding="utf-8") for p in (ROOT / "core/include").glob("*.h"))


def c_problems(names: list[str], headers: str, binding: set[str]) -> list[str]:
    words = set(re.findall(r"\w+", headers))
    bad = []
    for name in names:
        if name.endswith("*"):
            if not re.search(rf"\b{re.escape(name[:-1])}\w+", headers):
                bad.append(f"{name}: no such names in core/include")
        elif "|" in name:
            if not any(c in words for c in name.split("|")):
                bad.append(f"{name.split('|')[0]} is not in core/include")
        elif CLASS.match(name):
            if name not in binding:
                bad.append(f"{name} is no class of the compiled core's binding")
        elif name not in words:
            bad.append(f"{name} is not in core/include")
    return bad


def _binding() -> set[str]:
    names: set[str] = set()
    for module in BINDING:
        names |= set(dir(importlib.import_module(module)))
    return names


ROWS = table(DOC.read_text(encoding="utf-8"), HEADER)
PARAM_ROWS = table(DOC.read_text(encoding="utf-8"), PARAMS_HEADER)


def test_the_tables_are_found() -> None:
    assert len(ROWS) >= 25
    assert all(len(r) == 5 for r in ROWS), [r[0] for r in ROWS if len(r) != 5]
    assert len(PARAM_ROWS) >= 7
    ideas = {r[0] for r in ROWS}
    assert {"jerk limit", "self-collision", "tools and payloads"} <= ideas


def test_every_python_name_of_the_vocabulary_resolves() -> None:
    public = _public()
    names = [n for r in ROWS for n in python_names(r[1])]
    names += [n for r in PARAM_ROWS for n in python_names(r[2])]
    assert {"JointJerkLimit", "LEVEL_JERK", "JointLimits(max_jerk=)", "SelfCollision"} <= set(names)
    bad = python_problems(names, public)
    assert not bad, bad


def test_every_c_name_of_the_vocabulary_is_in_the_headers() -> None:
    pytest.importorskip("velfence_core._filter")
    names = [n for r in ROWS for n in c_names(r[4])]
    assert "jmax" in names
    assert "VF_FILTER_LEVEL_JERK|VF_FILTER_LEVEL_JERK|VF_FILTER_JERK" in names or any(
        "VF_FILTER_LEVEL_JERK" in n for n in names
    )
    bad = c_problems(names, _header_text(), _binding())
    assert not bad, bad


def test_the_checks_report_a_planted_drift() -> None:
    planted = (
        f"{HEADER}\n|---|---|---|---|---|\n"
        "| a | `NoSuchClass`, `JointLimits(max_jerks=)`, `LEVEL_JERK` | — | — | "
        "`VF_FILTER_LEVEL_JOINT`, `_NOPE`, `jmaxx`, `VF_NOPE_*`, `NoLaw` |\n\n"
    )
    (row,) = table(planted, HEADER)
    py = python_problems(python_names(row[1]), _public())
    assert py == [
        "NoSuchClass is no public name of velfence or a subpackage",
        "JointLimits(max_jerks=): no public JointLimits takes max_jerks=",
    ]
    c = c_problems(c_names(row[4]), _header_text(), {"ExactLaw"})
    assert c == [
        "VF_FILTER_LEVEL_NOPE is not in core/include",
        "jmaxx is not in core/include",
        "VF_NOPE_*: no such names in core/include",
        "NoLaw is no class of the compiled core's binding",
    ]


def _listed(idea: str, after: str) -> list[str]:
    """The names the Python cell of row ``idea`` lists after ``after`` (up to a parenthesis)."""
    cell = next(r[1] for r in ROWS if r[0] == idea)
    text = cell.split(after, 1)[1].split("(", 1)[0]
    return [w.strip().strip("`") for w in text.split(",") if w.strip()]


def test_the_listed_levels_stages_and_zones_are_the_code_s() -> None:
    """The level, stage and zone names the table spells out are the code's, in order."""
    from velfence.filter import LEVEL_NAMES
    from velfence.shaping import STAGE_NAMES, ZONE_NAMES

    assert _listed("the filter's rows", "`LEVEL_NAMES` =") == list(LEVEL_NAMES)
    assert _listed("stages", "`STAGE_NAMES`:") == list(STAGE_NAMES)
    assert _listed("zones", "`ZONE_NAMES` / `Zone`:") == list(ZONE_NAMES)
