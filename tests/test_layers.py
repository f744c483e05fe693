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
    (contract,) = config["contracts"]
    assert contract["type"] == "layers"
    assert "exclude_type_checking_imports" not in contract  # TYPE_CHECKING imports count
    res = _lint_imports(ROOT / "pyproject.toml", ROOT, SRC)
    assert res.returncode == 0, res.stdout + res.stderr
    assert "Contracts: 1 kept, 0 broken." in res.stdout


def _layer_modules(layers: list[str]) -> list[str]:
    return [name.strip() for layer in layers for name in layer.replace(":", "|").split("|")]


def _toy_package(tmp_path: Path, extra: dict[str, str]) -> Path:
    """Package ``toypkg`` with one empty module per layer entry, plus ``extra`` sources."""
    config = _project_config()
    (contract,) = config["contracts"]
    pkg = tmp_path / "toypkg"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    for name in _layer_modules(contract["layers"]):
        (pkg / f"{name}.py").write_text(extra.get(name, ""))
    toy = {**contract, "containers": ["toypkg"], "name": "toy layers"}
    toy.pop("ignore_imports", None)  # names velfence modules
    layers = ", ".join(f'"{layer}"' for layer in toy.pop("layers"))
    lines = ["[tool.importlinter]", 'root_package = "toypkg"', ""]
    lines.append("[[tool.importlinter.contracts]]")
    for key, value in toy.items():
        if isinstance(value, bool):
            lines.append(f"{key} = {'true' if value else 'false'}")
        elif isinstance(value, list):
            lines.append(f"{key} = [{', '.join(repr(v) for v in value)}]")
        else:
            lines.append(f"{key} = {value!r}")
    lines.append(f"layers = [{layers}]")
    cfg = tmp_path / "pyproject.toml"
    cfg.write_text("\n".join(lines).replace("'", '"') + "\n")
    return cfg


_DOWNWARD = {
    "geometry": "from toypkg import errors, _validate\n",
    "viz": "from toypkg import sim, teleop, mechanisms\n",
    "reproduce": "from toypkg import viz\n",
    "cli": "from toypkg import demo, benchmarking, reproduce\n",
}


def test_downward_imports_keep_the_contract(tmp_path):
    cfg = _toy_package(tmp_path, _DOWNWARD)
    res = _lint_imports(cfg, tmp_path, tmp_path)
    assert res.returncode == 0, res.stdout + res.stderr
    assert "Contracts: 1 kept, 0 broken." in res.stdout


@pytest.mark.parametrize(
    ("module", "source", "message"),
    [
        ("geometry", "from toypkg import shaping\n", "toypkg.geometry is not allowed to import"),
        (
            "viz",
            "from typing import TYPE_CHECKING\n\n"
            "if TYPE_CHECKING:\n    from toypkg import reproduce\n",
            "toypkg.viz is not allowed to import toypkg.reproduce",
        ),
        (
            "sim",
            "def f():\n    from toypkg import viz\n\n    return viz\n",
            "toypkg.sim is not allowed to import toypkg.viz",
        ),
        ("teleop", "from toypkg import cobot\n", "toypkg.teleop is not allowed to import"),
    ],
    ids=["upward", "type-checking", "lazy", "sibling"],
)
def test_a_forbidden_import_breaks_the_contract(tmp_path, module, source, message):
    cfg = _toy_package(tmp_path, {**_DOWNWARD, module: source})
    res = _lint_imports(cfg, tmp_path, tmp_path)
    assert res.returncode == 1, res.stdout + res.stderr
    assert "toy layers BROKEN" in res.stdout
    assert message in res.stdout
