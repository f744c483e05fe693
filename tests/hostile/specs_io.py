"""Specs of velfence.io."""

from __future__ import annotations

from harness import C, F, call

SPECS: dict[str, F | C] = {
    "io.DemoConfig": C(
        F(
            lambda: call(dt=0.001, seed=0),
            types={
                "polygon": "vector",
                "start": "vector",
                "duration": "positive",
                "noise_std": "nonneg",
            },
        )
    ),
    "io.load_config": F(lambda: call(None), types={"path": "path"}),
}
