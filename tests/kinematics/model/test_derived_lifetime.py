"""Derived values (compiled forms, IK seeds, Pinocchio's view) live as long as their model, and no
longer: a dropped model is freed with them (the weak-key cache that kept every model alive, found by
the soak test, is gone). Copies and pickles derive their own."""

from __future__ import annotations

import copy
import gc
import pickle
import weakref

from kinematics import api, compile_model
from kinematics.io.urdf import parse_urdf
from tests.paths import FIXTURES


def _model():
    return parse_urdf((FIXTURES / "planar_3r.urdf").read_text())


def test_a_dropped_model_is_freed_with_its_compiled_forms():
    model = _model()
    poe = compile_model(model)
    assert compile_model(model) is poe
    pose = api.fk(model, [0.1, 0.2, 0.3]).poses[0, -1]
    api.ik(model, pose, link=model.leaf_links[-1])
    api.jacobian(model, [0.1, 0.2, 0.3], verify=True)  # Pinocchio's view too
    refs = [weakref.ref(model), weakref.ref(poe)]
    del model, poe
    gc.collect()
    assert all(r() is None for r in refs)


def test_copies_and_pickles_derive_their_own():
    model = _model()
    poe = compile_model(model)
    for other in (copy.copy(model), copy.deepcopy(model), pickle.loads(pickle.dumps(model))):
        assert compile_model(other) is not poe and compile_model(other).model is other
    assert compile_model(model) is poe
