"""The built-in rows of a DH chain in one compiled call (``velfence_core._nd.FilterRows``).

With the compiled core and a robot whose ``chain_data()`` is a DH table (``DHChain``,
``Puma560``), every built-in row of a joint-mode cycle — joint position and velocity,
acceleration, workspace facets, obstacle-link pairs — comes from ``vf_nd_filter_rows``: the same
definitions as the providers of :mod:`velfence.filter.rows` (the joint and acceleration rows bit
for bit, the workspace and obstacle rows' sums in C: equal to round-off, tested) and the same
names; the one difference is the order of the joint rows (per joint: position lower, upper,
velocity lower, upper, where the Python route lists every position row before the velocity
rows). The ladder, the model check and the result are those of the Python route. The model
check's next pose uses the same compiled kinematics (``vf_nd_chain_kinematics``) and clearances
(``vf_nd_capsule_clearances``). A cycle with a user's provider or in twist mode runs the Python
providers. Until the whole cycle runs in C this route is what keeps the common cycle fast.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from velfence._docs import document_inits
from velfence._typing import FloatArray
from velfence.filter.limits import JointLimits, Profile, SphereObstacle, WorkspaceLimit
from velfence.filter.rows import (
    LEVEL_JOINT,
    LEVEL_OBSTACLE,
    LEVEL_RATE,
    LEVEL_WORKSPACE,
    WorkspaceRows,
)
from velfence.filter.stack import RowStack
from velfence.shaping.profiles import LinearBuffer

__all__ = ["CompiledRows", "compiled_rows"]

_SIDE = ("lower", "upper")


class _CompiledStack(RowStack):
    """A :class:`RowStack` filled from the compiled rows (tags instead of blocks)."""

    __slots__ = ("_d", "_kin", "_names", "_tags")

    def __init__(self, rows: CompiledRows, G: Any, b: Any, level: Any, ta: Any, tb: Any, d: Any):
        self.blocks = []
        self._kin = rows
        self.G = G
        self.b = b
        self.level = lv = level
        self.violated = d < 0.0
        self._d = d
        self._tags = (ta, tb)
        self.checked = np.flatnonzero((lv == LEVEL_WORKSPACE) | (lv == LEVEL_OBSTACLE))
        self.d0 = d[self.checked]

    def _group(self) -> Any:
        """0 position, 1 velocity, 2 acceleration, 3 workspace, 4 obstacle rows."""
        lv = self.level
        joint = np.where((self._tags[0] & 3) < 2, 0, 1)
        return np.select(
            [lv == LEVEL_JOINT, lv == LEVEL_RATE, lv == LEVEL_WORKSPACE], [joint, 2, 3], 4
        )

    def violations(
        self, names: Sequence[str], *, providers: int | None = None
    ) -> tuple[tuple[str, float | None], ...]:
        """``(name, depth)`` of every violated row (the compiled rows give every distance).

        Every row is the filter's own, so ``providers`` selects nothing out.
        """
        d = self._d
        return tuple((names[r], -float(d[r])) for r in np.flatnonzero(d < 0.0).tolist())

    def names(self) -> list[str]:
        """Every row's name (the Python providers' names), made now."""
        ws = self._kin.ws_names
        out: list[str] = []
        tags = (self._group(), *self._tags)
        for g, a, t in zip(*(x.tolist() for x in tags), strict=True):
            if g in (0, 1):
                j, r = divmod(a, 4)
                out.append(f"joint {j} {'position' if r < 2 else 'velocity'} ({_SIDE[r % 2]})")
            elif g == 2:
                out.append(f"joint {a} acceleration ({_SIDE[t]})")
            elif g == 3:
                out.append(ws[a][t])
            else:
                out.append(f"obstacle {a} on link {t}")
        return out

    def keys(self, rows: Sequence[int]) -> set[tuple[int, int]]:
        """``(group, tag)`` of the given rows (stable across cycles of this route)."""
        g, (a, t) = self._group(), self._tags
        return {(int(g[r]), int(a[r]) * 65536 + int(t[r])) for r in rows}

    def rows_of(self, keys: set[tuple[int, int]]) -> list[int]:
        """Row indices of the given keys (those present this cycle)."""
        g, (a, t) = self._group(), self._tags
        mine = {(int(x), int(y) * 65536 + int(z)) for x, y, z in zip(g, a, t, strict=True)}
        if not keys & mine:
            return []
        code = (g * (1 << 40) + a * 65536 + t).tolist()
        want = {k[0] * (1 << 40) + k[1] for k in keys}
        return [r for r, c in enumerate(code) if c in want]

    def distances_at(self, robot: Any, q1: FloatArray) -> FloatArray:
        """The checked rows' distances at ``q1``, by the compiled kinematics."""
        return self._kin.next_distances(q1, self)


class CompiledRows:
    """The compiled row builder of one filter (module docstring).

    Args:
        core: ``velfence_core._nd``.
        chain: The robot's ``chain_data()`` (a DH table).
        limits: The joint limits.
        profiles: The joint profiles.
        workspace: The workspace limits (their points in ``chain.point_index``).
        ws_profiles: The workspace limits' profiles.
        ws_names: Row names per workspace limit, per facet.
        obstacles: The spheres.
        link_radius: The links' capsule radii [m], (n,) or (1,).
        obstacle_buffer: The obstacles' buffer [m].
        spring_gain: The obstacles' recovery gain [1/s].
        dt: The control period [s] or ``None``.
    """

    def __init__(
        self,
        core: Any,
        chain: Any,
        limits: JointLimits,
        profiles: Sequence[Profile],
        workspace: Sequence[WorkspaceLimit],
        ws_profiles: Sequence[Profile],
        ws_names: Sequence[Sequence[str]],
        obstacles: Sequence[SphereObstacle],
        link_radius: Any,
        *,
        obstacle_buffer: float,
        spring_gain: float,
        dt: float | None,
    ) -> None:
        n = limits.dof
        self.ws_names = tuple(tuple(x) for x in ws_names)
        self._points = [chain.point_index[w.point] for w in workspace]
        self._ws = tuple(
            (np.asarray(w.polytope.normals, float), np.asarray(w.polytope.offsets, float))
            for w in workspace
        )
        self._dt = dt
        self._n = n
        jkind: list[int] = []
        jprm: list[float] = []
        for p in profiles:
            kind, params = p.kernel_profile
            jkind.append(int(kind))
            jprm.extend(float(v) for v in params)
        ws = []
        for i, w in enumerate(workspace):
            kind, params = ws_profiles[i].kernel_profile
            ws.append(
                (
                    np.ascontiguousarray(w.polytope.normals, dtype=np.float64).ravel(),
                    np.ascontiguousarray(w.polytope.offsets, dtype=np.float64),
                    int(self._points[i]),
                    int(kind),
                    [float(v) for v in params],
                )
            )
        self._caps: Any = None
        if obstacles:
            radii = np.asarray(link_radius, dtype=float).reshape(-1)
            lrad = np.broadcast_to(radii, (n,)) if radii.shape[0] == 1 else radii[:n]
            okind, oprm = LinearBuffer(
                buffer=obstacle_buffer, spring_gain=spring_gain
            ).kernel_profile
            self._caps = core.CapsuleRows(
                np.ascontiguousarray(lrad, dtype=np.float64),
                np.ascontiguousarray([o.center for o in obstacles], dtype=np.float64).ravel(),
                np.ascontiguousarray([o.radius for o in obstacles], dtype=np.float64),
                np.ascontiguousarray(limits.max_speed, dtype=np.float64),
                n,
                n,
                n,
                len(obstacles),
                obstacle_buffer,
                dt or 0.0,
                okind,
                list(oprm),
            )
        acc = limits.max_acceleration
        self._rows = core.FilterRows(
            [float(v) for v in np.asarray(chain.dh, dtype=float).ravel()],
            [float(v) for v in np.asarray(chain.tool, dtype=float)],
            np.asarray(limits.lower, dtype=np.float64), np.asarray(limits.upper, dtype=np.float64),
            np.asarray(limits.max_speed, dtype=np.float64),
            None if acc is None else np.asarray(acc, dtype=np.float64), jkind, jprm, ws,
            self._caps,
        )  # fmt: skip

    def stack(self, q: FloatArray, u: FloatArray, previous: FloatArray | None) -> RowStack:
        """This cycle's rows (``previous`` ``None``: no acceleration rows)."""
        G, b, level, ta, tb, dist = self._rows.rows(q, u, previous, self._dt or 0.0)
        return _CompiledStack(self, G, b, level, ta, tb, dist)

    def next_distances(self, q1: FloatArray, st: _CompiledStack) -> FloatArray:
        """The checked rows' true distances at ``q1``: compiled kinematics and clearances."""
        P, _axes, flange = self._rows.kinematics(np.ascontiguousarray(q1, dtype=np.float64))
        lv = st.level[st.checked]
        a = st._tags[0][st.checked]
        t = st._tags[1][st.checked]
        out = np.empty(st.checked.shape[0])
        ws = lv == LEVEL_WORKSPACE
        if ws.any():
            for i, (N, o) in enumerate(self._ws):
                sel = ws & (a == i)
                if sel.any():
                    idx = self._points[i]
                    out[sel] = (N @ (flange if idx < 0 else P[idx]) - o)[t[sel]]
        if not ws.all():
            clear = np.asarray(self._caps.clearances(P), dtype=np.float64)
            ob = ~ws
            out[ob] = clear[a[ob] * (P.shape[0] - 1) + t[ob]]
        return out


def compiled_rows(core: Any, filt: Any, profiles: Sequence[Profile]) -> CompiledRows | None:
    """The compiled row builder of a filter when the core runs and its robot is a DH table."""
    data = getattr(filt.robot, "chain_data", None)
    chain = data() if core is not None and callable(data) else None
    if chain is None or filt.task_dim != 3:
        return None
    if any(w.point not in chain.point_index for w in filt.workspace):
        return None
    ws = [p for p in filt.providers if isinstance(p, WorkspaceRows)]
    return CompiledRows(
        core, chain, filt.limits, profiles, filt.workspace, [p.profile for p in ws],
        [p.facet_row_names for p in ws], filt.obstacles,
        getattr(filt.robot, "link_radius", np.zeros(1)),
        obstacle_buffer=filt.obstacle_buffer, spring_gain=filt.spring_gain, dt=filt.dt,
    )  # fmt: skip


document_inits(globals())
