"""The allocation-free closed forms (kinematics.engine.ik_fast) give exactly the candidates of the
array forms (kinematics.engine.ik_closed): same counts, same flags, the same joint values."""

from __future__ import annotations

import numpy as np
import pytest

from kinematics import compile_model, default_catalogue
from kinematics.algorithms.ik_families import detect, reduce_chain
from kinematics.engine import ik_closed, ik_fast
from kinematics.spatial.transforms import inverse_transform


@pytest.mark.parametrize("model_id, link, locked", [
    ("ur5", "tool0", None), ("puma560_standard", "tool", None), ("stanford_arm", "tool", None),
    ("panda", "panda_link8", {"panda_joint7": 0.3}), ("kuka_lwr4", "tool", {"joint_3": 0.2}),
])
@pytest.mark.parametrize("width", [0.0, 0.05])
def test_tuple_and_array_forms_agree(model_id, link, locked, width):
    model = default_catalogue().get(model_id)
    fam = detect(reduce_chain(model, link, locked))
    ideal = fam.ideal
    Q = model.sample_configurations(300, np.random.default_rng(4))
    for name, value in (locked or {}).items():
        Q[:, model.q_index[name]] = value
    T = compile_model(model).fk(Q, [link])[:, 0]
    T[::7, :3, 3] *= 1.6  # some out of reach: least-squares branch points, spread when width > 0
    targets = inverse_transform(T) if fam.reversed else T
    G = np.ascontiguousarray(np.einsum("nij,jk->nik", targets, inverse_transform(ideal.M)))
    h, r, c = np.ascontiguousarray(ideal.h), np.ascontiguousarray(ideal.r), np.ascontiguousarray(fam.centre)
    out = []
    for mod in (ik_closed, ik_fast):
        Qc = np.zeros((len(G), 16, 6)); count = np.zeros(len(G), np.int64); flag = np.zeros((len(G), 16), np.int64)
        if fam.kernel == "spherical_wrist":
            mod.spherical_wrist(G, h, r, not bool(ideal.revolute[2]), c, fam.position, width, Qc, count, flag)
        else:
            mod.three_parallel(G, h, r, c, width, Qc, count, flag)
        out.append((Qc, count, flag))
    (Qa, ca, fa), (Qb, cb, fb) = out
    np.testing.assert_array_equal(ca, cb)
    assert ca.max() > 0
    for i in range(len(G)):
        np.testing.assert_allclose(Qa[i, :ca[i]], Qb[i, :cb[i]], atol=1e-12)
        np.testing.assert_array_equal(fa[i, :ca[i]], fb[i, :cb[i]])
