"""Markers for tests that need an optional dependency (an extra, or a test-only cross-check).

A core-only install (``pip install velfence`` plus pytest and hypothesis) must collect the whole
suite: a test that needs ``qpsolvers`` or ``matplotlib`` is skipped with the reason, it does not
break collection. Import the optional package inside the test (or after
``pytest.importorskip`` at module top when every test of the file needs it).
"""

from __future__ import annotations

from importlib.util import find_spec

import pytest

#: The extra (or "test-only") that provides each optional top-level module.
EXTRA = {
    "qpsolvers": "qp",
    "daqp": "qp",
    "numba": "fast",
    "matplotlib": "app",
    "PIL": "app",
    "pydantic": "app",
    "yaml": "app",
    "typer": "app",
    "rich": "app",
    "scipy": "test-only cross-check",
}


def missing(*modules: str) -> list[str]:
    """The modules of ``modules`` that cannot be imported here."""
    return [m for m in modules if find_spec(m) is None]


def requires(*modules: str) -> pytest.MarkDecorator:
    """``skipif`` marker: skip unless every module of ``modules`` is importable."""
    absent = missing(*modules)
    extras = sorted({EXTRA.get(m, "?") for m in absent})
    return pytest.mark.skipif(
        bool(absent), reason=f"needs {', '.join(absent)} (extra: {', '.join(extras)})"
    )


#: The QP cross-checks (qpsolvers with the daqp back-end).
requires_qp = requires("qpsolvers", "daqp")
