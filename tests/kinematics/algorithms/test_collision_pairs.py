"""UserPairs on an allowed-collision matrix: allow (reason user), forbid (checked, listed as forced),
the order of a model's settings and a request's, names checked, the SRDF."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
import pytest

from kinematics import UserPairs, collision
from kinematics.algorithms.collision_matrix import CollisionMatrix
from kinematics.errors import CollisionError

LINKS = ("a", "b", "c", "d")
MATRIX = CollisionMatrix(LINKS, {("a", "b"): "adjacent", ("a", "c"): "never"}, 100)


def test_allow_disables_and_forbid_enables():
    m = MATRIX.with_pairs(UserPairs(allow=[("d", "b")], forbid=[("c", "a"), ("b", "c")]))
    assert m.disabled == {("a", "b"): "adjacent", ("b", "d"): "user"}
    assert m.forced == (("a", "c"),)  # (b, c) was checked already: nothing to force
    assert m.enabled() == [("a", "c"), ("a", "d"), ("b", "c"), ("c", "d")]
    assert m.as_dict()["enabled"] == [{"links": ["a", "c"], "reason": "user"}]
    doc = ET.fromstring(m.to_srdf("r"))
    assert [(e.get("link1"), e.get("link2"), e.get("reason")) for e in doc.iter("enable_collisions")] == [
        ("a", "c", "User")]
    assert ("b", "d", "User") in [(e.get("link1"), e.get("link2"), e.get("reason")) for e in doc.iter("disable_collisions")]
    # an allowed pair already disabled keeps its reason; allowing a forced pair again disables it
    again = m.with_pairs(UserPairs(allow=[("a", "b"), ("a", "c")]))
    assert again.disabled[("a", "b")] == "adjacent" and again.disabled[("a", "c")] == "user" and again.forced == ()
    assert MATRIX.with_pairs(None) is MATRIX and MATRIX.with_pairs(UserPairs()) is MATRIX


def test_a_request_over_a_model_s_settings():
    model = UserPairs(allow=[("a", "d"), ("b", "c")], forbid=[("a", "c")])
    request = UserPairs(forbid=[("d", "a")], allow=[("c", "a")])
    both = model.then(request)
    assert both == UserPairs(allow=[("b", "c"), ("c", "a")], forbid=[("d", "a")])
    m = MATRIX.with_pairs(both)
    assert ("a", "d") in m.enabled() and m.disabled[("a", "c")] == "never" and m.disabled[("b", "c")] == "user"
    assert model.then(None) is model


@pytest.mark.parametrize("pairs, said", [
    (UserPairs(allow=[("a", "x")]), "link 'x' has no collision geometry"),
    (UserPairs(forbid=[("b", "b")]), "names one link twice"),
])
def test_bad_names_are_refused(pairs, said):
    with pytest.raises(CollisionError, match=said):
        MATRIX.with_pairs(pairs)
    with pytest.raises(CollisionError, match="unknown link 'x'; did you mean 'xy'"):
        MATRIX.with_pairs(UserPairs(allow=[("a", "x")]), model_links=("a", "b", "c", "d", "xy"))


@pytest.mark.parametrize("kwargs, said", [
    ({"allow": [("a", "b")], "forbid": [("b", "a")]}, "both allowed and forbidden"),
    ({"allow": [("a",)]}, "a pair names two links"),
    ({"forbid": ["ab"]}, "a pair names two links"),
])
def test_bad_pairs_are_refused(kwargs, said):
    with pytest.raises(CollisionError, match=said):
        UserPairs(**kwargs)


def test_the_use_case_checks_what_the_query_sets(catalogue):
    ur5 = catalogue.get("ur5")
    q = [-3.58, 1.75, 1.92, 5.83, -4.39, -0.22]  # (base_link, upper_arm_link) in collision
    plain = collision(ur5, [q], samples=300)
    assert ("base_link", "upper_arm_link") in plain.pairs[0]
    allowed = collision(ur5, [q], samples=300, collision_pairs={"allow": [("base_link", "upper_arm_link")]})
    assert allowed.pairs[0] == [p for p in plain.pairs[0] if p != ("base_link", "upper_arm_link")]
    assert len(allowed.checked) == len(plain.checked) - 1
    forced = collision(ur5, [q], samples=300, collision_pairs=UserPairs(forbid=[("wrist_1_link", "forearm_link")]))
    assert ("forearm_link", "wrist_1_link") in forced.checked and len(forced.checked) == len(plain.checked) + 1
    with pytest.raises(CollisionError, match="unknown link 'nope'"):
        collision(ur5, [q], samples=300, collision_pairs={"forbid": [("nope", "base_link")]})
    free = np.asarray(collision(ur5, [q], samples=300, collision_pairs={"allow": plain.pairs[0]}).colliding)
    assert not free.any()
