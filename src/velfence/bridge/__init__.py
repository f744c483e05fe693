"""Bridges to other robot software: ROS 2 on the wire, vendor zones, Foxglove live view."""

from __future__ import annotations

__all__: list[str] = []
