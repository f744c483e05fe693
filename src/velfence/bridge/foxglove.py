"""A live view of a shaped robot in Foxglove, and the same recorded to MCAP.

:class:`FoxgloveView` runs foxglove-sdk's WebSocket server (protocol ``foxglove.sdk.v1``; clients
offering its legacy name ``foxglove.websocket.v1`` are admitted too, through a small front that
renames it in the handshake) on the loopback interface and publishes, for every
:meth:`FoxgloveView.publish`:

* ``/velfence/scene`` — ``foxglove.SceneUpdate`` (protobuf): the fence (a polygon's outline as a
  ``LinePrimitive`` loop, a 3-D polytope's edges as a line list), the robot point as a sphere,
  the commanded (orange) and shaped (green) velocities as arrows of length ``|v| · arrow_time``;
* ``/velfence/status`` — JSON (with a JSON schema): ``t``, ``zone``, ``active`` constraint names,
  ``changed_by`` (``|command - shaped|``) and ``changed``;
* ``/velfence/velocity`` — JSON: ``t``, ``command``, ``shaped`` and their norms, for Foxglove's
  Plot panel (``/velfence/velocity.command[0]`` against ``.shaped[0]``).

``record=`` writes the same messages to an MCAP file through foxglove-sdk's writer; ``port=None``
records without a server (:func:`record_trajectory` replays a finished run that way). How to open
either in Foxglove: ``docs/foxglove.md``. foxglove-sdk (the ``ros`` extra) is imported when a view
is made, never by ``import velfence``.
"""

from __future__ import annotations

import contextlib
import ipaddress
import math
import time
from collections.abc import Mapping, Sequence
from pathlib import Path
from types import TracebackType
from typing import Any

import numpy as np

from velfence._docs import document_inits
from velfence._typing import FloatArray
from velfence._validate import (
    check_flag,
    check_output_path,
    check_positive,
    check_positive_int,
    check_text,
    finite_scalar,
    real_array,
    show,
)
from velfence.bridge._foxglove_front import SubprotocolFront
from velfence.errors import InvalidGeometry, InvalidInput, InvalidParameter
from velfence.geometry.polygon import ConvexPolygon
from velfence.geometry.polytope import ConvexPolytope

__all__ = [
    "SCENE_TOPIC",
    "STATUS_TOPIC",
    "VELOCITY_TOPIC",
    "FoxgloveView",
    "record_trajectory",
    "view_hook",
]

#: Topic of the 3-D scene (``foxglove.SceneUpdate``, protobuf).
SCENE_TOPIC = "/velfence/scene"
#: Topic of the status messages (JSON: zone, active constraints, changed-by).
STATUS_TOPIC = "/velfence/status"
#: Topic of the velocity time series (JSON: command and shaped).
VELOCITY_TOPIC = "/velfence/velocity"

_STATUS_SCHEMA: dict[str, Any] = {
    "title": "velfence.Status",
    "type": "object",
    "properties": {
        "t": {"type": "number", "description": "time [s]"},
        "zone": {"type": "string", "description": "the shaper's zone"},
        "active": {
            "type": "array",
            "items": {"type": "string"},
            "description": "names of the constraints that changed the command",
        },
        "changed_by": {"type": "number", "description": "|command - shaped| [units/s]"},
        "changed": {"type": "boolean", "description": "whether the shaper changed the command"},
    },
}
_VELOCITY_SCHEMA: dict[str, Any] = {
    "title": "velfence.Velocity",
    "type": "object",
    "properties": {
        "t": {"type": "number", "description": "time [s]"},
        "command": {"type": "array", "items": {"type": "number"}},
        "shaped": {"type": "array", "items": {"type": "number"}},
        "command_norm": {"type": "number"},
        "shaped_norm": {"type": "number"},
    },
}
_MAX_NAMES = 1000  # most entries of ``active``
_MAX_DIM = 64  # longest state / velocity vector
_CHANGED_TOL = 1e-12  # |command - shaped| above this counts as changed
_FENCE_RGBA = (0.2, 0.5, 1.0, 1.0)
_ROBOT_RGBA = (1.0, 1.0, 1.0, 1.0)
_COMMAND_RGBA = (1.0, 0.55, 0.0, 1.0)
_SHAPED_RGBA = (0.1, 0.8, 0.2, 1.0)


def _loopback(host: str) -> bool:
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def _fence_lines(fence: ConvexPolygon | ConvexPolytope) -> tuple[FloatArray, bool]:
    """Points (k, 3) of the fence's outline and whether they form one loop (else pairs)."""
    if isinstance(fence, ConvexPolygon):
        c = np.asarray(fence.corners)
        return np.column_stack([c, np.zeros(len(c))]), True
    if fence.dim == 2:
        v = np.asarray(fence.vertices)
        ctr = v.mean(axis=0)
        order = np.argsort(np.arctan2(v[:, 1] - ctr[1], v[:, 0] - ctr[0]))
        v = v[order]
        return np.column_stack([v, np.zeros(len(v))]), True
    V = np.asarray(fence.vertices)
    N, off = np.asarray(fence.normals), np.asarray(fence.offsets)
    scale = 1.0 + float(np.max(np.abs(V)))
    tight = np.abs(V @ N.T - off) <= 1e-7 * scale  # (vertices, facets)
    segments = []
    for i in range(len(V)):
        for j in range(i + 1, len(V)):
            common = np.flatnonzero(tight[i] & tight[j])
            if common.size >= 2 and np.linalg.matrix_rank(N[common], tol=1e-9) == 2:
                segments += [V[i], V[j]]
    return np.array(segments).reshape(-1, 3), False


def _check_fence(name: str, fence: Any) -> ConvexPolygon | ConvexPolytope | None:
    if fence is None or isinstance(fence, ConvexPolygon):
        return fence
    if not isinstance(fence, ConvexPolytope):
        raise InvalidGeometry(
            f"{name}: expected a ConvexPolygon, a ConvexPolytope or None, got "
            f"{type(fence).__name__} {show(fence, 40)}"
        )
    if fence.dim not in (2, 3):
        raise InvalidGeometry(
            f"{name}: expected a 2-D or 3-D polytope to draw, got {fence.dim} dimensions (a "
            "joint-space polytope has no picture; pass fence=None and publish the joints)"
        )
    if not fence.bounded:
        raise InvalidGeometry(f"{name}: expected a bounded polytope to draw, got an unbounded one")
    return fence


def _field(info: Any, key: str, default: Any = ...) -> Any:
    if isinstance(info, Mapping):
        if key in info:
            return info[key]
    elif hasattr(info, key):
        return getattr(info, key)
    if default is ...:
        raise InvalidInput(f"info.{key}: missing (publish needs t, state, command, shaped)")
    return default


def _vector(name: str, x: Any) -> FloatArray:
    v = real_array(name, x, (None,), what="a vector of real numbers")
    if not 1 <= v.shape[0] <= _MAX_DIM:
        raise InvalidInput(f"{name}: expected 1 to {_MAX_DIM} numbers, got {v.shape[0]}")
    return v


def _names(name: str, x: Any) -> list[str]:
    if isinstance(x, (str, bytes, Mapping)) or not isinstance(x, (Sequence, np.ndarray)):
        raise InvalidInput(f"{name}: expected a list of constraint names, got {show(x, 40)}")
    if len(x) > _MAX_NAMES:
        raise InvalidInput(f"{name}: expected at most {_MAX_NAMES} names, got {len(x)}")
    out = []
    for i, s in enumerate(x):
        if not isinstance(s, str) or len(s) > 200:
            raise InvalidInput(f"{name}[{i}]: expected a name (a string), got {show(s, 40)}")
        out.append(str(s))
    return out


def _quaternion_x_to(v: FloatArray) -> tuple[float, float, float, float]:
    """Unit quaternion (x, y, z, w) turning the x axis onto the direction of ``v`` (3,)."""
    u = v / np.linalg.norm(v)
    w = 1.0 + float(u[0])
    if w < 1e-9:  # v points along -x: half a turn about z
        return 0.0, 0.0, 1.0, 0.0
    q = np.array([0.0, -float(u[2]), float(u[1]), w])
    q /= np.linalg.norm(q)
    return float(q[0]), float(q[1]), float(q[2]), float(q[3])


class FoxgloveView:
    """A Foxglove live view (WebSocket server on the loopback) and/or an MCAP recording.

    Use it as a context manager, or call :meth:`close`. Each view has its own foxglove-sdk
    context: two views never see each other's channels.

    Args:
        host: Interface to listen on; loopback only (``"127.0.0.1"``, ``"::1"``,
            ``"localhost"``) unless ``allow_remote=True``.
        port: TCP port (``0``: any free port, read it from :attr:`port`); ``None``: no server
            (with ``record`` only).
        record: MCAP file to write the same messages to (must not exist; its directory must);
            ``None`` (default) for none.
        fence: The set to draw: a :class:`~velfence.geometry.polygon.ConvexPolygon` (drawn in
            the plane z = 0), a bounded 2-D or 3-D
            :class:`~velfence.geometry.polytope.ConvexPolytope`, or ``None``.
        frame_id: Frame of every scene entity (Foxglove's 3D panel "display frame").
        arrow_time: Seconds of motion an arrow shows: its length is ``|v| · arrow_time``.
        point_size: Diameter of the robot sphere, in the fence's units.
        allow_remote: Allow a non-loopback ``host`` (the view has no authentication: anyone who
            reaches the port sees the robot).
        name: Server name shown by Foxglove.

    Attributes:
        record: The MCAP file being written, or ``None``.

    Raises:
        InvalidParameter: a non-loopback host without ``allow_remote``, a bad port, no server
            and no recording, an existing ``record`` file or a server that cannot start (the
            port in use).
        InvalidGeometry: an unusable ``fence``.
    """

    def __init__(
        self,
        *,
        host: str = "127.0.0.1",
        port: int | None = 8765,
        record: str | Path | None = None,
        fence: ConvexPolygon | ConvexPolytope | None = None,
        frame_id: str = "world",
        arrow_time: float = 1.0,
        point_size: float = 0.02,
        allow_remote: bool = False,
        name: str = "velfence",
    ) -> None:
        self._closed = True  # until everything is open: close() and __del__ are safe
        self._server: Any = None
        self._front: SubprotocolFront | None = None
        self._writer: Any = None
        host = check_text("host", host, max_length=255)
        remote = check_flag("allow_remote", allow_remote)
        if not _loopback(host) and not remote:
            raise InvalidParameter(
                f"host: {host!r} is not a loopback address; the view has no authentication, so "
                "it listens on 127.0.0.1 unless allow_remote=True is given"
            )
        if port is not None:
            if isinstance(port, (bool, np.timedelta64)) or not isinstance(port, (int, np.integer)):
                raise InvalidParameter(
                    f"port: expected an int in [0, 65535] or None, got {show(port, 40)}"
                )
            if not 0 <= int(port) <= 65535:
                raise InvalidParameter(f"port: expected an int in [0, 65535], got {int(port)}")
        path = None if record is None else check_output_path("record", record)
        if path is not None and path.exists():
            raise InvalidParameter(f"record: {path} exists; choose a new file name")
        if port is None and path is None:
            raise InvalidParameter("port, record: expected a server port, a record file or both")
        self._frame = check_text("frame_id", frame_id, max_length=255)
        self._arrow_time = check_positive("arrow_time", arrow_time)
        self._point_size = check_positive("point_size", point_size)
        label = check_text("name", name, max_length=255)
        self._fence = _check_fence("fence", fence)
        self._fence_cache: tuple[FloatArray, bool] | None = None

        import foxglove
        from foxglove.channels import SceneUpdateChannel

        self._ctx = foxglove.Context()
        self._scene = SceneUpdateChannel(SCENE_TOPIC, context=self._ctx)
        self._status = foxglove.Channel(STATUS_TOPIC, schema=_STATUS_SCHEMA, context=self._ctx)
        self._velocity = foxglove.Channel(
            VELOCITY_TOPIC, schema=_VELOCITY_SCHEMA, context=self._ctx
        )
        if path is not None:
            try:
                self._writer = foxglove.open_mcap(path, context=self._ctx)
            except Exception as exc:  # an unwritable file
                raise InvalidParameter(f"record: cannot write {path}: {exc}") from None
        if port is not None:
            try:
                # The SDK's server on a free loopback port, behind a front on the view's
                # address that also admits the legacy subprotocol name (_foxglove_front).
                self._server = foxglove.start_server(
                    name=label, host="127.0.0.1", port=0, context=self._ctx
                )
                self._front = SubprotocolFront(host, int(port), int(self._server.port))
            except Exception as exc:  # the port in use, an unknown host name
                self._close_sinks()
                raise InvalidParameter(
                    f"port: cannot start the server on {host}:{int(port)}: {exc}"
                ) from None
        self._t0_ns = time.time_ns()
        self._closed = False
        self.record: Path | None = path
        if self._fence is not None:
            self._log_scene(None, None, None, 0)

    # ------------------------------------------------------------------ properties
    @property
    def port(self) -> int | None:
        """The server's TCP port (the one chosen for ``port=0``), or ``None`` without a server."""
        return None if self._front is None else self._front.port

    @property
    def url(self) -> str | None:
        """The address to open in Foxglove (``ws://127.0.0.1:8765``), or ``None``."""
        return None if self._front is None else f"ws://127.0.0.1:{self.port}"

    @property
    def closed(self) -> bool:
        """Whether :meth:`close` has run."""
        return self._closed

    # ------------------------------------------------------------------ publishing
    def scene(self, fence: ConvexPolygon | ConvexPolytope | None) -> None:
        """Replace the fence drawn in the scene (``None``: draw none).

        Args:
            fence: As the constructor's ``fence``.

        Raises:
            InvalidGeometry: an unusable fence.
            InvalidInput: the view is closed.
        """
        self._require_open()
        self._fence = _check_fence("fence", fence)
        self._fence_cache = None
        self._log_scene(None, None, None, self._log_time(None))

    def publish(self, info: Any) -> None:
        """Publish one control step: the scene, the status and the velocities.

        Args:
            info: A mapping (or an object with these attributes): ``t`` [s] (>= 0, the time
                since the start of the run), ``state`` (the robot point, 2 or 3 numbers, or a
                joint vector), ``command`` and ``shaped`` (the commanded and the shaped
                velocity, one shape), optional ``zone`` (str, default ``""``) and ``active``
                (constraint names, default none). The state is drawn as a point and the
                velocities as arrows when they have the fence's dimension (2 or 3; any of 2 or
                3 without a fence); joint vectors go to the JSON channels only.

        Raises:
            InvalidInput: a missing or malformed field (named as ``info.field``), or the view is
                closed.
        """
        self._require_open()
        t = finite_scalar("info.t", _field(info, "t"), unit="s", what="time")
        if t < 0:
            raise InvalidInput(f"info.t: expected a time >= 0 [s], got {show(t)}")
        state = _vector("info.state", _field(info, "state"))
        command = _vector("info.command", _field(info, "command"))
        shaped = _vector("info.shaped", _field(info, "shaped"))
        if shaped.shape != command.shape:
            raise InvalidInput(
                f"info.shaped: expected the shape of info.command {command.shape}, got "
                f"{shaped.shape}"
            )
        zone = _field(info, "zone", "")
        if not isinstance(zone, str) or len(zone) > 200:
            raise InvalidInput(f"info.zone: expected a zone name (a string), got {show(zone, 40)}")
        active = _names("info.active", _field(info, "active", ()))
        stamp = self._log_time(t)
        changed_by = float(np.linalg.norm(command - shaped))
        self._status.log(
            {
                "t": t,
                "zone": str(zone),
                "active": active,
                "changed_by": changed_by,
                "changed": changed_by > _CHANGED_TOL,
            },
            log_time=stamp,
        )
        self._velocity.log(
            {
                "t": t,
                "command": command.tolist(),
                "shaped": shaped.tolist(),
                "command_norm": float(np.linalg.norm(command)),
                "shaped_norm": float(np.linalg.norm(shaped)),
            },
            log_time=stamp,
        )
        self._log_scene(state, command, shaped, stamp)

    # ------------------------------------------------------------------ closing
    def close(self) -> None:
        """Stop the server and finish the MCAP file (idempotent)."""
        if self._closed:
            return
        self._closed = True
        self._close_sinks()

    def __enter__(self) -> FoxgloveView:
        """The view itself (``with FoxgloveView(...) as view:``)."""
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        """Close the view."""
        self.close()

    def __del__(self) -> None:
        """Close a view that was not closed (never raises)."""
        with contextlib.suppress(Exception):  # interpreter shutdown
            self.close()

    # ------------------------------------------------------------------ internals
    def _close_sinks(self) -> None:
        if self._front is not None:
            self._front.close()
            self._front = None
        if self._server is not None:
            self._server.stop()
            self._server = None
        if self._writer is not None:
            self._writer.close()
            self._writer = None

    def _require_open(self) -> None:
        if self._closed:
            raise InvalidInput("the FoxgloveView is closed; make a new one")

    def _log_time(self, t: float | None) -> int:
        if t is None:
            return time.time_ns()
        return self._t0_ns + round(t * 1e9)

    def _dim(self) -> tuple[int, ...]:
        if self._fence is None:
            return (2, 3)
        return (2,) if isinstance(self._fence, ConvexPolygon) else (self._fence.dim,)

    def _log_scene(
        self,
        state: FloatArray | None,
        command: FloatArray | None,
        shaped: FloatArray | None,
        stamp: int,
    ) -> None:
        from foxglove.messages import (
            ArrowPrimitive,
            Color,
            LinePrimitive,
            LinePrimitiveLineType,
            Point3,
            Pose,
            Quaternion,
            SceneEntity,
            SceneEntityDeletion,
            SceneUpdate,
            SpherePrimitive,
            Timestamp,
            Vector3,
        )

        ts = Timestamp(stamp // 1_000_000_000, stamp % 1_000_000_000)
        identity = Quaternion(x=0.0, y=0.0, z=0.0, w=1.0)

        def color(rgba: tuple[float, float, float, float]) -> Color:
            return Color(r=rgba[0], g=rgba[1], b=rgba[2], a=rgba[3])

        def xyz(p: FloatArray) -> tuple[float, float, float]:
            q = [float(a) for a in p] + [0.0] * (3 - len(p))
            return q[0], q[1], q[2]

        entities = []
        deletions = []
        if self._fence is not None:
            if self._fence_cache is None:
                self._fence_cache = _fence_lines(self._fence)
            pts, loop = self._fence_cache
            line = LinePrimitive(
                type=LinePrimitiveLineType.LineLoop if loop else LinePrimitiveLineType.LineList,
                pose=Pose(position=Vector3(x=0.0, y=0.0, z=0.0), orientation=identity),
                thickness=2.0,
                scale_invariant=True,
                points=[Point3(x=a, y=b, z=c) for a, b, c in pts.tolist()],
                color=color(_FENCE_RGBA),
            )
            entities.append(
                SceneEntity(timestamp=ts, frame_id=self._frame, id="fence", lines=[line])
            )
        else:
            deletions.append(SceneEntityDeletion(timestamp=ts, id="fence"))
        if state is not None and command is not None and shaped is not None:
            dims = self._dim()
            if state.shape[0] in dims:
                x, y, z = xyz(state)
                size = self._point_size
                sphere = SpherePrimitive(
                    pose=Pose(position=Vector3(x=x, y=y, z=z), orientation=identity),
                    size=Vector3(x=size, y=size, z=size),
                    color=color(_ROBOT_RGBA),
                )
                arrows = []
                if command.shape == state.shape:
                    for v, rgba in ((command, _COMMAND_RGBA), (shaped, _SHAPED_RGBA)):
                        v3 = np.array(xyz(v))
                        speed = float(np.linalg.norm(v3))
                        if not speed > 0.0 or not math.isfinite(speed):
                            continue
                        qx, qy, qz, qw = _quaternion_x_to(v3)
                        length = speed * self._arrow_time
                        arrows.append(
                            ArrowPrimitive(
                                pose=Pose(
                                    position=Vector3(x=x, y=y, z=z),
                                    orientation=Quaternion(x=qx, y=qy, z=qz, w=qw),
                                ),
                                shaft_length=0.8 * length,
                                shaft_diameter=0.25 * size,
                                head_length=0.2 * length,
                                head_diameter=0.6 * size,
                                color=color(rgba),
                            )
                        )
                entities.append(
                    SceneEntity(
                        timestamp=ts,
                        frame_id=self._frame,
                        id="robot",
                        spheres=[sphere],
                        arrows=arrows,
                    )
                )
        self._scene.log(SceneUpdate(deletions=deletions, entities=entities), log_time=stamp)


def record_trajectory(
    trajectory: Any,
    path: str | Path,
    *,
    fence: ConvexPolygon | ConvexPolytope | None = None,
    every: int = 1,
) -> Path:
    """Write a finished run to an MCAP file that Foxglove opens (no server).

    Every ``every``-th row of the trajectory becomes one :meth:`FoxgloveView.publish`: ``t``,
    ``state = p``, ``command = v_cmd``, ``shaped = v_out`` and ``zone``.

    Args:
        trajectory: A :class:`velfence.sim.Trajectory` (``t``, ``p``, ``v_cmd``, ``v_out``,
            ``zone``).
        path: The MCAP file to write (must not exist).
        fence: The set to draw (as :class:`FoxgloveView`'s ``fence``).
        every: Publish every ``every``-th row (the last row is always published).

    Returns:
        The MCAP file's path.

    Raises:
        InvalidInput: ``trajectory`` is not a Trajectory.
        InvalidParameter: a bad ``path`` (an existing file, a missing directory) or ``every``.
        InvalidGeometry: an unusable ``fence``.
    """
    from velfence.sim.runner import Trajectory

    if not isinstance(trajectory, Trajectory):
        raise InvalidInput(
            f"trajectory: expected a velfence.sim.Trajectory, got {type(trajectory).__name__}"
        )
    step = check_positive_int("every", every, maximum=10**9, example=10)
    out = check_output_path("path", path)
    n = len(trajectory.t)
    rows = list(range(0, n, step))
    if rows[-1] != n - 1:
        rows.append(n - 1)
    t0 = float(trajectory.t[0])
    with FoxgloveView(port=None, record=out, fence=fence) as view:
        for k in rows:
            view.publish(
                {
                    "t": float(trajectory.t[k]) - t0,
                    "state": trajectory.p[k],
                    "command": trajectory.v_cmd[k],
                    "shaped": trajectory.v_out[k],
                    "zone": str(trajectory.zone[k]),
                }
            )
    return out


def view_hook(view: FoxgloveView) -> Any:
    """An ``on_cycle`` callback that shows a bridge's every published command in ``view``.

    Time is counted from the first shown cycle. A cycle without a state (a fail-safe zero before
    any state arrived) is not shown; a watchdog zero (no command) is shown with a zero command.
    The view never stops the node: a step it cannot draw is skipped, and the first such refusal
    is logged on the ``velfence.bridge`` logger.

    Args:
        view: An open :class:`FoxgloveView` (server and/or MCAP recording).

    Returns:
        ``on_cycle(info)`` for :class:`~velfence.bridge.node.BridgeNode` and
        :func:`~velfence.bridge.node.serve`.

    Raises:
        InvalidParameter: ``view`` is not an open :class:`FoxgloveView`.
    """
    import logging

    from velfence.errors import VelfenceError

    if not isinstance(view, FoxgloveView) or view.closed:
        what = "a closed view" if isinstance(view, FoxgloveView) else type(view).__name__
        raise InvalidParameter(f"view: expected an open FoxgloveView, got {what}")
    start: list[float] = []
    warned: list[bool] = []

    def on_cycle(info: Any) -> None:
        state = getattr(info, "state", None)
        shaped = getattr(info, "shaped", None)
        if state is None or shaped is None:
            return
        t = float(getattr(info, "t", 0.0))
        if not start:
            start.append(t)
        command = getattr(info, "command", None)
        step = {
            "t": max(0.0, t - start[0]),
            "state": state,
            "command": np.zeros_like(shaped) if command is None else command,
            "shaped": shaped,
            "zone": getattr(info, "zone", ""),
            "active": getattr(info, "active", ()),
        }
        try:
            view.publish(step)
        except VelfenceError as exc:
            if not warned:
                warned.append(True)
                logging.getLogger("velfence.bridge").warning(
                    "foxglove view: a step was not shown (%s); further ones are skipped silently",
                    exc,
                )

    return on_cycle


document_inits(globals())
