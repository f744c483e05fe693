"""``velfence verify`` end to end: the report, a campaign stopped early, a known-bad campaign found,
shrunk and replayed (slow: each writes figures and shrinks)."""

from __future__ import annotations

import json
import re
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

pytest.importorskip("typer", reason="the command line needs the [app] extra")
pytest.importorskip("matplotlib", reason="the report needs the [app] extra")
import matplotlib

matplotlib.use("Agg")
import sys

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "viz"))
from figure_checks import check_every, record_figures
from typer.testing import CliRunner
from verify_campaigns import BAD, SMALL

from velfence.apps.cli import EXIT_VIOLATED, app
from velfence.apps.verify import load_scenario, replay, verify

pytestmark = pytest.mark.slow


def _cases(out: Path) -> list[dict[str, Any]]:
    """Every case record of the shard files, in shard order (timing left out)."""
    files = sorted((out / "shards").glob("*.json"))
    return [c for p in files for c in json.loads(p.read_text())["cases"]]


def _shuffled_map(fn: Callable[[Any], Any], items: list[Any]) -> Iterator[tuple[int, Any]]:
    """A mapper that runs the shards in reverse order, as another worker layout might."""
    for i in reversed(range(len(items))):
        yield i, fn(items[i])


def test_a_campaign_stopped_early_is_not_reported_complete(tmp_path: Path) -> None:
    def stops(fn: Callable[[Any], Any], items: list[Any]) -> Iterator[tuple[int, Any]]:
        yield 0, fn(items[0])
        raise KeyboardInterrupt

    o = verify(SMALL, tmp_path / "stop", mapper=stops)
    assert o.interrupted
    assert not o.summary.complete
    text = (tmp_path / "stop" / "report.md").read_text()
    assert "INCOMPLETE: 1 of 3 shards" in text
    assert "complete: " not in text.replace("INCOMPLETE: ", "")
    result = CliRunner().invoke(app, ["verify", "--replay", str(tmp_path / "nothing.yaml")])
    assert result.exit_code == 2


@pytest.fixture(scope="module")
def bad_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Any, dict[str, Any]]:
    out = tmp_path_factory.mktemp("bad") / "out"
    with pytest.MonkeyPatch.context() as mp, record_figures(mp) as figures:
        outcome = verify(BAD, out)
    return out, outcome, figures


def test_the_known_bad_campaign_is_found_and_shrunk(bad_run: Any) -> None:
    _out, outcome, _ = bad_run
    s = outcome.summary
    assert not s.holds
    assert s.worst["containment"][0] < -1e-3
    (cx,) = outcome.counterexamples
    assert "containment" in cx.violated
    small = load_scenario(cx.path)
    assert small.steps < cx.original_steps
    assert small.noise == 0.0
    assert small.lag == 0.0
    # Replayed bit for bit: the same worst margin twice.
    r1, r2 = replay(cx.path), replay(cx.path)
    assert r1.violated
    assert r1.worst == r2.worst
    # The same shrunk scenario with the filter given its period holds: the missing dt is the cause.
    from velfence.apps.verify.cases import run

    fixed = run(small.model_copy(update={"filter_dt": 1.0 / small.rate}))
    assert "containment" not in fixed.violated


def test_the_escape_is_seen_by_mujocos_own_kinematics(bad_run: Any) -> None:
    """The shrunk case's last state puts MuJoCo's TCP of the same arm outside the box."""
    pytest.importorskip("mujoco", reason="the cross-check needs the [physics] extra")
    from velfence.apps.verify.cases import TOOL, run
    from velfence.robots import seven_dof

    _, outcome, _ = bad_run
    small = load_scenario(outcome.counterexamples[0].path)
    r = run(small, record=True)
    assert small.box is not None
    model = seven_dof(tool=TOOL)
    p = np.asarray(model.fk(r.trace["q"][-1], "tcp"))
    lo, hi = np.array(small.box.lower), np.array(small.box.upper)
    depth = max(float(np.max(lo - p)), float(np.max(p - hi)))
    spheres_hit = r.worst["containment"][0] < 0 and small.spheres
    assert depth > 1e-6 or spheres_hit
    np.testing.assert_allclose(p, r.trace["tcp"][-1], atol=1e-9)


def test_the_report_and_its_figures(bad_run: Any) -> None:
    out, _outcome, figures = bad_run
    check_every(figures, out)
    md = (out / "report.md").read_text()
    for needed in ("Campaign hash", "velfence:", "complete: 1 of 1 shards", "not a certification",
                   "containment", "push #", "--replay counterexamples/"):  # fmt: skip
        assert needed in md, needed
    page = (out / "report.html").read_text()
    srcs = re.findall(r'src="([^"]*)"', page)
    assert len(srcs) == 3
    assert all(s.startswith("data:image/png;base64,") for s in srcs)


def test_the_command_line_exit_codes(bad_run: Any, tmp_path: Path) -> None:
    _out, outcome, _ = bad_run
    runner = CliRunner()
    cx = outcome.counterexamples[0].path
    result = runner.invoke(app, ["verify", "--replay", str(cx)])
    assert result.exit_code == EXIT_VIOLATED, result.output
    assert "still fails" in result.stdout
    bad = tmp_path / "bad.yaml"
    bad.write_text("robot: seven_dof\nfamilies: [{name: a, lag: [1, 0]}]\n")
    result = runner.invoke(app, ["verify", str(bad), "--out", str(tmp_path / "o"), "-q"])
    assert result.exit_code == 2
    assert "bad.yaml" in result.stderr
    assert "lag" in result.stderr
    good = tmp_path / "good.yaml"
    good.write_text("robot: seven_dof\nrate: 20\nfamilies: [{name: a, cases: 1, steps: 5}]\n")
    result = runner.invoke(app, ["verify", str(good), "--out", str(tmp_path / "g"), "-q"])
    assert result.exit_code == 0, result.output


def test_an_embedded_cluster_gives_the_same_results(tmp_path: Path) -> None:
    """Two worker processes of the engine's LocalCluster (127.0.0.1) write the same shards as a
    serial run, through the command line's --workers."""
    pytest.importorskip("distributed", reason="needs velfence[cluster] (dask)")
    verify(SMALL, tmp_path / "serial", report=False)
    spec = tmp_path / "small.yaml"
    import yaml

    spec.write_text(yaml.safe_dump(SMALL))
    out = tmp_path / "cluster"
    result = CliRunner().invoke(
        app, ["verify", str(spec), "--out", str(out), "--workers", "2", "-q"]
    )
    assert result.exit_code == 0, result.output
    assert _cases(out) == _cases(tmp_path / "serial")
