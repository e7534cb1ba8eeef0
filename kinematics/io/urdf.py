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
import xml.etree.ElementTree as ET
from typing import Iterable

import numpy as np
from defusedxml import DefusedXmlException
from defusedxml.ElementTree import fromstring as safe_fromstring

from ..errors import ModelTooLargeError, UnsupportedJointError, URDFError
from ..model.robot import MOVING_TYPES, SUPPORTED_TYPES, Joint, Limits, Mimic, RobotModel, Visual, frozen_array
from ..tolerances import AXIS_EPS, MAX_ABS_COORDINATE


#: Default cap on the number of links (and of joints) in one model.
DEFAULT_MAX_LINKS = 10_000
#: Joint types URDF knows but this product refuses for now.
UNSUPPORTED_TYPES = frozenset({"floating", "planar"})


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


def _read_xml(data: bytes) -> ET.Element:
    try:
        root = safe_fromstring(data, forbid_dtd=True, forbid_entities=True, forbid_external=True)
    except DefusedXmlException as exc:
        raise URDFError(
            f"URDF refused: it declares a DTD or entities ({type(exc).__name__}); "
            "entity expansion and external entities are disabled"
        ) from None
    except ET.ParseError as exc:
        raise URDFError(f"URDF is not well-formed XML: {exc}") from None
    except (ValueError, UnicodeError) as exc:
        raise URDFError(f"URDF could not be decoded: {exc}") from None
    return root


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
    link_names: set[str] = set()
    for i, el in enumerate(links):
        name = el.get("name")
        if not name:
            raise URDFError(f"<link> number {i + 1} has no 'name' attribute")
        if name in link_names:
            raise URDFError(f"duplicate link name {name!r}")
        link_names.add(name)
    joint_names: set[str] = set()
    for i, el in enumerate(joints):
        name = el.get("name")
        if not name:
            raise URDFError(f"<joint> number {i + 1} has no 'name' attribute")
        if name in joint_names:
            raise URDFError(f"duplicate joint name {name!r}")
        joint_names.add(name)
        jt = el.get("type")
        if jt in UNSUPPORTED_TYPES:
            raise UnsupportedJointError(
                f"joint {name!r} is of type {jt!r}, which is not supported; "
                "give the root link's world pose in the request instead of a floating joint"
            )
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
        if axis is not None and jt in MOVING_TYPES:
            xyz = _numbers(axis.get("xyz"), 3, f"joint {name!r} <axis xyz>", "1 0 0")
            if math.hypot(*xyz) < AXIS_EPS:  # hypot: no overflow for huge components
                raise URDFError(f"joint {name!r} has a zero <axis>")
        limit = el.find("limit")
        if limit is not None:
            lo = _number(limit.get("lower"), f"joint {name!r} <limit lower>", 0.0)
            hi = _number(limit.get("upper"), f"joint {name!r} <limit upper>", 0.0)
            _number(limit.get("effort"), f"joint {name!r} <limit effort>", 0.0)
            _number(limit.get("velocity"), f"joint {name!r} <limit velocity>", 0.0)
            if jt in ("revolute", "prismatic") and lo > hi:
                raise URDFError(f"joint {name!r} has lower limit {lo} above upper limit {hi}")
        mimic = el.find("mimic")
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
    root_el = _read_xml(data)
    _check_document(root_el, max_links)

    import yourdfpy  # heavy import, kept local

    try:
        urdf = yourdfpy.URDF.load(
            io.BytesIO(data),
            build_scene_graph=False,
            build_collision_scene_graph=False,
            load_meshes=False,
            load_collision_meshes=False,
        )
    except Exception as exc:  # yourdfpy raises bare Python errors; the checks above should catch first
        raise URDFError(f"URDF could not be parsed: {type(exc).__name__}: {exc}") from None
    robot = urdf.robot

    warnings: list[str] = []
    joint_names_all = {j.name for j in robot.joints}
    joints: list[Joint] = []
    for yj in robot.joints:
        axis = np.asarray(yj.axis if yj.axis is not None else (1.0, 0.0, 0.0), dtype=float)
        if yj.type in MOVING_TYPES:
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
