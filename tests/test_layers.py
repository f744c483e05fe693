"""The layer contract (pyproject ``[tool.importlinter]``, docs/architecture.md) holds, and can fail.

Both tests run import-linter's ``lint-imports`` in a subprocess on a config file: the project's
own contract on velfence, and the same contract (root package renamed) on small packages built in
``tmp_path`` with one forbidden import each — top level, under ``TYPE_CHECKING``, inside a
function, between independent siblings — which must be reported broken, and with only downward
imports, which must pass.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tomllib
from pathlib import Path
from typing import Any

import pytest

import velfence

pytest.importorskip("importlinter", reason="import-linter is not installed (dev extra)")

ROOT = Path(__file__).resolve().parents[1]
SRC = Path(velfence.__file__).resolve().parents[1]


def _lint_imports(config: Path, cwd: Path, pythonpath: Path) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "PYTHONPATH": str(pythonpath)}
    return subprocess.run(
        [
            sys.executable,
            "-c",
            "from importlinter.cli import lint_imports_command; lint_imports_command()",
            "--config",
            str(config),
            "--no-cache",
        ],
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )


def _project_config() -> dict[str, Any]:
    with (ROOT / "pyproject.toml").open("rb") as f:
        config: dict[str, Any] = tomllib.load(f)["tool"]["importlinter"]
    return config


def test_velfence_keeps_its_layers():
    config = _project_config()
    library, apps = config["contracts"]
    assert [c["type"] for c in (library, apps)] == ["layers", "layers"]
    assert library["containers"] == ["velfence"]
    assert library["layers"][0] == "apps"
    assert apps["containers"] == ["velfence.apps"]
    for contract in (library, apps):
        assert "exclude_type_checking_imports" not in contract  # TYPE_CHECKING imports count
    res = _lint_imports(ROOT / "pyproject.toml", ROOT, SRC)
    assert res.returncode == 0, res.stdout + res.stderr
    assert "Contracts: 2 kept, 0 broken." in res.stdout


def _layer_modules(layers: list[str]) -> list[str]:
    return [name.strip() for layer in layers for name in layer.replace(":", "|").split("|")]


def _toy_package(tmp_path: Path, extra: dict[str, str]) -> Path:
    """Package ``toypkg`` shaped as velfence's contracts say, plus ``extra`` sources.

    Each contract's container (``velfence``, ``velfence.apps``) becomes ``toypkg``,
    ``toypkg.apps``; each layer entry an empty module, or a package where it is itself a
    container. ``extra`` maps a dotted name below ``toypkg`` (``"apps.viz"``) to its source.
    """
    config = _project_config()
    lines = ["[tool.importlinter]", 'root_package = "toypkg"', ""]
    (tmp_path / "toypkg").mkdir()
    (tmp_path / "toypkg" / "__init__.py").write_text("")
    for contract in config["contracts"]:
        (container,) = contract["containers"]
        toy_container = "toypkg" + container.removeprefix("velfence")
        base = tmp_path.joinpath(*toy_container.split("."))
        base.mkdir(exist_ok=True)
        (base / "__init__.py").touch()
        for name in _layer_modules(contract["layers"]):
            dotted = f"{toy_container}.{name}".removeprefix("toypkg.")
            if any(c["containers"] == [f"{container}.{name}"] for c in config["contracts"]):
                (base / name).mkdir(exist_ok=True)
                (base / name / "__init__.py").write_text(extra.get(dotted, ""))
            else:
                (base / f"{name}.py").write_text(extra.get(dotted, ""))
        toy = {**contract, "containers": [toy_container], "name": f"toy {toy_container}"}
        toy.pop("ignore_imports", None)  # names velfence modules
        layers = ", ".join(f'"{layer}"' for layer in toy.pop("layers"))
        lines.append("[[tool.importlinter.contracts]]")
        for key, value in toy.items():
            if isinstance(value, bool):
                lines.append(f"{key} = {'true' if value else 'false'}")
            elif isinstance(value, list):
                lines.append(f"{key} = [{', '.join(repr(v) for v in value)}]")
            else:
                lines.append(f"{key} = {value!r}")
        lines.append(f"layers = [{layers}]")
        lines.append("")
    cfg = tmp_path / "pyproject.toml"
    cfg.write_text("\n".join(lines).replace("'", '"') + "\n")
    return cfg


_DOWNWARD = {
    "geometry": "from toypkg import errors, _validate\n",
    "apps.viz": "from toypkg import sim, mechanisms\nfrom toypkg.apps import teleop\n",
    "apps.reproduce": "from toypkg.apps import viz\n",
    "apps.cli": "from toypkg.apps import demo, bench, reproduce\nfrom toypkg import bridge\n",
}


def test_downward_imports_keep_the_contract(tmp_path):
    cfg = _toy_package(tmp_path, _DOWNWARD)
    res = _lint_imports(cfg, tmp_path, tmp_path)
    assert res.returncode == 0, res.stdout + res.stderr
    assert "Contracts: 2 kept, 0 broken." in res.stdout


@pytest.mark.parametrize(
    ("module", "source", "message"),
    [
        ("geometry", "from toypkg import shaping\n", "toypkg.geometry is not allowed to import"),
        (
            "apps.viz",
            "from typing import TYPE_CHECKING\n\n"
            "if TYPE_CHECKING:\n    from toypkg.apps import reproduce\n",
            "toypkg.apps.viz is not allowed to import toypkg.apps.reproduce",
        ),
        (
            "sim",
            "def f():\n    from toypkg.apps import viz\n\n    return viz\n",
            "toypkg.sim is not allowed to import toypkg.apps",
        ),
        ("cobot", "from toypkg import redundancy\n", "toypkg.cobot is not allowed to import"),
        (
            "filter",
            "import toypkg.apps.demo\n",
            "toypkg.filter is not allowed to import toypkg.apps",
        ),
    ],
    ids=["upward", "type-checking", "lazy", "sibling", "library-imports-an-application"],
)
def test_a_forbidden_import_breaks_the_contract(tmp_path, module, source, message):
    cfg = _toy_package(tmp_path, {**_DOWNWARD, module: source})
    res = _lint_imports(cfg, tmp_path, tmp_path)
    assert res.returncode == 1, res.stdout + res.stderr
    assert "BROKEN" in res.stdout
    assert message in res.stdout


def _doc_layers(doc: str) -> tuple[list[list[str]], list[list[str]]]:
    """The layers docs/architecture.md's diagram shows and its two layer tables list, top first
    (each a list of module names), library first then ``velfence.apps``."""
    import re

    diagram = doc.split("```text\n", 1)[1].split("```", 1)[0]
    lib_part, apps_part = diagram.split("velfence.apps:", 1)
    stacks = []
    for part in (lib_part, apps_part):
        rows = []
        for line in part.splitlines():
            if not line.startswith("  ") or line.strip() in ("", "│") or line.startswith("    "):
                continue
            head = re.match(r"\w+(?: │ \w+)*", line.strip())
            assert head is not None, line
            rows.append(head[0].split(" │ "))
        stacks.append(rows)
    tables = []
    for header in (
        "| Layer | Packages / modules | May import |",
        "| Layer | Packages / modules | Why",
    ):
        body = doc.split(header, 1)[1].split("\n\n", 1)[0]
        rows = []
        for line in body.splitlines()[2:]:
            cell = line.split("|")[2]
            rows.append(re.findall(r"`([\w.]+)`", cell.split("(")[0] if "(" in cell else cell))
        tables.append(rows)
    return stacks[0] + stacks[1], tables[0] + tables[1]


def test_the_architecture_page_shows_every_layer_of_the_contracts():
    """docs/architecture.md's diagram and tables list exactly the layers of the two contracts in
    pyproject.toml, in their order (so a layer added to a contract must be added to the page)."""
    contracts = _project_config()["contracts"]
    want = [[m.strip() for m in layer.split("|")] for c in contracts for layer in c["layers"]]
    doc = (ROOT / "docs" / "architecture.md").read_text(encoding="utf-8")
    diagram, tables = _doc_layers(doc)
    assert diagram == want
    assert tables == want


def test_the_spread_files_exist() -> None:
    """tests/conftest.py's SPREAD names test files that exist (a moved file would silently go
    back to one group)."""
    import ast

    tree = ast.parse((ROOT / "tests" / "conftest.py").read_text(encoding="utf-8"))
    spread = next(
        ast.literal_eval(node.value)
        for node in tree.body
        if isinstance(node, ast.Assign) and getattr(node.targets[0], "id", "") == "SPREAD"
    )
    assert spread
    missing = [p for p in spread if not (ROOT / p).is_file()]
    assert not missing, missing


def test_the_measured_slow_tests_exist() -> None:
    """Every line of tests/slow_tests.txt names a test function of an existing file (a renamed
    test would silently come back into `make check`)."""
    lines = (ROOT / "tests" / "slow_tests.txt").read_text(encoding="utf-8").splitlines()
    ids = [ln for ln in lines if ln and not ln.startswith("#")]
    assert ids
    for node in ids:
        path, *names = node.split("::")
        assert (ROOT / path).is_file(), node
        name = names[-1].split("[")[0]
        assert f"def {name}(" in (ROOT / path).read_text(encoding="utf-8"), node


def test_the_shared_run_groups_name_existing_tests() -> None:
    """Each prefix of tests/conftest.py's GROUPS names an existing file and, where it names a
    test, a test defined in that file (a renamed test would silently leave its group)."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("root_conftest", ROOT / "tests" / "conftest.py")
    assert spec is not None
    assert spec.loader is not None
    conftest = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(conftest)

    for prefixes in conftest.GROUPS.values():
        for prefix in prefixes:
            path, _, test = prefix.partition("::")
            assert (ROOT / path).is_file(), prefix
            name = test.split("[")[0]
            assert not name or f"def {name}" in (ROOT / path).read_text(encoding="utf-8"), prefix
    assert conftest.scope_of("tests/apps/progress/test_progress.py::test_x") == (
        "tests/apps/progress/test_progress.py::test_x"
    )  # a SPREAD file: each test on its own
    assert conftest.scope_of("tests/geometry/test_polygon.py::test_y[1]") == (
        "tests/geometry/test_polygon.py"
    )
    assert conftest.scope_of("tests/apps/reproduce/test_telerobotics_laser.py::test_z") == (
        "shared-telerobotics"
    )
