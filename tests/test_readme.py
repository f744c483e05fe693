"""Every code block of README.md and of every page under docs/ (tutorials included) is checked.

* ``python`` blocks run, each in its own process in its own temporary folder (``src/`` on
  the path, ``MPLBACKEND=Agg``, ``MUJOCO_GL=egl``; the folder links to the checkout's
  ``examples``, ``benchmarks``, ``core`` and ``tests``, so paths read as from the repository
  root). The process is forked from a server that imported NumPy, SciPy, matplotlib, MuJoCo
  and velfence's subpackages once (``tests/fork_server.py``), set up as ``python block.py``
  would start (:func:`test_a_forked_block_starts_as_a_fresh_interpreter_would`); nothing a
  block changes reaches the next one (:func:`test_blocks_do_not_leak_into_the_next`). A block
  whose output could depend on what is already imported, or that times anything
  (:func:`needs_fresh`), runs in a fresh interpreter. When the fenced block right after one
  (blank lines only in between) is a ``text`` block, the block's standard output must equal
  that text exactly, up to trailing whitespace on each line and blank lines at the end;
  otherwise the block must still exit cleanly. A ``yaml`` block of the same page whose first
  line is a comment naming a file (``# bridge.yaml: ...``) is written to that folder first, so
  a block can load it (and so can a ``yaml`` block naming it as a zone file,
  ``zone: {ur_safety_planes: cell.yaml}``).
  A ``python`` block may carry ``<!-- no-run: reason -->`` on the line right before it;
  :data:`NO_RUN_REASONS` lists every such block with its reason, and a block marked so that is not
  listed (or listed and not marked) fails :func:`test_no_run_blocks_are_the_listed_ones`.
  Blocks whose run takes more than a few seconds are listed in :data:`SLOW` and marked ``slow``.
* ``yaml`` blocks are velfence configuration files and are loaded through velfence's own loaders
  (the demo's :func:`~velfence.io.load_config`, the bridge's
  :func:`~velfence.bridge.load_bridge_config`, the replay's ``shaper:`` + ``replay:`` file,
  :func:`~velfence.io.parse_shaper`, the UR safety planes, the Nav2 collision-monitor file, and
  ``velfence verify``'s campaigns and scenarios).
* ``c`` and ``cpp`` blocks are reading material (fragments of a controller, not complete
  programs; the complete C and C++ examples are ``core/examples/`` and are compiled by
  ``tests/core``): every ``vf_*`` / ``VF_*`` name they use must be declared in
  ``core/include/``.
* ``bash`` and ``console`` blocks are not run (they build, install, serve or run for minutes);
  every ``velfence COMMAND --option`` in them must be an option of that command of the CLI,
  every ``make TARGET`` a target of the Makefile, every repository file they name must exist,
  and every ``--option`` given to a script of the repository must be one its text defines.
* Every fenced block names its language (one of :data:`LANGUAGES`), and every code block is
  fenced at the start of a line: an indented (four-space) code block or an indented fence would
  be seen by no check here (:func:`unfenced_blocks`).
"""

from __future__ import annotations

import atexit
import json
import os
import re
import shlex
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

from fork_server import ForkServer

ROOT = Path(__file__).resolve().parents[1]
PAGES = (ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md")))
FENCE = re.compile(r"^```([A-Za-z0-9_{}-]*)[ \t]*\n(.*?)^```[ \t]*$", re.M | re.S)
NO_RUN = re.compile(r"<!--\s*no-run:\s*(.+?)\s*-->")
NAMED_FILE = re.compile(r"\A#\s*([\w.-]+\.ya?ml)\b")
LANGUAGES = {"python", "text", "bash", "console", "yaml", "c", "cpp", "cmake", "xml"}
TIMEOUT_S = 120.0
#: Folders of the checkout a block's folder links to, so that a block reads ``examples/...`` as
#: it would from the repository root (blocks write only into their own folder).
CHECKOUT = ("examples", "benchmarks", "core", "tests")

#: Blocks that do not run, and why ("page:line" of the fence is not stable, so the key is the
#: page and the block's first line).
NO_RUN_REASONS = {
    ("bridge.md", "from velfence.bridge import BridgeNode, load_bridge_config"): (
        "runs a DDS node until it is stopped; tutorials/ros2.md runs the same node on loopback"
    ),
    ("robots.md", "import numpy as np"): (  # the block of MujocoRobot.from_urdf
        "needs a URDF of a UR5 and its meshes from a ROS installation (/opt/ros/...)"
    ),
}

#: Blocks whose run takes seconds (MuJoCo, long closed loops): marked ``slow``.
SLOW: set[tuple[str, int]] = set()


@dataclass(frozen=True)
class Block:
    page: str
    line: int
    language: str
    code: str
    expected: str | None
    no_run: str | None


def normalise(text: str) -> str:
    """Trailing whitespace removed from every line and blank lines from the end."""
    return "\n".join(line.rstrip() for line in text.splitlines()).rstrip("\n")


def extract(markdown: str, page: str) -> list[Block]:
    """Every fenced block of a page; a python block with the text block right after it (or None)."""
    fences = list(FENCE.finditer(markdown))
    blocks = []
    for i, m in enumerate(fences):
        expected = None
        if (
            m.group(1) == "python"
            and i + 1 < len(fences)
            and fences[i + 1].group(1) == "text"
            and not markdown[m.end() : fences[i + 1].start()].strip()
        ):
            expected = fences[i + 1].group(2)
        before = markdown[: m.start()].rstrip("\n").rsplit("\n", 1)[-1]
        marked = NO_RUN.fullmatch(before.strip())
        line = markdown.count("\n", 0, m.start()) + 1
        blocks.append(
            Block(page, line, m.group(1), m.group(2), expected, marked[1] if marked else None)
        )
    return blocks


def _page_name(page: Path) -> str:
    return page.relative_to(ROOT / "docs").as_posix() if page.parent != ROOT else page.name


ALL = [b for page in PAGES for b in extract(page.read_text(encoding="utf-8"), _page_name(page))]
PYTHON = [b for b in ALL if b.language == "python" and b.no_run is None]


def named_files(page: str) -> dict[str, str]:
    """The yaml blocks of ``page`` that name their file in their first line."""
    files = {}
    for b in ALL:
        m = NAMED_FILE.match(b.code)
        if b.page == page and b.language == "yaml" and m:
            files[m[1]] = b.code
    return files


#: What the fork server imports once: what most blocks import (each child still runs its block's
#: own imports; these find the modules loaded).
PRELOAD = [
    "numpy",
    "scipy.linalg",
    "scipy.optimize",
    "scipy.spatial",
    "matplotlib.pyplot",
    "pydantic",
    "yaml",
    "mujoco",
    "velfence",
    "velfence.geometry",
    "velfence.shaping",
    "velfence.filter",
    "velfence.mechanisms",
    "velfence.robots",
    "velfence.sim",
    "velfence.io",
    "velfence.cobot",
    "velfence.redundancy",
    "velfence.integrations",
    "velfence.bridge",
]
#: A block that looks at what is imported, or times anything, runs in a fresh interpreter.
FRESH = re.compile(
    r"sys\.modules|importtime|import_module|__import__|perf_counter|process_time|monotonic|"
    r"time\.time|timeit|resource\.|tracemalloc|gc\.get_objects|warnings\.filters"
)


def needs_fresh(code: str) -> bool:
    """Whether ``code`` could print something else when the preloaded modules are imported."""
    return FRESH.search(code) is not None


def block_env() -> dict[str, str]:
    """The environment a block runs in."""
    env = dict(os.environ, MPLBACKEND="Agg", PYTHONHASHSEED="0", PYTHONIOENCODING="utf-8")
    env.setdefault("MUJOCO_GL", "egl")
    src = str(ROOT / "src")
    env["PYTHONPATH"] = src + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    return env


_SERVERS: dict[str, ForkServer] = {}


def fork_server() -> ForkServer:
    """The fork server of this worker, started on first use (stopped at exit); one per
    environment, but for the test's name pytest keeps in it (each child gets the request's)."""
    env = block_env()
    key = repr(sorted((k, v) for k, v in env.items() if k != "PYTEST_CURRENT_TEST"))
    if key not in _SERVERS:
        _SERVERS[key] = ForkServer(PRELOAD, env)
        atexit.register(_SERVERS[key].close)
    return _SERVERS[key]


def run_block(
    code: str, folder: Path, files: dict[str, str] | None = None, *, fresh: bool | None = None
) -> subprocess.CompletedProcess[str]:
    """Run ``code`` as a script in ``folder`` holding ``files``: in a child of the fork server,
    or in a fresh interpreter (``fresh``, by default :func:`needs_fresh`)."""
    for name in CHECKOUT:
        if not (folder / name).exists():
            (folder / name).symlink_to(ROOT / name, target_is_directory=True)
    for name, text in (files or {}).items():
        (folder / name).write_text(text, encoding="utf-8")
    script = folder / "_block.py"
    script.write_text(code, encoding="utf-8")
    env = block_env()
    if not (needs_fresh(code) if fresh is None else fresh):
        return fork_server().run(script, cwd=folder, env=env, timeout=TIMEOUT_S)
    return subprocess.run(
        [sys.executable, str(script)],
        cwd=folder,
        env=env,
        capture_output=True,
        text=True,
        encoding="utf-8",
        timeout=TIMEOUT_S,
        check=False,
    )


def _param(b: Block) -> pytest.param:  # type: ignore[valid-type]
    marks = [pytest.mark.slow] if (b.page, b.line) in SLOW else []
    return pytest.param(b, id=f"{b.page}:{b.line}", marks=marks)


@pytest.mark.parametrize("block", [_param(b) for b in PYTHON])
def test_block_runs_and_prints_what_the_page_shows(block: Block, tmp_path: Path) -> None:
    proc = run_block(block.code, tmp_path, named_files(block.page))
    assert proc.returncode == 0, f"{block.page}:{block.line} failed:\n{proc.stderr}"
    if block.expected is not None:
        assert normalise(proc.stdout) == normalise(block.expected), (
            f"{block.page}:{block.line} printed:\n{proc.stdout}"
        )


def test_no_run_blocks_are_the_listed_ones() -> None:
    marked = {
        (b.page, b.code.splitlines()[0]): b.no_run
        for b in ALL
        if b.language == "python" and b.no_run is not None
    }
    assert set(marked) == set(NO_RUN_REASONS)
    assert all(reason for reason in marked.values())


def test_every_block_names_its_language() -> None:
    bad = [
        f"{b.page}:{b.line} ({b.language!r})"
        for b in ALL
        if b.language not in LANGUAGES and not b.language.startswith("{")
    ]
    assert not bad, bad


LIST_ITEM = re.compile(r"\s*(?:[*+-]|\d+[.)])\s")


def unfenced_blocks(markdown: str) -> list[int]:
    """Lines (1-based) where a code block starts that is not fenced at the start of a line: an
    indented fence, or a four-space indented block after a blank line that does not continue a
    list item."""
    lines = markdown.split("\n")
    found = []
    in_fence = False
    for i, line in enumerate(lines):
        if line.lstrip().startswith("```"):
            if line.startswith(" ") and not in_fence:
                found.append(i + 1)
            in_fence = not in_fence
            continue
        if in_fence or not line.startswith("    ") or not line.strip() or i == 0:
            continue
        if lines[i - 1].strip():
            continue  # a continuation line of a paragraph
        j = i - 1
        while j >= 0 and not lines[j].strip():
            j -= 1
        if j >= 0 and (LIST_ITEM.match(lines[j]) or lines[j].startswith("  ")):
            continue  # a list item's next paragraph
        found.append(i + 1)
    return found


def test_every_code_block_is_fenced_at_the_start_of_a_line() -> None:
    bad = [
        f"{_page_name(page)}:{line}"
        for page in PAGES
        for line in unfenced_blocks(page.read_text(encoding="utf-8"))
    ]
    assert not bad, bad


def test_unfenced_blocks_are_found() -> None:
    page = (
        "Prose\n\n    python x.py\n\n* item\n\n    more of the item\n\n"
        "* item\n\n  ```xml\n  <a/>\n  ```\n\n```python\n    indented code in a fence\n```\n"
    )
    assert unfenced_blocks(page) == [3, 11]


def test_every_page_with_python_has_checked_examples() -> None:
    for page in ("README.md", "choosing.md", "physics.md", "safety_filter.md", "quickstart.md"):
        blocks = [b for b in PYTHON if b.page == page]
        assert blocks, page
        assert any(b.expected is not None for b in blocks), page
    # one example per problem on the choosing page, each with its output
    choosing = [b for b in PYTHON if b.page == "choosing.md"]
    assert len(choosing) >= 7
    assert all(b.expected is not None for b in choosing)
    tutorials = {b.page for b in PYTHON if b.page.startswith("tutorials/")}
    assert len(tutorials) >= 5, tutorials


# ------------------------------------------------------------------------------ yaml blocks


def _load_yaml_block(code: str, path: Path) -> object:
    """Load a configuration file through the velfence loader its top-level keys call for."""
    from velfence.apps.demo.config import load_config
    from velfence.io import load_yaml, parse_shaper

    path.write_text(code, encoding="utf-8")
    doc = load_yaml(path)
    keys = set(doc)
    if "bridge" in keys:
        from velfence.bridge import load_bridge_config

        return load_bridge_config(path)
    if "safety_planes" in keys:
        from velfence.io.zones import load_ur_safety_planes

        return load_ur_safety_planes(path)
    if any(isinstance(v, dict) and "ros__parameters" in v for v in doc.values()):
        from velfence.io.zones import load_nav2_polygons

        return load_nav2_polygons(path, circle_sides=18)  # the page's k = 18
    if keys == {"shaper", "replay"}:
        from velfence.io.bags import _config

        return _config(path)
    if keys == {"shaper"}:
        return parse_shaper(doc["shaper"], base_dir=path.parent)
    if "families" in keys:
        from velfence.apps.verify import load_campaign

        return load_campaign(path)
    if "command_seed" in keys:
        from velfence.apps.verify import load_scenario

        return load_scenario(path)
    return load_config(path)


YAML = [b for b in ALL if b.language == "yaml"]


@pytest.mark.parametrize("block", YAML, ids=[f"{b.page}:{b.line}" for b in YAML])
def test_yaml_block_is_a_valid_velfence_config(block: Block, tmp_path: Path) -> None:
    for name, text in named_files(block.page).items():  # the zone files a config may name
        (tmp_path / name).write_text(text, encoding="utf-8")
    loaded = _load_yaml_block(block.code, tmp_path / "block.yaml")
    assert loaded is not None


def test_yaml_loader_refuses_a_bad_config(tmp_path: Path) -> None:
    from velfence.errors import InvalidParameter

    with pytest.raises(InvalidParameter):
        _load_yaml_block("shaper:\n  kind: polygon\n  bufer: 0.5\n", tmp_path / "a.yaml")
    with pytest.raises(InvalidParameter):
        _load_yaml_block("methods: [exact]\ndt: true\n", tmp_path / "b.yaml")


# ------------------------------------------------------------------------------- C blocks


def _core_names() -> set[str]:
    text = "".join(p.read_text(encoding="utf-8") for p in (ROOT / "core" / "include").glob("*.h"))
    return set(re.findall(r"\b(?:vf|VF)_\w+", text))


C_BLOCKS = [b for b in ALL if b.language in ("c", "cpp")]


@pytest.mark.parametrize("block", C_BLOCKS, ids=[f"{b.page}:{b.line}" for b in C_BLOCKS])
def test_c_block_uses_only_names_of_the_core_headers(block: Block) -> None:
    used = set(re.findall(r"\b(?:vf|VF)_\w+", block.code))
    assert used, "a C block of these pages shows the core's API"
    assert used <= _core_names(), sorted(used - _core_names())


# ------------------------------------------------------------------------- shell blocks

REPO_PATH = re.compile(r"^(?:examples|benchmarks|core|tests|docs|src)/[\w./-]*[\w]$")


def _cli_options() -> dict[tuple[str, ...], set[str]]:
    """Every command path of the ``velfence`` CLI and its options."""
    import typer

    from velfence.apps.cli import app

    options: dict[tuple[str, ...], set[str]] = {}

    def walk(cmd: object, path: tuple[str, ...]) -> None:
        opts = {
            o
            for p in getattr(cmd, "params", [])
            for o in (*getattr(p, "opts", []), *getattr(p, "secondary_opts", []))
        }
        options[path] = opts | {"--help"}
        for name, sub in getattr(cmd, "commands", {}).items():
            walk(sub, (*path, name))

    walk(typer.main.get_command(app), ())
    return options


def _make_targets() -> set[str]:
    text = (ROOT / "Makefile").read_text(encoding="utf-8")
    return set(re.findall(r"^([\w.$()/-]+):", text, re.M)) | {".venv/.installed"}


def shell_problems(code: str, cli: dict[tuple[str, ...], set[str]], targets: set[str]) -> list[str]:
    """What a shell block names that does not exist: CLI options, make targets, repository files."""
    problems = []
    for raw in code.splitlines():
        line = raw.strip().removeprefix("$ ").split(" #")[0]
        if not line or line.startswith("#"):
            continue
        for part in re.split(r"&&|;|\|\|", line):
            try:
                words = shlex.split(part.replace("[", " ").replace("]", " "))
            except ValueError:
                words = part.split()
            words = [w for w in words if "=" not in w or w.startswith("-")]  # drop VAR=value
            for w in words:
                if REPO_PATH.match(w) and "*" not in w and not (ROOT / w).exists():
                    problems.append(f"no file {w}")
            script = next((w for w in words if w.endswith(".py") and REPO_PATH.match(w)), None)
            if script and (ROOT / script).exists():
                text = (ROOT / script).read_text(encoding="utf-8")
                after = words[words.index(script) + 1 :]
                problems += [
                    f"{script}: no option {w}"
                    for w in after
                    if w.startswith("--") and f'"{w.split("=")[0]}"' not in text
                ]
            if words[:1] == ["make"]:
                problems += [f"no make target {t}" for t in words[1:] if t not in targets]
            if words[:1] == ["velfence"]:
                path: tuple[str, ...] = ()
                for w in words[1:]:
                    if (*path, w) in cli:
                        path = (*path, w)
                    elif not w.startswith("-"):
                        break
                if not path and len(words) > 1 and not words[1].startswith("-"):
                    problems.append(f"no command velfence {words[1]}")
                for w in words[1:]:
                    opt = w.split("=")[0].split("|")[0]
                    if opt.startswith("--") and opt not in cli[path]:
                        problems.append(f"velfence {' '.join(path)}: no option {opt}")
    return problems


SHELL = [b for b in ALL if b.language in ("bash", "console")]


def test_shell_blocks_name_real_commands_options_and_files() -> None:
    pytest.importorskip("typer")
    cli, targets = _cli_options(), _make_targets()
    bad = [f"{b.page}:{b.line}: {p}" for b in SHELL for p in shell_problems(b.code, cli, targets)]
    assert not bad, "\n".join(bad)


def test_shell_check_finds_what_does_not_exist() -> None:
    pytest.importorskip("typer")
    cli, targets = _cli_options(), _make_targets()
    assert shell_problems("velfence demo --out x\nmake docs", cli, targets) == []
    assert shell_problems("velfence demo --outt x", cli, targets) == [
        "velfence demo: no option --outt"
    ]
    assert shell_problems("make dogs", cli, targets) == ["no make target dogs"]
    assert shell_problems("python examples/nothing.py", cli, targets) == [
        "no file examples/nothing.py"
    ]
    assert shell_problems("velfence frobnicate", cli, targets) == ["no command velfence frobnicate"]
    assert shell_problems("python benchmarks/bench_core.py --batch", cli, targets) == []
    assert shell_problems("python benchmarks/bench_core.py --fast", cli, targets) == [
        "benchmarks/bench_core.py: no option --fast"
    ]


# ----------------------------------------------------------------------- the test itself


def test_extract_pairs_a_block_only_with_the_text_block_right_after_it() -> None:
    page = (
        "```python\nprint(1)\n```\n\n```text\n1\n```\n"
        "```python\nprint(2)\n```\n```bash\nls\n```\n```text\nnot mine\n```\n"
        "```python\nprint(3)\n```\nprose\n```text\nnot mine either\n```\n"
        "<!-- no-run: needs a robot -->\n```python\nprint(4)\n```\n"
    )
    a, b, c, d = (x for x in extract(page, "p") if x.language == "python")
    assert (a.code, a.expected, a.line, a.no_run) == ("print(1)\n", "1\n", 1, None)
    assert (b.code, b.expected) == ("print(2)\n", None)
    assert (c.code, c.expected) == ("print(3)\n", None)
    assert (d.code, d.no_run) == ("print(4)\n", "needs a robot")


def test_comparison_is_exact_up_to_trailing_whitespace(tmp_path: Path) -> None:
    assert normalise("a  \nb\n\n") == normalise("a\nb")
    assert normalise(" a") != normalise("a")
    assert normalise("[0.1 0.2]") != normalise("[0.1  0.2]")
    proc = run_block("print(open('f.yaml').read())", tmp_path, {"f.yaml": "x: 1"})
    assert normalise(proc.stdout) == "x: 1"
    assert normalise(proc.stdout) != normalise("y")


# ------------------------------------------------------------------ the fork server's children

#: Prints the state a script starts with: the same from a fresh interpreter and a forked child.
PROBE = """
import json, locale, os, signal, sys, threading, warnings
print(json.dumps({
    "name": __name__, "file": __file__, "argv": sys.argv, "path": sys.path, "cwd": os.getcwd(),
    "env": dict(os.environ), "flags": list(sys.flags), "hash": hash("velfence"),
    "threads": threading.active_count(), "warnings": [str(f) for f in warnings.filters],
    "stdout": [sys.stdout.encoding, sys.stdout.errors, sys.stdout.line_buffering],
    "stderr": [sys.stderr.encoding, sys.stderr.errors, sys.stderr.line_buffering],
    "stdin": sys.stdin.read(), "signals": [str(signal.getsignal(s)) for s in
        (signal.SIGINT, signal.SIGTERM, signal.SIGPIPE, signal.SIGCHLD)],
    "locale": locale.getlocale(), "recursion": sys.getrecursionlimit(),
    "umask": os.umask(0o22), "main": sorted(k for k in globals() if not k.startswith("__")),
}, sort_keys=True))
"""

#: Changes every kind of state a block could leave behind for the next one.
PLANT = """
import builtins, os, sys
import numpy as np
import velfence.geometry
builtins.LEAKED = "builtins"
np.LEAKED = "numpy"
velfence.geometry.LEAKED = "velfence.geometry"
np.set_printoptions(precision=2)
sys.modules["leaked_module"] = sys
sys.path.append("/leaked")
os.environ["LEAKED"] = "environ"
os.chdir("/")
LEAKED_GLOBAL = "globals"
print("planted")
"""

#: What the next block sees of it: nothing.
CHECK = """
import builtins, os, sys
import numpy as np
import velfence.geometry
print(sorted(name for name, seen in {
    "builtins": hasattr(builtins, "LEAKED"),
    "numpy": hasattr(np, "LEAKED"),
    "velfence.geometry": hasattr(velfence.geometry, "LEAKED"),
    "printoptions": np.get_printoptions()["precision"] != 8,
    "sys.modules": "leaked_module" in sys.modules,
    "sys.path": "/leaked" in sys.path,
    "environ": "LEAKED" in os.environ,
    "cwd": os.getcwd() == "/",
    "globals": "LEAKED_GLOBAL" in globals(),
}.items() if seen))
"""


def test_a_forked_block_starts_as_a_fresh_interpreter_would(tmp_path: Path) -> None:
    # A fresh interpreter that imported the preloaded modules (leaving no global behind)...
    preloaded = "".join(f"__import__('importlib').import_module({m!r})\n" for m in PRELOAD)
    runs = {
        "fresh": run_block(PROBE, tmp_path, fresh=True),
        "fresh, preloaded": run_block(preloaded + PROBE, tmp_path, fresh=True),
        "forked": run_block(PROBE, tmp_path, fresh=False),
    }
    for name, run in runs.items():
        assert run.returncode == 0, (name, run.stderr)
    fresh, preloaded_state, forked = (json.loads(run.stdout) for run in runs.values())
    # ... starts as the forked child does: paths, cwd, environment, flags, streams, signals.
    assert forked == preloaded_state
    assert forked["cwd"] == str(tmp_path)
    assert forked["path"][:2] == [str(tmp_path.resolve()), str(ROOT / "src")]
    # Without them the only differences are the warning filters NumPy and SciPy add on import
    # (which categories repeat on stderr; a block looking at them runs fresh) and the OpenGL
    # platform MuJoCo's import sets for its renderer from MUJOCO_GL.
    # (set already when this process imported MuJoCo).
    assert {k for k in fresh if fresh[k] != forked[k]} <= {"warnings", "env"}
    assert set(fresh["warnings"]) < set(forked["warnings"])
    assert {k: v for k, v in forked["env"].items() if fresh["env"].get(k) != v}.items() <= {
        ("PYOPENGL_PLATFORM", "egl")
    }
    assert set(fresh["env"]) <= set(forked["env"])
    assert needs_fresh("import warnings\nprint(warnings.filters)")


def test_blocks_do_not_leak_into_the_next(tmp_path: Path) -> None:
    first, second = tmp_path / "first", tmp_path / "second"
    first.mkdir()
    second.mkdir()
    planted = run_block(PLANT, first, fresh=False)
    assert (planted.returncode, planted.stdout) == (0, "planted\n"), planted.stderr
    after = run_block(CHECK, second, fresh=False)
    assert (after.returncode, after.stdout) == (0, "[]\n"), after.stderr
    # The check sees every leak when there is one: both blocks in one process.
    both = run_block(PLANT + CHECK, first, fresh=False)
    assert both.stdout.splitlines()[-1] == str(
        sorted(
            [
                "builtins",
                "numpy",
                "velfence.geometry",
                "printoptions",
                "sys.modules",
                "sys.path",
                "environ",
                "cwd",
                "globals",
            ]
        )
    )


def test_a_forked_block_exits_as_a_script_does(tmp_path: Path) -> None:
    cases = {
        "raise SystemExit(3)": (3, ""),
        "import sys; sys.exit('bye')": (1, "bye"),
        "raise ValueError('boom')": (1, "ValueError: boom"),
        "import os, signal; os.kill(os.getpid(), signal.SIGTERM)": (-15, ""),
        "import atexit; atexit.register(print, 'at exit'); print('body', end=' ')": (0, ""),
    }
    for code, (returncode, err) in cases.items():
        fresh, forked = (run_block(code, tmp_path, fresh=f) for f in (True, False))
        assert (forked.returncode, forked.stdout) == (fresh.returncode, fresh.stdout), code
        assert forked.returncode == returncode, (code, forked.stderr)
        assert err in forked.stderr.strip().splitlines()[-1:] or not err, (code, forked.stderr)
    assert run_block(next(reversed(cases)), tmp_path, fresh=False).stdout == "body at exit\n"


def test_a_block_that_looks_at_its_imports_runs_fresh() -> None:
    assert needs_fresh("import sys\nprint('numpy' in sys.modules)")
    assert needs_fresh("import time\nt = time.perf_counter()")
    assert not needs_fresh("import numpy as np\nprint(np.arange(3))")
