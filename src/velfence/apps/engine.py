"""The distributed engine: one function over many items, on a Dask cluster or in this process.

An :class:`Engine` runs ``fn(item)`` for every item of a list (a *shard* each: a bag to replay,
a campaign's run) and yields ``(index, result)`` as shards finish. Where they run:

* ``Engine()`` — an embedded Dask ``LocalCluster``: one worker process per core (``workers=N``
  for N), one thread each, listening on 127.0.0.1 only, dashboard off; started on entry
  (about 2 s) and stopped on exit. When Dask's own ``DASK_SCHEDULER_ADDRESS`` (or the
  ``scheduler-address`` of a Dask configuration file) is set and ``workers`` is not given, that
  cluster is used instead.
* ``Engine(cluster="tcp://host:8786")`` — the scheduler of a cluster the user runs (``dask
  scheduler`` and ``dask worker``, a Kubernetes or SLURM deployment, ...); a scheduler that does
  not answer within ``timeout`` raises :class:`ClusterUnavailable` instead of hanging.
* ``Engine(workers=0)`` — serial, in this process, in item order: deterministic and easy to
  debug (a breakpoint in ``fn`` works); needs no Dask.

Whatever runs them, the results are the same: :meth:`Engine.map` yields each shard's index with
its result and :meth:`Engine.run` returns the results in item order, never in arrival order. A
worker that dies loses only the shards it held: the scheduler gives them to another worker (Dask
counts a shard's workers lost, ``distributed.scheduler.allowed-failures``, 3 by default); a shard
whose ``fn`` raises is run again up to ``retries`` times. A shard that still fails raises
:class:`ShardFailed` naming its index. docs/distributed.md has the why and the how.

Dask (``velfence[cluster]``) is imported when an engine starts, never at import:
``Engine(workers=0)`` and this module work without it, any other engine raises
:class:`~velfence.errors.MissingExtra` naming ``velfence[cluster]``.
"""

from __future__ import annotations

import logging
import os
import signal
import sys
import threading
import time
import uuid
from collections.abc import Callable, Iterable, Iterator, Sequence
from contextlib import contextmanager
from typing import TYPE_CHECKING, Any, Literal, TypeVar

from velfence._extras import require
from velfence._validate import check_positive, check_positive_int, check_text, describe, show
from velfence.errors import InvalidParameter, VelfenceError

if TYPE_CHECKING:
    from types import TracebackType

    from velfence.apps.progress import OnProgress

__all__ = [
    "DEFAULT_RETRIES",
    "DEFAULT_TIMEOUT",
    "ClusterUnavailable",
    "Engine",
    "EngineMode",
    "ShardFailed",
    "default_workers",
    "progress_text",
]

ItemT = TypeVar("ItemT")
ResultT = TypeVar("ResultT")

#: How an engine runs its shards: in this process, on an embedded LocalCluster, or on a cluster
#: at an address.
EngineMode = Literal["serial", "local", "cluster"]

#: Seconds an engine waits for a scheduler (and its first worker) before giving up.
DEFAULT_TIMEOUT = 5.0
#: Times a shard whose function raised is run again (a lost worker's shards are rescheduled by
#: the scheduler regardless).
DEFAULT_RETRIES = 2
#: Most workers of an embedded cluster, most retries, most items of one map (a larger number is
#: a mistake, not a plan).
MAX_WORKERS = 1024
MAX_RETRIES = 100
MAX_ITEMS = 10_000_000
#: The schemes of a Dask address (``tcp://host:8786``); an address without one means tcp.
SCHEMES = ("tcp", "tls", "inproc", "ucx", "ws", "wss")

_WHAT = "velfence's distributed engine (velfence.apps.engine)"


class ClusterUnavailable(VelfenceError, ConnectionError):
    """A Dask scheduler did not answer, or has no worker, within the engine's ``timeout``."""


class ShardFailed(VelfenceError, RuntimeError):
    """A shard's function raised on every attempt, or the workers running it kept dying.

    Attributes:
        index: The shard's index in the items.
        reason: The last error, as ``"TypeName: message"``.
    """

    def __init__(self, index: int, reason: str, attempts: int) -> None:
        super().__init__(f"shard {index} failed after {attempts} attempt(s): {reason}")
        self.index = index
        self.reason = reason


#: Dask's nanny setting left out of the embedded cluster's workers (see ``Engine._start_local``).
_TRIM_THRESHOLD = "distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_"


def default_workers() -> int:
    """The cores this process may run on (the embedded cluster's default number of workers).

    Returns:
        ``len(os.sched_getaffinity(0))`` where the system has it, else ``os.cpu_count()``, at
        least 1.
    """
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # macOS, Windows
        return max(1, os.cpu_count() or 1)


def _clock(seconds: float) -> str:
    s = max(0, round(seconds))
    return f"{s // 3600}:{s // 60 % 60:02d}:{s % 60:02d}"


def progress_text(done: int, total: int, elapsed: float) -> str:
    """The engine's progress line: shards done, rate and the time left at that rate.

    Args:
        done: Shards finished.
        total: Shards in the map.
        elapsed: Seconds since the map started.

    Returns:
        E.g. ``"120/1000 shards, 41.3/s, ETA 0:00:21"`` (``ETA -`` before the first shard).

    Raises:
        InvalidParameter: counts that are not whole numbers >= 0 (``done`` at most ``total``),
            or an ``elapsed`` that is not a finite number >= 0.
    """
    total = check_positive_int("total", total, minimum=0, maximum=MAX_ITEMS)
    done = check_positive_int("done", done, minimum=0, maximum=MAX_ITEMS)
    if done > total:
        raise InvalidParameter(f"done, total: expected done <= total, got {done} > {total}")
    elapsed = check_positive("elapsed", elapsed, allow_zero=True, unit="s")
    rate = done / elapsed if elapsed > 0 and done else 0.0
    eta = _clock((total - done) / rate) if rate > 0 else "-"
    return f"{done}/{total} shards, {rate:.3g}/s, ETA {eta}"


def _address(value: Any) -> str:
    text = check_text("cluster", value, max_length=1000).strip()
    scheme, sep, rest = text.partition("://")
    if not sep:
        scheme, rest = "tcp", text
    if scheme not in SCHEMES or not rest or any(c.isspace() for c in rest):
        raise InvalidParameter(
            f"cluster: expected a Dask scheduler address such as tcp://host:8786 (schemes "
            f"{', '.join(SCHEMES)}), got {show(value)}"
        )
    return f"{scheme}://{rest}"


def _reason(exc: BaseException) -> str:
    text = str(exc)
    return f"{type(exc).__name__}: {text if len(text) <= 300 else text[:299] + '…'}"


class Engine:
    """Runs a function over many items on Dask (embedded or remote) or serially in this process.

    Use it as a context manager (``with Engine(workers=2) as engine: ...``): the cluster starts
    on entry and stops on exit, also on Ctrl-C. Used without ``with``, it starts on the first
    :meth:`map` and stops on :meth:`close`.

    Args:
        cluster: A Dask scheduler's address (``tcp://host:8786``; ``host:8786`` means tcp) to
            connect to; None: an embedded LocalCluster, or the scheduler of Dask's
            ``DASK_SCHEDULER_ADDRESS`` when it is set and ``workers`` is None.
        workers: Worker processes of the embedded cluster (default: the cores,
            :func:`default_workers`); 0 runs every shard serially in this process. Not with
            ``cluster`` (a cluster has its own workers).
        timeout: Seconds to wait for the scheduler to answer and to have a worker; then
            :class:`ClusterUnavailable`.

    Raises:
        InvalidParameter: a malformed address, a bad ``workers`` or ``timeout``, or ``workers``
            given with ``cluster``.
    """

    def __init__(
        self,
        *,
        cluster: str | None = None,
        workers: int | None = None,
        timeout: float = DEFAULT_TIMEOUT,
    ) -> None:
        self.address: str | None = None if cluster is None else _address(cluster)
        self.workers: int | None = (
            None
            if workers is None
            else check_positive_int("workers", workers, minimum=0, maximum=MAX_WORKERS)
        )
        if self.address is not None and self.workers is not None:
            raise InvalidParameter(
                f"workers: a cluster ({self.address}) brings its own workers; give cluster or "
                f"workers, not both (got workers={self.workers})"
            )
        self.timeout = check_positive("timeout", timeout, unit="s")
        if self.timeout > 3600:
            raise InvalidParameter(f"timeout: expected at most 3600 s, got {self.timeout:g}")
        self._client: Any = None
        self._cluster: Any = None
        self._mode: EngineMode = "serial" if self.workers == 0 else "local"

    # ------------------------------------------------------------------------ lifecycle

    @property
    def mode(self) -> EngineMode:
        """``"serial"``, ``"local"`` (embedded LocalCluster) or ``"cluster"`` (an address).

        Before the engine starts, an engine without ``cluster`` says ``"local"`` even when
        ``DASK_SCHEDULER_ADDRESS`` will make it ``"cluster"``.
        """
        return self._mode

    @property
    def started(self) -> bool:
        """Whether the engine is ready to run shards (serial engines always are)."""
        return self._mode == "serial" or self._client is not None

    @property
    def scheduler_address(self) -> str | None:
        """The scheduler's address (``tcp://…``) of a started Dask engine, else None."""
        if self._client is None:
            return None
        address: str = self._client.scheduler.address
        return address

    def n_workers(self) -> int:
        """Workers the engine runs shards on now (0 for a serial engine or one not started).

        Returns:
            The scheduler's count of connected workers.
        """
        if self._client is None:
            return 0
        return len(self._client.scheduler_info().get("workers", {}))

    def __enter__(self) -> Engine:
        self.start()
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    def start(self) -> None:
        """Start the embedded cluster or connect to the scheduler (nothing for a serial engine).

        Raises:
            MissingExtra: Dask is not installed (``pip install 'velfence[cluster]'``).
            ClusterUnavailable: the scheduler did not answer, or had no worker, within
                ``timeout``; the embedded cluster did not start.
        """
        if self.started:
            return
        require("dask", what=_WHAT, extra="cluster")
        distributed = require("distributed", what=_WHAT, extra="cluster")
        import dask

        address = self.address
        if address is None and self.workers is None:
            configured = dask.config.get("scheduler-address", None)
            if configured:
                address = _address(configured)
        if address is None:
            self._start_local(distributed)
        else:
            self._connect(distributed, address)

    def _start_local(self, distributed: Any) -> None:
        import dask

        n = self.workers or default_workers()
        try:
            # The worker processes are started with SIGINT ignored (inherited through exec), so a
            # Ctrl-C at the terminal reaches this process alone, which stops the cluster in
            # order, instead of every worker printing its own KeyboardInterrupt traceback.
            # Without the nanny's MALLOC_TRIM_THRESHOLD_ (Dask's default, to hand memory back to
            # the OS): setting it turns off glibc's adaptive mmap threshold, so every NumPy array
            # above 128 KiB is a fresh mmap and its page faults. A campaign's lock-step arrays
            # are that size: two processes side by side ran a step 10-30 % slower with it
            # (paired runs, docs/verify.md).
            with _sigint_ignored(), dask.config.set({_TRIM_THRESHOLD: None}):
                self._cluster = distributed.LocalCluster(
                    n_workers=n,
                    threads_per_worker=1,
                    processes=True,
                    host="127.0.0.1",
                    scheduler_port=0,
                    # Port 0: the scheduler's HTTP server (health, metrics) on a free port of
                    # 127.0.0.1, never a clash at 8787; no dashboard.
                    dashboard_address=":0",
                    scheduler_kwargs={"dashboard": False},
                    silence_logs=logging.ERROR,
                )
            self._client = distributed.Client(self._cluster, timeout=self.timeout)
        except Exception as exc:
            self.close()
            raise ClusterUnavailable(
                f"the embedded Dask cluster ({n} workers on 127.0.0.1) did not start: "
                f"{_reason(exc)} (its workers are new processes that import the main module: a "
                "script that starts an engine needs `if __name__ == '__main__':`)"
            ) from None
        self._mode = "local"

    def _connect(self, distributed: Any, address: str) -> None:
        try:
            self._client = distributed.Client(address, timeout=self.timeout)
        except Exception as exc:  # OSError / TimeoutError from comm.connect, ...
            self.close()
            raise ClusterUnavailable(
                f"cluster {address}: no Dask scheduler answered within {self.timeout:g} s "
                f"({_reason(exc)}); is `dask scheduler` running there, and is the port open?"
            ) from None
        try:
            self._client.wait_for_workers(1, timeout=self.timeout)
        except Exception:
            self.close()
            raise ClusterUnavailable(
                f"cluster {address}: the scheduler answered but had no worker within "
                f"{self.timeout:g} s; start one with `dask worker {address}`"
            ) from None
        self.address = address
        self._mode = "cluster"

    def close(self) -> None:
        """Stop the embedded cluster or disconnect from the scheduler (safe to call twice)."""
        client, cluster = self._client, self._cluster
        self._client = self._cluster = None
        for part in (client, cluster):
            if part is None:
                continue
            try:
                part.close()
            except Exception:  # a cluster already gone (Ctrl-C, a lost scheduler): nothing to do
                logging.getLogger(__name__).debug("closing %r failed", part, exc_info=True)
        _LOOP_LOG.setLevel(logging.NOTSET)

    # ---------------------------------------------------------------------------- work

    def map(
        self,
        fn: Callable[[ItemT], ResultT],
        items: Iterable[ItemT],
        *,
        retries: int = DEFAULT_RETRIES,
        progress: OnProgress | None = None,
    ) -> Iterator[tuple[int, ResultT]]:
        """Run ``fn(item)`` for every item; yield ``(index, result)`` as each shard finishes.

        The order of the pairs is the order shards finish in (item order for a serial engine);
        sort by index, or use :meth:`run`, for a result that does not depend on the workers.
        ``fn`` and the items travel to the workers by pickle (cloudpickle): a function of an
        installed module, or a closure over picklable values.

        Args:
            fn: The function of one item.
            items: The items (read into a list first).
            retries: Times a shard whose ``fn`` raised is run again (default 2).
            progress: Called as ``progress(done, total, what)`` after each shard, ``what`` with
                the rate and the time left (:func:`progress_text`); e.g. a stage of
                :mod:`velfence.apps.progress`.

        Yields:
            ``(index, result)`` pairs, one per item.

        Raises:
            InvalidParameter: ``fn`` or ``progress`` not callable, bad ``retries``, ``items``
                not iterable or too many.
            ShardFailed: a shard failed on every attempt; the shards still running are
                cancelled.
            ClusterUnavailable: the engine could not start (see :meth:`start`).
            MissingExtra: Dask is not installed and the engine is not serial.
        """
        if not callable(fn):
            raise InvalidParameter(f"fn: expected a callable, got {describe(fn)}")
        if progress is not None and not callable(progress):
            raise InvalidParameter(
                f"progress: expected a callable or None, got {describe(progress)}"
            )
        retries = check_positive_int("retries", retries, minimum=0, maximum=MAX_RETRIES)
        work = _listed(items)
        self.start()
        if self._mode == "serial":
            return self._serial(fn, work, retries, progress)
        return self._dask(fn, work, retries, progress)

    def run(
        self,
        fn: Callable[[ItemT], ResultT],
        items: Iterable[ItemT],
        *,
        retries: int = DEFAULT_RETRIES,
        progress: OnProgress | None = None,
    ) -> list[ResultT]:
        """Every shard's result, in item order (:meth:`map`, collected and sorted by index).

        Args:
            fn: The function of one item.
            items: The items.
            retries: Times a shard whose ``fn`` raised is run again.
            progress: As for :meth:`map`.

        Returns:
            ``[fn(items[0]), fn(items[1]), ...]``.

        Raises:
            InvalidParameter: as for :meth:`map`.
            ShardFailed: a shard failed on every attempt.
            ClusterUnavailable: the engine could not start.
            MissingExtra: Dask is not installed and the engine is not serial.
        """
        pairs = sorted(self.map(fn, items, retries=retries, progress=progress), key=_first)
        return [result for _, result in pairs]

    def _serial(
        self,
        fn: Callable[[ItemT], ResultT],
        work: Sequence[ItemT],
        retries: int,
        progress: OnProgress | None,
    ) -> Iterator[tuple[int, ResultT]]:
        start = time.perf_counter()
        for i, item in enumerate(work):
            for attempt in range(retries + 1):
                try:
                    result = fn(item)
                    break
                except Exception as exc:
                    if attempt == retries:
                        raise ShardFailed(i, _reason(exc), retries + 1) from exc
            if progress is not None:
                progress(i + 1, len(work), progress_text(i + 1, len(work), _since(start)))
            yield i, result

    def _dask(
        self,
        fn: Callable[[ItemT], ResultT],
        work: Sequence[ItemT],
        retries: int,
        progress: OnProgress | None,
    ) -> Iterator[tuple[int, ResultT]]:
        import distributed

        client = self._client
        start = time.perf_counter()
        token = uuid.uuid4().hex[:12]
        keys = [f"velfence-{token}-{i}" for i in range(len(work))]
        futures = client.map(fn, work, key=keys, retries=retries, pure=False) if work else []
        index = {f.key: i for i, f in enumerate(futures)}
        done = 0
        try:
            # On this client's event loop: as_completed defaults to the process's default
            # client, which is the last one started (a user's own Client, say), and waiting
            # on another loop than the futures' raises "bound to a different event loop".
            done_in_order = distributed.as_completed(futures, loop=client.loop)  # type: ignore[no-untyped-call]
            for future in done_in_order:
                i = index[future.key]
                try:
                    result = future.result()
                except Exception as exc:  # fn's own error, KilledWorker, a lost scheduler
                    raise ShardFailed(i, _reason(exc), retries + 1) from exc
                future.release()
                done += 1
                if progress is not None:
                    progress(done, len(work), progress_text(done, len(work), _since(start)))
                yield i, result
        finally:  # an error, Ctrl-C or a consumer that stops early: cancel what is left
            if isinstance(sys.exc_info()[1], KeyboardInterrupt):
                # Dask's own wait, interrupted, schedules a cancel on its event loop that may
                # fail as the cluster goes away; tornado logs that with a traceback. The user
                # pressed Ctrl-C: quiet until the engine is closed (close() restores it).
                _LOOP_LOG.setLevel(logging.CRITICAL + 1)
            left = [f for f in futures if not f.done()]
            if left:
                try:
                    client.cancel(left)
                except Exception:  # the cluster is already going away
                    logging.getLogger(__name__).debug("cancel failed", exc_info=True)


#: The event loop's error log (tornado, under Dask's client), quieted after a Ctrl-C.
_LOOP_LOG = logging.getLogger("tornado.application")


@contextmanager
def _sigint_ignored() -> Iterator[None]:
    """SIGINT ignored for the block (in the main thread; elsewhere nothing changes)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


def _first(pair: tuple[int, Any]) -> int:
    return pair[0]


def _since(start: float) -> float:
    return max(time.perf_counter() - start, 1e-9)


def _listed(items: Any) -> list[Any]:
    if isinstance(items, (str, bytes)) or not isinstance(items, Iterable):
        raise InvalidParameter(f"items: expected an iterable of items, got {describe(items)}")
    try:
        work = list(items)
    except Exception as exc:  # a hostile iterator is refused, not propagated
        raise InvalidParameter(f"items: could not be read ({_reason(exc)})") from None
    if len(work) > MAX_ITEMS:
        raise InvalidParameter(f"items: expected at most {MAX_ITEMS:,}, got {len(work):,}")
    return work
