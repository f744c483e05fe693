"""A headless Chromium driven over the Chrome DevTools Protocol (no downloads, no webdriver).

:func:`find_chromium` finds the Debian ``chromium`` (``None``: the tests skip). :class:`Browser`
starts it with a throwaway profile and ``--remote-debugging-port=0``, reads the chosen port from
``DevToolsActivePort``, opens one page target and talks CDP to it over a websocket (the
``websockets`` package). Every wait polls with a deadline; nothing sleeps a fixed time.
"""

from __future__ import annotations

import base64
import io
import itertools
import json
import os
import shutil
import subprocess
import tempfile
import time
import urllib.error
import urllib.request
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

from websockets.sync.client import connect

T = TypeVar("T")

FLAGS = (
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--enable-unsafe-swiftshader",
    "--use-angle=swiftshader",
    "--disable-default-apps",
    "--disable-extensions",
    "--window-size=1000,640",
)


def find_chromium() -> str | None:
    """The path of a Chromium / Chrome binary, or ``None``."""
    for name in ("chromium", "chromium-browser", "google-chrome", "chrome"):
        path = shutil.which(name)
        if path:
            return path
    return "/usr/bin/chromium" if os.access("/usr/bin/chromium", os.X_OK) else None


def poll(what: str, check: Callable[[], T | None], timeout: float = 10.0) -> T:
    """``check()`` until it returns something not ``None``/``False``, or fail after ``timeout``."""
    deadline = time.monotonic() + timeout
    last: Any = None
    while True:
        last = check()
        if last is not None and last is not False:
            return last
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out after {timeout} s waiting for {what}")
        time.sleep(0.02)  # the polling step of a deadline loop, not a fixed wait


def _port(active: Path) -> str | None:
    """The port in ``DevToolsActivePort`` once it is written completely."""
    try:
        first = active.read_text().split("\n")[0]
    except OSError:
        return None
    return first if first.isdigit() else None


def _new_target(port: str) -> dict[str, Any] | None:
    """Open a blank page target; ``None`` while the endpoint does not answer yet."""
    req = urllib.request.Request(f"http://127.0.0.1:{port}/json/new?about:blank", method="PUT")
    try:
        with urllib.request.urlopen(req, timeout=10) as r:
            return dict(json.load(r))
    except (urllib.error.URLError, ConnectionError):
        return None


class Browser:
    """A headless Chromium with one page; use as a context manager."""

    def __init__(self, binary: str) -> None:
        self._profile = tempfile.TemporaryDirectory(prefix="velfence-chromium-")
        self._proc = subprocess.Popen(
            [
                binary,
                *FLAGS,
                f"--user-data-dir={self._profile.name}",
                "--remote-debugging-port=0",
                "about:blank",
            ],
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        self._ids = itertools.count(1)
        self.events: list[dict[str, Any]] = []
        try:
            active = Path(self._profile.name) / "DevToolsActivePort"
            port = poll("DevToolsActivePort", lambda: _port(active), timeout=30.0)
            # The file can appear a moment before the endpoint answers: retry until the deadline.
            target = poll("the DevTools endpoint", lambda: _new_target(port), timeout=30.0)
            self._ws = connect(target["webSocketDebuggerUrl"], max_size=None, open_timeout=10)
        except BaseException:
            self.close()
            raise

    def send(self, method: str, timeout: float = 20.0, **params: Any) -> dict[str, Any]:
        """One CDP command; the events that arrive meanwhile go to :attr:`events`."""
        i = next(self._ids)
        self._ws.send(json.dumps({"id": i, "method": method, "params": params}))
        deadline = time.monotonic() + timeout
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                raise AssertionError(f"CDP {method}: no answer within {timeout} s")
            msg = json.loads(self._ws.recv(timeout=left))
            if msg.get("id") == i:
                if "error" in msg:
                    raise AssertionError(f"CDP {method}: {msg['error']}")
                return dict(msg.get("result", {}))
            self.events.append(msg)

    def evaluate(self, expression: str) -> Any:
        """The value of a JavaScript expression in the page (promises awaited)."""
        res = self.send(
            "Runtime.evaluate", expression=expression, returnByValue=True, awaitPromise=True
        )
        if "exceptionDetails" in res:
            raise AssertionError(f"page script failed: {res['exceptionDetails']}")
        return res.get("result", {}).get("value")

    def key(self, code: str, key: str, vk: int, *, up: bool = True) -> None:
        """Press (and by default release) a key, as the keyboard would."""
        text = key if len(key) == 1 else ""
        self.send(
            "Input.dispatchKeyEvent",
            type="keyDown",
            code=code,
            key=key,
            windowsVirtualKeyCode=vk,
            text=text,
        )
        if up:
            self.key_up(code, key, vk)

    def key_up(self, code: str, key: str, vk: int) -> None:
        self.send(
            "Input.dispatchKeyEvent", type="keyUp", code=code, key=key, windowsVirtualKeyCode=vk
        )

    def screenshot(self) -> bytes:
        """A PNG of the page as shown."""
        return base64.b64decode(self.send("Page.captureScreenshot", format="png")["data"])

    def requested_urls(self) -> list[tuple[str, str]]:
        """``(document URL, URL)`` of every request seen (``Network.enable`` must be on)."""
        self.send("Runtime.evaluate", expression="1")  # drain pending events
        out = []
        for e in self.events:
            if e.get("method") == "Network.requestWillBeSent":
                out.append((e["params"].get("documentURL", ""), e["params"]["request"]["url"]))
            elif e.get("method") == "Network.webSocketCreated":
                out.append(("", e["params"]["url"]))
        return out

    def close(self) -> None:
        ws = getattr(self, "_ws", None)
        if ws is not None:
            ws.close()
        self._proc.terminate()
        try:
            self._proc.wait(10)
        except subprocess.TimeoutExpired:
            self._proc.kill()
            self._proc.wait(10)
        self._profile.cleanup()

    def __enter__(self) -> Browser:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def image_stats(png: bytes) -> tuple[int, float]:
    """(number of distinct colours, pixel standard deviation) of a PNG."""
    import numpy as np
    from PIL import Image

    img = np.asarray(Image.open(io.BytesIO(png)).convert("RGB"))
    colours = len(np.unique(img.reshape(-1, 3), axis=0))
    return colours, float(img.std())
