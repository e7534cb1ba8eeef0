"""Estimation: the identifiable parameters from measurements, by Levenberg-Marquardt.

:func:`calibrate` fits the :class:`~.errors_model.ErrorModel` of a model and link to what a
measuring device saw -- positions (N, 3) of a marker on the link or poses (N, 4, 4) of a tool
on it, in the device's frame -- at joint values Q (N, dof):

1. a ``holdout`` fraction of the measurements is put aside (chosen by ``random_seed``);
2. the device frame needs no guess: its start is the rigid registration (Kabsch/Umeyama) of the
   nominal model's predictions onto the measured points; for poses the tool's rotation starts
   at the chordal mean of the remaining rotations;
3. the identification Jacobian at that start gives the identifiable combinations
   (:func:`~.identification.identify`); only their representatives are fitted, the others stay
   at their start values (their effect is carried by the ones they are a combination of);
4. ``loss="linear"``: Levenberg-Marquardt (``scipy.optimize.least_squares``, the analytic
   Jacobian); ``loss="huber"``: a Huber fit whose scale follows the residuals' robust spread
   (MAD), the measurements whose residual is beyond the chi-square 99.99 % bound of that spread
   named ``outliers``, and a final linear fit without them;
5. standard deviations from ``s^2 (J^T J)^{-1}`` at the solution (``s^2`` the residual variance),
   RMS and largest residual before (the nominal model, registered) and after, the condition
   number, the held-out RMS, and the calibrated URDF (:mod:`.urdf_out`).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.optimize import least_squares
from scipy.stats import chi2

from ...engine import cancel
from ...engine.poe import compile_model
from ...errors import CalibrationError, KinematicsError, UnsupportedJointError
from ...io.urdf import parse_urdf
from ...model.robot import RobotModel
from ...spatial.transforms import make_transform
from ...tolerances import MAX_ABS_COORDINATE
from .compliance import Compliance
from .prior import Prior
from .errors_model import ErrorModel
from .identification import identify, residual_and_jacobian, singular_values
from .urdf_out import corrected_urdf

#: false-alarm probability of the outlier test, per measurement
OUTLIER_PROBABILITY = 1e-4


@dataclass(frozen=True)
class FitOptions:
    """How a calibration fits, validated when built (a bad field is a :class:`CalibrationError` naming it):

    - ``parameters``: ``"full"`` (joint origins and zeros) or ``"joint_offsets"`` (zeros only);
    - ``base``: ``"estimate"``, ``"fixed"`` (the device frame is the root frame) or a fixed pose
      ``T_device_root`` (4, 4); ``tool``: ``"estimate"`` or ``"fixed"`` (at its guess);
    - ``loss``: ``"linear"`` or ``"huber"``; ``holdout``: the fraction of measurements kept out of the
      fit, drawn with ``random_seed``;
    - ``rotation_weight``: metres per radian of a rotation residual (poses);
    - ``compliance``: a :class:`~.compliance.Compliance` to estimate joint compliance under gravity
      too (its values are among the parameters, ``<joint>.compliance``; the calibrated URDF, which
      cannot say it, holds the geometric corrections only);
    - ``prior``: a :class:`~.prior.Prior`: the joint parameters estimated by maximum a posteriori
      (every one fitted, the prior holding those the data do not determine near nominal) after the
      plain fit of the identifiable combinations; None: the plain fit.

    >>> FitOptions(loss="cauchy")
    Traceback (most recent call last):
    ...
    kinematics.errors.CalibrationError: unknown loss 'cauchy'; expected 'linear' or 'huber'
    """

    parameters: str = "full"
    base: Any = "estimate"
    tool: str = "estimate"
    loss: str = "linear"
    holdout: float = 0.0
    random_seed: int = 0
    rotation_weight: float = 1.0
    compliance: Compliance | None = None
    prior: Prior | None = None

    def __post_init__(self) -> None:
        if self.parameters not in ("full", "joint_offsets"):
            raise CalibrationError(f"unknown parameters {self.parameters!r}; expected 'full' or 'joint_offsets'",
                                   field="parameters")
        if self.loss not in ("linear", "huber"):
            raise CalibrationError(f"unknown loss {self.loss!r}; expected 'linear' or 'huber'", field="loss")
        if self.tool not in ("estimate", "fixed"):
            raise CalibrationError(f"unknown tool {self.tool!r}; expected 'estimate' or 'fixed'", field="tool")
        if isinstance(self.base, str) and self.base not in ("estimate", "fixed"):
            raise CalibrationError(f"unknown base {self.base!r}; expected 'estimate', 'fixed' or a pose", field="base")
        if not 0.0 <= float(self.holdout) < 1.0:
            raise CalibrationError(f"holdout must be a fraction in [0, 1), got {self.holdout}", field="holdout")
        if not (np.isfinite(self.rotation_weight) and self.rotation_weight > 0):
            raise CalibrationError("rotation_weight must be a positive length (metres per radian)",
                                   field="rotation_weight")

    @classmethod
    def split(cls, fit: FitOptions | None, keywords: dict[str, Any]) -> tuple[FitOptions, dict[str, Any]]:
        """``(fit with the keywords naming its fields applied, the other keywords)``: so that
        ``calibrate(model, link, q, positions=P, loss="huber")`` keeps working."""
        names = {f.name for f in dataclasses.fields(cls)}
        mine = {k: v for k, v in keywords.items() if k in names}
        rest = {k: v for k, v in keywords.items() if k not in names}
        fit = fit or cls()
        return (dataclasses.replace(fit, **mine) if mine else fit), rest


@dataclass
class Calibration:
    """A calibration's result (the fields of ``POST /models/{id}/calibrate``).

    Attributes:
        model: the calibrated :class:`RobotModel` (its ``urdf`` the corrected document).
        source: the nominal model's name.
        base: ``T_device_root`` (4, 4). point: the marker point on the link (3,), positions measured.
        tool: ``T_link_tool`` (4, 4), poses measured (else None).
        identifiable: the number of combinations the data determine.
        parameters: ``{"name", "value", "sigma"}`` per fitted parameter (metres, radians).
        unidentifiable: ``{"name", "reason"}`` per other parameter.
        condition_number: of the column-equilibrated identification Jacobian at the solution.
        rmse_before, rmse_after, max_before, max_after: RMS and largest Euclidean position residual (m)
            over the fitted measurements (with huber, the named outliers left out).
        rotation_rmse_before, rotation_rmse_after: the same for rotations (rad), poses measured.
        outliers: indices of the measurements named outliers.
        holdout: indices held out of the fit; holdout_rmse: their RMS position residual (m), outliers
            among them left out (None if none).
        residuals_before, residuals_after: (N,) Euclidean position residual of every measurement.
        iterations: function evaluations of the fits. status: scipy's message.
        verification: the calibrated model's FK against Pinocchio's, when the use case was asked to verify.
    """

    model: RobotModel
    source: str
    link: str
    measure: str
    base: np.ndarray
    point: np.ndarray | None
    tool: np.ndarray | None
    identifiable: int
    parameters: list
    unidentifiable: list
    condition_number: float
    rmse_before: float
    rmse_after: float
    max_after: float
    max_before: float
    outliers: list
    holdout: list
    holdout_rmse: float | None
    residuals_before: np.ndarray
    residuals_after: np.ndarray
    iterations: int
    status: str
    rotation_rmse_before: float | None = None
    rotation_rmse_after: float | None = None
    x: np.ndarray = field(default=None, repr=False)
    error_model: ErrorModel = field(default=None, repr=False)
    verification: object = None  # set by the use case when asked (a kinematics.Verification)
    markers: np.ndarray | None = None  # several markers measured: their points (M, 3) on the link

    @property
    def urdf(self) -> str:
        return self.model.urdf

    def predict(self, q) -> np.ndarray:
        """The calibrated poses ``T_device_tool`` (N, 4, 4) at configurations q (N, dof): the device's
        view of the marker (its translation) or tool, joint compliance included (which the
        calibrated URDF cannot hold)."""
        return self.error_model.predict(np.atleast_2d(np.asarray(q, dtype=float)), self.x)

    def predict_markers(self, q) -> np.ndarray:
        """Where the device will see each marker (N, M, 3) at configurations q, several markers measured."""
        if self.markers is None:
            raise CalibrationError("this calibration was not fitted on several markers")
        T = self.predict(q) @ np.linalg.inv(self.tool)  # T_device_link: the markers are points on the link
        return np.einsum("nij,mj->nmi", T[:, :3, :3], self.markers) + T[:, None, :3, 3]


#: the largest correction of one parameter a calibration answers (metres or radians): more is a fit
#: that diverged on measurements the model cannot explain, not a robot as built
MAX_CORRECTION = 1.0
#: function evaluations of one least-squares solve (a converging fit takes about ten)
MAX_EVALUATIONS = 200

def kabsch(P: np.ndarray, M: np.ndarray) -> np.ndarray:
    """The rigid ``T`` (4, 4) minimising ``sum |M_i - T P_i|^2`` over points P, M (N, 3) (Umeyama, no scale).

    >>> P = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    >>> M = P @ np.array([[0.0, -1, 0], [1, 0, 0], [0, 0, 1]]).T + [1.0, 2, 3]
    >>> kabsch(P, M)[:3, 3].round(12) + 0.0
    array([1., 2., 3.])
    """
    cp, cm = P.mean(axis=0), M.mean(axis=0)
    H = (P - cp).T @ (M - cm)
    U, _, Vt = np.linalg.svd(H)
    d = np.sign(np.linalg.det(Vt.T @ U.T)) or 1.0
    R = Vt.T @ np.diag([1.0, 1.0, d]) @ U.T
    return make_transform(R, cm - R @ cp)


def register(T_link: np.ndarray, measured: np.ndarray, point: np.ndarray, base: np.ndarray | None,
             estimate_point: bool, iterations: int = 50) -> tuple[np.ndarray, np.ndarray]:
    """The device frame ``T_device_root`` (4, 4) and the point on the link (3,) that best map the
    nominal link poses T_link (N, 4, 4) onto the measured points (N, 3): Kabsch for the frame and
    linear least squares for the point, alternated (``base`` given: only the point;
    ``estimate_point`` False: only the frame)."""
    R_i, t_i = T_link[:, :3, :3], T_link[:, :3, 3]
    p = np.asarray(point, dtype=float).copy()
    B = base
    for _ in range(iterations if (base is None and estimate_point) else 1):
        if base is None:
            pts = (R_i @ p) + t_i
            centred = pts - pts.mean(axis=0)
            if np.linalg.svd(centred, compute_uv=False)[1] / np.sqrt(len(pts)) < 1e-6:
                raise CalibrationError("the measured configurations put the marker on a line (or at one point): "
                                       "they do not determine the device frame")
            B = kabsch(pts, measured)
        if estimate_point:
            local = (measured - B[:3, 3]) @ B[:3, :3] - t_i  # R_B^T (m - t_B) - t_i, row-wise
            p_new = np.linalg.lstsq(R_i.reshape(-1, 3), local.reshape(-1), rcond=None)[0]
            done = np.abs(p_new - p).max() < 1e-12
            p = p_new
            if done:
                break
    return B, p


def _project_rotation(A: np.ndarray) -> np.ndarray:
    U, _, Vt = np.linalg.svd(A)
    return U @ np.diag([1.0, 1.0, np.sign(np.linalg.det(U @ Vt)) or 1.0]) @ Vt


def check_measurements(model: RobotModel, q, positions=None, poses=None) -> tuple[np.ndarray, np.ndarray, str]:
    """Q (N, dof) and the measurements (N, 3) or (N, 4, 4), validated; the measure's name."""
    if model.multi_dof:
        raise UnsupportedJointError("calibration needs a model of one-dof joints (no floating or planar joint)")
    if (positions is None) == (poses is None):
        raise CalibrationError("give the measured positions or the measured poses (one of them)")
    try:
        Q = np.asarray(q, dtype=float)
    except (TypeError, ValueError):
        raise CalibrationError("the joint values q must be numbers", field="q") from None
    if Q.ndim != 2 or Q.shape[1] != model.dof:
        raise CalibrationError(f"every q must have {model.dof} values ({', '.join(model.joint_names)}); "
                               f"got an array of shape {Q.shape}", field="q")
    bad = np.flatnonzero(~np.all(np.isfinite(Q), axis=1))
    if bad.size:
        raise CalibrationError(f"measurement {int(bad[0])}: q has a non-finite value (NaN or inf)", field="q")
    measure = "position" if poses is None else "pose"
    try:
        data = np.asarray(positions if poses is None else poses, dtype=float)
    except (TypeError, ValueError):
        raise CalibrationError(f"the measured {measure}s must be numbers") from None
    shape = (Q.shape[0], 3) if measure == "position" else (Q.shape[0], 4, 4)
    if data.shape != shape:
        raise CalibrationError(f"expected {Q.shape[0]} measured {measure}s of shape {shape[1:]}, got {data.shape}")
    flat = data.reshape(len(data), -1)
    bad = np.flatnonzero(~np.all(np.isfinite(flat), axis=1))
    if bad.size:
        raise CalibrationError(f"measurement {int(bad[0])}: the measured {measure} has a non-finite value (NaN or inf)")
    bad = np.flatnonzero(np.any(np.abs(flat) > MAX_ABS_COORDINATE, axis=1))
    if bad.size:
        raise CalibrationError(f"measurement {int(bad[0])}: the measured {measure} has a value beyond "
                               f"+-{MAX_ABS_COORDINATE:g} m")
    if measure == "pose":
        R = data[:, :3, :3]
        err = np.abs(np.swapaxes(R, 1, 2) @ R - np.eye(3)).max(axis=(1, 2))
        bad = np.flatnonzero((err > 1e-6) | (np.linalg.det(R) < 0))
        if bad.size:
            raise CalibrationError(f"measurement {int(bad[0])}: the measured pose's rotation is not a rotation")
    if Q.shape[0] < 3:
        raise CalibrationError(f"{Q.shape[0]} measurement(s) are too few: a calibration needs dozens "
                               "(more equations than the parameter combinations they determine)")
    if np.ptp(Q, axis=0).max() < 1e-9:
        raise CalibrationError(f"the {Q.shape[0]} measurements are all at the same configuration: "
                               "they determine nothing (the arm must move between measurements)")
    return Q, data, measure


def calibrate(model: RobotModel, link: str, q, positions=None, poses=None, *, fit: FitOptions | None = None,
              **options) -> Calibration:
    """Calibrate ``model``'s chain to ``link`` from measured ``positions`` (N, 3) or ``poses`` (N, 4, 4):
    how it fits is ``fit`` (:class:`FitOptions`, or its fields as keywords: :meth:`FitOptions.split`),
    and the other options, ``point``, ``tool_guess`` and ``name``, are :func:`_calibrate`'s. A numerical breakdown on degenerate data (a linear-algebra
    routine that does not converge) is a :class:`CalibrationError`, never an unexplained failure.

    Several markers fixed to the link, measured together: ``positions`` (N, M, 3), M >= 3 not on a
    line. They are one rigid body: their shape is their mean constellation (generalised Procrustes),
    each measurement the body's pose (Kabsch), fitted as poses whose radian weighs the body's RMS
    radius -- the residual of its points -- (``rotation_weight`` is set so); ``markers`` of the
    answer holds their points on the link, :meth:`Calibration.predict_markers` where they will be seen."""
    fit, options = FitOptions.split(fit, options)
    try:
        if positions is not None and np.ndim(positions) == 3:
            shape, poses_, radius = markers_as_poses(np.asarray(positions, dtype=float))
            cal = _calibrate(model, link, q, None, poses_, fit=dataclasses.replace(fit, rotation_weight=radius),
                             **options)
            cal.markers = shape @ cal.tool[:3, :3].T + cal.tool[:3, 3]
            return cal
        return _calibrate(model, link, q, positions, poses, fit=fit, **options)
    except np.linalg.LinAlgError as exc:
        raise CalibrationError(f"the measurements are degenerate: the fit broke down ({exc})") from None


def markers_as_poses(P: np.ndarray, iterations: int = 5) -> tuple[np.ndarray, np.ndarray, float]:
    """Several markers of one rigid body measured together (N, M, 3): their shape (M, 3) about its
    centroid (the mean constellation, generalised Procrustes from the first measurement's axes), the
    body's pose (N, 4, 4) at each measurement, and the shape's RMS radius (m)."""
    if P.ndim != 3 or P.shape[2] != 3 or P.shape[1] < 3:
        raise CalibrationError(f"several markers: expected positions of shape (N, M, 3) with M >= 3, got {P.shape}")
    if not np.all(np.isfinite(P)):
        raise CalibrationError("several markers: a measured position has a non-finite value (NaN or inf)")
    shape = P[0] - P[0].mean(axis=0)
    if np.linalg.svd(shape, compute_uv=False)[1] < 1e-6:
        raise CalibrationError("several markers: the markers are on a line; they do not give the body's orientation")
    for _ in range(iterations):
        T = np.array([kabsch(shape, p) for p in P])
        local = np.einsum("nji,nmj->nmi", T[:, :3, :3], P - T[:, None, :3, 3])  # each measurement in the body frame
        shape = local.mean(axis=0)
        shape -= shape.mean(axis=0)
    T = np.array([kabsch(shape, p) for p in P])
    return shape, T, float(np.sqrt(np.mean(np.sum(shape ** 2, axis=1))))


def _calibrate(model: RobotModel, link: str, q, positions=None, poses=None, *, fit: FitOptions,
               point=None, tool_guess=None, name: str | None = None) -> Calibration:
    """Calibrate ``model``'s chain to ``link`` from measured ``positions`` (N, 3) or ``poses`` (N, 4, 4)
    as ``fit`` says (:class:`FitOptions`).

    Args:
        point: the marker point's guess on the link (3,), metres (default the link origin).
        tool_guess: the tool frame's guess ``T_link_tool`` (4, 4), poses measured (default identity).
        name: the calibrated robot's name (default ``<name>_calibrated``).
    """
    model.link_indices([link])
    parameters, base, tool, loss = fit.parameters, fit.base, fit.tool, fit.loss
    holdout, random_seed, rotation_weight = fit.holdout, fit.random_seed, fit.rotation_weight
    compliance, prior = fit.compliance, fit.prior
    Q, data, measure = check_measurements(model, q, positions, poses)
    if not any(j.moving for j in model.path_joints(link)):
        raise CalibrationError(f"no moving joint between the root and {link!r}: nothing to calibrate", field="link")
    N = len(Q)
    rng = np.random.default_rng(random_seed)
    n_hold = int(round(float(holdout) * N))
    order = rng.permutation(N)
    held = np.sort(order[:n_hold])
    fit = np.sort(order[n_hold:])
    if fit.size < 3:
        raise CalibrationError(f"holdout {holdout} keeps {fit.size} of {N} measurements for the fit; at least 3 are "
                               "needed (and more than the parameters they should determine)", field="holdout")
    point = np.zeros(3) if point is None else np.asarray(point, dtype=float)
    if point.shape != (3,) or not np.all(np.isfinite(point)):
        raise CalibrationError("point must be 3 finite numbers (metres, in the link frame)", field="point")
    T_tool0 = np.eye(4) if tool_guess is None else np.asarray(tool_guess, dtype=float)
    if measure == "position":
        T_tool0 = make_transform(np.eye(3), point)

    # 2. the start: the nominal predictions registered onto the measurements
    T_link = compile_model(model).fk(Q, [link])[:, 0]
    measured_points = data if measure == "position" else data[:, :3, 3]
    if isinstance(base, str) and base == "estimate":
        base_mode, B0 = "estimate", None
    elif isinstance(base, str):  # "fixed" (FitOptions refuses any other word)
        B0, base_mode = np.eye(4), "fixed"
    else:
        B0, base_mode = np.asarray(base, dtype=float), "fixed"
    B0, p0 = register(T_link[fit], measured_points[fit], T_tool0[:3, 3], B0, estimate_point=tool == "estimate")
    T_tool0 = make_transform(T_tool0[:3, :3], p0)
    nominal = T_link @ T_tool0
    tool_rotation = T_tool0[:3, :3]
    if measure == "pose" and tool == "estimate":
        link_R = B0[:3, :3] @ (nominal[fit, :3, :3] @ T_tool0[:3, :3].T)
        tool_rotation = _project_rotation(np.sum(np.swapaxes(link_R, 1, 2) @ data[fit, :3, :3], axis=0))
    em = ErrorModel(model, link, measure, parameters, base_mode, tool, R0=B0[:3, :3], t0=B0[:3, 3],
                    point=T_tool0[:3, 3], tool_rotation=tool_rotation, compliance=compliance)
    x0 = em.x0.copy()
    meas_fit = data[fit]
    d = 3 if measure == "position" else 6

    # 3. identifiability at the start
    r0, J0 = residual_and_jacobian(em, Q[fit], x0, meas_fit, rotation_weight)
    ident = identify(em, J0.reshape(-1, len(x0)), measure)
    if ident.rank == 0:
        raise CalibrationError("the measurements determine no parameter")
    if len(fit) * d <= ident.rank:
        raise CalibrationError(f"{len(fit)} measurements give {len(fit) * d} equations, not more than the "
                               f"{ident.rank} parameter combinations they should determine: measure more configurations")

    # 4. the fit; the identifiable set is read again at the first solution (a marker guessed on a
    # joint axis hides that joint's motion at the start, not at the solution)
    z, nfev, status = _solve(em, Q[fit], meas_fit, x0, ident.selected, x0[ident.selected].copy(), rotation_weight,
                             "linear", 1.0)
    x1 = _full(x0, ident.selected, z)
    _, J1 = residual_and_jacobian(em, Q[fit], x1, meas_fit, rotation_weight)
    ident1 = identify(em, J1.reshape(-1, len(x0)), measure)
    if ident1.rank > ident.rank:
        ident = ident1
        if len(fit) * d <= ident.rank:
            raise CalibrationError(f"{len(fit)} measurements give {len(fit) * d} equations, not more than the "
                                   f"{ident.rank} parameter combinations they should determine: measure more "
                                   "configurations")
    sel = ident.selected
    inliers = np.arange(len(fit))
    outliers_fit: np.ndarray = np.array([], dtype=np.intp)
    z = x1[sel].copy()
    if loss == "huber":  # from the linear fit, a robust one whose scale follows the residuals' spread
        for _ in range(3):
            r = _residuals(em, Q[fit], meas_fit, _full(x0, sel, z), rotation_weight)
            scale = _robust_sigma(r)
            z, n, status = _solve(em, Q[fit], meas_fit, x0, sel, z, rotation_weight, "huber", 1.345 * scale)
            nfev += n
        r = _residuals(em, Q[fit], meas_fit, _full(x0, sel, z), rotation_weight)
        scale = _robust_sigma(r)
        outliers_fit = np.flatnonzero(np.sum(r * r, axis=1) > scale ** 2 * chi2.ppf(1 - OUTLIER_PROBABILITY, d))
        inliers = np.setdiff1d(np.arange(len(fit)), outliers_fit)
        if len(inliers) * d <= ident.rank:
            raise CalibrationError("after leaving out the outliers too few measurements remain")
    z, n, status = _solve(em, Q[fit][inliers], meas_fit[inliers], x0, sel, z, rotation_weight, "linear", 1.0)
    nfev += n
    x = _full(x0, sel, z)
    identified, prior_w = sel, None
    if prior is not None:  # MAP from the plain fit: every parameter, the joints' held by the prior
        r = _residuals(em, Q[fit][inliers], meas_fit[inliers], x, rotation_weight).reshape(-1)
        noise = prior.noise if prior.noise is not None else np.sqrt(float(r @ r) / max(len(r) - len(sel), 1))
        prior_w = noise * prior.weights(em)
        sel = np.arange(len(x0))
        z, n, status = _solve(em, Q[fit][inliers], meas_fit[inliers], x0, sel, x.copy(), rotation_weight, "linear",
                              1.0, prior_w)
        nfev += n
        x = z
    if not np.all(np.isfinite(x)) or np.max(np.abs(em.corrections(Q[fit], x - x0))) > MAX_CORRECTION:
        raise CalibrationError(f"the fit diverged (a parameter moved by more than {MAX_CORRECTION:g} m or rad): the "
                               "measurements do not fit this model and link; with base 'fixed' they must be given "
                               "in the root frame, and with a point guess the marker must be on that link")
    r, J = residual_and_jacobian(em, Q[fit][inliers], x, meas_fit[inliers], rotation_weight)
    r = r.reshape(-1)
    Js = J.reshape(-1, len(x))[:, sel]
    if loss == "linear":
        rr = _residuals(em, Q[fit], meas_fit, x, rotation_weight)
        bound = _robust_sigma(rr) ** 2 * chi2.ppf(1 - OUTLIER_PROBABILITY, d)
        outliers_fit = np.flatnonzero(np.sum(rr * rr, axis=1) > bound)

    # 5. statistics (with a prior: the posterior's, the noise its s)
    if prior_w is None:
        s2 = float(r @ r) / max(len(r) - len(sel), 1)
        sv, Vt = singular_values(Js, vectors=True)
    else:
        s2 = noise ** 2
        penalised = np.flatnonzero(prior_w > 0)
        rows = np.zeros((len(penalised), len(sel)))
        rows[np.arange(len(penalised)), penalised] = prior_w[penalised]
        sv, Vt = singular_values(np.vstack([Js, rows]), vectors=True)
    cov = (Vt.T / sv ** 2) @ Vt * s2
    sigma = np.sqrt(np.diag(cov))
    Jid = Js[:, np.searchsorted(sel, identified)]  # the condition of what the data determine
    norms = np.linalg.norm(Jid, axis=0)
    sv_eq = singular_values(Jid / np.where(norms > 0, norms, 1.0))
    cond = float(sv_eq[0] / sv_eq[-1]) if sv_eq[-1] > 0 else float("inf")
    params = [{"name": em.names[i], "value": float(x[i]), "sigma": float(sigma[k])} for k, i in enumerate(sel)]

    before = residual_and_jacobian(em, Q, x0, data, rotation_weight, want_jacobian=False)[0]
    after = residual_and_jacobian(em, Q, x, data, rotation_weight, want_jacobian=False)[0]
    eb, ea = np.linalg.norm(before[:, :3], axis=1), np.linalg.norm(after[:, :3], axis=1)
    # held-out measurements beyond the same bound (the fit's residual spread) are outliers too
    spread = np.sqrt(s2)
    held_out = held[np.sum(after[held] ** 2, axis=1) > spread ** 2 * chi2.ppf(1 - OUTLIER_PROBABILITY, d)]
    held_in = np.setdiff1d(held, held_out)
    used = fit[inliers]
    corrections = {em.joints[k].name: em.origin_correction(k, x) for k in range(len(em.joints))}
    text = corrected_urdf(model, corrections, name or f"{model.name}_calibrated")
    calibrated = parse_urdf(text)
    T_link_tool = em.tool_pose(x)
    rot_b = rot_a = None
    if measure == "pose":
        rot_b = float(np.sqrt(np.mean(np.sum(before[used, 3:] ** 2, axis=1)))) / rotation_weight
        rot_a = float(np.sqrt(np.mean(np.sum(after[used, 3:] ** 2, axis=1)))) / rotation_weight
    return Calibration(
        model=calibrated, source=model.name, link=link, measure=measure, base=em.base_pose(x),
        point=T_link_tool[:3, 3].copy() if measure == "position" else None,
        tool=T_link_tool if measure == "pose" else None,
        identifiable=ident.rank, parameters=params, unidentifiable=ident.unidentifiable,
        condition_number=cond,
        rmse_before=float(np.sqrt(np.mean(eb[used] ** 2))), rmse_after=float(np.sqrt(np.mean(ea[used] ** 2))),
        max_after=float(ea[used].max()), max_before=float(eb[used].max()),
        outliers=sorted(int(i) for i in np.concatenate([fit[outliers_fit], held_out])),
        holdout=[int(i) for i in held],
        holdout_rmse=float(np.sqrt(np.mean(ea[held_in] ** 2))) if held_in.size else None,
        residuals_before=eb, residuals_after=ea, iterations=int(nfev), status=status,
        rotation_rmse_before=rot_b, rotation_rmse_after=rot_a, x=x, error_model=em,
    )


def _full(x0, sel, z):
    x = x0.copy()
    x[sel] = z
    return x


def _residuals(em, Q, meas, x, w):
    return residual_and_jacobian(em, Q, x, meas, w, want_jacobian=False)[0]


def _robust_sigma(r: np.ndarray) -> float:
    """Per-component standard deviation of residuals (n, d), from their median absolute deviation."""
    return max(1.4826 * float(np.median(np.abs(r - np.median(r, axis=0)))), 1e-12)


def _solve(em, Q, meas, x0, sel, z0, w, loss, f_scale, prior_w=None):
    """The parameters ``sel`` fitted from ``z0`` (the others held at ``x0``); ``prior_w`` (p,): rows
    ``prior_w_i (x_i - x0_i)`` appended for the parameters of positive weight (a Gaussian prior)."""
    pw = None if prior_w is None else prior_w[sel]
    pen = np.array([], dtype=np.intp) if pw is None else np.flatnonzero(pw > 0)
    prior_rows = np.zeros((len(pen), len(sel)))
    prior_rows[np.arange(len(pen)), pen] = [] if pw is None else pw[pen]

    def fun(z):
        cancel.check()  # a cancelled or timed-out request stops here (kinematics.engine.cancel)
        r = _residuals(em, Q, meas, _full(x0, sel, z), w).reshape(-1)
        return r if pw is None else np.concatenate([r, pw[pen] * (z[pen] - x0[sel][pen])])

    def jac(z):
        cancel.check()  # the Jacobian of every measurement is the larger part of each step
        _, J = residual_and_jacobian(em, Q, _full(x0, sel, z), meas, w)
        J = J.reshape(-1, len(x0))[:, sel]
        return J if pw is None else np.vstack([J, prior_rows])

    method = "lm" if loss == "linear" else "trf"
    try:
        res = least_squares(fun, z0, jac=jac, method=method, loss=loss, f_scale=f_scale, x_scale="jac",
                            xtol=1e-12, ftol=1e-12, gtol=1e-12, max_nfev=MAX_EVALUATIONS)
    except ValueError as exc:  # scipy refuses shapes it cannot solve
        raise KinematicsError(f"the calibration fit failed: {exc}") from None
    return res.x, int(res.nfev), str(res.message)
