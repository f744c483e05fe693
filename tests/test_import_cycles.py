"""No import circles between velfence's modules (docs/architecture.md, "Package boundaries").

The module import graph is built with ``grimp`` (import-linter's own graph library), counting
every import: at module level, inside functions, and under ``TYPE_CHECKING``. Any strongly
connected set of modules is a circle, reported with one concrete loop through it. Small packages
built in ``tmp_path`` show that a planted circle is reported (whichever way its imports are
written) and that a package without one passes.
"""

from __future__ import annotations

import importlib
import sys
import textwrap
from collections import deque
from pathlib import Path

import pytest

grimp = pytest.importorskip("grimp", reason="grimp is not installed (dev extra)")

#: Circles that are deliberate and cannot be broken yet, each with the reason. Empty: none.
#: This list may only shrink.
KNOWN_CYCLES: dict[frozenset[str], str] = {}


def _graph(package: str) -> dict[str, set[str]]:
    graph = grimp.build_graph(package, exclude_type_checking_imports=False, cache_dir=None)
    return {m: set(graph.find_modules_directly_imported_by(m)) for m in graph.modules}


def _components(adj: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected sets of two or more modules (or one that imports itself)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    out: list[list[str]] = []
    counter = 0
    for root in sorted(adj):
        if root in index:
            continue
        # Iterative Tarjan: (node, iterator over its successors).
        work = [(root, iter(sorted(adj[root])))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on_stack.add(root)
        while work:
            node, successors = work[-1]
            step = next(successors, None)
            if step is not None:
                if step not in index:
                    index[step] = low[step] = counter
                    counter += 1
                    stack.append(step)
                    on_stack.add(step)
                    work.append((step, iter(sorted(adj.get(step, ())))))
                elif step in on_stack:
                    low[node] = min(low[node], index[step])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                comp = []
                while True:
                    m = stack.pop()
                    on_stack.discard(m)
                    comp.append(m)
                    if m == node:
                        break
                if len(comp) > 1 or node in adj[node]:
                    out.append(sorted(comp))
    return out


def _loop(adj: dict[str, set[str]], comp: list[str]) -> list[str]:
    """One shortest loop through the first module of ``comp``: ``[a, b, ..., a]``."""
    start = comp[0]
    inside = set(comp)
    prev: dict[str, str] = {}
    queue = deque([start])
    while queue:
        node = queue.popleft()
        for nxt in sorted(adj[node] & inside):
            if nxt == start:
                path = [node]
                while path[-1] != start:
                    path.append(prev[path[-1]])
                return [*reversed(path), start]
            if nxt not in prev:
                prev[nxt] = node
                queue.append(nxt)
    raise AssertionError(f"no loop through {start}")  # pragma: no cover - comp is a cycle


def import_cycles(package: str) -> list[list[str]]:
    """Every import circle of ``package``, each as one loop ``[a, b, ..., a]``."""
    adj = _graph(package)
    return [_loop(adj, comp) for comp in _components(adj)]


def test_velfence_has_no_import_cycles() -> None:
    cycles = import_cycles("velfence")
    new = [c for c in cycles if frozenset(c) not in KNOWN_CYCLES]
    assert new == [], "import circles: " + "; ".join(" -> ".join(c) for c in new)
    gone = [sorted(k) for k in KNOWN_CYCLES if k not in {frozenset(c) for c in cycles}]
    assert gone == [], f"no longer circles (remove them from KNOWN_CYCLES): {gone}"


def _toy(tmp_path: Path, name: str, files: dict[str, str], monkeypatch: pytest.MonkeyPatch) -> str:
    root = tmp_path / name
    for rel, source in {"__init__.py": "", **files}.items():
        path = root / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(textwrap.dedent(source), encoding="utf-8")
    monkeypatch.syspath_prepend(str(tmp_path))
    importlib.invalidate_caches()
    monkeypatch.delitem(sys.modules, name, raising=False)
    return name


@pytest.mark.parametrize(
    "b_source",
    [
        "from toycycle import a\n",
        "def f():\n    from toycycle.a import X\n    return X\n",
        "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from toycycle.a import X\n",
    ],
    ids=["top-level", "in-a-function", "type-checking"],
)
def test_a_planted_cycle_is_reported(
    b_source: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    name = _toy(
        tmp_path,
        "toycycle",
        {
            "a.py": "from toycycle.sub import c\nX = 1\n",
            "sub/__init__.py": "",
            "sub/c.py": "import toycycle.b\n",
            "b.py": b_source,
            "d.py": "import toycycle.a\n",  # imports into the circle: not part of it
        },
        monkeypatch,
    )
    assert import_cycles(name) == [["toycycle.a", "toycycle.sub.c", "toycycle.b", "toycycle.a"]]


def test_a_package_without_cycles_passes(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    name = _toy(
        tmp_path,
        "toytree",
        {
            "a.py": "from toytree import b\n",
            "b.py": "def f():\n    from toytree import c\n    return c\n",
            "c.py": "import os\n",
        },
        monkeypatch,
    )
    assert import_cycles(name) == []
    assert _graph(name)["toytree.b"] == {"toytree.c"}  # the function-level import is seen
