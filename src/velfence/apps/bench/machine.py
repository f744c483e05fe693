"""What a benchmark ran on: CPU, cores, load, and the versions of everything timed."""

from __future__ import annotations

import datetime as _dt
import importlib.metadata
import importlib.util
import os
import platform
import sys
from dataclasses import dataclass

__all__ = ["Machine", "machine_info"]


@dataclass(frozen=True)
class Machine:
    """What the benchmark ran on.

    Attributes:
        cpu: CPU model name (``/proc/cpuinfo``, else :func:`platform.processor`).
        logical_cores: Logical CPUs of the machine.
        usable_cores: Logical CPUs this process may run on (affinity).
        numba_threads: Threads numba's parallel batch uses (0 without numba).
        platform: OS and kernel.
        python: Python version and implementation.
        numpy: NumPy version.
        numba: numba version, or ``"not installed"``.
        qpsolvers: qpsolvers version, or ``"not installed"``.
        daqp: daqp version, or ``"not installed"``.
        date: UTC time of the run, ISO 8601.
        load_average: 1-minute load average when the report was assembled (other work on the
            machine inflates the timings; -1 where the OS does not tell).
    """

    cpu: str
    logical_cores: int
    usable_cores: int
    numba_threads: int
    platform: str
    python: str
    numpy: str
    numba: str
    qpsolvers: str
    daqp: str
    date: str
    load_average: float


def _version(dist: str) -> str:
    try:
        return importlib.metadata.version(dist)
    except importlib.metadata.PackageNotFoundError:
        return "not installed"


def _cpu_model() -> str:
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as fh:
            for line in fh:
                if line.lower().startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine() or "unknown"


def _numba_threads() -> int:
    if importlib.util.find_spec("numba") is None:
        return 0
    import numba

    return int(numba.get_num_threads())


def _load_average() -> float:
    try:
        return float(os.getloadavg()[0])
    except (AttributeError, OSError):
        return -1.0


def machine_info() -> Machine:
    """Describe this machine and the versions of everything timed.

    Returns:
        The CPU, core counts, numba threads, platform and library versions.
    """
    logical = os.cpu_count() or 0
    try:
        usable = len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        usable = logical
    return Machine(
        cpu=_cpu_model(),
        logical_cores=logical,
        usable_cores=usable,
        numba_threads=_numba_threads(),
        platform=platform.platform(),
        python=f"{platform.python_implementation()} {sys.version.split()[0]}",
        numpy=_version("numpy"),
        numba=_version("numba"),
        qpsolvers=_version("qpsolvers"),
        daqp=_version("daqp"),
        date=_dt.datetime.now(_dt.UTC).replace(microsecond=0).isoformat(),
        load_average=_load_average(),
    )
