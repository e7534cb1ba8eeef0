"""Self-collision checks and distances: coal's narrow phase, placed by our batched FK (the only module that imports coal).

A :class:`CollisionModel` is built once per collision geometry
(:func:`kinematics.io.collision_geometry.collision_geometry`): every shape becomes a coal
object (primitives as coal's ``Box``, ``Sphere``, ``Cylinder``, ``Capsule``; meshes as
``BVHModelOBBRSS`` -- catalogue files through coal's own loader, as Pinocchio reads them; an
archive's bytes through ``trimesh``, handed over as vertices and triangles) with a bounding
sphere in its link frame, and every link with geometry gets a sphere enclosing its shapes.

:meth:`CollisionModel.check` then, for a batch ``Q`` (N, nq):

1. places every link with :meth:`compile_model(model).fk <kinematics.engine.poe.PoEModel.fk>`
   (one batched call);
2. broad phase: a pair of links whose bounding spheres are farther apart than ``margin`` cannot
   touch and is skipped (vectorised over the batch and the pairs);
3. narrow phase: ``coal.collide`` on the shape pairs that remain (shape spheres first), with
   ``security_margin = margin`` -- closer than ``margin`` counts as colliding, as in Pinocchio.

With ``distance=True`` each configuration also gets the minimum distance over the checked pairs
(``coal.distance``, signed: negative is penetration depth where coal computes it), the pair that
achieves it and its witness points (world frame). Pairs are visited by their spheres' lower
bound and the search stops once that bound exceeds the best distance found, so the minimum is
exact and most pairs are never measured.

>>> import numpy as np
>>> from kinematics.io.urdf import parse_urdf
>>> from kinematics.io.collision_geometry import collision_geometry
>>> m = parse_urdf('''<robot name="two"><link name="a"><collision><geometry><sphere radius="0.1"/></geometry>
...   </collision></link><link name="b"><collision><geometry><sphere radius="0.2"/></geometry></collision></link>
...   <joint name="x" type="prismatic"><parent link="a"/><child link="b"/><axis xyz="1 0 0"/>
...   <limit lower="0" upper="2" effort="1" velocity="1"/></joint></robot>''')
>>> cm = CollisionModel(m, collision_geometry(m))
>>> r = cm.check(np.array([[0.25], [1.0]]), distance=True)
>>> r.colliding.tolist(), r.pairs, np.round(r.min_distance, 12).tolist()
([True, False], [[('a', 'b')], []], [-0.05, 0.7])
"""

from __future__ import annotations

import io
import threading
import weakref
from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np

try:
    import coal
except ImportError:  # the `collision` extra (coal comes with pin); refused where a collision model is built
    coal = None

from ..engine import cancel
from ..engine.poe import compile_model
from ..errors import CollisionError, MissingExtraError
from ..io.collision_geometry import MAX_MESH_TRIANGLES, MAX_MODEL_TRIANGLES, CollisionGeometry, Shape
from ..model.robot import RobotModel

#: the broad phase's slack (m): spheres this much apart still go to the narrow phase (round-off)
BROAD_PHASE_SLACK = 1e-9
#: the hull filter's slack (m): hulls closer than margin + this go on to the meshes (GJK's tolerance)
HULL_SLACK = 1e-4
#: the most shape pairs one check looks at, and the most (configuration, shape pair) values of one chunk
MAX_SHAPE_PAIRS = 2_000_000
MAX_CHUNK_VALUES = 8_000_000


class CollisionGeometryError(CollisionError):
    """A collision shape could not be built (e.g. a mesh over the triangle caps)."""


class CollisionPairError(CollisionError):
    """A collision pair names a link without collision geometry, or one link twice."""


@dataclass(frozen=True)
class CollisionResult:
    """The answer for a batch of N configurations.

    Attributes:
        colliding: (N,) bool.
        pairs: per configuration, the link pairs in collision (``(a, b)`` in ``links`` order).
        min_distance: (N,) the minimum distance over the checked pairs (m; inf when no pair is
            checked), or None without ``distance``.
        closest: per configuration, the pair achieving it (or None), or None without ``distance``.
        points: (N, 2, 3) its witness points in the world (root) frame, NaN where none, or None.
    """

    colliding: np.ndarray
    pairs: list[list[tuple[str, str]]]
    min_distance: np.ndarray | None = None
    closest: list[tuple[str, str] | None] | None = None
    points: np.ndarray | None = None


_mesh_cache: dict[tuple, tuple[object, np.ndarray]] = {}
_mesh_lock = threading.Lock()


def _bvh(vertices: np.ndarray, triangles: np.ndarray):
    m = coal.BVHModelOBBRSS()
    m.beginModel(len(triangles), len(vertices))
    m.addVertices(np.ascontiguousarray(vertices, dtype=float))
    m.addTriangles(np.ascontiguousarray(triangles, dtype=np.int64))
    m.endModel()
    return m


def _triangles_at_least(data: bytes, fmt: str) -> int:
    """A lower bound of the triangles of a mesh file, read from its bytes without parsing it (0 when
    the format does not say): a binary STL's count, an ASCII STL's facets, an OBJ's face lines (a
    polygon is one or more triangles), a PLY's face element, a COLLADA file's triangle counts."""
    import re

    if fmt == "stl":
        if data[:5].lower() == b"solid" and b"facet" in data[:4096]:
            return data.count(b"facet normal")
        return int.from_bytes(data[80:84], "little") if len(data) >= 84 else 0
    if fmt == "obj":
        return data.count(b"\nf ") + data.count(b"\nf\t") + int(data[:2] in (b"f ", b"f\t"))
    if fmt == "ply":
        m = re.search(rb"element\s+face\s+(\d+)", data[:65536])
        return int(m.group(1)) if m else 0
    if fmt == "dae":
        return sum(int(c) for c in re.findall(rb"<(?:triangles|polylist|polygons)[^>]*?count=\"(\d{1,12})\"", data))
    return 0


def _mesh_from_bytes(shape: Shape):
    """vertices (scaled) and triangles of an archive's mesh, read with trimesh from memory only."""
    import trimesh  # heavy import, kept local

    data = shape.data or b""
    counted = _triangles_at_least(data, shape.format)  # from the bytes: a huge mesh is refused before parsing
    if counted > MAX_MESH_TRIANGLES:
        raise CollisionGeometryError(f"mesh {shape.source!r} has at least {counted} triangles; "
                                     f"the limit is {MAX_MESH_TRIANGLES}")
    if shape.format == "dae":  # XML: refuse DTDs and entities before any other parser sees it
        import defusedxml.ElementTree as DET

        try:
            DET.fromstring(data)
        except Exception as exc:  # noqa: BLE001 - defusedxml raises several kinds
            raise CollisionGeometryError(f"mesh {shape.source!r} is not safe, well-formed XML: {exc}") from None
    try:
        mesh = trimesh.load(io.BytesIO(data), file_type=shape.format, force="mesh", process=False,
                            resolver=None, skip_materials=True)
    except Exception as exc:  # noqa: BLE001 - trimesh raises whatever its readers raise
        raise CollisionGeometryError(f"mesh {shape.source!r} could not be read: {type(exc).__name__}: {exc}") from None
    V = np.asarray(getattr(mesh, "vertices", np.zeros((0, 3))), dtype=float)
    F = np.asarray(getattr(mesh, "faces", np.zeros((0, 3))), dtype=np.int64)
    if len(F) > MAX_MESH_TRIANGLES:
        raise CollisionGeometryError(f"mesh {shape.source!r} has {len(F)} triangles; the limit is {MAX_MESH_TRIANGLES}")
    if len(F) == 0 or not np.all(np.isfinite(V)):
        raise CollisionGeometryError(f"mesh {shape.source!r} has no triangles or non-finite vertices")
    return V * np.asarray(shape.size, dtype=float), F


def _mesh(shape: Shape):
    """(coal BVH, its vertices in the shape frame) of a mesh shape (catalogue files cached by path and scale)."""
    if shape.path is not None:
        key = (str(shape.path), tuple(shape.size))
        with _mesh_lock:
            hit = _mesh_cache.get(key)
        if hit is None:
            try:
                bvh = coal.MeshLoader().load(str(shape.path), np.asarray(shape.size, dtype=float))
            except Exception as exc:  # noqa: BLE001 - assimp's errors
                raise CollisionGeometryError(f"mesh {shape.source!r} could not be read: {exc}") from None
            if bvh.num_tris > MAX_MESH_TRIANGLES:
                raise CollisionGeometryError(f"mesh {shape.source!r} has {bvh.num_tris} triangles; "
                                             f"the limit is {MAX_MESH_TRIANGLES}")
            V = np.array(bvh.vertices(), dtype=float).reshape(-1, 3)
            hit = (bvh, V, _hull(V))
            with _mesh_lock:
                _mesh_cache[key] = hit
        return hit
    V, F = _mesh_from_bytes(shape)
    bvh = _bvh(V, F)
    return bvh, V, _hull(V)


def _hull(vertices: np.ndarray):
    """The mesh's convex hull (coal ``Convex``, qhull): it holds every triangle, so hulls apart by
    more than the margin prove the meshes are; None when qhull cannot make one (a flat mesh)."""
    points = coal.StdVec_Vec3s()
    for p in np.unique(vertices, axis=0):
        points.append(p)
    try:
        return coal.Convex.convexHull(points, False, None)
    except Exception:  # noqa: BLE001 - qhull refuses degenerate input
        return None


def _coal_shape(shape: Shape):
    """(coal geometry, its convex bound (a mesh's hull; a primitive itself), the centre (3,) of its
    bounding box and sphere in the shape frame, the sphere's radius, the box's half extents (3,),
    triangles) of one shape."""
    s = shape.size
    z = np.zeros(3)
    if shape.kind == "box":
        obj = coal.Box(*s)
        return obj, obj, z, 0.5 * float(np.linalg.norm(s)), (np.eye(4), 0.5 * np.array(s, dtype=float)), 0
    if shape.kind == "sphere":
        obj = coal.Sphere(s[0])
        return obj, obj, z, s[0], (np.eye(4), np.full(3, s[0])), 0
    if shape.kind == "cylinder":
        obj = coal.Cylinder(s[0], s[1])
        return obj, obj, z, float(np.hypot(s[0], 0.5 * s[1])), (np.eye(4), np.array([s[0], s[0], 0.5 * s[1]])), 0
    if shape.kind == "capsule":
        obj = coal.Capsule(s[0], s[1])
        return obj, obj, z, s[0] + 0.5 * s[1], (np.eye(4), np.array([s[0], s[0], s[0] + 0.5 * s[1]])), 0
    bvh, V, hull = _mesh(shape)
    lo, hi = V.min(axis=0), V.max(axis=0)
    c = 0.5 * (lo + hi)
    return bvh, hull, c, float(np.sqrt(((V - c) ** 2).sum(axis=1).max())), _box(V), int(bvh.num_tris)


def _box(V: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A box holding the points ``V``: (``T_shape_box`` 4x4, half extents (3,)); the smaller of the
    axis-aligned box and the box on the principal axes."""
    best = None
    axes = [np.eye(3)]
    if len(V) > 3:
        axes.append(np.linalg.svd(V - V.mean(axis=0), full_matrices=False)[2].T)
    for R in axes:
        if np.linalg.det(R) < 0:
            R = R * np.array([1.0, 1.0, -1.0])
        L = V @ R
        lo, hi = L.min(axis=0), L.max(axis=0)
        volume = float(np.prod(hi - lo))
        if best is None or volume < best[0]:
            T = np.eye(4)
            T[:3, :3] = R
            T[:3, 3] = R @ (0.5 * (lo + hi))
            best = (volume, T, 0.5 * (hi - lo))
    return best[1], best[2]


def _boxes_overlap(Wa, ha, Wb, hb) -> np.ndarray:
    """(K,) False where box a (half extents ``ha``, centred on and aligned with the frame ``Wa``
    (K, 4, 4)) and box b are certainly apart: the separating-axis test of two oriented boxes
    (15 axes, Gottschalk et al.), vectorised; True where they may touch."""
    Ra, Rb = Wa[:, :3, :3], Wb[:, :3, :3]
    wa, wb = Wa[:, :3, 3], Wb[:, :3, 3]
    R = Ra.transpose(0, 2, 1) @ Rb  # b's axes in a's frame
    t = np.einsum("kji,kj->ki", Ra, wb - wa)  # b's centre in a's frame
    absR = np.abs(R) + 1e-12
    apart = np.any(np.abs(t) > ha + (absR @ hb[:, :, None])[..., 0], axis=1)
    apart |= np.any(np.abs((t[:, None, :] @ R)[:, 0]) > (ha[:, None, :] @ absR)[:, 0] + hb, axis=1)
    for i in range(3):
        i1, i2 = (i + 1) % 3, (i + 2) % 3
        for j in range(3):
            j1, j2 = (j + 1) % 3, (j + 2) % 3
            lhs = np.abs(t[:, i2] * R[:, i1, j] - t[:, i1] * R[:, i2, j])
            rhs = (ha[:, i1] * absR[:, i2, j] + ha[:, i2] * absR[:, i1, j]
                   + hb[:, j1] * absR[:, i, j2] + hb[:, j2] * absR[:, i, j1])
            apart |= lhs > rhs
    return ~apart


@dataclass
class _NarrowPhase:
    """What one :meth:`CollisionModel.check` call's narrow phase keeps from chunk to chunk: the link
    pairs ``P`` (P, 2), coal's requests (``creq`` on the shapes, ``hreq`` on their hulls), the
    collision functors made so far per shape pair (``functors``), the two transforms it hands to coal
    (shape a's frame is the identity ``tf_id``, shape b is placed by ``tf_b``), and the answers it
    writes: ``colliding`` (N,) and ``hits`` (the colliding link pairs of each configuration)."""

    P: np.ndarray
    stop_at_first: bool
    creq: object
    hreq: object
    colliding: np.ndarray
    hits: list
    functors: dict
    tf_id: object
    tf_b: object


class CollisionModel:
    """coal objects of one model's collision geometry, with bounding spheres (immutable; share it
    between threads: every call makes its own transforms and requests).

    ``links``: the links with geometry (``model.links`` order); ``warnings``: the geometry's, plus
    shapes that could not be built (left out)."""

    def __init__(self, model: RobotModel, geometry: CollisionGeometry):
        self.model = model
        self.geometry = geometry
        warnings = list(geometry.warnings)
        per_link: dict[str, list[tuple]] = {}
        triangles = 0
        for link, shapes in geometry.shapes.items():
            for shape in shapes:
                try:
                    obj, bound, c, r, (box, half), nt = _coal_shape(shape)
                except CollisionGeometryError as exc:
                    warnings.append(f"link {link!r}: {exc}; the shape is left out")
                    continue
                triangles += nt
                if triangles > MAX_MODEL_TRIANGLES:
                    warnings.append(f"link {link!r}: the model's meshes pass {MAX_MODEL_TRIANGLES} triangles; "
                                    f"mesh {shape.source!r} and the rest are left out")
                    triangles -= nt
                    continue
                centre = shape.origin[:3, :3] @ c + shape.origin[:3, 3]
                per_link.setdefault(link, []).append((obj, np.array(shape.origin, dtype=float), centre, float(r), bound, c, half, box))
        self.links: tuple[str, ...] = tuple(l for l in geometry.shapes if l in per_link)
        self.warnings: tuple[str, ...] = tuple(warnings)
        self.link_index = {name: i for i, name in enumerate(self.links)}
        self.shapes: list[list[tuple]] = [per_link[l] for l in self.links]
        # a sphere per link enclosing its shapes' spheres (centre: the mean of theirs)
        centres = np.zeros((len(self.links), 3))
        radii = np.zeros(len(self.links))
        for i, shapes in enumerate(self.shapes):
            cs = np.array([s[2] for s in shapes])
            c = cs.mean(axis=0)
            centres[i] = c
            radii[i] = max(float(np.linalg.norm(s[2] - c)) + s[3] for s in shapes)
        self.centres, self.radii = centres, radii
        # every shape flattened: its link, T_link_shape, sphere centre (link frame) and radius
        flat = [(li, sh) for li, shapes in enumerate(self.shapes) for sh in shapes]
        self._objects = [sh[0] for _, sh in flat]
        #: a cheap exact filter per shape: a mesh's convex hull (None: none), a primitive is its own
        self._bounds = [sh[4] if sh[4] is not sh[0] else None for _, sh in flat]
        self._shape_link = np.array([li for li, _ in flat], dtype=np.intp)
        self._origins = np.array([sh[1] for _, sh in flat]).reshape(-1, 4, 4)
        self._centres = np.array([sh[5] for _, sh in flat], dtype=float).reshape(-1, 3)  # in the shape frame
        self._half = np.array([sh[6] for _, sh in flat], dtype=float).reshape(-1, 3)  # box half extents
        self._box = np.array([sh[7] for _, sh in flat], dtype=float).reshape(-1, 4, 4)  # T_shape_box
        self._radii = np.array([sh[3] for _, sh in flat])
        self._link_shapes = [[] for _ in self.links]
        for s_idx, (li, _) in enumerate(flat):
            self._link_shapes[li].append(s_idx)
        self._fk = compile_model(model)

    # -- pairs ------------------------------------------------------------------------------
    def all_pairs(self) -> list[tuple[str, str]]:
        """Every pair of links with geometry, ``links`` order (CollisionError past :data:`MAX_SHAPE_PAIRS`)."""
        n = len(self.links) * (len(self.links) - 1) // 2
        if n > MAX_SHAPE_PAIRS:
            raise CollisionError(f"{len(self.links)} links with collision geometry make {n} pairs; the limit is "
                                 f"{MAX_SHAPE_PAIRS}")
        return [(a, b) for i, a in enumerate(self.links) for b in self.links[i + 1:]]

    def pair_indices(self, pairs: Sequence[tuple[str, str]]) -> np.ndarray:
        """(P, 2) indices into ``links`` of named pairs (each ordered as in ``links``); a name
        without geometry, or a pair of one link, raises :class:`CollisionPairError`."""
        out = []
        for a, b in pairs:
            for name in (a, b):
                if name not in self.link_index:
                    raise CollisionPairError(f"link {name!r} has no collision geometry (links with geometry: "
                                             f"{', '.join(self.links[:8])}{' ...' if len(self.links) > 8 else ''})")
            i, j = self.link_index[a], self.link_index[b]
            if i == j:
                raise CollisionPairError(f"the pair ({a!r}, {b!r}) names one link twice")
            out.append((min(i, j), max(i, j)))
        return np.array(out, dtype=np.intp).reshape(-1, 2)

    # -- the check ----------------------------------------------------------------------------
    def link_poses(self, Q: np.ndarray) -> np.ndarray:
        """(N, L, 4, 4) ``T_root_link`` of the links with geometry (our batched FK)."""
        return self._fk.fk(np.ascontiguousarray(Q, dtype=float), list(self.links))

    def _shape_pairs(self, P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(K, 2) global shape indices of every shape pair of the link pairs ``P``, and (K,) the pair of each."""
        sp, owner = [], []
        for k, (i, j) in enumerate(P):
            for a in self._link_shapes[i]:
                for b in self._link_shapes[j]:
                    sp.append((a, b))
                    owner.append(k)
        return np.array(sp, dtype=np.intp).reshape(-1, 2), np.array(owner, dtype=np.intp)

    def _narrow_phase(self, call: _NarrowPhase, start: int, R_ab, p_ab, cn, K, cq, A, B) -> None:
        """coal on the candidates of one chunk (configurations from ``start``): shape ``B[c]`` placed at
        ``(R_ab[c], p_ab[c])`` in shape ``A[c]``'s frame, configuration ``start + cn[c]``, link pair
        ``K[c]``, shape pair ``cq[c]``; the hulls first where a shape has one, the shapes themselves if
        they touch."""
        objs, bounds, links = self._objects, self._bounds, self.links
        narrow, creq, hreq, tf_id, tf_b = call.functors, call.creq, call.hreq, call.tf_id, call.tf_b
        colliding, hits, stop_at_first, P = call.colliding, call.hits, call.stop_at_first, call.P
        nP = len(P)
        done = bytearray((max(cn, default=-1) + 1) * nP)  # (row, link pair) found colliding
        res = coal.CollisionResult()
        fresh = True  # coal adds contacts to a result and stops once it holds num_max_contacts: clear after a hit
        for r, t, n, k, q, a, b in zip(R_ab, p_ab, cn, K, cq, A, B):
            if done[n * nP + k] or (stop_at_first and colliding[start + n]):
                continue
            fns = narrow.get(q)
            if fns is None:
                ba, bb = bounds[a], bounds[b]
                hull = (None if ba is None and bb is None
                        else coal.ComputeCollision(objs[a] if ba is None else ba, objs[b] if bb is None else bb))
                fns = narrow[q] = (hull, coal.ComputeCollision(objs[a], objs[b]))
            tf_b.setRotation(r)
            tf_b.setTranslation(t)
            if fns[0] is not None:  # hulls apart: the meshes inside them are too
                if not fresh:
                    res.clear()
                fresh = not fns[0](tf_id, tf_b, hreq, res)
                if fresh:
                    continue
                res.clear()
            elif not fresh:
                res.clear()
            fresh = not fns[1](tf_id, tf_b, creq, res)
            if not fresh:
                done[n * nP + k] = 1
                colliding[start + n] = True
                i, j = P[k]
                hits[start + n].append((links[i], links[j]))

    def check(self, Q, pairs: Sequence[tuple[str, str]] | np.ndarray | None = None, *, margin: float = 0.0,
              distance: bool = False, stop_at_first: bool = False,
              progress: Callable[[int], None] | None = None, chunk: int = 8192) -> CollisionResult:
        """Check every configuration of ``Q`` (N, nq) on ``pairs`` (names, or (P, 2) indices into
        ``links``; None: every pair). ``margin`` (m, >= 0): closer counts as colliding.
        ``stop_at_first``: stop a configuration at the first colliding pair found (``pairs`` then
        lists only it; pairs are visited pair by pair over the batch, not in ``links`` order). ``progress(k)`` is called after every ``chunk`` configurations with the count done."""
        Q = np.atleast_2d(np.asarray(Q, dtype=float))
        if not (np.isfinite(margin) and margin >= 0):
            raise CollisionError(f"margin must be a finite distance >= 0 m, got {margin!r}")
        P = (self.pair_indices(self.all_pairs()) if pairs is None
             else np.asarray(pairs, dtype=np.intp).reshape(-1, 2) if isinstance(pairs, np.ndarray)
             else self.pair_indices(pairs))
        n_shape_pairs = sum(len(self._link_shapes[i]) * len(self._link_shapes[j]) for i, j in P)
        if n_shape_pairs > MAX_SHAPE_PAIRS:
            raise CollisionError(f"{n_shape_pairs} shape pairs to check ({len(P)} link pairs); the limit is "
                                 f"{MAX_SHAPE_PAIRS}: disable pairs, or merge a link's shapes")
        SP, owner = self._shape_pairs(P)
        chunk = max(1, min(int(chunk), MAX_CHUNK_VALUES // max(len(SP), 1)))  # bounds the (chunk, pairs) arrays
        N = len(Q)
        colliding = np.zeros(N, dtype=bool)
        hits: list[list[tuple[str, str]]] = [[] for _ in range(N)]
        dmin = np.full(N, np.inf) if distance else None
        closest: list | None = [None] * N if distance else None
        points = np.full((N, 2, 3), np.nan) if distance else None
        creq = coal.CollisionRequest()
        creq.security_margin = float(margin)
        creq.enable_contact = False
        creq.num_max_contacts = 1
        # the hull filter: GJK alone (no contacts) on the hulls, with HULL_SLACK added to the margin:
        # GJK's tolerance can call hulls that touch to ~1e-5 m apart, so only hulls apart by more
        # than the slack are taken as a proof that the meshes inside them are
        hreq = coal.CollisionRequest()
        hreq.security_margin = float(margin) + HULL_SLACK
        hreq.enable_contact = False
        hreq.num_max_contacts = 1
        dreq = coal.DistanceRequest()
        tf_a, tf_b = coal.Transform3s(), coal.Transform3s()
        tf_id = coal.Transform3s()  # the narrow phase places shape b in shape a's frame
        cres, dres = coal.CollisionResult(), coal.DistanceResult()
        # per shape pair: coal's collision functors (this call's own)
        call = _NarrowPhase(P, stop_at_first, creq, hreq, colliding, hits, {}, tf_id, tf_b)
        reach = float(margin) + BROAD_PHASE_SLACK
        objs, bounds = self._objects, self._bounds
        links = self.links
        for start in range(0, N, chunk):
            cancel.check()  # a cancelled or timed-out request stops here (kinematics.engine.cancel)
            T = self.link_poses(Q[start:start + chunk])
            n_rows = len(T)
            W = T[:, self._shape_link] @ self._origins  # (n, S, 4, 4) shapes in the world (matmul: einsum's 4x time)
            C = (W[:, :, :3, :3] @ self._centres[:, :, None])[..., 0] + W[:, :, :3, 3]
            if len(SP):
                gap = np.linalg.norm(C[:, SP[:, 0]] - C[:, SP[:, 1]], axis=2) - self._radii[SP[:, 0]] - self._radii[SP[:, 1]]
            else:
                gap = np.zeros((n_rows, 0))
            cq, cn = np.nonzero(gap.T <= reach)  # pair by pair: one pair's meshes stay in the caches
            if len(cn):
                A, B = SP[cq, 0], SP[cq, 1]
                Wa, Wb = W[cn, A], W[cn, B]
                keep = _boxes_overlap(Wa @ self._box[A], self._half[A] + reach, Wb @ self._box[B], self._half[B])
                cn, cq, A, B, Wa, Wb = cn[keep], cq[keep], A[keep], B[keep], Wa[keep], Wb[keep]
                # T_a_b = T_world_a^-1 T_world_b: one transform to hand over per call
                Ra = Wa[:, :3, :3]
                R_ab = list(Ra.transpose(0, 2, 1) @ Wb[:, :3, :3])
                p_ab = list(np.einsum("kji,kj->ki", Ra, Wb[:, :3, 3] - Wa[:, :3, 3]))
                self._narrow_phase(call, start, R_ab, p_ab, cn.tolist(), owner[cq].tolist(), cq.tolist(), A.tolist(),
                                   B.tolist())
            if distance and len(SP):
                for n in range(n_rows):
                    order = np.argsort(gap[n], kind="stable")
                    best, best_q, best_pts = np.inf, -1, None
                    for q in order:
                        if gap[n, q] > best:
                            break
                        a, b = SP[q]
                        Ma, Mb = W[n, a], W[n, b]
                        tf_a.setRotation(Ma[:3, :3])
                        tf_a.setTranslation(Ma[:3, 3])
                        tf_b.setRotation(Mb[:3, :3])
                        tf_b.setTranslation(Mb[:3, 3])
                        ba, bb = bounds[a], bounds[b]
                        if ba is not None or bb is not None:  # the hulls' distance is a lower bound
                            dres.clear()
                            if coal.distance(objs[a] if ba is None else ba, tf_a, objs[b] if bb is None else bb, tf_b,
                                             dreq, dres) > best:
                                continue
                        dres.clear()
                        d = coal.distance(objs[a], tf_a, objs[b], tf_b, dreq, dres)
                        if d < best:
                            best, best_q = d, q
                            best_pts = (np.array(dres.getNearestPoint1(), dtype=float),
                                        np.array(dres.getNearestPoint2(), dtype=float))
                    dmin[start + n] = best
                    if best_q >= 0:
                        i, j = P[owner[best_q]]
                        closest[start + n] = (links[i], links[j])
                        points[start + n, 0], points[start + n, 1] = best_pts
            if progress is not None:
                progress(min(start + chunk, N))
        for row in hits:  # a pair's order in links, the pairs in the order given
            if len(row) > 1:
                row.sort(key=lambda ab: (self.link_index[ab[0]], self.link_index[ab[1]]))
        return CollisionResult(colliding, hits, dmin, closest, points)


_models: "weakref.WeakKeyDictionary[CollisionGeometry, CollisionModel]" = weakref.WeakKeyDictionary()
_models_lock = threading.Lock()


def collision_model(model: RobotModel, geometry: CollisionGeometry) -> CollisionModel:
    """The :class:`CollisionModel` of ``geometry`` (built once per geometry object, then shared)."""
    if coal is None:
        raise MissingExtraError.of("collision", "self-collision", "coal")
    with _models_lock:
        cm = _models.get(geometry)
    if cm is None:
        cm = CollisionModel(model, geometry)
        with _models_lock:
            cm = _models.setdefault(geometry, cm)
    return cm
