"""URDF text -> :class:`~kinematics.model.RobotModel`.

The text is first read with :mod:`defusedxml` (no DTD, no entity expansion, no external
entity: XXE and billion-laughs documents are refused before any other parser sees them),
checked element by element so that every error names the element at fault, then parsed
by ``yourdfpy`` with scene graphs and mesh loading switched off: no file a URDF names is
ever opened.
"""

from __future__ import annotations

import hashlib
import io
import math
import re
import xml.etree.ElementTree as ET
from typing import Iterable

import numpy as np
from defusedxml import DefusedXmlException
from defusedxml.ElementTree import fromstring as safe_fromstring

from ..errors import ModelTooLargeError, UnsupportedJointError, URDFError
from ..model.robot import (MOVING_TYPES, MULTI_DOF_TYPES, SUPPORTED_TYPES, Joint, Limits, Mimic, RobotModel, Visual,
                           frozen_array)
from ..tolerances import AXIS_EPS, MAX_ABS_COORDINATE


#: Default cap on the number of links (and of joints) in one model.
DEFAULT_MAX_LINKS = 10_000
#: The only plane normal a planar joint may have: Pinocchio's URDF reader makes every planar joint
#: a JointModelPlanar, which moves in the x-y plane of the joint frame whatever <axis> says (and the
#: URDF default axis is x), so any other axis would silently disagree with the reference.
PLANAR_AXIS = (0.0, 0.0, 1.0)


def _numbers(text: str | None, count: int, what: str, default: str, bound: float | None = None) -> list[float]:
    """Parse ``count`` finite floats (each within ``bound`` if given) from an attribute value, naming ``what`` on failure."""
    raw = default if text is None else text
    parts = raw.split()
    if len(parts) != count:
        raise URDFError(f"{what}: expected {count} numbers, got {raw!r}")
    try:
        values = [float(p) for p in parts]
    except ValueError:
        raise URDFError(f"{what}: {raw!r} is not a list of numbers") from None
    if not all(math.isfinite(v) for v in values):
        raise URDFError(f"{what}: {raw!r} has a non-finite value")
    if bound is not None and any(abs(v) > bound for v in values):
        raise URDFError(f"{what}: {raw!r} has a value beyond +-{bound:g}")
    return values


def _number(text: str | None, what: str, default: float | None, bound: float | None = None) -> float | None:
    if text is None:
        return default
    try:
        v = float(text)
    except ValueError:
        raise URDFError(f"{what}: {text!r} is not a number") from None
    if not math.isfinite(v):
        raise URDFError(f"{what}: {text!r} is not finite")
    if bound is not None and abs(v) > bound:
        raise URDFError(f"{what}: {text!r} is beyond +-{bound:g}")
    return v


#: namespace given to a prefix the document uses without declaring it (``drake:``, ``xacro:``, ...)
UNDECLARED_NS = "urn:kinematics:undeclared:"
#: geometry elements URDF knows (anything else inside <geometry> is a simulator's extension)
URDF_GEOMETRIES = frozenset({"box", "cylinder", "sphere", "mesh"})
_PREFIX_USE = re.compile(rb"(?:<|\s)([A-Za-z_][\w.-]*):[A-Za-z_][\w.-]*")
_PREFIX_DECL = re.compile(rb"xmlns:([A-Za-z_][\w.-]*)\s*=\s*[\"']([^\"']*)[\"']")


def _parse(data: bytes) -> ET.Element:
    try:
        return safe_fromstring(data, forbid_dtd=True, forbid_entities=True, forbid_external=True)
    except DefusedXmlException as exc:
        raise URDFError(
            f"URDF refused: it declares a DTD or entities ({type(exc).__name__}); "
            "entity expansion and external entities are disabled"
        ) from None
    except (ValueError, UnicodeError) as exc:
        raise URDFError(f"URDF could not be decoded: {exc}") from None


def _root_start(data: bytes) -> int:
    """Offset just after the root element's name (comments, PIs and blanks before it skipped), or -1."""
    i = 0
    while True:
        i = data.find(b"<", i)
        if i < 0:
            return -1
        if data.startswith(b"<!--", i):
            i = data.find(b"-->", i)
            if i < 0:
                return -1
            continue
        if data.startswith(b"<?", i) or data.startswith(b"<!", i):
            i = data.find(b">", i)
            if i < 0:
                return -1
            continue
        m = re.compile(rb"<[A-Za-z_][\w.:-]*").match(data, i)
        return m.end() if m else -1


def _declare_prefixes(data: bytes) -> bytes | None:
    """``data`` with every prefix it uses but does not declare bound to ``UNDECLARED_NS + prefix`` on the root.

    Files exported for Drake (``drake:``) or written for xacro without ``xmlns:xacro`` use such
    prefixes; urdfdom (Pinocchio's reader) does not care, an XML parser does ("unbound prefix").
    """
    declared = {m.group(1) for m in _PREFIX_DECL.finditer(data)} | {b"xml", b"xmlns"}
    used = {m.group(1) for m in _PREFIX_USE.finditer(data)} - declared
    at = _root_start(data)
    if not used or at < 0:
        return None
    decls = b"".join(b' xmlns:%s="%s%s"' % (p, UNDECLARED_NS.encode(), p) for p in sorted(used))
    return data[:at] + decls + data[at:]


def read_xml(data: bytes) -> ET.Element:
    try:
        return _parse(data)
    except ET.ParseError as exc:
        if "unbound prefix" in str(exc):
            fixed = _declare_prefixes(data)
            if fixed is not None:
                try:
                    return _parse(fixed)
                except ET.ParseError:
                    pass
        raise URDFError(f"URDF is not well-formed XML: {exc}") from None


def _namespace(tag_or_attr: str) -> str | None:
    return tag_or_attr[1:].split("}", 1)[0] if tag_or_attr.startswith("{") else None


def _prefixed(name: str, prefixes: dict[str, str]) -> str:
    """``{uri}local`` -> ``prefix:local`` (the prefix the document used), for messages."""
    ns = _namespace(name)
    if ns is None:
        return name
    local = name.split("}", 1)[1]
    if ns.startswith(UNDECLARED_NS):
        return f"{ns[len(UNDECLARED_NS):]}:{local}"
    return f"{prefixes.get(ns, ns)}:{local}"


def _is_xacro_namespace(ns: str | None) -> bool:
    return ns is not None and "xacro" in ns.lower()


def _substitution(value: str) -> bool:
    return "${" in value or "$(" in value


def _mesh_file_names(root: ET.Element) -> dict[int, str]:
    """``id(mesh element) -> where it is`` (``link 'x' <visual> <mesh filename>``) for every
    ``<mesh>`` of a link's ``<visual>`` / ``<collision>`` geometry."""
    found: dict[int, str] = {}
    for link in root.findall("link"):
        for kind in ("visual", "collision"):
            for el in link.findall(kind):
                for mesh in el.findall("geometry/mesh"):
                    found[id(mesh)] = f"link {link.get('name')!r} <{kind}> <mesh filename>"
    return found


def xacro_use(root: ET.Element) -> str | None:
    """What makes the document xacro rather than URDF (an element or attribute in the xacro
    namespace, a ``${...}`` expression or ``$(...)`` substitution), or None. ``xmlns:xacro`` declared
    but unused is URDF, and so is a substitution left in a ``<mesh filename>`` (mesh files are never
    opened: :func:`mesh_substitutions` names them for the model's warnings)."""
    meshes = _mesh_file_names(root)
    for el in root.iter():
        if not isinstance(el.tag, str):
            continue
        if _is_xacro_namespace(_namespace(el.tag)):
            return f"element <xacro:{el.tag.split('}', 1)[1]}>"
        for name, value in el.attrib.items():
            if _is_xacro_namespace(_namespace(name)):
                return f"attribute xacro:{name.split('}', 1)[1]} on <{el.tag}>"
            if _substitution(value) and not (name == "filename" and id(el) in meshes):
                return f"expression {value[:60]!r} in <{el.tag} {name}>"
    return None


def mesh_substitutions(root: ET.Element) -> list[str]:
    """Where a ``$(...)`` / ``${...}`` is left in a ``<mesh filename>``, with the text:
    ``link 'x' <visual> <mesh filename="$(find pkg)/m.stl">``."""
    meshes = _mesh_file_names(root)
    out = []
    for link in root.findall("link"):
        for kind in ("visual", "collision"):
            for el in link.findall(kind):
                for mesh in el.findall("geometry/mesh"):
                    value = mesh.get("filename", "")
                    if _substitution(value):
                        out.append(f"{meshes[id(mesh)][:-1]}={value[:80]!r}>")
    return out


def _check_document(root: ET.Element, max_links: int) -> None:
    """Structural checks on the XML tree; every message names the element at fault."""
    if root.tag != "robot":
        raise URDFError(f"the root element is <{root.tag}>, expected <robot>")
    if not root.get("name"):
        raise URDFError("the <robot> element has no 'name' attribute")
    links = root.findall("link")
    joints = root.findall("joint")
    if not links:
        raise URDFError(f"robot {root.get('name')!r} has no <link>")
    if len(links) > max_links or len(joints) > max_links:
        raise ModelTooLargeError(
            f"robot has {len(links)} links and {len(joints)} joints; the limit is {max_links}"
        )
    link_names = set(_unique_names(links, "link"))
    for el, name in zip(joints, _unique_names(joints, "joint")):
        jt = el.get("type")
        if jt not in SUPPORTED_TYPES:
            raise URDFError(f"joint {name!r} has unknown type {jt!r}")
        for tag in ("parent", "child"):
            sub = el.find(tag)
            link = sub.get("link") if sub is not None else None
            if not link:
                raise URDFError(f"joint {name!r} has no <{tag} link=...>")
            if link not in link_names:
                raise URDFError(f"joint {name!r} names {tag} link {link!r}, which does not exist")
        origin = el.find("origin")
        if origin is not None:
            _numbers(origin.get("xyz"), 3, f"joint {name!r} <origin xyz>", "0 0 0", MAX_ABS_COORDINATE)
            _numbers(origin.get("rpy"), 3, f"joint {name!r} <origin rpy>", "0 0 0", MAX_ABS_COORDINATE)
        axis = el.find("axis")
        if axis is not None and jt in MOVING_TYPES and jt != "floating":
            xyz = _numbers(axis.get("xyz"), 3, f"joint {name!r} <axis xyz>", "1 0 0")
            if math.hypot(*xyz) < AXIS_EPS:  # hypot: no overflow for huge components
                raise URDFError(f"joint {name!r} has a zero <axis>")
        if jt == "planar":
            xyz = None if axis is None else _numbers(axis.get("xyz"), 3, f"joint {name!r} <axis xyz>", "1 0 0")
            unit = None if xyz is None else np.asarray(xyz) / math.hypot(*xyz)
            if unit is None or np.max(np.abs(unit - PLANAR_AXIS)) > AXIS_EPS:
                raise UnsupportedJointError(
                    f"planar joint {name!r} has plane normal (axis) {'1 0 0 (the URDF default)' if xyz is None else axis.get('xyz')}: "
                    "only <axis xyz=\"0 0 1\"/> is supported (Pinocchio moves every URDF planar joint in the x-y plane "
                    "of its frame whatever its axis); rotate the joint's <origin> so that the plane normal is its z axis")
        limit = el.find("limit")
        if limit is not None:
            lo = _number(limit.get("lower"), f"joint {name!r} <limit lower>", 0.0)
            hi = _number(limit.get("upper"), f"joint {name!r} <limit upper>", 0.0)
            _number(limit.get("effort"), f"joint {name!r} <limit effort>", 0.0)
            _number(limit.get("velocity"), f"joint {name!r} <limit velocity>", 0.0)
            if jt in ("revolute", "prismatic") and lo > hi:
                raise URDFError(f"joint {name!r} has lower limit {lo} above upper limit {hi}")
        mimic = el.find("mimic")
        if mimic is not None and jt in MULTI_DOF_TYPES:
            raise UnsupportedJointError(f"{jt} joint {name!r} has a <mimic>: only revolute, continuous and prismatic "
                                        "joints may mimic")
        if mimic is not None:
            if not mimic.get("joint"):
                raise URDFError(f"joint {name!r} has a <mimic> without a 'joint' attribute")
            _number(mimic.get("multiplier"), f"joint {name!r} <mimic multiplier>", 1.0, MAX_ABS_COORDINATE)
            _number(mimic.get("offset"), f"joint {name!r} <mimic offset>", 0.0, MAX_ABS_COORDINATE)
    for el in links:
        for vis in el.findall("visual"):
            o = vis.find("origin")
            if o is not None:
                _numbers(o.get("xyz"), 3, f"link {el.get('name')!r} <visual><origin xyz>", "0 0 0", MAX_ABS_COORDINATE)
                _numbers(o.get("rpy"), 3, f"link {el.get('name')!r} <visual><origin rpy>", "0 0 0", MAX_ABS_COORDINATE)


#: elements a URDF <robot> may hold (others are simulator or tool extensions, ignored with a warning)
URDF_TOP_LEVEL = frozenset({"link", "joint", "material", "transmission", "gazebo", "sensor"})
#: the extension blocks the URDF specification defines, left out silently (no kinematics in them)
URDF_EXTENSIONS = frozenset({"transmission", "gazebo", "sensor"})


def _names(items: list[str], limit: int = 6) -> str:
    uniq = list(dict.fromkeys(items))
    return ", ".join(uniq[:limit]) + (f" and {len(uniq) - limit} more" if len(uniq) > limit else "")


def _sanitise(root: ET.Element, data: bytes) -> tuple[bytes, list[str]]:
    """The document yourdfpy is given, and a warning per kind of thing left out of it.

    Left out: elements and attributes in a namespace (``drake:``, ``gazebo:``, ... : extensions
    of other tools), top-level elements URDF does not define, ``<visual>``/``<collision>`` whose
    geometry is not URDF's (pybullet's ``<plane>``, ``<cdf>``, ...), and -- silently, as this
    library never uses them -- every ``<collision>`` and ``<inertial>``. None changes the kinematics.
    """
    prefixes = {m.group(2).decode(errors="replace"): m.group(1).decode() for m in _PREFIX_DECL.finditer(data)}
    warnings: list[str] = []
    for child in list(root):  # URDF's own extension blocks: their content is for simulators and drivers
        if child.tag in URDF_EXTENSIONS:
            root.remove(child)
    foreign_el: list[str] = []
    foreign_attr: list[str] = []
    stack = [root]
    while stack:
        parent = stack.pop()
        for child in list(parent):
            if not isinstance(child.tag, str):
                parent.remove(child)
            elif _namespace(child.tag) is not None:
                foreign_el.append(f"<{_prefixed(child.tag, prefixes)}>")
                parent.remove(child)
            else:
                stack.append(child)
    for el in root.iter():
        for name in [a for a in el.attrib if _namespace(a) is not None]:
            if not name.startswith("{http://www.w3.org/XML/1998/namespace}"):
                foreign_attr.append(f"{_prefixed(name, prefixes)} on <{el.tag}>")
            del el.attrib[name]
    if foreign_el or foreign_attr:
        parts = []
        if foreign_el:
            parts.append(f"{len(foreign_el)} element(s) ({_names(foreign_el)})")
        if foreign_attr:
            parts.append(f"{len(foreign_attr)} attribute(s) ({_names(foreign_attr)})")
        warnings.append(f"ignored {' and '.join(parts)} of other tools' namespaces: they do not change the kinematics")
    unknown_top = [child for child in root if child.tag not in URDF_TOP_LEVEL]
    if unknown_top:
        warnings.append(f"ignored {len(unknown_top)} element(s) that URDF does not define "
                        f"({_names([f'<{c.tag}>' for c in unknown_top])}): they do not change the kinematics")
        for child in unknown_top:
            root.remove(child)
    odd_geometry: list[str] = []
    odd_children: list[str] = []
    for link in root.findall("link"):
        lname = link.get("name")
        for kind in ("visual", "collision"):
            for el in link.findall(kind):
                geom = el.find("geometry")
                shape = geom[0].tag if geom is not None and len(geom) else None
                if shape not in URDF_GEOMETRIES:
                    odd_geometry.append(f"link {lname!r} <{kind}>" + (f" <{shape}>" if shape else " without geometry"))
                    link.remove(el)
                elif kind == "collision":
                    link.remove(el)
        for el in link.findall("inertial"):
            link.remove(el)
        for el in list(link):
            if el.tag not in ("visual",):
                odd_children.append(f"link {lname!r} <{el.tag}>")
                link.remove(el)
    if odd_geometry:
        warnings.append(f"ignored {len(odd_geometry)} <visual>/<collision> element(s) whose geometry is not URDF's "
                        f"({_names(odd_geometry)}): they do not change the kinematics")
    if odd_children:
        warnings.append(f"ignored {len(odd_children)} element(s) inside links that URDF does not define "
                        f"({_names(odd_children)}): they do not change the kinematics")
    try:
        return ET.tostring(root, encoding="utf-8"), warnings
    except RecursionError:
        raise URDFError("URDF is nested too deeply to be read") from None


def _unique_names(elements, tag: str) -> list[str]:
    """The ``name`` of each ``<tag>`` element, in order; a missing or repeated name raises :class:`URDFError`."""
    names: list[str] = []
    seen: set[str] = set()
    for i, el in enumerate(elements):
        name = el.get("name")
        if not name:
            raise URDFError(f"<{tag}> number {i + 1} has no 'name' attribute")
        if name in seen:
            raise URDFError(f"duplicate {tag} name {name!r}")
        seen.add(name)
        names.append(name)
    return names


def _check_tree(link_names: Iterable[str], joints: list[Joint]) -> str:
    """Check that links and joints form one tree; return its root link."""
    link_names = list(link_names)
    parent_of: dict[str, str] = {}
    for j in joints:
        if j.child in parent_of:
            raise URDFError(
                f"link {j.child!r} has two parent joints ({parent_of[j.child]!r} and {j.name!r})"
            )
        parent_of[j.child] = j.name
    roots = [n for n in link_names if n not in parent_of]
    if not roots:
        raise URDFError("the joints form a cycle: every link has a parent, so there is no root link")
    if len(roots) > 1:
        shown = ", ".join(repr(r) for r in roots[:5]) + (" ..." if len(roots) > 5 else "")
        raise URDFError(f"the model has {len(roots)} root links ({shown}); a URDF must be one tree")
    root = roots[0]
    children: dict[str, list[str]] = {n: [] for n in link_names}
    for j in joints:
        children[j.parent].append(j.child)
    seen = {root}
    stack = [root]
    while stack:
        for c in children[stack.pop()]:
            if c not in seen:
                seen.add(c)
                stack.append(c)
    unreachable = [n for n in link_names if n not in seen]
    if unreachable:
        raise URDFError(
            "the joints form a cycle through links "
            + ", ".join(repr(n) for n in unreachable[:5])
            + " (not reachable from the root link "
            + repr(root)
            + ")"
        )
    return root


def _visuals(link) -> tuple[Visual, ...]:
    out = []
    for v in link.visuals or ():
        g = v.geometry
        if g is None:
            continue
        origin = frozen_array(v.origin if v.origin is not None else np.eye(4))
        if g.box is not None:
            out.append(Visual("box", origin, tuple(float(s) for s in np.ravel(g.box.size))))
        elif g.cylinder is not None:
            out.append(Visual("cylinder", origin, (float(g.cylinder.radius), float(g.cylinder.length))))
        elif g.sphere is not None:
            out.append(Visual("sphere", origin, (float(g.sphere.radius),)))
        elif g.mesh is not None:
            out.append(Visual("mesh", origin, ()))
    return tuple(out)


def parse_urdf(text: str | bytes, *, max_links: int = DEFAULT_MAX_LINKS) -> RobotModel:
    """Build a :class:`RobotModel` from URDF text.

    Raises :class:`~kinematics.errors.URDFError` (or its subclass
    :class:`~kinematics.errors.UnsupportedJointError`) naming the element at fault.
    """
    data = text.encode("utf-8") if isinstance(text, str) else bytes(text)
    root_el = read_xml(data)
    xacro = xacro_use(root_el)
    if xacro is not None:
        raise URDFError(
            f"this is a xacro file, not URDF (it uses the {xacro}): expand it first -- load it as xacro "
            "(`kinematics fk --xacro FILE`, kinematics.io.xacro.load_xacro, or POST it to /models, "
            "which expands it); it is never read as a URDF with its macros left out"
        )
    _check_document(root_el, max_links)
    substituted = mesh_substitutions(root_el)
    cleaned, ignored = _sanitise(root_el, data)
    if substituted:
        ignored.append(f"{len(substituted)} mesh file name(s) keep a xacro substitution ({_names(substituted)}): "
                       "left as written -- mesh files are never opened, and the kinematics do not use them")

    import yourdfpy  # heavy import, kept local

    try:
        urdf = yourdfpy.URDF.load(
            io.BytesIO(cleaned),
            build_scene_graph=False,
            build_collision_scene_graph=False,
            load_meshes=False,
            load_collision_meshes=False,
        )
    except Exception as exc:  # yourdfpy raises bare Python errors; the checks above should catch first
        raise URDFError(f"URDF could not be parsed: {type(exc).__name__}: {exc}") from None
    robot = urdf.robot

    warnings: list[str] = list(ignored)
    joint_names_all = {j.name for j in robot.joints}
    joints: list[Joint] = []
    for yj in robot.joints:
        axis = np.asarray(yj.axis if yj.axis is not None else (1.0, 0.0, 0.0), dtype=float)
        if yj.type == "floating":  # no axis: the joint moves in all six directions of its frame
            axis = np.array([0.0, 0.0, 1.0])
        elif yj.type in MOVING_TYPES:
            axis = axis / np.max(np.abs(axis))  # scale first: |axis|^2 may overflow (1e200)
            axis = axis / np.linalg.norm(axis)
        limits = None
        if yj.type in ("revolute", "prismatic"):
            if yj.limit is None:
                warnings.append(f"joint {yj.name!r} has no <limit>; treated as unbounded")
            else:
                limits = Limits(
                    lower=float(yj.limit.lower or 0.0),
                    upper=float(yj.limit.upper or 0.0),
                    effort=yj.limit.effort,
                    velocity=yj.limit.velocity,
                )
        mimic = None
        if yj.mimic is not None and yj.type in MOVING_TYPES:
            leader = yj.mimic.joint
            if leader not in joint_names_all:
                warnings.append(
                    f"joint {yj.name!r} mimics {leader!r}, which the file does not have; "
                    f"{yj.name!r} is treated as an independent joint"
                )
            else:
                mimic = Mimic(
                    leader=leader,
                    multiplier=float(1.0 if yj.mimic.multiplier is None else yj.mimic.multiplier),
                    offset=float(0.0 if yj.mimic.offset is None else yj.mimic.offset),
                )
        origin = yj.origin if yj.origin is not None else np.eye(4)
        joints.append(
            Joint(
                name=yj.name,
                type=yj.type,
                parent=yj.parent,
                child=yj.child,
                origin=frozen_array(origin),
                axis=frozen_array(axis),
                limits=limits,
                mimic=mimic,
            )
        )
    link_names = tuple(l.name for l in robot.links)
    root = _check_tree(link_names, joints)

    jmap = {j.name: j for j in joints}
    for j in joints:
        if j.mimic is None:
            continue
        leader = jmap[j.mimic.leader]
        if not leader.moving:
            raise URDFError(f"joint {j.name!r} mimics {leader.name!r}, which is a {leader.type} joint")
        if leader.type in MULTI_DOF_TYPES:
            raise UnsupportedJointError(f"joint {j.name!r} mimics {leader.name!r}, which is a {leader.type} joint "
                                        "(only one-dof joints can be mimicked)")
        seen = {j.name}
        k = leader
        while k.mimic is not None:
            if k.name in seen:
                raise URDFError(f"mimic joints form a cycle through {j.name!r}")
            seen.add(k.name)
            k = jmap[k.mimic.leader]
        if k.name in seen:
            raise URDFError(f"mimic joints form a cycle through {j.name!r}")

    q_names = tuple(j.name for j in joints if j.moving and j.mimic is None)
    return RobotModel(
        name=robot.name,
        links=link_names,
        joints=tuple(joints),
        root=root,
        joint_names=q_names,
        content_hash=hashlib.sha256(data).hexdigest(),
        urdf=data.decode("utf-8", errors="replace"),
        warnings=tuple(warnings),
        visuals={l.name: _visuals(l) for l in robot.links},
    )


def load_urdf(path, *, max_links: int = DEFAULT_MAX_LINKS) -> RobotModel:
    """Read a URDF file from disk and build its model (meshes it names are never opened)."""
    with open(path, "rb") as fh:
        return parse_urdf(fh.read(), max_links=max_links)
