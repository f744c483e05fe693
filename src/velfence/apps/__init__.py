"""The applications built on the velfence library.

Everything here uses the library (:mod:`velfence` and its subpackages) the way a user's own code
would, and nothing in the library imports it (the import contract in ``pyproject.toml``, checked
by ``make lint`` and ``tests/test_layers.py``):

* :mod:`velfence.apps.cli` — the ``velfence`` command line (``_entry`` is its console script);
* :mod:`velfence.apps.reproduce` — the reproductions of the five sources;
* :mod:`velfence.apps.demo`, :mod:`velfence.apps.soak`, :mod:`velfence.apps.soak_filter` — the
  demo and the containment campaigns;
* :mod:`velfence.apps.bench` — the benchmark runner and its cases (``velfence bench``; the
  stand-alone scripts under ``benchmarks/`` time the same cases);
* :mod:`velfence.apps.scenarios` — the MuJoCo scenarios (fence box, lag, obstacles, wrist);
* :mod:`velfence.apps.teleop` — the telerobotics study (Khokar 2009's traded control);
* :mod:`velfence.apps.viz` — plots, figures and videos; :mod:`velfence.apps.viewer` — the two
  interactive viewers (the browser canvas of a teleoperation session and the 3-D viser view).

Most need the ``[app]`` extra (typer, rich, pydantic, PyYAML, matplotlib); the viewers, the
scenarios and the peers' benchmarks need their own extras.
"""

__all__: list[str] = []
