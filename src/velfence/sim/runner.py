r"""Closed-loop runner: a shaper in the loop of a scripted operator and a kinematic plant.

Every step ``k = 0 … K`` at time :math:`t_k = k\,\Delta t` (see ``docs/simulation.md`` §1):

1. measured position :math:`\tilde p_k = p_k + \varepsilon_k`, :math:`\varepsilon_k \sim
   \mathcal N(0, \sigma^2 I)` drawn from ``numpy.random.default_rng(seed)``;
2. command :math:`v^{cmd}_k = c(t_k, p_k)` (the operator sees the true position);
3. shaped :math:`v_k = \mathrm{shaper}(\tilde p_k, v^{cmd}_k)`, then the actuator saturation
   :math:`v_k \leftarrow \mathrm{sat}(p_k, v_k)` when given;
4. explicit Euler on the true state, with the external velocity disturbance :math:`w`:
   :math:`p_{k+1} = p_k + \Delta t\,(v_k + w(t_k, p_k))` (not applied after the last row).

The state has the dimension of ``p0``: 2 for a workspace point (the polygon shapers), n for joint
vectors (the joint-stop limiter runs in the same loop, on joint angles).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, Literal, Protocol, get_args, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from velfence._docs import document_inits
from velfence._typing import FloatArray
from velfence._validate import (
    MAX_MAGNITUDE,
    check_choice,
    check_positive,
    check_positive_int,
    finite_scalar,
    readonly,
    real_array,
    show,
    step_count,
)
from velfence.errors import InvalidInput, InvalidParameter, VelfenceError
from velfence.shaping.base import Shaper

__all__ = [
    "CommandFn",
    "DisturbanceFn",
    "DynamicPlant",
    "SaturateFn",
    "Trajectory",
    "simulate",
    "simulate_many",
]


CommandFn = Callable[[float, FloatArray], ArrayLike]
"""Scripted operator ``(t [s], p (d,)) -> v_cmd (c,)`` [units / s]; usually c = d, but a shaper
may map another space's command into the state's (e.g. an end-effector velocity into joint
rates, c = task dimension)."""
DisturbanceFn = Callable[[float, FloatArray], ArrayLike]
"""External velocity disturbance ``(t [s], p (d,)) -> w (d,)`` [workspace units / s]."""
SaturateFn = Callable[[FloatArray, FloatArray], ArrayLike]
"""Actuator saturation ``(p (d,), v (d,)) -> v (d,)`` [workspace units / s]."""

Plant = Literal["kinematic"]
PLANTS: tuple[Plant, ...] = get_args(Plant)


@runtime_checkable
class DynamicPlant(Protocol):
    """A plant with dynamics of its own (e.g. :class:`velfence.sim.physics.MujocoPlant`).

    The runner calls ``reset(p0, dt)`` once (it returns the true initial state) and then, for
    every control period, ``advance(v, t)`` with the velocity reference held over
    ``[t, t + dt)``; it returns the true state at ``t + dt``.
    """

    def reset(self, q0: FloatArray, dt: float) -> FloatArray:
        """Start a run at ``q0`` [state units] with control period ``dt`` [s]; the true state."""
        ...

    def advance(self, v: FloatArray, t: float) -> FloatArray:
        """Apply reference ``v`` over one period from time ``t`` [s]; the new true state."""
        ...


MAX_STEPS = 10_000_000  # ~ 3 h at 1 kHz; ~ 0.5 GB of arrays


def _readonly_copy(
    name: str, x: ArrayLike, shape: tuple[int | None, ...], rule: str = ""
) -> FloatArray:
    # ``rule`` says which other argument fixed the expected shape (N rows from t, width from p).
    try:
        return readonly(real_array(name, x, shape, what="finite numbers"))
    except InvalidInput as exc:
        if not rule:
            raise
        raise InvalidInput(f"{exc}{rule}") from None


def _width(name: str, x: Any, default: int) -> int:
    """Row length of a recorded (N, c) array, ``default`` when ``x`` is not 2-D."""
    try:
        shape = np.shape(x)
    except Exception:  # ragged, hostile or huge: real_array names the argument
        return default
    return int(shape[1]) if len(shape) == 2 else default


@dataclass(frozen=True, eq=False, init=False)
class Trajectory:
    """A recorded closed-loop run (or a hand-made one, for metrics); read-only arrays.

    Row ``k`` is the state at ``t[k]`` and what the loop did there; ``v_out[k]`` is applied over
    ``[t[k], t[k+1])``. The last row is evaluated but not integrated.

    Attributes:
        t: Times, shape (N,), [s], strictly increasing, N >= 1.
        p: True positions, shape (N, 2), workspace units.
        v_cmd: Commanded velocities, shape (N, c) (c = d unless the shaper maps another space's
            command, e.g. end-effector velocities into joint rates), units per second.
        v_out: Velocities sent to the plant (shaped, then saturated), shape (N, 2).
        zone: Zone labels, shape (N,) of str: the shaper's zone names
            (``velfence.shaping.ZONE_NAMES``) in a simulated run, any label (a bridge's zone,
            ``"inside"``) in a recorded one; ``"unknown"`` when not given.
        name: Label of the run (the shaper's name in :func:`simulate_many`).
        p_measured: Positions the shaper saw (true + noise), shape (N, 2); defaults to ``p``.
    """

    t: FloatArray
    p: FloatArray
    v_cmd: FloatArray
    v_out: FloatArray
    zone: NDArray[np.str_]
    name: str
    p_measured: FloatArray

    def __init__(
        self,
        t: ArrayLike,
        p: ArrayLike,
        v_cmd: ArrayLike,
        v_out: ArrayLike,
        *,
        zone: ArrayLike | None = None,
        name: str = "",
        p_measured: ArrayLike | None = None,
    ) -> None:
        ta = real_array("t", t, (None,), what="times [s]")
        if ta.shape[0] < 1:
            raise InvalidInput("t: expected shape (N,) with N >= 1 times [s], got no rows")
        if np.any(np.diff(ta) <= 0.0):
            k = int(np.flatnonzero(np.diff(ta) <= 0.0)[0])
            raise InvalidInput(
                f"t: expected strictly increasing times [s], got t[{k}] = {ta[k]!r} >= "
                f"t[{k + 1}] = {show(ta[k + 1])}"
            )
        ta = readonly(ta)
        n = ta.shape[0]
        dim = _width("p", p, 2)
        pa = _readonly_copy("p", p, (n, dim), " (one row per entry of t)")
        rule = " (one row per entry of t, as wide as p)"
        pm = pa if p_measured is None else _readonly_copy("p_measured", p_measured, (n, dim), rule)
        if zone is None:
            za = np.full(n, "unknown")
        else:
            if isinstance(zone, (str, bytes)):
                raise InvalidInput(f"zone: expected {n} zone names, got {type(zone).__name__}")
            try:
                za = np.array(zone)
            except Exception:  # ragged, hostile or huge input; never repr() it
                raise InvalidInput(
                    f"zone: expected {n} zone names (str), got {type(zone).__name__}"
                ) from None
            if za.shape != (n,) or za.dtype.kind != "U":
                raise InvalidInput(
                    f"zone: expected {n} zone names (str) of shape ({n},), got "
                    f"{'dtype ' + str(za.dtype) if za.shape == (n,) else 'shape ' + str(za.shape)}"
                )
        za.setflags(write=False)
        if not isinstance(name, str):
            raise InvalidInput(f"name: expected a str label, got {type(name).__name__}")
        object.__setattr__(self, "t", ta)
        object.__setattr__(self, "p", pa)
        cdim = _width("v_cmd", v_cmd, dim)
        object.__setattr__(
            self, "v_cmd", _readonly_copy("v_cmd", v_cmd, (n, cdim), " (one row per entry of t)")
        )
        object.__setattr__(self, "v_out", _readonly_copy("v_out", v_out, (n, dim), rule))
        object.__setattr__(self, "zone", za)
        object.__setattr__(self, "name", name)
        object.__setattr__(self, "p_measured", pm)

    def __len__(self) -> int:
        """Number of rows N."""
        return int(self.t.shape[0])

    @property
    def duration(self) -> float:
        """``t[-1] - t[0]``, [s]."""
        return float(self.t[-1] - self.t[0])

    def window(self, t0: float, t1: float) -> Trajectory:
        """The rows with ``t0 <= t < t1`` [s], as a new trajectory (for per-phase metrics).

        Raises:
            InvalidInput: ``t0`` or ``t1`` not a finite real number, or no row in the window.
        """
        t0 = finite_scalar("t0", t0, unit="s", what="time")
        t1 = finite_scalar("t1", t1, unit="s", what="time")
        if not t1 > t0:
            raise InvalidInput(
                f"t1 must be later than t0 = {t0} s for the window [t0, t1), got t1 = {t1} s"
            )
        rows = (self.t >= t0) & (self.t < t1)
        if not rows.any():
            raise InvalidInput(
                f"t0, t1: no row in the window [{t0}, {t1}) s; "
                f"the run covers [{self.t[0]}, {self.t[-1]}] s"
            )
        return Trajectory(
            self.t[rows],
            self.p[rows],
            self.v_cmd[rows],
            self.v_out[rows],
            zone=self.zone[rows],
            name=self.name,
            p_measured=self.p_measured[rows],
        )


def _finite_vec(what: str, x: Any, dim: int | None, k: int, t: float) -> FloatArray:
    """A callable's result as a finite (dim,) vector; the message names the step and time."""
    size = "" if dim is None else f"{dim} "
    try:
        return real_array(what, x, (dim,), what=f"a vector of {size}finite numbers")
    except InvalidInput as exc:
        raise InvalidInput(
            f"{exc} at step {k} (t = {t} s); check the callable that produced it"
        ) from None


def _optional_callable(name: str, f: Any) -> None:
    if f is not None and not callable(f):
        raise InvalidParameter(f"{name} must be a callable or None, got {type(f).__name__}")
    # A class is callable but is not a callback: float(t, p) would raise TypeError mid-run.
    if isinstance(f, type):
        raise InvalidParameter(
            f"{name} must be a function (or None), got the class {f.__name__}; pass a function"
        )


def _n_steps(duration: float, dt: float) -> int:
    # Bounded first (no OverflowError, no hang for dt = 5e-324), then the exact rounding rule.
    step_count("duration", duration, "dt", dt, max_steps=MAX_STEPS)
    r = duration / dt
    k = round(r)
    steps = k if abs(r - k) <= 1e-9 * max(1.0, r) else math.ceil(r)
    steps = max(1, steps)
    if steps > MAX_STEPS:
        raise InvalidParameter(
            f"duration / dt must be at most {MAX_STEPS} steps, got {steps} "
            f"(duration={duration} s, dt={dt} s); shorten the run or increase dt"
        )
    return steps


def _validated_seed(seed: Any) -> int:
    return check_positive_int("seed", seed, minimum=0, maximum=2**63 - 1, example=0)


def simulate(
    shaper: Shaper,
    command: CommandFn,
    p0: ArrayLike,
    *,
    duration: float,
    dt: float = 1e-3,
    disturbance: DisturbanceFn | None = None,
    saturate: SaturateFn | None = None,
    noise_std: float = 0.0,
    seed: int = 0,
    plant: Plant | DynamicPlant = "kinematic",
    name: str | None = None,
    on_progress: Callable[[float], None] | None = None,
    on_result: Callable[[int, float, Any], None] | None = None,
) -> Trajectory:
    r"""Run ``shaper`` in closed loop and record the trajectory (explicit Euler, module docstring).

    Args:
        shaper: Any :class:`~velfence.shaping.base.Shaper`; its ``explain`` is called once per
            step (output and zone).
        command: Scripted operator ``(t, p) -> v_cmd``: time [s] and true position (read-only,
            shape (2,)) to a commanded velocity, shape (2,), workspace units per second.
        p0: Initial true position, shape (2,), workspace units.
        duration: Simulated time, [s], > 0. The run has ``K = ceil(duration / dt)`` steps
            (``round`` when within 1e-9 of an integer) and ``N = K + 1`` rows.
        dt: Control and integration period, [s], > 0 (default 1 ms, 1 kHz).
        disturbance: External velocity ``(t, p) -> w`` added to the plant's velocity, shape (2,),
            workspace units per second (e.g. :meth:`~velfence.sim.Disturbance.push`).
        saturate: Actuator limits ``(p, v) -> v`` applied to the shaped velocity at the true
            position (e.g. a mechanism's ``saturate``).
        noise_std: Standard deviation of the Gaussian position-measurement noise, per axis,
            workspace units, >= 0.
        seed: Seed of the ``numpy.random.default_rng`` that draws the noise (non-negative int).
        plant: ``"kinematic"`` (the integrator above) or a :class:`DynamicPlant` such as
            :class:`~velfence.sim.physics.MujocoPlant`, which receives the velocity (zero-order
            hold over each period) instead of the Euler step; ``disturbance`` is then refused
            (push bodies with the plant's own forces).
        name: Label of the trajectory; default ``type(shaper).__name__``.
        on_progress: Called with the completed fraction in [0, 1], about 100 times per run and
            with ``1.0`` at the end.
        on_result: Called as ``on_result(k, t, result)`` with every step's ``explain`` result
            (to log a shaper's diagnostics, e.g. the stop limiter's normal/tangential speeds).

    A shaper with ``stateful`` true and a ``reset()`` method (the stop limiter with rate
    limiters) is reset before the first step.

    Returns:
        The :class:`Trajectory` of ``N`` rows.

    Raises:
        InvalidParameter: for an out-of-range parameter or a non-callable.
        InvalidInput: for a bad ``p0``, or a callable or the shaper returning a wrong shape or
            non-finite values (the message names the step and time).
    """
    if not isinstance(shaper, Shaper):
        raise InvalidParameter(
            f"shaper must implement shape, explain and shape_batch, got {type(shaper).__name__}"
        )
    if not callable(command):
        raise InvalidParameter(
            f"command must be a callable (t, p) -> v_cmd, got {type(command).__name__}"
        )
    _optional_callable("command", command)
    _optional_callable("disturbance", disturbance)
    _optional_callable("saturate", saturate)
    _optional_callable("on_progress", on_progress)
    _optional_callable("on_result", on_result)
    duration = check_positive("duration", duration, unit="s")
    dt = check_positive("dt", dt, unit="s")
    noise_std = check_positive("noise_std", noise_std, allow_zero=True, unit="workspace units")
    seed = _validated_seed(seed)
    dynamic: DynamicPlant | None = None
    if isinstance(plant, DynamicPlant) and not isinstance(plant, str):
        dynamic = plant
        if disturbance is not None:
            raise InvalidParameter(
                "disturbance: a velocity disturbance belongs to the kinematic plant, got one with "
                f"plant={type(plant).__name__}; push bodies with the plant's forces instead"
            )
    else:
        check_choice("plant", plant, PLANTS)
    if name is not None and not isinstance(name, str):
        raise InvalidParameter(f"name: expected a str label or None, got {type(name).__name__}")
    p0a = real_array("p0", p0, (None,), what="an initial position")
    if p0a.shape[0] < 1:
        raise InvalidInput("p0: expected an initial position of shape (d,) with d >= 1, got []")
    dim = p0a.shape[0]
    steps = _n_steps(duration, dt)
    n = steps + 1
    # A stateful shaper (rate limiters) starts every run from rest, so runs never leak into
    # each other (simulate_many may pass the same instance twice).
    reset = getattr(shaper, "reset", None)
    if getattr(shaper, "stateful", False) and callable(reset):
        reset()
    rng = np.random.default_rng(seed)
    noise = rng.normal(0.0, noise_std, size=(n, dim)) if noise_std > 0.0 else None
    every = max(1, steps // 100)

    t_rec = np.empty(n)
    p_rec = np.empty((n, dim))
    pm_rec = np.empty((n, dim))
    vc_rec: FloatArray | None = None
    vo_rec = np.empty((n, dim))
    zones: list[str] = []
    state = p0a.copy()
    if dynamic is not None:
        state = _finite_vec("plant.reset(p0, dt)", dynamic.reset(p0a.copy(), dt), dim, 0, 0.0)
    for k in range(n):
        t = k * dt
        p = state.copy()
        p.setflags(write=False)
        pm = p if noise is None else p + noise[k]
        raw = command(t, p)
        cdim = None if vc_rec is None else vc_rec.shape[1]
        vc = _finite_vec("command(t, p)", raw, cdim, k, t)
        if vc_rec is None:
            vc_rec = np.empty((n, vc.shape[0]))
        if k == 0:
            try:
                res = shaper.explain(pm, vc)
            except VelfenceError as exc:
                # The first call is where a p0 or command of the wrong dimension shows up.
                raise type(exc)(
                    f"p0 (shape {p0a.shape}) or command(t, p) (shape {vc.shape}) does not fit "
                    f"the shaper: {exc}"
                ) from None
        else:
            res = shaper.explain(pm, vc)
        v = _finite_vec("shaper output", res.output, dim, k, t)
        if saturate is not None:
            v = _finite_vec("saturate(p, v)", saturate(p, v), dim, k, t)
        if on_result is not None:
            on_result(k, t, res)
        t_rec[k] = t
        p_rec[k] = state
        pm_rec[k] = pm
        vc_rec[k] = vc
        vo_rec[k] = v
        zones.append(str(res.zone))
        if k < steps:
            if dynamic is not None:
                state = _finite_vec("plant.advance(v, t)", dynamic.advance(v.copy(), t), dim, k, t)
            else:
                if disturbance is not None:
                    v = v + _finite_vec("disturbance(t, p)", disturbance(t, p), dim, k, t)
                state = state + dt * v
            if not (  # also catches NaN and inf; a short state in Python floats (cheaper)
                all(map(MAX_MAGNITUDE.__ge__, map(abs, state.tolist())))
                if dim <= 16
                else np.all(np.abs(state) <= MAX_MAGNITUDE)
            ):
                raise InvalidInput(
                    f"the state overflowed at step {k} (t = {t} s): expected |p| <= "
                    f"{MAX_MAGNITUDE:g}, got p = {state.tolist()}; check the shaper output and "
                    "the disturbance (too large for dt)"
                )
            if on_progress is not None and (k + 1) % every == 0 and k + 1 < steps:
                on_progress((k + 1) / steps)
    if on_progress is not None:
        on_progress(1.0)
    return Trajectory(
        t=t_rec,
        p=p_rec,
        v_cmd=vc_rec if vc_rec is not None else np.empty((n, dim)),
        v_out=vo_rec,
        zone=np.array(zones, dtype=str),
        name=type(shaper).__name__ if name is None else name,
        p_measured=pm_rec,
    )


def simulate_many(
    shapers: Mapping[str, Shaper],
    command: CommandFn,
    p0: ArrayLike,
    *,
    duration: float,
    dt: float = 1e-3,
    disturbance: DisturbanceFn | None = None,
    saturate: SaturateFn | None = None,
    noise_std: float = 0.0,
    seed: int = 0,
    plant: Plant | DynamicPlant = "kinematic",
    on_step: Callable[[str, float], None] | None = None,
) -> dict[str, Trajectory]:
    """Run several shapers through the same scenario, one :func:`simulate` each.

    Every run uses the same ``seed``, hence the same noise sequence (common random numbers, so
    differences between shapers are not noise).

    Args:
        shapers: Name -> shaper, non-empty; names become :attr:`Trajectory.name` and the keys of
            the result (same order).
        command: As in :func:`simulate`.
        p0: As in :func:`simulate`.
        duration: As in :func:`simulate`, [s].
        dt: As in :func:`simulate`, [s].
        disturbance: As in :func:`simulate`.
        saturate: As in :func:`simulate`.
        noise_std: As in :func:`simulate`, workspace units.
        seed: As in :func:`simulate`.
        plant: As in :func:`simulate`.
        on_step: Progress callback ``(name, fraction)``, fraction in [0, 1] of that shaper's run
            (about 100 calls per run, the last with 1.0); e.g. to drive a rich progress bar.

    Returns:
        Name -> :class:`Trajectory`.
    """
    if not isinstance(shapers, Mapping) or len(shapers) == 0:
        raise InvalidParameter(
            "shapers must be a non-empty mapping name -> shaper, got "
            f"{'an empty ' if isinstance(shapers, Mapping) else ''}{type(shapers).__name__}"
        )
    for key, value in shapers.items():
        if not isinstance(key, str):
            raise InvalidParameter(f"shapers: names must be str, got {type(key).__name__}")
        if not isinstance(value, Shaper):
            raise InvalidParameter(
                f"shapers['{str.__str__(key)}'] must implement shape, explain and shape_batch, "
                f"got {type(value).__name__}"
            )
    _optional_callable("on_step", on_step)

    def progress(name: str) -> Callable[[float], None] | None:
        if on_step is None:
            return None
        cb = on_step
        return lambda fraction: cb(name, fraction)

    return {
        name: simulate(
            shaper,
            command,
            p0,
            duration=duration,
            dt=dt,
            disturbance=disturbance,
            saturate=saturate,
            noise_std=noise_std,
            seed=seed,
            plant=plant,
            name=name,
            on_progress=progress(name),
        )
        for name, shaper in shapers.items()
    }


document_inits(globals())
