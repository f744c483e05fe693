"""The catalogue of bad (and valid-but-unusual) inputs the hostile suite applies to every argument.

A *kind* makes one value, either from nothing (``"12"``, ``None``, ``1e308``) or from the valid
value of the argument under attack (the valid vector with a NaN in it, transposed, as float32, ...),
and says, per parameter type, what the library must do with it:

* ``R`` -- refuse: raise a :class:`velfence.errors.VelfenceError` subclass whose message names the
  argument;
* ``A`` -- accept: return normally with finite output (a valid value in an unusual container);
* ``E`` -- either: refuse as above, or accept with finite output (never crash, hang or return NaN).

Parameter types: ``vector`` (array-like of real numbers), ``scalar`` (any real number),
``positive`` (a real > 0), ``nonneg`` (a real >= 0), ``count`` (an int >= 1), ``seed`` (an int
used to seed a generator),
``choice`` (one string among a fixed set), ``text`` (any string: names, titles), ``flag`` (a bool),
``object`` (a library object: polygon, path, scene, model, shaper), ``callable`` and ``path``
(a file path: any string may be refused as unreadable, non-strings must be refused).
"""

from __future__ import annotations

import datetime as _dt
from collections.abc import Callable
from dataclasses import dataclass
from decimal import Decimal
from fractions import Fraction
from typing import Any

import numpy as np

#: Parameter types the catalogue knows.
PTYPES = (
    "vector",
    "scalar",
    "positive",
    "nonneg",
    "count",
    "seed",
    "choice",
    "text",
    "flag",
    "object",
    "callable",
    "path",
    "rows",
)
NUMERIC = ("vector", "scalar", "positive", "nonneg", "count", "seed")
ALL = PTYPES


class NotApplicable(Exception):
    """Raised by a kind's maker when the kind makes no sense for this valid value."""


@dataclass(frozen=True)
class Kind:
    """One hostile (or unusual) input.

    Attributes:
        name: Catalogue name.
        make: ``make(valid) -> value``; raises :class:`NotApplicable` to skip.
        expect: Parameter type -> ``"R"``/``"A"``/``"E"``; types not listed are not attacked.
        derived: Whether the value is built from the valid value (else it is constant).
    """

    name: str
    make: Callable[[Any], Any]
    expect: dict[str, str]
    derived: bool = False
    note: str = ""
    timeout: float | None = None  # seconds, where the kind legitimately needs more than usual


def _const(value: Any) -> Callable[[Any], Any]:
    return lambda _valid: value


def _every(code: str, *types: str) -> dict[str, str]:
    return {t: code for t in (types or ALL)}


def _merge(*parts: dict[str, str]) -> dict[str, str]:
    out: dict[str, str] = {}
    for p in parts:
        out.update(p)
    return out


# --- hostile helper classes ------------------------------------------------------------------


class HostileFloat:
    """``__float__`` (and ``__index__``) raise: a conversion inside the library must not leak."""

    def __float__(self) -> float:
        raise ZeroDivisionError("hostile __float__")

    def __index__(self) -> int:
        raise ZeroDivisionError("hostile __index__")

    def __repr__(self) -> str:
        return "HostileFloat()"


class HostileArray:
    """``__array__`` raises."""

    def __array__(self, *args: Any, **kwargs: Any) -> Any:
        raise ZeroDivisionError("hostile __array__")

    def __repr__(self) -> str:
        return "HostileArray()"


class LyingLen:
    """A sequence whose ``__len__`` says 3 but whose items run out after one."""

    def __len__(self) -> int:
        return 3

    def __getitem__(self, i: int) -> float:
        if i == 0:
            return 1.0
        raise IndexError(i)

    def __repr__(self) -> str:
        return "LyingLen()"


class HugeLen:
    """A sequence that claims 10**12 entries (and runs out after three)."""

    def __len__(self) -> int:
        return 10**12

    def __getitem__(self, i: int) -> float:
        if i < 3:
            return 0.0
        raise IndexError(i)

    def __repr__(self) -> str:
        return "HugeLen()"


class HostileRepr:
    """A float-like object whose ``__repr__`` raises (messages must still be built)."""

    def __repr__(self) -> str:
        raise ZeroDivisionError("hostile __repr__")


class HostileBool:
    """An object whose truth value raises."""

    def __bool__(self) -> bool:
        raise ZeroDivisionError("hostile __bool__")

    def __repr__(self) -> str:
        return "HostileBool()"


def _recursive_list(_valid: Any) -> list[Any]:
    x: list[Any] = []
    x.append(x)
    return x


def _gen(_valid: Any) -> Any:
    return (float(i) for i in range(3))


def _valid_gen(valid: Any) -> Any:
    a = _vec(valid)
    return (x for x in a.tolist())


# --- derived makers ---------------------------------------------------------------------------


def _arr(valid: Any) -> np.ndarray[Any, Any]:
    """The valid value as a float array (only for numeric arrays of size >= 1)."""
    if valid is None or isinstance(valid, (str, bytes, bool, dict)):
        raise NotApplicable
    try:
        a = np.asarray(valid)
    except Exception:
        raise NotApplicable from None
    if a.dtype.kind not in "iuf" or a.size == 0:
        raise NotApplicable
    return a


def _vec(valid: Any) -> np.ndarray[Any, Any]:
    a = _arr(valid)
    if a.ndim == 0:
        raise NotApplicable
    return a


def _scal(valid: Any) -> Any:
    a = _arr(valid)
    if a.ndim != 0:
        raise NotApplicable
    return a.item()


def _with(entry: float) -> Callable[[Any], Any]:
    def make(valid: Any) -> Any:
        a = _vec(valid).astype(float)
        a.flat[0] = entry
        return a

    return make


def _transposed(valid: Any) -> Any:
    a = _vec(valid)
    if a.ndim != 2 or a.shape[0] == a.shape[1]:
        raise NotApplicable
    return a.T.copy()


def _longer(valid: Any) -> Any:
    a = _vec(valid).astype(float)
    return np.concatenate([a, a[-1:]], axis=0)


def _shorter(valid: Any) -> Any:
    a = _vec(valid).astype(float)
    if a.shape[0] < 2:
        raise NotApplicable
    return a[:-1]


def _wider(valid: Any) -> Any:
    a = _vec(valid).astype(float)
    return np.concatenate([a, a[..., -1:]], axis=-1)


def _readonly(valid: Any) -> Any:
    a = np.array(_vec(valid))
    a.setflags(write=False)
    return a


def _noncontig(valid: Any) -> Any:
    a = _vec(valid)
    big = np.repeat(a, 2, axis=-1)
    out = big[..., ::2]
    assert not out.flags.c_contiguous or out.size <= 1
    return out


def _fortran(valid: Any) -> Any:
    a = _vec(valid)
    if a.ndim < 2:
        raise NotApplicable
    return np.asfortranarray(a)


def _reversed_twice(valid: Any) -> Any:
    a = _vec(valid)
    return np.ascontiguousarray(a[::-1])[::-1]


def _as(dtype: Any) -> Callable[[Any], Any]:
    def make(valid: Any) -> Any:
        a = _vec(valid)
        if np.dtype(dtype).kind in "iu" and not np.array_equal(a, np.round(a)):
            raise NotApplicable
        return a.astype(dtype)

    return make


def _scalar_as(cast: Callable[[Any], Any], *, integral: bool = False) -> Callable[[Any], Any]:
    def make(valid: Any) -> Any:
        v = _scal(valid)
        if isinstance(v, float) and not np.isfinite(v):
            raise NotApplicable
        if integral and v != int(v):
            raise NotApplicable
        return cast(v)

    return make


def _zero_d(valid: Any) -> Any:
    return np.asarray(_scal(valid))


def _one_elem(valid: Any) -> Any:
    return np.asarray([_scal(valid)])


def _vec_to_scalar(valid: Any) -> Any:
    a = _vec(valid)
    return float(a.ravel()[0])


def _tuple_of(valid: Any) -> Any:
    a = _vec(valid)
    return tuple(tuple(r) if isinstance(r, list) else r for r in a.tolist())


def _list_of(valid: Any) -> Any:
    return _vec(valid).tolist()


def _strings_of(valid: Any) -> Any:
    return np.vectorize(str)(_vec(valid)).tolist()


def _str_choice_variant(transform: Callable[[str], str]) -> Callable[[Any], Any]:
    def make(valid: Any) -> Any:
        if not isinstance(valid, str) or not valid:
            raise NotApplicable
        return transform(valid)

    return make


def _bytes_choice(valid: Any) -> Any:
    if not isinstance(valid, str):
        raise NotApplicable
    return valid.encode()


def _np_str(valid: Any) -> Any:
    if not isinstance(valid, str):
        raise NotApplicable
    return np.str_(valid)


def _list_of_choice(valid: Any) -> Any:
    if not isinstance(valid, str):
        raise NotApplicable
    return [valid]


def _negated(valid: Any) -> Any:
    v = _scal(valid)
    if v == 0:
        raise NotApplicable
    return -v


def _tiny_array(valid: Any) -> Any:
    return np.full(_vec(valid).shape, 5e-324)


def _huge_int_array(valid: Any) -> Any:
    a = _vec(valid)
    return np.full(a.shape, 10**30, dtype=object).tolist()


_LONG = np.zeros(1_000_000)
_LONG.setflags(write=False)

# --- the catalogue ----------------------------------------------------------------------------

NONSENSE = _every("R", *NUMERIC, "nonneg", "choice", "text", "flag", "object", "callable")
NUM_R = _every("R", *NUMERIC)
SCALARS = ("scalar", "positive", "nonneg", "count", "seed")

KINDS: tuple[Kind, ...] = (
    # strings that look like numbers, and other strings
    Kind("str_int", _const("12"), _merge(NONSENSE, {"text": "A"})),
    Kind("str_float", _const("0.2"), _merge(NONSENSE, {"text": "A"})),
    Kind("str_nan", _const("nan"), _merge(NONSENSE, {"text": "A"})),
    Kind("str_inf", _const("inf"), _merge(NONSENSE, {"text": "A"})),
    Kind("str_word", _const("hello"), _merge(NONSENSE, {"text": "A"})),
    Kind("str_empty", _const(""), _merge(NONSENSE, {"text": "E"})),
    Kind("str_padded_number", _const(" 12 "), _merge(NONSENSE, {"text": "A"})),
    Kind("str_arabic_digits", _const("\u0661\u0662"), _merge(NONSENSE, {"text": "A"})),
    Kind("str_vector", _const("1, 2"), _merge(NONSENSE, {"text": "A"})),
    Kind("str_huge", _const("x" * 100_000), _merge(NONSENSE, {"text": "E"})),
    Kind("bytes", _const(b"12"), _every("R")),
    Kind("bytearray", _const(bytearray(b"12")), _every("R")),
    Kind("memoryview", _const(memoryview(b"12")), _every("R")),
    # containers that are not numbers
    Kind("dict_empty", _const({}), _every("R")),
    Kind("dict_xy", _const({"x": 1.0, "y": 2.0}), _every("R")),
    Kind("set", _const({1.0, 2.0}), _every("R")),
    Kind("frozenset", _const(frozenset({1.0})), _every("R")),
    # None and booleans
    Kind("none", _const(None), _every("R"), note="accepted where the parameter is optional"),
    Kind("true", _const(True), _merge(NONSENSE, {"text": "R", "flag": "A"})),
    Kind("false", _const(False), _merge(NONSENSE, {"text": "R", "flag": "A"})),
    Kind("np_true", _const(np.True_), _merge(NONSENSE, {"text": "R", "flag": "E"})),
    Kind("np_bool_array", _const(np.array([True, False])), _every("R")),
    Kind("bool_of_valid", _as(bool), {"vector": "R"}, derived=True),
    Kind("int_for_flag", _const(1), {"flag": "E", "choice": "R", "text": "R", "object": "R"}),
    # complex numbers
    Kind("complex", _const(1 + 2j), _every("R")),
    Kind("complex_real_part_only", _const(1 + 0j), _every("R")),
    Kind("complex_array", _const(np.array([1 + 1j, 2.0])), _every("R")),
    Kind("complex_of_valid", _as(complex), {"vector": "R"}, derived=True),
    Kind("np_complex_scalar", _const(np.complex128(0.5)), _every("R")),
    # object and exotic arrays
    Kind("object_array_mixed", _const(np.array([1.0, "a"], dtype=object)), _every("R")),
    Kind("object_array_none", _const(np.array([None, None], dtype=object)), _every("R")),
    Kind("object_of_valid", _as(object), {"vector": "E"}, derived=True),
    Kind("str_array", _const(np.array(["1", "2"])), _every("R")),
    Kind("strings_of_valid", _strings_of, {"vector": "R"}, derived=True),
    Kind("bytes_array", _const(np.array([b"1", b"2"])), _every("R")),
    Kind("structured_array", _const(np.zeros(2, dtype=[("a", float)])), _every("R")),
    Kind("masked_array", _const(np.ma.masked_array([1.0, 2.0], mask=[0, 1])), {"vector": "E"}),
    # dates and times
    Kind("datetime", _const(_dt.datetime(2024, 1, 1)), _every("R")),
    Kind("date", _const(_dt.date(2024, 1, 1)), _every("R")),
    Kind("timedelta", _const(_dt.timedelta(seconds=1)), _every("R")),
    Kind("np_datetime64", _const(np.datetime64("2024-01-01")), _every("R")),
    Kind("np_timedelta64", _const(np.timedelta64(1, "s")), _every("R")),
    Kind("datetime_array", _const(np.array(["2024-01-01"], dtype="datetime64[D]")), _every("R")),
    # other number types
    Kind("decimal", _const(Decimal("0.1")), _every("R", *NUMERIC, "choice", "text", "flag")),
    Kind("decimal_nan", _const(Decimal("NaN")), _every("R", *NUMERIC, "choice", "text", "flag")),
    Kind(
        "fraction",
        _const(Fraction(1, 3)),
        _merge(
            {"vector": "E", "scalar": "E"},
            {"positive": "E", "count": "R", "seed": "E", "choice": "R", "text": "R", "flag": "R"},
        ),
    ),
    Kind("longdouble_huge", _const(np.longdouble("1e4000")), _merge(NUM_R, {"choice": "R"})),
    # non-finite and extreme floats
    Kind("nan", _const(float("nan")), _merge(NONSENSE, {"text": "R"})),
    Kind("np_nan", _const(np.float64("nan")), _merge(NONSENSE, {"text": "R"})),
    Kind("inf", _const(float("inf")), _merge(NONSENSE, {"text": "R"})),
    Kind("neg_inf", _const(float("-inf")), _merge(NONSENSE, {"text": "R"})),
    Kind("float_1e308", _const(1e308), _merge(NUM_R, {"choice": "R", "flag": "R"})),
    Kind("float_neg_1e308", _const(-1e308), _merge(NUM_R, {"choice": "R", "flag": "R"})),
    Kind("float_1e200", _const(1e200), _merge(NUM_R, {"choice": "R"})),
    Kind(
        "float_5e_324",
        _const(5e-324),
        {"vector": "E", "scalar": "E", "positive": "E", "count": "R", "seed": "R", "flag": "R"},
    ),
    Kind("neg_zero", _const(-0.0), {"scalar": "E", "positive": "R", "count": "R"}),
    Kind("int_10_400", _const(10**400), _merge(NUM_R, {"choice": "R", "flag": "R"})),
    Kind(
        "int_10_30",
        _const(10**30),
        {
            "vector": "E",
            "scalar": "E",
            "positive": "E",
            "count": "R",
            "seed": "E",
            "choice": "R",
            "flag": "R",
        },
    ),
    Kind(
        "int_minus_1",
        _const(-1),
        {
            "positive": "R",
            "count": "R",
            "seed": "E",
            "scalar": "E",
            "choice": "R",
            "text": "R",
            "object": "R",
        },
    ),
    Kind(
        "int_zero",
        _const(0),
        {
            "positive": "R",
            "count": "E",
            "scalar": "E",
            "seed": "A",
            "choice": "R",
            "text": "R",
            "object": "R",
            "callable": "R",
        },
    ),
    Kind(
        "float_minus_1", _const(-1.0), {"positive": "R", "count": "R", "seed": "R", "scalar": "E"}
    ),
    Kind("float_2_5", _const(2.5), {"count": "R", "seed": "R", "choice": "R", "object": "R"}),
    Kind("float_integral", _const(3.0), {"count": "R", "seed": "R"}),
    Kind("negated_valid", _negated, {"positive": "R", "count": "R", "scalar": "E"}, derived=True),
    Kind("tiny_of_valid", _tiny_array, {"vector": "E"}, derived=True),
    Kind("nan_in_valid", _with(float("nan")), {"vector": "R"}, derived=True),
    Kind("inf_in_valid", _with(float("inf")), {"vector": "R"}, derived=True),
    Kind("neg_inf_in_valid", _with(float("-inf")), {"vector": "R"}, derived=True),
    # A huge finite entry is a real number: a shaper may refuse it or answer finitely (the
    # output walk checks the answer), as its on_invalid policy says.
    Kind("huge_in_valid", _with(1e308), {"vector": "E"}, derived=True),
    Kind("int_10_30_of_valid", _huge_int_array, {"vector": "E"}, derived=True),
    # empty, nested and ragged
    Kind("empty_list", _const([]), _merge(NUM_R, {"choice": "R", "text": "R", "object": "R"})),
    Kind("empty_tuple", _const(()), _merge(NUM_R, {"choice": "R", "object": "R"})),
    Kind("empty_array", _const(np.array([])), _merge(NUM_R, {"object": "R"})),
    Kind("empty_rows", _const(np.empty((0, 2))), _merge(NUM_R, {"object": "R"})),
    Kind("nested_too_deep", _const([[[1.0]]]), _merge(NUM_R, {"object": "R"})),
    Kind("ragged", _const([[1.0, 2.0], [3.0]]), _merge(NUM_R, {"object": "R"})),
    Kind("ragged_mixed", _const([1.0, [2.0, 3.0]]), _merge(NUM_R, {"object": "R"})),
    Kind("recursive_list", _recursive_list, _every("R")),
    # wrong shapes derived from the valid value
    Kind("added_axis", lambda v: _vec(v)[None], {"vector": "R"}, derived=True),
    Kind("three_d", lambda v: _vec(v)[None, None], {"vector": "R"}, derived=True),
    Kind("transposed", _transposed, {"vector": "R"}, derived=True),
    Kind(
        "one_longer",
        _longer,
        {"vector": "E"},
        derived=True,
        note="variable-length vectors may accept; fixed shapes must refuse",
    ),
    Kind("one_shorter", _shorter, {"vector": "E"}, derived=True),
    Kind("one_wider", _wider, {"vector": "E"}, derived=True),
    Kind("first_entry_only", _vec_to_scalar, {"vector": "E"}, derived=True),
    Kind("long_1e6", _const(_LONG), _merge(NUM_R, {"vector": "E"}), timeout=2.0),
    Kind(
        "one_element_array", _one_elem, {"scalar": "E", "positive": "E", "count": "E"}, derived=True
    ),
    Kind("vector_for_scalar", _const(np.array([1.0, 2.0])), _every("R", *SCALARS, "flag")),
    Kind("list_for_scalar", _const([1.0]), _every("R", *SCALARS, "flag", "choice")),
    # iterators and odd objects
    Kind("generator", _gen, _every("R")),
    Kind("generator_of_valid", _valid_gen, {"vector": "E"}, derived=True),
    Kind("iterator", lambda _v: iter([1.0, 2.0]), _every("R")),
    Kind("range", _const(range(3)), _merge(NUM_R, {"vector": "E", "object": "R"})),
    Kind(
        "lambda",
        _const(lambda *a, **k: 1.0),
        _every("R", *NUMERIC, "choice", "text", "flag", "object"),
    ),
    Kind("bare_object", _const(object()), _every("R")),
    Kind("ellipsis", _const(Ellipsis), _every("R")),
    Kind("type_float", _const(float), _every("R")),
    Kind("hostile_float", _const(HostileFloat()), _every("R")),
    Kind("hostile_array", _const(HostileArray()), _every("R")),
    Kind("hostile_repr", _const(HostileRepr()), _every("R")),
    Kind("hostile_bool", _const(HostileBool()), _every("R")),
    Kind("lying_len", _const(LyingLen()), _every("R")),
    Kind("huge_len", _const(HugeLen()), _every("R")),
    # choice strings
    Kind("choice_upper", _str_choice_variant(str.upper), {"choice": "R"}, derived=True),
    Kind("choice_padded", _str_choice_variant(lambda s: f" {s} "), {"choice": "R"}, derived=True),
    Kind("choice_bytes", _bytes_choice, {"choice": "R"}, derived=True),
    Kind("choice_in_list", _list_of_choice, {"choice": "R"}, derived=True),
    # valid values in unusual containers: must be accepted
    Kind("np_str_choice", _np_str, {"choice": "A", "text": "A"}, derived=True),
    Kind("tuple_of_valid", _tuple_of, {"vector": "A"}, derived=True),
    Kind("list_of_valid", _list_of, {"vector": "A"}, derived=True),
    Kind("float32_of_valid", _as(np.float32), {"vector": "A"}, derived=True),
    Kind("int64_of_valid", _as(np.int64), {"vector": "A"}, derived=True),
    Kind("readonly_of_valid", _readonly, {"vector": "A"}, derived=True),
    Kind("noncontiguous_of_valid", _noncontig, {"vector": "A"}, derived=True),
    Kind("fortran_of_valid", _fortran, {"vector": "A"}, derived=True),
    Kind("negative_strides_of_valid", _reversed_twice, {"vector": "A"}, derived=True),
    Kind(
        "np_float64_scalar", _scalar_as(np.float64), {"scalar": "A", "positive": "A"}, derived=True
    ),
    Kind(
        "np_float32_scalar", _scalar_as(np.float32), {"scalar": "A", "positive": "A"}, derived=True
    ),
    Kind(
        "int_of_valid",
        _scalar_as(int, integral=True),
        {"scalar": "A", "positive": "A"},
        derived=True,
    ),
    Kind(
        "np_int64_scalar",
        _scalar_as(np.int64, integral=True),
        {"scalar": "A", "positive": "A", "count": "A", "seed": "A"},
        derived=True,
    ),
    Kind("fraction_of_valid", _scalar_as(Fraction), {"scalar": "E", "positive": "E"}, derived=True),
    Kind("zero_d_of_valid", _zero_d, {"scalar": "A", "positive": "A", "count": "A"}, derived=True),
)

BY_NAME = {k.name: k for k in KINDS}
assert len(BY_NAME) == len(KINDS), "duplicate kind names"


def expectation(kind: Kind, ptype: str) -> str | None:
    """What the library must do with ``kind`` for a parameter of type ``ptype`` (None: skip)."""
    if ptype == "path":
        code = kind.expect.get("text")
        return "E" if code == "A" else code
    if ptype == "flag" and kind.name in ("true", "false"):
        return "E"  # another flag value may legitimately be refused in this call's context
    if ptype == "nonneg":
        if kind.name in ("int_zero", "neg_zero"):
            return "E"
        return kind.expect.get("nonneg", kind.expect.get("positive"))
    if ptype == "rows":
        # One vector or a batch of them (shape (d,) or (N, d)): a batch of one row and an
        # empty batch are valid batches.
        if kind.name in ("added_axis", "empty_rows"):
            return "E"
        return kind.expect.get("vector")
    return kind.expect.get(ptype)
