"""Fixtures shared by the applications' tests: a real Dask cluster on 127.0.0.1."""

from __future__ import annotations

import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent / "engine"))
from dask_cluster import RealCluster


@pytest.fixture
def real_cluster(tmp_path: Path) -> Iterator[RealCluster]:
    """A scheduler and two workers as separate processes (tests/apps/engine/dask_cluster.py)."""
    cluster = RealCluster(2, tmp_path)
    try:
        yield cluster
    finally:
        cluster.close()
