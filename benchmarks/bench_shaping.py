"""Run the benchmarks: a thin wrapper of ``velfence bench`` (same options, same code).

Usage: ``python benchmarks/bench_shaping.py [--quick] [--out PATH] [--json PATH]``. Without
``--out`` the report is printed; ``make bench`` writes ``out/benchmarks.md`` and ``make bench-docs``
updates ``docs/benchmarks.md``. The measurements live in :mod:`velfence.apps.bench`.
"""

from __future__ import annotations

import sys

from velfence.apps.cli import app


def main(argv: list[str] | None = None) -> None:
    """``velfence bench`` with ``argv`` (default: this script's arguments)."""
    app(["bench", *(sys.argv[1:] if argv is None else argv)], prog_name="bench_shaping.py")


if __name__ == "__main__":
    main()
