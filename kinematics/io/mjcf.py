"""MJCF (MuJoCo's format) -> URDF -> :class:`~kinematics.model.RobotModel`, by MuJoCo's own compiler.

The document is read with :mod:`defusedxml` (no DTD, no entity), then reduced to its
kinematics before MuJoCo sees it, so that **no file is ever opened**: ``<asset>`` (meshes,
textures, height fields, skins), every ``<geom>``, ``<site>``, ``<camera>``, ``<light>`` and
``<plugin>`` of the bodies, and the sections without kinematics (``<actuator>``,
``<sensor>``, ``<tendon>``, ``<equality>``, ``<contact>``, ``<keyframe>``, ...) are left out;
defaults keep only their ``<joint>`` settings. ``<include file>`` is refused in a single
document (:func:`parse_mjcf` with ``base_dir`` -- an extracted archive -- inlines included files
found inside it). The compiler is told not to fuse static bodies (every body is a link) and to
give bodies without mass a nominal one (``boundmass``: inertia never changes a pose).

``mujoco.MjModel.from_xml_string`` then resolves everything MJCF allows -- defaults classes,
``childclass``, ``<compiler angle eulerseq>``, every orientation form (``quat``, ``euler``,
``axisangle``, ``xyaxes``, ``zaxis``), ``<frame>``, ``<replicate>`` -- and the compiled model is
written out as URDF (as DH tables are), which :func:`~kinematics.io.urdf.parse_urdf` reads, so
Pinocchio can check it unchanged:

* every body is a link named as the body (unnamed: ``body<i>``); the world body is ``world``;
* a body with no joint hangs from its parent by a fixed joint (``<body pos quat>``);
* each hinge or slide joint is a revolute (or, unlimited, continuous) or prismatic joint
  named as the MuJoCo joint, on its anchor (``pos``) and axis; ``ref`` goes into the origin,
  so q is MuJoCo's ``qpos``; a body with several joints, or a hinge off the body origin, gets
  helper links ``<body>__<joint>`` (MuJoCo applies a body's joints in order, each about its
  anchor, exactly as that chain does);
* a slide without ``range`` gets limits of +-``MAX_ABS_COORDINATE`` (URDF and Pinocchio need
  limits on a prismatic joint), with a warning;
* a ``free`` joint (``<freejoint>`` or ``<joint type="free">``) is a URDF ``floating`` joint from
  the world to its body with an identity origin: MuJoCo places such a body at its ``qpos``
  (``x y z qw qx qy qz``, world frame), which is our q ``x y z qx qy qz qw`` (Pinocchio's order:
  the quaternion's w moves to the end); its velocity is the twist in the body frame, linear first;
* ``ball`` joints are refused naming the joint.
"""

from __future__ import annotations

import math
import os
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
from defusedxml import DefusedXmlException
from defusedxml.ElementTree import fromstring as safe_fromstring

from ..errors import MissingExtraError, MJCFError, ModelTooLargeError, UnsupportedJointError
from ..model.robot import RobotModel
from ..tolerances import MAX_ABS_COORDINATE
from ..spatial.rotations import matrix_to_rpy_exact, quaternion_to_matrix
from .urdf import DEFAULT_MAX_LINKS, parse_urdf

#: top-level sections without kinematics (left out)
DROPPED_SECTIONS = ("asset", "actuator", "sensor", "tendon", "equality", "contact", "keyframe", "visual",
                    "custom", "extension", "deformable", "statistic", "size", "option", "skin")
#: elements of bodies without kinematics (left out)
DROPPED_IN_BODIES = ("geom", "site", "camera", "light", "plugin")
#: elements that make bodies from files or generators: refused
REFUSED_IN_BODIES = ("composite", "flexcomp", "attach")
MAX_INCLUDE_DEPTH = 8
#: attributes of <compiler> that change the kinematics (the others are dropped)
KEPT_COMPILER_ATTRIBUTES = ("angle", "eulerseq", "autolimits")


def _read(data: bytes, what: str) -> ET.Element:
    try:
        return safe_fromstring(data, forbid_dtd=True, forbid_entities=True, forbid_external=True)
    except DefusedXmlException as exc:
        raise MJCFError(f"{what} refused: it declares a DTD or entities ({type(exc).__name__})") from None
    except ET.ParseError as exc:
        raise MJCFError(f"{what} is not well-formed XML: {exc}") from None
    except (ValueError, UnicodeError) as exc:
        raise MJCFError(f"{what} could not be decoded: {exc}") from None


def _inline_includes(el: ET.Element, base_dir: Path | None, depth: int = 0) -> None:
    for i, child in enumerate(list(el)):
        if child.tag == "include":
            name = child.get("file") or ""
            if base_dir is None:
                raise MJCFError(f"<include file={name!r}> names another file: a single MJCF document is read alone "
                                "(upload an archive holding every file it includes)")
            if depth >= MAX_INCLUDE_DEPTH:
                raise MJCFError(f"<include file={name!r}>: includes nested deeper than {MAX_INCLUDE_DEPTH}")
            target = (base_dir / name).resolve()
            if not str(target).startswith(str(base_dir.resolve()) + os.sep):
                raise MJCFError(f"<include file={name!r}> is outside the description's directory: refused")
            if not target.is_file():
                raise MJCFError(f"<include file={name!r}>: no such file beside the description")
            sub = _read(target.read_bytes(), f"included file {name!r}")
            if sub.tag != "mujoco":
                raise MJCFError(f"included file {name!r} has root <{sub.tag}>, expected <mujoco>")
            _inline_includes(sub, base_dir, depth + 1)
            el.remove(child)
            for k, grand in enumerate(list(sub)):
                el.insert(i + k, grand)
            return _inline_includes(el, base_dir, depth)  # indices moved: start again
        _inline_includes(child, base_dir, depth)


def _count_bodies(el: ET.Element, factor: int = 1) -> int:
    n = 0
    for child in el:
        if child.tag == "body":
            n += factor + _count_bodies(child, factor)
        elif child.tag == "replicate":
            try:
                count = int(child.get("count", "1"))
            except ValueError:
                raise MJCFError(f"<replicate count={child.get('count')!r}> is not an integer") from None
            n += _count_bodies(child, factor * max(count, 0))
        else:
            n += _count_bodies(child, factor)
    return n


def reduce_to_kinematics(root: ET.Element, base_dir: Path | None = None) -> tuple[str, list[str]]:
    """The MJCF text MuJoCo compiles (no file named anywhere), and what was left out."""
    if root.tag != "mujoco":
        raise MJCFError(f"the root element is <{root.tag}>, expected <mujoco>")
    _inline_includes(root, base_dir)
    left_out: dict[str, int] = {}
    for child in list(root):
        if child.tag in DROPPED_SECTIONS:
            if child.tag != "asset":
                left_out[child.tag] = left_out.get(child.tag, 0) + 1
            root.remove(child)
    for el in root.iter():
        for child in list(el):
            if child.tag in REFUSED_IN_BODIES:
                raise MJCFError(f"<{child.tag}> (in <{el.tag} name={el.get('name')!r}>) builds bodies from "
                                "generators or other files; it is not supported")
            if child.tag in DROPPED_IN_BODIES and el.tag in ("body", "worldbody", "frame", "replicate"):
                el.remove(child)
    for default in root.iter("default"):
        for child in list(default):
            if child.tag not in ("joint", "default"):
                default.remove(child)
    compiler = root.find("compiler")
    if compiler is None:
        compiler = ET.Element("compiler")
        root.insert(0, compiler)
    for attr in list(compiler.attrib):  # only what changes poses stays (angle units, Euler sequence, limits)
        if attr not in KEPT_COMPILER_ATTRIBUTES:
            del compiler.attrib[attr]
    compiler.set("fusestatic", "false")
    compiler.set("inertiafromgeom", "false")
    compiler.set("boundmass", "1e-3")
    compiler.set("boundinertia", "1e-6")
    compiler.set("alignfree", "false")
    warnings = []
    if left_out:
        shown = ", ".join(f"<{k}>" for k in left_out)
        warnings.append(f"ignored {shown}: no kinematics in them (meshes and geometry are never read)")
        if "equality" in left_out:
            warnings.append("equality constraints are not applied: the joints they couple are independent in q")
    return ET.tostring(root, encoding="unicode"), warnings


def _fmt(v: float) -> str:
    return repr(float(v)) if v != 0 else "0"


def _origin(T: np.ndarray) -> str:
    xyz = " ".join(_fmt(v) for v in T[:3, 3])
    rpy = " ".join(_fmt(v) for v in matrix_to_rpy_exact(T[:3, :3]))
    return f'<origin xyz="{xyz}" rpy="{rpy}"/>'


def _pose(pos, quat) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = quaternion_to_matrix(*(float(q) for q in quat))
    T[:3, 3] = pos
    return T


def _trans(p) -> np.ndarray:
    T = np.eye(4)
    T[:3, 3] = p
    return T


def _rot(axis, angle: float) -> np.ndarray:
    a = np.asarray(axis, dtype=float)
    a = a / np.linalg.norm(a)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    T = np.eye(4)
    T[:3, :3] = np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K
    return T


def _esc(name: str) -> str:
    return name.replace("&", "&amp;").replace('"', "&quot;").replace("<", "&lt;").replace(">", "&gt;")


def _mujoco():
    """The ``mujoco`` module (the ``mjcf`` extra), or :class:`~kinematics.errors.MissingExtraError`."""
    try:
        import mujoco
    except ImportError as exc:
        raise MissingExtraError.of("mjcf", "MJCF models", "mujoco") from exc
    return mujoco


def compiled_to_urdf(m, name: str, notes: list[str] | None = None) -> str:
    """URDF text of a compiled ``mujoco.MjModel`` (hinge, slide and fixed bodies; see the module doc);
    ``notes`` collects what a user should know (unbounded slides)."""
    notes = [] if notes is None else notes
    mujoco = _mujoco()

    def body_name(b: int) -> str:
        return mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b) or ("world" if b == 0 else f"body{b}")

    def joint_name(j: int) -> str:
        return mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j) or f"joint{j}"

    links = [body_name(b) for b in range(m.nbody)]
    if len(set(links)) != len(links):
        raise MJCFError("two bodies have the same name")
    taken = set(links)
    out_links = [f'<link name="{_esc(n)}"/>' for n in links]
    out_joints = []
    joint_names: set[str] = set()
    FREE, BALL, SLIDE, HINGE = (int(mujoco.mjtJoint.mjJNT_FREE), int(mujoco.mjtJoint.mjJNT_BALL),
                                int(mujoco.mjtJoint.mjJNT_SLIDE), int(mujoco.mjtJoint.mjJNT_HINGE))
    for b in range(1, m.nbody):
        parent = links[int(m.body_parentid[b])]
        body = links[b]
        pending = _pose(m.body_pos[b], m.body_quat[b])
        current = parent
        first, count = int(m.body_jntadr[b]), int(m.body_jntnum[b])
        for k, j in enumerate(range(first, first + count)):
            jname = joint_name(j)
            jtype = int(m.jnt_type[j])
            if jtype == FREE:
                if count != 1 or int(m.body_parentid[b]) != 0:
                    raise UnsupportedJointError(
                        f"free joint {jname!r} of body {body!r}: only a free joint alone in a body of the world is "
                        "supported (MuJoCo places that body at its qpos in the world frame)")
                if jname in joint_names:
                    raise MJCFError(f"two joints are named {jname!r}")
                joint_names.add(jname)
                out_joints.append(f'<joint name="{_esc(jname)}" type="floating"><parent link="{_esc(parent)}"/>'
                                  f'<child link="{_esc(body)}"/></joint>')
                current, pending = body, np.eye(4)
                continue
            if jtype == BALL:
                raise UnsupportedJointError(f"joint {jname!r} of body {body!r} is a ball joint, which is not supported")
            if jname in joint_names:
                raise MJCFError(f"two joints are named {jname!r}")
            joint_names.add(jname)
            axis = np.asarray(m.jnt_axis[j], dtype=float)
            anchor = np.asarray(m.jnt_pos[j], dtype=float)
            ref = float(m.qpos0[int(m.jnt_qposadr[j])])
            if jtype == HINGE:
                origin = pending @ _trans(anchor) @ _rot(axis, -ref)
                pending = _trans(-anchor)
            else:
                origin = pending @ _trans(-axis * ref)
                pending = np.eye(4)
            last = k == count - 1 and np.array_equal(pending, np.eye(4))
            child = body if last else _unique(f"{body}__{jname}", taken)
            if not last:
                out_links.append(f'<link name="{_esc(child)}"/>')
            limited = bool(m.jnt_limited[j])
            lo, hi = (float(v) for v in m.jnt_range[j])
            if jtype == HINGE:
                kind = "revolute" if limited else "continuous"
            else:
                kind = "prismatic"
                if not limited:  # URDF (and Pinocchio) need limits on a prismatic joint: unbounded in practice
                    lo, hi = -MAX_ABS_COORDINATE, MAX_ABS_COORDINATE
                    notes.append(f"slide joint {jname!r} has no range: its limits are +-{MAX_ABS_COORDINATE:g} m")
            limit = (f'<limit lower="{_fmt(lo)}" upper="{_fmt(hi)}" effort="0" velocity="0"/>' if kind != "continuous"
                     else "")
            ax = " ".join(_fmt(v) for v in axis)
            out_joints.append(f'<joint name="{_esc(jname)}" type="{kind}"><parent link="{_esc(current)}"/>'
                              f'<child link="{_esc(child)}"/>{_origin(origin)}<axis xyz="{ax}"/>{limit}</joint>')
            current = child
        if current != body:
            fixed = _unique(f"{body}__fixed", joint_names)
            joint_names.add(fixed)
            out_joints.append(f'<joint name="{_esc(fixed)}" type="fixed"><parent link="{_esc(current)}"/>'
                              f'<child link="{_esc(body)}"/>{_origin(pending)}</joint>')
    return (f'<?xml version="1.0"?>\n<robot name="{_esc(name)}">\n' + "\n".join(out_links) + "\n"
            + "\n".join(out_joints) + "\n</robot>\n")


def _unique(name: str, taken: set[str]) -> str:
    out, i = name, 1
    while out in taken:
        i += 1
        out = f"{name}{i}"
    taken.add(out)
    return out


def _quiet_mujoco(mujoco) -> None:
    """MuJoCo writes its warnings to ``MUJOCO_LOG.TXT`` in the working directory unless a handler
    is installed: install one (once per process) that sends them to the ``kinematics.io.mjcf`` logger."""
    if mujoco.get_mju_user_warning() is None:
        import logging

        log = logging.getLogger("kinematics.io.mjcf")
        mujoco.set_mju_user_warning(lambda msg: log.warning("MuJoCo: %s", msg))


def compile_mjcf(text: str | bytes, *, base_dir: os.PathLike | str | None = None, max_links: int = DEFAULT_MAX_LINKS):
    """``(mujoco.MjModel, warnings)`` of the MJCF reduced to its kinematics (no file is opened)."""
    mujoco = _mujoco()

    data = text.encode("utf-8") if isinstance(text, str) else bytes(text)
    root = _read(data, "MJCF document")
    xml, warnings = reduce_to_kinematics(root, Path(base_dir) if base_dir is not None else None)
    bodies = _count_bodies(root.find("worldbody") if root.find("worldbody") is not None else ET.Element("x"))
    if bodies + 1 > max_links:
        raise ModelTooLargeError(f"the MJCF has {bodies + 1} bodies; the limit is {max_links}")
    _quiet_mujoco(mujoco)
    try:
        m = mujoco.MjModel.from_xml_string(xml)
    except ValueError as exc:
        raise MJCFError(f"MuJoCo refused the MJCF: {str(exc).strip()}") from None
    return m, warnings, root.get("model") or "mjcf"


def parse_mjcf(text: str | bytes, *, base_dir: os.PathLike | str | None = None,
               max_links: int = DEFAULT_MAX_LINKS) -> RobotModel:
    """Build a model from MJCF text (see the module doc); ``base_dir`` resolves ``<include>``."""
    m, warnings, name = compile_mjcf(text, base_dir=base_dir, max_links=max_links)
    urdf = compiled_to_urdf(m, name, warnings)
    model = parse_urdf(urdf, max_links=max_links)
    from dataclasses import replace

    return replace(model, format="mjcf", warnings=tuple(warnings) + tuple(model.warnings))


def load_mjcf(path: os.PathLike | str, *, max_links: int = DEFAULT_MAX_LINKS) -> RobotModel:
    """Read an MJCF file (its meshes are never opened; ``<include>`` resolved inside its directory)."""
    path = Path(path)
    return parse_mjcf(path.read_bytes(), base_dir=path.resolve().parent, max_links=max_links)
