"""velfence.apps.reproduce.base: check helpers at their edges, Report.passed and the JSON form."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from velfence.apps.reproduce.base import Check, Report, check_at_least, check_at_most, check_close

NAN, INF = math.nan, math.inf


def _strict_loads(text: str) -> object:
    def reject(token: str) -> None:
        raise AssertionError(f"non-standard JSON constant {token}")

    return json.loads(text, parse_constant=reject)


# ------------------------------------------------------------------------------------- check_close


@pytest.mark.parametrize(
    ("expected", "measured", "tol", "ok"),
    [
        (1.0, 1.0, 0.0, True),
        (1.0, 1.25, 0.25, True),  # |Δ| == tol passes (binary-exact values)
        (1.0, 0.75, 0.25, True),
        (1.0, 1.25 + 1e-12, 0.25, False),
        (1.0, 0.75 - 1e-12, 0.25, False),
        (0.0, 1e-300, 0.0, False),
        (0.0, NAN, 1.0, False),
        (0.0, INF, 1e300, False),
        (0.0, -INF, INF, False),
        (NAN, 0.0, 1.0, False),
    ],
)
def test_check_close(expected: float, measured: float, tol: float, ok: bool) -> None:
    c = check_close("c", "src", expected, measured, tol, note="n")
    assert c.passed is ok
    assert (c.name, c.source, c.expected, c.tolerance, c.note) == ("c", "src", expected, tol, "n")
    assert c.source_defect is False
    assert c.measured is measured


@pytest.mark.parametrize(
    ("limit", "measured", "ok"),
    [
        (0.0, 0.0, True),
        (0.0, -1.0, True),
        (0.0, 1e-300, False),
        (1e-9, 1e-9, True),
        (1e-9, 1.0000001e-9, False),
        (0.0, -INF, True),
        (1.0, INF, False),
        (1.0, NAN, False),
    ],
)
def test_check_at_most(limit: float, measured: float, ok: bool) -> None:
    c = check_at_most("c", "src", limit, measured)
    assert c.passed is ok
    assert c.expected == f"<= {limit:g}"
    assert c.tolerance == limit


@pytest.mark.parametrize(
    ("limit", "measured", "ok"),
    [
        (0.9, 0.9, True),
        (0.9, 1.0, True),
        (0.9, 0.8999999, False),
        (1.3, INF, True),
        (1.3, -INF, False),
        (1.3, NAN, False),
    ],
)
def test_check_at_least(limit: float, measured: float, ok: bool) -> None:
    c = check_at_least("c", "src", limit, measured)
    assert c.passed is ok
    assert c.expected == f">= {limit:g}"
    assert c.tolerance == limit


def test_helpers_accept_numpy_scalars_and_return_plain_bools() -> None:
    checks = [
        check_at_most("a", "s", 0.5, np.float64(0.25)),
        check_at_least("b", "s", 0.5, np.float32(0.75)),
        check_close("c", "s", 1.0, np.float64(1.0), 0.0),
    ]
    for c in checks:
        assert type(c.passed) is bool
        assert c.passed
    # ...and the JSON form is plain too.
    d = _strict_loads(Report("r", tuple(checks)).to_json())
    assert isinstance(d, dict)
    assert [c["measured"] for c in d["checks"]] == [0.25, 0.75, 1.0]


# ------------------------------------------------------------------------------------------ Check


def test_check_to_dict_minimal() -> None:
    c = Check("n", "s", 1.0, 2.0, 0.5, False)
    assert c.to_dict() == {
        "name": "n",
        "source": "s",
        "expected": 1.0,
        "measured": 2.0,
        "tolerance": 0.5,
        "passed": False,
    }


def test_check_to_dict_note_and_source_defect() -> None:
    c = Check("n", "s", "<= 0", 0.1, 0.0, False, note="why", source_defect=True)
    d = c.to_dict()
    assert d["note"] == "why"
    assert d["source_defect"] is True


def test_check_passed_is_coerced_to_bool() -> None:
    d = Check("n", "s", 0, 0, 0, np.bool_(True)).to_dict()  # type: ignore[arg-type]
    assert d["passed"] is True
    json.dumps(d)  # a numpy bool would not serialise


@pytest.mark.parametrize(
    ("value", "text"), [(INF, "inf"), (-INF, "-inf"), (NAN, "nan"), (np.float64(INF), "inf")]
)
def test_non_finite_values_are_serialised_as_strings(value: float, text: str) -> None:
    c = Check("n", "s", value, value, value, False)
    d = _strict_loads(Report("r", (c,)).to_json())
    assert isinstance(d, dict)
    got = d["checks"][0]
    assert (got["expected"], got["measured"], got["tolerance"]) == (text, text, text)


def test_arrays_and_nested_sequences_become_lists() -> None:
    c = Check("n", "s", np.array([1.0, INF]), [(1, NAN), np.int64(3)], (0.1, 0.2), True)
    d = _strict_loads(Report("r", (c,)).to_json())
    assert isinstance(d, dict)
    got = d["checks"][0]
    assert got["expected"] == [1.0, "inf"]
    assert got["measured"] == [[1, "nan"], 3]
    assert got["tolerance"] == [0.1, 0.2]


def test_check_is_frozen() -> None:
    c = Check("n", "s", 0, 0, 0, True)
    with pytest.raises(AttributeError):
        c.passed = False  # type: ignore[misc]


# ----------------------------------------------------------------------------------------- Report

OK = Check("ok", "s", 0, 0, 0, True)
BAD = Check("bad", "s", 0, 1, 0, False)
DEFECT = Check("defect", "s", 0, 1, 0, False, source_defect=True)
DEFECT_OK = Check("defect ok", "s", 0, 0, 0, True, source_defect=True)


@pytest.mark.parametrize(
    ("checks", "passed"),
    [
        ((), True),
        ((OK,), True),
        ((OK, BAD), False),
        ((OK, DEFECT), True),
        ((DEFECT, DEFECT_OK), True),
        ((DEFECT, BAD), False),
    ],
)
def test_report_passed_ignores_source_defects(checks: tuple[Check, ...], passed: bool) -> None:
    assert Report("r", checks).passed is passed


def test_report_to_dict_shape() -> None:
    r = Report("wrist", (OK, DEFECT), ("a.png", "b.png"))
    d = r.to_dict()
    assert list(d) == ["name", "checks", "artifacts"]
    assert d["name"] == "wrist"
    assert d["checks"] == [OK.to_dict(), DEFECT.to_dict()]
    assert d["artifacts"] == ["a.png", "b.png"]
    assert Report("x", ()).to_dict() == {"name": "x", "checks": [], "artifacts": []}


def test_report_to_json_round_trips() -> None:
    r = Report(
        "wrist",
        (
            check_close("c", "s", 0.025, 0.02499, 0.00125),
            check_at_most("m", "s", 0.0, INF, note="diverged"),
            DEFECT,
        ),
        ("out/x.png",),
    )
    text = r.to_json()
    parsed = _strict_loads(text)
    assert parsed == r.to_dict()
    assert isinstance(parsed, dict)
    assert parsed["checks"][1]["measured"] == "inf"
    assert parsed["checks"][1]["passed"] is False
    assert "\n" in text  # indented: one object over several lines
    assert text.lstrip().startswith("{")
    assert text.rstrip().endswith("}")
