"""One YAML reader: every YAML file velfence reads goes through ``velfence.io.yaml_reader``.

An AST scan of the library finds every call of a PyYAML loading function (``yaml.safe_load``,
``yaml.load`` & co., also imported by name); only the reader module may call one. The scan is
run on a planted call too, so the rule can fail. The reader's one error contract (the file and the
line in the message, :class:`~velfence.errors.InvalidParameter`) is checked for each kind of
file: a config file, a zone file, a joint-limit file and a bag's ``metadata.yaml``.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

import velfence
from velfence.errors import InvalidParameter
from velfence.io.yaml_reader import read_yaml

pytest.importorskip("yaml")

PACKAGE = Path(velfence.__file__).resolve().parent
READER = PACKAGE / "io" / "yaml_reader.py"
LOADERS = frozenset(
    {"load", "safe_load", "full_load", "unsafe_load", "load_all", "safe_load_all",
     "full_load_all", "unsafe_load_all"}
)  # fmt: skip


def yaml_loads(source: str) -> list[int]:
    """Lines of ``source`` that call (or import by name) a PyYAML loading function."""
    tree = ast.parse(source)
    modules = {"yaml"}  # names bound to the yaml module (import yaml as y)
    direct: set[str] = set()  # loading functions imported by name
    lines: list[int] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            modules |= {a.asname or a.name for a in node.names if a.name == "yaml"}
        elif isinstance(node, ast.ImportFrom) and node.module == "yaml":
            for a in node.names:
                if a.name in LOADERS:
                    direct.add(a.asname or a.name)
                    lines.append(node.lineno)
    for node in ast.walk(tree):
        if not isinstance(node, ast.Call):
            continue
        f = node.func
        if (
            isinstance(f, ast.Attribute)
            and f.attr in LOADERS
            and isinstance(f.value, ast.Name)
            and f.value.id in modules
        ) or (isinstance(f, ast.Name) and f.id in direct):
            lines.append(node.lineno)
    return sorted(set(lines))


def test_only_the_reader_loads_yaml() -> None:
    found = [
        f"{path.relative_to(PACKAGE.parent)}:{line}"
        for path in sorted(PACKAGE.rglob("*.py"))
        if path != READER
        for line in yaml_loads(path.read_text(encoding="utf-8"))
    ]
    assert found == [], "YAML loaded outside velfence.io.yaml_reader: " + ", ".join(found)
    assert yaml_loads(READER.read_text(encoding="utf-8")), "the reader itself loads YAML"


@pytest.mark.parametrize(
    ("source", "lines"),
    [
        ("import yaml\n\nyaml.safe_load('a: 1')\n", [3]),
        ("import yaml as y\nx = y.load(t, Loader=y.SafeLoader)\n", [2]),
        ("from yaml import safe_load as sl\n\nsl('a: 1')\n", [1, 3]),
        ("def f(t):\n    import yaml\n    return yaml.full_load(t)\n", [3]),
        ("import yaml\n\nyaml.safe_dump({'a': 1})\n", []),
        ("import json\n\njson.load(f)\n", []),
    ],
)
def test_the_scan_finds_a_planted_load(source: str, lines: list[int]) -> None:
    assert yaml_loads(source) == lines


def _line_error(exc: pytest.ExceptionInfo[InvalidParameter], path: Path, line: int) -> None:
    text = str(exc.value)
    assert str(path) in text, text
    assert f"line {line}," in text, text


def test_a_config_file_error_names_the_file_and_the_line(tmp_path: Path) -> None:
    from velfence.apps.demo.config import load_config

    p = tmp_path / "demo.yaml"
    p.write_text("dt: 0.001\nduration: 1.0\ndt: 0.002\n", encoding="utf-8")
    with pytest.raises(InvalidParameter) as exc:
        load_config(p)
    _line_error(exc, p, 3)


def test_a_zone_file_error_names_the_file_and_the_line(tmp_path: Path) -> None:
    from velfence.io.zones import load_nav2_polygons, load_ur_safety_planes

    p = tmp_path / "zones.yaml"
    p.write_text("safety_planes:\n  - {a: 1}\n  - {a: 1, a: 2}\n", encoding="utf-8")
    with pytest.raises(InvalidParameter) as exc:
        load_ur_safety_planes(p)
    _line_error(exc, p, 3)
    with pytest.raises(InvalidParameter) as exc:
        load_nav2_polygons(p)
    _line_error(exc, p, 3)


def test_a_joint_limit_file_error_names_the_file_and_the_line(tmp_path: Path) -> None:
    from velfence.io import load_joint_limits

    p = tmp_path / "limits.yaml"
    p.write_text("joint_limits:\n  a: &x {max_velocity: 1.0}\n  b: *x\n", encoding="utf-8")
    with pytest.raises(InvalidParameter) as exc:
        load_joint_limits(p, ["a", "b"])
    _line_error(exc, p, 2)
    assert "anchors" in str(exc.value)


def test_bag_metadata_goes_through_the_reader(tmp_path: Path) -> None:
    from velfence.io import bags

    bag = tmp_path / "bag"
    bag.mkdir()
    meta = bag / "metadata.yaml"
    meta.write_text(
        "rosbag2_bagfile_information:\n  storage_identifier: mcap\n  storage_identifier: x\n",
        encoding="utf-8",
    )
    with pytest.raises(InvalidParameter) as exc:
        bags._bag_source(bag)
    _line_error(exc, meta, 3)
    assert "bag metadata file" in str(exc.value)
    meta.write_text("rosbag2_bagfile_information:\n  storage_identifier: mcap\n", encoding="utf-8")
    assert bags._bag_source(bag).storage == "mcap"


def test_the_reader_names_the_file_it_cannot_read(tmp_path: Path) -> None:
    with pytest.raises(InvalidParameter, match=r"cannot read config file .*missing\.yaml"):
        read_yaml(tmp_path / "missing.yaml")
    p = tmp_path / "list.yaml"
    p.write_text("- 1\n- 2e-3\n", encoding="utf-8")
    assert read_yaml(p) == [1, 0.002]
    with pytest.raises(InvalidParameter, match="what: expected a string"):
        read_yaml(p, what=3)
