"""The campaign's fast route: a shard's cases in lock-step, the same closed loop as :func:`run`.

:func:`velfence.apps.verify.cases.run` runs one case at a time, and at about 10 µs for the
filter's C cycle a closed-loop step spent some 200 µs in Python around it: the forward
kinematics of the next state (twice with a push), the links' clearance to the spheres, the
margins, each a handful of small NumPy calls whose fixed cost dwarfs their arithmetic.
:func:`run_batch` runs many cases of one shape (robot, rate, steps, mode, properties) step by
step together: the plant, the servo's lag and latency, the forward kinematics, the clearance,
the margins and the bookkeeping are one NumPy call each over the whole batch, so their fixed
cost is shared by every case; what cannot be shared stays per case: the filter's cycle (each
case has its own limits, box and spheres: one ``SafetyFilter.filter`` call per case and step,
its C cycle when the robot has one), the operator's random draws (each case's own generator,
called only when its command expires) and the scripted jog.

The arithmetic is :func:`run`'s, element by element: the forward kinematics is the chain's one
kinematics pass (``DHChain``'s plain-float composition, column-wise over the batch, with the
C library's ``sin`` and ``cos``: NumPy's where they give :mod:`math`'s values, checked once,
else :mod:`math`'s), the clearance :func:`clearance`'s
``einsum`` contractions with a batch axis, the norms and dot products NumPy's ``vecdot``
(the same BLAS dot as ``np.linalg.norm`` and ``@`` of one vector), the sensor noise drawn in
blocks (a generator's block of draws is its draws one after the other). A case's result is
therefore :func:`run`'s bit for bit, whatever the other cases of its batch
(``tests/apps/verify/test_batch.py`` checks it on random campaigns with pushes, lag, latency,
noise, both modes and every operator).

The arrays of a step are laid out so that every NumPy call takes operands of one shape, the
batch along the last axis where it can (the kinematics' frame columns (3, B), the box's and the
joints' margins facet and joint first, the clearance sphere first): a call that broadcasts,
or takes a Python float, costs a few times the fixed cost of one that does not, at these sizes.
The per-case constants (the DH constants as arrays, the spheres repeated per link, the box's
facets, the joint limits, the servo's gains) are laid out once per batch.

Only the kinematic plant runs here: a scenario of another plant (a ``plant`` field other than
``"kinematic"``) is handed to :func:`run` unchanged, as are the traces (``record``) and the
stop at the first failure of shrinking, which stay :func:`run`'s.
"""

from __future__ import annotations

import functools
import json
import math
import time
from collections.abc import Sequence
from typing import Any

import numpy as np

from velfence._typing import FloatArray
from velfence._validate import check_positive_int, check_text, describe
from velfence.apps.soak_filter import any_start
from velfence.apps.verify.campaign import PROPERTIES
from velfence.apps.verify.cases import (
    CaseResult,
    Scenario,
    build_filter,
    chain,
    draw_command,
    face_tangent,
    jerk_margin,
    progress_margin,
    run,
    step_margin,
    tolerances,
)
from velfence.errors import InvalidParameter
from velfence.filter.ccycle import c_cycle_or_none
from velfence.geometry.projection import PROJECT_DEADLINE, PROJECT_ITERATION_CAP

__all__ = ["BATCH", "run_batch"]

#: Most cases run in lock-step at once (larger shards run in chunks of this many).
BATCH = 128
#: Sensor-noise draws made at once per case [steps].
_NOISE_BLOCK = 256


def _plant(sc: Scenario) -> str:
    """The scenario's plant (``"kinematic"`` unless it names another)."""
    return str(getattr(sc, "plant", "kinematic"))


def run_batch(
    scenarios: Sequence[Scenario],
    *,
    family: str = "",
    indices: Sequence[int] | None = None,
    timings: dict[str, float] | None = None,
) -> list[CaseResult]:
    """Run many scenarios: each result equals ``run(scenario, family=..., index=...)``.

    Scenarios of one shape (robot, link radius, rate, steps, mode, whether there is a box,
    properties) on the kinematic plant run in lock-step, at most :data:`BATCH` at once; any
    other scenario runs through :func:`~velfence.apps.verify.cases.run`.

    Args:
        scenarios: The scenarios.
        family: The family's name (for the results).
        indices: Each case's index (default ``0, 1, ...``).
        timings: If a dict, the CPU seconds spent in each part of the lock-step are added to it
            (``setup``, ``operator``, ``filter``, ``plant``, ``kinematics``, ``clearance``,
            ``margins``; the benchmark's breakdown).

    Returns:
        One :class:`~velfence.apps.verify.cases.CaseResult` per scenario, in order.

    Raises:
        InvalidParameter: not a list or tuple of scenarios, a family name that is no string,
            ``indices`` not ints >= 0 or of another length, ``timings`` not a dict.
    """
    if not isinstance(scenarios, (list, tuple)):
        raise InvalidParameter(
            f"scenarios: expected a list or tuple of Scenario, got {describe(scenarios)}"
        )
    scs = list(scenarios)
    bad = [j for j, sc in enumerate(scs) if not isinstance(sc, Scenario)]
    if bad:
        raise InvalidParameter(
            f"scenarios: expected a list or tuple of Scenario, item {bad[0]} is "
            f"{describe(scs[bad[0]])}"
        )
    family = check_text("family", family, max_length=80)
    if indices is None:
        idx = list(range(len(scs)))
    elif isinstance(indices, (list, tuple)):
        idx = [check_positive_int(f"indices[{j}]", v, example=0, minimum=0)
               for j, v in enumerate(indices)]  # fmt: skip
    else:
        raise InvalidParameter(f"indices: expected a list of ints or None, got {describe(indices)}")
    if len(idx) != len(scs):
        raise InvalidParameter(
            f"scenarios, indices: expected one index per scenario, got {len(scs)} scenarios "
            f"and {len(idx)} indices"
        )
    if timings is not None and not isinstance(timings, dict):
        raise InvalidParameter(f"timings: expected a dict or None, got {describe(timings)}")
    clock = _Clock(timings)
    out: list[CaseResult | None] = [None] * len(scs)
    groups: dict[str, list[int]] = {}
    for j, sc in enumerate(scs):
        if _plant(sc) != "kinematic":
            out[j] = run(sc, family=family, index=idx[j])
            continue
        key = json.dumps(
            [sc.robot, sc.link_radius, sc.rate, sc.steps, sc.mode, sc.box is None,
             sc.properties.model_dump(mode="json")], sort_keys=True,
        )  # fmt: skip
        groups.setdefault(key, []).append(j)
    for members in groups.values():
        for c in range(0, len(members), BATCH):
            part = members[c : c + BATCH]
            got = _lockstep([scs[j] for j in part], family, [idx[j] for j in part], clock)
            for j, r in zip(part, got, strict=True):
                out[j] = r
    return [r for r in out if r is not None]


@functools.cache
def _trig_is_libm() -> bool:
    """Whether NumPy's float64 ``cos`` and ``sin`` give :mod:`math`'s (the C library's) values.

    The chain's kinematics calls :func:`math.cos` and :func:`math.sin`; NumPy's are the same
    functions on most builds, but some use their own vectorised ones (SVML on AVX-512), which
    differ in the last bit now and then. Checked once on 4,096 angles; when any differs the
    batch calls :mod:`math` for every angle (about ten times slower, still exact).
    """
    th = np.random.default_rng(0).uniform(-7.0, 7.0, 4096)
    th[:4] = (0.0, math.pi / 2, -math.pi, 1e3)
    values = th.tolist()
    return bool(
        np.array_equal(np.cos(th), [math.cos(v) for v in values])
        and np.array_equal(np.sin(th), [math.sin(v) for v in values])
    )


class _Kinematics:
    """The chain's one kinematics pass over a batch: the TCP and the link segments."""

    def __init__(self, robot: Any) -> None:
        data = robot.chain_data()
        self.rows = [tuple(float(v) for v in r) for r in np.asarray(data.dh).tolist()]
        self.tool = tuple(float(v) for v in np.asarray(data.tool).tolist())
        self.tcp = int(data.point_index["tcp"])
        self.off = np.array([[r[4]] for r in self.rows])  # (n, 1)
        self._constants: dict[int, tuple[FloatArray, FloatArray, FloatArray, FloatArray]] = {}

    def constants(self, B: int) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        """The DH constants as arrays of a batch's shape: ``cos α``, ``sin α``, ``[a, d]``, tool.

        Made once per batch size (no scalar or broadcasting call in the pass).
        """
        got = self._constants.get(B)
        if got is None:
            n = len(self.rows)
            rows = np.array(self.rows)
            CA = np.empty((n, 2, 3, B))
            CA[...] = rows[:, 1, None, None, None]
            SA = np.empty((n, 2, 3, B))
            SA[...] = rows[:, 2, None, None, None]
            AD = np.empty((n, 2, 3, B))
            AD[:, 0] = rows[:, 0, None, None]
            AD[:, 1] = rows[:, 3, None, None]
            TOOL = np.empty((3, 3, B))
            TOOL[...] = np.array(self.tool)[:, None, None]
            got = self._constants[B] = (CA, SA, AD, TOOL)
        return got

    def __call__(self, Q: FloatArray) -> tuple[FloatArray, FloatArray]:
        """``(tcp (B, 3), joint points (B, n + 1, 3))`` of the joint positions ``Q`` (B, n).

        Link ``l`` is the segment from point ``l`` to point ``l + 1`` (the chain's segments).
        """
        B, n = Q.shape
        CA, SA, AD, TOOL = self.constants(B)
        # DHChain._kinematics_lists, element by element (the same operations in the same
        # order), on the frames' columns x, y, z and origin o laid out as (3, B) arrays, every
        # operand of one shape (NumPy's calls that broadcast cost several times more): one
        # call per pair of columns, [x, y] and [u, z]. A term whose DH constant is exactly 0
        # is left out: it adds a zero to the origin, which is never -0 (it starts at +0 and
        # only sums), so the points are the same bit for bit.
        th = np.add(Q.T, self.off, out=np.empty((n, B)))  # qs[i] + off, contiguous
        if _trig_is_libm():
            cos, sin = np.cos(th), np.sin(th)
        else:
            cos = np.fromiter(map(math.cos, th.ravel().tolist()), np.float64, B * n).reshape(n, B)
            sin = np.fromiter(map(math.sin, th.ravel().tolist()), np.float64, B * n).reshape(n, B)
        CT = np.empty((n, 2, 3, B))
        CT[...] = cos[:, None, None, :]
        ST = np.empty((n, 2, 3, B))
        ST[...] = sin[:, None, None, :]
        XY = np.zeros((2, 3, B))  # [x, y]
        XY[0, 0] = 1.0
        XY[1, 1] = 1.0
        UZ = np.zeros((2, 3, B))  # [u, z]
        UZ[1, 2] = 1.0
        T1 = np.empty((2, 3, B))
        T2 = np.empty((2, 3, B))
        inc = np.empty((2, 3, B))
        PT = np.zeros((n + 1, 3, B))  # the origins; the last: the tool point
        mul, add, sub = np.multiply, np.add, np.subtract
        for i, (a, _, _, d, _) in enumerate(self.rows):
            mul(XY, CT[i], out=T1)  # [c x, c y]
            mul(XY, ST[i], out=T2)  # [s x, s y]
            sub(T1[1], T2[0], out=UZ[0])  # u = c y - s x
            add(T1[0], T2[1], out=XY[0])  # x' = c x + s y
            o, o1 = PT[i], PT[i + 1]  # o' = o + (a x' + d z)
            if a != 0.0 and d != 0.0:
                mul(XY[0], AD[i, 0], out=inc[0])
                mul(UZ[1], AD[i, 1], out=inc[1])
                add(o, add(inc[0], inc[1], out=inc[0]), out=o1)
            elif a != 0.0:
                add(o, mul(XY[0], AD[i, 0], out=inc[0]), out=o1)
            elif d != 0.0:
                add(o, mul(UZ[1], AD[i, 1], out=inc[1]), out=o1)
            else:
                o1[...] = o
            mul(UZ, CA[i], out=T1)  # [ca u, ca z]
            mul(UZ, SA[i], out=T2)  # [sa u, sa z]
            add(T1[0], T2[1], out=XY[1])  # y' = ca u + sa z
            sub(T1[1], T2[0], out=UZ[1])  # z' = ca z - sa u
        flange = PT[n].T.copy() if self.tcp < 0 else None
        tool = PT[n]  # o + tx x + ty y + tz z
        for k, col in enumerate((XY[0], XY[1], UZ[1])):
            if self.tool[k] != 0.0:
                add(tool, mul(col, TOOL[k], out=inc[0]), out=tool)
        P = np.ascontiguousarray(PT.transpose(2, 0, 1))
        tcp = flange if flange is not None else P[:, self.tcp].copy()
        return tcp, P


class _Clearance:
    """:func:`velfence.apps.soak_filter.clearance` of each case (inf for a case without one).

    The spheres of the batch's cases: ``C`` (B, K, 3), ``R`` (B, K); ``real`` (B, K) the
    spheres that exist; ``lrad`` (L,) the links' radii. The arithmetic is the function's
    element by element (one step left out, exactly: see ``__call__``), its ``einsum``
    contractions with a batch axis (each over the last axis, contiguous, as there), laid out
    sphere first, (K, B, L): the per-case constants (the centres repeated per link, the radii)
    are made once, and no call broadcasts along the coordinates' short axis (NumPy's slow
    case): the ``t E`` product repeats ``t`` along it first.
    """

    def __init__(self, lrad: FloatArray, C: FloatArray, R: FloatArray, real: Any) -> None:
        B, K = R.shape
        L = lrad.shape[0]
        self.CT = np.empty((K, B, L, 3))
        self.CT[...] = C.transpose(1, 0, 2)[:, :, None, :]
        self.rel = np.empty_like(self.CT)  # (one buffer for every step: the same memory)
        self.LR = np.empty((K, B, L))
        self.LR[...] = lrad
        self.RR = np.empty((K, B, L))
        self.RR[...] = R.T[:, :, None]
        self.gone = None
        if not np.all(real):
            self.gone = np.empty((K, B, L), dtype=bool)
            self.gone[...] = ~real.T[:, :, None]

    def __call__(self, P: FloatArray) -> FloatArray:
        """The smallest clearance of each case (B,), ``P`` (B, L + 1, 3) the joint points.

        Link ``l`` runs from point ``l`` to point ``l + 1``.
        """
        A = np.ascontiguousarray(P[:, :-1])
        E = P[:, 1:] - A
        ee = np.einsum("bij,bij->bi", E, E)
        pos = ee > 0.0
        rel = np.subtract(self.CT, A, out=self.rel)
        t = np.einsum("pbsk,bsk->pbs", rel, E)
        np.divide(t, np.where(pos, ee, 1.0), out=t)
        np.clip(t, 0.0, 1.0, out=t)
        # (the function's t = where(ee > 0, t, 0) is left out: for a link of length 0, E = 0,
        # so t E is a zero whatever t, and rel - t E is rel: the same distances bit for bit)
        K, B, L = t.shape
        tE = np.repeat(t, 3, axis=-1).reshape(K, B, L, 3)
        np.multiply(tE, E, out=tE)
        np.subtract(rel, tE, out=rel)  # diff
        dist = np.einsum("pbsk,pbsk->pbs", rel, rel)
        np.sqrt(dist, out=dist)
        np.subtract(dist, self.LR, out=dist)
        np.subtract(dist, self.RR, out=dist)
        if self.gone is not None:
            np.copyto(dist, np.inf, where=self.gone)
        return np.asarray(dist.min(axis=0).min(axis=1))


class _BoxMargin:
    """:func:`~velfence.apps.verify.cases.box_margin` of each case's TCP (inf without a box).

    The facets ``N`` (B, m, 3), ``o`` (B, m) laid out facet first, (3, m, B) and (m, B): the
    same sums, with operands of one shape.
    """

    def __init__(self, N: FloatArray, o: FloatArray) -> None:
        self.NT = np.ascontiguousarray(N.transpose(2, 1, 0))
        self.OT = np.ascontiguousarray(o.T)

    def __call__(self, p: FloatArray) -> FloatArray:
        """The margins (B,) of the TCPs ``p`` (B, 3)."""
        _, m, B = self.NT.shape
        if m == 0:
            return np.full(B, np.inf)
        NP = np.empty_like(self.NT)
        NP[...] = p.T[:, None, :]
        np.multiply(self.NT, NP, out=NP)  # N[..., j] p[..., j]
        d = np.add(NP[0], NP[1], out=NP[0])
        np.add(d, NP[2], out=d)
        np.subtract(d, self.OT, out=d)
        return np.asarray(d.min(axis=0))


class _JointMargin:
    """:func:`~velfence.apps.verify.cases.joint_margin` of each case, joint first (n, B)."""

    def __init__(self, lo: FloatArray, hi: FloatArray) -> None:
        self.LO = np.ascontiguousarray(lo.T)
        self.HI = np.ascontiguousarray(hi.T)

    def __call__(self, Q: FloatArray) -> FloatArray:
        """The margins (B,) of the joints ``Q`` (B, n)."""
        QT = Q.T.copy()
        a = np.subtract(QT, self.LO)
        np.minimum(a, np.subtract(self.HI, QT, out=QT), out=a)
        return np.asarray(a.min(axis=0))


def _c_route(flts: list[Any], twist: bool) -> Any:
    """``cycle_many`` of the compiled core, or None (each case's ``SafetyFilter`` in turn).

    The compiled route needs joint mode and every case's filter running its cycle in C.
    """
    if twist or not all(f.cycle_in_c for f in flts):
        return None
    from velfence.shaping.backend import compiled_filter

    mod = compiled_filter()
    return None if mod is None else getattr(mod, "cycle_many", None)


def _cycle_many(
    many: Any,
    cycles: list[Any],
    Q: FloatArray,
    U: FloatArray,
    X: FloatArray,
    FP: FloatArray | None,
    FP2: FloatArray | None,
    use: Any,
    use2: Any,
) -> Any:
    """The cycles of every row into ``X``; returns the statuses.

    Each row gets its previous outputs where ``use`` / ``use2`` say (the rows grouped by that
    pattern, one call per group: in lock-step there is one group).
    """
    if not use.any() and not use2.any():  # no previous outputs (a stateless filter)
        return many(cycles, Q, U, None, None, X)[1]
    status = np.zeros(len(cycles), dtype=np.int64)
    patterns = use.astype(np.int64) + 2 * use2.astype(np.int64)
    for pat in np.unique(patterns).tolist():
        p = FP if pat & 1 else None
        p2 = FP2 if pat & 2 else None
        if np.all(patterns == pat):
            _, st, _ = many(cycles, Q, U, p, p2, X)
            status[:] = st
            continue
        sel = np.flatnonzero(patterns == pat)
        x, st, _ = many([cycles[i] for i in sel.tolist()], Q[sel], U[sel],
                        None if p is None else p[sel], None if p2 is None else p2[sel])  # fmt: skip
        X[sel] = x
        status[sel] = st
    return status


class _Worst:
    """:class:`velfence.apps.verify.cases` ``_Worst`` over a batch."""

    def __init__(self, props: Any, B: int) -> None:
        self.tol = tolerances(props)
        self.m = {name: np.zeros(B) for name in self.tol}
        self.step = {name: np.full(B, -1) for name in self.tol}
        self.first = {name: np.full(B, -1) for name in self.tol}

    def add(self, name: str, margin: FloatArray, k: int, mask: Any = None) -> None:
        if name not in self.tol:
            return
        m, s, f = self.m[name], self.step[name], self.first[name]
        new = (s < 0) | (margin < m)
        bad = (f < 0) & (margin < -self.tol[name])
        if mask is not None:
            new &= mask
            bad &= mask
        if new.any():  # (most steps: no case's worst margin moves)
            m[new] = margin[new]
            s[new] = k
        if bad.any():
            f[bad] = k


class _Clock:
    """CPU seconds (this thread's) per part of the lock-step, added to ``timings``.

    Nothing is measured when ``timings`` is None. CPU time, not wall time: on a shared machine
    the wall time also counts the other processes.
    """

    def __init__(self, timings: dict[str, float] | None) -> None:
        self.timings = timings
        self.t = time.thread_time() if timings is not None else 0.0

    def __call__(self, part: str) -> None:
        """The time since the last call goes to ``part``."""
        if self.timings is not None:
            t = time.thread_time()
            self.timings[part] = self.timings.get(part, 0.0) + (t - self.t)
            self.t = t


@any_start()
def _lockstep(scs: list[Scenario], family: str, idx: list[int], clock: _Clock) -> list[CaseResult]:
    """:func:`run` of scenarios of one shape, step by step together (module docstring)."""
    clock("setup")  # (the grouping before)
    B = len(scs)
    sc0 = scs[0]
    robot = chain(sc0.robot, sc0.link_radius)  # one model for all (a chain is immutable)
    flts = [build_filter(sc, robot) for sc in scs]
    kin = _Kinematics(robot)
    n = int(robot.dof)
    dt = 1.0 / sc0.rate
    twist = sc0.mode == "twist"
    props = sc0.properties
    worst = _Worst(props, B)
    rows = np.arange(B)
    rngs = [np.random.default_rng(sc.command_seed) for sc in scs]
    noise_rngs = [np.random.default_rng(sc.noise_seed) for sc in scs]
    sigma = [sc.noise for sc in scs]
    noisy = np.array([s > 0.0 for s in sigma])
    noisy_rows = np.flatnonzero(noisy).tolist()
    vmax = [np.array(sc.max_speed) for sc in scs]
    LO = np.array([sc.lower for sc in scs])
    HI = np.array([sc.upper for sc in scs])
    lrad = np.asarray(robot.link_radius, dtype=np.float64)
    has_box = sc0.box is not None
    Ns: list[FloatArray] = []
    os_: list[FloatArray] = []
    for sc, f in zip(scs, flts, strict=True):
        if sc.box is not None:  # the filter's own box (ConvexPolytope.box of the scenario's)
            P0 = f.workspace[0].polytope
            Ns.append(np.asarray(P0.normals, dtype=np.float64))
            os_.append(np.asarray(P0.offsets, dtype=np.float64))
        else:
            Ns.append(np.zeros((0, 3)))
            os_.append(np.zeros(0))
    NB = np.array(Ns)  # (B, m, 3)
    OB = np.array(os_)  # (B, m)
    buffer = np.array([sc.box.buffer if sc.box is not None else 0.0 for sc in scs])
    K = max(len(sc.spheres) for sc in scs)
    CB = np.zeros((B, K, 3))
    RB = np.zeros((B, K))
    real = np.zeros((B, K), dtype=bool)
    for i, sc in enumerate(scs):
        for j, s in enumerate(sc.spheres):
            CB[i, j] = s[:3]
            RB[i, j] = s[3]
            real[i, j] = True
    jogs: list[Any] = [None] * B
    if sc0.operator == "scripted" or any(sc.operator == "scripted" for sc in scs):
        from velfence.sim.scenarios import TcpJog

        for i, sc in enumerate(scs):
            if sc.operator == "scripted" and sc.targets:
                jogs[i] = TcpJog(
                    robot.fk,
                    [(t[0], np.array(t[1:])) for t in sc.targets],
                    speed=sc.jog_speed,
                )
    jog_rows = [i for i in range(B) if jogs[i] is not None]
    draw_rows = np.array([jogs[i] is None for i in range(B)])
    pushes = [[(ps.start, ps.end, np.array(ps.velocity)) for ps in sc.pushes] for sc in scs]
    push_rows = [i for i in range(B) if pushes[i]]
    ALPHA = np.empty((B, n))  # (B, n) and DT too: no call broadcasts in the loop
    ALPHA[...] = np.array([[1.0 - math.exp(-dt / sc.lag) if sc.lag > 0.0 else 1.0] for sc in scs])
    DT = np.full((B, n), dt)
    LAT = np.array([sc.latency for sc in scs])
    Lmax = int(LAT.max())
    ring = np.zeros((Lmax + 1, B, n))
    many = _c_route(flts, twist)
    cycles = [] if many is None else [c_cycle_or_none(f) for f in flts]
    remember = np.array([f.stateful for f in flts])
    has_jerk = np.array([sc.max_jerk is not None and sc.filter_dt is not None for sc in scs])
    FP = np.zeros((B, n))  # each filter's remembered outputs (SafetyFilter's previous ...
    FP2 = np.zeros((B, n))  # ... and the one before), for the C route
    has_fp = np.zeros(B, dtype=bool)
    has_fp2 = np.zeros(B, dtype=bool)
    jerk_max = None if props.jerk is None else props.jerk.max
    prog = props.progress if twist else None
    window = 0 if prog is None else max(1, round(prog.window * sc0.rate))
    tc = worst.tol.get("containment", 0.0)
    tj = worst.tol.get("joint_limits", 0.0)

    clear = _Clearance(lrad, CB, RB, real)
    inside = _BoxMargin(NB, OB)
    limits = _JointMargin(LO, HI)

    def at(Qq: FloatArray, sel: Any = slice(None)) -> tuple[FloatArray, FloatArray, FloatArray]:
        """TCP, containment margin and joint margin of the rows ``sel`` at ``Qq``."""
        clock("plant")
        p, pts = kin(Qq)
        clock("kinematics")
        if not K:
            c = np.full(len(p), np.inf)
        elif isinstance(sel, slice):
            c = clear(pts)
        else:  # the pushed rows
            c = _Clearance(lrad, CB[sel], RB[sel], real[sel])(pts)
        clock("clearance")
        if isinstance(sel, slice):
            cm = np.minimum(inside(p), c)
            jm = limits(Qq)
        else:
            cm = np.minimum(_BoxMargin(NB[sel], OB[sel])(p), c)
            jm = _JointMargin(LO[sel], HI[sel])(Qq)
        return p, cm, jm

    Q = np.array([sc.q0 for sc in scs])
    clock("setup")
    P, CM0, JM0 = at(Q)
    APPLIED = np.zeros((B, n))
    PREV: FloatArray | None = None
    PREV2: FloatArray | None = None
    d_cmd = 3 if twist else n
    CMD = np.zeros((B, d_cmd))
    CN = np.zeros(B)
    HOLD = np.zeros(B, dtype=np.int64)
    SEG_LEN = np.zeros(B, dtype=np.int64)
    SEG_ALONG = np.zeros(B)
    SEG_TAN = np.zeros(B)
    MISSES = np.zeros(B, dtype=np.int64)
    EXC = np.zeros(B, dtype=np.int64)
    INTER_SUM = np.zeros(B)
    INTER_MAX = np.zeros(B)
    NZ = np.zeros((B, _NOISE_BLOCK, n))
    X = np.zeros((B, n))
    steps = sc0.steps
    operators = [sc.operator for sc in scs]
    clock("setup")
    for k in range(steps):
        if noisy_rows:
            b = k % _NOISE_BLOCK
            if b == 0:
                for i in noisy_rows:
                    NZ[i] = noise_rngs[i].normal(0.0, sigma[i], (_NOISE_BLOCK, n))
            QM = Q.copy()
            QM[noisy] = Q[noisy] + NZ[noisy, b]
        else:
            QM = Q
        for i in jog_rows:
            CMD[i] = np.asarray(jogs[i](k * dt, QM[i]), dtype=np.float64)
            CN[i] = float(np.linalg.norm(CMD[i]))
        due = np.flatnonzero(draw_rows & (HOLD <= 0)).tolist()
        for i in due:
            pm = P[i]
            if noisy[i] and twist and has_box:  # the push draw aims from the measured TCP
                pm = np.asarray(robot.fk(QM[i]), dtype=np.float64)
            cmd, hold = draw_command(operators[i], rngs[i], twist=twist, N=Ns[i], o=os_[i],
                                     p=pm, vmax=vmax[i], rate=sc0.rate)  # fmt: skip
            CMD[i] = cmd
            HOLD[i] = hold
        if due:  # the new commands' norms (np.linalg.norm's dot), their segments begun
            CD = CMD[due]
            CN[due] = np.sqrt(np.vecdot(CD, CD))
            SEG_LEN[due], SEG_ALONG[due], SEG_TAN[due] = 0, 0.0, 0.0
        HOLD -= 1
        clock("operator")
        X = np.empty((B, n))
        if many is not None:
            # SafetyFilter.filter's C fast path for every case in one call: the previous
            # outputs it would pass (remembered ones only), then what it remembers.
            late = _cycle_many(many, cycles, QM, CMD, X, FP if remember.any() else None,
                               FP2 if has_jerk.any() else None, remember & has_fp,
                               has_jerk & has_fp2)  # fmt: skip
            good = late >= 0
            missed = MISSES
            if late.max() >= min(PROJECT_ITERATION_CAP, PROJECT_DEADLINE):
                missed = MISSES + (
                    np.equal(late, PROJECT_ITERATION_CAP) | np.equal(late, PROJECT_DEADLINE)
                )
            if not good.all():  # refused by C: SafetyFilter.filter raises InvalidInput
                EXC += ~good
                X[~good] = np.nan
            upd = good & remember
            if upd.any():
                j2 = upd & has_jerk
                FP2[j2] = FP[j2]
                has_fp2[j2] = has_fp[j2]
                FP[upd] = X[upd]
                has_fp[upd] = True
        else:
            missed = np.empty(B, dtype=np.int64)
            for i in range(B):
                f = flts[i]
                try:
                    X[i] = f.filter_twist(QM[i], CMD[i]) if twist else f.filter(QM[i], CMD[i])
                except Exception:  # counted as a violation of "finite"; the campaign goes on
                    EXC[i] += 1
                    X[i] = np.nan
                missed[i] = f.deadline_misses
        clock("filter")
        # "finite" and "deadline": a margin of 0 everywhere changes nothing after the first
        # step (every case has a worst margin <= 0 then, and 0 violates nothing)
        if not np.isfinite(X).all():
            OK = np.all(np.isfinite(X), axis=1)
            X[~OK] = 0.0
            worst.add("finite", np.where(OK, 0.0, -1.0), k)
        elif k == 0:
            worst.add("finite", np.zeros(B), k)
        late_now = missed > MISSES
        if k == 0 or late_now.any():
            worst.add("deadline", np.where(late_now, -1.0, 0.0), k)
        MISSES = missed
        if jerk_max is not None and PREV is not None and PREV2 is not None:
            worst.add("jerk", jerk_margin(jerk_max, X, PREV, PREV2, dt), k)
        PREV2, PREV = PREV, X
        if Lmax:
            ring[k % (Lmax + 1)] = X
            XD = ring[(k - LAT) % (Lmax + 1), rows]
            XD[k < LAT] = 0.0
        else:
            XD = X
        clock("margins")
        APPLIED = APPLIED + ALPHA * (XD - APPLIED)
        Q1 = Q + DT * APPLIED
        P1, CM1, JM1 = at(Q1)
        worst.add("containment", step_margin(CM1, CM0, tc), k)
        worst.add("joint_limits", step_margin(JM1, JM0, tj), k)
        VT = (P1 - P) / dt if twist else APPLIED  # (the TCP's velocity: twist mode only)
        D = VT - CMD
        big = CN > 1e-9
        REL = np.where(big, np.sqrt(np.vecdot(D, D)) / np.where(big, CN, 1.0), 0.0)
        INTER_SUM += REL
        INTER_MAX = np.maximum(INTER_MAX, REL)
        if prog is not None and has_box:
            CT = face_tangent(NB, OB, P, CMD, buffer)
            tn = np.sqrt(np.vecdot(CT, CT))
            go = big & (tn > 1e-3)
            if go.any():
                SEG_LEN[go] += 1
                SEG_ALONG[go] += np.vecdot(VT[go], CT[go]) / tn[go]
                SEG_TAN[go] += tn[go]
                chk = go & (window <= SEG_LEN)
                if chk.any():
                    with np.errstate(divide="ignore", invalid="ignore"):
                        m = progress_margin(SEG_ALONG, SEG_TAN, SEG_LEN, prog.min_fraction)
                    worst.add("progress", m, k, chk)
        if push_rows:
            hit: list[int] = []
            W = np.zeros((B, n))
            for i in push_rows:
                w = None
                for a, b2, v in pushes[i]:
                    if a <= k < b2:
                        w = v if w is None else w + v
                if w is not None:
                    hit.append(i)
                    W[i] = w
            if hit:
                Q1[hit] = Q1[hit] + dt * W[hit]
                p2, cm2, jm2 = at(Q1[hit], hit)
                P1[hit], CM1[hit], JM1[hit] = p2, cm2, jm2
        Q, P, CM0, JM0 = Q1, P1, CM1, JM1
        clock("margins")
    out = []
    names = [name for name in PROPERTIES if name in worst.tol]
    for i in range(B):
        wm: dict[str, tuple[float, int]] = {
            name: (float(worst.m[name][i]), int(worst.step[name][i]))
            for name in names
            if worst.step[name][i] >= 0
        }
        first = {name: int(worst.first[name][i]) for name in names if worst.first[name][i] >= 0}
        out.append(
            CaseResult(
                family=family,
                index=idx[i],
                steps=steps,
                worst=wm,
                violated=[name for name in PROPERTIES if name in first],
                first=first,
                intervention_mean=float(INTER_SUM[i]) / max(steps, 1),
                intervention_max=float(INTER_MAX[i]),
                exceptions=int(EXC[i]),
            )
        )
    return out
