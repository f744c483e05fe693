"""One backend picker (``velfence.shaping.backend.pick_backend``) behind every ``backend=``.

The picker's rule on a stand-in binding (auto picks C when the core is importable, ``"python"``
forces Python, ``"c"`` without the core raises :class:`~velfence.errors.InvalidParameter`), the
import made to fail for real (``sys.modules`` entry set to None: the loaders see an ImportError),
and every user — PolygonShaper, PolytopeShaper, SafetyFilter, ConfigurationController — giving
the same refusal, the same vocabulary and, where the core is installed, the same results on both
routes.
"""

from __future__ import annotations

import importlib.util
import sys
from collections.abc import Callable, Iterator
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

import velfence.shaping.backend as backend_module
from velfence.errors import InvalidParameter
from velfence.filter import JointLimits, SafetyFilter, SphereObstacle, WorkspaceLimit
from velfence.geometry.polygon import ConvexPolygon
from velfence.geometry.polytope import ConvexPolytope
from velfence.mechanisms.chain import DHChain
from velfence.redundancy import ConfigurationController
from velfence.shaping import PolygonShaper, PolytopeShaper
from velfence.shaping.backend import BACKENDS, pick_backend

HAVE_CORE = importlib.util.find_spec("velfence_core") is not None
LOADERS = {"core": "compiled_core", "nd": "compiled_nd", "filter": "compiled_filter"}
MODULES = {
    "core": "velfence_core._core",
    "nd": "velfence_core._nd",
    "filter": "velfence_core._filter",
}

SQUARE = ConvexPolygon(np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]))
BOX = ConvexPolytope.box([-1.0, -1.0, -1.0], [1.0, 1.0, 1.0])
ARM = DHChain.seven_dof(link_radius=0.06)
Q0 = np.array([0.2, 0.5, 0.1, -1.2, 0.1, 0.8, 0.0])


def _filter(backend: str) -> SafetyFilter:
    lim = ARM.joint_limits
    return SafetyFilter(
        ARM,
        limits=JointLimits(lim[:, 0], lim[:, 1], max_speed=np.full(7, 1.5)),
        workspace=WorkspaceLimit(
            ConvexPolytope.box(ARM.fk(Q0) - 0.3, ARM.fk(Q0) + 0.05), buffer=0.1
        ),
        backend=backend,
    )


def _controller(backend: str) -> ConfigurationController:
    center = ARM.fk(Q0) + np.array([0.0, 0.15, 0.0])
    obstacle = SphereObstacle(center=center, radius=0.02, influence=0.3)
    return ConfigurationController(ARM, [obstacle], backend=backend)


#: Each user of the picker: how to build it with a backend.
USERS: dict[str, Callable[[str], Any]] = {
    "PolygonShaper": lambda b: PolygonShaper(SQUARE, buffer=0.2, backend=b),
    "PolytopeShaper": lambda b: PolytopeShaper(BOX, buffer=0.2, backend=b, accelerate=False),
    "SafetyFilter": _filter,
    "ConfigurationController": _controller,
}


@pytest.fixture
def fresh_loaders() -> Iterator[None]:
    """The loaders' caches emptied before and after (a test may hide the core)."""
    for name in LOADERS.values():
        getattr(backend_module, name).cache_clear()
    yield
    for name in LOADERS.values():
        getattr(backend_module, name).cache_clear()


@pytest.mark.parametrize("binding", sorted(LOADERS))
def test_auto_picks_c_when_the_core_is_importable(
    binding: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    core = SimpleNamespace(name=binding)
    monkeypatch.setattr(backend_module, LOADERS[binding], lambda: core)
    assert pick_backend("auto", binding=binding) == (core, "c")  # type: ignore[arg-type]
    assert pick_backend("c", binding=binding) == (core, "c")  # type: ignore[arg-type]
    assert pick_backend("python", binding=binding) == (None, "python")  # type: ignore[arg-type]
    # a configuration the core cannot run: auto is Python, c refuses with the caller's words
    assert pick_backend("auto", usable=False, binding=binding) == (None, "python")  # type: ignore[arg-type]
    with pytest.raises(InvalidParameter, match=r"^backend='c' runs only this; use backend="):
        pick_backend("c", usable=False, refusal="runs only this", binding=binding)  # type: ignore[arg-type]


@pytest.mark.parametrize("binding", sorted(LOADERS))
def test_c_without_the_core_raises(
    binding: str, monkeypatch: pytest.MonkeyPatch, fresh_loaders: None
) -> None:
    monkeypatch.setitem(sys.modules, MODULES[binding], None)  # import raises ImportError
    assert getattr(backend_module, LOADERS[binding])() is None
    assert pick_backend("auto", binding=binding) == (None, "python")  # type: ignore[arg-type]
    with pytest.raises(InvalidParameter) as exc:
        pick_backend("c", binding=binding)  # type: ignore[arg-type]
    assert str(exc.value) == (
        f"backend='c' needs the compiled core (its module {MODULES[binding]}: the velfence_core "
        "distribution, `pip install ./core` from velfence's source), which is not importable; "
        "use backend='auto' or 'python'"
    )


@pytest.mark.skipif(not HAVE_CORE, reason="the compiled core is not installed")
@pytest.mark.parametrize("binding", sorted(LOADERS))
def test_auto_finds_the_installed_core(binding: str, fresh_loaders: None) -> None:
    module, name = pick_backend("auto", binding=binding)  # type: ignore[arg-type]
    assert name == "c"
    assert module is importlib.import_module(MODULES[binding])


@pytest.mark.parametrize("bad", ["C", "Python", "numba", "compiled", "", None, 1, True])
def test_one_vocabulary(bad: object) -> None:
    assert BACKENDS == ("auto", "python", "c")
    with pytest.raises(InvalidParameter, match=r"backend must be one of \['auto', 'python', 'c'\]"):
        pick_backend(bad)
    for build in USERS.values():
        with pytest.raises(InvalidParameter, match=r"backend must be one of \['auto', 'python'"):
            build(bad)  # type: ignore[arg-type]


def test_no_binding_outside_the_three() -> None:
    with pytest.raises(InvalidParameter, match="binding must be one of"):
        pick_backend("auto", binding="gpu")  # type: ignore[arg-type]


@pytest.mark.parametrize("user", sorted(USERS))
def test_every_user_refuses_c_without_the_core_in_the_same_words(
    user: str, monkeypatch: pytest.MonkeyPatch, fresh_loaders: None
) -> None:
    for module in MODULES.values():
        monkeypatch.setitem(sys.modules, module, None)
    assert USERS[user]("auto").backend == "python"
    assert USERS[user]("python").backend == "python"
    with pytest.raises(
        InvalidParameter, match=r"^backend='c' needs the compiled core \(its module"
    ):
        USERS[user]("c")


@pytest.mark.skipif(not HAVE_CORE, reason="the compiled core is not installed")
@pytest.mark.parametrize("user", sorted(USERS))
def test_every_user_runs_c_by_default_with_the_core(user: str) -> None:
    assert USERS[user]("auto").backend == "c"
    assert USERS[user]("c").backend == "c"
    assert USERS[user]("python").backend == "python"


@pytest.mark.skipif(not HAVE_CORE, reason="the compiled core is not installed")
def test_both_routes_give_the_same_results() -> None:
    rng = np.random.default_rng(7)
    for n, build in (
        (2, lambda b: PolygonShaper(SQUARE, buffer=0.2, backend=b)),
        (3, lambda b: PolytopeShaper(BOX, buffer=0.2, backend=b, accelerate=False)),
    ):
        c, py = build("c"), build("python")
        for _ in range(50):
            p = rng.uniform(-1.2, 1.2, n)
            v = rng.normal(size=n)
            np.testing.assert_array_equal(c.shape(p, v), py.shape(p, v))
    fc, fp = _filter("c"), _filter("python")
    cc, cp = _controller("c"), _controller("python")
    for _ in range(10):
        q = Q0 + rng.normal(scale=0.05, size=7)
        u = rng.normal(size=7)
        np.testing.assert_allclose(fc.filter(q, u), fp.filter(q, u), rtol=1e-9, atol=1e-12)
        v = rng.normal(scale=0.1, size=3)
        np.testing.assert_allclose(
            cc.control(q, v).output, cp.control(q, v).output, rtol=1e-9, atol=1e-12
        )


def test_the_old_homes_still_hold_the_picker() -> None:
    from velfence.shaping import polytope

    assert polytope.pick_backend is pick_backend
    assert polytope.compiled_nd is backend_module.compiled_nd
