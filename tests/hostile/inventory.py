"""Run the whole hostile catalogue outside pytest and write a failure inventory.

Usage (from the repository root)::

    PYTHONPATH=src python tests/hostile/inventory.py OUT.txt [--write-known]

Per public callable and argument: which kinds fail and how, then totals by failure class. With
``--write-known`` the failures are also written to ``known_defects.json`` (the open-defect
baseline the test compares against; see docs/reliability-inputs.md).
"""

from __future__ import annotations

import collections
import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))

import harness
from kinds import KINDS


def keyword_only_violations() -> list[str]:
    """Public constructors whose defaults are positional or whose scalars are positional."""
    import inspect

    out = []
    for key, obj in harness.public_callables().items():
        if not inspect.isclass(obj) or harness.is_protocol(obj):
            continue
        bad = []
        for p in inspect.signature(obj).parameters.values():
            if p.kind in (p.VAR_POSITIONAL, p.VAR_KEYWORD) or p.kind is p.KEYWORD_ONLY:
                continue
            ann = p.annotation if isinstance(p.annotation, str) else ""
            if p.default is not p.empty or ann.replace(" | None", "") in (
                "float",
                "int",
                "bool",
                "str",
            ):
                bad.append(p.name)
        if bad:
            out.append(f"{key}: {', '.join(bad)}")
    return out


KNOWN = Path(__file__).parent / "known_defects.json"


def failure_id(f: harness.Failure) -> str:
    """The stable identity of one failure: argument, kind and failure class."""
    return f"{f.param}|{f.kind}|{f.klass}"


def main(out: str, write_known: bool = False) -> int:
    t_start = time.perf_counter()
    targets, missing = harness.targets()
    by_class: collections.Counter[str] = collections.Counter()
    by_escape: collections.Counter[str] = collections.Counter()
    lines: list[str] = []
    n_calls = 0
    clean = 0
    results = harness.attack_many([t.key for t in targets])
    for t in targets:
        fails, calls = results[t.key]
        n_calls += calls
        if not fails:
            clean += 1
            continue
        groups: dict[tuple[str, str], list[str]] = collections.defaultdict(list)
        for f in fails:
            by_class[f.klass.split(":")[0]] += 1
            if f.klass.startswith("escape:"):
                by_escape[f.klass.split(":", 1)[1]] += 1
            groups[(f.param, f.klass)].append(f.kind if f.klass != "valid-failed" else f.detail)
        lines.append(f"{t.key}  [{len(fails)} failures]")
        for (param, klass), kinds in sorted(groups.items()):
            lines.append(f"    {param:<18} {klass:<28} {', '.join(kinds)}")
        examples = {}
        for f in fails:
            examples.setdefault(f.klass, f)
        for f in examples.values():
            lines.append(f"        e.g. {f.param} <- {f.kind}: {f.detail[:150]}")
    elapsed = time.perf_counter() - t_start
    kw = keyword_only_violations()
    head = [
        "velfence hostile-input inventory",
        f"kinds in the catalogue: {len(KINDS)}",
        f"targets (constructors, methods, functions): {len(targets)}; clean: {clean}",
        f"calls made: {n_calls}; wall time: {elapsed:.1f} s with {harness.jobs()} worker(s)",
        f"public names without a spec: {len(missing)} {missing}",
        "",
        "failures by class:",
        *(f"    {k:<22} {v}" for k, v in by_class.most_common()),
        f"    {'total':<22} {sum(by_class.values())}",
        "",
        "escapes by exception type:",
        *(f"    {k:<22} {v}" for k, v in by_escape.most_common()),
        "",
        f"constructors breaking the keyword-only rule: {len(kw)}",
        *(f"    {line}" for line in kw),
        "",
        "per callable and argument (class: kinds that failed):",
    ]
    Path(out).write_text("\n".join(head + lines) + "\n")
    if write_known:
        known = {
            t.key: sorted({failure_id(f) for f in results[t.key][0]})
            for t in targets
            if results[t.key][0]
        }
        KNOWN.write_text(json.dumps(known, indent=1, sort_keys=True) + "\n")
    print("\n".join(head[:16]))
    return 0


if __name__ == "__main__":
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    raise SystemExit(
        main(args[0] if args else "hostile-inventory.txt", "--write-known" in sys.argv)
    )
