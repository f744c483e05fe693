"""Bridge tests: DDS on loopback only, one random domain per test session, a bridge per test.

``CYCLONEDDS_URI`` confines Cyclone DDS to ``lo`` without multicast (peers found by unicast on
127.0.0.1), before cyclonedds is imported anywhere, and the client processes inherit it. Each
test gets its own ROS namespace, so endpoints of one test never meet another's.
"""

from __future__ import annotations

import contextlib
import importlib.util
import itertools
import json
import logging
import os
import random
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

LOOPBACK = (
    '<CycloneDDS><Domain id="any"><General><Interfaces><NetworkInterface name="lo" '
    'multicast="false"/></Interfaces><AllowMulticast>false</AllowMulticast></General>'
    '<Discovery><ParticipantIndex>auto</ParticipantIndex><Peers><Peer address="127.0.0.1"/>'
    "</Peers></Discovery></Domain></CycloneDDS>"
)
os.environ["CYCLONEDDS_URI"] = LOOPBACK
#: The DDS domain of this test session (random: parallel sessions do not see each other).
DOMAIN = random.SystemRandom().randint(1, 230)
os.environ["ROS_DOMAIN_ID"] = str(DOMAIN)

if importlib.util.find_spec("cyclonedds") is None:  # the ros extra is not installed
    collect_ignore_glob = ["test_*.py"]

import velfence  # noqa: E402

CLIENT = Path(__file__).with_name("ros_client.py")
SRC = Path(velfence.__file__).resolve().parents[1]
_NAMESPACES = itertools.count()
#: Unique to this session: two sessions that drew the same domain still never share a topic.
_SESSION = f"s{os.getpid()}x{random.SystemRandom().randrange(16**6):06x}"


class RunningBridge:
    """A bridge node running in a thread of the test process."""

    def __init__(self, doc: dict[str, Any], **kwargs: Any) -> None:
        from velfence.bridge import BridgeNode, parse_bridge_config

        self.config = parse_bridge_config(doc, source="test")
        self.node = BridgeNode(self.config, **kwargs)
        self.error: BaseException | None = None
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()
        if not self.node.wait_ready(30.0):
            raise RuntimeError(f"bridge did not start: {self.error!r}")

    def _run(self) -> None:
        try:
            self.node.run()
        except BaseException as exc:
            self.error = exc

    def topic(self, name: str) -> str:
        from velfence.bridge.config import dds_topic

        return dds_topic(self.config.settings, name)

    def close(self) -> None:
        self.node.stop()
        self.thread.join(30.0)
        assert not self.thread.is_alive(), "the bridge did not stop"
        assert self.error is None, repr(self.error)


@pytest.fixture
def bridge() -> Iterator[Callable[..., RunningBridge]]:
    """Factory: ``bridge(bridge_section, shaper_section, **node_kwargs)``; stopped afterwards."""
    started: list[RunningBridge] = []

    def start(section: dict[str, Any], shaper: dict[str, Any], **kwargs: Any) -> RunningBridge:
        doc = {
            "bridge": {
                "domain_id": DOMAIN,
                "namespace": f"/{_SESSION}/t{next(_NAMESPACES)}",
                **section,
            },
            "shaper": shaper,
        }
        b = RunningBridge(doc, **kwargs)
        started.append(b)
        return b

    yield start
    for b in started:
        b.close()


def run_client(
    spec: dict[str, Any],
    tmp_path: Path,
    *,
    bridge: RunningBridge | None = None,
    timeout: float = 60.0,
) -> dict[str, Any]:
    """Run ros_client.py in its own process with ``spec``; its JSON result.

    With ``bridge`` (a stream scenario), the client sends nothing until this process has seen the
    bridge's endpoints match every one of the client's (:func:`_release_when_matched`): the
    client's own matches only say that *it* found the bridge, and the bridge's output writer
    sends its first answers to no one while it has not matched the client's reader.
    """
    n = next(_NAMESPACES)
    path = tmp_path / f"client-{n}.json"
    sync = None if bridge is None else tmp_path / f"sync-{n}"
    if sync is not None:
        spec = {**spec, "sync": str(sync)}
    path.write_text(json.dumps({"domain": DOMAIN, **spec}), encoding="utf-8")
    env = {**os.environ, "PYTHONPATH": str(SRC), "CYCLONEDDS_URI": LOOPBACK}
    with subprocess.Popen(
        [sys.executable, str(CLIENT), str(path)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
    ) as proc:
        if bridge is not None and sync is not None:
            _release_when_matched(proc, bridge, sync, deadline=time.monotonic() + timeout)
        try:
            out, err = proc.communicate(timeout=timeout)
        except subprocess.TimeoutExpired:
            proc.kill()
            out, err = proc.communicate()
            raise AssertionError(f"client timed out after {timeout} s: {err[-2000:]}") from None
    if proc.returncode != 0:
        raise AssertionError(f"client failed ({proc.returncode}): {err[-2000:]}")
    result: dict[str, Any] = json.loads(out)
    return result


def _release_when_matched(
    proc: subprocess.Popen[str], bridge: RunningBridge, sync: Path, *, deadline: float
) -> None:
    """Write the client's go-ahead once the bridge's side has matched every client endpoint.

    The client names its writers and its output reader (GUIDs) in ``<sync>.ready`` after its
    own endpoints matched. Delivery needs the writer's side: a writer sends a volatile sample
    only to the readers it has matched when it writes it, so the bridge's output writer must
    have matched the client's reader before the first answer; the bridge's readers must have
    matched the client's writers too (the client checked its writers' side itself).
    """
    node: Any = bridge.node
    ready = Path(str(sync) + ".ready")
    readers = [node._cmd_reader, node._state_reader, *node._tf_readers.values()]
    readers += node._sensor_readers
    writers = [node._out_writer]

    def matched() -> bool:
        if not ready.exists():
            return False
        client = json.loads(ready.read_text(encoding="utf-8"))
        by_readers, by_writers = _matched(readers), _matched(writers)
        return set(client["writers"]) <= by_readers and set(client["readers"]) <= by_writers

    while not matched():
        if proc.poll() is not None or time.monotonic() > deadline:
            return  # the client's own error (or its timeout) reports it
        time.sleep(0.005)
    Path(str(sync) + ".go").touch()


def _matched(endpoints: list[Any]) -> set[str]:
    """The GUIDs of the peers' endpoints that ``endpoints`` (readers or writers) have matched."""
    keys = set()
    for e in endpoints:
        reader = hasattr(e, "get_matched_publications")
        handles = e.get_matched_publications() if reader else e.get_matched_subscriptions()
        for h in handles:
            with contextlib.suppress(Exception):  # a peer that left since it was listed
                data = (
                    e.get_matched_publication_data(h)
                    if reader
                    else e.get_matched_subscription_data(h)
                )
                if data is not None:
                    keys.add(str(data.key))
    return keys


@pytest.fixture
def bridge_log(caplog: pytest.LogCaptureFixture) -> pytest.LogCaptureFixture:
    caplog.set_level(logging.INFO, logger="velfence.bridge")
    return caplog
