"""Capsule links of an MJCF arm: the geometry the SafetyFilter's obstacle rows need.

Link ``k`` of an arm with sites ``"joint0"`` … ``"joint{n-1}"`` runs from joint ``k``'s site to
joint ``k + 1``'s (the last link to the ``"flange"`` site, or ``"tcp"`` without one), as in
``DHChain`` (``P_k`` to ``P_{k+1}``); zero-length links are kept (a sphere), so link ``k`` is
moved by joints ``0 … k`` exactly. Its radius is the largest of the capsule and sphere geoms
on joint ``k``'s body (a body without one, e.g. a zero-length link of a model given one radius
for all links, gets the largest radius of the model, which covers the joint between its
neighbours). Both ends are rigidly attached to body ``k``
(joint ``k + 1`` turns about an axis through its own site), so the Jacobian of the point at
fraction ``t`` is the exact interpolation ``(1 - t) J_k + t J_{k+1}`` of the two sites'
Jacobians.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from velfence._docs import document_inits
from velfence._typing import FloatArray
from velfence._validate import check_positive_int, finite_scalar, readonly
from velfence.errors import InvalidGeometry, InvalidInput

__all__ = ["CapsuleLinks"]


class CapsuleLinks:
    """The capsule-link part of the Kinematics protocol, mixed into MujocoRobot.

    ``link_radius``, ``link_segments``, ``joint_positions`` and ``point_jacobian`` (module docs).
    """

    _model: Any
    _site: dict[str, int]

    def _q(self, q: ArrayLike) -> FloatArray:  # provided by MujocoRobot
        raise NotImplementedError

    def _pose(self, q: FloatArray) -> None:  # provided by MujocoRobot
        raise NotImplementedError

    def _link_sites(self) -> list[int]:
        """Site ids of ``P_0 … P_n`` (joint sites, then the flange or the tcp)."""
        cached = getattr(self, "_chain_sites", None)
        if cached is not None:
            return list(cached)
        n = int(self._model.nv)
        names = [f"joint{i}" for i in range(n)]
        missing = [s for s in names if s not in self._site]
        if missing:
            raise InvalidGeometry(
                f"robot: capsule links need the sites 'joint0' … 'joint{n - 1}' on the joint axes "
                f"(as the shipped arms have), got none named {missing[:5]}"
            )
        end = "flange" if "flange" in self._site else "tcp"
        ids = [self._site[s] for s in [*names, end]]
        self._chain_sites = tuple(ids)
        return ids

    @property
    def link_radius(self) -> FloatArray:
        """Capsule radius of each link [m], shape (n,), read-only (module docs)."""
        cached = getattr(self, "_radii", None)
        if cached is not None:
            return cached  # type: ignore[no-any-return]
        m = self._model
        ids = self._link_sites()
        r = np.zeros(len(ids) - 1)
        for k in range(len(r)):
            body = int(m.site_bodyid[ids[k]])
            for g in range(m.ngeom):
                if int(m.geom_bodyid[g]) == body and int(m.geom_type[g]) in (2, 3):  # ball, capsule
                    r[k] = max(r[k], float(m.geom_size[g][0]))
        r[r == 0.0] = float(r.max()) if r.size else 0.0
        self._radii = readonly(r)
        return self._radii

    def joint_positions(self, q: ArrayLike) -> FloatArray:
        """Joint sites and the end of the last link in the world frame.

        Args:
            q: Joint position [rad], shape (n,).

        Returns:
            Points ``P_0 … P_n`` [m], shape (n + 1, 3).

        Raises:
            InvalidInput: bad ``q``.
            InvalidGeometry: the model lacks the joint sites.
        """
        ids = self._link_sites()
        self._pose(self._q(q))
        out = np.array(self._data_site_xpos()[ids], dtype=float)
        if not np.all(np.isfinite(out)):
            raise InvalidInput("q: expected a pose with finite kinematics, got non-finite values")
        return out

    def _data_site_xpos(self) -> FloatArray:
        return np.asarray(self._data.site_xpos)  # type: ignore[attr-defined]

    def link_segments(self, q: ArrayLike) -> FloatArray:
        """Start and end point of every link.

        Args:
            q: Joint position [rad], shape (n,).

        Returns:
            Segments [m], shape (n, 2, 3); ``[k, 0]`` = ``P_k``, ``[k, 1]`` = ``P_{k+1}``.
        """
        P = self.joint_positions(q)
        return np.stack([P[:-1], P[1:]], axis=1)

    def point_jacobian(self, q: ArrayLike, link: int, t: float) -> FloatArray:
        """Linear-velocity Jacobian of the point at fraction ``t`` along ``link`` (module docs).

        Args:
            q: Joint position [rad], shape (n,).
            link: Link index in ``0 … n-1``.
            t: Fraction along the link, in [0, 1].

        Returns:
            ``dp/dq`` [m/rad], shape (3, n).

        Raises:
            InvalidInput: bad ``q``, ``link`` or ``t``.
        """
        ids = self._link_sites()
        nl = len(ids) - 1
        link = check_positive_int("link", link, minimum=0, maximum=nl - 1, error=InvalidInput)
        tt = finite_scalar("t", t, what="fraction along the link")
        if not 0.0 <= tt <= 1.0:
            raise InvalidInput(f"t: expected a fraction in [0, 1], got {tt}")
        qa = self._q(q)
        ja = self._site_jacobian(qa, ids[int(link)])
        jb = self._site_jacobian(qa, ids[int(link) + 1])
        return (1.0 - tt) * ja + tt * jb

    def _site_jacobian(self, q: FloatArray, sid: int) -> FloatArray:  # provided by MujocoRobot
        raise NotImplementedError

    # The rest of the serial-chain interface of velfence.mechanisms.chain (end effector = the
    # "tcp" site), so the arm baselines and the configuration controller run on MJCF arms too.

    @property
    def n_links(self) -> int:
        """Number of capsule links (one per joint)."""
        return len(self._link_sites()) - 1

    @property
    def task_dim(self) -> int:
        """Dimension of the end-effector task space: 3 (the ``"tcp"`` site's position)."""
        return 3

    def end_effector(self, q: ArrayLike) -> FloatArray:
        """Position of the ``"tcp"`` site [m], shape (3,).

        Args:
            q: Joint position [rad], shape (n,).

        Returns:
            The tool point [m], shape (3,).
        """
        qa = self._q(q)
        return self._site_jacobian_point(qa)

    def ee_jacobian(self, q: ArrayLike) -> FloatArray:
        """Linear-velocity Jacobian of the ``"tcp"`` site [m/rad], shape (3, n).

        Args:
            q: Joint position [rad], shape (n,).

        Returns:
            ``dp/dq`` [m/rad], shape (3, n).
        """
        return self._site_jacobian(self._q(q), self._site["tcp"])

    def _site_jacobian_point(self, q: FloatArray) -> FloatArray:
        self._pose(q)
        out = np.array(self._data_site_xpos()[self._site["tcp"]], dtype=float)
        if not np.all(np.isfinite(out)):
            raise InvalidInput("q: expected a pose with finite kinematics, got non-finite values")
        return out


document_inits(globals())
