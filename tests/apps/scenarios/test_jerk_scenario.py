"""The jerk scenario (``velfence.apps.scenarios.jerk``) on a short run, in MuJoCo.

The jerk is recomputed here from the recorded commands (``numpy.diff`` of the command sequence,
rest before the start) and compared with the Panda's limits as MuJoCo reads them from the model:
every cycle of the jerk-row run that the filter did not flag holds them; the run without jerk
rows shows the measurement can fail (it breaks them at the start of the jog).
"""

from __future__ import annotations

import importlib.util
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from optional import requires

pytestmark = requires("mujoco", "matplotlib")


@pytest.fixture(scope="module")
def short() -> dict[str, Any]:
    from velfence.apps.scenarios.jerk import run

    # 0.12 s: the operator's jog starts with a step to 0.25 m/s (the first cycles' jerk)
    return run(duration=0.12, methods=("safety-filter-jerk-rows", "safety-filter-no-jerk-rows"))


def _jerk(command: np.ndarray, dt: float) -> np.ndarray:
    c = np.vstack([np.zeros((2, command.shape[1])), command])
    return np.diff(c, 2, axis=0) / dt**2


def test_unflagged_cycles_hold_the_published_jerk_limits(short: dict[str, Any]) -> None:
    from velfence.apps.scenarios.fence_box import DT
    from velfence.robots import panda

    limit = np.asarray(panda().model.numeric("jerk_limits").data)  # MuJoCo's reading
    r = short["safety-filter-jerk-rows"]
    assert r.command.shape == (r.t.shape[0], 7)
    assert np.all(np.isfinite(r.command))
    jerk = _jerk(r.command, DT)
    np.testing.assert_allclose(r.jerk, jerk, rtol=1e-12, atol=1e-6)
    ok = np.abs(jerk) <= limit * (1 + 1e-9)
    assert ok[~r.flagged].all(), (np.abs(jerk) / limit)[~r.flagged].max()
    # the jerk rows shaped the start: some joint ran at its limit
    assert (np.abs(jerk) / limit).max() > 0.99
    assert r.margin.min() > 0.0  # (and the TCP stayed in the box)
    # without jerk rows the same start breaks the limit (the measurement can fail)
    raw = short["safety-filter-no-jerk-rows"]
    assert not raw.flagged.any()
    assert (np.abs(_jerk(raw.command, DT)) / limit).max() > 1.5


def test_table_and_figure(
    short: dict[str, Any], monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    from velfence.apps.scenarios.jerk import jerk_table, plot_jerk

    rows = {row.method: row for row in jerk_table(short)}
    jr, raw = rows["safety-filter-jerk-rows"], rows["safety-filter-no-jerk-rows"]
    assert jr.over == 0
    assert jr.max_ratio_unflagged <= 1 + 1e-9
    assert raw.over > 0
    assert raw.max_ratio == pytest.approx(float(short["safety-filter-no-jerk-rows"].ratio.max()))
    assert jr.cycles == raw.cycles == short["safety-filter-jerk-rows"].t.shape[0]
    assert jr.penetration == 0.0
    spec = importlib.util.spec_from_file_location(
        "figure_checks", Path(__file__).parents[1] / "viz" / "figure_checks.py"
    )
    assert spec is not None
    assert spec.loader is not None
    checks = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(checks)
    with checks.record_figures(monkeypatch) as figures:
        out = plot_jerk(short, tmp_path / "jerk.png")
    checks.check_all(figures, {"jerk.png"})
    assert out.stat().st_size > 10_000


def test_bad_arguments() -> None:
    from velfence.apps.scenarios.jerk import run
    from velfence.errors import InvalidParameter

    with pytest.raises(InvalidParameter, match="methods"):
        run(duration=0.01, methods=("safety-filter",))  # a plain filter is no variant here
    with pytest.raises(InvalidParameter, match="methods"):
        run(duration=0.01, methods=())
    with pytest.raises(InvalidParameter, match="duration"):
        run(duration=0.0)
    with pytest.raises(InvalidParameter, match="speed"):
        run(speed=-1.0)
