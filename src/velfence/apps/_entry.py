"""The ``velfence`` console script: the CLI, or one clear line when an extra is not installed.

``pip install velfence`` installs the library only (NumPy); the command line lives in the
``[app]`` extra (typer, rich, pydantic, PyYAML, matplotlib, pillow). This module imports nothing
beyond the standard library until it has imported the CLI, so a core-only install gets
``pip install 'velfence[app]'`` instead of a ``ModuleNotFoundError`` traceback. Only the
extras' own modules are translated; a missing module inside velfence is a bug and is re-raised.
Ctrl-C while the CLI's modules load (a second or more on a loaded machine, before any command has
installed its own handling) ends with one line and exit code 130, as it does in a command.
"""

from __future__ import annotations

import sys

from velfence import _extras

__all__ = ["EXTRA_OF", "main", "missing_extra"]

#: Top-level module -> the velfence extra that installs it (the library's one table).
EXTRA_OF = _extras.EXTRA_OF


def _top(exc: ModuleNotFoundError) -> str:
    return (exc.name or "").partition(".")[0]


def missing_extra(exc: ModuleNotFoundError) -> str | None:
    """The extra that provides the module ``exc`` failed to import, or None if it is not ours."""
    return _extras.extra_of(exc.name)


def main() -> None:
    """Entry point of the ``velfence`` script (exit code 2 when an extra is missing).

    Exit code 130, with one line and no traceback, on Ctrl-C while the CLI is still loading.
    """
    try:
        try:
            from velfence.apps.cli import main as cli_main
        except KeyboardInterrupt:
            sys.stderr.write("velfence: interrupted while starting (exit 130)\n")
            raise SystemExit(130) from None
        cli_main()
    except ModuleNotFoundError as exc:
        extra = missing_extra(exc)
        if extra is None:
            raise
        what = "the velfence command" if extra == "app" else "this command"
        sys.stderr.write(f"velfence: {_extras.message(_top(exc), what, extra)}\n")
        raise SystemExit(2) from None


if __name__ == "__main__":
    main()
