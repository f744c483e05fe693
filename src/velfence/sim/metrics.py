r"""Metrics of closed-loop runs against a convex polygon: one definition each, used everywhere.

Notation (``docs/simulation.md`` §2): rows ``k = 0 … N-1`` of a :class:`Trajectory`;
:math:`d_i(p)` the signed distance to edge ``i`` (positive inside);
:math:`\delta_k = \min_i d_i(p_k)` and :math:`e_k = \arg\min_i d_i(p_k)` (first index on ties),
the *nearest edge* (inside: the nearest boundary edge; outside: the most violated one);
:math:`\Delta t_k = t_{k+1} - t_k`. A row is *near the boundary* when :math:`|\delta_k| \le`
``band``. Normal/tangential parts use :func:`velfence.geometry.decompose` with the inward normal
of :math:`e_k`.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from velfence._typing import FloatArray
from velfence._validate import check_positive, check_positive_int, real_array
from velfence.errors import InvalidInput, InvalidParameter
from velfence.geometry.polygon import ConvexPolygon, as_polygon, decompose
from velfence.shaping.base import Shaper
from velfence.sim.runner import Trajectory

if TYPE_CHECKING:
    from velfence.geometry.polytope import ConvexPolytope

__all__ = [
    "DEADBAND",
    "area_gain",
    "box_penetration",
    "chatter_rate",
    "corner_escape_time",
    "face_sliding_ratio",
    "joint_limit_violation",
    "max_joint_acceleration",
    "max_output_jump",
    "max_penetration",
    "sliding_ratio",
    "sphere_penetration",
    "summarize",
    "time_outside",
    "time_to_reach",
]


DEADBAND = 1e-9
"""Default deadband on normal and tangential speeds, workspace units per second."""

MAX_GRID_POINTS = 4_000_000


def _check(traj: Any, polygon: Any) -> None:
    if not isinstance(traj, Trajectory):
        raise InvalidParameter(f"traj must be a velfence.sim.Trajectory, got {type(traj).__name__}")
    as_polygon(polygon)


def _nearest(traj: Trajectory, polygon: ConvexPolygon) -> tuple[FloatArray, NDArray[np.intp]]:
    """Smallest signed distance and its edge index (the nearest edge) for every row."""
    d = np.atleast_2d(polygon.signed_distances(traj.p))
    return d.min(axis=1), d.argmin(axis=1)


def max_penetration(traj: Trajectory, polygon: ConvexPolygon) -> float:
    r"""Largest violation over the run: :math:`\max_k \max(0, -\delta_k)`, workspace units.

    Args:
        traj: The run.
        polygon: The permissible workspace.

    Returns:
        0.0 when the run never leaves the closed polygon.
    """
    _check(traj, polygon)
    delta, _ = _nearest(traj, polygon)
    return float(max(0.0, float(-delta.min())))


def time_outside(traj: Trajectory, polygon: ConvexPolygon, *, tol: float = 0.0) -> float:
    r"""Time spent outside, [s]: :math:`\sum_{k<N-1,\ \delta_k<-tol} \Delta t_k` (left rule).

    A spring or recovery bound proportional to the penetration returns *exponentially*, so it
    never makes :math:`\delta_k` exactly 0; pass a small ``tol`` to count only real excursions.

    Args:
        traj: The run.
        polygon: The permissible workspace.
        tol: Penetration below which a row counts as inside, workspace units (>= 0).

    Returns:
        The time outside [s], >= 0.
    """
    _check(traj, polygon)
    tol = check_positive("tol", tol, allow_zero=True, unit="workspace units")
    delta, _ = _nearest(traj, polygon)
    dt = np.diff(traj.t)
    return float(dt[delta[:-1] < -tol].sum())


def _sign(x: float, deadband: float) -> int:
    return 1 if x > deadband else (-1 if x < -deadband else 0)


def chatter_rate(
    traj: Trajectory, polygon: ConvexPolygon, *, band: float, deadband: float = DEADBAND
) -> float:
    r"""Sign changes of the output's normal velocity per second spent near the boundary, [1/s].

    For every row near the boundary, :math:`s_k = \mathrm{sign}_\epsilon(n_{e_k}\cdot v^{out}_k)`
    (+1 above ``deadband``, -1 below ``-deadband``, 0 otherwise). Within each maximal run of
    consecutive near rows *with the same nearest edge*, zeros are skipped and the changes between
    successive non-zero signs are counted (``+, 0, -`` is one change) — unless the command's own
    normal sign changed between the two rows: a reversal the operator asked for is not chatter,
    and neither is the change of reference normal when the nearest edge switches at a corner.
    The rate is that count divided by
    :math:`T_{near} = \sum \Delta t_k` over consecutive row pairs both near; 0.0 when
    :math:`T_{near} = 0`.

    Args:
        traj: The run.
        polygon: The permissible workspace.
        band: Half-width of the band around the boundary, workspace units (> 0).
        deadband: Normal speeds with magnitude <= this count as zero, workspace units per second
            (>= 0).

    Returns:
        The chatter rate [1/s], >= 0 (0.0 when no time was spent near the boundary).
    """
    _check(traj, polygon)
    band = check_positive("band", band, unit="workspace units")
    deadband = check_positive("deadband", deadband, allow_zero=True, unit="workspace units / s")
    delta, edge = _nearest(traj, polygon)
    near = np.abs(delta) <= band
    count = 0
    t_near = 0.0
    last = 0
    last_cmd = 0
    for k in range(len(traj)):
        if not near[k] or (k > 0 and edge[k] != edge[k - 1]):
            last = 0
        if not near[k]:
            continue
        if k > 0 and near[k - 1]:
            t_near += float(traj.t[k] - traj.t[k - 1])
        vn, _ = decompose(traj.v_out[k], polygon.normals[edge[k]])
        cn, _ = decompose(traj.v_cmd[k], polygon.normals[edge[k]])
        s = _sign(vn, deadband)
        c = _sign(cn, deadband)
        if s != 0:
            if last != 0 and s != last and c == last_cmd:
                count += 1
            last = s
            last_cmd = c
    return count / t_near if t_near > 0.0 else 0.0


def sliding_ratio(
    traj: Trajectory, polygon: ConvexPolygon, *, band: float, deadband: float = DEADBAND
) -> float:
    r"""Tangential progress achieved over tangential progress commanded while pressing an edge.

    Row ``k < N-1`` *presses* when it is near the boundary and the command points out through
    the nearest edge: :math:`v^{cmd}_{n} = n_{e_k}\cdot v^{cmd}_k < -`\ ``deadband``. With the
    command's tangential part :math:`v^{cmd}_{t}` (norm > ``deadband``) and
    :math:`u_k = v^{cmd}_t / \|v^{cmd}_t\|`:

    .. math:: \rho = \frac{\sum_{k\ \mathrm{presses}} u_k\cdot(p_{k+1} - p_k)}
                          {\sum_{k\ \mathrm{presses}} \|v^{cmd}_t\|\,\Delta t_k}

    1 means the shaper kept all the commanded sliding; 0 means it stuck. It can exceed 1 or be
    negative under disturbances (the achieved motion is the true one).

    Args:
        traj: The run.
        polygon: The permissible workspace.
        band: Half-width of the band around the boundary, workspace units (> 0).
        deadband: Speeds with magnitude <= this count as zero, workspace units per second (>= 0).

    Returns:
        The ratio, or ``nan`` when no row presses with a tangential component.
    """
    _check(traj, polygon)
    band = check_positive("band", band, unit="workspace units")
    deadband = check_positive("deadband", deadband, allow_zero=True, unit="workspace units / s")
    delta, edge = _nearest(traj, polygon)
    near = np.abs(delta) <= band
    achieved = 0.0
    commanded = 0.0
    for k in np.flatnonzero(near[:-1]):
        vn, vt = decompose(traj.v_cmd[k], polygon.normals[edge[k]])
        speed_t = math.hypot(float(vt[0]), float(vt[1]))
        if vn >= -deadband or speed_t <= deadband:
            continue
        commanded += speed_t * float(traj.t[k + 1] - traj.t[k])
        achieved += float(vt @ (traj.p[k + 1] - traj.p[k])) / speed_t
    return achieved / commanded if commanded > 0.0 else math.nan


def corner_escape_time(
    traj: Trajectory, polygon: ConvexPolygon, corner_index: int, *, radius: float
) -> float:
    r"""Time from first entering a disc around a corner to first leaving it afterwards, [s].

    With :math:`r_k = \|p_k - c\|` for corner ``c``: :math:`k_{in}` is the first row with
    :math:`r_k <` ``radius``, :math:`k_{out}` the first later row with :math:`r_k \ge`
    ``radius``; the result is :math:`t_{k_{out}} - t_{k_{in}}`. Only the first visit counts.

    Args:
        traj: The run.
        polygon: The permissible workspace.
        corner_index: Index into ``polygon.corners`` (CCW order), in ``[0, n)``.
        radius: Disc radius, workspace units (> 0).

    Returns:
        The time, ``inf`` when the run never leaves the disc, ``nan`` when it never enters it.
    """
    _check(traj, polygon)
    check_positive_int("corner_index", corner_index, minimum=0, maximum=polygon.n - 1)
    radius = check_positive("radius", radius, unit="workspace units")
    r = np.hypot(*(traj.p - polygon.corners[int(corner_index)]).T)
    inside = r < radius
    if not inside.any():
        return math.nan
    k_in = int(np.argmax(inside))
    after = np.flatnonzero(~inside[k_in:])
    if after.size == 0:
        return math.inf
    return float(traj.t[k_in + int(after[0])] - traj.t[k_in])


def max_output_jump(
    shaper: Shaper,
    polygon: ConvexPolygon,
    *,
    spacing: float,
    commands: ArrayLike,
    margin: float | None = None,
) -> float:
    r"""Largest change of the output between neighbouring grid positions (the continuity metric).

    The grid has step ``spacing`` in x and y and covers the polygon's bounding box grown by
    ``margin`` on every side. For every command ``c`` (held fixed), the outputs
    :math:`V(p) = \mathrm{shaper}(p, c)` are evaluated with ``shaper.shape_batch`` and the result
    is :math:`\max \|V(p) - V(p')\|` over all horizontally or vertically adjacent grid points and
    all commands. A continuous law's value shrinks with ``spacing``; a discontinuous one's does
    not (compare two spacings).

    Args:
        shaper: The law to probe.
        polygon: Its workspace (sets the grid extent).
        spacing: Grid step, workspace units (> 0).
        commands: Commands to probe, shape (M, 2), workspace units per second, M >= 1.
        margin: Extra extent outside the bounding box, workspace units (>= 0); default 10 % of
            the larger side of the bounding box.

    Returns:
        The largest jump, workspace units per second.

    Raises:
        InvalidParameter: for a bad parameter or a grid of more than 4,000,000 points.
    """
    if not isinstance(shaper, Shaper):
        raise InvalidParameter(
            f"shaper must implement shape, explain and shape_batch, got {type(shaper).__name__}"
        )
    as_polygon(polygon)
    spacing = check_positive("spacing", spacing, unit="workspace units")
    C = real_array(
        "commands", commands, (None, 2), error=InvalidParameter, what="commands of shape (M, 2)"
    )
    if C.shape[0] == 0:
        raise InvalidParameter(
            f"commands must be a non-empty finite (M, 2) array, got shape {C.shape}"
        )
    lo = polygon.corners.min(axis=0)
    hi = polygon.corners.max(axis=0)
    if margin is None:
        m = 0.1 * float((hi - lo).max())
    else:
        m = check_positive("margin", margin, allow_zero=True, unit="workspace units")
    # Ratios as floats first: spacing = 5e-324 gives inf, which must not reach math.ceil.
    ratios = [float(hi[a] - lo[a] + 2.0 * m) / spacing for a in (0, 1)]
    if not (ratios[0] + 1.0) * (ratios[1] + 1.0) <= MAX_GRID_POINTS:
        raise InvalidParameter(
            f"spacing {spacing:g} with margin {m:g} gives a {ratios[0] + 1.0:.3g} x "
            f"{ratios[1] + 1.0:.3g} grid, more than {MAX_GRID_POINTS} points; increase spacing "
            "or reduce margin"
        )
    counts = [math.ceil(r) + 1 for r in ratios]
    if counts[0] * counts[1] > MAX_GRID_POINTS:
        raise InvalidParameter(
            f"spacing {spacing} with margin {m:g} gives a {counts[0]} x {counts[1]} grid, more "
            f"than {MAX_GRID_POINTS} points; increase spacing or reduce margin"
        )
    xs = lo[0] - m + spacing * np.arange(counts[0])
    ys = lo[1] - m + spacing * np.arange(counts[1])
    X, Y = np.meshgrid(xs, ys)
    P = np.stack([X.ravel(), Y.ravel()], axis=1)
    worst = 0.0
    for c in C:
        V = shaper.shape_batch(P, np.broadcast_to(c, P.shape)).reshape(counts[1], counts[0], 2)
        jx = np.hypot(*np.moveaxis(V[:, 1:] - V[:, :-1], -1, 0))
        jy = np.hypot(*np.moveaxis(V[1:] - V[:-1], -1, 0))
        for j in (jx, jy):
            if j.size:
                worst = max(worst, float(j.max()))
    return worst


def area_gain(polygon: ConvexPolygon) -> float:
    """Polygon area over its largest inscribed axis-aligned rectangle's (``area_ratio()``).

    The workspace a polygon limit gains over conventional per-axis joint limits (>= 1).

    Args:
        polygon: The permissible workspace.

    Returns:
        The area ratio, >= 1.
    """
    as_polygon(polygon)
    return float(polygon.area_ratio())


def _given(x: object) -> str:
    return "not given" if x is None else "given"


def summarize(
    traj: Trajectory,
    polygon: ConvexPolygon,
    *,
    band: float,
    corner_index: int | None = None,
    radius: float | None = None,
    shaper: Shaper | None = None,
    spacing: float | None = None,
    commands: ArrayLike | None = None,
    tol: float = 0.0,
) -> dict[str, float]:
    """Every metric of one run, as plain floats (JSON-serialisable; ``inf``/``nan`` possible).

    Keys: ``duration`` [s], ``max_penetration``, ``time_outside`` [s], ``chatter_rate`` [1/s],
    ``sliding_ratio``, ``area_gain``; plus ``corner_escape_time`` [s] when ``corner_index`` and
    ``radius`` are given, and ``max_output_jump`` when ``shaper`` and ``spacing`` are given
    (``commands`` defaulting to the run's distinct commands).

    Args:
        traj: The run.
        polygon: The permissible workspace.
        band: Band for :func:`chatter_rate` and :func:`sliding_ratio`, workspace units.
        corner_index: Corner for :func:`corner_escape_time`.
        radius: Radius for :func:`corner_escape_time`, workspace units.
        shaper: Shaper for :func:`max_output_jump`.
        spacing: Grid step for :func:`max_output_jump`, workspace units.
        commands: Commands for :func:`max_output_jump`, shape (M, 2).
        tol: Tolerance of :func:`time_outside`, workspace units.

    Returns:
        Metric name -> value (the keys above).
    """
    _check(traj, polygon)
    out = {
        "duration": traj.duration,
        "max_penetration": max_penetration(traj, polygon),
        "time_outside": time_outside(traj, polygon, tol=tol),
        "chatter_rate": chatter_rate(traj, polygon, band=band),
        "sliding_ratio": sliding_ratio(traj, polygon, band=band),
        "area_gain": area_gain(polygon),
    }
    # Messages say "given"/"not given", never repr(): a value's __repr__ is user code.
    if (corner_index is None) != (radius is None):
        raise InvalidParameter(
            "corner_index and radius go together: pass both for corner_escape_time or neither, "
            f"got corner_index {_given(corner_index)} and radius {_given(radius)}"
        )
    if corner_index is not None and radius is not None:
        out["corner_escape_time"] = corner_escape_time(traj, polygon, corner_index, radius=radius)
    if (shaper is None) != (spacing is None):
        raise InvalidParameter(
            "shaper and spacing go together: pass both for max_output_jump or neither, "
            f"got shaper {_given(shaper)} and spacing {_given(spacing)}"
        )
    if commands is not None and shaper is None:
        raise InvalidParameter(
            "commands is only used by max_output_jump: pass shaper and spacing with it, "
            "or leave commands out"
        )
    if shaper is not None and spacing is not None:
        cmds = np.unique(traj.v_cmd, axis=0) if commands is None else commands
        out["max_output_jump"] = max_output_jump(shaper, polygon, spacing=spacing, commands=cmds)
    return {k: float(v) for k, v in out.items()}


# ----------------------------------------------------------------------------- arm (n-D) metrics
# The arm scenario's runs live in joint space (Trajectory.p = q); these metrics take the task-space
# arrays (TCP positions, link segments) that go with the rows, plus the trajectory where joint data
# is enough. Definitions in docs/arm_box.md.


def _points(name: str, x: Any, width: int | None = None) -> FloatArray:
    return real_array(name, x, (None, width), what="positions, one row per sample")


def box_penetration(points: ArrayLike, polytope: ConvexPolytope) -> float:
    r"""Largest violation of a polytope over a path: :math:`\max_k \max(0, -\min_i d_i(x_k))`.

    The n-D form of :func:`max_penetration` (e.g. the TCP path and its box).

    Args:
        points: Positions, shape (N, n), length units (e.g. [m]).
        polytope: A :class:`~velfence.geometry.polytope.ConvexPolytope` of dimension n.

    Returns:
        The penetration depth in the units of ``points``; 0.0 when the path stays in the closed
        polytope (and for an empty path).
    """
    if not hasattr(polytope, "signed_distances_batch"):
        raise InvalidParameter(
            f"polytope must be a velfence ConvexPolytope, got {type(polytope).__name__}"
        )
    X = _points("points", points, int(polytope.dim))
    if X.shape[0] == 0:
        return 0.0
    d = np.asarray(polytope.signed_distances_batch(X), dtype=float)
    return float(max(0.0, float(-d.min())))


def sphere_penetration(
    segments: ArrayLike, link_radius: ArrayLike, center: ArrayLike, radius: float
) -> float:
    r"""Largest overlap of capsule links with a sphere: :math:`\max_{k,l} \max(0, -s_{kl})`.

    :math:`s_{kl} = |c - x_{kl}| - r - r_l` with :math:`x_{kl}` the point of link ``l``'s axis
    nearest to the centre ``c`` at row ``k`` (the clearance of
    :func:`velfence.geometry.primitives.sphere_capsule_distance`).

    Args:
        segments: Link axes per row, shape (N, L, 2, 3), [m] (start, end).
        link_radius: Capsule radius per link, shape (L,) or scalar, [m].
        center: Sphere centre, shape (3,), [m].
        radius: Sphere radius [m], >= 0.

    Returns:
        The overlap depth [m]; 0.0 when no link ever touches the sphere's interior.
    """
    from velfence.geometry.primitives import points_segments_distances

    S = real_array("segments", segments, (None, None, 2, 3), what="link segments [m]")
    c = real_array("center", center, (3,), what="a sphere centre [m]")
    r = check_positive("radius", radius, allow_zero=True, unit="m")
    n_rows, n_links = S.shape[:2]
    R = real_array("link_radius", link_radius, what="capsule radii [m]")
    if R.shape not in ((), (n_links,)):
        raise InvalidInput(
            f"link_radius: expected a scalar or shape ({n_links},) (one per link), got shape "
            f"{R.shape}"
        )
    if n_rows * n_links == 0:
        return 0.0
    # Every row's links as one list of segments (the same per-pair arithmetic as row by row),
    # in blocks of rows that keep the temporaries small.
    worst = 0.0
    block = max(1, 65536 // n_links)
    for k in range(0, n_rows, block):
        seg = S[k : k + block]
        m = seg.shape[0]
        _, clear = points_segments_distances(
            c[None, :],
            seg[:, :, 0].reshape(m * n_links, 3),
            seg[:, :, 1].reshape(m * n_links, 3),
            radii=R if R.ndim == 0 else np.tile(R, m),
        )
        worst = max(worst, float(np.max(-(clear.reshape(m, n_links).min(axis=1) - r))))
    return worst


def joint_limit_violation(q: ArrayLike, lower: ArrayLike, upper: ArrayLike) -> float:
    r"""Largest excursion beyond a joint limit, [rad].

    :math:`\max_{k,i} \max(0,\ q_{ki} - u_i,\ l_i - q_{ki})`.

    Args:
        q: Joint positions, shape (N, n), [rad].
        lower: Lower limits, shape (n,), [rad].
        upper: Upper limits, shape (n,), [rad].

    Returns:
        The violation [rad]; 0.0 when every row is within the limits.
    """
    Q = _points("q", q)
    n = Q.shape[1]
    lo = real_array("lower", lower, (n,), what="joint limits [rad]")
    hi = real_array("upper", upper, (n,), what="joint limits [rad]")
    if Q.shape[0] == 0:
        return 0.0
    return float(max(0.0, float((Q - hi).max()), float((lo - Q).max())))


def face_sliding_ratio(
    t: ArrayLike,
    points: ArrayLike,
    commands: ArrayLike,
    polytope: ConvexPolytope,
    *,
    band: float,
    deadband: float = DEADBAND,
) -> float:
    r"""The n-D form of :func:`sliding_ratio`: tangential progress kept while pressing a facet.

    Row ``k < N-1`` *presses* when :math:`|\delta_k| \le` ``band`` for the nearest facet
    :math:`f_k = \arg\min_i d_i(x_k)` (:math:`\delta_k` its distance) and the command points out
    through it, :math:`n_{f_k}\cdot v_k < -`\ ``deadband``. With the tangential part
    :math:`v_{t,k} = v_k - (n_{f_k}\cdot v_k)\,n_{f_k}` (norm > ``deadband``) and
    :math:`u_k = v_{t,k}/\|v_{t,k}\|`:

    .. math:: \rho = \frac{\sum_{k\ \mathrm{presses}} u_k\cdot(x_{k+1} - x_k)}
                          {\sum_{k\ \mathrm{presses}} \|v_{t,k}\|\,(t_{k+1} - t_k)}

    Args:
        t: Times, shape (N,), [s].
        points: Positions, shape (N, n), length units (the TCP [m]).
        commands: Commanded velocities of the points, shape (N, n), length units per second.
        polytope: The permitted set, dimension n.
        band: Half-width of the band around the boundary, length units (> 0).
        deadband: Speeds at or below this count as zero, length units per second (>= 0).

    Returns:
        The ratio, ``nan`` when no row presses with a tangential component.
    """
    band = check_positive("band", band, unit="length units")
    deadband = check_positive("deadband", deadband, allow_zero=True, unit="length units / s")
    n = int(polytope.dim)
    X = _points("points", points, n)
    N = X.shape[0]
    ta = real_array("t", t, (N,), what="times [s]")
    V = real_array("commands", commands, (N, n), what="commanded velocities")
    if N < 2:
        return math.nan
    d = np.asarray(polytope.signed_distances_batch(X), dtype=float)
    facet = d.argmin(axis=1)
    delta = d[np.arange(N), facet]
    normals = np.asarray(polytope.normals, dtype=float)[facet]
    vn = np.einsum("ij,ij->i", V, normals)
    vt = V - vn[:, None] * normals
    speed_t = np.linalg.norm(vt, axis=1)
    press = (np.abs(delta) <= band) & (vn < -deadband) & (speed_t > deadband)
    press[-1] = False
    k = np.flatnonzero(press)
    if k.size == 0:
        return math.nan
    commanded = float(np.sum(speed_t[k] * (ta[k + 1] - ta[k])))
    achieved = float(np.sum(np.einsum("ij,ij->i", vt[k], X[k + 1] - X[k]) / speed_t[k]))
    return achieved / commanded


def time_to_reach(
    t: ArrayLike, points: ArrayLike, target: ArrayLike, *, tol: float, after: float = -math.inf
) -> float:
    r"""First time the path comes within ``tol`` of ``target``, [s].

    :math:`\min\{t_k : t_k \ge t_a,\ \|x_k - x^\star\| \le \epsilon\}` with :math:`t_a` =
    ``after`` and :math:`\epsilon` = ``tol``.

    Args:
        t: Times, shape (N,), [s].
        points: Positions, shape (N, n), length units.
        target: The target, shape (n,).
        tol: Reach radius, length units, > 0.
        after: Rows before this time [s] are ignored (e.g. the start of the final phase).

    Returns:
        The time [s], ``inf`` when never reached.
    """
    X = _points("points", points)
    ta = real_array("t", t, (X.shape[0],), what="times [s]")
    x = real_array("target", target, (X.shape[1],), what="a target position")
    tol = check_positive("tol", tol, unit="length units")
    ok = (np.linalg.norm(X - x, axis=1) <= tol) & (ta >= after)
    return float(ta[int(np.argmax(ok))]) if ok.any() else math.inf


def max_joint_acceleration(traj: Trajectory) -> float:
    r"""Largest finite-difference acceleration of the output, [units of ``v_out`` / s].

    :math:`\max_{k,i} |v^{out}_{k+1,i} - v^{out}_{k,i}| / (t_{k+1} - t_k)`.

    The start from rest is not counted (row 0 is the first output).

    Args:
        traj: The run (joint velocities in ``v_out`` [rad/s]).

    Returns:
        The acceleration [rad/s²] (units of ``v_out`` per second); 0.0 for a single row.
    """
    if not isinstance(traj, Trajectory):
        raise InvalidParameter(f"traj must be a velfence.sim.Trajectory, got {type(traj).__name__}")
    if len(traj) < 2:
        return 0.0
    acc = np.abs(np.diff(traj.v_out, axis=0)) / np.diff(traj.t)[:, None]
    return float(acc.max())
