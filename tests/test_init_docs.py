"""Every public class of the library shows its arguments in ``help(Class.__init__)``.

The arguments are documented once, in the class docstring; ``velfence._docs.document_inits``
gives each public class's ``__init__`` a docstring made from it. This walks every module of the
library (not ``velfence.apps``), every class of its ``__all__``, and checks that the docstring
``inspect.getdoc(Class.__init__)`` returns names each parameter of the constructor as an
``Args`` entry (``name: ...``) — or that the class has no constructor of its own.
"""

from __future__ import annotations

import importlib
import inspect
import pkgutil
import re
import warnings

import pytest

import velfence
from velfence._docs import document_inits, init_parameters


def _public_classes() -> dict[str, type]:
    found: dict[str, type] = {}
    for info in pkgutil.walk_packages(velfence.__path__, "velfence."):
        parts = info.name.split(".")
        if parts[1] == "apps" or any(p.startswith("_") for p in parts[1:]):
            continue
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", DeprecationWarning)
                module = importlib.import_module(info.name)
        except ModuleNotFoundError as exc:  # an optional extra
            if (exc.name or "").startswith("velfence"):
                raise
            continue
        for name in getattr(module, "__all__", ()):
            obj = getattr(module, name, None)
            if inspect.isclass(obj) and obj.__module__.startswith("velfence."):
                found.setdefault(f"{obj.__module__}.{obj.__qualname__}", obj)
    return found


CLASSES = _public_classes()


def test_the_walk_finds_the_library_classes() -> None:
    names = set(CLASSES)
    for want in (
        "velfence.filter.filter.SafetyFilter",
        "velfence.filter.limits.SphereObstacle",
        "velfence.geometry.polytope.ConvexPolytope",
        "velfence.filter.twist.TwistMode",
    ):
        assert want in names
    assert len(CLASSES) > 100


#: ROS 2 message structs: their fields are the ROS ``.msg`` definition's, named in the class
#: docstring by the message's name, not described field by field.
ROS_MESSAGES = ("velfence.bridge.msgs.", "velfence.bridge.ros_interfaces.")


@pytest.mark.parametrize("qualname", sorted(CLASSES))
def test_init_docstring_names_every_parameter(qualname: str) -> None:
    cls = CLASSES[qualname]
    params = init_parameters(cls)
    if not params:
        return  # no constructor arguments of its own (object.__init__, an exception, ...)
    doc = inspect.getdoc(cls.__init__) or ""  # type: ignore[misc]
    assert doc, qualname
    assert not doc.startswith("Initialize self"), qualname
    if qualname.startswith(ROS_MESSAGES):
        return
    missing = [p for p in params if not re.search(rf"^\s*\**{p}\b.*:", doc, re.MULTILINE)]
    assert not missing, f"{qualname}.__init__ docstring does not describe {missing}"


def test_the_mechanism_reads_args_and_attributes() -> None:
    class Demo:
        """A demo.

        Args:
            alpha: The first
                argument [m].
            beta: The second.

        Attributes:
            gamma: Set from beta.
        """

        def __init__(self, alpha: float, *, beta: float = 1.0) -> None:
            self.gamma = alpha + beta

    class Bare:
        """Nothing documented."""

        def __init__(self, x: int) -> None:
            self.x = x

    namespace = {"__name__": Demo.__module__, "__all__": ["Demo", "Bare"], "Demo": Demo,
                 "Bare": Bare}  # fmt: skip
    document_inits(namespace)
    doc = inspect.getdoc(Demo.__init__) or ""
    assert "Args:\n    alpha: The first\n        argument [m].\n    beta: The second." in doc
    assert "gamma" not in doc
    bare = inspect.getdoc(Bare.__init__) or ""
    assert "x:" not in bare  # nothing invented: the walk above would report it
