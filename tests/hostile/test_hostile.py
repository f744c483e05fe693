"""The hostile-input catalogue applied to every public callable (docs/reliability-inputs.md).

One test per callable: it loops over the callable's parameters and every applicable kind of
:mod:`kinds`, and fails with one readable list of every (argument, kind) that misbehaved.
"""

from __future__ import annotations

import dataclasses
import inspect
import json
from typing import Any

import harness
import pytest
from harness import (
    UNAVAILABLE,
    C,
    attack,
    attack_many,
    available,
    constructor_rule,
    documented_callables,
    documented_imports,
    public_callables,
    public_methods,
    registry,
    targets,
    tuning_positional,
)
from inventory import KNOWN as KNOWN_FILE
from inventory import failure_id
from kinds import KINDS

TARGETS, MISSING = targets()


def test_catalogue_has_at_least_80_kinds() -> None:
    assert len(KINDS) >= 80
    assert {"refuse", "accept"} <= {
        {"R": "refuse", "A": "accept", "E": "either"}[c] for k in KINDS for c in k.expect.values()
    }


def test_every_public_callable_has_a_spec() -> None:
    """A new public name (function, class, public method) must be added to a specs_*.py file,
    and so must a name that README.md, docs/ or examples/ import from a module path."""
    assert not MISSING, "public names without a hostile spec:\n  " + "\n  ".join(MISSING)
    enumerated = {id(o) for o in public_callables().values()}
    reg = registry()
    unspecified = [
        key
        for key, obj in documented_callables().items()
        if id(obj) not in enumerated or not any(public_callables().get(k) is obj for k in reg)
    ]
    assert not unspecified, "documented imports without a hostile spec: " + str(unspecified)


def test_documented_imports_are_found() -> None:
    """The scan of the documentation finds the module paths users import from (a scan that found
    nothing would make the check above pass vacuously)."""
    imports = documented_imports()
    assert {"run", "jerk_table", "plot_jerk"} <= imports["velfence.apps.scenarios.jerk"]
    assert "plot_collision_fit" in imports["velfence.apps.viz.collision"]
    assert "serve_web" in imports["velfence.apps.viewer.web"]
    assert "*" in imports["velfence"]  # ``import velfence``
    keys = set(public_callables())
    assert {
        "scenarios.jerk.run",
        "viz.collision.plot_collision_fit",
        "viewer.web.serve_web",
    } <= keys
    # a name exported by its package keeps the package's key (and its spec)
    assert "geometry.ConvexPolytope" in keys
    assert "geometry.polytope.ConvexPolytope" not in keys


def test_a_documented_import_without_spec_is_reported(monkeypatch: pytest.MonkeyPatch) -> None:
    """Planted: a page importing a name no spec covers makes the name missing."""
    page = ("docs/planted.md", "from velfence.apps.scenarios.jerk import JerkRow, run\n")
    monkeypatch.setattr(harness, "documented_sources", lambda: [page])
    _, missing = targets()
    assert "scenarios.jerk.JerkRow" in missing
    assert "scenarios.jerk.run" not in missing
    # without the page, jerk's names would not be public: the registry's entry is then unused
    monkeypatch.setattr(harness, "documented_sources", lambda: [])
    _, missing = targets()
    assert "scenarios.jerk.run (registered but not public)" in missing


@pytest.fixture(scope="session")
def hostile_results(request: pytest.FixtureRequest) -> dict[str, tuple[list, int]]:
    """Every selected target attacked once, in parallel worker processes (see harness.jobs)."""
    keys = [
        item.callspec.params["target"].key
        for item in request.session.items
        if getattr(item, "originalname", "") == "test_hostile_inputs"
    ]
    return attack_many(keys)


#: Open defects, listed one by one (argument | kind | failure class) and regenerated with
#: ``inventory.py --write-known``. A new failure fails the test; so does a listed one that no
#: longer fails (the list may only shrink: remove the fixed entries).
KNOWN: dict[str, list[str]] = json.loads(KNOWN_FILE.read_text()) if KNOWN_FILE.exists() else {}
KNOWN = {k: v for k, v in KNOWN.items() if available(k)}


def test_optional_modules_are_attacked_too() -> None:
    """Reports (as a skip) the modules left out because their optional dependency is missing."""
    if UNAVAILABLE:
        missing = ", ".join(f"{m} (needs {dep})" for m, dep in sorted(UNAVAILABLE.items()))
        pytest.skip(f"not attacked, an extra is not installed: {missing}")


@pytest.mark.slow
@pytest.mark.parametrize("target", TARGETS, ids=[t.key for t in TARGETS])
def test_hostile_inputs(target, hostile_results) -> None:  # type: ignore[no-untyped-def]
    failures, _calls = hostile_results.get(target.key) or attack(target)
    known = set(KNOWN.get(target.key, ()))
    new = [f for f in failures if failure_id(f) not in known]
    fixed = sorted(known - {failure_id(f) for f in failures})
    msg = []
    if new:
        lines = "\n  ".join(f.line() for f in new)
        msg.append(f"{len(new)} new hostile-input failure(s):\n  {lines}")
    if fixed:
        msg.append(
            f"{len(fixed)} listed defect(s) no longer fail; remove them from "
            f"known_defects.json:\n  " + "\n  ".join(fixed)
        )
    if msg:
        pytest.fail("\n".join(msg), pytrace=False)


def test_known_defects_name_only_public_targets() -> None:
    keys = {t.key for t in TARGETS}
    assert not set(KNOWN) - keys, sorted(set(KNOWN) - keys)


def _classes() -> list[tuple[str, type]]:
    """Public classes a user constructs (output records the library builds are exempt)."""
    reg = registry()

    def record(key: str) -> bool:
        spec = reg.get(key)
        return isinstance(spec, C) and bool(spec.record)

    return [
        (k, o)
        for k, o in public_callables().items()
        if inspect.isclass(o) and not getattr(o, "_is_protocol", False) and not record(k)
    ]


@pytest.mark.parametrize("cls", [c for _, c in _classes()], ids=[k for k, _ in _classes()])
def test_constructor_keyword_only_rule(cls: type) -> None:
    """Defaults are keyword-only; positional parameters are never scalar tuning values."""
    bad = constructor_rule(cls)
    assert not bad, f"{cls.__name__}{inspect.signature(cls)}: " + "; ".join(bad)


def _signed_callables() -> list[tuple[str, Any]]:
    """Every public function, constructor (output records excepted) and public method."""
    reg = registry()
    out: list[tuple[str, Any]] = []
    for key, obj in public_callables().items():
        spec = reg.get(key)
        if inspect.isclass(obj):
            if not (isinstance(spec, C) and (spec.record or spec.abstract)):
                out.append((key, obj))
            out += [(f"{key}.{m}", getattr(obj, m)) for m in public_methods(obj)]
        else:
            out.append((key, obj))
    return out


def test_tuning_parameters_are_keyword_only_everywhere() -> None:
    """Beyond the first (data) argument, no public callable takes a tuning value by position."""
    bad = [line for key, obj in _signed_callables() for line in tuning_positional(key, obj)]
    assert not bad, "tuning parameters taken by position:\n  " + "\n  ".join(bad)


_ = dataclasses
