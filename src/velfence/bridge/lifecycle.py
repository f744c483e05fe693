"""The ROS 2 managed-node state machine (``ros2 lifecycle``, Nav2's lifecycle manager).

The states and transitions are those of ``rcl_lifecycle``'s default state machine: the primary
states unconfigured (1), inactive (2), active (3) and finalized (4); a transition (configure 1,
cleanup 2, activate 3, deactivate 4, shutdown 5/6/7 from unconfigured/inactive/active) passes
through a transition state (configuring 10 … errorprocessing 15) and ends by the callback's
result (success, failure or error; ids 10–62). A callback that raises goes to
errorprocessing, whose own success returns to unconfigured.

The services are ``<node>/change_state``, ``get_state``, ``get_available_states``,
``get_available_transitions`` and ``get_transition_graph`` (which uses the
GetAvailableTransitions type, as rclcpp does); every completed step is published on
``<node>/transition_event``.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from velfence._docs import document_inits
from velfence.bridge import ros_interfaces as ri

__all__ = ["STATES", "TRANSITIONS", "LifecycleMachine"]

#: State id -> label.
STATES: dict[int, str] = {
    0: "unknown",
    1: "unconfigured",
    2: "inactive",
    3: "active",
    4: "finalized",
    10: "configuring",
    11: "cleaningup",
    12: "shuttingdown",
    13: "activating",
    14: "deactivating",
    15: "errorprocessing",
}

#: (transition id, label, start state, goal state), in rcl_lifecycle's order.
TRANSITIONS: tuple[tuple[int, str, int, int], ...] = (
    (1, "configure", 1, 10),
    (10, "transition_success", 10, 2),
    (11, "transition_failure", 10, 1),
    (12, "transition_error", 10, 15),
    (2, "cleanup", 2, 11),
    (20, "transition_success", 11, 1),
    (21, "transition_failure", 11, 2),
    (22, "transition_error", 11, 15),
    (3, "activate", 2, 13),
    (30, "transition_success", 13, 3),
    (31, "transition_failure", 13, 2),
    (32, "transition_error", 13, 15),
    (4, "deactivate", 3, 14),
    (40, "transition_success", 14, 2),
    (41, "transition_failure", 14, 3),
    (42, "transition_error", 14, 15),
    (5, "shutdown", 1, 12),
    (6, "shutdown", 2, 12),
    (7, "shutdown", 3, 12),
    (50, "transition_success", 12, 4),
    (51, "transition_failure", 12, 4),
    (52, "transition_error", 12, 15),
    (60, "transition_success", 15, 1),
    (61, "transition_failure", 15, 4),
    (62, "transition_error", 15, 4),
)

#: Transition state -> the name of the callback that runs in it.
_CALLBACKS = {
    10: "configure",
    11: "cleanup",
    12: "shutdown",
    13: "activate",
    14: "deactivate",
    15: "error",
}
_RESULTS = ("success", "failure", "error")


def _state(sid: int) -> ri.LifecycleState:
    return ri.LifecycleState(id=sid, label=STATES[sid])


def _description(tr: tuple[int, str, int, int]) -> ri.TransitionDescription:
    tid, label, start, goal = tr
    return ri.TransitionDescription(
        transition=ri.LifecycleTransition(id=tid, label=label),
        start_state=_state(start),
        goal_state=_state(goal),
    )


class LifecycleMachine:
    """The state machine and the answers of the lifecycle services.

    Args:
        callbacks: ``{"configure": f, "activate": f, ...}``; each returns ``"success"``,
            ``"failure"`` or ``"error"`` (a missing one succeeds; one that raises is an error).
        publish: Called with each :class:`~velfence.bridge.ros_interfaces.TransitionEvent`.
        initial: The starting primary state (1 unconfigured, or 3 active for a node that
            starts running).
    """

    def __init__(
        self,
        callbacks: dict[str, Callable[[], str]],
        publish: Callable[[ri.TransitionEvent], None],
        *,
        initial: int = 1,
    ) -> None:
        self.state = initial
        self._callbacks = callbacks
        self._publish = publish

    @property
    def label(self) -> str:
        """The current state's label."""
        return STATES[self.state]

    def _step(self, tid: int) -> None:
        tr = next(t for t in TRANSITIONS if t[0] == tid and t[2] == self.state)
        self.state = tr[3]
        self._publish(
            ri.TransitionEvent(
                timestamp=time.time_ns(),
                transition=ri.LifecycleTransition(id=tr[0], label=tr[1]),
                start_state=_state(tr[2]),
                goal_state=_state(tr[3]),
            )
        )

    def trigger(self, tid: int = 0, label: str = "") -> bool:
        """Run a transition by id, or by label (which takes precedence, as in rclcpp).

        Returns:
            Whether the transition exists from the current state and its callback succeeded.
        """
        candidates = [t for t in TRANSITIONS if t[2] == self.state and t[0] < 10]
        tr = next(
            (t for t in candidates if (t[1] == label if label else t[0] == tid)),
            None,
        )
        if tr is None:
            return False
        self._step(tr[0])
        result = self._run(_CALLBACKS[self.state])
        self._step(self._outcome(result))
        if self.state == 15:  # errorprocessing: its own callback decides where to go
            self._step(self._outcome(self._run("error")))
        return result == "success"

    def _outcome(self, result: str) -> int:
        base = {10: 10, 11: 20, 12: 50, 13: 30, 14: 40, 15: 60}[self.state]
        return base + _RESULTS.index(result)

    def _run(self, name: str) -> str:
        fn = self._callbacks.get(name)
        if fn is None:
            return "success"
        try:
            result = fn()
        except Exception:
            return "error"
        return result if result in _RESULTS else "error"

    # ---------------------------------------------------------------- the services
    def change_state(self, req: Any) -> ri.ChangeState_Response:
        """``change_state``."""
        ok = self.trigger(int(req.transition.id), str(req.transition.label))
        return ri.ChangeState_Response(success=ok)

    def get_state(self, req: Any) -> ri.GetState_Response:
        """``get_state``."""
        return ri.GetState_Response(current_state=_state(self.state))

    def get_available_states(self, req: Any) -> ri.GetAvailableStates_Response:
        """``get_available_states``: every state of the machine."""
        return ri.GetAvailableStates_Response(available_states=[_state(s) for s in STATES])

    def get_available_transitions(self, req: Any) -> ri.GetAvailableTransitions_Response:
        """``get_available_transitions``: those from the current state."""
        return ri.GetAvailableTransitions_Response(
            available_transitions=[_description(t) for t in TRANSITIONS if t[2] == self.state]
        )

    def get_transition_graph(self, req: Any) -> ri.GetAvailableTransitions_Response:
        """``get_transition_graph``: every transition of the machine."""
        return ri.GetAvailableTransitions_Response(
            available_transitions=[_description(t) for t in TRANSITIONS]
        )

    def handlers(self) -> tuple[tuple[str, type, type, Callable[[Any], Any]], ...]:
        """(service suffix, request type, response type, handler) of the five services."""
        gat = (ri.GetAvailableTransitions_Request, ri.GetAvailableTransitions_Response)
        return (
            ("change_state", ri.ChangeState_Request, ri.ChangeState_Response, self.change_state),
            ("get_state", ri.GetState_Request, ri.GetState_Response, self.get_state),
            ("get_available_states", ri.GetAvailableStates_Request,
             ri.GetAvailableStates_Response, self.get_available_states),
            ("get_available_transitions", *gat, self.get_available_transitions),
            ("get_transition_graph", *gat, self.get_transition_graph),
        )  # fmt: skip


document_inits(globals())
