"""Figures of the telerobotics reproduction (Khokar 2009): kinematics, laser and motion checks.

Drawing functions of data already computed by ``velfence reproduce telerobotics``: each takes the
measured series (and the thesis numbers it compares them with) and writes one image, returning
its path. Nothing here runs a simulation.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Protocol

from velfence._extras import missing

try:
    import matplotlib
except ModuleNotFoundError as exc:  # an optional dependency: name the extra
    raise missing(exc, what=__name__) from exc

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from velfence._typing import FloatArray
from velfence.apps.teleop.laser import VoltageModel
from velfence.apps.teleop.thesis_data import (
    EQ1_OFFSET_CM,
    EQ1_SLOPE_CM_PER_V,
    TABLE1_DISTANCE_CM,
    TABLE1_VOLTAGE_V,
)
from velfence.apps.teleop.trajectory import Execution
from velfence.apps.viz.plots import save_figure

__all__ = [
    "ReadingSeries",
    "SingularityRuns",
    "StepSeries",
    "plot_accuracy",
    "plot_calibration",
    "plot_cartesian_errors",
    "plot_fk_errors",
    "plot_joint_angles",
    "plot_manipulability",
    "plot_readings",
    "plot_step",
]


# ------------------------------------------------------------------------------- kinematics
def plot_fk_errors(
    ea: FloatArray,
    eb: FloatArray,
    mean_err: dict[str, float],
    path: Path,
    *,
    tolerance_mm: float,
) -> Path:
    """Bar chart of the FK error per recorded final point (thesis Tables 4/5).

    Args:
        ea: Distance [mm] of each set-A final point to FK of its recorded joint angles, shape (10,).
        eb: The same for set B [mm], shape (10,).
        mean_err: ``{"A": mm, "B": mm}``, distance of FK to each set's mean point.
        path: Output image; its folder is created.
        tolerance_mm: The check's tolerance on the means [mm], drawn as a dotted line.

    Returns:
        The path written.
    """
    path.parent.mkdir(parents=True, exist_ok=True)
    fig, ax = plt.subplots(figsize=(8.0, 3.8))
    idx = np.arange(1, 11)
    ax.bar(idx - 0.2, ea, width=0.4, label="set A (Table 4) vs FK(traj. 1-2 final q)")
    ax.bar(idx + 0.2, eb, width=0.4, label="set B (Table 5) vs FK(traj. 3-5 final q)")
    ax.axhline(
        mean_err["A"], color="C0", ls="--", lw=1, label=f"|FK - set-A mean| {mean_err['A']:.2f}"
    )
    ax.axhline(
        mean_err["B"], color="C1", ls="--", lw=1, label=f"|FK - set-B mean| {mean_err['B']:.2f}"
    )
    ax.axhline(tolerance_mm, color="k", ls=":", lw=1, label=f"tolerance {tolerance_mm:g} (means)")
    ax.set_xticks(idx)
    ax.set_xlabel("recorded final point (trajectory of the repeatability set) [index]")
    ax.set_ylabel("distance to FK [mm]")
    ax.set_title("Khokar 2009: FK (eqs. 11-22) of the recorded joint angles vs Tables 4/5")
    ax.set_ylim(0.0, 1.6 * max(float(ea.max()), float(eb.max()), tolerance_mm))
    ax.legend(fontsize=7, loc="upper center", ncol=2)
    return save_figure(fig, path, dpi=120)


# ------------------------------------------------------------------------------------ laser
class ReadingSeries(Protocol):
    """Readings of the simulated DT60 at one true distance (what :func:`plot_readings` reads)."""

    @property
    def distance_cm(self) -> float:
        """True distance [cm]."""
        ...

    @property
    def t(self) -> FloatArray:
        """Sample times [s], shape (N,)."""
        ...

    @property
    def raw_cm(self) -> FloatArray:
        """Unfiltered readings [cm], shape (N,)."""
        ...

    @property
    def filtered_cm(self) -> FloatArray:
        """Filtered readings [cm], shape (N,)."""
        ...

    @property
    def raw_spread(self) -> float:
        """Max - min of the unfiltered readings [cm]."""
        ...

    @property
    def filtered_spread(self) -> float:
        """Max - min of the filtered readings [cm]."""
        ...


class StepSeries(Protocol):
    """One scheme's readings across a beam-length step (what :func:`plot_step` reads)."""

    @property
    def label(self) -> str:
        """Legend label."""
        ...

    @property
    def style(self) -> str:
        """Matplotlib line style, e.g. ``"-"`` or ``"o-"``."""
        ...

    @property
    def t(self) -> Sequence[float]:
        """Reading times [s]."""
        ...

    @property
    def distance_cm(self) -> Sequence[float]:
        """Readings [cm], one per time."""
        ...


def plot_calibration(path: Path, fit: VoltageModel, residual: FloatArray) -> Path:
    """Table 1 against eq. (1) and its re-fit, with the residual of eq. (1).

    Args:
        path: Output image.
        fit: The least-squares re-fit of distance on voltage.
        residual: Eq. (1) minus the Table 1 reference [cm], shape (21,).

    Returns:
        The path written.
    """
    V = np.asarray(TABLE1_VOLTAGE_V)
    D = np.asarray(TABLE1_DISTANCE_CM)
    fig, (ax, axr) = plt.subplots(
        2, 1, figsize=(6.4, 6.0), sharex=True, gridspec_kw={"height_ratios": [3, 1]}
    )
    vv = np.linspace(V.min() - 0.02, V.max() + 0.02, 50)
    ax.plot(V, D, "o", label="Table 1 (DME2000 reference)")
    ax.plot(
        vv,
        EQ1_SLOPE_CM_PER_V * vv + EQ1_OFFSET_CM,
        "-",
        label=f"eq. (1): {EQ1_SLOPE_CM_PER_V:.4f} V {EQ1_OFFSET_CM:+.4f}",
    )
    ax.plot(
        vv,
        fit.slope_cm_per_v * vv + fit.offset_cm,
        "--",
        label=f"re-fit: {fit.slope_cm_per_v:.4f} V {fit.offset_cm:+.4f}",
    )
    ax.set_ylabel("distance [cm]")
    ax.set_title("DT60 calibration (Khokar 2009, §3.3.1)")
    ax.legend(loc="upper left")
    axr.axhline(0.0, color="0.6", lw=0.8, label="no error")
    axr.plot(V, residual, "o-", ms=3, label="eq. (1) − Table 1, at its voltages")
    axr.legend(fontsize=7, loc="best")
    axr.set_xlabel("voltage [V]")
    axr.set_ylabel("eq. (1) − ref [cm]")
    return save_figure(fig, path, dpi=110)


def plot_readings(path: Path, runs: Sequence[ReadingSeries]) -> Path:
    """Raw and filtered readings at the eight Table 9 distances (2 x 4 panels).

    Args:
        path: Output image.
        runs: Eight series, one per distance.

    Returns:
        The path written.
    """
    fig, axes = plt.subplots(2, 4, figsize=(13, 6), sharex=True)
    for ax, r in zip(axes.ravel(), runs, strict=True):
        t = r.t - r.t[0]
        ax.plot(t, r.raw_cm, ".", ms=1.5, color="0.6", label="unfiltered (90 Hz)")
        ax.plot(t, r.filtered_cm, "-", lw=1.2, color="C0", label="50-sample average")
        ax.axhline(r.distance_cm, color="k", ls="--", lw=0.8, label="true")
        ax.set_title(
            f"{r.distance_cm:g} cm: spread {r.raw_spread:.1f} → {r.filtered_spread:.2f} cm",
            fontsize=9,
        )
        ax.set_ylim(r.distance_cm - 2.5, r.distance_cm + 2.5)
    for ax in axes[1]:
        ax.set_xlabel("time [s]")
    fig.supylabel("reading [cm]")  # each panel's own range, one quantity for all
    axes[0, 0].legend(fontsize=7, loc="lower right")
    fig.suptitle("Simulated DT60 readings at the Table 9 distances (Khokar 2009, §7.3)")
    return save_figure(fig, path, dpi=100)


def plot_step(path: Path, series: Sequence[StepSeries], *, t_step: float) -> Path:
    """Readings of each scheme across a step of the beam length, with the thesis's settling band.

    Args:
        path: Output image.
        series: One reading series per scheme.
        t_step: Time of the step [s].

    Returns:
        The path written.
    """
    fig, ax = plt.subplots(figsize=(7, 4))
    for s in series:
        ax.step(s.t, s.distance_cm, s.style, where="post", ms=3, label=s.label)
    ax.axvline(t_step, color="k", lw=0.8, ls=":", label=f"the step (t = {t_step:g} s)")
    ax.axvspan(t_step + 0.5, t_step + 0.55, color="C2", alpha=0.3, label="thesis: 0.5-0.55 s")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("reading [cm]")
    ax.set_title("Beam length steps 40 → 60 cm: settling of the two schemes")
    ax.legend(fontsize=8)
    return save_figure(fig, path, dpi=110)


# ----------------------------------------------------------------------------------- motion
class SingularityRuns(Protocol):
    """One §7.4 trajectory run with both inverses (what the motion figures read)."""

    @property
    def name(self) -> str:
        """``"trajectory 1"`` or ``"trajectory 2"``."""
        ...

    @property
    def jinv(self) -> Execution:
        """Execution with the plain inverse Jacobian."""
        ...

    @property
    def sr(self) -> Execution:
        """Execution with the singularity-robust inverse."""
        ...

    @property
    def open_loop_sr(self) -> Execution:
        """SR inverse with via-to-via increments (no feedback)."""
        ...


def plot_manipulability(
    runs: Sequence[SingularityRuns],
    singular_at: Sequence[float],
    path: Path,
    *,
    w0: float,
    title: str,
) -> Path:
    """Manipulability and det J over time, one panel per run (thesis Figs. 78/79).

    Args:
        runs: The runs.
        singular_at: Per run, the time [s] at which det J reached 0 under the plain inverse.
        path: Output image.
        w0: The SR inverse's manipulability threshold, drawn dashed.
        title: Figure title.

    Returns:
        The path written.
    """
    fig, axes = plt.subplots(1, len(runs), figsize=(11.0, 4.0))
    for ax, run_, t_s in zip(axes, runs, singular_at, strict=True):
        ax.plot(run_.jinv.t, run_.jinv.det, color="C3", lw=1.0, label="det J, J⁻¹")
        ax.plot(run_.sr.t, run_.sr.w, color="C0", lw=1.4, label="w, SR inverse")
        ax.plot(run_.sr.t, run_.sr.det, color="C0", lw=0.8, ls=":", label="det J, SR")
        ax.axhline(w0, color="k", ls="--", lw=0.8, label=f"w0 = {w0:g}")
        ax.axhline(0.0, color="k", lw=0.5)
        ax.axvline(t_s, color="C3", ls=":", lw=0.8, label=f"J⁻¹: det J = 0 at {t_s:.3f} s")
        # Linear up to the SR run's peak, logarithmic beyond: the plain inverse's det J swings
        # far past it once the arm is singular, and those swings stay in view.
        top = 1.2 * float(np.max(run_.sr.w))
        swing = float(np.max(np.abs(run_.jinv.det[np.isfinite(run_.jinv.det)])))
        ax.set_yscale("symlog", linthresh=top, linscale=4.0)
        ax.set_ylim(-max(0.3 * top, 1.3 * swing), max(top, 1.3 * swing))
        ax.set_xlabel("t [s]")
        ax.set_ylabel(f"manipulability w, det J [m³]\n(log beyond ±{top:.2g} m³)")
        ax.set_title(f"§7.4 {run_.name}", fontsize=10)
        ax.legend(fontsize=7)
    fig.suptitle(title, fontsize=10)
    return save_figure(fig, path, dpi=120)


def plot_joint_angles(runs: Sequence[SingularityRuns], path: Path) -> Path:
    """Joint angles over time under each inverse, one row per run.

    Returns:
        The path written.
    """
    fig, axes = plt.subplots(len(runs), 2, figsize=(11.0, 6.5), sharex="row")
    for row, run_ in enumerate(runs):
        for col, (label, ex) in enumerate((("J⁻¹", run_.jinv), ("SR inverse", run_.sr))):
            ax = axes[row, col]
            for j in range(ex.q.shape[1]):
                ax.plot(ex.t, np.degrees(ex.q_true[:, j]), lw=1.0, label=f"θ{j + 1}")
            if col == 0:
                ax.set_yscale("symlog", linthresh=360.0)
            ax.set_title(f"§7.4 {run_.name}, {label}", fontsize=9)
            ax.set_xlabel("t [s]")
            ax.set_ylabel("joint angle [deg]")
            ax.legend(fontsize=6, ncol=3)
    return save_figure(fig, path, dpi=120)


def plot_cartesian_errors(runs: Sequence[SingularityRuns], path: Path) -> Path:
    """Position and orientation error of the SR-inverse runs (and the open-loop variant).

    Returns:
        The path written.
    """
    fig, axes = plt.subplots(1, len(runs), figsize=(11.0, 4.0))
    for ax, run_ in zip(axes, runs, strict=True):
        ex = run_.sr
        ax.plot(ex.t, ex.tracking_error * 1e2, color="C0", label="position error [cm]")
        ax.plot(ex.t, np.degrees(ex.orientation_error), color="C1", label="orientation error [deg]")
        ax.plot(
            run_.open_loop_sr.t,
            run_.open_loop_sr.tracking_error * 1e2,
            color="C0",
            ls=":",
            label="position error, via-to-via (open loop) [cm]",
        )
        ax.set_xlabel("t [s]")
        ax.set_ylabel("position error [cm], orientation error [deg]")
        ax.set_title(f"§7.4 {run_.name}, SR inverse: Cartesian error", fontsize=10)
        ax.legend(fontsize=7)
    return save_figure(fig, path, dpi=120)


def plot_accuracy(acc: Sequence[Execution], path: Path, *, table_max_mm: float, title: str) -> Path:
    """Tracking error and path deviation of the §7.1 trajectories.

    Args:
        acc: One execution per trajectory.
        path: Output image.
        table_max_mm: Largest position error the thesis tabulates [mm], drawn dashed.
        title: Figure title.

    Returns:
        The path written.
    """
    fig, axes = plt.subplots(1, 2, figsize=(11.0, 3.8))
    for i, ex in enumerate(acc):
        axes[0].plot(ex.t, ex.tracking_error * 1e3, lw=1.0, label=f"trajectory {i + 1}")
        axes[1].plot(ex.t, ex.path_deviation * 1e3, lw=1.0, label=f"trajectory {i + 1}")
    axes[0].axhline(
        table_max_mm, color="k", ls="--", lw=0.8, label=f"Table 3 max {table_max_mm:g} mm"
    )
    axes[0].set_ylabel("|FK(q) - due via point| [mm]")
    axes[1].set_ylabel("distance from the segment start-end [mm]\n(overshoot at the stop)")
    for ax in axes:
        ax.set_xlabel("t [s]")
        ax.legend(fontsize=7)
    fig.suptitle(title, fontsize=10)
    return save_figure(fig, path, dpi=120)
