"""A user's row provider that misbehaves is named in a VelfenceError, never a raw exception.

Found by a hostile review of the filter: RowBlocks that passed the shape check but carried
``names=None``, too few names, a raising names callable, ``b`` as a list, string keys, or a
``next_distances`` that raised or answered the wrong shape let a TypeError, IndexError,
AttributeError, ValueError or the provider's own exception escape ``filter`` / ``explain`` /
``filter_twist``. Also: metric weights whose ratio makes the solve's round-off dominate are
refused, and the model check's scaling accepts a solve's answer to the solve's own round-off
(a needless stop before).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

from velfence.errors import InvalidInput, InvalidParameter, VelfenceError
from velfence.filter import JointLimits, RowBlock, SafetyFilter
from velfence.filter import ladder as ld
from velfence.mechanisms.chain import DHChain

ARM = DHChain.seven_dof(link_radius=0.04)
LIM = ARM.joint_limits
Q0 = np.array([0.1, 0.6, 0.0, -1.2, 0.0, 0.8, 0.0])
E = np.eye(7)


def _block(**kw: Any) -> RowBlock:
    args: dict[str, Any] = {
        "G": E[:1], "b": np.array([-0.1]), "violated": np.zeros(1, bool), "keys": np.arange(1),
        "names": ["a"],
    }  # fmt: skip
    args.update(kw)
    return RowBlock(**args)


class _Provider:
    level = 1
    label = "table"

    def __init__(self, make: Callable[[], RowBlock], nxt: Any = None) -> None:
        self.make = make
        if nxt is not None:
            self.next_distances = nxt

    def rows(self, ctx: Any) -> RowBlock:
        return self.make()


def _distance_block(**kw: Any) -> RowBlock:
    return _block(b=np.array([0.0]), distance=np.array([0.0]), **kw)


CASES = {
    "names None": _Provider(lambda: _block(names=None)),
    "names too short": _Provider(
        lambda: _block(
            G=E[:2], b=np.array([-0.1, -0.1]), violated=np.zeros(2, bool), keys=np.arange(2)
        )
    ),
    "names callable raises": _Provider(lambda: _block(names=lambda: 1 / 0)),
    "string keys": _Provider(lambda: _block(keys=np.array(["k"]))),
    "next_distances raises": _Provider(_distance_block, nxt=lambda frame, blk: 1 / 0),
    "next_distances wrong shape": _Provider(_distance_block, nxt=lambda frame, blk: np.zeros(3)),
    "next_distances None": _Provider(_distance_block, nxt=lambda frame, blk: None),
    "distance wrong shape": _Provider(
        lambda: _block(b=np.array([0.0]), distance=np.zeros(4)), nxt=lambda frame, blk: np.zeros(1)
    ),
}


@pytest.mark.parametrize("backend", ["auto", "python"])
@pytest.mark.parametrize("case", sorted(CASES))
def test_a_bad_provider_is_named_in_a_velfence_error(case: str, backend: str) -> None:
    f = SafetyFilter(
        ARM, limits=JointLimits(LIM[:, 0], LIM[:, 1], max_speed=np.full(7, 1.5)),
        providers=[CASES[case]],
        dt=1e-3, backend=backend,
    )  # fmt: skip
    calls = (
        lambda: f.filter(Q0, -np.ones(7)),
        lambda: f.explain(Q0, -np.ones(7)),
        lambda: f.filter_twist(Q0, np.full(3, 0.5)),
    )
    errors: list[VelfenceError] = []
    for call in calls:
        try:
            out = call()
        except VelfenceError as exc:
            errors.append(exc)
        else:
            x = getattr(out, "output", out)
            assert np.all(np.isfinite(x))
    assert errors  # every case is refused by at least the call that reads the bad part
    assert all(isinstance(e, InvalidInput) and "table" in str(e) for e in errors), errors


def test_b_as_a_list_is_accepted_like_an_array() -> None:
    f = SafetyFilter(
        ARM, limits=JointLimits(LIM[:, 0], LIM[:, 1], max_speed=np.full(7, 1.5)),
        providers=[_Provider(lambda: _block(b=[-0.1]))], backend="python",
    )  # fmt: skip
    ref = SafetyFilter(
        ARM, limits=JointLimits(LIM[:, 0], LIM[:, 1], max_speed=np.full(7, 1.5)),
        providers=[_Provider(_block)], backend="python",
    )  # fmt: skip
    np.testing.assert_array_equal(f.filter(Q0, -np.ones(7)), ref.filter(Q0, -np.ones(7)))
    assert f.filter(Q0, -np.ones(7))[0] >= -0.1  # the provider's row holds


@pytest.mark.parametrize(
    "weights",
    [np.r_[np.ones(6), 1e-13], np.diag(np.r_[np.ones(6), 1e13])],
    ids=["vector", "matrix"],
)
def test_weight_ratios_beyond_1e12_are_refused(weights: Any) -> None:
    with pytest.raises(InvalidParameter, match="weights: expected the largest weight at most"):
        SafetyFilter(
            ARM,
            limits=JointLimits(LIM[:, 0], LIM[:, 1], max_speed=np.full(7, 1.5)),
            weights=weights,
        )
    SafetyFilter(  # 1e12 itself is accepted
        ARM, limits=JointLimits(LIM[:, 0], LIM[:, 1], max_speed=np.full(7, 1.5)),
        weights=np.r_[np.ones(6), 1e-12],
    )  # fmt: skip


def test_model_scaling_accepts_a_solve_answer_to_its_own_round_off() -> None:
    # A solve from a command of size 1500 misses a "no further out" row (c = 0) by 2e-11
    # relative to |x| = 1: that is the solve's round-off (1e-12 * |g| * |u|), and scaling x
    # cannot shrink it relative to x; judged against |x| alone nothing passes and the cycle stops.
    G = np.array([[1.0, 0.0]])
    c = np.array([0.0])
    x = np.array([-2e-11, 1.0])
    target = np.zeros(1)

    def nxt(xt: np.ndarray) -> np.ndarray:
        return np.zeros(1)  # the model check holds for every candidate

    out, how = ld._scaled(x, G, c, target, nxt)
    assert how == "stop"
    np.testing.assert_array_equal(out, 0.0)
    out, how = ld._scaled(x, G, c, target, nxt, 1500.0)
    assert how == "model-scaled"
    np.testing.assert_array_equal(out, x)
