"""The validation layer's fast accept equals its full checks for every policy argument.

``real_array`` answers a float64 ndarray of the right shape without the full checks when it can
(a check in Python floats for small arrays, one reduction for larger ones, or none with
``allow_nonfinite`` and no magnitude cap). The same values seen as an ndarray subclass always take
the full checks; both must accept, return and refuse alike, for every combination of
``allow_nonfinite`` and ``max_abs``. ``real_floats`` is ``real_array`` answered as Python floats,
and ``finite_scalar``'s fast accept of a plain ``float`` equals its full checks (a float subclass).
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from velfence._validate import (
    MAX_MAGNITUDE,
    _fast_accept,
    finite_scalar,
    real_array,
    real_floats,
)

_SHAPES_OF_ARRAYS = hnp.array_shapes(min_dims=0, max_dims=3, min_side=0, max_side=3)
_VALUES = st.one_of(
    hnp.arrays(
        np.float64,
        _SHAPES_OF_ARRAYS,
        elements=st.floats(allow_nan=True, allow_infinity=True) | st.sampled_from([1e300, 1e16]),
    ),
    hnp.arrays(st.sampled_from([np.float32, np.int64, np.bool_, np.complex128]), _SHAPES_OF_ARRAYS),
    hnp.arrays(np.float64, st.sampled_from([(2,), (3,), (2, 2), (0,)])),
    st.lists(st.floats(), max_size=3),
    st.floats(),
    st.just("ab"),
    st.none(),
)
_SHAPES = st.sampled_from([None, (2,), (3,), (None,), (2, 2), (2, None), (None, None, None)])
_CAPS = st.sampled_from([MAX_MAGNITUDE, None, 1e20])


class array(np.ndarray):  # type: ignore[type-arg]  # noqa: N801
    """Not exactly ``np.ndarray``: the full checks, never the fast accept (named so that its repr,
    truncated in messages, reads as an ndarray's: the messages must be equal)."""


@given(_VALUES, _SHAPES, st.booleans(), _CAPS)
def test_fast_accept_equals_the_full_checks(x, shape, allow_nonfinite, max_abs):
    kw = {"what": "things", "allow_nonfinite": allow_nonfinite, "max_abs": max_abs}
    full = x.view(array) if isinstance(x, np.ndarray) else x
    try:
        want, err = np.asarray(real_array("x", full, shape, **kw)), None
    except Exception as exc:  # the full checks' refusal, compared below
        want, err = None, exc
    if err is not None:
        with pytest.raises(type(err)) as got:
            real_array("x", x, shape, **kw)

        def norm(m: str) -> str:
            return "".join(m.split())

        assert norm(str(got.value)) == norm(str(err))
        return
    got = real_array("x", x, shape, **kw)
    assert type(got) is np.ndarray
    assert got.dtype == want.dtype
    np.testing.assert_array_equal(got, want)
    if isinstance(x, np.ndarray):
        assert not np.shares_memory(got, x)
    # copy=False (readers of large batches): the same values, the input itself when it passes as
    # it is (a float64 ndarray), never a different answer.
    kept = real_array("x", x, shape, copy=False, **kw)
    np.testing.assert_array_equal(kept, want)
    if _fast_accept(x, shape, allow_nonfinite, max_abs):
        assert kept is x
    elif isinstance(x, np.ndarray):
        assert not np.shares_memory(kept, x)


@given(_VALUES, st.sampled_from([1, 2, 3]))
def test_real_floats_equals_real_array_as_floats(x, n):
    # real_floats is real_array with shape (n,), answered as Python floats: same acceptance,
    # same refusals and messages, the same values.
    try:
        want, err = real_array("x", x, (n,), what="things").tolist(), None
    except Exception as exc:  # the refusal, compared below
        want, err = None, exc
    if err is not None:
        with pytest.raises(type(err)) as got:
            real_floats("x", x, n, what="things")
        assert str(got.value) == str(err)
        return
    vals = real_floats("x", x, n, what="things")
    assert type(vals) is list
    assert all(type(v) is float for v in vals)
    assert vals == want


class _Float(float):
    """Not exactly ``float``: the full checks of ``finite_scalar``, never its fast accept."""


@given(
    st.floats(allow_nan=True, allow_infinity=True) | st.sampled_from([1e300, -1e151, 1e150]),
    st.sampled_from([MAX_MAGNITUDE, None, 1e20]),
)
def test_finite_scalar_fast_accept_equals_the_full_checks(x, max_abs):
    try:
        want, err = finite_scalar("x", _Float(x), max_abs=max_abs), None
    except Exception as exc:  # the refusal, compared below
        want, err = None, exc
    if err is not None:
        with pytest.raises(type(err)) as got:
            finite_scalar("x", x, max_abs=max_abs)
        assert str(got.value) == str(err)
        return
    got = finite_scalar("x", x, max_abs=max_abs)
    assert type(got) is float
    assert got == want


def test_zero_d_arrays_are_scalars_in_the_validation_layer() -> None:
    # DHChain.puma560(link_radius=np.array(0.05)) and counts given as np.array(3) were refused
    import numpy as np

    from velfence._validate import check_flag, check_positive, check_positive_int, finite_scalar
    from velfence.mechanisms import DHChain

    assert check_positive_int("n", np.array(3)) == 3
    assert check_positive("r", np.array(0.05)) == 0.05
    assert finite_scalar("x", np.array(-1.5)) == -1.5
    assert check_flag("f", np.array(True)) is True
    chain = DHChain.puma560(link_radius=np.array(0.05))
    np.testing.assert_array_equal(chain.link_radius, np.full(6, 0.05))
