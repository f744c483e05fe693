"""Every module of velfence imports with the base install, or says which extra it needs.

A subprocess blocks every optional dependency (``sys.modules[name] = None`` for the modules of
the extras in ``pyproject.toml``) and imports each module of the package, each from a clean
slate in a process of its own (forked from the one that imported its parent package, see
:data:`_PROBE`; :func:`test_the_probe_imports_each_module_from_a_clean_slate` shows a module
that imports only after a sibling is reported): it must import, or raise an ``ImportError``
whose message names the extra as ``velfence[...]``; a bare "No module named ..." fails the
test. The result must match the table "module → extra" of docs/install.md, row for row.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

import velfence
from velfence._extras import EXTRA_OF, extra_of, message, missing, require
from velfence.errors import MissingExtra, VelfenceError

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = Path(velfence.__file__).resolve().parent
#: Distribution name -> the top-level module it installs, where the two differ.
_MODULE_OF = {
    "PyYAML": "yaml",
    "pillow": "PIL",
    "imageio-ffmpeg": "imageio_ffmpeg",
    "mcap-ros2-support": "mcap_ros2",
    "foxglove-sdk": "foxglove",
}
#: Extras that install no runtime dependency of a velfence module (tools, meta-extras).
_TOOLS = {"docs", "dev", "all"}


def _optional_modules() -> dict[str, set[str]]:
    """Top-level module -> the extras that install it, over every runtime extra."""
    extras = tomllib.loads((ROOT / "pyproject.toml").read_text("utf-8"))["project"][
        "optional-dependencies"
    ]
    found: dict[str, set[str]] = {}
    for extra, requirements in extras.items():
        if extra in _TOOLS:
            continue
        for requirement in requirements:
            dist = re.split(r"[<>=!~\[ ;]", requirement, maxsplit=1)[0]
            found.setdefault(_MODULE_OF.get(dist, dist.replace("-", "_")), set()).add(extra)
    return found


def _modules() -> list[str]:
    """Every module of the package, from its files (importing nothing)."""
    names = []
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts.pop()
        names.append(".".join(parts))
    return names


#: The probe imports each module from a clean slate (no velfence module loaded) in a process of
#: its own, forked from the process that imported the module's parent package from a clean
#: slate: importing ``a.b.c`` imports ``a`` and then ``a.b`` first, so that process is where a
#: clean-slate import of ``a.b.c`` stands when ``a.b.c``'s own code starts. A module whose
#: parent failed to import is imported from its grandparent's process (it re-runs the parent's
#: failing import). Each package's ``__init__`` runs once instead of once per module below it.
#: The modules outside velfence that the package loads (NumPy, SciPy) are imported first, as one
#: interpreter importing the modules in turn keeps them loaded.
_PROBE = """
import importlib, json, os, sys, warnings
blocked, modules, package = json.loads(sys.argv[1])
warnings.simplefilter("ignore")
for name in blocked:
    sys.modules[name] = None

def ours(name):
    return name == package or name.startswith(package + ".")

def forked(work):
    read, write = os.pipe()
    pid = os.fork()
    if pid == 0:
        os.close(read)
        with os.fdopen(write, "w") as out:
            json.dump(work(), out)
        os._exit(0)
    os.close(write)
    with os.fdopen(read) as inp:
        text = inp.read()
    _, status = os.waitpid(pid, 0)
    assert status == 0 and text, (work, status)
    return json.loads(text)

def everything():
    for module in modules:
        try:
            importlib.import_module(module)
        except ImportError:
            pass
    return sorted(m for m, v in sys.modules.items() if v is not None and not ours(m))

for name in forked(everything):
    try:
        importlib.import_module(name)
    except ImportError:
        pass
assert not [m for m in sys.modules if ours(m)]

def below(package):
    return [m for m in modules if m.startswith(package + ".")]

def children(package, among):
    depth = package.count(".") + 1 if package else 0
    return [m for m in among if m.count(".") == depth]

def attempt(module):
    try:
        importlib.import_module(module)
    except ImportError as exc:
        return {module: [type(exc).__name__, str(exc)]}
    return {module: None}

def visit(package):
    results = {}
    for module in children(package, below(package) if package else modules):
        def one(module=module):
            found = attempt(module)
            return {**found, **visit(module)} if found[module] is None else found
        results.update(forked(one))
        if results[module] is not None:  # its modules each from here (they fail on it again)
            for sub in below(module):
                results.update(forked(lambda sub=sub: attempt(sub)))
    return results

print(json.dumps(visit("")))
"""


def run_probe(
    blocked: list[str], modules: list[str], package: str, path: Path
) -> subprocess.CompletedProcess[str]:
    """:data:`_PROBE` on ``modules`` of ``package`` (found on ``path``), ``blocked`` missing."""
    return subprocess.run(
        [sys.executable, "-c", _PROBE, json.dumps([blocked, modules, package])],
        capture_output=True,
        text=True,
        env={**os.environ, "PYTHONPATH": str(path)},
        timeout=300,
        check=False,
    )


@pytest.fixture(scope="module")
def results() -> dict[str, list[str] | None]:
    blocked = sorted(set(_optional_modules()) | set(EXTRA_OF))
    proc = run_probe(blocked, _modules(), "velfence", PACKAGE.parent)
    assert proc.returncode == 0, proc.stderr
    out: dict[str, list[str] | None] = json.loads(proc.stdout.strip().splitlines()[-1])
    return out


def test_the_probe_imports_each_module_from_a_clean_slate(tmp_path: Path) -> None:
    files = {
        "__init__.py": "",
        "b.py": "X = 1\n",
        "c.py": "import leaky\nY = leaky.b.X  # works only when leaky.b was imported before\n",
        "d.py": "import yaml\n",
        "bad/__init__.py": "import yaml\n",
        "bad/e.py": "",
    }
    for name, text in files.items():
        (tmp_path / "leaky" / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / "leaky" / name).write_text(text, encoding="utf-8")
    found = run_probe(
        ["yaml"], ["leaky", "leaky.b", "leaky.bad", "leaky.bad.e", "leaky.d"], "leaky", tmp_path
    )
    assert found.returncode == 0, found.stderr
    halted = ["ModuleNotFoundError", "import of yaml halted; None in sys.modules"]
    assert json.loads(found.stdout) == {
        "leaky": None,
        "leaky.b": None,
        "leaky.bad": halted,
        "leaky.bad.e": halted,
        "leaky.d": halted,
    }
    # leaky.c imports after leaky.b in one interpreter, but not from a clean slate.
    leak = run_probe([], ["leaky", "leaky.b", "leaky.c"], "leaky", tmp_path)
    assert leak.returncode != 0
    assert "AttributeError: module 'leaky' has no attribute 'b'" in leak.stderr


def test_the_table_knows_every_optional_dependency_of_pyproject() -> None:
    optional = _optional_modules()
    assert {"pydantic", "yaml", "matplotlib", "mujoco", "cyclonedds", "viser"} <= set(optional)
    for module, extras in optional.items():
        assert module in EXTRA_OF, f"{module} ({extras}) is missing from _extras.EXTRA_OF"
        assert EXTRA_OF[module] in extras, (module, EXTRA_OF[module], extras)


def test_every_module_imports_or_names_its_extra(results: dict[str, list[str] | None]) -> None:
    assert len(results) > 50  # the walk found the package
    assert results["velfence"] is None
    for module, error in results.items():
        if error is None:
            continue
        kind, text = error
        assert kind == "MissingExtra", f"{module}: {kind}: {text}"
        assert re.search(r"pip install 'velfence\[[a-z]+\]'", text), f"{module}: {text}"
        assert "No module named" not in text, f"{module}: {text}"


def test_the_base_install_imports_the_library_core(results: dict[str, list[str] | None]) -> None:
    # docs/zones.md and docs/install.md promise these with NumPy and SciPy only.
    for module in (
        "velfence.geometry",
        "velfence.shaping",
        "velfence.filter",
        "velfence.io",
        "velfence.io.zones",
        "velfence.io.yaml_reader",
        "velfence.io.joint_limits",
        "velfence.bridge",
        "velfence.apps._entry",
    ):
        assert results[module] is None, (module, results[module])


def _documented() -> dict[str, str]:
    """docs/install.md's table "module → extra": module (or ``prefix.*``) -> extra."""
    text = (ROOT / "docs" / "install.md").read_text("utf-8")
    section = text.split("## Which module needs which extra", 1)[1].split("\n## ", 1)[0]
    rows = re.findall(r"^\| `(velfence[\w.*]*)` \| `(\w+)` \|", section, flags=re.MULTILINE)
    assert rows, "docs/install.md has no module → extra table"
    return dict(rows)


def _covering(module: str, table: dict[str, str]) -> str | None:
    matches = [
        e for e in table if e == module or (e.endswith(".*") and f"{module}.".startswith(e[:-1]))
    ]
    return max(matches, key=len, default=None)


def test_docs_install_table_matches_the_imports(results: dict[str, list[str] | None]) -> None:
    table = _documented()
    used: set[str] = set()
    for module, error in results.items():
        entry = _covering(module, table)
        if error is None:
            assert entry is None, f"{module} imports with the base install, docs say {entry}"
            continue
        named = re.search(r"velfence\[([a-z]+)\]", error[1])
        assert named is not None
        assert entry is not None, f"{module} needs [{named.group(1)}]; docs/install.md omits it"
        assert table[entry] == named.group(1), (module, entry, table[entry], error[1])
        used.add(entry)
    assert set(table) == used, f"rows matching no module: {set(table) - used}"


def test_missing_extra_is_an_import_error_and_a_velfence_error(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setitem(sys.modules, "viser", None)
    with pytest.raises(MissingExtra) as info:
        require("viser", what="the 3-D web view")
    assert isinstance(info.value, ImportError)
    assert isinstance(info.value, VelfenceError)
    assert info.value.name == "viser"
    assert str(info.value) == (
        "the 3-D web view needs the optional 'web' dependencies (viser is not installed); "
        "install them with: pip install 'velfence[web]'"
    )


def test_a_missing_velfence_module_is_not_disguised() -> None:
    bug = ModuleNotFoundError("No module named 'velfence.nowhere'", name="velfence.nowhere")
    assert missing(bug, what="x") is bug
    assert extra_of("velfence.nowhere") is None
    assert extra_of("yaml.constructor") == "app"
    assert "velfence[ros]" in message("rosbags", "replay")
