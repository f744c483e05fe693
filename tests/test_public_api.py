import importlib

import pytest

import velfence as vf

SUBPACKAGES = [
    "velfence.geometry",
    "velfence.shaping",
    "velfence.mechanisms",
    "velfence.sim",
    "velfence.reproduce",
    "velfence.io",
    "velfence.redundancy",
    "velfence.viz",
    "velfence.cobot",
    "velfence.teleop",
]


def _isort_key(name):
    # The order ruff's RUF022 enforces: SCREAMING_CASE, then CamelCase, then the rest.
    group = 0 if name.isupper() else 1 if name[0].isupper() else 2
    return (group, name)


@pytest.mark.parametrize("module", ["velfence", *SUBPACKAGES])
def test_every_exported_name_resolves_and_all_is_sorted(module):
    mod = importlib.import_module(module)
    assert mod.__all__ == sorted(mod.__all__, key=_isort_key)
    assert len(set(mod.__all__)) == len(mod.__all__)
    for name in mod.__all__:
        assert getattr(mod, name) is not None, name


@pytest.mark.parametrize("module", SUBPACKAGES)
def test_subpackage_docstring_states_a_math_contract(module):
    doc = importlib.import_module(module).__doc__
    assert doc is not None
    assert "contract" in doc.lower()


def test_version_is_single_sourced():
    from importlib.metadata import version

    assert vf.__version__ == version("velfence")


def test_core_import_is_light():
    import subprocess
    import sys

    code = (
        "import sys, velfence; "
        "heavy = [m for m in ('matplotlib', 'numba', 'qpsolvers', 'pydantic', 'typer', 'yaml') "
        "if m in sys.modules]; print(','.join(heavy))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == ""
