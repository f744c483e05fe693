"""The bridge's transform store: :class:`velfence.io.transforms.TransformStore`.

The store lives in :mod:`velfence.io.transforms`, where the bag replay uses it too; the bridge
fills it from ``/tf`` and ``/tf_static``.
"""

from __future__ import annotations

from velfence.io.transforms import TransformStore

__all__ = ["TransformStore"]
