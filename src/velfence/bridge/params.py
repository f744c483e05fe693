"""The bridge's settings as ROS 2 parameters (``ros2 param list/get/set/describe``).

Every field of the ``bridge:`` section is a parameter, named as ROS 2 names nested parameters
(``command_in.topic``, ``diagnostics.period``). Most are read-only (their descriptor says so, and
a set is refused with that reason); the timing fields the node can change between two cycles
are writable: :data:`LIVE` lists them. A set goes through :mod:`velfence._validate` with the
bounds of the configuration file, and a refused value leaves the parameter as it was, with the
reason in ``SetParametersResult.reason``. Every accepted set is announced on
``/parameter_events`` (``rcl_interfaces/msg/ParameterEvent``, ``changed_parameters``).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any

from velfence._docs import document_inits
from velfence._validate import check_range
from velfence.bridge import ros_interfaces as ri
from velfence.bridge.config import BridgeConfig
from velfence.bridge.msgs import Time
from velfence.errors import VelfenceError

__all__ = ["LIVE", "PARAMETER_TYPES", "ParameterStore"]

#: ``rcl_interfaces/msg/ParameterType`` ids.
PARAMETER_TYPES: dict[str, int] = {
    "not_set": 0,
    "bool": 1,
    "integer": 2,
    "double": 3,
    "string": 4,
    "byte_array": 5,
    "bool_array": 6,
    "integer_array": 7,
    "double_array": 8,
    "string_array": 9,
}

#: The parameters that can change while the node runs: name -> (low, high] [s].
LIVE: dict[str, tuple[float, float]] = {
    "incoming_command_timeout": (0.0, 3600.0),
    "state_timeout": (0.0, 3600.0),
    "watchdog_period": (0.0, 3600.0),
    "diagnostics.period": (0.0, 3600.0),
}

_DESCRIPTIONS = {
    "incoming_command_timeout": "a command older than this [s] is stale (zero is sent)",
    "state_timeout": "a state older than this [s] is stale (every command is answered with zero)",
    "watchdog_period": "how often [s] the zero command is repeated while commands are stale",
    "diagnostics.period": "at most one diagnostics message per period [s]",
}


@dataclass
class _Param:
    value: Any
    type: int
    description: str


def _type_of(value: Any) -> int:
    if isinstance(value, bool):
        return PARAMETER_TYPES["bool"]
    if isinstance(value, int):
        return PARAMETER_TYPES["integer"]
    if isinstance(value, float):
        return PARAMETER_TYPES["double"]
    if isinstance(value, str):
        return PARAMETER_TYPES["string"]
    if isinstance(value, list) and all(isinstance(v, str) for v in value):
        return PARAMETER_TYPES["string_array"]
    return PARAMETER_TYPES["not_set"]


def _flatten(prefix: str, data: Any, out: dict[str, Any]) -> None:
    if isinstance(data, dict):
        for k, v in data.items():
            _flatten(f"{prefix}.{k}" if prefix else str(k), v, out)
    elif isinstance(data, list) and all(isinstance(v, dict) for v in data):
        for i, v in enumerate(data):  # sensors: sensors.0.topic, ...; none: no parameter
            _flatten(f"{prefix}.{i}", v, out)
    elif data is not None:
        out[prefix] = data


class ParameterStore:
    """The node's parameters and the answers of the six parameter services.

    Args:
        config: The validated bridge configuration (its ``bridge:`` section becomes the
            parameters; unset optional fields are left out).
        apply: Called with ``(name, value)`` for an accepted set of a :data:`LIVE` parameter,
            before the answer is written; it makes the node use the value.
        publish_event: Called with the ``/parameter_events`` message of each accepted set
            (one per parameter of ``set_parameters``, one for all of
            ``set_parameters_atomically``, as rclcpp does).
        node: The node's fully qualified name (``ParameterEvent.node``).
    """

    def __init__(
        self,
        config: BridgeConfig,
        apply: Callable[[str, float], None],
        *,
        publish_event: Callable[[ri.ParameterEvent], None] | None = None,
        node: str = "",
    ) -> None:
        flat: dict[str, Any] = {}
        _flatten("", config.settings.model_dump(), flat)
        flat["domain_id"] = config.domain_id  # the resolved domain (ROS_DOMAIN_ID or 0)
        self._params: dict[str, _Param] = {}
        for name in sorted(flat):
            value = flat[name]
            if isinstance(value, (list, tuple)):
                value = [str(v) for v in value]
            typ = _type_of(value)
            if typ == PARAMETER_TYPES["not_set"]:
                continue
            self._params[name] = _Param(value, typ, _DESCRIPTIONS.get(name, "bridge setting"))
        self._apply = apply
        self._publish_event = publish_event
        self._node = node

    def names(self) -> list[str]:
        """Every parameter's name, sorted."""
        return sorted(self._params)

    def get(self, name: str) -> Any:
        """A parameter's value (None for an unknown name)."""
        p = self._params.get(name)
        return None if p is None else p.value

    def event(self, *, new: Iterable[str] = (), changed: Iterable[str] = ()) -> ri.ParameterEvent:
        """The ``rcl_interfaces/msg/ParameterEvent`` for new and changed parameters, stamped now."""
        ns = time.time_ns()
        return ri.ParameterEvent(
            stamp=Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000),
            node=self._node,
            new_parameters=[self._parameter(n) for n in new],
            changed_parameters=[self._parameter(n) for n in changed],
        )

    def _parameter(self, name: str) -> ri.Parameter:
        return ri.Parameter(name=name, value=self._value(name))

    def _changed(self, names: list[str]) -> None:
        if names and self._publish_event is not None:
            self._publish_event(self.event(changed=names))

    # ---------------------------------------------------------------- values
    def _value(self, name: str) -> ri.ParameterValue:
        p = self._params.get(name)
        if p is None:
            return ri.ParameterValue(type=PARAMETER_TYPES["not_set"])
        v = ri.ParameterValue(type=p.type)
        if p.type == PARAMETER_TYPES["bool"]:
            v.bool_value = bool(p.value)
        elif p.type == PARAMETER_TYPES["integer"]:
            v.integer_value = int(p.value)
        elif p.type == PARAMETER_TYPES["double"]:
            v.double_value = float(p.value)
        elif p.type == PARAMETER_TYPES["string"]:
            v.string_value = str(p.value)
        else:
            v.string_array_value = list(p.value)
        return v

    def _descriptor(self, name: str) -> ri.ParameterDescriptor:
        p = self._params.get(name)
        if p is None:
            return ri.ParameterDescriptor(name=name, type=PARAMETER_TYPES["not_set"])
        d = ri.ParameterDescriptor(
            name=name, type=p.type, description=p.description, read_only=name not in LIVE
        )
        if name in LIVE:
            low, high = LIVE[name]
            d.additional_constraints = f"seconds in ({low:g}, {high:g}]"
            d.floating_point_range = [ri.FloatingPointRange(from_value=low, to_value=high)]
        return d

    def _check(self, param: Any) -> tuple[str, float | None]:
        """(reason, value): an empty reason and the checked value, or why it is refused."""
        name = str(param.name)
        p = self._params.get(name)
        if p is None:
            return f"parameter {name!r} is not declared (the bridge declares no new ones)", None
        if name not in LIVE:
            return f"parameter {name!r} is read-only (set it in the bridge file)", None
        v = param.value
        if v.type == PARAMETER_TYPES["double"]:
            raw: Any = float(v.double_value)
        elif v.type == PARAMETER_TYPES["integer"]:
            raw = int(v.integer_value)
        else:
            return (
                f"parameter {name!r} is a double [s], got a value of type "
                f"{_TYPE_NAMES.get(int(v.type), str(v.type))}",
                None,
            )
        low, high = LIVE[name]
        try:
            x = check_range(name, raw, low=low, high=high, low_open=True, unit="s")
        except VelfenceError as exc:
            return str(exc), None
        return "", x

    # ---------------------------------------------------------------- the services
    def list_parameters(self, req: Any) -> ri.ListParameters_Response:
        """``list_parameters``: names under the prefixes, to ``depth`` dots (0: all)."""
        prefixes = [str(p) for p in req.prefixes]
        depth = int(req.depth)
        names: list[str] = []
        found_prefixes: list[str] = []
        for name in self.names():
            if prefixes:
                ok = any(
                    name == pre
                    or (
                        name.startswith(pre + ".")
                        and (depth == 0 or name[len(pre) + 1 :].count(".") < depth)
                    )
                    for pre in prefixes
                )
            else:
                ok = depth == 0 or name.count(".") < depth
            if not ok:
                continue
            names.append(name)
            if "." in name:
                pre = name.rsplit(".", 1)[0]
                if pre not in found_prefixes:
                    found_prefixes.append(pre)
        return ri.ListParameters_Response(
            result=ri.ListParametersResult(names=names, prefixes=found_prefixes)
        )

    def get_parameters(self, req: Any) -> ri.GetParameters_Response:
        """``get_parameters``: one value per name (type NOT_SET for an unknown name)."""
        return ri.GetParameters_Response(values=[self._value(str(n)) for n in req.names])

    def get_parameter_types(self, req: Any) -> ri.GetParameterTypes_Response:
        """``get_parameter_types``."""
        types = [
            self._params[n].type if n in self._params else PARAMETER_TYPES["not_set"]
            for n in (str(x) for x in req.names)
        ]
        return ri.GetParameterTypes_Response(types=types)

    def describe_parameters(self, req: Any) -> ri.DescribeParameters_Response:
        """``describe_parameters``."""
        return ri.DescribeParameters_Response(
            descriptors=[self._descriptor(str(n)) for n in req.names]
        )

    def set_parameters(self, req: Any) -> ri.SetParameters_Response:
        """``set_parameters``: each parameter on its own; a refused one keeps its value."""
        results = []
        for param in req.parameters:
            reason, x = self._check(param)
            if x is not None:
                self._set(str(param.name), x)
                self._changed([str(param.name)])
            results.append(ri.SetParametersResult(successful=x is not None, reason=reason))
        return ri.SetParameters_Response(results=results)

    def set_parameters_atomically(self, req: Any) -> ri.SetParametersAtomically_Response:
        """``set_parameters_atomically``: all of them, or none (the first refusal's reason)."""
        checked = []
        for param in req.parameters:
            reason, x = self._check(param)
            if x is None:
                return ri.SetParametersAtomically_Response(
                    result=ri.SetParametersResult(successful=False, reason=reason)
                )
            checked.append((str(param.name), x))
        for name, x in checked:
            self._set(name, x)
        self._changed([name for name, _ in checked])
        return ri.SetParametersAtomically_Response(result=ri.SetParametersResult(successful=True))

    def _set(self, name: str, x: float) -> None:
        if not math.isfinite(x):  # check_range refuses these already; never store one
            return
        self._apply(name, x)
        self._params[name].value = x

    def handlers(self) -> Iterable[tuple[str, type, type, Callable[[Any], Any]]]:
        """(service suffix, request type, response type, handler) of the six services."""
        return (
            ("list_parameters", ri.ListParameters_Request, ri.ListParameters_Response,
             self.list_parameters),
            ("get_parameters", ri.GetParameters_Request, ri.GetParameters_Response,
             self.get_parameters),
            ("set_parameters", ri.SetParameters_Request, ri.SetParameters_Response,
             self.set_parameters),
            ("set_parameters_atomically", ri.SetParametersAtomically_Request,
             ri.SetParametersAtomically_Response, self.set_parameters_atomically),
            ("describe_parameters", ri.DescribeParameters_Request,
             ri.DescribeParameters_Response, self.describe_parameters),
            ("get_parameter_types", ri.GetParameterTypes_Request, ri.GetParameterTypes_Response,
             self.get_parameter_types),
        )  # fmt: skip


_TYPE_NAMES = {v: k for k, v in PARAMETER_TYPES.items()}

document_inits(globals())
