"""Write tests/slow_tests.txt from a JUnit file of a ``make check`` run (pytest --junitxml).

Every test that took ``--at-least`` seconds (setup, call and teardown) is listed; the list is
read by tests/conftest.py, which marks those tests ``slow``: ``make check`` leaves them out,
``make test`` and CI run them.

    .venv/bin/python tests/slow_tests.py JUNIT.xml > tests/slow_tests.txt
"""

from __future__ import annotations

import argparse
import xml.etree.ElementTree as ET
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

HEADER = """\
# Tests left out of `make check` because they are slow one by one: each took {at_least:g} s or
# more of a `make check` run on this 2-core machine under a load of about 8 (0.5-1 s or more
# idle). `make test` and CI run them. Regenerate from a JUnit file of a `make check` run with
#   .venv/bin/python tests/slow_tests.py JUNIT.xml > tests/slow_tests.txt
# tests/test_layers.py checks that every line names a test that exists.
"""


def node_id(classname: str, name: str) -> str:
    """The pytest node id of a JUnit test case (``tests.a.test_b.TestC`` + ``test_d``)."""
    parts = classname.split(".")
    for k in range(len(parts), 0, -1):
        path = "/".join(parts[:k]) + ".py"
        if (ROOT / path).is_file():
            return "::".join([path, *parts[k:], name])
    raise SystemExit(f"no test file for {classname}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("junit", type=Path)
    parser.add_argument("--at-least", type=float, default=2.0, help="seconds (default 2)")
    args = parser.parse_args()
    cases = ET.parse(args.junit).getroot().iter("testcase")
    ids = sorted(
        node_id(c.get("classname", ""), c.get("name", ""))
        for c in cases
        if float(c.get("time", 0.0)) >= args.at_least
    )
    print(HEADER.format(at_least=args.at_least), end="")
    for i in ids:
        print(i)


if __name__ == "__main__":
    main()
