"""The one YAML reader: every YAML file velfence reads goes through :func:`read_yaml`.

Configuration files (demo, shaper, bridge, replay), zone files, ros2_control joint-limit files and
a rosbag2 bag's ``metadata.yaml`` are all read here, by one narrow reader built on PyYAML's
``SafeLoader`` (``docs/config.md``):

* at most :data:`MAX_FILE_BYTES` of UTF-8 text (a BOM is allowed), from a regular file;
* plain YAML only: anchors, aliases, merge keys (``<<``), duplicate keys and the YAML tags that
  build dates, binary data, sets or ordered pairs are refused, each with its line; nesting is
  capped at :data:`MAX_DEPTH` levels;
* numbers in exponent notation (``1e-3``) are numbers, as in YAML 1.2 and JSON.

One error contract: every failure is an :class:`~velfence.errors.InvalidParameter` whose message
names the file and, for a YAML problem, the line and column. No other module of velfence calls
``yaml.safe_load`` or ``yaml.load`` (``tests/io/test_one_yaml_reader.py``).
"""

from __future__ import annotations

import math
import os
import re
import stat
from pathlib import Path
from typing import TYPE_CHECKING, Any, NoReturn

from velfence._validate import check_text
from velfence.errors import InvalidParameter

if TYPE_CHECKING:
    from collections.abc import Iterable

    import yaml

__all__ = ["MAX_DEPTH", "MAX_FILE_BYTES", "file_path", "read_yaml"]

#: Largest accepted config file [bytes] (a full scenario with 1000 corners is about 50 KiB).
MAX_FILE_BYTES = 1024 * 1024
#: Deepest accepted nesting of the YAML document (the schema itself needs 4 levels).
MAX_DEPTH = 16


def file_path(path: Any) -> Path:
    """``path`` as a :class:`~pathlib.Path` (internal API of :mod:`velfence.io` and the bridge).

    Args:
        path: A ``str`` or ``os.PathLike`` (not ``bytes``).

    Returns:
        The path.

    Raises:
        InvalidParameter: ``path`` is no file path.
    """
    if isinstance(path, Path):
        return path
    if isinstance(path, str) or (isinstance(path, os.PathLike) and not isinstance(path, bytes)):
        return Path(path)
    raise InvalidParameter(f"path: expected a file path (str or Path), got {type(path).__name__}")


def _read_text(p: Path, what: str) -> str:
    """The file's text: a regular file of at most MAX_FILE_BYTES, UTF-8 (BOM allowed)."""
    try:
        st = p.stat()
    except OSError as exc:
        raise InvalidParameter(f"cannot read {what} {p}: {exc.strerror}; check the path") from None
    if stat.S_ISDIR(st.st_mode):
        raise InvalidParameter(
            f"cannot read {what} {p}: it is a directory; give the path of a file"
        )
    if not stat.S_ISREG(st.st_mode):
        # A FIFO or device (/dev/zero) could block or never end.
        raise InvalidParameter(
            f"cannot read {what} {p}: not a regular file; give the path of a file"
        )
    if st.st_size > MAX_FILE_BYTES:
        raise InvalidParameter(
            f"{what} {p} is {st.st_size:,} bytes; at most {MAX_FILE_BYTES:,} are accepted"
        )
    try:
        with p.open("rb") as fh:
            raw = fh.read(MAX_FILE_BYTES + 1)  # the file may have grown since stat()
    except OSError as exc:
        raise InvalidParameter(f"cannot read {what} {p}: {exc.strerror}; check the path") from None
    if len(raw) > MAX_FILE_BYTES:
        raise InvalidParameter(f"{what} {p} is larger than {MAX_FILE_BYTES:,} bytes")
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = raw.count(b"\n", 0, exc.start) + 1
        column = exc.start - (raw.rfind(b"\n", 0, exc.start) + 1) + 1
        bad = raw[exc.start : exc.end].hex(" ")
        raise InvalidParameter(
            f"{what} {p} is not UTF-8 text: byte(s) {bad} at line {line}, column {column}; "
            "save the file as UTF-8"
        ) from None


def _need_yaml() -> None:
    """Raise :class:`~velfence.errors.MissingExtra` naming the ``app`` extra without PyYAML."""
    from velfence._extras import require

    require("yaml", what="reading a YAML file")


def _yaml_error_text(exc: Exception) -> str:
    """One line: 'line L, column C: problem (context)' for a marked YAML error."""
    _need_yaml()
    import yaml

    if isinstance(exc, yaml.MarkedYAMLError) and exc.problem_mark is not None:
        mark = exc.problem_mark
        text = f"line {mark.line + 1}, column {mark.column + 1}: {exc.problem}"
        if exc.context:
            text += f" ({exc.context}"
            if exc.context_mark is not None and exc.context_mark.line != mark.line:
                text += f" at line {exc.context_mark.line + 1}"
            text += ")"
        return " ".join(text.split())
    return " ".join(str(exc).split())


_LOADERS: dict[bool, type[yaml.SafeLoader]] = {}
_REFUSED: type[yaml.MarkedYAMLError] | None = None


def _refused_error() -> type[yaml.MarkedYAMLError]:
    """The error of well-formed YAML that the config reader does not accept (aliases, ...)."""
    global _REFUSED
    if _REFUSED is None:
        _need_yaml()
        import yaml

        class Refused(yaml.MarkedYAMLError):
            pass

        _REFUSED = Refused
    return _REFUSED


def _loader(angle_tags: bool = False) -> type[yaml.SafeLoader]:
    """The SafeLoader subclass of the config reader (built once, on first use).

    With ``angle_tags`` it reads ``!degrees x`` as ``x`` degrees in radians and ``!radians x``
    as ``x``; every other local tag is refused either way.
    """
    cached = _LOADERS.get(angle_tags)
    if cached is not None:
        return cached
    _need_yaml()
    import yaml

    refused = _refused_error()

    def stop(problem: str, mark: Any) -> NoReturn:
        raise refused(None, None, problem, mark)

    def _refuse(what: str) -> Any:
        def construct(loader: yaml.SafeLoader, node: yaml.Node) -> Any:
            stop(f"{what} ({node.tag}) are not accepted in a config file", node.start_mark)

        return construct

    class Loader(yaml.SafeLoader):
        """Plain YAML: no aliases or anchors, no duplicate or merge keys, bounded nesting."""

        def __init__(self, stream: str) -> None:
            super().__init__(stream)
            self._depth = 0

        def compose_node(self, parent: yaml.Node | None, index: Any) -> yaml.Node | None:
            event = self.peek_event()  # type: ignore[no-untyped-call]
            if isinstance(event, yaml.AliasEvent):
                stop(
                    f"aliases (*{event.anchor}) are not accepted in a config file; write the "
                    "value out",
                    event.start_mark,
                )
            anchor = getattr(event, "anchor", None)
            if anchor is not None:
                stop(
                    f"anchors (&{anchor}) are not accepted in a config file; write the value out",
                    event.start_mark,
                )
            if self._depth >= MAX_DEPTH:
                stop(
                    f"nesting deeper than {MAX_DEPTH} levels is not accepted in a config file",
                    event.start_mark,
                )
            self._depth += 1
            try:
                return super().compose_node(parent, index)
            finally:
                self._depth -= 1

        def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict[Any, Any]:
            first: dict[Any, int] = {}
            for key_node, _ in node.value:
                if key_node.tag == "tag:yaml.org,2002:merge":
                    stop(
                        "merge keys (<<) are not accepted in a config file; write the keys out",
                        key_node.start_mark,
                    )
                key = self.construct_object(key_node, deep=True)
                try:
                    seen = key in first
                except TypeError:
                    stop("a key must be a plain value", key_node.start_mark)
                if seen:
                    stop(
                        f"duplicate key {key!r} (first at line {first[key]}); each key may "
                        "appear once",
                        key_node.start_mark,
                    )
                first[key] = key_node.start_mark.line + 1
            return super().construct_mapping(node, deep)

        def construct_yaml_int(self, node: yaml.ScalarNode) -> int:
            try:
                return super().construct_yaml_int(node)
            except ValueError:  # more digits than Python converts (sys.get_int_max_str_digits)
                stop("integer with too many digits", node.start_mark)

    def construct_unknown(loader: yaml.SafeLoader, node: yaml.Node) -> Any:
        accepted = " (!degrees and !radians are)" if angle_tags else ""
        raise yaml.constructor.ConstructorError(
            None, None, f"the tag {node.tag} is not accepted here{accepted}", node.start_mark
        )

    def construct_angle(loader: yaml.SafeLoader, node: yaml.Node) -> float:
        implicit = None
        if isinstance(node, yaml.ScalarNode):
            implicit = loader.resolve(yaml.ScalarNode, node.value, (True, False))  # type: ignore[no-untyped-call]
        if implicit not in ("tag:yaml.org,2002:int", "tag:yaml.org,2002:float"):
            stop(f"{node.tag} must tag a number, as in '{node.tag} 180.0'", node.start_mark)
        value = float(
            loader.construct_object(yaml.ScalarNode(implicit, node.value, node.start_mark))
        )
        return math.radians(value) if node.tag == "!degrees" else value

    Loader.add_constructor(None, construct_unknown)
    if angle_tags:
        Loader.add_constructor("!degrees", construct_angle)
        Loader.add_constructor("!radians", construct_angle)
    Loader.add_constructor("tag:yaml.org,2002:int", Loader.construct_yaml_int)
    # YAML 1.1 (PyYAML) reads 1e-3 and 1.0e308 as strings (it wants a dot and a signed
    # exponent); numbers in exponent notation are numbers here, as in YAML 1.2 and JSON.
    Loader.add_implicit_resolver(
        "tag:yaml.org,2002:float",
        re.compile(r"^[-+]?(?:[0-9][0-9_]*(?:\.[0-9_]*)?|\.[0-9_]+)[eE][-+]?[0-9]+$"),
        list("-+0123456789."),
    )
    for tag, what in (
        ("timestamp", "dates and times"),
        ("binary", "binary values"),
        ("set", "sets"),
        ("omap", "ordered maps"),
        ("pairs", "pair lists"),
    ):
        Loader.add_constructor(f"tag:yaml.org,2002:{tag}", _refuse(what))
    _LOADERS[angle_tags] = Loader
    return Loader


def _parse(p: Path, text: str, what: str, angle_tags: bool = False) -> Any:
    _need_yaml()
    import yaml

    try:
        return yaml.load(text, Loader=_loader(angle_tags))
    except _refused_error() as exc:
        raise InvalidParameter(f"{what} {p}, {_yaml_error_text(exc)}") from None
    except yaml.YAMLError as exc:
        raise InvalidParameter(f"{what} {p} is not valid YAML: {_yaml_error_text(exc)}") from None
    except RecursionError:  # belt and braces: nesting is capped in compose_node
        raise InvalidParameter(
            f"{what} {p} is nested too deeply (at most {MAX_DEPTH} levels)"
        ) from None


def read_yaml(
    path: str | os.PathLike[str], *, what: str = "config file", angle_tags: bool = False
) -> Any:
    """The document of one YAML file, read by velfence's narrow reader (module docs).

    Args:
        path: The file (``str`` or ``os.PathLike``).
        what: How messages name the file (``"config file"``, ``"bag metadata file"``, ...).
        angle_tags: Read ``!degrees x`` as ``x`` degrees in radians and ``!radians x`` as ``x``
            (joint-limit files, as Universal Robots writes them); default False refuses them as
            every other tag.

    Returns:
        The parsed document: a mapping, list or scalar as the file holds it (``None`` for an
        empty file).

    Raises:
        InvalidParameter: the path is no file path; the file is missing, not a regular file,
            larger than :data:`MAX_FILE_BYTES` or not UTF-8; or it is not plain YAML or holds a
            tag it does not accept (the message names the file, the line and the column).
        MissingExtra: PyYAML is not installed.
    """
    what = check_text("what", what)
    p = file_path(path)
    return _parse(p, _read_text(p, what), what, angle_tags is True)


def did_you_mean(word: str, choices: Iterable[str]) -> str:
    """``"; did you mean 'x'?"`` for the choice closest to a mistyped ``word``, or ``""``.

    Internal API of :mod:`velfence.io` and :mod:`velfence.bridge`: every config message about
    an unknown key ends with it (the pydantic-validated files through
    :func:`velfence.io.config.describe_validation_error`, the zone files directly). The closest
    choice with difflib's similarity ratio >= 0.6 is named.

    Args:
        word: The unknown key.
        choices: The keys allowed there.

    Returns:
        The suffix for the message.
    """
    import difflib

    close = difflib.get_close_matches(word, sorted(set(choices)), n=1)
    return f"; did you mean {close[0]!r}?" if close else ""
