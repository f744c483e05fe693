r"""Evidence campaigns for the n-D shaper and the safety filter ("does it ever let the robot out?").

Two campaigns, reusable on a user's own configuration and run by ``make soak-filter``
(``python -m velfence.apps.soak_filter``), which writes its section of ``docs/reliability.md``:

**Vertex and edge campaign** (:func:`run_vertex_campaign`). Random H-representation polytopes of
3 to 7 dimensions (:func:`random_polytope`); states exactly at a vertex (the vertex re-solved from
its tight facets, so it sits on or a round-off outside each of them), on an edge or on a higher
face (a point of the segment between two vertices sharing facets), then, for half of them,
pushed outward by 1-8 ulps on some of their tight facets or by exactly 2e-16 (the round-off of
the first vertex escape found, 0.025 out in one 1 ms step);
commands of random direction, along the outward normal of one tight facet (into the facet the
point is inside or on) or into the corner. One step ``x1 = x0 + dt · y`` of ``dt = 1 ms`` per
state. An *escape* is a step whose depth outside grows by more than the round-off tolerance
``tol = 1e-12 (scale + |x0|_inf)`` (``scale``: the polytope's largest vertex coordinate about its
Chebyshev centre): ``depth(x1) - depth(x0) > tol`` with ``depth(x) = max(0, max_i -d_i(x))``.
Measured for :class:`~velfence.shaping.polytope.PolytopeShaper` (``method="exact"``, three
buffers, ``dt`` set; :meth:`~velfence.shaping.polytope.PolytopeShaper.shape_batch`) and for the
workspace rows of :class:`~velfence.filter.SafetyFilter` on :class:`CartesianPoint`, a
robot whose point is its joint vector (so a 3-D workspace polytope is the filter's safe set).

**Closed-loop filter soak** (:func:`run_loop_campaign`). Episodes of a ``SafetyFilter`` on the
shipped UR5e and Panda models (:func:`velfence.robots.ur5e`, :func:`velfence.robots.panda`,
capsule links of 5 cm, a 5 cm tool) with random joint-limit ranges (some episodes with
acceleration limits), a random box on the tool, one or two tilted planes, or both, and up to
four sphere obstacles near the links, at a given rate with ``dt`` set; joint or twist commands
held for 20-200 ms, some pushing at the nearest workspace facet. A quarter of the episodes start
**resting**: the tool exactly on two tilted planes while two or three joints sit exactly at a
limit (where a UR5e tool once drifted through a tilted plane at 500 Hz). The plant is kinematic:
``q ← q + x dt``. Per step it counts
workspace escapes (a step beginning inside, by the forward kinematics, ending outside by more
than ``1e-12 (1 + |p|_inf)`` m), joint-limit crossings, sphere penetrations (capsule clearance
below ``-tol``, a step that began clear), non-finite outputs, exceptions, deadline fallbacks
(``result.deadline`` when the filter reports it) and the stages seen.
"""

from __future__ import annotations

import math
import time
import warnings
from collections import Counter
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from velfence._typing import FloatArray
from velfence._validate import (
    check_flag,
    check_positive,
    check_positive_int,
    check_range,
    check_seed,
    check_text,
    describe,
    real_array,
)
from velfence.errors import InvalidGeometry, InvalidInput, InvalidParameter, StartedInViolation

__all__ = [
    "CartesianPoint",
    "LoopResult",
    "VertexResult",
    "any_start",
    "clearance",
    "render_markdown",
    "run_loop_campaign",
    "run_vertex_campaign",
    "soak_command",
]

Rng = np.random.Generator
Progress = Callable[[str], None]
#: ``on_progress(done, total, what)``: the type of :data:`velfence.apps.progress.OnProgress`.
OnProgress = Callable[[float, float, str], None]

#: Relative round-off tolerance of every check (times a length scale).
ROUND_OFF = 1e-12

SECTION_BEGIN = "<!-- soak_filter: begin (python -m velfence.apps.soak_filter --out) -->"
SECTION_END = "<!-- soak_filter: end -->"
#: Text of a section from this marker to :data:`SECTION_END` (earlier runs kept for the record)
#: survives :func:`write_section`.
HISTORY = "<!-- soak_filter: earlier runs (kept on rewrite) -->"

INTRO = """## The n-D shaper and the safety filter: vertex campaign and closed-loop soak

Module `velfence.apps.soak_filter` (`make soak-filter`, reusable: `run_vertex_campaign`,
`run_loop_campaign`) gathers the evidence that neither lets the robot out (the fixes:
docs/derivations.md §7.2-7.3, docs/safety_filter.md).

**Vertex and edge campaign.** Random H-representation polytopes of 3 to 7 dimensions (`d + 1` to
`2 d + 4` random facets, scales 0.1-10). States exactly at a vertex (re-solved from its tight
facets), on an edge, or on a higher face (a point between two vertices sharing facets); half of
them then pushed outward by 1-8 ulps on some of their tight facets or by exactly 2e-16. Commands
of random direction, along the outward normal of one tight facet, or into the corner, at 0.1-30
scales per second. One step of `dt = 1 ms`. An **escape** is a step whose depth outside grows by
more than `1e-12 (scale + |x|)`. Run on `PolytopeShaper` (exact law, `dt` set, buffers of 2 %,
20 % and 90 % of the Chebyshev radius, `shape_batch`) and on `SafetyFilter`'s workspace rows
(joint mode on `CartesianPoint`, a robot whose point is its joint vector, same buffers; 3-D
polytopes only, the filter's task space being 2-D or 3-D).

**Closed-loop filter soak.** `SafetyFilter` on the shipped UR5e and Panda models
(`velfence.robots.ur5e` / `panda`, capsule links of 5 cm, a 5 cm tool), `dt` set, a kinematic
plant `q ← q + x dt`. Every 500-step episode draws joint-limit ranges around a random start (some
joints exactly at a limit in a fifth of the episodes; acceleration limits in 30 %), a box on the
tool, one or two tilted planes, or both (buffers 1-5 cm), up to four spheres near the links,
and joint-velocity or twist commands held for 20-200 ms (40 % push at the nearest facet). A
quarter of the episodes are **resting**: the tool exactly on two tilted planes, two or three
joints exactly at a limit, twist commands (where a UR5e tool once drifted through a tilted plane at
500 Hz). Counted with the forward
kinematics: *ws escapes* (a step that began inside every workspace limit ends outside by more
than `1e-12 (1 + |p|)` m), *deepened* (a step that began outside goes further out by more than
that), *joint crossings*, *sphere penetrations* (capsule clearance < 0 after a step that began
clear), non-finite outputs, exceptions, deadline fallbacks (`result.deadline`) and the stages.

**Reproducing a finding.** `VertexResult.example` holds an escaping vertex state with its
polytope and buffer; with `--examples DIR` every closed-loop case saves its first escape as an
`.npz` (scene, state, command, previous output, output, stages) that
`velfence.apps.soak_filter.replay_loop_example` runs again bit for bit. The regression cases in
`tests/data/` `vertex_polytope_shaper.npz` and
`loop_ur5e_100hz_projection_recovery.npz` came from these runs (`state_*.npz`, a UR5e and a
Panda filter state whose next 1 ms step left
the box by 3.56 mm / 0.52 mm, and `project_filter_rows.npz`, rows the projection once called
infeasible, from an independent campaign).
"""


#: Least time [s] between two ``on_progress`` reports of a campaign.
TICK = 0.25


def _quiet(_: str) -> None:
    """Progress sink that prints nothing."""


def _check_callable(name: str, f: Any, *, optional: bool = False) -> None:
    """Refuse a non-callable (``None`` allowed with ``optional``)."""
    if (f is None and optional) or callable(f):
        return
    raise InvalidParameter(
        f"{name}: expected a callable{' or None' if optional else ''}, got {describe(f)}"
    )


# ------------------------------------------------------------------------ vertex campaign
@dataclass(frozen=True)
class VertexResult:
    """What a vertex and edge campaign measured for one implementation.

    Attributes:
        name: The implementation and its settings.
        states: States stepped.
        polytopes: Random polytopes they were drawn from.
        dims: The polytopes' dimensions (distinct, sorted).
        escapes: Steps whose depth outside grew by more than the round-off tolerance.
        max_escape: Largest growth of the depth outside over all steps [units]; 0 if none grew.
        max_escape_relative: The same divided by the polytope's scale.
        nonfinite: Outputs with a non-finite entry.
        exceptions: States whose call raised (counted; the campaign goes on).
        kinds: Escapes per state kind (``"vertex"``, ``"edge"``, ``"face"``).
        seconds: Wall time [s].
        example: The largest escape of the first batch that had one (``dim``, the polytope's
            ``normals`` and ``offsets``, ``buffer``, ``x``, ``u``, output ``y``, ``escape``), or
            ``None``.
    """

    name: str
    states: int
    polytopes: int
    dims: tuple[int, ...]
    escapes: int
    max_escape: float
    max_escape_relative: float
    nonfinite: int
    exceptions: int
    kinds: dict[str, int]
    seconds: float
    example: dict[str, Any] | None = None


@contextmanager
def any_start() -> Iterator[None]:
    """No :class:`~velfence.errors.StartedInViolation` inside (a context or a decorator).

    A campaign draws its filters' first states anywhere, beyond a limit too, on purpose, and
    measures what follows: the warning a user's loop gets for such a start is not news here.
    Internal API of the campaigns (``verify`` runs its cases under it too).

    Returns:
        A context manager (``with any_start(): ...``) that is also a function decorator
        (``@any_start()``); the warning filters are restored on leaving it.
    """
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", StartedInViolation)
        yield


def random_polytope(rng: Rng, dim: int, *, scale: float = 1.0) -> Any:
    """A random bounded polytope in ``dim`` dimensions (a ``ConvexPolytope``).

    ``dim + 1`` to ``2 dim + 4`` random unit inward normals at random distances
    (``scale`` x 0.3-1) from a random centre (within ``scale`` of the origin); redrawn until
    bounded. Redundant facets are removed by the constructor.

    Args:
        rng: Random generator.
        dim: Dimension, >= 2.
        scale: Size [units], > 0.

    Returns:
        The :class:`~velfence.geometry.polytope.ConvexPolytope`.
    """
    from velfence.geometry.polytope import ConvexPolytope

    while True:
        m = int(rng.integers(dim + 1, 2 * dim + 5))
        N = rng.normal(size=(m, dim))
        N /= np.linalg.norm(N, axis=1)[:, None]
        centre = rng.uniform(-scale, scale, dim)
        off = N @ centre - scale * rng.uniform(0.3, 1.0, m)
        try:
            P = ConvexPolytope(N, off)
            V = P.vertices
        except InvalidGeometry:
            continue
        if V.shape[0] >= dim + 1:
            return P


@dataclass
class _States:
    """A batch of vertex/edge/face states of one polytope (rows aligned)."""

    X: FloatArray
    U: FloatArray
    kind: NDArray[np.int8]  # 0 vertex, 1 edge, 2 face


_KINDS = ("vertex", "edge", "face")


def vertex_states(rng: Rng, P: Any, n: int, *, max_speed: float) -> tuple[FloatArray, FloatArray]:
    """States on vertices, edges and faces of ``P``, some a few ulps outside, with commands.

    Args:
        rng: Random generator.
        P: A bounded ``ConvexPolytope``.
        n: Number of states.
        max_speed: Largest command speed [units/s].

    Returns:
        ``(X, U)``, both shape (n, dim): the states and the commands (module docstring).
    """
    s = _vertex_states(rng, P, n, max_speed)
    return s.X, s.U


def _vertex_states(rng: Rng, P: Any, n: int, max_speed: float) -> _States:
    N: FloatArray = np.asarray(P.normals)
    off: FloatArray = np.asarray(P.offsets)
    dim = N.shape[1]
    V0: FloatArray = np.asarray(P.vertices)
    scale = float(np.max(np.abs(V0 - P.chebyshev_center)))
    tight = np.abs(V0 @ N.T - off) <= 1e-9 * (1.0 + scale)
    # Re-solve each vertex from its tight facets: it then sits on them to round-off.
    V = np.empty_like(V0)
    for k in range(V0.shape[0]):
        rows = np.flatnonzero(tight[k])
        sol = np.linalg.lstsq(N[rows], off[rows], rcond=None)[0] if rows.size >= dim else V0[k]
        V[k] = sol if np.all(np.isfinite(sol)) else V0[k]
    nv = V.shape[0]
    Ti = tight.astype(np.int32)
    shared = Ti @ Ti.T
    np.fill_diagonal(shared, 0)
    edges = np.argwhere(np.triu(shared >= dim - 1, 1))
    faces = np.argwhere(np.triu((shared >= 1) & (shared < dim - 1), 1))
    kind = rng.choice(3, size=n, p=(0.4, 0.35, 0.25)).astype(np.int8)
    kind[(kind == 1) & (edges.shape[0] == 0)] = 0
    kind[(kind == 2) & (faces.shape[0] == 0)] = 1 if edges.shape[0] else 0
    X = np.empty((n, dim))
    on = np.zeros((n, N.shape[0]), dtype=bool)  # the facets each state lies on
    iv = np.flatnonzero(kind == 0)
    k0 = rng.integers(0, nv, iv.size)
    X[iv] = V[k0]
    on[iv] = tight[k0]
    for code, pairs in ((1, edges), (2, faces)):
        idx = np.flatnonzero(kind == code)
        if idx.size == 0:
            continue
        pr = pairs[rng.integers(0, pairs.shape[0], idx.size)]
        t = rng.uniform(0.0, 1.0, (idx.size, 1))
        X[idx] = V[pr[:, 0]] + t * (V[pr[:, 1]] - V[pr[:, 0]])
        on[idx] = tight[pr[:, 0]] & tight[pr[:, 1]]
    # Outward perturbations on a random subset of each state's facets.
    pert = rng.random(n) < 0.5
    pick = on & (rng.random(on.shape) < 0.5) & pert[:, None]
    exact = rng.random(n) < 0.3  # the first vertex escape's -2e-16, else 1-8 ulps
    ulp = np.spacing(np.maximum(np.max(np.abs(X), axis=1), 1.0))
    amount = np.where(exact, 2e-16, ulp * rng.choice([1.0, 2.0, 4.0, 8.0], n))
    X = X - amount[:, None] * (pick.astype(np.float64) @ N)
    # Commands: random, outward through one facet the state is on, or into the corner.
    D = rng.normal(size=(n, dim))
    D /= np.linalg.norm(D, axis=1)[:, None]
    mode = rng.choice(3, size=n, p=(0.3, 0.4, 0.3))
    for i in np.flatnonzero(mode > 0):
        rows = np.flatnonzero(on[i])
        if rows.size == 0:
            continue
        out = -N[rng.choice(rows)] if mode[i] == 1 else -N[rows].sum(axis=0)
        nrm = float(np.linalg.norm(out))
        if nrm == 0.0:
            continue
        out = out / nrm
        tang = D[i] - float(D[i] @ out) * out
        d = out + rng.uniform(0.0, 0.5) * tang
        D[i] = d / np.linalg.norm(d)
    U = D * rng.uniform(0.05, 1.0, (n, 1)) * max_speed
    return _States(X, U, kind)


class CartesianPoint:
    """A robot whose only point is its joint vector: ``fk(q) = q``, ``J = I``.

    Makes a workspace polytope the :class:`~velfence.filter.SafetyFilter`'s safe set (the
    filter's workspace rows, alone; the filter accepts task spaces of 2 or 3 dimensions).

    Args:
        dim: Number of joints and task dimensions, >= 1.

    Raises:
        InvalidParameter: ``dim`` not an int in [1, 64].
    """

    def __init__(self, *, dim: int) -> None:
        self.dof = check_positive_int("dim", dim, maximum=64)
        self.joint_names = tuple(f"x{i}" for i in range(self.dof))
        self.points = ("tcp",)

    def _check(self, q: ArrayLike, point: str) -> FloatArray:
        qa = real_array("q", q, (self.dof,), what="joint values")
        if not isinstance(point, str) or point != "tcp":
            raise InvalidInput(f"point: expected 'tcp', got {describe(point)}")
        return qa

    def fk(self, q: ArrayLike, point: str = "tcp") -> FloatArray:
        """The point: ``q`` itself [units], shape (dim,).

        Args:
            q: Joint values, shape (dim,), finite.
            point: ``"tcp"`` (the only point).

        Returns:
            A copy of ``q``.

        Raises:
            InvalidInput: a bad ``q`` or ``point``.
        """
        return np.array(self._check(q, point), dtype=np.float64)

    def jacobian(self, q: ArrayLike, point: str = "tcp") -> FloatArray:
        """The identity, shape (dim, dim).

        Args:
            q: Joint values, shape (dim,), finite.
            point: ``"tcp"`` (the only point).

        Returns:
            The identity matrix.

        Raises:
            InvalidInput: a bad ``q`` or ``point``.
        """
        self._check(q, point)
        return np.eye(self.dof)


def _depth(P: Any, X: FloatArray) -> FloatArray:
    """Depth outside ``P`` of each row of ``X``: ``max(0, max_i -(n_i·x - o_i))``."""
    d = X @ np.asarray(P.normals).T - np.asarray(P.offsets)
    return np.asarray(np.maximum(0.0, -d.min(axis=1)), dtype=np.float64)


@dataclass
class _Tally:
    """Running counts of one vertex-campaign implementation."""

    name: str
    states: int = 0
    escapes: int = 0
    max_escape: float = 0.0
    max_rel: float = 0.0
    nonfinite: int = 0
    exceptions: int = 0
    kinds: Counter[str] = field(default_factory=Counter)
    seconds: float = 0.0
    example: dict[str, Any] | None = None

    def add(
        self,
        P: Any,
        scale: float,
        st: _States,
        Y: FloatArray,
        dt: float,
        buffers: Sequence[float],
        failed: NDArray[np.bool_] | None = None,
    ) -> None:
        bad: NDArray[np.bool_] = np.asarray(~np.isfinite(Y).all(axis=1), dtype=np.bool_)
        self.nonfinite += int(bad.sum())
        Y = np.where(bad[:, None], 0.0, Y)
        X1 = st.X + dt * Y
        grow = _depth(P, X1) - _depth(P, st.X)
        tol = ROUND_OFF * (scale + np.max(np.abs(st.X), axis=1))
        esc = grow > tol
        if failed is not None:
            esc &= ~failed
            self.exceptions += int(failed.sum())
        self.states += st.X.shape[0]
        self.escapes += int(esc.sum())
        for k in st.kind[esc]:
            self.kinds[_KINDS[int(k)]] += 1
        top = float(grow.max(initial=0.0))
        self.max_escape = max(self.max_escape, top)
        self.max_rel = max(self.max_rel, top / scale)
        if esc.any() and self.example is None:
            i = int(np.argmax(np.where(esc, grow, -np.inf)))
            parts = np.array_split(np.arange(st.X.shape[0]), len(buffers))
            j = next(k for k, part in enumerate(parts) if i in part)
            self.example = {
                "dim": int(st.X.shape[1]),
                "normals": np.asarray(P.normals).tolist(),
                "offsets": np.asarray(P.offsets).tolist(),
                "buffer": float(buffers[j]),
                "x": st.X[i].tolist(),
                "u": st.U[i].tolist(),
                "y": Y[i].tolist(),
                "escape": float(grow[i]),
            }

    def result(self, polytopes: int, dims: Sequence[int]) -> VertexResult:
        return VertexResult(
            name=self.name,
            states=self.states,
            polytopes=polytopes,
            dims=tuple(sorted(set(dims))),
            escapes=self.escapes,
            max_escape=self.max_escape,
            max_escape_relative=self.max_rel,
            nonfinite=self.nonfinite,
            exceptions=self.exceptions,
            kinds=dict(self.kinds),
            seconds=self.seconds,
            example=self.example,
        )


#: Largest polytope dimension the filter campaign uses: the filter's task space is 2-D or 3-D.
_FILTER_MAX_DIM = 3

ShaperFactory = Callable[[Any, float, float], Any]
"""``factory(polytope, buffer, dt)`` → the shaper under test (has ``shape_batch(X, U)``)."""


def _exact_shaper(P: Any, buffer: float, dt: float) -> Any:
    from velfence.shaping.polytope import PolytopeShaper

    return PolytopeShaper(P, buffer=buffer, dt=dt)


def run_vertex_campaign(
    *,
    states: int = 1_000_000,
    filter_states: int = 100_000,
    dims: Sequence[int] = (3, 4, 5, 6, 7),
    per_polytope: int = 5000,
    dt: float = 1e-3,
    shaper: ShaperFactory | None = None,
    seed: int = 0,
    progress: Progress = _quiet,
    on_progress: OnProgress | None = None,
) -> list[VertexResult]:
    """Run the vertex and edge campaign (module docstring) on the shaper and the filter.

    Args:
        states: States stepped by the shaper (``PolytopeShaper`` exact with ``dt``), >= 1.
        filter_states: States stepped by the filter's workspace rows, >= 0 (0: no filter run);
            drawn from the polytopes of dimension <= 3 (the filter's task space is 2-D or 3-D).
        dims: Dimensions of the random polytopes (cycled), each 2-10.
        per_polytope: States per polytope, >= 1 (the filter gets the same share of polytopes).
        dt: Step [s], > 0.
        shaper: ``factory(polytope, buffer, dt)`` building the shaper under test (default: the
            exact ``PolytopeShaper`` with ``dt``); the tests plant a broken one.
        seed: Seed of the random generator.
        progress: Called with a line of progress now and then (every 10 s).
        on_progress: Called about four times a second as ``on_progress(done, total, what)``
            (states stepped; a command passes :func:`velfence.apps.progress.update`).

    Returns:
        One :class:`VertexResult` for the shaper and, with ``filter_states``, one for the filter.

    Raises:
        InvalidParameter: a count or ``dt`` out of range, an empty or bad ``dims``.
    """
    total = check_positive_int("states", states, maximum=10**9)
    zero = type(filter_states) is int and filter_states == 0
    nf = 0 if zero else check_positive_int("filter_states", filter_states, maximum=10**9)
    per = check_positive_int("per_polytope", per_polytope, maximum=10**7)
    dt = check_positive("dt", dt, unit="s")
    if (
        not isinstance(dims, list | tuple)
        or not all(
            isinstance(d, int | np.integer) and not isinstance(d, bool) and 2 <= d <= 10
            for d in dims
        )
        or not dims
    ):
        raise InvalidParameter(
            f"dims: expected a non-empty list or tuple of ints in [2, 10], got {describe(dims)}"
        )
    dl = [int(d) for d in dims]
    eligible = sum(d <= _FILTER_MAX_DIM for d in dl)  # the filter's task space is 2-D or 3-D
    if nf and not eligible:
        raise InvalidParameter(
            f"dims: the filter's workspace rows need a dimension <= {_FILTER_MAX_DIM} in dims "
            f"(its task space is 2-D or 3-D), got {dl}; or pass filter_states=0"
        )
    _check_callable("shaper", shaper, optional=True)
    _check_callable("progress", progress)
    _check_callable("on_progress", on_progress, optional=True)
    if isinstance(on_progress, type):  # a class is callable, but not with (done, total, what)
        raise InvalidParameter(f"on_progress: expected a function, got the class {on_progress}")
    make = shaper if shaper is not None else _exact_shaper
    rng = np.random.default_rng(check_seed("seed", seed))
    sh = _Tally(f"PolytopeShaper exact, dt = {dt:g} s" if shaper is None else "shaper under test")
    fl = _Tally(f"SafetyFilter workspace rows (CartesianPoint), dt = {dt:g} s")
    polys = 0
    seen: list[int] = []
    seen_f: list[int] = []
    done_f = 0
    next_report = time.perf_counter() + 10.0
    next_tick = 0.0
    while sh.states < total or done_f < nf:
        dim = dl[polys % len(dl)]
        scale = float(10.0 ** rng.uniform(-1.0, 1.0))
        P = random_polytope(rng, dim, scale=scale)
        polys += 1
        seen.append(dim)
        size = float(np.max(np.abs(np.asarray(P.vertices) - P.chebyshev_center)))
        speed = size * float(10.0 ** rng.uniform(-1.0, 1.5))
        r = float(P.chebyshev_radius)
        buffers = (0.02 * r, 0.2 * r, 0.9 * r)
        if sh.states < total:
            k = min(per, total - sh.states)
            st = _vertex_states(rng, P, k, speed)
            t0 = time.perf_counter()
            Y = np.empty_like(st.X)
            for j, part in enumerate(np.array_split(np.arange(k), len(buffers))):
                Y[part] = make(P, buffers[j], dt).shape_batch(st.X[part], st.U[part])
            sh.seconds += time.perf_counter() - t0
            sh.add(P, size, st, Y, dt, buffers)
        if done_f < nf and dim <= _FILTER_MAX_DIM:
            share = -(-per * nf * len(dl) // (max(total, 1) * eligible))
            k = min(max(1, share), nf - done_f)
            st = _vertex_states(rng, P, k, speed)
            t0 = time.perf_counter()
            Y, failed = _filter_steps(P, st, buffers, speed, dt)
            fl.seconds += time.perf_counter() - t0
            fl.add(P, size, st, Y, dt, buffers, failed)
            seen_f.append(dim)
            done_f += k
        now = time.perf_counter()
        if on_progress is not None and now >= next_tick:
            next_tick = now + TICK
            on_progress(
                sh.states + done_f, total + nf, f"shaper {sh.states:,}/{total:,} states, "
                f"filter {done_f:,}/{nf:,}, {polys} polytopes",
            )  # fmt: skip
        if now >= next_report:
            next_report = now + 10.0
            progress(
                f"vertex campaign: shaper {sh.states:,}/{total:,} (escapes {sh.escapes}), "
                f"filter {done_f:,}/{nf:,} (escapes {fl.escapes}), {polys} polytopes"
            )
    out = [sh.result(polys, seen)]
    if nf:
        out.append(fl.result(len(seen_f), seen_f))
    return out


@any_start()
def _filter_steps(
    P: Any, st: _States, buffers: Sequence[float], speed: float, dt: float
) -> tuple[FloatArray, NDArray[np.bool_]]:
    """One filter cycle per state (joint mode on a CartesianPoint): outputs and failures."""
    from velfence.filter import JointLimits, SafetyFilter, WorkspaceLimit

    n, dim = st.X.shape
    robot = CartesianPoint(dim=dim)
    lim = JointLimits(
        np.full(dim, -np.inf), np.full(dim, np.inf), max_speed=np.full(dim, 10.0 * speed)
    )
    Y = np.zeros((n, dim))
    failed = np.zeros(n, dtype=bool)
    for j, part in enumerate(np.array_split(np.arange(n), len(buffers))):
        ws = WorkspaceLimit(P, buffer=buffers[j], spring_gain=1.0)
        flt = SafetyFilter(robot, limits=lim, workspace=ws, dt=dt)
        for i in part:
            try:
                Y[i] = flt.filter(st.X[i], st.U[i])
            except Exception:
                failed[i] = True
    return Y, failed


# ------------------------------------------------------------------------ closed-loop soak
RobotName = Literal["ur5e", "panda", "ur5e-dh"]
_ROBOTS: tuple[RobotName, ...] = ("ur5e", "panda", "ur5e-dh")
_DEFAULT_ROBOTS: tuple[RobotName, ...] = ("ur5e", "panda")
_LABELS = {"ur5e": "UR5e", "panda": "Panda", "ur5e-dh": "UR5e (DHChain)"}


@dataclass(frozen=True)
class LoopResult:
    """What a closed-loop filter campaign measured.

    Attributes:
        name: Robot and rate.
        robot: ``"ur5e"`` or ``"panda"`` (the MuJoCo models of :mod:`velfence.robots`), or
            ``"ur5e-dh"`` (``DHChain.ur5e``: the filter's fused compiled route).
        rate: Control rate [Hz] (``dt = 1 / rate`` set on the filter).
        episodes: Episodes run.
        resting: Of those, episodes starting with the tool on two planes and joints at limits.
        steps: Closed-loop steps in total.
        workspace_escapes: Steps that began inside every workspace limit and ended outside one
            by more than the tolerance.
        max_workspace_escape: Largest depth outside after such a step [m].
        deepened: Steps that began outside and went further out by more than the tolerance.
        max_deepened: Largest such growth of the depth outside in one step [m].
        max_depth: Largest depth outside any workspace limit reached at any step of an episode
            that started inside [m] (an escape followed by a drift shows here).
        joint_crossings: Steps that began within the joint limits and ended beyond one by more
            than the tolerance.
        max_joint_crossing: Largest such excess [rad].
        sphere_penetrations: Steps that began clear of every sphere and ended inside one.
        max_sphere_penetration: Largest depth inside after such a step [m].
        nonfinite: Non-finite outputs.
        exceptions: Cycles that raised.
        exception_kinds: Exception type name → count.
        deadline_fallbacks: Cycles flagged by ``result.deadline`` (0 where not reported).
        max_rows: Largest number of rows of a cycle.
        stages: Stage → number of cycles that reported it.
        escape_stages: Stages of the cycles that let the tool out (stage tuple → count).
        seconds: Wall time [s].
        example: The first workspace escape as plain data (robot, rate, ``q``, command ``v``,
            ``mode``, joint limits ``lo``/``hi``/``vmax``/``amax``, facets ``N``, ``o`` with
            their limit ``W`` and the limits' buffers ``B``, spheres ``C``, ``R``, the previous
            output, the output ``x``, ``stages``, distances ``d0``, ``d1``), or ``None``; saved
            by ``--examples`` and replayed by ``replay_loop_example``.
    """

    name: str
    robot: str
    rate: float
    episodes: int
    resting: int
    steps: int
    workspace_escapes: int
    max_workspace_escape: float
    deepened: int
    max_deepened: float
    max_depth: float
    joint_crossings: int
    max_joint_crossing: float
    sphere_penetrations: int
    max_sphere_penetration: float
    nonfinite: int
    exceptions: int
    exception_kinds: dict[str, int]
    deadline_fallbacks: int
    max_rows: int
    stages: dict[str, int]
    escape_stages: dict[str, int]
    seconds: float
    example: dict[str, Any] | None = None

    @property
    def contained(self) -> bool:
        """No escape, crossing, penetration, non-finite output or exception."""
        return not (
            self.workspace_escapes
            or self.joint_crossings
            or self.sphere_penetrations
            or self.nonfinite
            or self.exceptions
        )


def _robot(name: str) -> tuple[Any, FloatArray]:
    """The model (capsule links of 5 cm, a 5 cm tool) and its joint speed limits [rad/s]."""
    from velfence.robots import panda, ur5e

    if name == "ur5e-dh":
        from velfence.mechanisms.chain import DHChain

        chain = DHChain.ur5e(link_radius=0.05, tool=(0.0, 0.0, 0.05))
        return chain, np.full(6, math.pi)
    build = ur5e if name == "ur5e" else panda
    model = build(radius=0.05, tool=(0.0, 0.0, 0.05))
    return model, np.asarray(model.velocity_limits, dtype=np.float64)


@dataclass
class _Episode:
    """One randomised episode: the filter and what the measurement needs."""

    flt: Any
    q: FloatArray
    lo: FloatArray
    hi: FloatArray
    N: FloatArray  # all workspace facets stacked (m, 3); n·p >= o inside
    o: FloatArray
    centres: FloatArray  # (k, 3)
    radii: FloatArray  # (k,)
    twist: bool
    resting: bool
    limit_of_row: NDArray[np.int64]  # workspace limit index of each row of N
    buffers: FloatArray  # buffer of each workspace limit [m]
    acc: FloatArray | None  # joint acceleration limits [rad/s²]


def _unit(rng: Rng, k: int = 3) -> FloatArray:
    v = rng.normal(size=k)
    return np.asarray(v / np.linalg.norm(v), dtype=np.float64)


FilterFactory = Callable[..., Any]
"""Builds the filter under test with ``SafetyFilter``'s arguments (robot, limits=, workspace=,
obstacles=, dt=); its ``explain(q, u)`` and ``explain_twist(q, v)`` return a result with
``output``, ``stages`` and ``constraint_names``."""


def _episode(
    rng: Rng,
    robot: Any,
    vmax: FloatArray,
    dt: float,
    *,
    resting: bool,
    make: FilterFactory | None = None,
) -> _Episode:
    """A random scene around a random start (module docstring)."""
    from velfence.filter import JointLimits, SafetyFilter, SphereObstacle, WorkspaceLimit
    from velfence.geometry.polytope import ConvexPolytope

    n = int(robot.dof)
    lim0 = np.asarray(robot.joint_limits, dtype=np.float64)  # (n, 2)
    span = np.minimum(lim0[:, 1] - lim0[:, 0], 2.0 * math.pi)
    q = lim0[:, 0] + (lim0[:, 1] - lim0[:, 0] - span) / 2 + span * rng.uniform(0.1, 0.9, n)
    lo = np.maximum(lim0[:, 0], q - rng.uniform(0.1, 2.0, n))
    hi = np.minimum(lim0[:, 1], q + rng.uniform(0.1, 2.0, n))
    if resting or rng.random() < 0.2:
        for j in rng.choice(n, size=int(rng.integers(2, 4)), replace=False):
            if rng.random() < 0.5:
                lo[j] = q[j]
            else:
                hi[j] = q[j]
    acc = None
    if rng.random() < 0.3:
        acc = np.full(n, float(rng.uniform(5.0, 30.0)))
    limits = JointLimits(lo, hi, max_speed=vmax, max_acceleration=acc)
    p = np.asarray(robot.fk(q), dtype=np.float64)
    rows_n: list[FloatArray] = []
    rows_o: list[float] = []
    ws: list[Any] = []
    shape = "planes" if resting else str(rng.choice(["box", "planes", "both"]))
    if shape in ("box", "both"):
        lower = p - rng.uniform(0.0 if rng.random() < 0.3 else 0.01, 0.3, 3)
        upper = p + rng.uniform(0.01, 0.3, 3)
        box = ConvexPolytope.box(lower, upper)
        ws.append(WorkspaceLimit(box, buffer=float(rng.uniform(0.01, 0.05))))
    if shape in ("planes", "both"):
        k = 2 if resting else int(rng.integers(1, 3))
        N = np.empty((k, 3))
        o = np.empty(k)
        for i in range(k):
            axis = np.zeros(3)
            axis[int(rng.integers(0, 3))] = 1.0 if rng.random() < 0.5 else -1.0
            nrm = axis + 0.8 * rng.uniform(0.0, 1.0) * _unit(rng)
            N[i] = nrm / np.linalg.norm(nrm)
            o[i] = float(N[i] @ p) - (0.0 if resting else float(rng.uniform(0.0, 0.1)))
        try:
            planes = ConvexPolytope(N, o)
        except InvalidGeometry:
            planes = ConvexPolytope(N[:1], o[:1])
        ws.append(WorkspaceLimit(planes, buffer=float(rng.uniform(0.01, 0.05))))
    owner: list[int] = []
    for k, w in enumerate(ws):
        rows_n.append(np.asarray(w.polytope.normals))
        rows_o.extend(np.asarray(w.polytope.offsets).tolist())
        owner.extend([k] * w.polytope.n_facets)
    # Spheres near the links, clear of them at the start.
    seg = np.asarray(robot.link_segments(q), dtype=np.float64)
    lrad = np.asarray(robot.link_radius, dtype=np.float64)
    centres: list[FloatArray] = []
    radii: list[float] = []
    for _ in range(int(rng.integers(0, 5))):
        for _try in range(20):
            L = int(rng.integers(1, seg.shape[0]))
            a = seg[L, 0] + rng.uniform(0.0, 1.0) * (seg[L, 1] - seg[L, 0])
            R = float(rng.uniform(0.02, 0.1))
            c = a + (R + float(lrad[L]) + float(rng.uniform(0.02, 0.25))) * _unit(rng)
            if clearance(seg, lrad, c[None, :], np.array([R])) > 0.01:
                centres.append(c)
                radii.append(R)
                break
    obstacles = [SphereObstacle(c, radius=r) for c, r in zip(centres, radii, strict=True)]
    build = SafetyFilter if make is None else make
    flt = build(robot, limits=limits, workspace=ws, obstacles=obstacles, dt=dt)
    return _Episode(
        flt=flt,
        q=q,
        lo=lo,
        hi=hi,
        N=np.vstack(rows_n) if rows_n else np.zeros((0, 3)),
        o=np.asarray(rows_o, dtype=np.float64),
        centres=np.asarray(centres, dtype=np.float64).reshape(-1, 3),
        radii=np.asarray(radii, dtype=np.float64),
        twist=resting or bool(rng.random() < 0.5),
        resting=resting,
        limit_of_row=np.asarray(owner, dtype=np.int64),
        buffers=np.array([w.buffer for w in ws], dtype=np.float64),
        acc=acc,
    )


def clearance(seg: FloatArray, lrad: FloatArray, C: FloatArray, R: FloatArray) -> float:
    """Smallest clearance between the capsule links and the spheres [m] (inf: no sphere).

    Args:
        seg: The links' segments, shape (L, 2, 3) [m] (``robot.link_segments(q)``).
        lrad: The links' capsule radii, shape (L,) [m].
        C: Sphere centres, shape (k, 3) [m].
        R: Sphere radii, shape (k,) [m].

    Returns:
        The smallest surface distance over every link and sphere [m]; negative: a penetration.

    Raises:
        InvalidInput: arrays of the wrong shape, or non-finite or negative entries.
    """
    seg = real_array("seg", seg, (None, 2, 3), what="link segments [m]", copy=False)
    lrad = real_array("lrad", lrad, (None,), what="capsule radii [m]", copy=False)
    C = real_array("C", C, (None, 3), what="sphere centres [m]", copy=False)
    R = real_array("R", R, (None,), what="sphere radii [m]", copy=False)
    if lrad.shape[0] != seg.shape[0]:
        raise InvalidInput(f"seg, lrad: {seg.shape[0]} link segments but {lrad.shape[0]} radii")
    if R.shape[0] != C.shape[0]:
        raise InvalidInput(f"C, R: {C.shape[0]} sphere centres but {R.shape[0]} radii")
    if np.any(lrad < 0.0) or np.any(R < 0.0):
        raise InvalidInput("lrad, R: expected radii >= 0 [m]")
    if C.shape[0] == 0 or seg.shape[0] == 0:
        return math.inf
    A = seg[:, 0]
    E = seg[:, 1] - A
    ee = np.einsum("ij,ij->i", E, E)
    rel = C[:, None, :] - A[None, :, :]
    t = np.clip(np.einsum("psk,sk->ps", rel, E) / np.where(ee > 0.0, ee, 1.0), 0.0, 1.0)
    t = np.where(ee > 0.0, t, 0.0)
    diff = rel - t[:, :, None] * E[None, :, :]
    dist = np.sqrt(np.einsum("psk,psk->ps", diff, diff)) - lrad[None, :] - R[:, None]
    return float(dist.min())


def soak_command(
    rng: Rng,
    *,
    twist: bool,
    N: FloatArray,
    o: FloatArray,
    p: FloatArray,
    vmax: FloatArray,
    rate: float,
    push_probability: float = 0.4,
) -> tuple[FloatArray, int]:
    """The closed-loop soak's operator: a new command and the steps it is held (20-200 ms).

    In twist mode a push (with probability ``push_probability`` when there are facets) drives
    at the nearest workspace facet with up to half its length of random tangential part, at
    0.05-1 m/s; otherwise a random direction at 0-1 m/s. In joint mode a random joint velocity
    of 10-100 % of ``vmax`` (the push draw is made but unused, as in the soak).

    Args:
        rng: Random generator (its draws are the soak's, in the soak's order).
        twist: Twist mode (a TCP velocity [m/s], shape (3,)) or joint mode ([rad/s], (dof,)).
        N: Workspace facets' inward normals, shape (m, 3) (``N p >= o`` inside).
        o: Their offsets [m], shape (m,).
        p: The TCP [m], shape (3,).
        vmax: Joint speed limits [rad/s], shape (dof,).
        rate: Control rate [Hz] (the hold in steps).
        push_probability: Share of commands that push at the nearest facet, in [0, 1].

    Returns:
        ``(command, hold)``: the command and the number of steps it is held (>= 1).

    Raises:
        InvalidInput: facets, TCP or speed limits of the wrong shape or not finite.
        InvalidParameter: a non-positive ``rate`` or a ``push_probability`` outside [0, 1].
    """
    twist = check_flag("twist", twist)
    N = real_array("N", N, (None, 3), what="facet normals", copy=False)
    o = real_array("o", o, (None,), what="facet offsets [m]", copy=False)
    if o.shape[0] != N.shape[0]:
        raise InvalidInput(f"N, o: {N.shape[0]} facet normals but {o.shape[0]} offsets")
    p = real_array("p", p, (3,), what="the TCP [m]", copy=False)
    vmax = real_array("vmax", vmax, (None,), what="joint speed limits [rad/s]", copy=False)
    if vmax.shape[0] == 0:
        raise InvalidInput("vmax: expected at least one joint speed limit [rad/s], got none")
    rate = check_positive("rate", rate, unit="Hz")
    push_probability = check_range("push_probability", push_probability, low=0.0, high=1.0)
    hold = max(1, round(float(rng.uniform(0.02, 0.2)) * rate))
    push = N.shape[0] > 0 and rng.random() < push_probability
    cmd: FloatArray
    if twist:
        if push:
            i = int(np.argmin(N @ p - o))
            cmd = -N[i] + 0.5 * rng.uniform(0.0, 1.0) * _unit(rng)
            cmd *= float(rng.uniform(0.05, 1.0)) / np.linalg.norm(cmd)
        else:
            cmd = _unit(rng) * float(rng.uniform(0.0, 1.0))
    else:
        cmd = rng.uniform(-1.0, 1.0, vmax.shape[0]) * vmax * float(rng.uniform(0.1, 1))
    return cmd, hold


@any_start()
def run_loop_campaign(
    robot: RobotName,
    rate: float,
    *,
    steps: int = 100_000,
    episode_steps: int = 500,
    resting_fraction: float = 0.25,
    make_filter: FilterFactory | None = None,
    seed: int = 0,
    progress: Progress = _quiet,
    on_progress: OnProgress | None = None,
) -> LoopResult:
    """Run the closed-loop filter soak (module docstring) on one robot at one rate.

    Args:
        robot: ``"ur5e"`` or ``"panda"`` (the MuJoCo models of :mod:`velfence.robots`), or
            ``"ur5e-dh"`` (``DHChain.ur5e``: the filter's fused compiled route).
        rate: Control rate [Hz], > 0 (``dt = 1 / rate``).
        steps: Closed-loop steps in total (rounded up to whole episodes), >= 1.
        episode_steps: Steps per episode, >= 1.
        resting_fraction: Share of episodes starting with the tool on two planes and joints at
            their limits, in [0, 1].
        make_filter: Builds the filter under test (default ``SafetyFilter``); the tests plant
            broken ones.
        seed: Seed of the random generator.
        progress: Called with a line of progress now and then (every 10 s).
        on_progress: Called about four times a second as ``on_progress(done, total, what)``
            (closed-loop steps; a command passes :func:`velfence.apps.progress.update`).

    Returns:
        The campaign's :class:`LoopResult`.

    Raises:
        InvalidParameter: an unknown robot, a rate, count or fraction out of range.
    """
    if robot not in _ROBOTS:
        raise InvalidParameter(f"robot: expected one of {list(_ROBOTS)}, got {robot!r}")
    rate = check_positive("rate", rate, unit="Hz")
    total = check_positive_int("steps", steps, maximum=10**9)
    per = check_positive_int("episode_steps", episode_steps, maximum=10**7)
    frac = check_positive("resting_fraction", resting_fraction, allow_zero=True)
    if frac > 1.0:
        raise InvalidParameter(f"resting_fraction must be in [0, 1], got {frac}")
    _check_callable("make_filter", make_filter, optional=True)
    _check_callable("progress", progress)
    _check_callable("on_progress", on_progress, optional=True)
    if isinstance(on_progress, type):  # a class is callable, but not with (done, total, what)
        raise InvalidParameter(f"on_progress: expected a function, got the class {on_progress}")
    rng = np.random.default_rng(check_seed("seed", seed))
    model, vmax = _robot(robot)
    dt = 1.0 / rate
    lrad = np.asarray(model.link_radius, dtype=np.float64)
    episodes = -(-total // per)
    ws_esc = deep = jc = sp = nonfinite = exc = deadline = resting_n = max_rows = 0
    ws_max = j_max = s_max = deep_max = depth_max = 0.0
    kinds: Counter[str] = Counter()
    stages: Counter[str] = Counter()
    esc_stages: Counter[str] = Counter()
    example: dict[str, Any] | None = None
    t0 = time.perf_counter()
    next_report = t0 + 10.0
    next_tick = 0.0
    done = 0
    for e in range(episodes):
        ep = _episode(rng, model, vmax, dt, resting=bool(rng.random() < frac), make=make_filter)
        resting_n += ep.resting
        q = ep.q
        p = np.asarray(model.fk(q), dtype=np.float64)
        d_ws = float(np.min(ep.N @ p - ep.o, initial=math.inf))
        clear = clearance(np.asarray(model.link_segments(q)), lrad, ep.centres, ep.radii)
        began_inside = d_ws >= -ROUND_OFF * (1.0 + float(np.max(np.abs(p))))
        cmd = np.zeros(3)
        change = 0
        previous: FloatArray | None = None
        for _k in range(per):
            change -= 1
            if change <= 0:  # a new command, held for 20-200 ms
                cmd, change = soak_command(rng, twist=ep.twist, N=ep.N, o=ep.o, p=p, vmax=vmax,
                                           rate=rate)  # fmt: skip
            try:
                res = ep.flt.explain_twist(q, cmd) if ep.twist else ep.flt.explain(q, cmd)
                x = np.asarray(res.output, dtype=np.float64)
                stg = tuple(res.stages)
                if getattr(res, "deadline", None) is not None:
                    deadline += 1
                max_rows = max(max_rows, len(res.constraint_names))
            except Exception as err:
                exc += 1
                kinds[type(err).__name__] += 1
                x = np.zeros(q.shape[0])
                stg = ("exception",)
            for s in stg:
                stages[s] += 1
            if not np.all(np.isfinite(x)):
                nonfinite += 1
                x = np.zeros(q.shape[0])
            q1 = q + x * dt
            p1 = np.asarray(model.fk(q1), dtype=np.float64)
            tol = ROUND_OFF * (1.0 + float(np.max(np.abs(p1))))
            d1 = float(np.min(ep.N @ p1 - ep.o, initial=math.inf))
            if d_ws >= -tol and d1 < -tol:
                ws_esc += 1
                ws_max = max(ws_max, -d1)
                esc_stages[", ".join(stg)] += 1
                if example is None:
                    example = _example(robot, rate, ep, vmax, q, cmd, previous, x, stg, d_ws, d1)
            elif d_ws < -tol and d1 < d_ws - tol:
                deep += 1
                deep_max = max(deep_max, d_ws - d1)
            if began_inside:
                depth_max = max(depth_max, -d1)
            tq = ROUND_OFF * (1.0 + np.abs(q1))
            inside = (q >= ep.lo - tq) & (q <= ep.hi + tq)
            over = np.maximum(ep.lo - q1, q1 - ep.hi)
            cross = inside & (over > tq)
            if cross.any():
                jc += 1
                j_max = max(j_max, float(over[cross].max()))
            c1 = clearance(np.asarray(model.link_segments(q1)), lrad, ep.centres, ep.radii)
            if clear >= -tol and c1 < -tol:
                sp += 1
                s_max = max(s_max, -c1)
            q, p, d_ws, clear, previous = q1, p1, d1, c1, x
            done += 1
            now = time.perf_counter()
            if on_progress is not None and now >= next_tick:
                next_tick = now + TICK
                on_progress(done, episodes * per, f"{robot} {rate:g} Hz: step {done:,}")
            if now >= next_report:
                next_report = now + 10.0
                progress(
                    f"{robot} {rate:g} Hz: {done:,}/{episodes * per:,} steps, episode {e + 1}, "
                    f"escapes {ws_esc}, crossings {jc}, penetrations {sp}, exceptions {exc}"
                )
    return LoopResult(
        name=f"{_LABELS[robot]}, {rate:g} Hz",
        robot=robot,
        rate=rate,
        episodes=episodes,
        resting=resting_n,
        steps=done,
        workspace_escapes=ws_esc,
        max_workspace_escape=ws_max,
        deepened=deep,
        max_deepened=deep_max,
        max_depth=depth_max,
        joint_crossings=jc,
        max_joint_crossing=j_max,
        sphere_penetrations=sp,
        max_sphere_penetration=s_max,
        nonfinite=nonfinite,
        exceptions=exc,
        exception_kinds=dict(kinds),
        deadline_fallbacks=deadline,
        max_rows=max_rows,
        stages=dict(stages),
        escape_stages=dict(esc_stages),
        seconds=time.perf_counter() - t0,
        example=example,
    )


def _example(
    robot: str,
    rate: float,
    ep: _Episode,
    vmax: FloatArray,
    q: FloatArray,
    cmd: FloatArray,
    previous: FloatArray | None,
    x: FloatArray,
    stages: tuple[str, ...],
    d0: float,
    d1: float,
) -> dict[str, Any]:
    """One cycle's state and scene as plain data (see :attr:`LoopResult.example`)."""
    return {
        "robot": robot,
        "rate": float(rate),
        "q": q.copy(),
        "v": np.array(cmd, dtype=np.float64),
        "mode": "twist" if ep.twist else "joint",
        "lo": ep.lo.copy(),
        "hi": ep.hi.copy(),
        "vmax": vmax.copy(),
        "amax": np.zeros(0) if ep.acc is None else ep.acc.copy(),
        "N": ep.N.copy(),
        "o": ep.o.copy(),
        "W": ep.limit_of_row.copy(),
        "B": ep.buffers.copy(),
        "C": ep.centres.copy(),
        "R": ep.radii.copy(),
        "previous": np.zeros(0) if previous is None else previous.copy(),
        "x": x.copy(),
        "stages": ", ".join(stages),
        "d0": float(d0),
        "d1": float(d1),
    }


@any_start()
def replay_loop_example(example: Any) -> tuple[FloatArray, float, float, tuple[str, ...]]:
    """Run the cycle of a saved closed-loop example again (:attr:`LoopResult.example`).

    Args:
        example: The example dict, or a mapping loaded from its ``.npz`` (``np.load``).

    Returns:
        ``(x, d0, d1, stages)``: the output, the workspace distance before and after one step
        [m], and the cycle's stages.

    Raises:
        InvalidParameter: an unknown robot name.
    """
    from velfence.filter import JointLimits, SafetyFilter, SphereObstacle, WorkspaceLimit
    from velfence.geometry.polytope import ConvexPolytope

    ex = {k: example[k] for k in example}
    name = str(ex["robot"])
    if name not in _ROBOTS:
        raise InvalidParameter(f"example: robot {name!r} is not one of {list(_ROBOTS)}")
    model, _ = _robot(name)
    amax = np.asarray(ex["amax"], dtype=np.float64)
    limits = JointLimits(
        ex["lo"], ex["hi"], max_speed=ex["vmax"], max_acceleration=amax if amax.size else None
    )
    N = np.asarray(ex["N"], dtype=np.float64)
    o = np.asarray(ex["o"], dtype=np.float64)
    W = np.asarray(ex["W"], dtype=np.int64)
    ws = [
        WorkspaceLimit(ConvexPolytope(N[np.equal(W, k)], o[np.equal(W, k)]), buffer=float(b))
        for k, b in enumerate(np.asarray(ex["B"], dtype=np.float64))
    ]
    obstacles = [
        SphereObstacle(c, radius=float(r))
        for c, r in zip(np.asarray(ex["C"]).reshape(-1, 3), np.asarray(ex["R"]), strict=True)
    ]
    dt = 1.0 / float(ex["rate"])
    flt = SafetyFilter(model, limits=limits, workspace=ws, obstacles=obstacles, dt=dt)
    q = np.asarray(ex["q"], dtype=np.float64)
    prev = np.asarray(ex["previous"], dtype=np.float64)
    previous = prev if prev.size else None
    if str(ex["mode"]) == "twist":
        res = flt.explain_twist(q, ex["v"], previous=previous)
    else:
        res = flt.explain(q, ex["v"], previous=previous)
    x = np.asarray(res.output, dtype=np.float64)
    d0 = float(np.min(N @ np.asarray(model.fk(q)) - o))
    d1 = float(np.min(N @ np.asarray(model.fk(q + x * dt)) - o))
    return x, d0, d1, tuple(res.stages)


# ------------------------------------------------------------------------------- report
def render_markdown(
    results: Sequence[VertexResult | LoopResult],
    *,
    command: str,
    notes: str = "",
    intro: str = INTRO,
) -> str:
    """The campaigns' tables as a Markdown section (between the section markers).

    Args:
        results: The campaigns' results (:class:`VertexResult` and :class:`LoopResult`, in
            display order; at least one).
        command: The command that produced them.
        notes: Markdown appended after the tables.
        intro: Markdown before the tables (default: the campaigns' description).

    Returns:
        The section, starting with :data:`SECTION_BEGIN` and ending with :data:`SECTION_END`.

    Raises:
        InvalidParameter: wrong result types, ``command`` or ``notes`` not text.
    """
    if (
        not isinstance(results, list | tuple)
        or not results
        or not all(isinstance(r, VertexResult | LoopResult) for r in results)
    ):
        raise InvalidParameter(
            "results: expected a non-empty list or tuple of VertexResult and LoopResult, got "
            f"{describe(results)}"
        )
    vertex = [r for r in results if isinstance(r, VertexResult)]
    loops = [r for r in results if isinstance(r, LoopResult)]
    command = check_text("command", command)
    notes = check_text("notes", notes, max_length=100_000)
    intro = check_text("intro", intro, max_length=100_000)
    out = [SECTION_BEGIN, intro, f"Produced by `{command}`.\n"]
    if vertex:
        out.append(
            "| implementation | states | dims | escapes | max escape (abs / rel. to scale) "
            "| non-finite | exceptions | escapes by kind | states/s |\n"
            "| --- | ---: | --- | ---: | ---: | ---: | ---: | --- | ---: |"
        )
        for v in vertex:
            kinds = ", ".join(f"{k} {c}" for k, c in sorted(v.kinds.items())) or "—"
            rate = v.states / v.seconds if v.seconds > 0 else math.inf
            out.append(
                f"| {v.name} | {v.states:,} | {_span(v.dims)} | {v.escapes:,} | "
                f"{v.max_escape:.3g} / {v.max_escape_relative:.3g} | {v.nonfinite:,} | "
                f"{v.exceptions:,} | {kinds} | {rate:,.0f} |"
            )
        out.append("")
    if loops:
        out.append(
            "| robot, rate | steps | episodes (resting) | ws escapes | max escape [m] | "
            "max depth [m] | "
            "deepened (max [m]) | joint crossings | sphere penetrations (max [m]) | non-finite | "
            "exceptions | deadline | max rows | steps/s |\n"
            "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: "
            "| ---: | ---: |"
        )
        for r in loops:
            rate = r.steps / r.seconds if r.seconds > 0 else math.inf
            out.append(
                f"| {r.name} | {r.steps:,} | {r.episodes} ({r.resting}) | "
                f"{r.workspace_escapes:,} | {r.max_workspace_escape:.3g} | "
                f"{max(r.max_depth, 0.0):.3g} | "
                f"{r.deepened:,} ({r.max_deepened:.3g}) | "
                f"{r.joint_crossings:,} | {r.sphere_penetrations:,} "
                f"({r.max_sphere_penetration:.3g}) | {r.nonfinite:,} | {r.exceptions:,} | "
                f"{r.deadline_fallbacks:,} | {r.max_rows} | {rate:,.0f} |"
            )
        out.append("")
        seen: Counter[str] = Counter()
        esc: Counter[str] = Counter()
        for r in loops:
            seen.update(r.stages)
            esc.update(r.escape_stages)
        out.append(
            "Stages seen (cycles): "
            + ", ".join(f"`{s}` {c:,}" for s, c in seen.most_common())
            + "."
        )
        if esc:
            out.append(
                "\nStages of the escaping cycles: "
                + "; ".join(f"`{s}` ×{c}" for s, c in esc.most_common())
                + "."
            )
        out.append("")
    out.append(notes)
    out.append(SECTION_END)
    return "\n".join(out) + "\n"


def _span(dims: Sequence[int]) -> str:
    """``"3"`` or ``"3–7"``."""
    lo, hi = min(dims, default=0), max(dims, default=0)
    return f"{lo}" if lo == hi else f"{lo}–{hi}"


def write_section(path: Any, section: str) -> None:
    """Replace the marked section of a Markdown file with ``section`` (append it if absent).

    The old section's text from :data:`HISTORY` to its end (a record of earlier runs) is kept,
    placed at the end of the new section.
    """
    from pathlib import Path

    p = Path(path)
    text = p.read_text() if p.exists() else ""
    a, b = text.find(SECTION_BEGIN), text.find(SECTION_END)
    if a >= 0 and b > a:
        h = text.find(HISTORY, a, b)
        body = section.rstrip("\n")
        if h >= 0 and HISTORY not in section and body.endswith(SECTION_END):
            section = body[: -len(SECTION_END)] + text[h:b] + SECTION_END
        text = text[:a] + section.rstrip("\n") + text[b + len(SECTION_END) :]
    else:
        text = text.rstrip("\n") + ("\n\n" if text else "") + section
    p.write_text(text if text.endswith("\n") else text + "\n")


def _revision() -> str:
    """`` on <commit>`` of the source tree velfence runs from, or ``""`` outside a git checkout."""
    import subprocess
    from pathlib import Path

    try:
        out = subprocess.run(
            ["git", "rev-parse", "--short", "HEAD"],
            cwd=Path(__file__).resolve().parent,
            capture_output=True,
            text=True,
            timeout=10,
            check=True,
        ).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return ""
    return f" on {out}" if out else ""


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m velfence.apps.soak_filter``: run both campaigns, print and write the section.

    Progress goes to stderr through :mod:`velfence.apps.progress` (a live line with the ETA on
    a terminal, one line per finished campaign and a heartbeat otherwise; ``--quiet``: neither);
    stdout gets one result line per campaign, then the closing summary (the files written, the
    first escapes saved with ``--examples``, and the verdict).
    """
    import argparse
    import os
    from pathlib import Path

    from velfence.apps import progress

    ap = argparse.ArgumentParser(prog="python -m velfence.apps.soak_filter", description=__doc__)
    ap.add_argument("--vertex-states", type=int, default=1_000_000, help="shaper states")
    ap.add_argument("--filter-states", type=int, default=100_000, help="filter vertex states")
    ap.add_argument("--steps", type=int, default=1_000_000, help="closed-loop steps in total")
    ap.add_argument("--episode-steps", type=int, default=500)
    ap.add_argument("--rates", type=str, default="1000,500,100", help="control rates [Hz]")
    ap.add_argument(
        "--robots", type=str, default=",".join(_DEFAULT_ROBOTS), help=f"from {list(_ROBOTS)}"
    )
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=str, default=None, help="Markdown file whose section to write")
    ap.add_argument(
        "--examples",
        type=str,
        default=None,
        help="directory to save each closed-loop case's first escape in (.npz)",
    )
    ap.add_argument(
        "--quiet", "-q", action="store_true", help="no progress on stderr (results only)"
    )
    args = ap.parse_args(argv)
    rates = [float(r) for r in args.rates.split(",") if r.strip()]
    robots = [r.strip() for r in args.robots.split(",") if r.strip()]
    bad = [r for r in robots if r not in _ROBOTS]
    if bad:
        ap.error(f"--robots: expected names from {list(_ROBOTS)}, got {bad}")
    cases = [(rb, rt) for rb in robots for rt in rates] if args.steps > 0 else []
    each = max(args.episode_steps, args.steps // len(cases)) if cases else 0
    # Weights: about the seconds of each stage (a filter cycle costs ~20 shaper states).
    plan = [("vertex campaign", (args.vertex_states + 20 * args.filter_states) / 2e5)] * (
        args.vertex_states > 0
    ) + [(f"{_LABELS[rb]}, {rt:g} Hz", each / 5e3) for rb, rt in cases]
    vertex: list[VertexResult] = []
    loops: list[LoopResult] = []
    written: list[Path] = []
    with progress.Tracker(plan or [("nothing", 0.0)], title="soak_filter", quiet=args.quiet):
        if args.vertex_states > 0:
            with progress.stage("vertex campaign") as report:
                vertex = run_vertex_campaign(
                    states=args.vertex_states,
                    filter_states=args.filter_states,
                    seed=args.seed,
                    on_progress=report,
                )
            for v in vertex:
                print(
                    f"{v.name}: {v.states:,} states, escapes {v.escapes}, max escape "
                    f"{v.max_escape:.3g} ({v.max_escape_relative:.3g} of scale), non-finite "
                    f"{v.nonfinite}, exceptions {v.exceptions}, by kind {v.kinds}",
                    flush=True,
                )
        for i, (rb, rt) in enumerate(cases):
            with progress.stage(f"{_LABELS[rb]}, {rt:g} Hz") as report:
                r = run_loop_campaign(
                    rb,
                    rt,
                    steps=each,
                    episode_steps=args.episode_steps,
                    seed=args.seed + i,
                    on_progress=report,
                )
            print(
                f"{r.name}: {r.steps:,} steps, {r.episodes} episodes ({r.resting} resting), "
                f"ws escapes {r.workspace_escapes} (max {r.max_workspace_escape:.3g} m, depth "
                f"{max(r.max_depth, 0.0):.3g} m), "
                f"deepened {r.deepened} (max {r.max_deepened:.3g} m), joint crossings "
                f"{r.joint_crossings}, penetrations "
                f"{r.sphere_penetrations} (max {r.max_sphere_penetration:.3g} m), non-finite "
                f"{r.nonfinite}, exceptions {r.exceptions} {r.exception_kinds}, deadline "
                f"{r.deadline_fallbacks}, escape stages {r.escape_stages}",
                flush=True,
            )
            loops.append(r)
            if args.examples is not None and r.example is not None:
                folder = Path(args.examples)
                folder.mkdir(parents=True, exist_ok=True)
                path = folder / f"loop_{rb}_{rt:g}hz_seed{args.seed + i}.npz"
                np.savez(path, **r.example)
                written.append(path)
    if args.out is not None and (vertex or loops):
        cmd = (
            f"python -m velfence.apps.soak_filter --vertex-states {args.vertex_states} "
            f"--filter-states {args.filter_states} --steps {args.steps} "
            f"--episode-steps {args.episode_steps} --rates {args.rates} --robots {args.robots} "
            f"--seed {args.seed}"
        )
        load = os.getloadavg()
        stamp = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
        notes = (
            f"Run {stamp}{_revision()}, load average {load[0]:.2f} / {load[1]:.2f} / "
            f"{load[2]:.2f}.\n"
        )
        write_section(args.out, render_markdown([*vertex, *loops], command=cmd, notes=notes))
        written.insert(0, Path(args.out))
    ok = all(v.escapes == 0 and v.nonfinite == 0 and v.exceptions == 0 for v in vertex) and all(
        r.contained for r in loops
    )
    verdict = (
        f"soak_filter: {len(vertex) + len(loops)} campaign result(s) ({len(vertex)} vertex, "
        f"{len(loops)} closed-loop); " + ("contained, exit 0" if ok else "NOT contained, exit 1")
    )
    for line in progress.summary(None, written, verdict):
        print(line)
    return 0 if ok else 1


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
