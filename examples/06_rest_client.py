"""The REST service from Python: numpy arrays in and out with ``kinematics.client``.

Start a service first (``make serve``, or ``docker run -p 8000:8000 kinematics``); the example
talks to ``KIN_BASE_URL`` (default http://127.0.0.1:8000). The client needs only numpy.

Run: KIN_BASE_URL=http://127.0.0.1:8000 python examples/06_rest_client.py
"""

import os

import numpy as np

from kinematics.client import Client, ServiceError

kin = Client(os.environ.get("KIN_BASE_URL", "http://127.0.0.1:8000"), api_key=os.environ.get("KIN_API_KEY"))
print("service:", kin.health()["status"], "with", len(kin.models()), "models")

# FK and Jacobians of a batch over the binary (.npy) transport
Q = np.random.default_rng(0).uniform(-3, 3, size=(1000, 6))
T = kin.fk("ur5", Q, links=["tool0"], verify=True)
print("FK:", T.shape, "links", kin.links(), "verified:", kin.last_headers.get("x-verification-reference"))
J = kin.jacobian("ur5", Q, link="tool0", reference="local")
print("Jacobians:", J.shape, "columns", kin.joint_names())

# IK of those poses: every target solved, and FK of the answers is back on target
sol = kin.ik("ur5", T[:, 0], link="tool0", random_seed=0)
T_back = kin.fk("ur5", sol["q"], links=["tool0"])[:, 0]
ok = sol["success"]
print(f"IK: solved {int(ok.sum())}/{len(ok)}, worst position error of the solved "
      f"{np.abs(T_back[ok] - T[ok, 0]).max():.1e}")

# a model of your own: a DH table (201 created, 200 when it is already there)
two_link = {"name": "example_2r", "convention": "standard", "angles": "degrees",
            "joints": [{"type": "revolute", "a": 0.5, "alpha": 0, "d": 0, "theta": 0},
                       {"type": "revolute", "a": 0.4, "alpha": 0, "d": 0, "theta": 0}]}
model = kin.upload_dh(two_link)
print("uploaded:", model["id"], model["joint_names"], "leaf", model["leaf_links"])
p = kin.fk(model["id"], [[0.0, np.pi / 2]], links=["tool"])[0, 0, :3, 3]
print("2R tip at q = (0, 90 deg):", np.round(p, 12))  # (0.5, 0.4, 0)

# twists of a moving arm, three references at once
V = kin.velocity("ur5", Q[:2], np.ones((2, 6)), links=["tool0"])
print("velocity references:", sorted(V), V["world"].shape)

# errors are problem details, raised as ServiceError with the status and a slug
try:
    kin.fk("ur5", np.zeros((1, 5)))
except ServiceError as error:
    print("refused:", error.status, error.slug, "-", error.detail[:60])
kin.delete_model(model["id"])
