#!/usr/bin/env bash
# Smoke test of a running service (the container CI starts with container-check KEEP=1):
#   .ci/smoke.sh [BASE_URL]        (default http://127.0.0.1:8000)
# Checks /health, FK and a Jacobian on ur5 (against the library computed here, and the
# closed value of UR5 at q = 0), every IK solution of a UR5 pose, self-collision on the catalogue's
# meshes and calibration poses (scipy), a DH table upload (201) and FK on it against the closed
# form of the 2R planar arm with verify=true (Pinocchio inside the container), the docs
# page /docs (HTML, every asset it references served by the service: docs work offline).
# Exits non-zero on the first failure. Uses only the Python standard library (plus the
# project's library, when .venv has it, for the reference values).
set -euo pipefail
BASE=${1:-http://127.0.0.1:8000}
cd "$(dirname "$0")/.."
PY=.venv/bin/python
[ -x "$PY" ] || PY=python3
exec "$PY" - "$BASE" <<'PYEOF'
import json
import math
import re
import sys
import time
import urllib.error
import urllib.request

BASE = sys.argv[1].rstrip("/")
TOL = 1e-9
checks = 0


def fail(msg):
    print(f"smoke: FAIL: {msg}", flush=True)
    sys.exit(1)


def ok(msg):
    global checks
    checks += 1
    print(f"smoke: ok   {msg}", flush=True)


def call(method, path, body=None, expect=(200,)):
    data = None if body is None else json.dumps(body).encode()
    req = urllib.request.Request(BASE + path, data=data, method=method,
                                 headers={"Content-Type": "application/json"} if data else {})
    t0 = time.perf_counter()
    try:
        with urllib.request.urlopen(req, timeout=60) as r:
            status, ctype, raw = r.status, r.headers.get("Content-Type", ""), r.read()
    except urllib.error.HTTPError as e:
        status, ctype, raw = e.code, e.headers.get("Content-Type", ""), e.read()
    except OSError as e:
        fail(f"{method} {path}: {e}")
    ms = (time.perf_counter() - t0) * 1000
    if status not in expect:
        fail(f"{method} {path}: status {status} (expected {expect}): {raw[:500]!r}")
    return status, ctype, raw, ms


def get_json(method, path, body=None, expect=(200,)):
    status, ctype, raw, ms = call(method, path, body, expect)
    if "json" not in ctype:
        fail(f"{method} {path}: content type {ctype!r}, expected JSON")
    return status, json.loads(raw), ms


def close(a, b, tol=TOL):
    flat_a = [x for row in a for x in row] if isinstance(a[0], list) else a
    flat_b = [x for row in b for x in row] if isinstance(b[0], list) else b
    return len(flat_a) == len(flat_b) and all(abs(x - y) <= tol for x, y in zip(flat_a, flat_b))


try:  # reference values from the library in this checkout (CI's .venv); closed forms otherwise
    import numpy as np
    from kinematics import compile_model, default_catalogue
    LIB = default_catalogue().get("ur5")
except ImportError:
    LIB = None

# ---------------------------------------------------------------- health
_, health, ms = get_json("GET", "/health")
if health.get("status") not in ("ok", "healthy", "up"):
    fail(f"/health status {health.get('status')!r}: {health}")
ok(f"GET /health {ms:.0f} ms: {json.dumps(health)}")

# ---------------------------------------------------------------- FK on ur5
_, fk0, ms = get_json("POST", "/models/ur5/fk", {"q": [0, 0, 0, 0, 0, 0], "links": ["tool0"]})
T0 = fk0["poses"]["tool0"]["matrix"]
if len(T0) != 4 or any(len(r) != 4 for r in T0) or T0[3] != [0, 0, 0, 1]:
    fail(f"ur5 FK pose is not a 4x4 homogeneous matrix: {T0}")
# UR5 stretched out at q = 0: (a2 + a3, d4 + d6, d1 - d5) from its DH parameters
closed = [0.425 + 0.39225, 0.10915 + 0.0823, 0.089159 - 0.09465]
if not close(fk0["poses"]["tool0"]["position"], closed):
    fail(f"ur5 tool0 at q=0: {fk0['poses']['tool0']['position']} != closed form {closed}")
ok(f"POST /models/ur5/fk q=0 {ms:.0f} ms: tool0 at {closed} (closed form)")

Q = [[0.1, -0.7, 1.2, -0.3, 0.9, 2.1], [-1.0, 0.4, -0.2, 1.7, -2.2, 0.5], [2.5, -1.9, 0.8, 0.3, 1.1, -0.6]]
_, fkb, ms = get_json("POST", "/models/ur5/fk", {"q": Q, "links": ["tool0", "wrist_2_link"]})
poses = fkb["poses"]
if not isinstance(poses, list) or len(poses) != len(Q):
    fail(f"batch FK: expected {len(Q)} pose maps, got {type(poses).__name__} of {len(poses)}")
if LIB is not None:
    ref = compile_model(LIB).fk(np.array(Q), ["tool0", "wrist_2_link"])
    for n in range(len(Q)):
        for k, link in enumerate(["tool0", "wrist_2_link"]):
            if not close(poses[n][link]["matrix"], ref[n, k].tolist()):
                fail(f"batch FK row {n} link {link}: {poses[n][link]['matrix']} != library {ref[n, k].tolist()}")
    ok(f"POST /models/ur5/fk batch of {len(Q)} {ms:.0f} ms: equal to the library to {TOL:g}")
else:
    ok(f"POST /models/ur5/fk batch of {len(Q)} {ms:.0f} ms: shape (library not importable here)")

_, jac, ms = get_json("POST", "/models/ur5/jacobian", {"q": Q[0], "link": "tool0", "reference": "local_world_aligned"})
J = jac["jacobian"]
if len(J) != 6 or any(len(r) != 6 for r in J):
    fail(f"ur5 Jacobian is not 6x6: {J}")
if LIB is not None:
    refJ = compile_model(LIB).jacobian(np.array([Q[0]]), "tool0", "local_world_aligned")[0]
    if not close(J, refJ.tolist()):
        fail(f"ur5 Jacobian {J} != library {refJ.tolist()}")
ok(f"POST /models/ur5/jacobian {ms:.0f} ms: 6x6" + (", equal to the library" if LIB is not None else ""))

# ---------------------------------------------------------------- IK on ur5
# the target is the pose FK gave for Q[1]; the answer (any of the arm's solutions) must reproduce it
target = poses[1]["tool0"]["matrix"]
_, ikr, ms = get_json("POST", "/models/ur5/ik", {"link": "tool0", "target": target, "verify": True})
if ikr.get("success") is not True or ikr["position_error"] > 1e-6 or ikr["rotation_error"] > 1e-6:
    fail(f"ur5 IK of a reachable target: {ikr}")
_, back, _ = get_json("POST", "/models/ur5/fk", {"q": ikr["q"], "links": ["tool0"]})
if not close(back["poses"]["tool0"]["matrix"], target, 1e-6):
    fail(f"FK of the IK answer {back['poses']['tool0']['matrix']} is not the target {target}")
if ikr["verification"]["position_error"] > 1e-6:
    fail(f"Pinocchio disagrees with the IK answer: {ikr['verification']}")
ok(f"POST /models/ur5/ik {ms:.0f} ms: solved in {ikr['iterations']} iterations; FK of the answer is the target "
   f"(position error {ikr['position_error']:.1e} m, Pinocchio {ikr['verification']['position_error']:.1e} m)")

# ---------------------------------------------------------------- every IK solution, self-collision, calibration
# the UR5 at Q[1] reached in every way: 8 branches, the generating configuration among them (modulo 2 pi)
_, fk1, _ = get_json("POST", "/models/ur5/fk", {"q": Q[1], "links": ["tool0"]})
_, alls, ms = get_json("POST", "/models/ur5/ik", {"link": "tool0", "target": fk1["poses"]["tool0"]["matrix"],
                                                  "solutions": "all", "limits": "ignore"})
if alls.get("family") != "three_parallel" or alls.get("count") != 8:
    fail(f"ur5 every IK solution: family {alls.get('family')!r}, count {alls.get('count')!r} (expected three_parallel, 8)")
wrap = lambda a: (a + math.pi) % (2 * math.pi) - math.pi
if not any(all(abs(wrap(x - y)) < 1e-9 for x, y in zip(s["q"], Q[1])) for s in alls["solutions"]):
    fail("ur5 every IK solution: the generating configuration is not among them")
ok(f"POST /models/ur5/ik solutions all {ms:.0f} ms: three_parallel, 8 solutions, the generating one among them")
# the elbow shut: the UR5's upper arm and wrist meshes meet (catalogue meshes inside the image)
_, col, ms = get_json("POST", "/models/ur5/collision", {"q": [[0, -1.2, 0, 0, 0, 0], [0, -1.2, 3.1, 0, 0, 0]]})
if col.get("colliding") != [False, True]:
    fail(f"ur5 self-collision: colliding {col.get('colliding')!r}, expected [False, True]")
ok(f"POST /models/ur5/collision {ms:.0f} ms: stretched free, elbow shut colliding {col['pairs'][1]}")
_, poses, ms = get_json("POST", "/models/ur5/calibration/poses", {"link": "tool0", "n": 8})
if len(poses.get("q", [])) != 8:
    fail(f"ur5 calibration poses: {poses}")
ok(f"POST /models/ur5/calibration/poses {ms:.0f} ms: 8 configurations chosen (scipy in the image)")

# ---------------------------------------------------------------- DH upload + FK
l1, l2 = 0.7, 0.45
table = {
    "name": "smoke_planar_2r",
    "convention": "standard",
    "angles": "radians",
    "joints": [
        {"type": "revolute", "a": l1, "alpha": 0, "d": 0, "theta": 0, "name": "j1"},
        {"type": "revolute", "a": l2, "alpha": 0, "d": 0, "theta": 0, "name": "j2"},
    ],
}
status, info, ms = get_json("POST", "/models/dh", table, expect=(201,))
mid = info.get("id")
if not mid or info.get("dof") != 2:
    fail(f"POST /models/dh: id/dof missing or wrong: {info}")
ok(f"POST /models/dh {ms:.0f} ms: 201, id {mid}, dof 2")
_, again, _ = get_json("POST", "/models/dh", table, expect=(200,))
if again.get("id") != mid:
    fail(f"same DH table registered twice gave ids {mid} and {again.get('id')}")
ok("POST /models/dh again: 200, same id")

q1, q2 = 0.6, -1.1
_, fkd, ms = get_json("POST", f"/models/{mid}/fk", {"q": [q1, q2], "verify": True})
expected = [l1 * math.cos(q1) + l2 * math.cos(q1 + q2), l1 * math.sin(q1) + l2 * math.sin(q1 + q2), 0.0]
leaves = fkd["poses"]
if len(leaves) != 1:
    fail(f"DH model FK: expected one leaf (the tool), got {list(leaves)}")
(tool, pose), = leaves.items()
if not close(pose["position"], expected):
    fail(f"DH 2R FK {tool}: {pose['position']} != closed form {expected}")
ver = fkd.get("verification") or {}
if not (ver.get("max_position_error", 1) <= TOL and ver.get("max_rotation_error", 1) <= TOL):
    fail(f"DH 2R FK verification vs Pinocchio: {ver}")
ok(f"POST /models/{mid}/fk {ms:.0f} ms: {tool} at closed form l1 c1 + l2 c12, l1 s1 + l2 s12; "
   f"verified against {ver.get('reference')} ({ver.get('max_position_error'):.1e} m)")
_, listing, _ = get_json("GET", "/models")
if mid not in {m["id"] for m in listing} or "ur5" not in {m["id"] for m in listing}:
    fail("GET /models lacks ur5 or the uploaded DH model")
ok(f"GET /models: {len(listing)} models, ur5 and {mid} among them")

# ---------------------------------------------------------------- docs (offline)
status, ctype, raw, ms = call("GET", "/docs")
html = raw.decode("utf-8", "replace")
if "text/html" not in ctype or "swagger" not in html.lower():
    fail(f"/docs is not the Swagger UI page ({ctype}): {html[:300]!r}")
assets = re.findall(r'(?:src|href)\s*=\s*["\']([^"\']+)["\']', html)
external = [a for a in assets if re.match(r"^(https?:)?//", a)]
if external:
    fail(f"/docs loads assets from other hosts (does not work offline): {external}")
for a in assets:
    call("GET", a if a.startswith("/") else "/" + a)
_, spec, _ = get_json("GET", "/openapi.json")
for path in ("/health", "/models", "/models/dh", "/models/{model_id}/fk", "/models/{model_id}/jacobian"):
    if path not in spec.get("paths", {}):
        fail(f"/openapi.json lacks {path}")
ok(f"GET /docs {ms:.0f} ms: HTML, {len(assets)} assets all served locally; /openapi.json has the contract's paths")

print(f"smoke: all {checks} checks succeeded against {BASE}")
PYEOF
