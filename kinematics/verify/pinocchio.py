"""Cross-check against Pinocchio: the only module of the library that imports it (an
import contract checks that).

Builds the Pinocchio model from the same URDF text (``mimic=True``), maps our q to
Pinocchio's (a continuous joint is ``(cos, sin)`` there; a mimic joint has no entry),
computes every link's pose (BODY frames) and the Jacobians, and reports the largest
deviations from our PoE results.

Pinocchio 4.1 refuses ``mimic=True`` on some catalogue files ("The parent joint of the
mimic joint is not in the kinematic tree"): there the model is built without mimic, each
mimic joint is set from its leader, and its Jacobian column is folded into the leader's.

Floating and planar joints have the same layout here and in Pinocchio (JointModelFreeFlyer:
``x, y, z, qx, qy, qz, qw`` and 6 velocities; JointModelPlanar: ``x, y, cos, sin`` and 3), so
their entries are copied as they are. A model made by ``floating_base``
(``model.base_model`` set) is checked against Pinocchio's own construction,
``buildModelFromXML(base_urdf, JointModelFreeFlyer())``: its root joint is Pinocchio's
``root_joint`` and its new root link Pinocchio's ``universe`` frame.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass

import numpy as np

from ..errors import MissingExtraError, ReferenceUnavailableError

try:
    import pinocchio as pin
except ImportError as exc:  # the `verify` extra
    raise MissingExtraError.of("verify", "verification against Pinocchio", "pinocchio") from exc

from ..engine.poe import compile_model
from ..model.derived import PerModel
from ..model.robot import RobotModel
from ..spatial.reference import REFERENCES, Reference

PINOCCHIO_VERSION = pin.__version__
REFERENCE_NAME = f"pinocchio {PINOCCHIO_VERSION}"

_REFERENCE_FRAMES = {
    Reference.WORLD: pin.ReferenceFrame.WORLD,
    Reference.LOCAL: pin.ReferenceFrame.LOCAL,
    Reference.LOCAL_WORLD_ALIGNED: pin.ReferenceFrame.LOCAL_WORLD_ALIGNED,
}


@dataclass(frozen=True)
class Deviation:
    """Largest absolute deviations between our results and Pinocchio's."""

    max_position_error: float
    max_rotation_error: float
    max_jacobian_error: float | None = None
    reference: str = REFERENCE_NAME

    @property
    def worst(self) -> float:
        return max(self.max_position_error, self.max_rotation_error, self.max_jacobian_error or 0.0)


class PinocchioReference:
    """Pinocchio's view of one of our models (build once, then call from any thread)."""

    def __init__(self, model: RobotModel):
        self.model = model
        self.mimic_native = True
        base = model.base_model
        urdf = model.urdf if base is None else base.urdf
        extra = () if base is None else (pin.JointModelFreeFlyer(),)
        try:
            self.pin_model = pin.buildModelFromXML(urdf, *extra, mimic=True)
        except Exception as exc:  # noqa: BLE001 - Pinocchio raises plain RuntimeError/ValueError
            try:
                self.pin_model = pin.buildModelFromXML(urdf, *extra, mimic=False)
                self.mimic_native = False
            except Exception:
                raise ReferenceUnavailableError(f"Pinocchio cannot load model {model.name!r}: {exc}") from None
        pm = self.pin_model
        self._data = threading.local()
        # Pinocchio's names of our joints and links where they differ (a floating_base model's root)
        alias = {} if base is None else {"root_joint": model.joint_names[0]}
        # our joint -> (idx_q, idx_v, kind) in Pinocchio; only joints with their own entry
        self.q_map: list[tuple[int, int, str, str]] = []  # (idx_q, idx_v, type, our joint name)
        for jid in range(1, pm.njoints):
            name = alias.get(pm.names[jid], pm.names[jid])
            if name not in model.joint_map:
                continue
            jm = pm.joints[jid]
            if jm.nq == 0:  # a native mimic joint
                continue
            self.q_map.append((jm.idx_q, jm.idx_v, model.joint_map[name].type, name))
        self.frame_ids: dict[str, int] = {}
        for fid, fr in enumerate(pm.frames):
            if fr.type == pin.FrameType.BODY and fr.name in model.joint_map.keys() | set(model.links):
                if fr.name in set(model.links) and fr.name not in self.frame_ids:
                    self.frame_ids[fr.name] = fid
        if base is not None and model.root not in self.frame_ids:
            self.frame_ids[model.root] = pm.getFrameId("universe")
        missing = [l for l in model.links if l not in self.frame_ids]
        if missing:
            raise ReferenceUnavailableError(f"Pinocchio has no BODY frame for links {missing[:5]}")

    def data(self) -> pin.Data:
        d = getattr(self._data, "d", None)
        if d is None:
            d = self.pin_model.createData()
            self._data.d = d
        return d

    def to_pinocchio_q(self, q: np.ndarray) -> np.ndarray:
        """Our q (nq,) -> Pinocchio's configuration vector (its nq)."""
        m = self.model
        values = {s.name: (q[s.q_start] if s.nq == 1 else q[s.q_slice]) for s in m.layout}
        for j in m.moving_joints:  # mimic values, used when Pinocchio has them as joints
            r = m.resolve_mimic(j)
            if r is not None:
                values[j.name] = r[1] * values[r[0]] + r[2]
        x = pin.neutral(self.pin_model)
        for idx_q, _, jtype, name in self.q_map:
            v = values[name]
            if jtype == "continuous":
                x[idx_q], x[idx_q + 1] = np.cos(v), np.sin(v)
            elif jtype in ("floating", "planar"):  # the same layout in both
                x[idx_q:idx_q + len(v)] = v
            else:
                x[idx_q] = v
        return x

    def _fold_columns(self, Jp: np.ndarray) -> np.ndarray:
        """Pinocchio Jacobian (6, its nv) -> ours (6, nv), folding mimic columns into leaders."""
        m = self.model
        J = np.zeros((6, m.nv))
        for _, idx_v, _, name in self.q_map:
            joint = m.joint_map[name]
            r = m.resolve_mimic(joint)
            if r is None:
                s = m.slot[name]
                J[:, s.v_slice] += Jp[:, idx_v:idx_v + s.nv]
            else:
                J[:, m.slot[r[0]].v_start] += r[1] * Jp[:, idx_v]
        return J

    def to_pinocchio_v(self, qdot: np.ndarray) -> np.ndarray:
        """Our joint velocities (nv,) -> Pinocchio's velocity vector (its nv): the entries of each joint
        with its own q entry (a continuous joint has one velocity, not two; floating 6, planar 3, the
        same order); a mimic joint Pinocchio has as a joint of its own moves with
        ``multiplier * qdot[leader]``."""
        m = self.model
        values = {s.name: qdot[s.v_slice] for s in m.layout}
        for j in m.moving_joints:
            r = m.resolve_mimic(j)
            if r is not None:
                values[j.name] = r[1] * values[r[0]]
        v = np.zeros(self.pin_model.nv)
        for _, idx_v, _, name in self.q_map:
            val = values[name]
            v[idx_v:idx_v + len(val)] = val
        return v

    def gravity(self, q: np.ndarray) -> dict[str, float]:
        """The generalised gravity torque of each of our one-dof joints at q (nq,) (Pinocchio's
        ``computeGeneralizedGravity``, from the URDF's inertials; gravity along the root's -z, 9.81)."""
        pm = self.pin_model
        saved = pm.gravity.linear.copy()
        try:
            pm.gravity.linear = np.array([0.0, 0.0, -9.81])
            g = pin.computeGeneralizedGravity(pm, self.data(), self.to_pinocchio_q(np.asarray(q, dtype=float)))
        finally:
            pm.gravity.linear = saved
        return {name: float(g[idx_v]) for _, idx_v, jtype, name in self.q_map if jtype not in ("floating", "planar")}

    def poses(self, q: np.ndarray) -> dict[str, np.ndarray]:
        """Every link's pose for one configuration: {link: 4x4}."""
        d = self.data()
        pin.framesForwardKinematics(self.pin_model, d, self.to_pinocchio_q(q))
        return {l: d.oMf[fid].homogeneous.copy() for l, fid in self.frame_ids.items()}

    def jacobian(self, q: np.ndarray, link: str, reference: str = Reference.WORLD) -> np.ndarray:
        """Jacobian (6, dof) of ``link`` (linear rows first) in ``reference``."""
        d = self.data()
        x = self.to_pinocchio_q(q)
        Jp = pin.computeFrameJacobian(self.pin_model, d, x, self.frame_ids[link], _REFERENCE_FRAMES[reference])
        # eigenpy hands a 6x1 Jacobian (one-DOF model) back as shape (6,): restore the column
        return self._fold_columns(np.asarray(Jp).reshape(6, -1))

    def frames(self, links, tool: np.ndarray | None = None) -> "Frames":
        """Pinocchio frames of ``links`` (their BODY frames), or, with a tool offset ``T_link_tool``,
        of an operational frame added on each link at that offset (``pin.Frame(..., OP_FRAME)``,
        parent joint and frame those of the link's BODY frame), in a copy of the model."""
        links = list(links)
        if tool is None:
            return Frames(self, self.pin_model, self.data(), {l: self.frame_ids[l] for l in links})
        pm = pin.Model(self.pin_model)
        placement = pin.SE3(np.asarray(tool, dtype=float))
        ids = {}
        for link in links:
            body = pm.frames[self.frame_ids[link]]
            frame = pin.Frame(f"{link}__tool", body.parentJoint, self.frame_ids[link], body.placement * placement,
                              pin.FrameType.OP_FRAME)
            ids[link] = pm.addFrame(frame, False)
        return Frames(self, pm, pm.createData(), ids)


class Frames:
    """Some frames of a (possibly extended) Pinocchio model, with a :class:`pin.Data` of it
    (one thread's: :meth:`PinocchioReference.frames` builds it per call)."""

    def __init__(self, ref: "PinocchioReference", pin_model, data, ids: dict[str, int]):
        self.ref, self.pin_model, self.data, self.ids = ref, pin_model, data, ids

    def poses(self, q: np.ndarray) -> dict[str, np.ndarray]:
        """{link: 4x4 pose of its frame} for one configuration."""
        pin.framesForwardKinematics(self.pin_model, self.data, self.ref.to_pinocchio_q(q))
        return {l: self.data.oMf[fid].homogeneous.copy() for l, fid in self.ids.items()}

    def jacobian(self, q: np.ndarray, link: str, reference: str = Reference.WORLD) -> np.ndarray:
        """Jacobian (6, dof) of the frame of ``link`` (linear rows first) in ``reference``."""
        Jp = pin.computeFrameJacobian(self.pin_model, self.data, self.ref.to_pinocchio_q(q), self.ids[link],
                                      _REFERENCE_FRAMES[reference])
        return self.ref._fold_columns(np.asarray(Jp).reshape(6, -1))

    def velocities(self, q: np.ndarray, qdot: np.ndarray, references=REFERENCES) -> dict[str, dict[str, np.ndarray]]:
        """{link: {reference: twist (6,), linear first}} of every frame for one configuration and
        its joint velocities (``pin.forwardKinematics(model, data, q, v)`` then
        ``pin.getFrameVelocity``)."""
        pin.forwardKinematics(self.pin_model, self.data, self.ref.to_pinocchio_q(q), self.ref.to_pinocchio_v(qdot))
        return {l: {r: pin.getFrameVelocity(self.pin_model, self.data, fid, _REFERENCE_FRAMES[r]).vector.copy()
                    for r in references} for l, fid in self.ids.items()}


_references = PerModel(PinocchioReference)


def reference_for(model: RobotModel) -> PinocchioReference:
    """Pinocchio's view of a model object, built on first use and kept as long as the model lives."""
    return _references(model)


def compare_fk(model: RobotModel, Q: np.ndarray, links=None, poses: np.ndarray | None = None,
               tool: np.ndarray | None = None) -> Deviation:
    """Largest deviation of our FK of ``links`` (default all) from Pinocchio's over a batch Q
    (``tool``: of the frames at that offset ``T_link_tool`` from each link)."""
    Q = np.atleast_2d(np.asarray(Q, dtype=float))
    poe = compile_model(model)
    links = list(model.links) if links is None else list(links)
    ours = poe.fk(Q, links, tool=tool) if poses is None else poses
    ref = reference_for(model)
    frames = ref.frames(links, tool) if tool is not None else ref
    pos_err = rot_err = 0.0
    for n, q in enumerate(Q):
        theirs = frames.poses(q)
        for k, l in enumerate(links):
            diff = ours[n, k] - theirs[l]
            pos_err = max(pos_err, float(np.max(np.abs(diff[:3, 3]))))
            rot_err = max(rot_err, float(np.max(np.abs(diff[:3, :3]))))
    return Deviation(pos_err, rot_err)


def compare_jacobian(model: RobotModel, Q: np.ndarray, link: str, references=REFERENCES, jacobians: dict | None = None,
                     tool: np.ndarray | None = None) -> float:
    """Largest entry-wise deviation of our Jacobians of ``link`` (``tool``: of the frame at that
    offset from it) from Pinocchio's."""
    Q = np.atleast_2d(np.asarray(Q, dtype=float))
    poe = compile_model(model)
    ref = reference_for(model)
    frames = ref.frames([link], tool) if tool is not None else ref
    err = 0.0
    for reference in references:
        ours = poe.jacobian(Q, link, reference, tool=tool) if jacobians is None else jacobians[reference]
        for n, q in enumerate(Q):
            theirs = frames.jacobian(q, link, reference)
            if theirs.size:
                err = max(err, float(np.max(np.abs(ours[n] - theirs))))
    return err


def compare_velocity(model: RobotModel, Q: np.ndarray, Qd: np.ndarray, links=None, references=REFERENCES,
                     twists: dict | None = None, tool: np.ndarray | None = None) -> float:
    """Largest entry-wise deviation of our link twists (``twists``: ``{reference: (N, L, 6)}``, else
    computed) from Pinocchio's ``getFrameVelocity`` after ``forwardKinematics(model, data, q, v)``,
    over a batch of joint values ``Q`` and velocities ``Qd`` (N, dof)."""
    Q = np.atleast_2d(np.asarray(Q, dtype=float))
    Qd = np.atleast_2d(np.asarray(Qd, dtype=float))
    links = list(model.links) if links is None else list(links)
    if twists is None:
        twists = compile_model(model).velocity(Q, Qd, links, tool=tool)
    frames = reference_for(model).frames(links, tool)
    err = 0.0
    for n in range(Q.shape[0]):
        theirs = frames.velocities(Q[n], Qd[n], references)
        for k, link in enumerate(links):
            for reference in references:
                err = max(err, float(np.max(np.abs(twists[reference][n, k] - theirs[link][reference]))))
    return err


def compare_mjcf(model: RobotModel, path, Q: np.ndarray, skip=frozenset()) -> tuple[float, int]:
    """Largest deviation of our FK (a model read from the MJCF file ``path``) from Pinocchio's own
    MJCF reader (``buildModelFromMJCF``) over the batch ``Q``, on every body both know, and the
    number of bodies compared (in the frame of the first body when it is fixed: Pinocchio's reader
    places that body at its world origin). Joints are matched by name; Pinocchio's q of a joint with
    ``nq == 2`` (unbounded revolute) is ``(cos, sin)``."""
    Q = np.atleast_2d(np.asarray(Q, dtype=float))
    try:
        pm = pin.buildModelFromMJCF(str(path))
    except Exception as exc:  # noqa: BLE001 -- Pinocchio's reader raises plain RuntimeErrors
        raise ReferenceUnavailableError(f"Pinocchio cannot read {path}: {exc}") from exc
    data = pm.createData()
    bodies = {f.name: i for i, f in enumerate(pm.frames) if f.type == pin.FrameType.BODY and f.name in model.links}
    root = next(iter(bodies), None)
    links = [root] + [b for b in bodies if b != root and b not in skip] if root is not None else []
    ours = compile_model(model).fk(Q, links)
    # Pinocchio's reader makes the first body the root of its model: that body's own pose in the
    # world is dropped, so a fixed root body is where both are compared from.
    if root is not None and pm.frames[bodies[root]].parentJoint == 0:
        ours = np.linalg.inv(ours[:, :1]) @ ours
    worst = 0.0
    for n, q in enumerate(Q):
        qp = pin.neutral(pm)
        for jid in range(1, pm.njoints):
            joint = pm.joints[jid]
            qp[joint.idx_q:joint.idx_q + joint.nq] = _mjcf_joint_q(model, q, pm, jid)
        pin.framesForwardKinematics(pm, data, qp)
        for k, link in enumerate(links):
            worst = max(worst, float(np.max(np.abs(ours[n, k] - data.oMf[bodies[link]].homogeneous))))
    return worst, len(links)


def _mjcf_joint_q(model: RobotModel, q: np.ndarray, pm, jid: int) -> np.ndarray:
    """Pinocchio's q of joint ``jid`` of its MJCF model: a hinge or slide (``nq == 1``), an unbounded
    hinge (``(cos, sin)``), a free joint (ours is the floating joint above the same body: the same
    7 values), or the composite joint that a body with several joints becomes
    (``Composite_<first joint>``: the body's joints, consecutive in document order)."""
    name, nq, nv = pm.names[jid], pm.joints[jid].nq, pm.joints[jid].nv
    if nq == 7 and nv == 6:
        body = next(f.name for f in pm.frames if f.type == pin.FrameType.BODY and f.parentJoint == jid)
        return q[model.slot[model.parent_joint[body].name].q_slice]
    if name.startswith("Composite_") and name not in model.slot:
        first = model.slot[name[len("Composite_"):]].q_start
        if nq != nv:
            raise ReferenceUnavailableError(f"composite joint {name!r} holds unbounded joints")
        return q[first:first + nq]
    value = q[model.slot[name].q_start]
    return np.array([value] if nq == 1 else [np.cos(value), np.sin(value)])


class PinocchioCollision:
    """Pinocchio's collision model of the same URDF (``buildGeomFromUrdfString`` with
    ``COLLISION``, meshes from ``package_dirs``: the installed packages) with collision pairs
    for exactly the link ``pairs`` given -- every geometry object of one link against every one
    of the other -- so its ``computeCollisions`` checks what ours does.

    ``margin`` (m) is every pair's ``security_margin``. Links of ``pairs`` Pinocchio has no
    geometry for raise :class:`ReferenceUnavailableError`."""

    def __init__(self, model: RobotModel, pairs, package_dirs, margin: float = 0.0):
        self.ref = reference_for(model)
        pm = self.ref.pin_model
        try:
            self.geom_model = pin.buildGeomFromUrdfString(pm, model.urdf, pin.GeometryType.COLLISION,
                                                          package_dirs=[str(p) for p in package_dirs])
        except Exception as exc:  # noqa: BLE001 - Pinocchio raises plain errors
            raise ReferenceUnavailableError(f"Pinocchio cannot load the collision geometry of {model.name!r}: {exc}") from None
        gm = self.geom_model
        by_link: dict[str, list[int]] = {}
        for gid, obj in enumerate(gm.geometryObjects):
            by_link.setdefault(pm.frames[obj.parentFrame].name, []).append(gid)
        self.by_link = by_link
        self.pairs = [tuple(p) for p in pairs]
        self.owner: list[int] = []  # collision pair k -> index into self.pairs
        for k, (a, b) in enumerate(self.pairs):
            for name in (a, b):
                if name not in by_link:
                    raise ReferenceUnavailableError(f"Pinocchio has no collision geometry for link {name!r}")
            for ga in by_link[a]:
                for gb in by_link[b]:
                    gm.addCollisionPair(pin.CollisionPair(ga, gb))
                    self.owner.append(k)
        self.owner_array = np.array(self.owner, dtype=np.intp)
        self.geom_data = gm.createData()
        for req in self.geom_data.collisionRequests:
            req.security_margin = float(margin)
        self.data = pm.createData()

    def collisions(self, q: np.ndarray) -> list[tuple[str, str]]:
        """The link pairs in collision at our ``q`` (``pairs`` order)."""
        pin.computeCollisions(self.ref.pin_model, self.data, self.geom_model, self.geom_data,
                              self.ref.to_pinocchio_q(np.asarray(q, dtype=float)), False)
        hit = set()
        for k, res in enumerate(self.geom_data.collisionResults):
            if res.isCollision():
                hit.add(self.owner[k])
        return [self.pairs[k] for k in sorted(hit)]

    def distances(self, q: np.ndarray) -> np.ndarray:
        """(P,) each link pair's distance (the minimum over its geometry pairs) at our ``q``."""
        pin.computeDistances(self.ref.pin_model, self.data, self.geom_model, self.geom_data,
                             self.ref.to_pinocchio_q(np.asarray(q, dtype=float)))
        d = np.array([r.min_distance for r in self.geom_data.distanceResults])
        out = np.full(len(self.pairs), np.inf)
        np.minimum.at(out, self.owner_array, d)
        return out

    def run_loop(self, Qpin: np.ndarray) -> int:
        """Pinocchio's own loop: ``computeCollisions`` on every row of ``Qpin`` (Pinocchio's q);
        the count of configurations in collision (what a benchmark times)."""
        pm, data, gm, gd = self.ref.pin_model, self.data, self.geom_model, self.geom_data
        return sum(bool(pin.computeCollisions(pm, data, gm, gd, q, False)) for q in Qpin)


@dataclass(frozen=True)
class CollisionAgreement:
    """How our collision answers compare with Pinocchio's over a batch: ``configurations``,
    ``same_pairs`` (configurations with the same colliding pairs), ``mismatches`` (their indices),
    ``max_distance_error`` (largest |ours - Pinocchio's| of the minimum distance over the pairs,
    configurations where both are positive; None without distances)."""

    configurations: int
    same_pairs: int
    mismatches: tuple[int, ...]
    max_distance_error: float | None = None
    reference: str = REFERENCE_NAME

    @property
    def fraction(self) -> float:
        return self.same_pairs / max(self.configurations, 1)


def compare_collision(model: RobotModel, Q: np.ndarray, pairs, package_dirs, ours, margin: float = 0.0,
                      distances=None) -> CollisionAgreement:
    """Compare ``ours`` (per configuration of ``Q``, the list of colliding link pairs) and, when
    given, ``distances`` ((N,) our minimum distance over ``pairs``) with Pinocchio's on the same
    geometry and pairs."""
    Q = np.atleast_2d(np.asarray(Q, dtype=float))
    pc = PinocchioCollision(model, pairs, package_dirs, margin)
    mismatches = []
    worst = 0.0
    for n, q in enumerate(Q):
        if sorted(map(tuple, ours[n])) != sorted(pc.collisions(q)):
            mismatches.append(n)
        if distances is not None:
            theirs = float(np.min(pc.distances(q))) if pairs else np.inf
            if theirs > 0 and distances[n] > 0 and np.isfinite(theirs):
                worst = max(worst, abs(theirs - float(distances[n])))
    return CollisionAgreement(len(Q), len(Q) - len(mismatches), tuple(mismatches),
                              worst if distances is not None else None)


def multistart_solutions(model: RobotModel, link: str, target: np.ndarray, columns, q_fixed: np.ndarray,
                         seeds: int = 256, steps: int = 80, seed: int = 0, tolerance: float = 1e-10) -> np.ndarray:
    """An independent reference for every-solution IK: damped Newton on **Pinocchio's** FK and frame
    Jacobian from ``seeds`` random starts of the joints ``columns`` (revolute: over (−π, π]; the
    others keep their ``q_fixed`` values), keeping each converged configuration (pose error below
    ``tolerance``, m and rad) once (angles compared modulo 2π, within 1e-6). A search: it finds what
    its starts reach, nothing proves it found all. Returns (K, dof), angles in (−π, π]."""
    ref = reference_for(model)
    pm, d, fid = ref.pin_model, ref.data(), ref.frame_ids[link]
    goal = pin.SE3(np.asarray(target, dtype=float))
    cols = np.asarray(columns, dtype=np.intp)
    rng = np.random.default_rng(seed)
    found: list[np.ndarray] = []

    def error(q):
        pin.framesForwardKinematics(pm, d, ref.to_pinocchio_q(q))
        return pin.log6(d.oMf[fid].actInv(goal)).vector

    for _ in range(seeds):
        q = np.array(q_fixed, dtype=float)
        q[cols] = rng.uniform(-np.pi, np.pi, len(cols))
        e, lam = error(q), 1e-2
        for _ in range(steps):
            if e @ e < tolerance ** 2:
                break
            J = ref._fold_columns(np.asarray(pin.computeFrameJacobian(pm, d, ref.to_pinocchio_q(q), fid,
                                                                       pin.ReferenceFrame.LOCAL)))[:, cols]
            dq = np.linalg.solve(J.T @ J + lam * np.eye(len(cols)), J.T @ e)
            trial = q.copy()
            trial[cols] += dq
            e2 = error(trial)
            if e2 @ e2 < e @ e:
                q, e, lam = trial, e2, max(lam / 4, 1e-12)
            else:
                lam = min(lam * 8, 1e6)
        if e @ e >= tolerance ** 2:
            continue
        q[cols] = np.mod(q[cols] + np.pi, 2 * np.pi) - np.pi
        if not any(np.abs(np.angle(np.exp(1j * (q[cols] - x[cols])))).max() < 1e-6 for x in found):
            found.append(q)
    return np.array(found).reshape(-1, len(q_fixed))
