r"""Region and workspace analysis of the CoSPM (Lê et al. 2024 §2): :math:`Q^*` and :math:`W^*`.

Built on the model of :mod:`velfence.mechanisms.cospm`: :func:`stops_polygon` (the quadrilateral
:math:`Q^*` in :math:`(q_1, q_2)` from the paper's stops), :func:`validate_region` (our offline
grid check that :math:`Q^*` is singularity-free and reaches the regular workspace :math:`W^*`),
:func:`singular_curves` and :func:`workspace_map` (arrays for plots in the joint and workspace
planes). Every grid is refused above :data:`MAX_GRID_NODES` nodes before anything is allocated.
Derivations: ``docs/cospm.md``.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from velfence._docs import document_inits
from velfence._typing import BoolArray, FloatArray
from velfence._validate import (
    check_positive,
    finite_scalar,
    readonly,
    real_array,
    show,
)
from velfence.errors import InvalidGeometry, InvalidInput, InvalidParameter
from velfence.geometry.polygon import ConvexPolygon, polygon_from_halfplanes
from velfence.mechanisms.cospm import (
    _HALF_PI,
    _JUMP,
    PAPER_STOPS,
    PAPER_WORKSPACE,
    Q_AUX,
    CoSPM,
)

__all__ = [
    "MAX_BANKS",
    "MAX_GRID_NODES",
    "MAX_THETA3",
    "RegionReport",
    "SingularGrid",
    "WorkspaceMap",
    "singular_curves",
    "stops_polygon",
    "validate_region",
    "workspace_map",
]

#: Most grid nodes validate_region, singular_curves and workspace_map may be asked to evaluate.
MAX_GRID_NODES = 1_000_000
#: Most bank angles validate_region reports an elevation interval for (each is a bisection).
MAX_BANKS = 100
#: Largest accepted |theta3| [rad] of the region tools (far beyond any multi-turn joint).
MAX_THETA3 = 1e3


def _stops(stops: ArrayLike) -> FloatArray:
    S = real_array(
        "stops",
        stops,
        error=InvalidGeometry,
        what="rows (a_i, b_i, c_i) of shape (m, 3)",
        allow_nonfinite=True,
    )
    if S.ndim != 2 or S.shape[1] != 3 or S.shape[0] < 3:
        raise InvalidGeometry(
            f"stops: expected shape (m, 3) with m >= 3 rows (a_i, b_i, c_i), got shape {S.shape}"
        )
    if not np.all(np.isfinite(S)):
        raise InvalidGeometry(f"stops: expected finite coefficients, got {S.tolist()}")
    return S


def stops_polygon(stops: ArrayLike = PAPER_STOPS) -> ConvexPolygon:
    r"""The regular joint space :math:`Q^*` in :math:`(q_1, q_2)` from its stops (Lê et al. §2).

    :math:`Q^* = \{q : a_i q_1 + b_i q_2 + c_i \ge 0\ \forall i\}`, built by
    :func:`velfence.geometry.polygon.polygon_from_halfplanes` (half-planes ordered by normal
    angle, consecutive lines intersected; bounded and every stop used, else an error). For
    :data:`PAPER_STOPS` the corners (CCW) are d4∩d1, d1∩d2, d2∩d3, d3∩d4 and edge ``k`` lies on
    stop ``k``; the polygon's signed distances are the paper's :math:`\delta_i`.

    Args:
        stops: Rows ``(a_i, b_i, c_i)``, shape (m, 3), m >= 3 (``a``, ``b`` dimensionless,
            ``c`` [rad]).

    Returns:
        The polygon in the :math:`(q_1, q_2)` plane [rad].

    Raises:
        InvalidGeometry: wrong shape, non-finite coefficients, an unbounded region or a
            redundant stop.
    """
    S = _stops(stops)
    try:
        polygon, _ = polygon_from_halfplanes(S[:, :2], S[:, 2])
    except InvalidGeometry as exc:
        raise InvalidGeometry(f"stops: {exc}") from None
    return polygon


def _q3_for(q12: FloatArray, theta3: float | None, q3_home: float) -> FloatArray:
    """q3 such that theta3 = Q^T q has the given value (or q3 = its home value when None)."""
    if theta3 is None:
        return np.full(q12.shape[0], q3_home)
    out: FloatArray = (theta3 - Q_AUX[0, 2] * q12[:, 0] - Q_AUX[1, 2] * q12[:, 1]) / Q_AUX[2, 2]
    return out


def _flood(
    cospm: CoSPM,
    theta: FloatArray,
    mask: NDArray[np.bool_],
    start: tuple[int, int],
    *,
    keep_sign: bool,
) -> tuple[FloatArray, BoolArray]:
    """Continuation FKP over a 2-D grid of joint poses (n2, n1, 3), wave by wave from ``start``.

    Each point's Newton starts from an already solved 8-neighbour's chi plus the predictor
    J Δθ. Expansion stops at points that fail (no convergence or a branch jump) and, with
    ``keep_sign``, at points where det[v×w] has left the home sign (the leaf's fold).
    """
    n2, n1 = mask.shape
    chi = np.full((n2, n1, 3), np.nan)
    solved = np.zeros((n2, n1), dtype=bool)
    visited = np.zeros((n2, n1), dtype=bool)
    th_home, _ = cospm.home()
    sign0 = float(np.sign(cospm.type2(th_home, np.zeros(3))))
    c0, ok0, _ = cospm._continue(th_home[None], np.zeros((1, 3)), theta[start][None])
    visited[start] = True
    if not ok0[0]:
        return chi, solved
    chi[start] = c0[0]
    solved[start] = True
    frontier = deque([start])
    offsets = [(a, b) for a in (-1, 0, 1) for b in (-1, 0, 1) if (a, b) != (0, 0)]
    while frontier:
        wave: list[tuple[int, int]] = []
        parent: list[tuple[int, int]] = []
        for _ in range(len(frontier)):
            i, j = frontier.popleft()
            for di, dj in offsets:
                a, b = i + di, j + dj
                if 0 <= a < n2 and 0 <= b < n1 and mask[a, b] and not visited[a, b]:
                    visited[a, b] = True
                    wave.append((a, b))
                    parent.append((i, j))
        if not wave:
            break
        ia = np.array(wave)
        pa = np.array(parent)
        th_new = theta[ia[:, 0], ia[:, 1]]
        th_par = theta[pa[:, 0], pa[:, 1]]
        ch_par = chi[pa[:, 0], pa[:, 1]]
        pred = ch_par + cospm._predict(th_par, ch_par, th_new - th_par)
        ch_new, conv, _ = cospm._newton(th_new, pred)
        good = conv & (np.max(np.abs(ch_new - pred), axis=1) <= _JUMP)
        if keep_sign:
            _, v, w = cospm._vectors(th_new, ch_new)
            good &= np.sign(np.linalg.det(np.cross(v, w))) == sign0
        for k in np.flatnonzero(good):
            a, b = int(ia[k, 0]), int(ia[k, 1])
            chi[a, b] = ch_new[k]
            solved[a, b] = True
            frontier.append((a, b))
    return chi, solved


def _grid_nodes(step_name: str, step: float, *spans: float) -> None:
    """Refuse a grid of more than MAX_GRID_NODES nodes before anything is allocated."""
    nodes = 1.0
    for span in spans:
        nodes *= span / step + 2.0  # float: 5e-324 gives inf, never an OverflowError
    if not nodes <= MAX_GRID_NODES:
        raise InvalidParameter(
            f"{step_name}: expected a grid of at most {MAX_GRID_NODES:,} nodes, got "
            f"{step_name} = {step:g} rad giving about {nodes:.3g}; increase {step_name}"
        )


def _theta3(theta3: Any) -> float | None:
    if theta3 is None:
        return None
    return finite_scalar(
        "theta3", theta3, unit="rad", what="angle", error=InvalidParameter, max_abs=MAX_THETA3
    )


def _grid(lo: float, hi: float, step: float) -> FloatArray:
    """Multiples of ``step`` in [lo, hi] (so that 0, home, is a node when inside)."""
    k0 = math.ceil(lo / step - 1e-9)
    k1 = math.floor(hi / step + 1e-9)
    out: FloatArray = np.arange(k0, k1 + 1, dtype=float) * step
    return out


def _sign(x: FloatArray) -> int:
    if x.size and np.all(x > 0.0):
        return 1
    if x.size and np.all(x < 0.0):
        return -1
    return 0


@dataclass(frozen=True, eq=False, kw_only=True)
class RegionReport:
    r"""Outcome of :func:`validate_region`: is :math:`Q^*` regular and dextrous?

    Attributes:
        step: Grid step in :math:`(q_1, q_2)` [rad].
        theta3: The fixed :math:`\theta_3` [rad] that sets :math:`q_3`, or ``None`` when
            :math:`q_3` was held at its home value.
        q: Grid points of :math:`Q^*`, shape (N, 2) [rad].
        theta: Their joint angles :math:`Q_{AUX}^T (q_1, q_2, q_3)`, shape (N, 3) [rad].
        chi: FKP by continuation from home, shape (N, 3) [rad]; NaN rows where it failed.
        solved: Whether the FKP converged on the home branch, shape (N,).
        det_a: :math:`\det(\partial f/\partial\chi)`, shape (N,).
        det_b: :math:`\det(\partial f/\partial\theta)`, shape (N,).
        type2: :math:`\det[v_i\times w_i]`, shape (N,).
        leg_b: Diagonal of ``B``, shape (N, 3) (its signs are the legs' working modes).
        sign_det_a: +1 or -1 when ``det_a`` keeps that sign over every point, else 0.
        sign_det_b: Same for ``det_b``.
        leg_modes_constant: Whether every leg's ``B_ii`` keeps the home sign everywhere.
        min_abs_det_a: :math:`\min|\det A|` over the grid.
        min_abs_det_b: :math:`\min|\det B|`.
        min_abs_type2: :math:`\min|\det[v\times w]|`.
        bank_range: ``(min, max)`` bank reached on the grid [rad].
        elevation_range: ``(min, max)`` elevation reached on the grid [rad].
        workspace: The rectangle checked, ``(bank_min, bank_max, elev_min, elev_max)`` [rad].
        workspace_margin: Smallest signed distance (positive inside) of
            :math:`\mathrm{IKP}(W^*)` to any stop, over the rectangle's sample grid [rad of q].
        workspace_included: ``workspace_margin > 0``: :math:`W^* \subset FKP(Q^*)` strictly.
        elevation_at_bank: For each requested bank ``b``, ``(b, elev_lo, elev_hi)`` [rad]:
            the elevation interval through 0 whose IKP stays in :math:`Q^*` (NaN when the
            bank itself is out).
    """

    step: float
    theta3: float | None
    q: FloatArray
    theta: FloatArray
    chi: FloatArray
    solved: BoolArray
    det_a: FloatArray
    det_b: FloatArray
    type2: FloatArray
    leg_b: FloatArray
    sign_det_a: int
    sign_det_b: int
    leg_modes_constant: bool
    min_abs_det_a: float
    min_abs_det_b: float
    min_abs_type2: float
    bank_range: tuple[float, float]
    elevation_range: tuple[float, float]
    workspace: tuple[float, float, float, float]
    workspace_margin: float
    workspace_included: bool
    elevation_at_bank: tuple[tuple[float, float, float], ...]

    @property
    def n_points(self) -> int:
        """Number of grid points in :math:`Q^*`."""
        return int(self.q.shape[0])

    @property
    def n_failed(self) -> int:
        """Grid points whose continuation FKP failed (0 for a regular, connected region)."""
        return int(np.count_nonzero(~self.solved))

    @property
    def ok(self) -> bool:
        """Every point solved, constant signs of det A and det B and of every leg's mode, and
        :math:`W^*` strictly inside.
        """  # noqa: D205
        return (
            self.n_failed == 0
            and self.sign_det_a != 0
            and self.sign_det_b != 0
            and self.leg_modes_constant
            and self.workspace_included
        )


def _workspace_margin(
    cospm: CoSPM, S: FloatArray, chi: FloatArray, theta_prev: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """IKP (home modes) of orientations (N, 3) and their least signed stop distance (N,)."""
    th = cospm._ikp(chi, theta_prev, np.full(3, -1.0), "validate_region")
    q = th @ Q_AUX.T
    d = stops_polygon(S).signed_distances(q[:, :2])
    return th, np.asarray(np.min(d, axis=1), dtype=np.float64)


def _elevation_interval(
    cospm: CoSPM, S: FloatArray, bank: float, scan: float
) -> tuple[float, float]:
    """Elevation interval through 0 at this bank whose IKP stays inside the stops [rad]."""
    th0, _ = cospm.home()

    def margin(e: float, prev: FloatArray) -> tuple[FloatArray, float]:
        try:
            th, m = _workspace_margin(cospm, S, np.array([[bank, e, 0.0]]), prev[None])
        except InvalidInput:
            return prev, -math.inf
        return th[0], float(m[0])

    prev, m0 = margin(0.0, th0)
    if not m0 >= 0.0:
        return math.nan, math.nan
    ends = []
    limit = math.radians(89.0)
    for direction in (-1.0, 1.0):
        e_in, th_in = 0.0, prev
        e_out = math.nan
        while abs(e_in) < limit:
            e = direction * min(abs(e_in) + scan, limit)
            th, m = margin(e, th_in)
            if m < 0.0:
                e_out = e
                break
            e_in, th_in = e, th
        if math.isnan(e_out):
            ends.append(e_in)
            continue
        for _ in range(48):
            mid = 0.5 * (e_in + e_out)
            th, m = margin(mid, th_in)
            if m >= 0.0:
                e_in, th_in = mid, th
            else:
                e_out = mid
        ends.append(e_in)
    return ends[0], ends[1]


def validate_region(
    cospm: CoSPM | None = None,
    stops: ArrayLike = PAPER_STOPS,
    *,
    step: float = 0.02,
    theta3: float | None = _HALF_PI,
    workspace: tuple[float, float, float, float] = PAPER_WORKSPACE,
    workspace_step: float = math.radians(1.0),
    banks: tuple[float, ...] = (math.radians(-10.0), 0.0, math.radians(10.0)),
) -> RegionReport:
    r"""Grid check that the stops' region :math:`Q^*` is regular and dextrous (our tool).

    Stands in for Lê et al. 2024's offline certification (Kantorovich unicity operator and
    certified Newton, §1), which the paper does not specify:

    1. grid :math:`Q^*` in :math:`(q_1, q_2)` at multiples of ``step`` (home is a node);
       :math:`q_3` is chosen so that :math:`\theta_3` = ``theta3`` (the paper's "immobilize
       the 3rd leg" at π/2), or held at its home value :math:`\sqrt3\,\pi/2` when ``None``. By
       the bearing invariance the choice changes only the bearing :math:`\chi_3`, never the
       bank, elevation or any determinant;
    2. FKP by continuation, wave by wave from home over the 8-connected grid (each Newton
       starts from a solved neighbour); record det A, det B, :math:`\det[v\times w]` and the
       bank/elevation reached;
    3. dextrousness, exactly, through the closed-form IKP: sample the rectangle ``workspace``
       (bank × elevation, bearing 0 — irrelevant by the invariance) every ``workspace_step``,
       map each sample through IKP (home working modes, unwrapped along the grid) and
       :data:`Q_AUX`, and take the least signed distance to the stops. This is valid because
       step 2 checks that each leg keeps its home working mode over :math:`Q^*`.

    Args:
        cospm: The mechanism; ``CoSPM()`` (Table 1) when ``None``.
        stops: Rows ``(a_i, b_i, c_i)``, shape (m, 3); the paper's by default.
        step: Grid step in :math:`(q_1, q_2)` [rad], > 0.
        theta3: Fixed third joint [rad], or ``None`` for a fixed :math:`q_3`.
        workspace: ``(bank_min, bank_max, elev_min, elev_max)`` [rad] to check.
        workspace_step: Sample spacing over ``workspace`` [rad], > 0.
        banks: Bank values [rad] at which to report the reachable elevation interval.

    Returns:
        A :class:`RegionReport`.

    Raises:
        InvalidGeometry: bad stops (see :func:`stops_polygon`).
        InvalidParameter: bad options.
    """
    if cospm is None:
        cospm = CoSPM()
    if not isinstance(cospm, CoSPM):
        raise InvalidParameter(f"cospm: expected a CoSPM, got {type(cospm).__name__}")
    S = _stops(stops)
    polygon = stops_polygon(S)
    step = check_positive("step", step, unit="[rad]")
    workspace_step = check_positive("workspace_step", workspace_step, unit="[rad]")
    theta3 = _theta3(theta3)
    ws = tuple(
        real_array(
            "workspace",
            workspace,
            error=InvalidParameter,
            what="(bank_min, bank_max, elev_min, elev_max) [rad]",
            allow_nonfinite=True,
        )
        .reshape(-1)
        .tolist()
    )
    if len(ws) != 4 or not all(math.isfinite(x) for x in ws) or ws[0] > ws[1] or ws[2] > ws[3]:
        raise InvalidParameter(
            "workspace: expected (bank_min, bank_max, elev_min, elev_max) [rad] with min <= max, "
            f"got {workspace!r}"
        )
    banks_a = real_array(
        "banks", banks, (None,), error=InvalidParameter, what="bank angles [rad]", max_abs=1e3
    )
    if banks_a.shape[0] > MAX_BANKS:
        raise InvalidParameter(
            f"banks: expected at most {MAX_BANKS} bank angles, got {banks_a.shape[0]}"
        )
    th_home, _ = cospm.home()
    q3_home = float((Q_AUX @ th_home)[2])
    q_home = Q_AUX @ th_home

    # 1-2. continuation FKP over the grid of Q*.
    lo = polygon.corners.min(axis=0)
    hi = polygon.corners.max(axis=0)
    _grid_nodes("step", step, float(hi[0] - lo[0]), float(hi[1] - lo[1]))
    _grid_nodes("workspace_step", workspace_step, ws[1] - ws[0], ws[3] - ws[2])
    g1 = _grid(float(lo[0]), float(hi[0]), step)
    g2 = _grid(float(lo[1]), float(hi[1]), step)
    Q1, Q2 = np.meshgrid(g1, g2)
    pts = np.column_stack([Q1.ravel(), Q2.ravel()])
    inside = np.asarray(polygon.contains(pts), dtype=bool)
    mask = inside.reshape(Q1.shape)
    if not mask.any():
        raise InvalidParameter(
            f"step: expected a grid fine enough to sample Q*, got step = {show(step)} rad with no "
            "node inside; use a smaller step"
        )
    q3 = _q3_for(pts, theta3, q3_home)
    theta_grid = (np.column_stack([pts, q3]) @ Q_AUX).reshape((*Q1.shape, 3))
    dist = np.where(mask, np.hypot(Q1 - q_home[0], Q2 - q_home[1]), np.inf)
    start_flat = int(np.argmin(dist))
    start = (start_flat // Q1.shape[1], start_flat % Q1.shape[1])
    chi_grid, solved_grid = _flood(cospm, theta_grid, mask, start, keep_sign=False)

    sel = mask.ravel()
    q = pts[sel]
    theta = theta_grid.reshape(-1, 3)[sel]
    chi = chi_grid.reshape(-1, 3)[sel]
    solved = solved_grid.ravel()[sel]
    ok_t, ok_c = theta[solved], chi[solved]
    _, v, w = cospm._vectors(ok_t, ok_c)
    det_a_ok, _, type2_ok = cospm._indicators(v, w, ok_c)
    leg_b_ok = cospm._leg_b(v, w)

    def full(x: FloatArray, shape: tuple[int, ...]) -> FloatArray:
        out = np.full(shape, np.nan)
        out[solved] = x
        out.setflags(write=False)
        return out

    n = q.shape[0]
    det_a = full(det_a_ok, (n,))
    det_b = full(np.prod(leg_b_ok, axis=1), (n,))
    type2 = full(type2_ok, (n,))
    leg_b = full(leg_b_ok, (n, 3))
    _, v0, w0 = cospm._vectors(th_home[None], np.zeros((1, 3)))
    home_modes = np.sign(cospm._leg_b(v0, w0))[0]
    leg_constant = bool(np.all(np.sign(leg_b_ok) == home_modes))

    def span(x: FloatArray) -> tuple[float, float]:
        return (float(np.min(x)), float(np.max(x))) if x.size else (math.nan, math.nan)

    def min_abs(x: FloatArray) -> float:
        return float(np.min(np.abs(x))) if x.size else math.nan

    # 3. dextrousness through the closed-form IKP, unwrapped along elevation rows.
    banks_ws = np.linspace(ws[0], ws[1], max(2, math.ceil((ws[1] - ws[0]) / workspace_step) + 1))
    elevs = np.linspace(ws[2], ws[3], max(2, math.ceil((ws[3] - ws[2]) / workspace_step) + 1))
    margin = math.inf
    try:
        mid = int(np.argmin(np.abs(elevs)))
        order = list(range(mid, elevs.size)) + list(range(mid - 1, -1, -1))
        row0 = np.column_stack([banks_ws, np.zeros_like(banks_ws), np.zeros_like(banks_ws)])
        start_th, _ = _workspace_margin(cospm, S, row0, np.broadcast_to(th_home, row0.shape).copy())
        prev = start_th
        for k in order:
            if k == mid - 1:
                prev = start_th
            chi_row = np.column_stack(
                [banks_ws, np.full_like(banks_ws, elevs[k]), np.zeros_like(banks_ws)]
            )
            prev, m = _workspace_margin(cospm, S, chi_row, prev)
            margin = min(margin, float(np.min(m)))
    except InvalidInput:
        margin = -math.inf  # a sample of W* is out of reach of a leg: certainly not included

    scan = math.radians(0.5)
    at_bank: list[tuple[float, float, float]] = []
    for b in banks_a.tolist():
        e_lo, e_hi = _elevation_interval(cospm, S, float(b), scan)
        at_bank.append((float(b), e_lo, e_hi))
    return RegionReport(
        step=step,
        theta3=theta3,
        q=readonly(q),
        theta=readonly(theta),
        chi=readonly(chi),
        solved=readonly(solved),
        det_a=det_a,
        det_b=det_b,
        type2=type2,
        leg_b=leg_b,
        sign_det_a=_sign(det_a_ok) if solved.all() else 0,
        sign_det_b=_sign(np.prod(leg_b_ok, axis=1)) if solved.all() else 0,
        leg_modes_constant=leg_constant and bool(solved.all()),
        min_abs_det_a=min_abs(det_a_ok),
        min_abs_det_b=min_abs(np.prod(leg_b_ok, axis=1)),
        min_abs_type2=min_abs(type2_ok),
        bank_range=span(ok_c[:, 0]),
        elevation_range=span(ok_c[:, 1]),
        workspace=(ws[0], ws[1], ws[2], ws[3]),
        workspace_margin=margin,
        workspace_included=bool(margin > 0.0),
        elevation_at_bank=tuple(at_bank),
    )


@dataclass(frozen=True, eq=False, kw_only=True)
class SingularGrid:
    r"""Singularity indicators of the home leaf over a window of the :math:`(q_1, q_2)` plane.

    For a contour plot: ``contour(q1, q2, det_b, [0])`` draws the Type-1 curves crossed by the
    leaf; the Type-2 curves (:math:`\det A = 0`) are where the leaf folds, i.e. the edge of
    ``reached`` with :math:`|\det A| \to 0` there (``contour(q1, q2, type2, [small])`` or the
    boundary of ``reached``). Values are NaN where the leaf was not reached.

    Attributes:
        q1: Grid abscissae [rad], shape (n1,).
        q2: Grid ordinates [rad], shape (n2,).
        theta3: The fixed :math:`\theta_3` [rad] (or ``None``: fixed home :math:`q_3`).
        reached: Whether the continuation reached the point on the home leaf, shape (n2, n1).
        chi: Orientation [rad], shape (n2, n1, 3).
        det_a: :math:`\det A`, shape (n2, n1).
        det_b: :math:`\det B`, shape (n2, n1).
        type2: :math:`\det[v_i\times w_i]`, shape (n2, n1).
    """

    q1: FloatArray
    q2: FloatArray
    theta3: float | None
    reached: BoolArray
    chi: FloatArray
    det_a: FloatArray
    det_b: FloatArray
    type2: FloatArray


def singular_curves(
    cospm: CoSPM | None = None,
    *,
    window: tuple[float, float, float, float] = (-1.6, 2.4, -1.8, 1.4),
    step: float = 0.02,
    theta3: float | None = _HALF_PI,
) -> SingularGrid:
    r"""Grids of det A, det B and :math:`\det[v\times w]` on the home leaf, for plotting.

    FKP by continuation from home over the window (as :func:`validate_region`), expanding only
    while :math:`\det[v\times w]` keeps its home sign, so the leaf stops at its Type-2 fold.

    Args:
        cospm: The mechanism; ``CoSPM()`` when ``None``.
        window: ``(q1_min, q1_max, q2_min, q2_max)`` [rad]; must contain home (0, 0).
        step: Grid step [rad], > 0.
        theta3: Fixed third joint [rad] or ``None`` (fixed home :math:`q_3`); only the bearing
            depends on it.

    Returns:
        A :class:`SingularGrid`.

    Raises:
        InvalidParameter: bad window or step.
    """
    if cospm is None:
        cospm = CoSPM()
    if not isinstance(cospm, CoSPM):
        raise InvalidParameter(f"cospm: expected a CoSPM, got {type(cospm).__name__}")
    step = check_positive("step", step, unit="[rad]")
    theta3 = _theta3(theta3)
    wnd = tuple(
        real_array(
            "window",
            window,
            (4,),
            error=InvalidParameter,
            what="(q1_min, q1_max, q2_min, q2_max) [rad]",
            allow_nonfinite=True,
        ).tolist()
    )
    th_home, _ = cospm.home()
    q_home = Q_AUX @ th_home
    if (
        len(wnd) != 4
        or not all(math.isfinite(x) for x in wnd)
        or not (wnd[0] <= q_home[0] <= wnd[1] and wnd[2] <= q_home[1] <= wnd[3])
    ):
        raise InvalidParameter(
            "window: expected finite (q1_min, q1_max, q2_min, q2_max) [rad] around home "
            f"({q_home[0]:.3g}, {q_home[1]:.3g}), got {window!r}"
        )
    _grid_nodes("step", step, wnd[1] - wnd[0], wnd[3] - wnd[2])
    g1 = _grid(wnd[0], wnd[1], step)
    g2 = _grid(wnd[2], wnd[3], step)
    Q1, Q2 = np.meshgrid(g1, g2)
    pts = np.column_stack([Q1.ravel(), Q2.ravel()])
    q3 = _q3_for(pts, theta3, float(q_home[2]))
    theta = (np.column_stack([pts, q3]) @ Q_AUX).reshape((*Q1.shape, 3))
    dist = np.hypot(Q1 - q_home[0], Q2 - q_home[1])
    s = int(np.argmin(dist))
    start = (s // Q1.shape[1], s % Q1.shape[1])
    chi, reached = _flood(cospm, theta, np.ones(Q1.shape, dtype=bool), start, keep_sign=True)
    det_a = np.full(Q1.shape, np.nan)
    det_b = np.full(Q1.shape, np.nan)
    type2 = np.full(Q1.shape, np.nan)
    if reached.any():
        t, c = theta[reached], chi[reached]
        _, v, w = cospm._vectors(t, c)
        det_a[reached], det_b[reached], type2[reached] = cospm._indicators(v, w, c)
    return SingularGrid(
        q1=readonly(g1),
        q2=readonly(g2),
        theta3=theta3,
        reached=readonly(reached),
        chi=readonly(chi),
        det_a=readonly(det_a),
        det_b=readonly(det_b),
        type2=readonly(type2),
    )


@dataclass(frozen=True, eq=False, kw_only=True)
class WorkspaceMap:
    r"""The home working mode over a (bank, elevation) grid, by the closed-form IKP.

    The content of Lê et al. 2024 Fig. 3b: in the home working mode the reachable set is bounded
    by the Type-1 singularities (:math:`|C_i| = R_i` for some leg, the edge of ``reachable``);
    :math:`\mathrm{FKP}(Q^*)` is where ``stop_margin >= 0`` (valid when
    :func:`validate_region` reports ``leg_modes_constant``); :math:`W^*` is the rectangle
    :data:`PAPER_WORKSPACE`. The same grid mapped to :math:`(q_1, q_2)` (``q``, a curvilinear
    grid) carries ``det_a`` for a contour of the Type-2 curves in the joint plane. Bearing is 0
    (irrelevant by the invariance); NaN where unreachable.

    Attributes:
        bank: Bank samples [rad], shape (n1,).
        elevation: Elevation samples [rad], shape (n2,).
        reachable: IKP exists in working mode (-1, -1, -1), shape (n2, n1).
        theta: Joint angles, unwrapped continuously from home [rad], shape (n2, n1, 3).
        q: Auxiliary coordinates :math:`(q_1, q_2)` [rad], shape (n2, n1, 2).
        det_a: :math:`\det A`, shape (n2, n1).
        det_b: :math:`\det B`, shape (n2, n1).
        type2: :math:`\det[v_i\times w_i]`, shape (n2, n1).
        stop_margin: Least signed distance of ``q`` to the stops, positive inside [rad],
            shape (n2, n1).
    """

    bank: FloatArray
    elevation: FloatArray
    reachable: BoolArray
    theta: FloatArray
    q: FloatArray
    det_a: FloatArray
    det_b: FloatArray
    type2: FloatArray
    stop_margin: FloatArray


def workspace_map(
    cospm: CoSPM | None = None,
    stops: ArrayLike = PAPER_STOPS,
    *,
    bank: tuple[float, float] = (-_HALF_PI, _HALF_PI),
    elevation: tuple[float, float] = (math.radians(-89.0), math.radians(89.0)),
    step: float = math.radians(1.0),
) -> WorkspaceMap:
    r"""Map the (bank, elevation) plane through the closed-form IKP (Lê et al. 2024 Fig. 3b).

    Each sample's joint angles are unwrapped to an already computed neighbour, marching outward
    from the sample nearest home, so ``q`` is continuous over the reachable set.

    Args:
        cospm: The mechanism; ``CoSPM()`` when ``None``.
        stops: Rows ``(a_i, b_i, c_i)``, shape (m, 3), for ``stop_margin``.
        bank: ``(min, max)`` bank [rad].
        elevation: ``(min, max)`` elevation [rad]; keep inside ``(-π/2, π/2)``.
        step: Sample spacing [rad], > 0.

    Returns:
        A :class:`WorkspaceMap`.

    Raises:
        InvalidParameter: bad ranges or step.
        InvalidGeometry: bad stops.
    """
    if cospm is None:
        cospm = CoSPM()
    if not isinstance(cospm, CoSPM):
        raise InvalidParameter(f"cospm: expected a CoSPM, got {type(cospm).__name__}")
    S = _stops(stops)
    stops_polygon(S)
    step = check_positive("step", step, unit="[rad]")
    ranges = []
    for name, rng in (("bank", bank), ("elevation", elevation)):
        lo, hi = real_array(
            name, rng, (2,), error=InvalidParameter, what="(min, max) [rad]", allow_nonfinite=True
        ).tolist()
        if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
            raise InvalidParameter(f"{name}: expected (min, max) [rad] with min < max, got {rng!r}")
        ranges.append((lo, hi))
    elev_lo, elev_hi = ranges[1]
    if not (elev_lo > -_HALF_PI and elev_hi < _HALF_PI):
        raise InvalidParameter(
            f"elevation: expected a range inside (-π/2, π/2) rad (gimbal lock at ±π/2), got "
            f"{show(elevation)}"
        )
    _grid_nodes("step", step, ranges[0][1] - ranges[0][0], ranges[1][1] - ranges[1][0])
    b = np.linspace(*ranges[0], max(2, math.ceil((ranges[0][1] - ranges[0][0]) / step) + 1))
    e = np.linspace(*ranges[1], max(2, math.ceil((ranges[1][1] - ranges[1][0]) / step) + 1))
    n1, n2 = b.size, e.size
    modes = np.full(3, -1.0)
    th_home, _ = cospm.home()
    theta = np.full((n2, n1, 3), np.nan)
    i0, j0 = int(np.argmin(np.abs(e))), int(np.argmin(np.abs(b)))
    # Central row: march along bank from the sample nearest home.
    for cols in (range(j0, n1), range(j0 - 1, -1, -1)):
        prev = th_home if not cols or cols[0] == j0 else theta[i0, j0]
        if not np.all(np.isfinite(prev)):
            prev = th_home
        for j in cols:
            th, _, _, _ = cospm._ikp_raw(np.array([[b[j], e[i0], 0.0]]), prev[None], modes)
            theta[i0, j] = th[0]
            if np.all(np.isfinite(th[0])):
                prev = th[0]
    # Other rows: march along elevation, all columns at once; carry the last finite row.
    for rows in (range(i0 + 1, n2), range(i0 - 1, -1, -1)):
        carry = theta[i0].copy()
        fill = np.broadcast_to(th_home, carry.shape)
        carry = np.where(np.isfinite(carry), carry, fill)
        for i in rows:
            chi = np.column_stack([b, np.full(n1, e[i]), np.zeros(n1)])
            th, _, _, _ = cospm._ikp_raw(chi, carry, modes)
            theta[i] = th
            carry = np.where(np.isfinite(th), th, carry)
    reachable = np.all(np.isfinite(theta), axis=2)
    q = theta @ Q_AUX.T
    det_a = np.full((n2, n1), np.nan)
    det_b = np.full((n2, n1), np.nan)
    type2 = np.full((n2, n1), np.nan)
    if reachable.any():
        B_, E_ = np.meshgrid(b, e)
        chi_r = np.column_stack([B_[reachable], E_[reachable], np.zeros(int(reachable.sum()))])
        _, v, w = cospm._vectors(theta[reachable], chi_r)
        det_a[reachable], det_b[reachable], type2[reachable] = cospm._indicators(v, w, chi_r)
    q12 = q[:, :, :2]
    margin = (
        stops_polygon(S)
        .signed_distances(np.nan_to_num(q12).reshape(-1, 2))
        .min(axis=1)
        .reshape(q12.shape[:2])
    )
    margin = np.where(reachable, margin, np.nan)
    return WorkspaceMap(
        bank=readonly(b),
        elevation=readonly(e),
        reachable=readonly(reachable),
        theta=readonly(theta),
        q=readonly(np.ascontiguousarray(q12)),
        det_a=readonly(det_a),
        det_b=readonly(det_b),
        type2=readonly(type2),
        stop_margin=readonly(margin),
    )


document_inits(globals())
