"""The top-level facade: the names it exposes, lazy loading, and the deprecated names and paths.

``import velfence`` must stay cheap (no NumPy, no subpackage until a name is touched; its time is
measured in benchmarks/startup.py, never here), every facade name must resolve to its
subpackage's own object, every name the top level dropped in 0.2 must still resolve with a
DeprecationWarning naming its new home, and every moved module path must import as the very same
module object with a warning.
"""

from __future__ import annotations

import ast
import importlib
import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

import velfence
from velfence import _moved

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def _fresh(code: str) -> str:
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=120
    )
    return out.stdout


def test_import_velfence_loads_no_numpy_and_no_subpackage() -> None:
    code = (
        "import json, sys; import velfence; "
        "print(json.dumps(sorted(m for m in sys.modules if m.startswith(('velfence', 'numpy')))))"
    )
    loaded = json.loads(_fresh(code))
    assert loaded == [
        "velfence",
        "velfence._deprecate",
        "velfence._lazy",
        "velfence._moved",
        "velfence.errors",
    ]


def test_first_use_loads_only_what_it_needs() -> None:
    code = (
        "import json, sys; import velfence; velfence.ConvexPolygon; "
        "print(json.dumps(sorted(m for m in sys.modules if m.startswith('velfence.'))))"
    )
    loaded = set(json.loads(_fresh(code)))
    assert "velfence.geometry" in loaded
    assert not loaded & {"velfence.filter", "velfence.robots", "velfence.sim", "velfence.io"}


def test_the_facade_is_narrow_and_sorted() -> None:
    names = [n for n in velfence.__all__ if n != "__version__"]
    assert 20 <= len(names) <= 40
    assert set(names) == set(velfence._FACADE)
    assert len(set(velfence.__all__)) == len(velfence.__all__)


@pytest.mark.parametrize("name", sorted(velfence._FACADE))
def test_every_facade_name_is_its_subpackage_s_object(name: str) -> None:
    home = importlib.import_module(velfence._FACADE[name])
    assert getattr(velfence, name) is getattr(home, name)
    assert name in getattr(home, "__all__", ())


@pytest.mark.parametrize("name", sorted(velfence._FORMER))
def test_former_top_level_names_warn_and_still_work(name: str) -> None:
    home, _, new = velfence._FORMER[name].partition(":")
    new = new or name
    with pytest.warns(DeprecationWarning, match=rf"'{name}' is now '{home}\.{new}'.*goes in 0\.3"):
        value = getattr(velfence, name)
    assert value is getattr(importlib.import_module(home), new)
    assert name not in velfence.__all__


def test_subpackages_resolve_as_attributes() -> None:
    code = "import velfence as vf; print(vf.geometry.Circle.__name__, vf.filter.__name__)"
    assert _fresh(code).split() == ["Circle", "velfence.filter"]
    with pytest.raises(AttributeError, match="no attribute 'no_such_thing'"):
        velfence.no_such_thing  # noqa: B018


@pytest.mark.parametrize("old", sorted(_moved.MOVED))
def test_moved_module_paths_import_the_same_module_with_a_warning(old: str) -> None:
    code = (
        "import importlib, json, warnings\n"
        "with warnings.catch_warnings(record=True) as w:\n"
        "    warnings.simplefilter('always')\n"
        f"    old = importlib.import_module({old!r})\n"
        f"new = importlib.import_module({_moved.MOVED[old]!r})\n"
        "print(json.dumps([old is new, [str(x.message) for x in w\n"
        "                  if issubclass(x.category, DeprecationWarning)]]))\n"
    )
    same, messages = json.loads(_fresh(code))
    assert same
    assert any(_moved.MOVED[old] in m and "goes in velfence 0.3" in m for m in messages)


def test_a_submodule_of_a_moved_package_is_not_loaded_twice() -> None:
    code = (
        "import warnings; warnings.simplefilter('ignore')\n"
        "import velfence.teleop.laser as a, velfence.apps.teleop.laser as b\n"
        "print(a is b, a.__name__)\n"
    )
    assert _fresh(code).split() == ["True", "velfence.apps.teleop.laser"]


def test_new_name_maps_longest_prefix_first() -> None:
    assert _moved.new_name("velfence.teleop.viewer") == "velfence.apps.viewer.server"
    assert _moved.new_name("velfence.teleop.laser") == "velfence.apps.teleop.laser"
    assert _moved.new_name("velfence.viz.web") == "velfence.apps.viewer.web"
    assert _moved.new_name("velfence.soak_filter") == "velfence.apps.soak_filter"
    assert _moved.new_name("velfence.filter") is None
    assert _moved.new_name("velfence.simulation") is None


def _package_of(module: str) -> bool:
    """Whether an example may import ``module``: velfence, a library subpackage (not one of its
    modules), or a public module of an application (the applications have no narrower facade)."""
    parts = module.split(".")
    if parts[0] != "velfence" or len(parts) == 1:
        return True
    if any(p.startswith("_") for p in parts):
        return False
    return parts[1] == "apps" or len(parts) == 2


def import_problems(tree: ast.AST, pending: frozenset[str] = frozenset()) -> list[str]:
    """Imports of velfence in ``tree`` that name a module, not its package (a library module
    path such as ``velfence.geometry.polytope``, or anything private), or a name the package
    does not export (``__all__``). ``pending``: module paths tolerated for now."""
    bad = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("velfence"):
            if node.module in pending:
                continue
            if not _package_of(node.module):
                bad.append(f"line {node.lineno}: from {node.module} (a module, not a package)")
                continue
            module = importlib.import_module(node.module)
            exported = set(getattr(module, "__all__", ()))
            bad += [
                f"line {node.lineno}: {node.module}.{a.name} is not in its __all__"
                for a in node.names
                if a.name not in exported
            ]
        elif isinstance(node, ast.Import):
            bad += [
                f"line {node.lineno}: import {a.name}"
                for a in node.names
                if a.name.startswith("velfence")
                and not _package_of(a.name)
                and a.name not in pending
            ]
    return bad


@pytest.mark.parametrize("path", sorted(EXAMPLES.glob("*.py")), ids=lambda p: p.name)
def test_examples_import_only_public_paths(path: Path) -> None:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    bad = import_problems(tree)
    assert not bad, f"{path.name}: " + "; ".join(bad)


ROOT = EXAMPLES.parent
FENCE = re.compile(r"^```python[ \t]*\n(.*?)^```[ \t]*$", re.M | re.S)
#: Module paths of the docs another change moves (the arm scene's module is being renamed; its
#: docs lines move with it). Tolerated until then; the list may only shrink.
PENDING = frozenset({"velfence.sim.arm"})


def _doc_blocks() -> list[tuple[str, int, str]]:
    pages = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
    blocks = []
    for page in pages:
        text = page.read_text(encoding="utf-8")
        for m in FENCE.finditer(text):
            line = text.count("\n", 0, m.start()) + 1
            blocks.append((page.relative_to(ROOT).as_posix(), line, m.group(1)))
    return blocks


DOC_BLOCKS = _doc_blocks()


def test_the_docs_have_python_blocks_to_check() -> None:
    assert len(DOC_BLOCKS) >= 40
    assert {p for p, _, _ in DOC_BLOCKS} >= {"README.md", "docs/safety_filter.md", "docs/zones.md"}


@pytest.mark.parametrize(
    ("page", "line", "code"), DOC_BLOCKS, ids=[f"{p}:{n}" for p, n, _ in DOC_BLOCKS]
)
def test_docs_import_only_public_paths(page: str, line: int, code: str) -> None:
    """Every python block of README.md and docs/ imports velfence the way the examples must:
    from a package (``velfence.geometry``, not ``velfence.geometry.polytope``), names in its
    ``__all__``, nothing private."""
    bad = import_problems(ast.parse(code), PENDING)
    assert not bad, f"{page}:{line}: " + "; ".join(bad)


def test_the_import_rule_refuses_deep_and_private_paths() -> None:
    code = (
        "from velfence.geometry.polytope import ConvexPolytope\n"
        "from velfence.geometry import ConvexPolytope\n"
        "from velfence.filter import _ccycle\n"
        "import velfence.io.zones\n"
        "from velfence.integrations import NoSuchName\n"
        "from velfence.apps.bench import run_benchmarks\n"
        "from velfence.sim.arm import TwistMode\n"
    )
    assert import_problems(ast.parse(code), PENDING) == [
        "line 1: from velfence.geometry.polytope (a module, not a package)",
        "line 3: velfence.filter._ccycle is not in its __all__",
        "line 4: import velfence.io.zones",
        "line 5: velfence.integrations.NoSuchName is not in its __all__",
    ]
