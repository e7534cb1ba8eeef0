"""POST /models/{id}/ik with ``verify``: a verification object whatever the strategy (``locked``
joints, ``method: analytic``), each answer's Pinocchio FK against its target."""

from __future__ import annotations

import numpy as np
import pytest

import kinematics


@pytest.mark.parametrize("model_id, link, extra", [
    ("panda", "panda_hand", {"locked": {"panda_joint3": 0.2}}),
    ("ur5", "tool0", {"method": "analytic"}),
])
def test_locked_or_analytic_ik_answers_a_verification(api_client, catalogue, model_id, link, extra):
    model = catalogue.get(model_id)
    q = np.clip(np.random.default_rng(4).uniform(-1.5, 1.5, model.dof), model.lower_limits, model.upper_limits)
    for name, value in extra.get("locked", {}).items():
        q[model.q_index[name]] = value
    T = kinematics.fk(model, q[None], links=[link]).poses[0, 0]
    r = api_client.post(f"/models/{model_id}/ik", json={"link": link, "target": T.tolist(), "verify": True, **extra})
    assert r.status_code == 200, r.text
    body = r.json()
    assert body["success"] is True
    v = body["verification"]
    assert v is not None and v["reference"].startswith("pinocchio")
    assert v["position_error"] < 1e-9 and v["rotation_error"] < 1e-9
