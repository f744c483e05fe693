"""Study checks of ``velfence reproduce telerobotics`` (Khokar 2009 §7.2), on a tiny study."""

from __future__ import annotations

import json


def test_study_checks_on_a_tiny_study(telerobotics_run):
    # study_checks as the shared reproduction ran it (tests/apps/reproduce/conftest.py): 2 subjects
    # x 1 run, seed 0
    assert telerobotics_run.calls["study_checks"] == (
        (telerobotics_run.out,),
        {"subjects": 2, "runs": 1, "study": None},
    )
    checks, paths = telerobotics_run.parts["study_checks"]
    names = [c.name for c in checks]
    assert "every simulated subject faster with assistance (per-subject mean time)" in names
    assert any("straighter" in n for n in names)
    for c in checks:
        d = c.to_dict()
        json.dumps(d)
        assert c.source.startswith("Khokar 2009 §7.2")
        assert c.passed, (c.name, c.measured, c.note)
    assert [p.name for p in paths] == ["study.json", "study_times.png", "study_paths.png"]
    assert all(p.exists() and p.stat().st_size > 0 for p in paths)
    faster = next(c for c in checks if c.name.startswith("every simulated subject faster"))
    assert "speed-up x" in faster.note
    assert not any(c.expected == "not published" for c in checks)
