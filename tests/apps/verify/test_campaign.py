"""The campaign file of ``velfence verify``: defaults, hash, seeds, messages of bad inputs."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pydantic", reason="campaign files need the [app] extra")

from velfence.apps.verify.campaign import campaign_hash, load_campaign, parse_campaign
from velfence.apps.verify.cases import case_seed, sample
from velfence.errors import InvalidParameter

ONE_LINE = "robot: seven_dof\nfamilies: [{name: box, cases: 2, steps: 20}]\n"


def _file(tmp_path: Path, text: str, name: str = "c.yaml") -> Path:
    p = tmp_path / name
    p.write_text(text)
    return p


def test_a_one_line_campaign_gets_every_default(tmp_path: Path) -> None:
    c = load_campaign(_file(tmp_path, ONE_LINE))
    assert c.robot == "seven_dof"
    assert c.rate == 1000.0
    assert c.seed == 0
    assert c.filter_dt == pytest.approx(1e-3)  # "control": the filter gets 1 / rate
    assert c.families[0].operator == "wander"
    assert c.families[0].cases == 2
    props = c.properties
    assert props.containment is not None
    assert props.joint_limits is not None
    assert props.jerk is None
    assert props.progress is None


def test_the_hash_covers_the_normalised_config(tmp_path: Path) -> None:
    a = load_campaign(_file(tmp_path, ONE_LINE, "a.yaml"))
    # The same campaign with a default written out: same normalised config, same hash.
    b = load_campaign(_file(tmp_path, ONE_LINE + "rate: 1000.0\n", "b.yaml"))
    c = load_campaign(_file(tmp_path, ONE_LINE + "seed: 1\n", "c.yaml"))
    assert campaign_hash(a) == campaign_hash(b)
    assert campaign_hash(a) != campaign_hash(c)
    assert len(campaign_hash(a)) == 64


def test_case_seeds_are_the_seed_sequences_spawned_children() -> None:
    """Case i of family f: SeedSequence(seed).spawn(F)[f].spawn(N)[i], by numpy's own spawn."""
    root = np.random.SeedSequence(7)
    spawned = root.spawn(3)[2].spawn(5)[4]
    assert np.array_equal(case_seed(7, 2, 4).generate_state(8), spawned.generate_state(8))
    assert not np.array_equal(case_seed(7, 2, 3).generate_state(8), spawned.generate_state(8))


def test_a_case_depends_on_its_seed_family_and_index_only(tmp_path: Path) -> None:
    c = load_campaign(_file(tmp_path, ONE_LINE))
    more = parse_campaign({**c.normalised(), "families": [
        {**c.families[0].model_dump(), "cases": 50}]})  # fmt: skip
    assert sample(c, 0, 1) == sample(more, 0, 1)
    assert sample(c, 0, 0) != sample(c, 0, 1)


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        (ONE_LINE + "familes: []\n", "did you mean 'families'?"),
        (ONE_LINE.replace("steps", "stpes"), "families.0.stpes: Extra inputs are not permitted; "
         "did you mean 'steps'?"),
        (ONE_LINE.replace("seven_dof", "sevn_dof"), "unknown robot 'sevn_dof'"),
        (ONE_LINE.replace("seven_dof", "sevn_dof"), "did you mean 'seven_dof'?"),
        (ONE_LINE.replace("steps: 20", "steps: 20, lag: [0.2, 0.1]"),
         "lag: expected [low, high] with low <= high, got [0.2, 0.1]"),
        (ONE_LINE.replace("steps: 20", "steps: 0"), "families.0.steps"),
        (ONE_LINE.replace("cases: 2", "cases: '2'"), "families.0.cases"),
        (ONE_LINE + "rate: -5\n", "rate"),
        ("robot: seven_dof\nfamilies: []\n", "families"),
        (ONE_LINE.replace("steps: 20", "steps: 20, obstacles: {count: [3, 1]}"),
         "count: expected [low, high]"),
        (ONE_LINE.replace("{name: box,", "{name: box, plant: mujocco,"),
         "families.0.plant: unknown plant 'mujocco'"),
        (ONE_LINE.replace("{name: box,", "{name: box, plant: mujocco,"), "did you mean 'mujoco'?"),
        (ONE_LINE + "families: [{name: a}, {name: a}]\n", "duplicate key"),
    ],
)  # fmt: skip
def test_bad_campaigns_are_refused_naming_file_and_field(
    tmp_path: Path, text: str, expected: str
) -> None:
    p = _file(tmp_path, text)
    with pytest.raises(InvalidParameter) as info:
        load_campaign(p)
    msg = str(info.value)
    assert expected in msg
    assert str(p) in msg or "c.yaml" in msg


def test_a_missing_file_is_named(tmp_path: Path) -> None:
    with pytest.raises(InvalidParameter, match=r"nothere\.yaml"):
        load_campaign(tmp_path / "nothere.yaml")


@pytest.mark.slow  # two closed loops in twist mode (the filter's Python route): about 3 s
def test_the_jerk_and_progress_properties_can_hold_and_fail() -> None:
    """A jerk bound far above what a 1 kHz filter without jerk rows does holds, one of 1 rad/s³
    fails; the scripted jog along a box without spheres or joints at limits makes progress, and
    asking for more progress than the commanded speed fails."""
    from velfence.apps.verify.cases import run

    def campaign(jerk: float, fraction: float) -> object:
        return parse_campaign({
            "robot": "seven_dof", "rate": 100.0,
            "properties": {"jerk": {"max": jerk}, "progress": {"min_fraction": fraction,
                                                               "window": 0.05}},
            "families": [{"name": "jog", "cases": 1, "steps": 60, "operator": "scripted",
                          "at_limit": 0.0, "start_margin": [1.0, 2.0],
                          "obstacles": {"count": [0, 0]}}],
        })  # fmt: skip

    easy = run(sample(campaign(1e12, 0.0), 0, 0))
    assert "jerk" in easy.worst
    assert "progress" in easy.worst
    assert easy.violated == []
    hard = run(sample(campaign(1.0, 1.0), 0, 0))
    assert "jerk" in hard.violated
    assert "progress" in hard.violated
    assert hard.worst["jerk"][0] < 0.0
