"""No private names across packages (docs/architecture.md, "Package boundaries").

A package is a first-level subpackage of ``velfence`` (geometry, shaping, io, bridge, ...) or of
``velfence.apps`` (viz, teleop, ...); the top-level modules ``velfence._validate``,
``velfence._typing``, ``velfence._moved`` and ``velfence._extras`` are the library's shared
internals (importable everywhere, but their private names are theirs alone). The scripts of
``benchmarks/`` are scanned too, as code outside every package. An AST scan reports, with file
and line:

* ``from a.b import _x`` where ``a.b`` is in another package;
* ``import a._b`` / ``from a import _b`` / ``from a._b import x`` of a private module of another
  package, and ``importlib.import_module("a._b")`` (any call whose first argument is such a
  string);
* ``m._x`` where ``m`` names a module of another package imported in the file, also through a
  chain (``import a.b.c`` then ``a.b.c._x``), the shared internals included
  (``_validate._x``);
* a compiled-core binding module (``velfence_core._x``) named anywhere in the library but in
  ``velfence.shaping.backend``, the one loader (in an import or an ``import_module`` string).

The compiled core's extension modules (``velfence_core._core``, ``._nd``, ``._filter``) are the
binding's public surface, not velfence's private names: code outside the library (the
benchmarks, which time the binding itself) may import them. That is the one exemption.

The scanner itself is run on small packages in ``tmp_path``: one with each kind of violation
planted (all reported) and a clean one (nothing reported).
"""

from __future__ import annotations

import ast
import re
import textwrap
from pathlib import Path

import pytest

import velfence

PACKAGE = Path(velfence.__file__).resolve().parent
SHARED = frozenset({"_validate", "_typing", "_moved", "_extras"})
CORE_LOADER = "shaping.backend"


def _private(name: str) -> bool:
    return name.startswith("_") and not name.startswith("__")


def _module_name(root: Path, path: Path) -> str:
    parts = list(path.relative_to(root.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _package(module: str) -> str:
    """The package a module belongs to: ``top.X`` or ``top.apps.X`` (or ``top`` itself)."""
    parts = module.split(".")
    depth = 3 if len(parts) >= 3 and parts[1] == "apps" else 2
    return ".".join(parts[:depth])


def _private_module_owner(module: str, top: str) -> str | None:
    """The module whose private submodule ``module`` is (``top.shaping`` for ``_kernels``)."""
    parts = module.split(".")
    for i in range(1, len(parts)):
        if _private(parts[i]):
            if i == 1 and parts[0] == top and parts[i] in SHARED:
                return None
            return ".".join(parts[:i])
    return None


def _is_module(root: Path, dotted: str) -> bool:
    rel = Path(*dotted.split(".")[1:]) if "." in dotted else Path()
    base = root / rel
    return base.with_suffix(".py").is_file() or (base / "__init__.py").is_file()


def _dotted(node: ast.AST) -> str | None:
    """``a.b.c`` of a chain of attribute lookups on a name, or None."""
    parts = []
    while isinstance(node, ast.Attribute):
        parts.append(node.attr)
        node = node.value
    if not isinstance(node, ast.Name):
        return None
    return ".".join([node.id, *reversed(parts)])


def _files(root: Path, outside: tuple[Path, ...]) -> list[tuple[Path, str, bool]]:
    """``(path, module name, inside the package)`` of every file scanned."""
    files = [(p, _module_name(root, p), True) for p in sorted(root.rglob("*.py"))]
    for folder in outside:
        files += [(p, f"{folder.name}.{p.stem}", False) for p in sorted(folder.glob("*.py"))]
    return files


def scan(root: Path, core: str = "velfence_core", outside: tuple[Path, ...] = ()) -> list[str]:
    """Every cross-package private name in the package at ``root`` and in the scripts of the
    folders ``outside`` (code of no package): ``file:line: what``."""
    top = root.name
    found: list[str] = []
    for path, module, inside in _files(root, outside):
        here = _package(module) if inside else module
        is_pkg = path.name == "__init__.py"
        tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
        where = f"{path.relative_to(root.parent if inside else path.parent.parent)}"
        modules: dict[str, str] = {}  # local name -> module of this package tree
        # the compiled core's binding modules: only the loader in the library; outside, public
        core_ok = module.endswith("." + CORE_LOADER) or not inside

        def report(node: ast.AST, what: str, where: str = where) -> None:
            found.append(f"{where}:{getattr(node, 'lineno', 0)}: {what}")

        def foreign_private_module(target: str, node: ast.AST) -> None:
            owner = _private_module_owner(target, top)
            inside = module == owner or module.startswith(f"{owner}.")  # noqa: B023
            if owner is not None and not inside:
                report(node, f"imports the private module {target} of {owner}")

        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                for alias in node.names:
                    if alias.name.split(".")[0] == core and _private_module_owner(alias.name, top):
                        if not core_ok:
                            report(node, f"imports the compiled core's {alias.name}")
                        continue
                    if alias.name.split(".")[0] != top:
                        continue
                    foreign_private_module(alias.name, node)
                    if alias.asname:
                        modules[alias.asname] = alias.name
                    else:  # ``import a.b.c`` binds ``a``: chains a.b.c._x are resolved below
                        modules[top] = top
            elif isinstance(node, ast.ImportFrom):
                if node.level:
                    base = module.split(".") if is_pkg else module.split(".")[:-1]
                    base = base[: len(base) - node.level + 1]
                    target = ".".join([*base, *([node.module] if node.module else [])])
                else:
                    target = node.module or ""
                if target.split(".")[0] == core:
                    names = [f"{target}.{a.name}" for a in node.names]
                    if any(_private_module_owner(n, top) for n in [target, *names]) and (
                        not core_ok
                    ):
                        report(node, f"imports from the compiled core's {target}")
                    continue
                if target.split(".")[0] != top:
                    continue
                foreign_private_module(target, node)
                for alias in node.names:
                    full = f"{target}.{alias.name}"
                    if _is_module(root, full):
                        foreign_private_module(full, node)
                        modules[alias.asname or alias.name] = full
                    elif _private(alias.name) and _package(target) != here:
                        report(node, f"imports the private name {alias.name} from {target}")
            elif (
                isinstance(node, ast.Call)
                and node.args
                and isinstance(node.args[0], ast.Constant)
                and isinstance(node.args[0].value, str)
            ):
                named = node.args[0].value
                if named.split(".")[0] == core and _private_module_owner(named, top):
                    if not core_ok:
                        report(node, f"names the compiled core's {named}")
                elif named.split(".")[0] == top and re.fullmatch(r"[\w.]+", named):
                    foreign_private_module(named, node)
        for node in ast.walk(tree):
            if not (isinstance(node, ast.Attribute) and _private(node.attr)):
                continue
            dotted = _dotted(node.value)
            if dotted is None:
                continue
            first, _, rest = dotted.partition(".")
            if first not in modules:
                continue
            owner = ".".join(p for p in (modules[first], rest) if p)
            if owner == top or not _is_module(root, owner):
                continue
            if _package(owner) != here:
                report(node, f"uses the private name {node.attr} of {owner}")
    return found


BENCHMARKS = PACKAGE.parents[1] / "benchmarks"


def test_no_private_names_across_packages() -> None:
    assert BENCHMARKS.is_dir()
    found = scan(PACKAGE, outside=(BENCHMARKS,))
    assert found == [], "private names used across packages:\n" + "\n".join(found)


def _toy(tmp_path: Path, files: dict[str, str]) -> Path:
    root = tmp_path / "toypkg"
    for rel, source in files.items():
        path = root / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(textwrap.dedent(source), encoding="utf-8")
    for d in [root, *(p for p in root.rglob("*") if p.is_dir())]:
        (d / "__init__.py").touch()
    return root


CLEAN = {
    "_validate.py": "def _helper(): ...\ndef show(): ...\n",
    "geometry/paths.py": "class _Base: ...\nclass Line(_Base): ...\n",
    "geometry/_kernels.py": "def _k(): ...\n",
    "geometry/shapes.py": (
        "from toypkg.geometry._kernels import _k\nfrom toypkg.geometry import paths\npaths._Base\n"
    ),
    "shaping/backend.py": "import importlib\nimportlib.import_module('velfence_core._nd')\n",
    "shaping/law.py": "from toypkg._validate import show\nfrom toypkg.geometry.paths import Line\n",
    "apps/viz/_draw.py": "def _pen(): ...\n",
    "apps/viz/plots.py": (
        "from toypkg.apps.viz._draw import _pen\nfrom . import _draw\n_draw._pen\n"
    ),
    "apps/teleop/run.py": "from toypkg.apps.viz.plots import *\nimport toypkg._moved\n",
}


def test_the_scanner_passes_a_clean_package(tmp_path: Path) -> None:
    assert scan(_toy(tmp_path, CLEAN)) == []


@pytest.mark.parametrize(
    ("rel", "source", "what"),
    [
        ("shaping/law.py", "from toypkg.geometry.paths import _Base\n",
         "shaping/law.py:1: imports the private name _Base from toypkg.geometry.paths"),
        ("shaping/law.py", "x = 1\nfrom toypkg._validate import _helper\n",
         "shaping/law.py:2: imports the private name _helper from toypkg._validate"),
        ("shaping/law.py", "import toypkg.geometry._kernels\n",
         "shaping/law.py:1: imports the private module toypkg.geometry._kernels"),
        ("shaping/law.py", "from toypkg.geometry import _kernels as k\n",
         "shaping/law.py:1: imports the private module toypkg.geometry._kernels"),
        ("shaping/law.py", "from toypkg.geometry._kernels import run\n",
         "shaping/law.py:1: imports the private module toypkg.geometry._kernels"),
        ("shaping/law.py", "from ..geometry._kernels import run\n",
         "shaping/law.py:1: imports the private module toypkg.geometry._kernels"),
        ("shaping/law.py", "from toypkg.geometry import paths\n\n\npaths._Base()\n",
         "shaping/law.py:4: uses the private name _Base of toypkg.geometry.paths"),
        ("apps/teleop/run.py", "from toypkg.apps.viz._draw import pen\n",
         "apps/teleop/run.py:1: imports the private module toypkg.apps.viz._draw"),
        ("apps/teleop/run.py", "def f():\n    from toypkg.apps.viz.plots import _x\n",
         "apps/teleop/run.py:2: imports the private name _x from toypkg.apps.viz.plots"),
        ("shaping/law.py", "import importlib\nimportlib.import_module('velfence_core._nd')\n",
         "shaping/law.py:2: names the compiled core's velfence_core._nd"),
        ("shaping/law.py", "from velfence_core._core import ExactLaw\n",
         "shaping/law.py:1: imports from the compiled core's velfence_core._core"),
        ("shaping/law.py", "from toypkg import _validate\n\n_validate._helper()\n",
         "shaping/law.py:3: uses the private name _helper of toypkg._validate"),
        ("shaping/law.py", "import toypkg._validate as v\nv._helper()\n",
         "shaping/law.py:2: uses the private name _helper of toypkg._validate"),
        ("shaping/law.py", "import toypkg.geometry.paths\n\ntoypkg.geometry.paths._Base\n",
         "shaping/law.py:3: uses the private name _Base of toypkg.geometry.paths"),
        ("shaping/law.py", "from toypkg import geometry\ngeometry.paths._Base\n",
         "shaping/law.py:2: uses the private name _Base of toypkg.geometry.paths"),
        ("shaping/law.py", "import importlib as il\nil.import_module('toypkg.geometry._kernels')\n",
         "shaping/law.py:2: imports the private module toypkg.geometry._kernels"),
        ("apps/teleop/run.py",
         "import importlib\nimportlib.import_module('toypkg.apps.viz._draw')\n",
         "apps/teleop/run.py:2: imports the private module toypkg.apps.viz._draw"),
    ],
)  # fmt: skip
def test_the_scanner_reports_a_planted_violation(
    tmp_path: Path, rel: str, source: str, what: str
) -> None:
    root = _toy(tmp_path, {**CLEAN, rel: source})
    found = scan(root)
    assert len(found) == 1, found
    assert what.split(":", 2)[2] in found[0], found
    assert found[0].startswith(f"toypkg/{what.split(':', 1)[0]}:{what.split(':')[1]}:"), found


def test_the_scanner_reads_the_scripts_outside_the_package(tmp_path: Path) -> None:
    """The folders ``outside`` (benchmarks/) are scanned as code of no package: a private name
    of any package is reported there; the compiled core's binding modules are not (the one
    exemption, for code outside the library)."""
    root = _toy(tmp_path, CLEAN)
    bench = tmp_path / "benchmarks"
    bench.mkdir()
    (bench / "fine.py").write_text(
        "import velfence_core._nd\nfrom velfence_core import _filter\n"
        "from toypkg.geometry.paths import Line\nfrom toypkg import _validate\n_validate.show()\n",
        encoding="utf-8",
    )
    assert scan(root, outside=(bench,)) == []
    (bench / "time_it.py").write_text(
        "import importlib\nfrom toypkg.geometry.paths import _Base\n"
        "from toypkg.geometry._kernels import run\nimport toypkg.geometry.paths\n"
        "toypkg.geometry.paths._Base\nimportlib.import_module('toypkg.geometry._kernels')\n"
        "from toypkg._validate import _helper\n",
        encoding="utf-8",
    )
    assert sorted(scan(root, outside=(bench,))) == [
        "benchmarks/time_it.py:2: imports the private name _Base from toypkg.geometry.paths",
        "benchmarks/time_it.py:3: imports the private module toypkg.geometry._kernels of "
        "toypkg.geometry",
        "benchmarks/time_it.py:5: uses the private name _Base of toypkg.geometry.paths",
        "benchmarks/time_it.py:6: imports the private module toypkg.geometry._kernels of "
        "toypkg.geometry",
        "benchmarks/time_it.py:7: imports the private name _helper from toypkg._validate",
    ]
