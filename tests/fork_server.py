"""Scripts each in their own process, forked from one interpreter that imported the modules once.

Starting a fresh interpreter for every documentation block re-imports NumPy, SciPy and velfence
each time, and that import is most of what a short block costs. :class:`ForkServer` starts one
interpreter (this file run as a script) with the environment the scripts get, imports the modules
it is given, and then forks a child per script. The child is set up as ``python SCRIPT`` would
be:

* its own process (its own ``sys.modules``, globals, cwd and environment: nothing it changes
  reaches the server or the next script, which is forked from the untouched server);
* ``cwd``, ``os.environ``, ``sys.argv`` and ``sys.path[0]`` (the script's folder) as a fresh
  interpreter sets them; standard input ``/dev/null``; standard output and error captured into
  files and returned as a :class:`subprocess.CompletedProcess`, as ``subprocess.run(...,
  capture_output=True, text=True)`` returns them;
* the script runs as ``__main__`` at the top level of the child (``runpy.run_path``): an uncaught
  exception prints its traceback and exits with 1, ``SystemExit`` gives its code, and the
  interpreter's normal exit runs (``atexit`` handlers, threads joined, buffers flushed);
* the random generators are re-seeded (``random`` re-seeds itself after a fork; NumPy's global
  one does not).

What differs from a fresh interpreter is only that the preloaded modules are already in
``sys.modules``: a script whose output depends on what an import loads, or on how long it takes,
must run in a fresh interpreter (``tests/test_readme.py`` sends such blocks there), and a test
that checks which modules an import loads does not use this server at all.
``tests/test_readme.py`` checks the equivalence: a probe block prints the same
interpreter state from both routes, and a block that leaks globals, module state, cwd or
environment does not affect the next one.
"""

from __future__ import annotations

import json
import os
import select
import signal
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

SERVER = Path(__file__).resolve()
#: The server's environment before it imported anything.
_START_ENV = dict(os.environ)


class ForkServer:
    """One preloaded interpreter forking a child per script (see the module docstring)."""

    def __init__(self, preload: list[str], env: dict[str, str]) -> None:
        self.env = dict(env)
        #: The CPU time of the last script (user + system, seconds).
        self.cpu_s = 0.0
        self._proc = subprocess.Popen(
            [sys.executable, str(SERVER), json.dumps(preload)],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            env=self.env,
            cwd=tempfile.gettempdir(),
            text=True,
            encoding="utf-8",
        )
        ready = self._proc.stdout.readline() if self._proc.stdout else ""
        if json.loads(ready or "null") != "ready":
            self.close()
            raise RuntimeError(f"the fork server did not start: {ready!r}")

    def run(
        self, script: Path, *, cwd: Path, env: dict[str, str], timeout: float
    ) -> subprocess.CompletedProcess[str]:
        """Run ``script`` as ``python script`` would, in ``cwd`` with ``env``."""
        assert self._proc.stdin
        assert self._proc.stdout
        with tempfile.TemporaryDirectory(prefix="fork-server-out-") as out:
            stdout, stderr = Path(out, "stdout"), Path(out, "stderr")
            request = {
                "script": str(script),
                "cwd": str(cwd),
                "env": env,
                "stdout": str(stdout),
                "stderr": str(stderr),
                "timeout": timeout,
            }
            self._proc.stdin.write(json.dumps(request) + "\n")
            self._proc.stdin.flush()
            reply = json.loads(self._proc.stdout.readline() or "null")
            if reply is None:
                raise RuntimeError("the fork server stopped")
            args = [sys.executable, str(script)]
            if reply["timed_out"]:
                raise subprocess.TimeoutExpired(args, timeout)
            self.cpu_s = float(reply["cpu_s"])
            return subprocess.CompletedProcess(
                args,
                reply["returncode"],
                stdout.read_text(encoding="utf-8"),  # universal newlines, as text=True reads
                stderr.read_text(encoding="utf-8"),
            )

    def close(self) -> None:
        """Stop the server (its children have all been waited for)."""
        if self._proc.stdin:
            self._proc.stdin.close()
        try:
            self._proc.wait(timeout=30)
        except subprocess.TimeoutExpired:
            self._proc.kill()
            self._proc.wait()
        if self._proc.stdout:
            self._proc.stdout.close()


# ------------------------------------------------------------------------- the server side


def _serve(preload: list[str]) -> dict[str, Any] | None:
    """Import ``preload``, then fork a child per request; the child returns its request."""
    import gc
    import importlib
    import threading

    requests = os.fdopen(os.dup(0), "r", encoding="utf-8")
    replies = os.fdopen(os.dup(1), "w", encoding="utf-8")
    for fd in (requests.fileno(), replies.fileno()):
        os.set_inheritable(fd, False)
    null = os.open(os.devnull, os.O_RDONLY)
    os.dup2(null, 0)
    os.close(null)
    os.dup2(2, 1)  # whatever the server prints stays out of the replies
    for name in preload:
        importlib.import_module(name)
    # A fork copies only the forking thread: a preloaded module must not have started one.
    assert threading.active_count() == 1, threading.enumerate()
    # What is loaded now stays out of the children's garbage collections (which would otherwise
    # write to every page they share with the server).
    gc.collect()
    gc.freeze()
    print(json.dumps("ready"), file=replies, flush=True)
    for line in requests:
        request = json.loads(line)
        sys.stdout.flush()
        sys.stderr.flush()
        pid = os.fork()
        if pid == 0:
            requests.close()
            replies.close()
            return dict(request)
        replies.write(json.dumps(_wait(pid, float(request["timeout"]))) + "\n")
        replies.flush()
    return None


def _wait(pid: int, timeout: float) -> dict[str, Any]:
    """Wait for child ``pid`` at most ``timeout`` seconds (killed after that)."""
    fd = os.pidfd_open(pid)
    try:
        ready, _, _ = select.select([fd], [], [], timeout)
        if not ready:
            os.kill(pid, signal.SIGKILL)
        _, status, usage = os.wait4(pid, 0)
    finally:
        os.close(fd)
    return {
        "returncode": os.waitstatus_to_exitcode(status),
        "timed_out": not ready,
        "cpu_s": usage.ru_utime + usage.ru_stime,
    }


def _become(request: dict[str, Any]) -> str:
    """Set the child up as ``python SCRIPT`` would start; the script's path."""
    for fd, key in ((1, "stdout"), (2, "stderr")):
        out = os.open(request[key], os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
        os.dup2(out, fd)
        os.close(out)
    script = str(request["script"])
    os.chdir(request["cwd"])
    # The environment as the server started with it, changed where the request's differs; what
    # the preloaded modules set on import (mujoco: PYOPENGL_PLATFORM) stays, as it would be set
    # by the script's own import of them.
    for key in set(_START_ENV) - set(request["env"]):
        os.environ.pop(key, None)
    for key, value in request["env"].items():
        if _START_ENV.get(key) != value:
            os.environ[key] = value
    sys.argv[:] = [script]
    sys.path[0] = os.path.dirname(os.path.realpath(script))
    numpy_random = sys.modules.get("numpy.random")
    if numpy_random is not None:
        numpy_random.seed()  # type: ignore[attr-defined]
    return script


def _run(script: str) -> None:
    """Run ``script`` as ``__main__`` and end the process as the interpreter's exit would, without
    tearing down the preloaded modules (the teardown would write to every page shared with the
    server, the cost the server is there to save)."""
    import atexit
    import runpy
    import threading

    code, interrupted = 0, False
    try:
        runpy.run_path(script, run_name="__main__")
    except SystemExit as exc:
        if exc.code is None or isinstance(exc.code, int):
            code = exc.code or 0
        else:
            print(exc.code, file=sys.stderr)
            code = 1
    except BaseException as exc:
        interrupted = isinstance(exc, KeyboardInterrupt)
        sys.excepthook(type(exc), exc, exc.__traceback__)
        code = 1
    # The interpreter's exit: wait for the threads, run the atexit functions, flush the streams.
    for thread in threading.enumerate():
        if thread is not threading.current_thread() and not thread.daemon:
            thread.join()
    atexit._run_exitfuncs()
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):
            code = 120
    if interrupted:
        signal.signal(signal.SIGINT, signal.SIG_DFL)
        os.kill(os.getpid(), signal.SIGINT)
    os._exit(code & 0xFF)


if __name__ == "__main__":
    _request = _serve(json.loads(sys.argv[1]))
    if _request is not None:
        _run(_become(_request))
