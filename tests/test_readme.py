"""The code in README.md and docs pages (choosing, physics, safety_filter) runs as printed.

Every fenced ``python`` block is run in a fresh interpreter from the repository root. When the
next fenced block after it (with only prose or blank lines in between) is a ``text`` block, the
block's standard output must equal that text exactly, up to trailing whitespace on each line and
blank lines at the end. A block without a ``text`` block after it must still exit cleanly.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = (
    ROOT / "README.md",
    ROOT / "docs" / "choosing.md",
    ROOT / "docs" / "physics.md",
    ROOT / "docs" / "safety_filter.md",
)
FENCE = re.compile(r"^```([A-Za-z0-9_-]*)[ \t]*\n(.*?)^```[ \t]*$", re.M | re.S)
TIMEOUT_S = 120.0


@dataclass(frozen=True)
class Block:
    page: str
    line: int
    code: str
    expected: str | None


def normalise(text: str) -> str:
    """Trailing whitespace removed from every line and blank lines from the end."""
    return "\n".join(line.rstrip() for line in text.splitlines()).rstrip("\n")


def extract(markdown: str, page: str) -> list[Block]:
    """The python blocks of a page, each with the text block that follows it (or None)."""
    fences = list(FENCE.finditer(markdown))
    blocks = []
    for i, m in enumerate(fences):
        if m.group(1) != "python":
            continue
        expected = None
        if i + 1 < len(fences) and fences[i + 1].group(1) == "text":
            expected = fences[i + 1].group(2)
        line = markdown.count("\n", 0, m.start()) + 1
        blocks.append(Block(page, line, m.group(2), expected))
    return blocks


BLOCKS = [b for page in PAGES for b in extract(page.read_text(encoding="utf-8"), page.name)]


def run_block(code: str, folder: Path) -> subprocess.CompletedProcess[str]:
    """Run ``code`` as a script in a fresh interpreter, from the repository root."""
    script = folder / "block.py"
    script.write_text(code, encoding="utf-8")
    env = dict(os.environ, MPLBACKEND="Agg", PYTHONHASHSEED="0", PYTHONIOENCODING="utf-8")
    src = str(ROOT / "src")
    env["PYTHONPATH"] = src + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    return subprocess.run(
        [sys.executable, str(script)],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        encoding="utf-8",
        timeout=TIMEOUT_S,
        check=False,
    )


@pytest.mark.parametrize("block", BLOCKS, ids=[f"{b.page}:{b.line}" for b in BLOCKS])
def test_block_runs_and_prints_what_the_page_shows(block: Block, tmp_path: Path) -> None:
    proc = run_block(block.code, tmp_path)
    assert proc.returncode == 0, f"{block.page}:{block.line} failed:\n{proc.stderr}"
    if block.expected is not None:
        assert normalise(proc.stdout) == normalise(block.expected), (
            f"{block.page}:{block.line} printed:\n{proc.stdout}"
        )


def test_every_page_has_checked_examples() -> None:
    for page in PAGES:
        blocks = [b for b in BLOCKS if b.page == page.name]
        assert blocks, page
        assert any(b.expected is not None for b in blocks), page
    # one example per problem on the choosing page, each with its output
    choosing = [b for b in BLOCKS if b.page == "choosing.md"]
    assert len(choosing) >= 7
    assert all(b.expected is not None for b in choosing)


def test_extract_pairs_a_block_only_with_the_text_block_right_after_it() -> None:
    page = (
        "```python\nprint(1)\n```\n\nprose\n\n```text\n1\n```\n"
        "```python\nprint(2)\n```\n```bash\nls\n```\n```text\nnot mine\n```\n"
    )
    a, b = extract(page, "p")
    assert (a.code, a.expected, a.line) == ("print(1)\n", "1\n", 1)
    assert (b.code, b.expected) == ("print(2)\n", None)


def test_comparison_is_exact_up_to_trailing_whitespace(tmp_path: Path) -> None:
    assert normalise("a  \nb\n\n") == normalise("a\nb")
    assert normalise(" a") != normalise("a")
    assert normalise("[0.1 0.2]") != normalise("[0.1  0.2]")
    proc = run_block("print('x')", tmp_path)
    assert normalise(proc.stdout) == "x"
    assert normalise(proc.stdout) != normalise("y")
