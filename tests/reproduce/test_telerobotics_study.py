"""Study checks of ``velfence reproduce telerobotics`` (Khokar 2009 §7.2), on a tiny study."""

from __future__ import annotations

import json

from velfence.reproduce._telerobotics_study import study_checks


def test_study_checks_on_one_subject(tmp_path):
    checks, paths = study_checks(tmp_path, subjects=1, runs=1, seed=1)
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
