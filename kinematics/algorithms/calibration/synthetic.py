"""Synthetic truth, as calibration papers test: a nominal model with planted errors, measured.

:func:`plant` draws the errors of a robot "as built" -- every path joint's origin off by
``origin_error`` metres and radians per component (1 mm, 1 mrad), every zero by ``zero_error``
(10 mrad), an unknown device frame (a random rotation, a translation of about a metre) and a
marker point or tool frame -- and :meth:`Truth.measure` what a device with per-axis noise
``sigma`` sees at configurations Q (``outliers``: indices moved by ``outlier_size`` metres).

:func:`moved_origins` is a calibrated robot as a plain model: every moving joint's origin moved and
turned a little, for what runs on a calibrated model (inverse kinematics of a chain whose axes are
no longer exactly parallel or intersecting).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from ...model.robot import RobotModel
from ...spatial.rotations import rpy_to_matrix
from ...spatial.transforms import exp_screws
from .errors_model import ErrorModel


@dataclass
class Truth:
    """The planted robot: its :class:`ErrorModel` and parameter vector ``x`` (full parameters)."""

    em: ErrorModel
    x: np.ndarray
    base: np.ndarray
    tool: np.ndarray

    def predict(self, Q: np.ndarray) -> np.ndarray:
        """Noise-free ``T_device_tool`` (N, 4, 4)."""
        return self.em.predict(Q, self.x)

    def measure(self, Q: np.ndarray, sigma: float = 20e-6, rng: np.random.Generator | None = None,
                rotation_sigma: float | None = None, outliers=(), outlier_size: float = 5e-3) -> np.ndarray:
        """Measured positions (N, 3) or poses (N, 4, 4) with Gaussian noise (``sigma`` m per axis,
        ``rotation_sigma`` rad per axis, default ``sigma`` per metre); ``outliers`` moved by ``outlier_size``."""
        rng = np.random.default_rng(0) if rng is None else rng
        T = self.predict(Q)
        p = T[:, :3, 3] + rng.normal(0.0, sigma, (len(Q), 3))
        for i in outliers:
            d = rng.normal(size=3)
            p[i] += outlier_size * d / np.linalg.norm(d)
        if self.em.measure == "position":
            return p
        rs = sigma if rotation_sigma is None else rotation_sigma
        out = T.copy()
        out[:, :3, 3] = p
        for i in range(len(Q)):
            out[i, :3, :3] = rpy_to_matrix(rng.normal(0.0, rs, 3)) @ T[i, :3, :3]
        return out


def plant(model: RobotModel, link: str, measure: str = "position", rng: np.random.Generator | None = None,
          origin_error: float = 1e-3, zero_error: float = 10e-3, point=(0.05, 0.03, 0.1)) -> Truth:
    """A robot as built: errors drawn uniformly in ``±origin_error`` (origins) and ``±zero_error`` (zeros)
    with random signs of the full size, a random device frame and tool."""
    rng = np.random.default_rng(0) if rng is None else rng
    R0 = rpy_to_matrix(rng.uniform(-np.pi, np.pi, 3))
    t0 = rng.uniform(-1.0, 1.0, 3)
    tool_R = rpy_to_matrix(rng.uniform(-0.3, 0.3, 3))
    em = ErrorModel(model, link, measure, "full", "estimate", "estimate", R0=R0, t0=t0,
                    point=np.asarray(point, dtype=float), tool_rotation=tool_R)
    x = em.x0.copy()
    for i, p in enumerate(em.parameters):
        if p.group in ("base", "tool"):
            continue
        size = zero_error if p.component == "offset" else origin_error
        x[i] = size * rng.choice([-1.0, 1.0]) * rng.uniform(0.5, 1.0)
    if measure == "pose":
        for c in ("yaw", "pitch", "roll"):
            x[em.index[f"tool.{c}"]] = 0.0
    base = em.base_pose(x)
    tool = em.tool_pose(x)
    return Truth(em, x, base, tool)


def experiment(model: RobotModel, link: str, measure: str, n: int, rng: np.random.Generator,
               sigma: float = 20e-6, outliers=()) -> tuple[Truth, np.ndarray, np.ndarray]:
    """A planted robot, ``n`` random configurations within the limits and what the device measured of
    them: ``(truth, Q (n, dof), data)``, drawn from ``rng`` in that order (:func:`plant`,
    ``sample_configurations``, :meth:`Truth.measure`)."""
    truth = plant(model, link, measure, rng)
    Q = model.sample_configurations(n, rng)
    return truth, Q, truth.measure(Q, sigma, rng, outliers=outliers)


def moved_origins(model: RobotModel, seed: int = 3, distance: float = 1e-3, angle: float = 1e-3) -> RobotModel:
    """``model`` as a per-robot calibration finds it: every moving joint's origin ``T_parent_joint``
    turned by ``angle`` rad about a random axis of the joint frame (``origin @ exp([w] angle)``), then
    moved by ``distance`` m in a random direction of the parent frame; the axis and the direction of
    each joint are drawn in joint order from ``default_rng(seed)``. Its ``content_hash`` gets the
    suffix ``-calibrated-<seed>`` (it compiles to its own kernels).

    >>> from kinematics.io import parse_urdf
    >>> m = parse_urdf('<robot name="r"><link name="a"/><link name="b"/><joint name="j" type="revolute">'
    ...                '<parent link="a"/><child link="b"/><axis xyz="0 0 1"/>'
    ...                '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>')
    >>> moved = moved_origins(m, seed=1)
    >>> round(float(np.linalg.norm(moved.joints[0].origin[:3, 3] - m.joints[0].origin[:3, 3])), 12)
    0.001
    >>> moved.content_hash == m.content_hash + "-calibrated-1"
    True
    """
    rng = np.random.default_rng(seed)
    joints = []
    for j in model.joints:
        if j.moving:
            w, v = rng.normal(size=3), rng.normal(size=3)
            E = exp_screws(np.array([w / np.linalg.norm(w)]), np.zeros((1, 3)), np.array([True]), np.array([angle]))[0]
            origin = j.origin @ E
            origin[:3, 3] += distance * v / np.linalg.norm(v)
            j = dataclasses.replace(j, origin=origin)
        joints.append(j)
    return dataclasses.replace(model, joints=tuple(joints), content_hash=model.content_hash + f"-calibrated-{seed}")
