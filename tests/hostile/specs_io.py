"""Specs of velfence.io."""

from __future__ import annotations

from harness import C, F, call

SPECS: dict[str, F | C] = {
    "io.DemoConfig": C(
        F(
            lambda: call(dt=0.001, seed=0),
            # The fields are Annotated[...] pydantic types, which the inference reads as objects.
            types={
                "polygon": "vector",
                "start": "vector",
                "dt": "positive",
                "duration": "positive",
                "noise_std": "nonneg",
                "seed": "seed",
                "saturate": "flag",
                "gif": "flag",
            },
        )
    ),
    "io.load_config": F(lambda: call(None), types={"path": "path"}),
    "io.check_run_length": F(lambda: call(1.0, 0.001), types={"duration_name": "text"}),
}
