"""The machinery of the hostile suite: public-name enumeration, spec types, the guarded call and
the checks (see ``docs/reliability-inputs.md``)."""

from __future__ import annotations

import ast
import copy
import dataclasses
import functools
import importlib
import inspect
import math
import multiprocessing
import os
import pathlib
import pkgutil
import re
import resource
import signal
import sys
import tempfile
import time
import typing
import warnings
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
from kinds import KINDS, NotApplicable, expectation

import velfence
import velfence.apps
from velfence.errors import VelfenceError

#: Seconds one call may take before it counts as a hang (a kind may allow more, e.g. 10⁶ entries).
TIMEOUT_S = 1.0
#: The wall-clock alarm is this many times the CPU-time limit.
WALL_FACTOR = 10.0
#: Seconds the first (valid) call may take: it may compile numba kernels.
WARMUP_TIMEOUT_S = 60.0
#: After this many arguments that hung, a callable is not attacked further (heavy callables:
#: after the first).
MAX_HANGS = 2
#: CPU seconds beyond which a valid call's factory is replaced by deep copies of one of its calls
#: (where copying is at least twice as cheap; :func:`_fresh_calls`).
SLOW_FACTORY_S = 2e-3
#: The kinds tried on callables too heavy to run (their valid call is never made).
HEAVY_KINDS = ("str_int", "nan", "true", "dict_xy", "int_minus_1", "float_1e308")
#: Extra address space one call may take [bytes] (beyond what the process already has): a call
#: that tries to allocate more gets MemoryError (reported as an escape) instead of swapping.
MEMORY_HEADROOM = 2 * 1024**3
#: Skipped modules: the command-line front end (tests/apps/cli/test_cli.py, test_cli_hostile.py).
SKIP_MODULES = ("velfence.apps.cli",)
#: Modules inside a sub-package whose own ``__all__`` users import from directly (shown in the
#: documentation or the examples), attacked like the packages (docs/reliability-inputs.md,
#: "What is enumerated"; every other module-level ``__all__`` serves its package only).
EXTRA_MODULES = (
    "velfence.apps.demo.arm_box",
    "velfence.apps.scenarios.lag",
    "velfence.apps.verify.batch",
)
#: The repository root (the documentation and the examples are scanned for imports).
ROOT = pathlib.Path(__file__).resolve().parents[2]
_FENCE = re.compile(r"^```([A-Za-z0-9_{}-]*)[ \t]*\n(.*?)^```[ \t]*$", re.M | re.S)


def documented_sources() -> list[tuple[str, str]]:
    """``(where, code)`` of every ``python`` block of README.md and docs/**/*.md and of every
    ``examples/*.py``: the code users copy."""
    out: list[tuple[str, str]] = []
    for page in (ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))):
        for m in _FENCE.finditer(page.read_text(encoding="utf-8")):
            if m.group(1) == "python":
                out.append((str(page.relative_to(ROOT)), m.group(2)))
    for ex in sorted((ROOT / "examples").glob("*.py")):
        out.append((str(ex.relative_to(ROOT)), ex.read_text(encoding="utf-8")))
    return out


def documented_imports() -> dict[str, set[str]]:
    """Module path -> the names the documentation and the examples import from it.

    ``from velfence.x.y import A, B`` gives ``{"velfence.x.y": {"A", "B"}}``; ``import
    velfence.x.y`` gives ``{"velfence.x.y": {"*"}}`` (the module's whole ``__all__``). A block
    that does not parse is an error of the documentation (tests/test_readme.py runs it).
    """
    key = documented_sources  # a test may put a planted page in its place: its own entry
    if key not in _IMPORTS_MEMO:
        _IMPORTS_MEMO[key] = _documented_imports(documented_sources())
    return {k: set(v) for k, v in _IMPORTS_MEMO[key].items()}


#: Parsed once per worker: every hostile file asks, and parsing every docs page takes seconds.
_IMPORTS_MEMO: dict[Any, dict[str, set[str]]] = {}
_CALLABLES_MEMO: dict[Any, dict[str, Any]] = {}
_MODULES_MEMO: list[str] = []


def _documented_imports(sources: list[tuple[str, str]]) -> dict[str, set[str]]:
    out: dict[str, set[str]] = {}
    for where, code in sources:
        try:
            tree = ast.parse(code, filename=where)
        except SyntaxError as exc:
            raise AssertionError(f"{where}: a python block does not parse: {exc}") from exc
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                if node.module.split(".")[0] == "velfence":
                    out.setdefault(node.module, set()).update(a.name for a in node.names)
            elif isinstance(node, ast.Import):
                for alias in node.names:
                    if alias.name.split(".")[0] == "velfence":
                        out.setdefault(alias.name, set()).add("*")
    return out


# --- the registry's vocabulary ----------------------------------------------------------------


@dataclass
class Call:
    """One call: positional and keyword arguments."""

    args: tuple[Any, ...] = ()
    kwargs: dict[str, Any] = field(default_factory=dict)


def call(*args: Any, **kwargs: Any) -> Call:
    """A :class:`Call` (shorthand used by the spec modules)."""
    return Call(args, kwargs)


@dataclass
class F:
    """Spec of a function, or of a method (inside :class:`C`), or of a constructor (``C.new``).

    Attributes:
        valid: Factory of one valid call.
        types: Parameter name -> parameter type (see :mod:`kinds`), overriding the inferred type.
        heavy: Reason the callable is too heavy to run: then only :data:`HEAVY_KINDS` are tried,
            and they must all be refused quickly.
        skip: Parameter name -> reason it is not attacked (e.g. a numpy Generator).
        required: Parameters whose annotation allows ``None`` but whose valid call needs a
            value (``None`` is then tried as "either").
        accepts: Parameter name -> {kind name: reason}: a kind the catalogue would refuse but
            whose value the callable documents as valid (an empty list meaning "none", ``inf``
            meaning "no limit"); it must then be accepted. Every entry is argued in
            docs/reliability-inputs.md ("Documented exemptions").
        nonfinite: Output path (``out``, ``out.distance``, ``out['key']``) -> reason: a
            non-finite value there is a documented answer (``inf``: never; ``nan``: undefined),
            argued in the same section.
    """

    valid: Callable[[], Call]
    types: dict[str, str] = field(default_factory=dict)
    heavy: str | None = None
    skip: dict[str, str] = field(default_factory=dict)
    required: frozenset[str] = frozenset()  # parameters typed Optional where None is refused here
    accepts: dict[str, dict[str, str]] = field(default_factory=dict)
    nonfinite: dict[str, str] = field(default_factory=dict)


@dataclass
class C:
    """Spec of a class: its constructor and its public methods.

    Attributes:
        new: Spec of the constructor (``None`` with ``record`` or ``abstract`` given).
        methods: Method name -> spec (an :class:`F`, or a bare factory of a valid call).
        instance: Factory of a valid instance for the methods (default: call ``new``).
        record: Reason the constructor is not attacked (an output record the library builds).
        abstract: Reason the class is not called at all (a Protocol).
    """

    new: F | Callable[[], Call] | None = None
    methods: dict[str, F | Callable[[], Call]] = field(default_factory=dict)
    instance: Callable[[], Any] | None = None
    record: str | None = None
    abstract: str | None = None


def as_f(spec: F | Callable[[], Call]) -> F:
    return spec if isinstance(spec, F) else F(spec)


# --- enumeration ------------------------------------------------------------------------------


#: Public modules that cannot be imported here because an optional dependency (an extra) is not
#: installed: module -> the missing package. Their names are neither attacked nor required to
#: have a spec (a core-only install runs the catalogue on the core modules).
UNAVAILABLE: dict[str, str] = {}


def _optional(exc: ModuleNotFoundError) -> bool:
    """Whether the missing module is a third-party one (a missing velfence module is a bug)."""
    return exc.name is not None and exc.name.split(".")[0] != "velfence"


def public_modules() -> list[str]:
    """``velfence`` and every public sub-module or sub-package that declares ``__all__``."""
    if not _MODULES_MEMO:
        _MODULES_MEMO.extend(_public_modules())
    return list(_MODULES_MEMO)


def _public_modules() -> list[str]:
    names = ["velfence"]
    infos = [("velfence", info) for info in pkgutil.iter_modules(velfence.__path__)]
    infos += [("velfence.apps", info) for info in pkgutil.iter_modules(velfence.apps.__path__)]
    for package, info in infos:
        full = f"{package}.{info.name}"
        if info.name.startswith("_") or info.name == "apps" or full in SKIP_MODULES:
            continue
        try:
            importlib.import_module(full)
        except ModuleNotFoundError as exc:
            if not _optional(exc):
                raise
            UNAVAILABLE[full] = str(exc.name)
            continue
        names.append(full)
    for full in EXTRA_MODULES:
        try:
            importlib.import_module(full)
        except ModuleNotFoundError as exc:
            if not _optional(exc):
                raise
            UNAVAILABLE[full] = str(exc.name)
            continue
        names.append(full)
    return names


def available(key: str) -> bool:
    """Whether the module of a canonical name (``"viz.plot_quiver"``) could be imported."""
    parts = key.split(".")[:-1]
    return all(_full(".".join(parts[: i + 1])) not in UNAVAILABLE for i in range(len(parts)))


@functools.cache
def _apps() -> frozenset[str]:
    return frozenset(info.name for info in pkgutil.iter_modules(velfence.apps.__path__))


def _full(short: str) -> str:
    """The module path of a canonical name's module (the applications under velfence.apps)."""
    apps = _apps()
    return f"velfence.apps.{short}" if short.split(".")[0] in apps else f"velfence.{short}"


def _skipped_by_type(obj: Any) -> bool:
    if inspect.isclass(obj):
        return issubclass(obj, BaseException)
    if typing.get_origin(obj) is not None:  # a type alias (``EngineMode = Literal[...]``): data
        return True
    return not callable(obj)


def public_callables() -> dict[str, Any]:
    """Canonical name (``"shaping.PolygonShaper"``) -> object, for every public callable.

    A name exported from several modules gets the name of the deepest module (the sub-package,
    not the top-level re-export). Constants, data and exception classes are skipped by type.
    """
    key = documented_sources
    if key not in _CALLABLES_MEMO:
        _CALLABLES_MEMO[key] = _public_callables()
    return dict(_CALLABLES_MEMO[key])


def _public_callables() -> dict[str, Any]:
    found: dict[int, tuple[str, Any]] = {}
    for modname in public_modules():
        mod = importlib.import_module(modname)
        for name in getattr(mod, "__all__", ()):
            obj = getattr(mod, name)
            if _skipped_by_type(obj):
                continue
            key = _key(modname, name)
            old = found.get(id(obj))
            if old is None or old[0].count(".") < key.count("."):
                found[id(obj)] = (key, obj)
    for key, obj in documented_callables().items():
        found.setdefault(id(obj), (key, obj))  # a name also exported by a package keeps its key
    return dict(sorted(found.values(), key=lambda kv: kv[0]))


def _key(modname: str, name: str) -> str:
    short = modname.removeprefix("velfence").removeprefix(".apps").lstrip(".")
    return f"{short}.{name}" if short else name


def documented_callables() -> dict[str, Any]:
    """Canonical name -> object of every callable the documentation and the examples import
    (:func:`documented_imports`), keyed by the module they import it from.

    Modules whose optional dependency is missing are recorded in :data:`UNAVAILABLE`, the CLI
    module (:data:`SKIP_MODULES`) is attacked through its command line (test_cli_hostile.py).
    """
    out: dict[str, Any] = {}
    for modname, names in sorted(documented_imports().items()):
        if modname in SKIP_MODULES:
            continue
        try:
            mod = importlib.import_module(modname)
        except ModuleNotFoundError as exc:
            if not _optional(exc):
                raise
            UNAVAILABLE[modname] = str(exc.name)
            continue
        wanted = set(getattr(mod, "__all__", ())) if "*" in names else names - {"*"}
        for name in sorted(wanted):
            obj = getattr(mod, name)  # a documented name that does not exist: AttributeError
            if inspect.ismodule(obj) or _skipped_by_type(obj):
                continue
            out[_key(modname, name)] = obj
    return out


def is_protocol(cls: type) -> bool:
    return bool(getattr(cls, "_is_protocol", False))


def public_methods(cls: type) -> list[str]:
    """Public methods (not properties, not from outside velfence) of ``cls``, sorted."""
    out = []
    for name in dir(cls):
        if name.startswith("_"):
            continue
        owner = next((c for c in cls.__mro__ if name in c.__dict__), None)
        if owner is None or not owner.__module__.startswith("velfence"):
            continue
        raw = owner.__dict__[name]
        if isinstance(raw, property) or not callable(getattr(cls, name)):
            continue
        if dataclasses.is_dataclass(cls) and name in {f.name for f in dataclasses.fields(cls)}:
            continue
        out.append(name)
    return sorted(out)


# --- parameter types --------------------------------------------------------------------------

_POSITIVE = re.compile(
    r"(^dt$|duration|radius|^tol$|_tol$|gain|rate$|speed|spacing|time|length|stiffness|force|"
    r"window|step|margin|buffer|influence|_range$|inertia|^k[pd0]?$|^w0$|^max_|^min_|period|"
    r"extent|height|quantum|share|limit$|tick|band$|substep|along|across|standoff|rise|"
    r"above_destination|settle|d_max|d_safe|friction|noise|spring|recovery|damping|weight|"
    r"^omega$|^eps$|^u$|^r_o$|^max_speed$|^max_acceleration$|^ds$|^epsilon$|^sigma$)"
)


_NONNEG = re.compile(
    r"(noise|tremor|margin|friction|damping|spring|recovery|tol$|weight|"
    r"lookahead|error$|^t0$|curvature$)"
)


def _is_choice(base: str, namespace: dict[str, Any] | None) -> bool:
    """Whether the annotation ``base`` names a ``Literal`` of strings (a typed choice)."""
    alias = (namespace or {}).get(base)
    if typing.get_origin(alias) is not Literal:
        return False
    return all(isinstance(a, str) for a in typing.get_args(alias))


def infer_type(param: inspect.Parameter, namespace: dict[str, Any] | None = None) -> str:
    """The parameter type of ``param`` (see :mod:`kinds`), from its annotation, name and default.

    ``namespace`` (the callable's module globals) resolves an annotation that names a ``Literal``
    alias (``OnInvalid``, ``PolygonMethod``, ...): such a parameter is a choice.
    """
    ann = param.annotation
    text = ann if isinstance(ann, str) else getattr(ann, "__name__", str(ann))
    base = text.replace(" | None", "").replace("None | ", "").strip()
    name = param.name
    if _is_choice(base, namespace):
        return "choice"
    if "Callable" in base or base.endswith("Fn") or base == "Progress":
        return "callable"
    if base in ("float", "float | int"):
        if _NONNEG.search(name):
            return "nonneg"
        if _POSITIVE.search(name):
            d = param.default
            zero_ok = isinstance(d, (int, float)) and d == 0
            return "nonneg" if zero_ok else "positive"
        return "scalar"
    if base == "int":
        return "seed" if name == "seed" else "count"
    if base == "bool":
        return "flag"
    if base == "str":
        return "text" if name in ("name", "title", "message", "source", "note") else "choice"
    if base == "complex":
        return "scalar"
    if any(t in base for t in ("ArrayLike", "FloatArray", "Sequence[float", "tuple[float")):
        return "vector"
    if "Sequence[Sequence[float" in base or "tuple[int, int" in base:
        return "vector"
    if "str | Path" in base or "PathLike" in base:
        return "path"
    return "object"


def is_optional(param: inspect.Parameter) -> bool:
    ann = param.annotation
    text = ann if isinstance(ann, str) else str(ann)
    return param.default is None or "None" in text.split("->")[0]


# --- the guarded call -------------------------------------------------------------------------


class Hang(BaseException):
    """Raised by the alarm: the call took longer than its timeout (BaseException so that a
    library ``except Exception`` cannot swallow it)."""


def _alarm(_signum: int, _frame: Any) -> None:
    raise Hang


def guarded(fn: Callable[[], Any], timeout: float = TIMEOUT_S) -> tuple[str, Any, list[str]]:
    """Run ``fn()`` in the main thread under two alarms, recording (not raising) warnings.

    ``timeout`` is CPU time (SIGPROF: the process's user + system time), so a loaded machine does
    not turn slow calls into false hangs; a wall-clock alarm of :data:`WALL_FACTOR` times as
    much catches calls that block without computing.

    Returns:
        ``("ok", result, warnings)``, ``("raised", exception, warnings)`` or
        ``("hang", None, warnings)``; ``warnings`` names the RuntimeWarning-family categories
        (overflow, invalid value, ComplexWarning, ...) the call emitted.
    """
    old_prof = signal.signal(signal.SIGPROF, _alarm)
    old_real = signal.signal(signal.SIGALRM, _alarm)
    caught: list[warnings.WarningMessage] = []
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            signal.setitimer(signal.ITIMER_PROF, timeout)
            signal.setitimer(signal.ITIMER_REAL, timeout * WALL_FACTOR)
            try:
                result: tuple[str, Any] = ("ok", fn())
            except Hang:
                result = ("hang", None)
            except Exception as exc:  # the point: catch everything the library lets escape
                result = ("raised", exc)
            finally:
                signal.setitimer(signal.ITIMER_PROF, 0)
                signal.setitimer(signal.ITIMER_REAL, 0)
    finally:
        signal.signal(signal.SIGPROF, old_prof)
        signal.signal(signal.SIGALRM, old_real)
    names = sorted({w.category.__name__ for w in caught if issubclass(w.category, RuntimeWarning)})
    return result[0], result[1], names


def nonfinite_paths(obj: Any, path: str = "out", depth: int = 0) -> Iterator[str]:
    """Paths of non-finite floats inside a returned object (arrays, floats, dataclasses, ...)."""
    if depth > 6:
        return
    if isinstance(obj, (bool, np.bool_, int, np.integer, str, bytes)) or obj is None:
        return
    if isinstance(obj, (float, np.floating)):
        if not math.isfinite(float(obj)):
            yield f"{path}={float(obj)}"
        return
    if isinstance(obj, (complex, np.complexfloating)):
        if not (math.isfinite(obj.real) and math.isfinite(obj.imag)):
            yield f"{path}={obj}"
        return
    if isinstance(obj, np.ndarray):
        obj = obj.view(np.ndarray)  # masked arrays and other subclasses: the raw data
        if obj.dtype.kind in "fc" and obj.size and not np.all(np.isfinite(obj)):
            yield f"{path}[{int(np.sum(~np.isfinite(obj)))} non-finite of {obj.size}]"
        elif obj.dtype.kind == "O":
            for i, e in enumerate(obj.ravel()[:50]):
                yield from nonfinite_paths(e, f"{path}[{i}]", depth + 1)
        return
    if isinstance(obj, (list, tuple)):
        for i, e in enumerate(obj[:200]):
            yield from nonfinite_paths(e, f"{path}[{i}]", depth + 1)
        return
    if isinstance(obj, dict):
        for k, e in list(obj.items())[:200]:
            yield from nonfinite_paths(e, f"{path}[{k!r}]", depth + 1)
        return
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        for f in dataclasses.fields(obj):
            yield from nonfinite_paths(getattr(obj, f.name, None), f"{path}.{f.name}", depth + 1)


def _base(path: str) -> str:
    """The place of a non-finite value: ``out.x[2 non-finite of 5]`` -> ``out.x``,
    ``out['ratio']=nan`` -> ``out['ratio']``."""
    base = path.split("=")[0]
    if base.endswith("]") and " non-finite of " in base:
        base = base[: base.rindex("[")]
    return base


# --- attacking one callable -------------------------------------------------------------------


@dataclass
class Failure:
    """One (callable, argument, kind) that did not behave."""

    target: str
    param: str
    kind: str
    klass: str  # escape / non-finite / silently-accepted / unnamed / hang / refused-valid / ...
    detail: str

    def line(self) -> str:
        return f"{self.target}({self.param}) <- {self.kind}: {self.klass}: {self.detail}"


@dataclass
class Target:
    """One callable under attack: how to get the function and its valid call."""

    key: str
    get: Callable[[], Callable[..., Any]]  # fresh bound callable (builds a fresh instance)
    spec: F
    constructor: bool


def _short(exc: BaseException) -> str:
    text = str(exc).replace("\n", " ")
    return f"{type(exc).__name__}: {text[:120]}"


def _names(message: str, param: str) -> bool:
    return re.search(rf"(?<![A-Za-z0-9_]){re.escape(param)}(?![A-Za-z0-9_])", message) is not None


def _classify(
    target: str,
    param: str,
    kind: str,
    code: str,
    outcome: tuple[str, Any, list[str]],
    walk: bool,
    known_nonfinite: frozenset[str] = frozenset(),
) -> Failure | None:
    """The failure of one call given what it had to do (``code``), or ``None``."""
    status, value, warned = outcome
    f: Failure | None = None
    if status == "hang":
        f = Failure(target, param, kind, "hang", "no answer within the time limit")
    elif status == "raised":
        if not isinstance(value, VelfenceError):
            f = Failure(target, param, kind, f"escape:{type(value).__name__}", _short(value))
        elif code == "A":
            f = Failure(target, param, kind, "refused-valid", _short(value))
        elif param != "(valid)" and not _names(str(value), param):
            f = Failure(target, param, kind, "unnamed", _short(value))
    elif code == "R":
        f = Failure(target, param, kind, "silently-accepted", f"returned {type(value).__name__}")
    elif walk:
        bad = [p for p in nonfinite_paths(value) if _base(p) not in known_nonfinite]
        if bad:
            f = Failure(target, param, kind, "non-finite", ", ".join(bad[:3]))
    if warned:
        text = "emitted " + ", ".join(warned)
        if f is None:
            f = Failure(target, param, kind, "warning", text)
        else:
            f.detail += f" ({text})"
    return f


def _signature(fn: Callable[..., Any]) -> inspect.Signature | None:
    try:
        return inspect.signature(fn)
    except (TypeError, ValueError):
        return None


def _copy(x: Any) -> Any:
    try:
        return copy.deepcopy(x)
    except Exception:  # immutable library objects refuse to be copied: they need not be
        return x


class memory_cap:  # noqa: N801 (a context manager used like a function)
    """Cap the address space at what the process has plus :data:`MEMORY_HEADROOM`."""

    def __enter__(self) -> None:
        self.limits = resource.getrlimit(resource.RLIMIT_AS)
        with open("/proc/self/statm") as fh:
            in_use = int(fh.read().split()[0]) * resource.getpagesize()
        cap = in_use + MEMORY_HEADROOM
        if self.limits[1] != resource.RLIM_INFINITY:
            cap = min(cap, self.limits[1])
        resource.setrlimit(resource.RLIMIT_AS, (cap, self.limits[1]))

    def __exit__(self, *exc: object) -> None:
        resource.setrlimit(resource.RLIMIT_AS, self.limits)


def attack(t: Target) -> tuple[list[Failure], int]:
    """:func:`attack_uncapped` under :class:`memory_cap`."""
    with memory_cap():
        return attack_uncapped(t)


def attack_uncapped(t: Target) -> tuple[list[Failure], int]:
    """Apply every applicable kind to every parameter of ``t``.

    The valid call is made first (and must return finite output); then each parameter in turn
    gets each kind while the others keep their valid values.

    Returns:
        The failures and the number of calls made.
    """
    spec = t.spec
    fails: list[Failure] = []
    calls = 0
    probe = guarded(t.get, WARMUP_TIMEOUT_S)
    if probe[0] != "ok":
        return [Failure(t.key, "(valid)", "instance", "valid-failed", _short(probe[1]))], 0
    sig = _signature(probe[1])
    if sig is None:
        return [Failure(t.key, "(valid)", "signature", "valid-failed", "no signature")], 0
    module = sys.modules.get(getattr(probe[1], "__module__", "") or "")
    namespace = vars(module) if module is not None else None
    try:
        started = time.process_time()
        valid = spec.valid()
        cost = time.process_time() - started
    except Exception as exc:  # a registry entry out of date with the library is a failure
        return [Failure(t.key, "(valid)", "factory", "valid-failed", _short(exc))], 0
    fresh_call = _fresh_calls(spec.valid, valid, cost)
    walk_default = not t.constructor
    known: frozenset[str] = frozenset(spec.nonfinite)
    if spec.heavy is None:
        fresh = fresh_call()
        outcome = guarded(lambda: t.get()(*fresh.args, **fresh.kwargs), WARMUP_TIMEOUT_S)
        calls += 1
        walk = walk_default or dataclasses.is_dataclass(outcome[1])
        f = _classify(t.key, "(valid)", "valid", "A", outcome, walk, known)
        if f is not None:
            if f.klass == "refused-valid" or f.klass.startswith("escape") or f.klass == "hang":
                f.klass = "valid-failed"
                return [f], calls
            fails.append(f)  # non-finite output of the valid call: reported once, then ignored
            if outcome[0] == "ok":
                known = known | frozenset(_base(p) for p in nonfinite_paths(outcome[1]))
    try:
        bound = sig.bind_partial(*valid.args, **valid.kwargs)
    except TypeError as exc:
        return [Failure(t.key, "(valid)", "bind", "valid-failed", str(exc))], calls
    names = list(bound.arguments)
    total_hangs = 0
    for name, p in sig.parameters.items():
        if p.kind in (p.VAR_POSITIONAL, p.VAR_KEYWORD) or name in spec.skip:
            continue
        if p.kind is p.POSITIONAL_ONLY and name not in bound.arguments:
            continue
        ptype = spec.types.get(name) or infer_type(p, namespace)
        optional = is_optional(p)
        if name in bound.arguments:
            vvalue = bound.arguments[name]
        elif p.default is not p.empty:
            vvalue = p.default
        else:
            continue
        index = names.index(name) if name in names else -1
        positional = 0 <= index < len(valid.args)
        hangs = 0
        for kind in KINDS:
            if spec.heavy is not None and kind.name not in HEAVY_KINDS:
                continue
            code = expectation(kind, ptype)
            if code is None:
                continue
            try:
                value = kind.make(_copy(vvalue) if kind.derived else None)
            except NotApplicable:
                continue
            if kind.name == "none" and optional:
                code = "E" if name in spec.required else "A"
            if kind.name in spec.accepts.get(name, {}):
                code = "A"  # documented as a valid value (see F.accepts)
            if (
                kind.name in ("nan", "np_nan", "inf", "neg_inf")
                and isinstance(vvalue, float)
                and not math.isfinite(vvalue)
            ):
                code = "E"
            if spec.heavy is not None and code != "R":
                continue

            def run(
                value: Any = value,
                positional: bool = positional,
                index: int = index,
                name: str = name,
            ) -> Any:
                c = fresh_call()
                args = list(c.args)
                if positional:
                    args[index] = value
                else:
                    c.kwargs[name] = value
                return t.get()(*args, **c.kwargs)

            outcome = guarded(run, kind.timeout or TIMEOUT_S)
            calls += 1
            walk = walk_default or dataclasses.is_dataclass(outcome[1])
            f = _classify(t.key, name, kind.name, code, outcome, walk, known)
            if f is not None:
                fails.append(f)
                if f.klass == "hang":
                    hangs += 1
                    break  # one hang per argument is enough: the rest would cost 2 s each
        if hangs:
            total_hangs += 1
            if total_hangs >= (1 if spec.heavy else MAX_HANGS):
                fails.append(
                    Failure(
                        t.key, name, "(rest)", "hang", "stopped attacking after this hung argument"
                    )
                )
                break
    return fails, calls


def _fresh_calls(factory: Callable[[], Call], proto: Call, cost: float) -> Callable[[], Call]:
    """A maker of fresh valid calls: ``factory`` itself or, where the factory is slow (it builds
    a model, runs a simulation: more than :data:`SLOW_FACTORY_S` of CPU time) and its call can be
    deep-copied in less than half that, a deep copy of ``proto`` (one of its calls, never itself
    passed to the callable). Either way each call gets objects of its own: a call that mutates
    its arguments cannot reach the next one."""
    if cost < SLOW_FACTORY_S:
        return factory
    try:
        started = time.process_time()
        copy.deepcopy(proto)
        copied = time.process_time() - started
    except Exception:  # a generator, a live connection, a compiled handle: build anew each time
        return factory
    if 2.0 * copied > cost:
        return factory
    return lambda: copy.deepcopy(proto)


def _method_getter(make: Callable[[], Any], method: str) -> Callable[[], Any]:
    """A getter of ``method`` on a fresh instance: a deep copy of one prototype where the
    instance can be copied (cheap), else a new instance from ``make``."""
    cache: dict[str, Any] = {}

    def get() -> Any:
        if "proto" not in cache:
            t0 = time.perf_counter()
            proto = make()
            cache["proto"] = None
            if time.perf_counter() - t0 > 2e-3:  # slow to build: copy instead, if it can be
                try:
                    copy.deepcopy(proto)
                    cache["proto"] = proto
                except Exception:  # immutable or holding generators: build anew each time
                    pass
        proto = cache["proto"]
        return getattr(make() if proto is None else copy.deepcopy(proto), method)

    return get


# --- registry assembly ------------------------------------------------------------------------

SPEC_MODULES = (
    "specs_top",
    "specs_geometry",
    "specs_shaping",
    "specs_mechanisms",
    "specs_robots",
    "specs_redundancy",
    "specs_sim",
    "specs_cobot",
    "specs_teleop",
    "specs_io",
    "specs_integrations",
    "specs_bridge",
    "specs_viz",
    "specs_reproduce",
    "specs_tools",
    "specs_bridge_zones",
    "specs_io_zones",
    "specs_arm",
    "specs_documented",
    "specs_apps",
)


def registry() -> dict[str, F | C]:
    """Canonical public name -> spec, merged from every spec module."""
    public_modules()  # fills UNAVAILABLE
    reg: dict[str, F | C] = {}
    for modname in SPEC_MODULES:
        try:
            mod = importlib.import_module(modname)
        except ModuleNotFoundError as exc:
            if not _optional(exc) or not UNAVAILABLE:
                raise  # a spec module may only need what an unavailable module needs
            continue
        for key, spec in mod.SPECS.items():
            assert key not in reg, f"{key} registered twice"
            if available(key):
                reg[key] = spec
    return reg


def targets() -> tuple[list[Target], list[str]]:
    """Every attackable target and the names that are missing from the registry."""
    reg = registry()
    out: list[Target] = []
    missing: list[str] = []
    for key, obj in public_callables().items():
        spec = reg.get(key)
        if spec is None:
            missing.append(key)
            continue
        if inspect.isclass(obj):
            if not isinstance(spec, C):
                missing.append(f"{key} (registered as a function, is a class)")
                continue
            if spec.abstract:
                continue
            if spec.new is None and not spec.record:
                missing.append(f"{key} (constructor)")
            if spec.new is not None:
                out.append(Target(key, lambda obj=obj: obj, as_f(spec.new), True))
            make = spec.instance
            if make is None and spec.new is not None:
                new = as_f(spec.new)

                def make(obj: Any = obj, new: F = new) -> Any:
                    c = new.valid()
                    return obj(*c.args, **c.kwargs)

            for m in public_methods(obj):
                mspec = spec.methods.get(m)
                if mspec is None:
                    missing.append(f"{key}.{m}")
                    continue
                if make is None:
                    missing.append(f"{key}.{m} (no instance factory)")
                    continue
                out.append(Target(f"{key}.{m}", _method_getter(make, m), as_f(mspec), False))
            extra = set(spec.methods) - set(public_methods(obj))
            missing.extend(f"{key}.{m} (registered but not public)" for m in sorted(extra))
        else:
            if isinstance(spec, C):
                missing.append(f"{key} (registered as a class, is a function)")
                continue
            out.append(Target(key, lambda obj=obj: obj, spec, False))
    missing.extend(
        f"{k} (registered but not public)" for k in sorted(set(reg) - set(public_callables()))
    )
    return out, missing


# --- running many targets in parallel -------------------------------------------------------


def _attack_key(key: str) -> tuple[str, list[Failure], int]:
    global _WORKER_TARGETS
    if not _WORKER_TARGETS:  # a fresh worker process: build the targets here
        _WORKER_TARGETS = targets()[0]
    for t in _WORKER_TARGETS:
        if t.key == key:
            # in a scratch working directory: a hostile path ("12", "") given to a callable
            # that writes a file lands there, never in the repository
            here = os.getcwd()
            with tempfile.TemporaryDirectory(prefix="hostile-") as scratch:
                os.chdir(scratch)
                try:
                    fails, calls = attack(t)
                finally:
                    os.chdir(here)
            return key, fails, calls
    raise KeyError(key)


_WORKER_TARGETS: list[Target] = []


def prepare_worker() -> None:
    """Import every public module and build the targets once, in the fork server
    (``hostile_worker``, preloaded by :func:`attack_many`): each worker forked from it starts
    with them (they took seconds of CPU per worker when each built its own)."""
    global _WORKER_TARGETS
    if not _WORKER_TARGETS:
        _WORKER_TARGETS = targets()[0]


#: Targets one worker attacks before it is replaced by a fresh fork (None: never). A fresh
#: worker redoes the lazy imports and first-call set-ups its predecessor had done: replacing
#: every 50 targets cost about 12 s of CPU per catalogue run (126 s against 138 s, 2 workers,
#: one run each on a loaded machine).
#: A callable that left a busy thread behind would show as false hangs (the guard counts the
#: whole process's CPU time), not as a hidden defect.
MAX_TASKS: int | None = None


def jobs() -> int:
    """Worker processes: ``HOSTILE_JOBS`` or the usable cores (at most 4)."""
    env = os.environ.get("HOSTILE_JOBS")
    if env:
        return max(1, int(env))
    return max(1, min(4, len(os.sched_getaffinity(0))))


def _start_fork_server(ctx: Any) -> None:
    """Start the fork server with this folder importable and :mod:`hostile_worker` preloaded.

    The fork server does not take the test process's ``sys.path`` before it preloads (Python
    3.11 passes it and ignores it), and a preload that fails to import is skipped silently: it
    gets this folder through ``PYTHONPATH`` in its environment, set while it starts. A fork server
    already running (started earlier in this process) is used as it is: its workers then build
    the targets themselves.
    """
    from multiprocessing import forkserver

    here = str(pathlib.Path(__file__).resolve().parent)
    old = os.environ.get("PYTHONPATH")
    os.environ["PYTHONPATH"] = here if not old else os.pathsep.join([here, old])
    try:
        ctx.set_forkserver_preload(["harness", "hostile_worker"])
        forkserver.ensure_running()
    finally:
        if old is None:
            del os.environ["PYTHONPATH"]
        else:
            os.environ["PYTHONPATH"] = old


def attack_many(keys: list[str], n_jobs: int | None = None) -> dict[str, tuple[list[Failure], int]]:
    """Attack the targets named ``keys`` in ``n_jobs`` worker processes.

    Each worker runs its calls in its own main thread, so the SIGALRM guard works there too.
    Workers come from a fork server (a clean single-threaded process), not from a fork of the
    test process: by the time this runs, earlier tests may have started threads in it (numba's
    parallel thread pool behind ``shape_batch``), and a forked child that uses such a pool again
    can die or deadlock, which loses its task and hangs the pool.
    """
    global _WORKER_TARGETS
    all_targets, _ = targets()
    _WORKER_TARGETS = [t for t in all_targets if t.key in set(keys)]
    n = n_jobs or jobs()
    out: dict[str, tuple[list[Failure], int]] = {}
    if n == 1 or len(keys) < 2:
        for k in keys:
            _, fails, calls = _attack_key(k)
            out[k] = (fails, calls)
        return out
    ctx = multiprocessing.get_context("forkserver")
    _start_fork_server(ctx)
    with ctx.Pool(n, maxtasksperchild=MAX_TASKS) as pool:
        for key, fails, calls in pool.imap_unordered(_attack_key, keys, chunksize=1):
            out[key] = (fails, calls)
    return out


# --- the signature and equivalence rules (test_hostile.py, test_equivalence.py) ----------------


def constructor_rule(cls: type) -> list[str]:
    """Breaches of the constructor rule: every parameter with a default is keyword-only, and no
    positional parameter is annotated ``float``, ``int``, ``bool`` or ``str``."""
    bad = []
    for p in inspect.signature(cls).parameters.values():
        if p.kind in (p.VAR_POSITIONAL, p.VAR_KEYWORD):
            continue
        if p.default is not p.empty and p.kind is not p.KEYWORD_ONLY:
            bad.append(f"{p.name} has a default but is not keyword-only")
        ann = (
            p.annotation if isinstance(p.annotation, str) else getattr(p.annotation, "__name__", "")
        )
        base = ann.replace(" | None", "").strip() if isinstance(ann, str) else ""
        if p.kind is not p.KEYWORD_ONLY and base in ("float", "int", "bool", "str"):
            bad.append(f"{p.name}: {base} is positional (scalar tuning values are keyword-only)")
    return bad


#: Names of tuning parameters (gains, radii, limits, tolerances, ...): beyond a callable's first
#: (data) argument they must be keyword-only, so that a call reads ``f(x, radius=0.1)`` and an
#: argument added later cannot shift them.
TUNING = re.compile(
    r"(radius|radii|extents|^max_|^min_|gain|limits$|^tol$|_tol$|buffer|margin|influence|"
    r"stiffness|damping|weight|spring|threshold|window|timeout|^k[pd]?$|^eps$)"
)

#: Positional parameters whose names look like tuning but which are data (with the reason).
POSITIONAL_DATA = {
    "mechanisms.CoSPM.bearing_shift": {"eps": "the shift along the invariance axis itself"},
}


def tuning_positional(key: str, obj: Any) -> list[str]:
    """``"key: name"`` of each tuning parameter (:data:`TUNING`) that ``obj`` takes by position
    beyond its first (data) argument."""
    sig = _signature(obj)
    if sig is None:
        return []
    positional = [
        p
        for p in sig.parameters.values()
        if p.name not in ("self", "cls") and p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD)
    ]
    allowed = POSITIONAL_DATA.get(key, {})
    return [
        f"{key}: {p.name}"
        for p in positional[1:]
        if TUNING.search(p.name) and p.name not in allowed
    ]


#: Rows of the batch-equivalence check.
ROWS = 48


def batch_disagreements(make: Callable[[], Any], valid: Call) -> list[str]:
    """Rows where ``shape_batch`` (or ``explain(...).output``) of a shaper disagrees with its
    ``shape``, on :data:`ROWS` random rows around the valid batch call's first row (each row on
    a fresh instance from ``make``, so stateful shapers start alike)."""
    P0, V0 = (np.asarray(a, dtype=float) for a in valid.args[:2])
    rng = np.random.default_rng(3)
    size = float(np.abs(P0).max()) + 0.1
    P = P0[0] + 0.8 * size * rng.standard_normal((ROWS, P0.shape[1]))
    V = (float(np.abs(V0).max()) + 0.1) * rng.standard_normal((ROWS, V0.shape[1]))
    V[0] = 0.0  # no command
    P[1] = P0[0]  # the valid row itself
    batch = make().shape_batch(P, V, *valid.args[2:], **valid.kwargs)
    out = np.asarray(batch[0] if isinstance(batch, tuple) else getattr(batch, "output", batch))
    assert out.shape[0] == ROWS
    has_explain = hasattr(make(), "explain")
    bad = []
    for i in range(ROWS):
        one = np.asarray(make().shape(P[i], V[i]))
        tol = 1e-9 * (1.0 + float(np.abs(V[i]).max()))
        if not np.all(np.abs(one - out[i]) <= tol):
            bad.append(f"row {i}: shape {one.tolist()} != shape_batch {out[i].tolist()}")
        if has_explain:
            ex = np.asarray(make().explain(P[i], V[i]).output)
            if not np.all(np.abs(ex - one) <= tol):
                bad.append(f"row {i}: explain().output {ex.tolist()} != shape {one.tolist()}")
    return bad
