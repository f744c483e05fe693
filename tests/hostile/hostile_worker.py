"""Preloaded by the fork server of ``harness.attack_many``: every public module imported and the
targets built once there, so that each worker process forked from it starts with them."""

from __future__ import annotations

import harness

harness.prepare_worker()
