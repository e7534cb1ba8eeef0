"""Kinematic calibration of the query's link: :func:`calibrate` and :func:`calibration_poses`.

The query gives the model, the ``link`` the marker or tool is on, its ``point`` (the marker's
guess; for poses ``tool``, the tool frame's guess) and the budget (measurements count as
configurations). What calibration estimates -- the device frame and the marker or tool -- are
its own arguments ``base`` and ``tool`` (``"estimate"`` or ``"fixed"``), so the query's ``base``
is refused. scipy (the ``calibration`` extra) is imported when these are called, not before.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..engine.poe import require_one_dof
from ..errors import CalibrationError, JointValueError, KinematicsError
from ..io.measurements import parse_measurements_csv
from ..io.poses import base_poses, pose_list
from ..model.robot import RobotModel
from .query import Query, joint_batch


def calibration_measurements(query: Query | RobotModel, measurements: Any = None, *, csv: str | bytes | None = None,
                             **options: Any) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
    """``(Q (N, dof), positions (N, 3) or None, poses (N, 4, 4) or None)`` of a request's measurements:
    a list of ``{"q": .., "position": [x, y, z]}`` or ``{"q": .., "pose": <pose>}`` (q as a vector or a
    name map; every entry of one kind), or a CSV text (:mod:`kinematics.io.measurements`)."""
    query = Query.of(query, **options)
    model = query.robot
    if csv is not None:  # its rows counted from the bytes, before any is parsed
        query.budget.check("max_measurements", _csv_rows(csv), what="measurements (CSV rows)", field="measurements")
        m = parse_measurements_csv(csv, model.joint_names)
        query.budget.check_batch(len(m.q))
        return m.q, m.positions, m.poses
    if not isinstance(measurements, (list, tuple)) or not measurements:
        raise CalibrationError("measurements: give a non-empty list of {q, position} or {q, pose}")
    query.budget.check("max_measurements", len(measurements), what="measurements", field="measurements")
    kinds = set()
    for i, m in enumerate(measurements):
        if not isinstance(m, dict) or "q" not in m or len({"position", "pose"} & set(m)) != 1:
            raise CalibrationError(f"measurements[{i}]: expected {{\"q\", \"position\"}} or {{\"q\", \"pose\"}}")
        kinds.add("position" if "position" in m else "pose")
    if len(kinds) > 1:
        raise CalibrationError("measurements: every measurement must be a position, or every one a pose (not a mix)")
    try:
        Q, _ = joint_batch(model, [m["q"] for m in measurements], query.budget)
    except JointValueError as exc:
        raise CalibrationError(f"measurements: {exc}", field="q") from None
    if "position" in kinds:
        try:
            P = np.array([m["position"] for m in measurements], dtype=float)
        except (TypeError, ValueError):
            raise CalibrationError("measurements: every position must be [x, y, z] (numbers)") from None
        if P.shape != (len(Q), 3):
            raise CalibrationError(f"measurements: every position must be [x, y, z]; got shape {P.shape}")
        return Q, P, None
    T, _ = pose_list([m["pose"] for m in measurements], "measurements.pose")
    return Q, None, T


def _csv_rows(csv: str | bytes) -> int:
    """The rows of a CSV text after its header line (blank lines counted too: an upper bound)."""
    nl = b"\n" if isinstance(csv, bytes) else "\n"
    lines = csv.count(nl) + (0 if csv.endswith(nl) or not csv else 1)
    return max(0, lines - 1)


def _calibration_query(query: Query) -> tuple[RobotModel, str]:
    if query.base is not None:
        raise KinematicsError("base: a calibration estimates the device frame; give calibrate(..., base='fixed') "
                              "or base=<pose> to hold it instead")
    model = query.robot
    link = query.frame_link()
    require_one_dof(model, "calibration")
    return model, link


#: the fields of :class:`~kinematics.algorithms.calibration.FitOptions`, given to :func:`calibrate` as keywords
FIT_FIELDS = ("parameters", "base", "tool", "loss", "holdout", "random_seed", "rotation_weight", "compliance", "prior")


def calibrate(query: Query | RobotModel, measurements: Any = None, *, csv: str | bytes | None = None,
              fit=None, name: str | None = None, **options: Any):
    """Calibrate the query's ``link`` from measurements (see :func:`calibration_measurements`):
    a :class:`~kinematics.algorithms.calibration.Calibration` whose ``model`` is the calibrated model,
    ``base`` its ``T_device_root`` and ``point`` / ``tool`` the marker / tool on the link.

    How it fits is ``fit`` (:class:`~kinematics.algorithms.calibration.FitOptions`, built once) or
    its fields as keywords (:data:`FIT_FIELDS`; the other keywords are the query's):
    ``base``: ``"estimate"`` (no guess needed), ``"fixed"`` (the device frame is the root frame) or a
    pose ``T_device_root`` (held there); ``tool``: ``"estimate"`` or ``"fixed"`` (at the query's
    ``point`` / ``tool``); ``parameters``: ``"full"`` or ``"joint_offsets"``; ``loss``: ``"linear"`` or
    ``"huber"``; ``holdout``: the fraction kept out of the fit; ``rotation_weight``: metres per radian
    of a rotation residual; ``name``: the calibrated robot's name; ``compliance``: a
    :class:`~kinematics.algorithms.calibration.Compliance` (joint compliance under gravity estimated
    too); ``prior``: a :class:`~kinematics.algorithms.calibration.Prior` (MAP estimate of the joint
    parameters); either may be given as ``True`` (the defaults) or a map of its fields (a request's JSON). With the query's ``verify``, the
    calibrated model's FK is compared with Pinocchio's on the measured configurations
    (``verification`` of the answer)."""
    from ..algorithms.calibration import Compliance, FitOptions, Prior
    from ..algorithms.calibration import calibrate as _calibrate

    fields = {k: options.pop(k) for k in FIT_FIELDS if k in options}
    for key, cls in (("compliance", Compliance), ("prior", Prior)):
        if key in fields:
            fields[key] = _option(cls, fields[key], key)
    if not isinstance(fields.get("base", "estimate"), str):
        fields["base"] = base_poses(fields["base"], 1)[0]
    fit, _ = FitOptions.split(fit, fields)

    query = Query.of(query, **options)
    model, link = _calibration_query(query)
    Q, P, T = calibration_measurements(query, measurements, csv=csv)
    T_tool = query.T_tool
    guess = None if T_tool is None else T_tool[:3, 3]
    cal = _calibrate(model, link, Q, positions=P, poses=T, point=guess,
                     tool_guess=T_tool if T is not None else None, fit=fit, name=name)
    if query.verify:
        from ..verify.pinocchio import REFERENCE_NAME, compare_fk
        from .query import Verification

        query.budget.check_verify(len(Q))
        dev = compare_fk(cal.model, Q, [link])
        cal.verification = Verification(REFERENCE_NAME, max_position_error=dev.max_position_error,
                                        max_rotation_error=dev.max_rotation_error)
    return cal


def _option(cls, value, name: str):
    """An option object from itself, ``True`` (its defaults), a map of its fields, or None / False (none)."""
    if value is None or value is False:
        return None
    if value is True:
        return cls()
    if isinstance(value, dict):
        try:
            return cls(**{k: (tuple(v) if isinstance(v, list) else v) for k, v in value.items() if v is not None})
        except TypeError as exc:
            raise CalibrationError(f"{name}: {exc}", field=name) from None
    if isinstance(value, cls):
        return value
    raise CalibrationError(f"{name}: give true, a map of its fields or a {cls.__name__}", field=name)


def calibration_poses(query: Query | RobotModel, n: int, *, measure: str = "position", random_seed: int = 0,
                      parameters: str = "full", **options: Any):
    """``n`` configurations within the limits that best determine the calibration of the query's
    ``link`` (D-optimal; ``point``: where the marker will be, default 5 cm off the link origin on
    every axis): a :class:`~kinematics.algorithms.calibration.PoseChoice`."""
    from ..algorithms.calibration import select_poses

    query = Query.of(query, **options)
    model, link = _calibration_query(query)
    guess = (0.05, 0.05, 0.05) if query.T_tool is None else query.T_tool[:3, 3]
    return select_poses(model, link, n, measure, random_seed, point=guess, parameters=parameters)
