r"""One 3-D web view for every scene, drawn by viser (a three.js viewer driven from Python).

:func:`serve_web` (CLI: ``velfence view --scenario teleop|arm-box|fence-box``) shows a session in
the browser and lets a person drive it with the keys of the teleop page
(:mod:`velfence.apps.viewer.server`): the thesis's mode keys ``A S F D G P T``, ``C`` (clutch),
``H`` (hand), the arrows and PgUp/PgDn to jog, ``U O I K J L`` to turn, ``[`` ``]`` for the jog
speed, Space to stop. Scenes (:data:`velfence.apps.viewer.view.SCENES`, built by
:func:`velfence.apps.viewer.view.scene_session`):

* ``"teleop"`` — the PUMA 560 of :class:`velfence.apps.teleop.session.Session` (laser-assisted
  traded
  control) with its table, shelf and cup, the laser beam and the fixture line;
* ``"arm-box"`` — the 7-DoF arm of ``docs/arm_box.md``
  (:func:`velfence.apps.demo.arm_box.arm_box_scene`), its TCP kept in the box and its links off
  the sphere by the :class:`~velfence.filter.SafetyFilter` (kinematic plant, 5 ms period);
* ``"fence-box"`` — the Panda-like arm of :mod:`velfence.apps.scenarios.fence_box` in MuJoCo
  (computed-torque servo, 2 ms period; needs the ``physics`` extra).

In the two arm scenes the arrows jog the TCP, ``C`` toggles the clutch (released: the command is
zero) and ``A`` toggles the autopilot, the scripted jog of the scenario (into a corner, along a
face, past the sphere); the other keys are refused with a message. Every scene draws its fence
(the box polytope, translucent), its obstacles, the arm as a chain of capsules, and two arrows at
the TCP: the **commanded** velocity (orange; the jog or the autopilot) and the **shaped** one
(green; what the filter let through, the TCP velocity of its joint velocity). Arrow length:
1 m per 1 m/s (:data:`ARROW_SCALE`).

How it is served. viser runs its own HTTP + websocket server (the ``websockets`` package) and
offers no hook on the handshake, its headers or its HTTP responses. So :class:`WebView` puts the
teleop viewer's hardened server (:class:`velfence.apps.viewer.server.ViewerServer`) in front of it:

* the public port (``127.0.0.1`` only) serves the page (viser's built client, shipped in its
  wheel as one ``index.html``, with a small key script and status line added) and the teleop
  JSON API (``GET /state``, ``GET /scene``, ``POST /key``, ``POST /jog``, ``POST /step``)
  with every check of :mod:`velfence.apps.viewer.server`: ``Host`` must be ``127.0.0.1:port`` or
  ``localhost:port``, a ``POST`` or websocket handshake with a foreign ``Origin`` is a 403,
  body limits, and ``X-Frame-Options: DENY`` plus ``Content-Security-Policy: frame-ancestors
  'none'`` on every response;
* a checked websocket handshake is forwarded byte for byte to viser's server on a second,
  ephemeral loopback port, with a per-server secret header added; viser's connect callback
  closes (code 1008) every websocket that lacks the secret, so a page that finds the internal
  port cannot open a scene connection there. That port still answers plain ``GET`` with the
  client's static files (public code, no state).

Nothing is downloaded at run time: the client is one file in the wheel, and the browser test
(``tests/browser``) records every request the page makes and finds only this server.

The simulation holds still until a client fetches the page (or posts a key); ``start=True``
(``--start``) starts the clock at once. Without ``realtime`` the scene advances only on
``POST /step`` (tests).
"""

from __future__ import annotations

import contextlib
import io
import json
import logging
import math
import secrets
import socket
import threading
from collections.abc import Callable
from http.server import BaseHTTPRequestHandler
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from velfence._typing import FloatArray
from velfence._validate import check_range, real_array, require_package
from velfence.apps.viewer.server import (
    CLUTCH_KEY,
    DEFAULT_CONNECTION_TIMEOUT,
    DEFAULT_MAX_CONNECTIONS,
    HOST,
    SessionLike,
    ViewerServer,
)
from velfence.errors import InvalidInput

__all__ = ["ARROW_SCALE", "AUTOPILOT_KEY", "WebView", "serve_web"]

_log = logging.getLogger(__name__)

#: In the arm scenes, toggles the scenario's scripted jog.
AUTOPILOT_KEY = "A"
#: Arrow length per speed [m per m/s].
ARROW_SCALE = 1.0
#: The header the front server adds to a forwarded handshake (any copy a client sends is dropped).
_PROXY_HEADER = "X-Velfence-Proxy"
_COMMANDED_COLOR = (245, 130, 20)
_SHAPED_COLOR = (30, 170, 60)
_ARM_COLOR = (90, 100, 120)
_FENCE_COLOR = (70, 130, 230)
_OBSTACLE_COLOR = (220, 60, 60)
#: Control period of the live arm-box scene [s]: the docs' 1 ms costs about 1 ms of filter time
#: per period here, too close to real time; 5 ms leaves room.
_ARM_BOX_DT = 5e-3


# ---------------------------------------------------------------------------------- scenes
class _ArmSession:
    """A velocity-controlled arm whose TCP jog is shaped by a filter: SessionLike."""

    def __init__(
        self,
        name: str,
        robot: Any,
        shaper: Any,
        plant: Callable[[FloatArray, FloatArray, float], FloatArray],
        q0: FloatArray,
        dt: float,
        lower: FloatArray,
        upper: FloatArray,
        sphere: tuple[FloatArray, float],
        autopilot: Callable[[float, FloatArray], FloatArray],
    ) -> None:
        self.name = name
        self.robot = robot
        self.shaper = shaper
        self._plant = plant
        self.dt = dt
        self.q = np.array(q0, dtype=float)
        self.t = 0.0
        self._lower, self._upper = np.asarray(lower, float), np.asarray(upper, float)
        self._sphere = sphere
        self._autopilot = autopilot
        self._auto_t0: float | None = None
        self._clutch = True
        self._jog = np.zeros(3)
        self._commanded = np.zeros(3)
        self._shaped = np.zeros(3)
        self._pending = 0.0
        self._min_margin = self.margin()

    def margin(self) -> float:
        """The TCP's distance inside the box [m] (negative: outside)."""
        x = np.asarray(self.robot.fk(self.q), dtype=float)
        return float(min(np.min(x - self._lower), np.min(self._upper - x)))

    def press(self, key: str) -> None:
        if key == AUTOPILOT_KEY:
            self._auto_t0 = None if self._auto_t0 is not None else self.t
        elif key == CLUTCH_KEY:
            self._clutch = not self._clutch
        else:
            raise InvalidInput(
                f"key: {key!r} is not used in the {self.name} scene; expected "
                f"{AUTOPILOT_KEY!r} (autopilot) or {CLUTCH_KEY!r} (clutch)"
            )

    def jog(self, linear: ArrayLike, angular: ArrayLike) -> None:
        self._jog = real_array("linear", linear, (3,), what="TCP velocity [m/s]").copy()

    def advance(self, dt: float) -> None:
        self._pending += float(dt)
        while self._pending >= self.dt * (1.0 - 1e-9):
            self._pending -= self.dt
            self._step()

    def _step(self) -> None:
        q = self.q
        if self._auto_t0 is not None:
            v = np.asarray(self._autopilot(self.t - self._auto_t0, q), dtype=float)
        elif self._clutch:
            v = self._jog
        else:
            v = np.zeros(3)
        qdot = np.asarray(self.shaper.shape(q, v), dtype=float)
        x0 = np.asarray(self.robot.fk(q), dtype=float)
        # The shaped TCP velocity: where the joint velocity takes the TCP in one period.
        x1 = np.asarray(self.robot.fk(q + qdot * self.dt), dtype=float)
        self._commanded = v.copy()
        self._shaped = (x1 - x0) / self.dt
        self.q = np.asarray(self._plant(q, qdot, self.t), dtype=float)
        self.t += self.dt
        self._min_margin = min(self._min_margin, self.margin())

    def snapshot(self) -> dict[str, Any]:
        tcp = np.asarray(self.robot.fk(self.q), dtype=float)
        mode = "autopilot" if self._auto_t0 is not None else "jog"
        return {
            "t": self.t,
            "scene": self.name,
            "mode": mode,
            "clutch": self._clutch,
            "q": self.q.tolist(),
            "joints": np.asarray(self.robot.joint_positions(self.q), float).tolist(),
            "tcp": tcp.tolist(),
            "commanded": self._commanded.tolist(),
            "shaped": self._shaped.tolist(),
            "margin": self.margin(),
            "min_margin": self._min_margin,
            "status": f"{self.name}: {mode}, clutch {'engaged' if self._clutch else 'released'}",
        }

    def scene_primitives(self) -> list[dict[str, Any]]:
        center = (self._lower + self._upper) / 2.0
        half = (self._upper - self._lower) / 2.0
        signs = [[(1 if i >> b & 1 else -1) for b in range(3)] for i in range(8)]
        corners = [(center + np.array(s) * half).tolist() for s in signs]
        c, r = self._sphere
        return [
            {
                "type": "box",
                "name": "fence",
                "dynamic": False,
                "fence": True,
                "center": center.tolist(),
                "half_extents": half.tolist(),
                "rotation": np.eye(3).tolist(),
                "corners": corners,
            },
            {
                "type": "sphere",
                "name": "sphere",
                "dynamic": False,
                "center": np.asarray(c, float).tolist(),
                "radius": float(r),
            },
        ]


def _arm_box_session() -> _ArmSession:
    from velfence.apps.demo.arm_box import (
        arm_box_scene,
        arm_jog,
        arm_script,
        build_arm_controllers,
    )

    scene = arm_box_scene(dt=_ARM_BOX_DT)
    shaper = build_arm_controllers(scene, methods=("safety-filter",))["safety-filter"]
    jog = arm_jog(scene.robot, arm_script(scene, 0.25))

    def plant(q: FloatArray, qdot: FloatArray, t: float) -> FloatArray:
        return q + qdot * scene.dt

    return _ArmSession(
        "arm-box",
        scene.robot,
        shaper,
        plant,
        np.asarray(scene.q0, float),
        scene.dt,
        np.asarray(scene.box_lower, float),
        np.asarray(scene.box_upper, float),
        (np.asarray(scene.sphere_center, float), float(scene.sphere_radius)),
        jog,
    )


class _TeleopSession:
    """:class:`velfence.apps.teleop.session.Session` plus the commanded and shaped tool velocity."""

    def __init__(self) -> None:
        from velfence.apps.teleop.session import Session

        self.session = Session()
        self._jog = np.zeros(3)
        self._shaped = np.zeros(3)

    def press(self, key: str) -> None:
        self.session.press(key)

    def jog(self, linear: ArrayLike, angular: ArrayLike) -> None:
        self._jog = real_array("linear", linear, (3,), what="velocity [m/s]").copy()
        self.session.jog(linear, angular)

    def advance(self, dt: float) -> None:
        x0 = np.asarray(self.session.snapshot()["tool"], float)[:3, 3]
        self.session.advance(dt)
        x1 = np.asarray(self.session.snapshot()["tool"], float)[:3, 3]
        self._shaped = (x1 - x0) / float(dt)

    def snapshot(self) -> dict[str, Any]:
        snap = dict(self.session.snapshot())
        snap["scene"] = "teleop"
        snap["tcp"] = np.asarray(snap["tool"], float)[:3, 3].tolist()
        snap["commanded"] = self._jog.tolist()
        snap["shaped"] = self._shaped.tolist()
        return snap

    def scene_primitives(self) -> list[dict[str, Any]]:
        return self.session.scene_primitives()


# ---------------------------------------------------------------------------------- page
_KEYS_SCRIPT = r"""
<div id="velfence-status" style="position:fixed;left:8px;bottom:8px;z-index:1000;
 font:12px monospace;background:rgba(255,255,255,.85);padding:4px 8px;border-radius:4px;
 pointer-events:none">velfence: connecting…</div>
<script>
"use strict";
(() => {
  const MODE_KEYS = "ASFDGPTCH";
  const MOVE = { ArrowRight: [0, 1], ArrowLeft: [0, -1], ArrowUp: [1, 1], ArrowDown: [1, -1],
                 PageUp: [2, 1], PageDown: [2, -1] };
  const TURN = { KeyU: [0, 1], KeyO: [0, -1], KeyI: [1, 1], KeyK: [1, -1],
                 KeyJ: [2, 1], KeyL: [2, -1] };
  const box = document.getElementById("velfence-status");
  const held = new Set();
  let speed = 0.05, turn = 0.3, shift = false, lastJog = "", err = "", lastKey = "";
  const fmt = (v) => v ? "[" + v.map((x) => x.toFixed(3)).join(", ") + "]" : "-";
  async function post(path, body) {
    try {
      const r = await fetch(path, { method: "POST",
        headers: { "Content-Type": "application/json" }, body: JSON.stringify(body) });
      const j = await r.json();
      err = r.ok ? "" : path + ": " + (j.error || r.status);
    } catch (e) { err = "viewer unreachable: " + e; }
  }
  function jogVector() {
    const lin = [0, 0, 0], ang = [0, 0, 0], k = shift ? 3 : 1;
    for (const code of held) {
      if (MOVE[code]) lin[MOVE[code][0]] += MOVE[code][1] * speed * k;
      if (TURN[code]) ang[TURN[code][0]] += TURN[code][1] * turn * k;
    }
    return { linear: lin, angular: ang };
  }
  function sendJog(force) {
    const j = jogVector(), s = JSON.stringify(j);
    if (s !== lastJog || force) { lastJog = s; post("/jog", j); }
  }
  function typing(e) {
    const t = e.target;
    return t && (t.tagName === "INPUT" || t.tagName === "TEXTAREA" || t.isContentEditable);
  }
  window.addEventListener("keydown", (e) => {
    if (e.ctrlKey || e.metaKey || e.altKey || typing(e)) return;
    shift = e.shiftKey;
    if (MOVE[e.code] || TURN[e.code]) {
      e.preventDefault(); e.stopPropagation(); held.add(e.code); sendJog(false); return;
    }
    if (e.repeat) return;
    const ch = e.code.startsWith("Key") ? e.code.slice(3) : "";
    if (ch && MODE_KEYS.includes(ch)) {
      e.preventDefault(); e.stopPropagation(); lastKey = ch; post("/key", { key: ch });
    } else if (e.code === "Space") { e.preventDefault(); held.clear(); sendJog(true); }
    else if (e.code === "BracketLeft") { speed /= 2; turn /= 2; sendJog(false); }
    else if (e.code === "BracketRight") {
      speed = Math.min(speed * 2, 0.3); turn = Math.min(turn * 2, 1.5); sendJog(false);
    }
  }, true);
  window.addEventListener("keyup", (e) => {
    shift = e.shiftKey;
    if (held.delete(e.code) || e.key === "Shift") sendJog(false);
  }, true);
  window.addEventListener("blur", () => { held.clear(); shift = false; sendJog(true); });
  async function poll() {
    try {
      const r = await fetch("/state", { cache: "no-store" });
      if (r.ok) {
        const s = await r.json(), v = s.viewer || {};
        box.textContent = "velfence " + (s.scene || "") + "  t = " + Number(s.t).toFixed(2) +
          " s  mode = " + s.mode + "  clutch = " + s.clutch + "  key = " + (lastKey || "-") +
          "  commanded = " + fmt(s.commanded) + "  shaped = " + fmt(s.shaped) + " m/s" +
          (v.error ? "  session stopped: " + v.error : "") + (err ? "  " + err : "");
        box.dataset.mode = s.mode; box.dataset.clutch = String(s.clutch);
        box.dataset.t = String(s.t);
      }
    } catch (e) { box.textContent = "velfence: viewer unreachable: " + e; }
    if (held.size) sendJog(true);  // keep-alive of a held jog (the server's dead-man)
    setTimeout(poll, 100);
  }
  poll();
})();
</script>
"""


def _viser_page() -> bytes:
    """Viser's built client (one ``index.html`` in its wheel) with the key script appended."""
    from importlib.resources import files

    page = files("viser").joinpath("client/build/index.html").read_text(encoding="utf-8")
    at = page.rfind("</body>")
    if at < 0:  # a viser release that changes the page layout must be looked at
        raise RuntimeError("viser client page: expected a </body>, found none")
    return (page[:at] + _KEYS_SCRIPT + page[at:]).encode()


#: On every response of the web view: no framing, no sniffing.
_WEB_HEADERS: tuple[tuple[str, str], ...] = (
    ("X-Frame-Options", "DENY"),
    ("Content-Security-Policy", "frame-ancestors 'none'; base-uri 'none'; form-action 'none'"),
    ("X-Content-Type-Options", "nosniff"),
    ("Referrer-Policy", "same-origin"),
)


def _pump(src: socket.socket, dst: socket.socket) -> None:
    """Copy bytes from ``src`` to ``dst`` until either side closes, then close both ways."""
    try:
        while data := src.recv(65536):
            dst.sendall(data)
    except OSError:
        pass
    finally:
        for s in (src, dst):
            with contextlib.suppress(OSError):
                s.shutdown(socket.SHUT_RDWR)


# ---------------------------------------------------------------------------------- server
class WebView(ViewerServer):
    """The web view: viser behind the teleop viewer's checked server (module docstring).

    Create it with :func:`serve_web`. The JSON API, the checks and the stepping are those of
    :class:`~velfence.apps.viewer.server.ViewerServer`; this adds the viser page and its websocket.

    Args:
        session: The scene (:func:`velfence.apps.viewer.view.scene_session`, or any SessionLike).
        port: Public TCP port on ``127.0.0.1``; 0 picks a free one.
        realtime: Advance with wall-clock time (default); ``False`` only on ``POST /step``.
        start: Start the clock at once; ``False`` (default) waits for a client.
        tick: Real-time stepping period [s] (see ViewerServer).
        max_step: Longest real-time advance [s].
        jog_timeout: Dead-man on held jogs [s]; ``math.inf`` disables it.
        connection_timeout: Per-connection socket timeout [s] (not for open websockets).
        max_connections: Connections served at once (open websockets included).
        frame_rate: Redraws of the 3-D scene per second [Hz], in [1, 60].

    Raises:
        InvalidParameter: a bad argument (the message names it), or viser is not installed
            (``pip install 'velfence[web]'``).
        OSError: the port is in use.
    """

    def __init__(
        self,
        session: SessionLike,
        *,
        port: int = 0,
        realtime: bool = True,
        start: bool = False,
        tick: float = 0.02,
        max_step: float = 0.1,
        jog_timeout: float = 0.5,
        connection_timeout: float = DEFAULT_CONNECTION_TIMEOUT,
        max_connections: int = DEFAULT_MAX_CONNECTIONS,
        frame_rate: float = 20.0,
    ) -> None:
        self._period = 1.0 / check_range("frame_rate", frame_rate, low=1.0, high=60.0, unit="Hz")
        viser = require_package("session", "viser", extra="web", what="the 3-D web view")
        self._page_bytes = _viser_page()
        self._security_headers = _WEB_HEADERS
        self._token = secrets.token_urlsafe(24)
        self._viser_port = 0
        self._forwarded = 0
        self._frame_stop = threading.Event()
        self._handles: dict[str, Any] = {}
        self._last_frame = ""
        self._frame_thread: threading.Thread | None = None
        # viser prints a banner with its own (internal) URL whatever ``verbose`` says; a person
        # must open the front port instead, so the banner goes to the debug log.
        banner = io.StringIO()
        with contextlib.redirect_stdout(banner):
            self._viser = viser.ViserServer(host=HOST, port=0, verbose=False)
        _log.debug("viser: %s", banner.getvalue())
        try:
            self._guard_viser()
            self._viser_port = int(self._viser.get_port())
            super().__init__(
                session,
                port=port,
                realtime=realtime,
                tick=tick,
                max_step=max_step,
                jog_timeout=jog_timeout,
                connection_timeout=connection_timeout,
                max_connections=max_connections,
                start=start,
            )
            self._draw_static()
        except BaseException:
            if hasattr(self, "_httpd"):  # the front server started: stop it too
                ViewerServer.stop(self)
            self._viser.stop()
            raise
        self._frame_thread = threading.Thread(
            target=self._run_frames, name="velfence-web-frames", daemon=True
        )
        self._frame_thread.start()

    @property
    def viser_port(self) -> int:
        """The internal loopback port of viser's own server (it refuses direct websockets)."""
        return self._viser_port

    @property
    def forwarded_websockets(self) -> int:
        """How many websocket handshakes passed the checks and were forwarded to viser."""
        return self._forwarded

    def stop(self) -> None:
        """Stop drawing, stepping and serving, and viser's server (idempotent)."""
        if not self.running:
            return
        self._frame_stop.set()
        if self._frame_thread is not None:
            self._frame_thread.join()
        super().stop()
        self._viser.stop()

    def __repr__(self) -> str:
        return f"WebView({self.url}, viser on port {self._viser_port})"

    # -------------------------------------------------------------------------- websocket
    def _guard_viser(self) -> None:
        """Close every viser websocket that did not come through :meth:`_upgrade`."""
        ws = self._viser._websock_server
        token = self._token

        async def guard(conn: Any) -> None:
            raw = ws._live_connections.get(conn.client_id)
            request = getattr(raw, "request", None)
            sent = "" if request is None else request.headers.get(_PROXY_HEADER, "")
            if raw is not None and not secrets.compare_digest(str(sent), token):
                _log.warning("refused a websocket that bypassed the web view's port")
                await raw.close(1008, "connect through the velfence web view's own port")

        ws.on_client_connect(guard)
        # viser starts serving inside its constructor, before the guard could be registered:
        # drop whatever connected in that window (a client reconnects and is checked then).
        ws.disconnect_all_clients()

    def _upgrade(self, handler: BaseHTTPRequestHandler) -> bool:
        """Forward a checked websocket handshake to viser and pipe both ways until closed."""
        if self._viser_port == 0 or not self.running:
            return False
        self._client_seen()
        self._forwarded += 1
        upstream = socket.create_connection((HOST, self._viser_port), timeout=5.0)
        lines = [handler.requestline]
        lines += [
            f"{k}: {v}" for k, v in handler.headers.items() if k.lower() != "x-velfence-proxy"
        ]
        lines.append(f"{_PROXY_HEADER}: {self._token}")
        client = handler.connection
        handler.close_connection = True
        try:
            upstream.sendall(("\r\n".join(lines) + "\r\n\r\n").encode("latin-1"))
            upstream.settimeout(None)
            client.settimeout(None)  # a scene connection may stay open for hours
            back = threading.Thread(target=_pump, args=(upstream, client), daemon=True)
            back.start()
            try:  # the handler's buffered reader may already hold the first frames
                while data := handler.rfile.read1(65536):
                    upstream.sendall(data)
            except OSError:
                pass
            finally:
                for s in (upstream, client):
                    with contextlib.suppress(OSError):
                        s.shutdown(socket.SHUT_RDWR)
                back.join(5.0)
        finally:
            upstream.close()
        return True

    # -------------------------------------------------------------------------- drawing
    def _draw_static(self) -> None:
        scene = self._viser.scene
        scene.set_up_direction("+z")
        # No shadow maps and no environment-map prefiltering: both cost seconds per frame in a
        # browser without a GPU (software WebGL), and the view needs neither.
        scene.configure_default_lights(cast_shadow=False)
        scene.configure_environment_map(hdri=None)
        scene.add_grid("/grid", width=3.0, height=3.0, cell_size=0.1, position=(0.0, 0.0, -0.001))
        self._dynamic: dict[str, Any] = {}
        for i, prim in enumerate(self.scene()):
            self._draw_primitive(f"/scene/{i}_{prim.get('name', '')}", prim)
        state = self.state()
        tcp = np.asarray(state.get("tcp", (0.0, 0.0, 0.0)), float)
        # Looking at a point between the base and the TCP, from the front right and above.
        look = tcp * 0.85
        self._viser.initial_camera.look_at = tuple(look)
        self._viser.initial_camera.position = tuple(look + np.array([1.1, -0.8, 0.5]))
        self._viser.gui.configure_theme(control_width="small", show_logo=False)
        keys = (
            "**Keys** (click the scene first): arrows, PgUp/PgDn jog the TCP; `C` clutch; "
            + (
                "`A S F D G P T` modes, `H` hand; `U O I K J L` turn."
                if state.get("scene") == "teleop"
                else "`A` autopilot (the scripted jog)."
            )
            + " `[` `]` jog speed, Space stops. Orange arrow: commanded, green: shaped."
        )
        self._viser.gui.add_markdown(keys)
        self._status = self._viser.gui.add_markdown("…")

    def _draw_primitive(self, name: str, p: dict[str, Any]) -> None:
        from viser import transforms

        scene = self._viser.scene
        kind = p.get("type")
        handle: Any
        color = _FENCE_COLOR if p.get("fence") else (150, 140, 120)
        if kind == "box":
            rot = transforms.SO3.from_matrix(np.asarray(p["rotation"], float)).wxyz
            dims = tuple(2.0 * np.asarray(p["half_extents"], float))
            opacity = 0.15 if p.get("fence") else 0.6
            handle = scene.add_box(
                name, color, dims, opacity=opacity, position=tuple(p["center"]), wxyz=rot
            )
            if p.get("fence"):
                c = np.asarray(p["corners"], float)
                edges = [(i, i ^ (1 << b)) for i in range(8) for b in range(3) if not i >> b & 1]
                pts = np.array([[c[a], c[b]] for a, b in edges])
                scene.add_line_segments(f"{name}_edges", pts, _FENCE_COLOR, thickness=0.006)
        elif kind == "sphere":
            handle = scene.add_icosphere(
                name, float(p["radius"]), _OBSTACLE_COLOR, position=tuple(p["center"])
            )
        elif kind == "cylinder":
            handle = scene.add_cylinder(
                name, float(p["radius"]), float(p["height"]), color, position=tuple(p["center"])
            )
        elif kind == "disk":
            n = np.asarray(p["normal"], float)
            wxyz = _rotation_to(n)
            handle = scene.add_cylinder(
                name, float(p["radius"]), 0.004, color, position=tuple(p["center"]), wxyz=wxyz
            )
        elif kind == "plane" and p.get("corners") is not None:
            c = np.asarray(p["corners"], float)
            handle = scene.add_mesh_simple(
                name,
                c,
                np.array([[0, 1, 2], [0, 2, 3]]),
                color=(200, 200, 190),
                side="double",
                opacity=0.5,
            )
        else:
            return
        if p.get("dynamic"):
            self._dynamic[str(p.get("name"))] = (handle, kind)

    def _run_frames(self) -> None:
        while not self._frame_stop.wait(self._period):
            try:
                self._draw_frame(self.state())
            except Exception:  # a drawing failure must not kill the view: log, go on
                _log.debug("web view frame failed", exc_info=True)

    def _draw_frame(self, s: dict[str, Any]) -> None:
        # Only what changed is sent, and by updating a node's props, not re-creating it: a
        # browser without a GPU (software WebGL) otherwise spends its time rebuilding meshes.
        key = json.dumps(
            [s.get(k) for k in ("joints", "tcp", "commanded", "shaped", "laser", "fixture", "task")]
        )
        if key == self._last_frame:
            return
        self._last_frame = key
        joints = np.asarray(s.get("joints") or [], float).reshape(-1, 3)
        if len(joints) >= 2:
            self._segments(
                "/arm/links", np.stack([joints[:-1], joints[1:]], axis=1), _ARM_COLOR, 0.06
            )
            self._points("/arm/joints", joints)
        tcp = np.asarray(s.get("tcp") or (0.0, 0.0, 0.0), float)
        for name, color in (("commanded", _COMMANDED_COLOR), ("shaped", _SHAPED_COLOR)):
            v = np.asarray(s.get(name) or (0.0, 0.0, 0.0), float)
            tip = tcp + ARROW_SCALE * v
            show = bool(np.all(np.isfinite(tip))) and float(np.linalg.norm(v)) > 1e-4
            self._arrow(f"/velocity/{name}", tcp, tip if show else tcp + 1e-6, color, show)
        laser = s.get("laser") or {}
        beam = None
        if laser.get("origin") is not None and laser.get("point") is not None:
            beam = np.array([[laser["origin"], laser["point"]]], float)
        self._segments("/teleop/laser", beam, (230, 0, 0), 0.004)
        fixture = s.get("fixture")
        line = None if not fixture else np.array([[fixture["start"], fixture["end"]]], float)
        self._segments("/teleop/fixture", line, (200, 0, 200), 0.006)
        grip = s.get("gripper")
        g = None if not grip else np.array([[grip["start"], grip["end"]]], float)
        self._segments("/teleop/gripper", g, (60, 60, 60), 0.03)
        task = s.get("task") or {}
        for name, (handle, kind) in self._dynamic.items():
            where = task.get(name)
            handle.visible = where is not None
            if where is not None:
                pos = np.asarray(where, float)
                if kind == "cylinder":  # task gives the bottom centre
                    pos = pos + np.array([0.0, 0.0, float(getattr(handle, "height", 0.0)) / 2])
                handle.position = tuple(pos)
        text = (
            f"**t** = {float(s.get('t') or 0.0):.2f} s · **mode** {s.get('mode')} · "
            f"**clutch** {s.get('clutch')}"
        )
        if text != self._status.content:
            self._status.content = text

    def _segments(
        self, name: str, pts: FloatArray | None, color: tuple[int, int, int], width: float
    ) -> None:
        handle = self._handles.get(name)
        if pts is None:
            if handle is not None:
                handle.visible = False
            return
        if handle is None or handle.points.shape != pts.shape:
            if handle is not None:
                handle.remove()
            self._handles[name] = self._viser.scene.add_line_segments(
                name, pts, color, thickness=width
            )
        else:
            handle.points = pts.astype(np.float32)
            handle.visible = True

    def _points(self, name: str, pts: FloatArray) -> None:
        handle = self._handles.get(name)
        if handle is None or handle.points.shape != pts.shape:
            if handle is not None:
                handle.remove()
            self._handles[name] = self._viser.scene.add_point_cloud(
                name, pts, (40, 40, 50), point_size=0.04, point_shape="circle"
            )
        else:
            handle.points = pts.astype(np.float32)

    def _arrow(
        self, name: str, a: FloatArray, b: FloatArray, color: tuple[int, int, int], show: bool
    ) -> None:
        pts = np.array([[a, b]], dtype=np.float32)
        handle = self._handles.get(name)
        if handle is None:
            self._handles[name] = self._viser.scene.add_arrows(
                name,
                pts,
                color,
                shaft_radius=0.012,
                head_radius=0.03,
                head_length=0.05,
                visible=show,
            )
        else:
            handle.points = pts
            handle.visible = show


def _rotation_to(n: FloatArray) -> tuple[float, float, float, float]:
    """The quaternion (w, x, y, z) turning +z onto the unit vector ``n``."""
    z = np.array([0.0, 0.0, 1.0])
    n = n / float(np.linalg.norm(n))
    c = float(z @ n)
    if c < -1.0 + 1e-12:
        return (0.0, 1.0, 0.0, 0.0)
    axis = np.cross(z, n)
    w = math.sqrt((1.0 + c) / 2.0)
    xyz = axis / (2.0 * w)
    return (w, float(xyz[0]), float(xyz[1]), float(xyz[2]))


def serve_web(
    session: SessionLike,
    *,
    port: int = 0,
    realtime: bool = True,
    start: bool = False,
    jog_timeout: float = 0.5,
) -> WebView:
    """Serve a session as a 3-D web view on ``http://127.0.0.1:port/`` (module docstring).

    Args:
        session: The scene: :func:`velfence.apps.viewer.view.scene_session` builds the named ones,
        or any
            :class:`~velfence.apps.viewer.server.SessionLike`.
        port: TCP port on ``127.0.0.1``; 0 picks a free one (read it back from ``.port``).
        realtime: Advance with wall-clock time (default); ``False`` only on ``POST /step``.
        start: Start the clock at once; ``False`` (default) waits for the first client.
        jog_timeout: Dead-man on held jogs [s]; ``math.inf`` disables it.

    Returns:
        The running :class:`WebView`; :meth:`WebView.stop` it (or use ``with``).

    Raises:
        InvalidParameter: a bad session or argument, or viser missing.
        OSError: the port is in use.
    """
    return WebView(session, port=port, realtime=realtime, start=start, jog_timeout=jog_timeout)
