"""URDF to MJCF for :meth:`MujocoRobot.from_urdf <velfence.robots.MujocoRobot.from_urdf>`.

MuJoCo compiles URDF itself (``<robot>`` documents, with its ``<mujoco><compiler .../>``
extension); this module prepares the text and finishes the model:

* ``package://pkg/rel`` mesh URIs are resolved against ``package_paths`` (directories that
  contain ``pkg/``, like ROS's package search path), ``file://`` URIs and relative names against
  the URDF's directory, all rewritten to absolute paths;
* ``meshes=False`` removes every ``<visual>``/``<collision>`` whose geometry is a mesh, so the
  kinematics loads without any mesh file; ``meshes=True`` keeps them (``discardvisual="false"``)
  and names the first missing file; ``meshes="collision"`` removes every ``<visual>`` and keeps
  the ``<collision>`` meshes (visual meshes are often COLLADA files MuJoCo cannot read, and
  the collision fit of :mod:`velfence.robots.collision` needs only the collision geometry);
* ``fusestatic="false"``: links behind fixed joints stay bodies, so every link frame stays
  reachable; each link gets a site of its own name, and the ``"tcp"`` site sits on ``tcp_link``
  at ``tool``;
* joint ranges come from ``<limit lower= upper=>``; ``<limit effort=>`` becomes the joint's
  ``actuatorfrcrange`` and ``<limit velocity=>`` the ``velocity_limits`` custom numeric (a value
  ``<= 0`` or absent: no limit).

MuJoCo's XML writer keeps 6 significant digits; the written document gets the compiled model's
own body, joint, inertial, site and primitive-geom numbers back at full precision, so the
MJCF recompiles to the same kinematics (to the last bit) as the URDF.
"""

from __future__ import annotations

import math
import os
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from velfence._typing import FloatArray
from velfence._validate import check_flag, real_array
from velfence.errors import InvalidGeometry, InvalidParameter
from velfence.robots.mjcf import VELOCITY_LIMITS_NUMERIC, _mujoco

__all__: list[str] = []

#: Most package search directories accepted.
MAX_PACKAGE_PATHS = 1000
#: Largest URDF file read [bytes].
MAX_URDF_BYTES = 100_000_000


def _show(text: str, limit: int = 200) -> str:
    return repr(text if len(text) <= limit else text[: limit - 3] + "...")


def _read(path: Any) -> tuple[str, Path]:
    if isinstance(path, (bytes, bytearray)) or not isinstance(path, (str, os.PathLike)):
        raise InvalidParameter(f"path: expected a str or Path, got {type(path).__name__}")
    try:
        p = Path(os.fspath(path))
        if p.stat().st_size > MAX_URDF_BYTES:
            raise InvalidParameter(
                f"path: expected a URDF file of at most {MAX_URDF_BYTES:,} bytes, got "
                f"{p.stat().st_size:,}"
            )
        text = p.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError, ValueError, TypeError) as exc:
        raise InvalidParameter(
            f"path: expected a readable UTF-8 URDF file, got {_show(str(path))} "
            f"({type(exc).__name__})"
        ) from None
    return text, p.resolve().parent


def _package_paths(value: Any) -> list[Path]:
    if isinstance(value, (str, bytes, os.PathLike)) or not isinstance(value, Sequence):
        raise InvalidParameter(
            "package_paths: expected a sequence (list or tuple) of directories (str or Path), "
            f"got {type(value).__name__}; wrap one directory in a list"
        )
    if len(value) > MAX_PACKAGE_PATHS:
        raise InvalidParameter(
            f"package_paths: expected at most {MAX_PACKAGE_PATHS} directories, got {len(value)}"
        )
    out = []
    for i, d in enumerate(value):
        if isinstance(d, (bytes, bytearray)) or not isinstance(d, (str, os.PathLike)):
            raise InvalidParameter(
                f"package_paths[{i}]: expected a directory (str or Path), got {type(d).__name__}"
            )
        try:
            p = Path(os.fspath(d))
            ok = p.is_dir()
        except (OSError, ValueError, TypeError):
            ok = False
        if not ok:
            raise InvalidParameter(
                f"package_paths[{i}]: expected an existing directory, got {_show(str(d))}"
            )
        out.append(p.resolve())
    return out


def _resolve(uri: str, base: Path, packages: list[Path]) -> Path:
    """The file a mesh ``filename`` names (ROS semantics for ``package://``)."""
    if uri.startswith("package://"):
        rest = uri[len("package://") :]
        pkg, _, rel = rest.partition("/")
        for d in packages:
            if (d / pkg).is_dir():
                return d / pkg / rel
        raise InvalidGeometry(
            f"path: mesh {_show(uri)}: expected package {pkg!r} in a directory of "
            f"package_paths, got package_paths {[str(d) for d in packages][:10]}"
        )
    if uri.startswith("file://"):
        return Path(uri[len("file://") :])
    p = Path(uri)
    return p if p.is_absolute() else base / p


def _limit(joint: ET.Element, attr: str) -> float:
    lim = joint.find("limit")
    raw = None if lim is None else lim.get(attr)
    try:
        v = float(raw) if raw is not None else math.inf
    except ValueError:
        raise InvalidGeometry(
            f"path: expected a number in <limit {attr}=...> of joint {joint.get('name')!r}, "
            f"got {_show(raw or '')}"
        ) from None
    return v if math.isfinite(v) and v > 0.0 else math.inf


def _last_link(links: list[str], joints: list[ET.Element]) -> str:
    """The leaf link with the most joints between it and the root (first on ties)."""
    parent: dict[str, str] = {}
    for j in joints:
        p, c = j.find("parent"), j.find("child")
        if p is not None and c is not None:
            parent[str(c.get("link"))] = str(p.get("link"))
    has_child = set(parent.values())
    best, depth = links[0], -1
    for name in links:
        if name in has_child:
            continue
        k, cur, seen = 0, name, {name}
        while cur in parent and parent[cur] not in seen:
            cur = parent[cur]
            seen.add(cur)
            k += 1
        if k > depth:
            best, depth = name, k
    return best


def _prepare(
    root: ET.Element, base: Path, packages: list[Path], meshes: bool, collision_only: bool = False
) -> tuple[list[str], dict[str, tuple[float, float]]]:
    """Rewrite mesh URIs (or drop mesh geometry) and the compiler extension, in place."""
    links = [str(link.get("name")) for link in root.findall("link")]
    if not links or any(not n or n == "None" for n in links):
        raise InvalidGeometry("path: expected a URDF <robot> with named <link> elements, got none")
    for link in root.findall("link"):
        if collision_only:
            for elem in link.findall("visual"):
                link.remove(elem)
        for tag in ("visual", "collision"):
            for elem in link.findall(tag):
                mesh = elem.find("geometry/mesh")
                if mesh is None:
                    continue
                if not meshes:
                    link.remove(elem)
                    continue
                uri = mesh.get("filename") or ""
                f = _resolve(uri, base, packages)
                if not f.is_file():
                    raise InvalidGeometry(
                        f"path: expected the mesh file {_show(str(f))} (from {_show(uri)}) of "
                        f"link {link.get('name')!r} to exist, got no such file; fix "
                        "package_paths or load with meshes=False"
                    )
                mesh.set("filename", str(f.resolve()))
    ext = root.find("mujoco")
    if ext is None:
        ext = ET.Element("mujoco")
        root.insert(0, ext)
    compiler = ext.find("compiler")
    if compiler is None:
        compiler = ET.SubElement(ext, "compiler")
    compiler.set("fusestatic", "false")
    compiler.set("strippath", "false")
    compiler.set("discardvisual", "false" if meshes else "true")
    compiler.attrib.pop("meshdir", None)
    limits = {}
    for j in root.findall("joint"):
        limits[str(j.get("name"))] = (_limit(j, "velocity"), _limit(j, "effort"))
    return links, limits


def _fmt(v: Any) -> str:
    return " ".join(repr(float(x)) for x in np.asarray(v, dtype=float).ravel())


def _restore_precision(xml: str, model: Any, mujoco: Any) -> str:
    """Put the compiled model's numbers back into MuJoCo's 6-digit XML (module docs)."""
    root = ET.fromstring(xml)
    world = root.find("worldbody")
    if world is None:  # pragma: no cover - MuJoCo always writes one
        return xml
    mesh_type = int(mujoco.mjtGeom.mjGEOM_MESH)
    nsize = {2: 1, 3: 2, 5: 2, 4: 3, 6: 3}  # sphere, capsule, cylinder, ellipsoid, box
    geoms = [0]

    def ident(kind: str, elem: ET.Element) -> int:
        name = elem.get("name")
        return int(getattr(model, kind)(name).id) if name else -1

    def walk(elem: ET.Element, b: int) -> None:
        for child in list(elem):
            tag = child.tag
            if tag == "body":
                c = ident("body", child)
                if c < 0:
                    continue  # an unnamed body: keep MuJoCo's numbers (URDF links are named)
                child.set("pos", _fmt(model.body_pos[c]))
                child.set("quat", _fmt(model.body_quat[c]))
                for k in ("euler", "axisangle", "xyaxes", "zaxis"):
                    child.attrib.pop(k, None)
                inertial = child.find("inertial")
                if inertial is not None:
                    inertial.set("pos", _fmt(model.body_ipos[c]))
                    inertial.set("quat", _fmt(model.body_iquat[c]))
                    inertial.set("mass", _fmt(model.body_mass[c]))
                    inertial.set("diaginertia", _fmt(model.body_inertia[c]))
                    inertial.attrib.pop("fullinertia", None)
                walk(child, c)
            elif tag == "joint" and child.get("name"):
                j = ident("joint", child)
                child.set("pos", _fmt(model.jnt_pos[j]))
                child.set("axis", _fmt(model.jnt_axis[j]))
                if bool(model.jnt_limited[j]):
                    child.set("range", _fmt(model.jnt_range[j]))
                if bool(model.jnt_actfrclimited[j]):
                    child.set("actuatorfrcrange", _fmt(model.jnt_actfrcrange[j]))
            elif tag == "geom":
                g = geoms[0]
                geoms[0] += 1
                if g >= model.ngeom or int(model.geom_bodyid[g]) != b:
                    continue
                t = int(model.geom_type[g])
                if t != mesh_type and t in nsize:
                    child.set("pos", _fmt(model.geom_pos[g]))
                    child.set("quat", _fmt(model.geom_quat[g]))
                    child.set("size", _fmt(model.geom_size[g][: nsize[t]]))
                    for k in ("fromto", "euler", "axisangle", "xyaxes", "zaxis"):
                        child.attrib.pop(k, None)
            elif tag == "site" and child.get("name"):
                s = ident("site", child)
                child.set("pos", _fmt(model.site_pos[s]))
                child.set("quat", _fmt(model.site_quat[s]))

    walk(world, 0)
    for num in root.iter("numeric"):
        k = int(model.numeric(num.get("name")).id)
        adr, size = int(model.numeric_adr[k]), int(model.numeric_size[k])
        data = model.numeric_data[adr : adr + size]
        num.set("data", " ".join(repr(float(v)) if math.isfinite(v) else "inf" for v in data))
    return ET.tostring(root, encoding="unicode")


def urdf_document(
    path: Any,
    *,
    package_paths: Any = (),
    tcp_link: Any = None,
    tool: ArrayLike | None = None,
    meshes: Any = False,
) -> str:
    """The MJCF document of a URDF file (module docs); arguments as ``MujocoRobot.from_urdf``.

    Args:
        path: The URDF file.
        package_paths: Directories that contain the ``package://`` packages.
        tcp_link: Link that carries the ``"tcp"`` site (default: the last link of the chain).
        tool: Offset of the ``"tcp"`` site in ``tcp_link``'s frame [m], shape (3,).
        meshes: Keep mesh geometry (True), strip it (False), or drop every ``<visual>`` and
            keep the collision meshes (``"collision"``).

    Returns:
        The MJCF document (str).

    Raises:
        InvalidParameter: a bad argument.
        InvalidGeometry: the URDF cannot be read or compiled, a mesh file is missing, or
            ``tcp_link`` is not one of its links.
    """
    text, base = _read(path)
    packages = _package_paths(package_paths)
    collision_only = isinstance(meshes, str) and meshes == "collision"
    if isinstance(meshes, str) and not collision_only:
        raise InvalidParameter(
            f"meshes: expected True, False or 'collision', got {_show(meshes, 40)}"
        )
    keep = True if collision_only else check_flag("meshes", meshes)
    offset: FloatArray = (
        np.zeros(3)
        if tool is None
        else real_array("tool", tool, (3,), error=InvalidParameter, what="an offset [m]")
    )
    if tcp_link is not None and not isinstance(tcp_link, str):
        raise InvalidParameter(
            f"tcp_link: expected a link name (str) or None, got {type(tcp_link).__name__}"
        )
    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        raise InvalidGeometry(
            f"path: expected a URDF (XML) document, got the parse error: {str(exc)[:200]}"
        ) from None
    if root.tag != "robot":
        raise InvalidGeometry(
            f"path: expected a URDF document with a <robot> root, got <{str(root.tag)[:40]}>"
        )
    links, limits = _prepare(root, base, packages, keep, collision_only)
    if tcp_link is None:
        tcp_link = _last_link(links, root.findall("joint"))
    elif tcp_link not in links:
        shown = tcp_link if len(tcp_link) <= 40 else tcp_link[:37] + "..."
        raise InvalidGeometry(f"tcp_link: expected one of the links {links[:50]}, got {shown!r}")

    mujoco = _mujoco()
    try:
        spec = mujoco.MjSpec.from_string(ET.tostring(root, encoding="unicode"))
        model = spec.compile()
    except ValueError as exc:
        first = (str(exc).strip().splitlines() or ["no message"])[0][:200]
        raise InvalidGeometry(
            f"path: expected a URDF MuJoCo compiles, got the error: {first}"
        ) from None
    joint_names = [model.joint(i).name for i in range(model.njnt)]
    velocity = []
    for name in joint_names:
        vel, effort = limits.get(name, (math.inf, math.inf))
        velocity.append(vel)
        j = spec.joint(name)
        if math.isfinite(effort):
            j.actfrclimited = mujoco.mjtLimited.mjLIMITED_TRUE
            j.actfrcrange = [-effort, effort]
        else:
            j.actfrclimited = mujoco.mjtLimited.mjLIMITED_FALSE
    if velocity:
        spec.add_numeric(name=VELOCITY_LIMITS_NUMERIC, data=velocity)
    for name in links:
        body = spec.body(name)
        if body is None:  # pragma: no cover - fusestatic="false" keeps every link
            continue
        if name != "tcp":
            body.add_site(name=name)
    spec.body(tcp_link).add_site(name="tcp", pos=[float(x) for x in offset])
    try:
        model = spec.compile()
        xml = spec.to_xml()
    except ValueError as exc:
        first = (str(exc).strip().splitlines() or ["no message"])[0][:200]
        raise InvalidGeometry(
            f"path: expected a URDF MuJoCo compiles, got the error: {first}"
        ) from None
    return _restore_precision(xml, model, mujoco)
