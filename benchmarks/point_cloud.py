"""Point cloud to obstacle rows: ``PointCloudRows.update`` + ``rows``, and the filter cycle.

Usage: ``PYTHONPATH=src python benchmarks/point_cloud.py [--quick]`` prints two Markdown tables
(the ones in ``docs/benchmarks.md``, "Obstacles from point clouds").

The scene, in the base frame of the 7-joint arm (``DHChain.seven_dof(link_radius=0.04)`` at a
fixed pose): a table top (1.2 m x 1.2 m at z = 0.2 m, half the points), a box and a ball near
the gripper (a quarter), and the arm's own capsule surfaces (a quarter, which the self filter
removes); every frame draws new points with 2 mm of noise (seeded), as a depth camera does.
``voxel`` = 2 cm, ``decay`` = 0.5 s, ``nearest`` = 8, ``buffer`` = 5 cm, ``dt`` = 4 ms.

* **cloud to rows**: ``update(points, stamp)`` then ``rows(ctx)`` at 1k, 24k (a 160 x 150 depth
  image) and 100k points per frame;
* **filter cycle**: ``update`` then ``SafetyFilter.filter(q, u)`` with the provider, 24k points;
* **from the message**: the same clouds as ``sensor_msgs/PointCloud2`` CDR bytes (what DDS and
  rosbag2 carry; x, y, z FLOAT32 and an intensity, point_step 16, in a camera frame turned and
  moved against the base), ``decode_point_cloud2`` alone, then decode + ``update(points,
  stamp, transform=camera pose)`` + ``rows``: back to back, and in a periodic loop at 30 Hz (a
  depth camera's rate; each call starts on its tick, the time of the call is measured).

Each call is timed on its own with ``time.perf_counter_ns()`` and ``time.thread_time_ns()``, the
garbage collector off; the tables give the median, the 99th percentile and the maximum [ms].
"""

from __future__ import annotations

import argparse
import gc
import struct
import time
from collections.abc import Callable

import numpy as np

from velfence.filter import JointLimits, PointCloudRows, RowContext, SafetyFilter
from velfence.filter.kinematics import frame_of
from velfence.io.sensors import decode_point_cloud2
from velfence.mechanisms.chain import DHChain

DT = 0.004
SIZES = (1_000, 24_000, 100_000)
ARM = DHChain.seven_dof(link_radius=0.04)
Q0 = np.array([0.0, 0.6, 0.0, -1.2, 0.0, 0.8, 0.0])


def _frames(rng: np.random.Generator, count: int, frames: int) -> list[np.ndarray]:
    """``frames`` clouds of ``count`` points of the scene [m]."""
    segs = ARM.link_segments(Q0)
    tcp = frame_of(ARM, Q0).point("tcp")
    out = []
    for _ in range(frames):
        n_table = count // 2
        n_obj = count // 4
        n_arm = count - n_table - n_obj
        xy = rng.uniform(-0.6, 0.6, size=(n_table, 2))
        table = np.column_stack([xy, np.full(n_table, 0.2)])
        half = n_obj // 2
        box = tcp + np.array([0.2, -0.1, -0.3]) + rng.uniform(-0.05, 0.05, size=(half, 3))
        v = rng.normal(size=(n_obj - half, 3))
        ball = tcp + np.array([0.15, 0.1, 0.0]) + 0.06 * v / np.linalg.norm(v, axis=1)[:, None]
        link = rng.integers(0, segs.shape[0], size=n_arm)
        t = rng.uniform(size=n_arm)
        axis = segs[link, 0] + t[:, None] * (segs[link, 1] - segs[link, 0])
        w = rng.normal(size=(n_arm, 3))
        arm = axis + 0.04 * w / np.linalg.norm(w, axis=1)[:, None]
        pts = np.vstack([table, box, ball, arm]) + rng.normal(scale=0.002, size=(count, 3))
        out.append(pts)
    return out


#: The camera's pose in the base frame: turned 90° about z, 1 m behind and 0.5 m above.
CAMERA = np.array(
    [[0.0, -1.0, 0.0, -1.0], [1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.5], [0.0, 0.0, 0.0, 1.0]]
)


def _cdr_cloud(points: np.ndarray, stamp: float) -> bytes:
    """A PointCloud2 in little-endian CDR (header, x y z intensity FLOAT32, point_step 16)."""
    sec = int(stamp)
    body = struct.pack("<iI", sec, int((stamp - sec) * 1e9)) + struct.pack("<I", 7) + b"camera\0"
    body += b"\0" * (-len(body) % 4)
    body += struct.pack("<II", 1, points.shape[0]) + struct.pack("<I", 4)
    for i, name in enumerate((b"x", b"y", b"z", b"intensity")):
        body += struct.pack("<I", len(name) + 1) + name + b"\0"
        body += b"\0" * (-len(body) % 4) + struct.pack("<I", 4 * i) + b"\x07"
        body += b"\0" * (-len(body) % 4) + struct.pack("<I", 1)
    n = points.shape[0]
    body += b"\0" + b"\0" * (-(len(body) + 1) % 4) + struct.pack("<II", 16, 16 * n)
    data = np.zeros((n, 4), dtype="<f4")
    data[:, :3] = points
    body += struct.pack("<I", 16 * n) + data.tobytes() + b"\x01"
    return b"\x00\x01\x00\x00" + body


def _time(
    call: Callable[[int], object], calls: int, period: float | None = None
) -> tuple[np.ndarray, np.ndarray]:
    for k in range(5):  # warm-up
        call(k)
    wall = np.empty(calls)
    cpu = np.empty(calls)
    gc.disable()
    tick = time.perf_counter()
    try:
        for k in range(calls):
            if period is not None:  # a periodic loop: each call starts on its tick
                tick += period
                pause = tick - time.perf_counter()
                if pause > 0:
                    time.sleep(pause)
            c0 = time.thread_time_ns()
            t0 = time.perf_counter_ns()
            call(k + 5)
            wall[k] = (time.perf_counter_ns() - t0) / 1e6
            cpu[k] = (time.thread_time_ns() - c0) / 1e6
    finally:
        gc.enable()
    return wall, cpu


def _row(label: str, extra: str, wall: np.ndarray, cpu: np.ndarray) -> str:
    w = np.percentile(wall, [50, 99])
    c = np.percentile(cpu, [50, 99])
    return (
        f"| {label} | {extra} | {w[0]:.3f} | {w[1]:.3f} | {wall.max():.3f} | "
        f"{c[0]:.3f} | {c[1]:.3f} |"
    )


def _provider() -> PointCloudRows:
    return PointCloudRows(
        voxel=0.02,
        link_radius=ARM.link_radius,
        max_speed=np.full(7, 1.5),
        buffer=0.05,
        spring_gain=1.0,
        decay=0.5,
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="50 calls per row instead of 500")
    args = ap.parse_args()
    calls = 50 if args.quick else 500
    rng = np.random.default_rng(30)
    lim = np.radians([-170.0, -120.0, -170.0, -120.0, -170.0, -120.0, -175.0])
    limits = JointLimits(lim, -lim, max_speed=np.full(7, 1.5))
    frame = frame_of(ARM, Q0)
    ctx = RowContext(Q0, np.zeros(7), None, DT, frame)
    print(f"Cloud to rows, 7-joint arm, voxel 2 cm, {calls} calls per row, [ms]\n")
    print("| points | voxels / rows | median | p99 | max | CPU median | CPU p99 |")
    print("|---|---|---|---|---|---|---|")
    clouds: dict[int, list[np.ndarray]] = {}
    for size in SIZES:
        clouds[size] = _frames(rng, size, 16)
        rows = _provider()
        nrows: list[int] = []

        def cycle(
            k: int, rows: PointCloudRows = rows, size: int = size, nrows: list[int] = nrows
        ) -> None:
            rows.update(clouds[size][k % 16], stamp=k * DT)
            block = rows.rows(ctx)
            nrows.append(0 if block is None else block.size)

        wall, cpu = _time(cycle, calls)
        label = f"{rows.voxel_count} / {np.mean(nrows):.0f}"
        print(_row(f"{size:,}", label, wall, cpu))
    print(f"\nFilter cycle (update + filter), 24k points, dt = 4 ms, {calls} calls per row, [ms]\n")
    print("| filter | rows | median | p99 | max | CPU median | CPU p99 |")
    print("|---|---|---|---|---|---|---|")
    u = np.linalg.pinv(frame.jacobian("tcp")) @ np.array([0.3, 0.0, 0.0])
    plain = SafetyFilter(ARM, limits=limits, dt=DT)
    wall, cpu = _time(lambda k: plain.filter(Q0, u), calls)
    print(_row(f"no provider ({plain.backend})", "–", wall, cpu))
    rows = _provider()
    filt = SafetyFilter(ARM, limits=limits, providers=[rows], dt=DT)

    def fcycle(k: int) -> None:
        rows.update(clouds[24_000][k % 16], stamp=k * DT)
        filt.filter(Q0, u)

    wall, cpu = _time(fcycle, calls)
    block = rows.rows(ctx)
    print(_row("PointCloudRows", f"{0 if block is None else block.size}", wall, cpu))
    periodic = max(calls // 4, 30)
    print(
        f"\nFrom the message: PointCloud2 CDR bytes in a camera frame, {calls} calls per row "
        f"back to back, {periodic} at 30 Hz, [ms]\n"
    )
    print("| points | what | median | p99 | max | CPU median | CPU p99 |")
    print("|---|---|---|---|---|---|---|")
    inv = np.linalg.inv(CAMERA)
    for size in SIZES:
        raws = [
            _cdr_cloud(c @ inv[:3, :3].T + inv[:3, 3], 1000.0 + k * 0.033)
            for k, c in enumerate(clouds[size])
        ]
        check = decode_point_cloud2(raws[0]).points @ CAMERA[:3, :3].T + CAMERA[:3, 3]
        assert np.allclose(check, clouds[size][0], atol=1e-5)  # float32 coordinates
        wall, cpu = _time(lambda k, raws=raws: decode_point_cloud2(raws[k % 16]), calls)
        print(_row(f"{size:,}", "decode", wall, cpu))
        for label, period in (("decode + update + rows", None), ("same, at 30 Hz", 1 / 30)):
            rows = _provider()

            def mcycle(k: int, rows: PointCloudRows = rows, raws: list[bytes] = raws) -> None:
                sp = decode_point_cloud2(raws[k % 16])
                rows.update(sp.points, stamp=k * DT, transform=CAMERA)
                rows.rows(ctx)

            wall, cpu = _time(mcycle, periodic if period else calls, period)
            print(_row(f"{size:,}", label, wall, cpu))


if __name__ == "__main__":
    main()
