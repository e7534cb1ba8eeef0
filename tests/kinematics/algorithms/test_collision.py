"""Self-collision: closed-form distances of primitives, margins, batches, the allowed-collision
matrix's reasons against sampling, its cache and SRDF."""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from kinematics import api
from kinematics.algorithms.collision import CollisionModel
from kinematics.algorithms.collision_matrix import adjacent_pairs, collision_matrix, compute_matrix
from kinematics.errors import CollisionError, KinematicsError
from kinematics.io.collision_geometry import collision_geometry
from kinematics.io.urdf import parse_urdf


def _slider(shape_a: str, shape_b: str, origin_b: str = "0 0 0") -> CollisionModel:
    """Link a fixed at the origin; link b slides along x (q = its offset)."""
    m = parse_urdf(f"""<robot name="s">
      <link name="a"><collision><geometry>{shape_a}</geometry></collision></link>
      <link name="b"><collision><origin xyz="{origin_b}"/><geometry>{shape_b}</geometry></collision></link>
      <joint name="x" type="prismatic"><parent link="a"/><child link="b"/><axis xyz="1 0 0"/>
        <limit lower="-5" upper="5" effort="1" velocity="1"/></joint></robot>""")
    return CollisionModel(m, collision_geometry(m))


def test_sphere_sphere_distance_is_closed_form():
    cm = _slider('<sphere radius="0.1"/>', '<sphere radius="0.25"/>')
    x = np.linspace(-2, 2, 41)
    r = cm.check(x[:, None], distance=True)
    expected = np.abs(x) - 0.35
    np.testing.assert_allclose(r.min_distance, expected, atol=1e-9)
    assert r.colliding.tolist() == (expected < 0).tolist()
    # witness points on the centre line, on each sphere's surface
    k = 30  # x = 1.0
    np.testing.assert_allclose(r.points[k], [[0.1, 0, 0], [0.75, 0, 0]], atol=1e-9)
    assert r.closest[k] == ("a", "b")


def test_box_sphere_distance_is_closed_form():
    cm = _slider('<box size="0.2 0.4 0.6"/>', '<sphere radius="0.05"/>', origin_b="0 0.5 0.8")
    rng = np.random.default_rng(3)
    x = rng.uniform(-1, 1, 50)
    centre = np.stack([x, np.full_like(x, 0.5), np.full_like(x, 0.8)], axis=1)
    outside = np.maximum(np.abs(centre) - [0.1, 0.2, 0.3], 0.0)
    expected = np.linalg.norm(outside, axis=1) - 0.05
    r = cm.check(x[:, None], distance=True)
    np.testing.assert_allclose(r.min_distance, expected, atol=1e-9)


def test_cylinder_and_capsule():
    cm = _slider('<cylinder radius="0.1" length="1.0"/>', '<capsule radius="0.05" length="0.4"/>')
    r = cm.check([[0.5], [0.1501], [0.149]], distance=True)  # parallel axes (both z), apart by x
    np.testing.assert_allclose(r.min_distance[:2], [0.35, 0.0001], atol=1e-9)
    assert r.colliding.tolist() == [False, False, True]


def test_margin_counts_closer_as_colliding():
    cm = _slider('<sphere radius="0.1"/>', '<sphere radius="0.1"/>')
    Q = [[0.25], [0.35]]  # 0.05 m and 0.15 m apart
    assert cm.check(Q).colliding.tolist() == [False, False]
    assert cm.check(Q, margin=0.1).colliding.tolist() == [True, False]
    with pytest.raises(CollisionError):
        cm.check(Q, margin=-1.0)


def test_a_batch_equals_its_rows_one_by_one(catalogue):
    model = catalogue.get("panda")
    Q = model.sample_configurations(200, np.random.default_rng(7))
    batch = api.collision(model, Q.tolist(), distance=True, samples=500)
    for n in range(0, 200, 37):
        one = api.collision(model, Q[n].tolist(), distance=True, samples=500)
        assert not one.is_batch
        assert one.pairs[0] == batch.pairs[n] and one.min_distance[0] == batch.min_distance[n]
    assert batch.is_batch and batch.colliding.any() and not batch.colliding.all()


def test_no_pairs_means_nothing_collides():
    m = parse_urdf('<robot name="one"><link name="a"><collision><geometry><sphere radius="1"/></geometry>'
                   '</collision></link></robot>')
    r = CollisionModel(m, collision_geometry(m)).check(np.zeros((3, 0)), distance=True)
    assert not r.colliding.any() and np.all(np.isinf(r.min_distance)) and r.closest == [None] * 3


CHAIN = """<robot name="chain">
  <link name="base"><collision><geometry><sphere radius="0.2"/></geometry></collision></link>
  <link name="l1"><collision><origin xyz="0 0 0.5"/><geometry><box size="0.05 0.05 0.6"/></geometry></collision></link>
  <link name="bare"/>
  <link name="l2"><collision><origin xyz="0.6 0 0"/><geometry><box size="1.2 0.05 0.05"/></geometry></collision></link>
  <link name="far"><collision><origin xyz="0 0 5"/><geometry><sphere radius="0.1"/></geometry></collision></link>
  <link name="hub"><collision><geometry><sphere radius="0.15"/></geometry></collision></link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="j2" type="fixed"><parent link="l1"/><child link="bare"/><origin xyz="0 0 1"/></joint>
  <joint name="j3" type="revolute"><parent link="bare"/><child link="l2"/><axis xyz="0 1 0"/>
    <limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="j4" type="fixed"><parent link="base"/><child link="far"/></joint>
  <joint name="j5" type="revolute"><parent link="far"/><child link="hub"/><axis xyz="1 0 0"/>
    <limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
</robot>"""


def test_matrix_reasons_against_sampling():
    m = parse_urdf(CHAIN)
    cm = CollisionModel(m, collision_geometry(m))
    assert cm.links == ("base", "l1", "l2", "far", "hub")
    # adjacent: joints' parent and child; l1 and l2 through the geometry-less 'bare'
    assert adjacent_pairs(cm) == {("base", "l1"), ("l1", "l2"), ("base", "far"), ("far", "hub")}
    matrix = compute_matrix(cm, 2000)
    # 'hub' sits on the base's sphere whatever the joints do: always; 'far' is 5 m up: never with l2 ...
    assert matrix.disabled[("base", "hub")] == "always"
    assert matrix.disabled[("l2", "far")] == "never"
    # ... and the reasons are what sampling says, pair by pair
    Q = m.sample_configurations(2000, np.random.default_rng(0), continuous_range=np.pi)
    others = [p for p in cm.all_pairs() if p not in adjacent_pairs(cm)]
    counts = {p: 0 for p in others}
    for row in cm.check(Q, others).pairs:
        for p in row:
            counts[p] += 1
    for p, c in counts.items():
        reason = matrix.disabled.get(p)
        assert reason == ("always" if c == 2000 else "never" if c == 0 else None), (p, c, reason)
    # l2 swings through the base's sphere in some configurations only: checked
    assert ("base", "l2") in matrix.enabled() and 0 < counts[("base", "l2")] < 2000


def test_matrix_is_cached_and_exported(tmp_path):
    m = parse_urdf(CHAIN)
    cm = CollisionModel(m, collision_geometry(m))
    seen = []
    first = collision_matrix(cm, 300, cache_dir=tmp_path, progress=seen.append)
    files = list(tmp_path.glob("collision-matrix-*.json"))
    assert len(files) == 1 and seen[-1] == 300
    stored = json.loads(files[0].read_text())
    assert stored["samples"] == 300
    # a second call reads it back (corrupt the counts to prove it is not recomputed)
    stored["disabled"].append({"links": ["l2", "hub"], "reason": "never"})
    files[0].write_text(json.dumps(stored))
    again = collision_matrix(cm, 300, cache_dir=tmp_path)
    assert again.disabled.get(("l2", "hub")) == "never" and len(again.disabled) == len(first.disabled) + (
        ("l2", "hub") not in first.disabled)
    files[0].write_text("not json")  # unreadable: recomputed, never fatal
    assert collision_matrix(cm, 300, cache_dir=tmp_path).disabled == first.disabled
    user = first.with_user([("l2", "base")])
    assert user.disabled[("base", "l2")] == "user" and ("base", "l2") not in user.enabled()
    with pytest.raises(KinematicsError, match="no collision geometry"):
        first.with_user([("bare", "l2")])
    srdf = ET.fromstring(user.to_srdf("chain"))
    rows = {(e.get("link1"), e.get("link2")): e.get("reason") for e in srdf.iter("disable_collisions")}
    assert rows[("base", "l1")] == "Adjacent" and rows[("base", "hub")] == "Always" and rows[("base", "l2")] == "User"
    assert len(rows) == len(user.disabled)


def test_collision_free_is_the_negated_check(catalogue):
    model = catalogue.get("ur5")
    Q = model.sample_configurations(300, np.random.default_rng(11))
    free = api.collision_free(model, Q)
    assert free.dtype == bool and free.shape == (300,)
    assert (free == ~api.collision(model, Q.tolist()).colliding).all()


def test_a_floating_base_form_shares_the_meshes(catalogue):
    from kinematics import usecases

    model = catalogue.get("panda")
    ready = [0, -0.785, 0, -2.356, 0, 1.571, 0.785, 0.02]
    fixed = usecases.collision(model, [ready], samples=300, distance=True)
    free = usecases.collision(model, [[0, 0, 0, 0, 0, 0, 1] + ready], samples=300, distance=True, floating_base=True)
    assert free.links == fixed.links and free.warnings == ()
    assert free.min_distance[0] == pytest.approx(fixed.min_distance[0], abs=1e-12)


def test_too_many_pairs_is_a_clean_error(monkeypatch):
    from kinematics.algorithms import collision

    m = parse_urdf(CHAIN)
    cm = CollisionModel(m, collision_geometry(m))
    monkeypatch.setattr(collision, "MAX_SHAPE_PAIRS", 5)
    with pytest.raises(CollisionError, match="the limit is 5"):
        cm.all_pairs()
    with pytest.raises(CollisionError, match="the limit is 5"):
        cm.check(np.zeros((1, m.nq)), [("base", "l2")] * 6)
