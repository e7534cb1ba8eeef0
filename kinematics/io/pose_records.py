"""The product's pose output: what an FK answer holds per link, in one of three formats.

- ``pose``: per configuration, per link, ``{"matrix": 4x4, "position": [x, y, z],
  "quaternion": {"w", "x", "y", "z"}, "rpy": [roll, pitch, yaw]}`` (quaternion as an object
  so its order is never in doubt; w >= 0; rpy as URDF, ``R = Rz(yaw) Ry(pitch) Rx(roll)``);
- ``matrix``: per configuration, per link, the 4x4 matrix only;
- ``compact``: per link, ``positions`` (N, 3) and ``quaternions`` (N, 4, w first).

Values are numpy arrays and floats: orjson serialises them as they are; ``json.dumps``
with ``default=ndarray.tolist`` gives the same text.
"""

from __future__ import annotations

import numpy as np

from ..spatial.transforms import pose_components


def pose_record(T: np.ndarray) -> dict:
    """One pose ``T`` (4, 4) as a request's ``base`` or ``tool`` field takes it: ``{"position": [x, y, z],
    "quaternion": {"w", "x", "y", "z"}}`` (plain floats, w >= 0).

    >>> pose_record(np.eye(4))
    {'position': [0.0, 0.0, 0.0], 'quaternion': {'w': 1.0, 'x': 0.0, 'y': 0.0, 'z': 0.0}}
    """
    c = pose_components(T)
    w, x, y, z = (float(v) for v in c["quaternion"])
    return {"position": [float(v) for v in c["position"]], "quaternion": {"w": w, "x": x, "y": y, "z": z}}


def pose_output(T: np.ndarray, links: list[str], fmt: str = "pose", is_batch: bool = True):
    """``poses`` of an FK answer from ``T`` (N, L, 4, 4): a list of per-configuration maps
    (one map when ``is_batch`` is false), or for ``compact`` one map of per-link arrays.

    >>> out = pose_output(np.eye(4)[None, None], ["tool"], is_batch=False)
    >>> out["tool"]["quaternion"], out["tool"]["position"].tolist()
    ({'w': 1.0, 'x': 0.0, 'y': 0.0, 'z': 0.0}, [0.0, 0.0, 0.0])
    """
    N = T.shape[0]
    if fmt == "matrix":
        per_config = [{link: T[n, k] for k, link in enumerate(links)} for n in range(N)]
        return per_config if is_batch else per_config[0]
    comps = pose_components(T)
    position = np.ascontiguousarray(comps["position"])
    quaternion = np.ascontiguousarray(comps["quaternion"])
    if fmt == "compact":
        return {link: {"positions": np.ascontiguousarray(position[:, k]),
                       "quaternions": np.ascontiguousarray(quaternion[:, k])} for k, link in enumerate(links)}
    rpy = np.ascontiguousarray(comps["rpy"])
    quats = quaternion.tolist()
    per_config = []
    for n in range(N):
        qn = quats[n]
        per_config.append({
            link: {"matrix": T[n, k], "position": position[n, k],
                   "quaternion": {"w": qn[k][0], "x": qn[k][1], "y": qn[k][2], "z": qn[k][3]}, "rpy": rpy[n, k]}
            for k, link in enumerate(links)
        })
    return per_config if is_batch else per_config[0]
