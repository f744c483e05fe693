"""Time the polygon shapers and write docs/benchmarks.md.

Usage: ``python benchmarks/bench_shaping.py [--quick] [--out PATH] [--json PATH]``.
The measurements live in :mod:`velfence.benchmarking`; this script only runs them and writes files.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from velfence.benchmarking import run_benchmarks, write_report

ROOT = Path(__file__).resolve().parents[1]


def _progress(message: str, fraction: float) -> None:
    print(f"[{fraction:4.0%}] {message}", file=sys.stderr, flush=True)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small sizes (smoke test)")
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "benchmarks.md")
    parser.add_argument("--json", type=Path, default=None, help="also write the raw report")
    args = parser.parse_args(argv)
    report = run_benchmarks(quick=args.quick, progress=_progress)
    path = write_report(report, args.out)
    print(f"wrote {path}", file=sys.stderr)
    if args.json is not None:
        args.json.write_text(json.dumps(report.to_dict(), indent=2) + "\n", encoding="utf-8")
    for t in report.targets:
        print(f"{'PASS' if t.passed else 'FAIL'}  {t.name}: {t.measured:.3g} {t.unit} ({t.target})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
