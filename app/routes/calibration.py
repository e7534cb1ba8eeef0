"""Calibration: ``POST /models/{id}/calibrate`` and ``POST /models/{id}/calibration/poses``.

``calibrate`` takes the measurements as JSON (a ``CalibrationRequest``) or as a CSV body
(``Content-Type: text/csv``: joint columns by name, then ``x,y,z`` or ``x,y,z,qw,qx,qy,qz``;
the other fields as query parameters, ``point`` as ``x,y,z``). The calibrated model is
registered like an upload (the corrected URDF, under its content's id) and the answer is 201
with its id; bad measurements are a 422 naming the problem and register nothing.
"""

from __future__ import annotations

from typing import Annotated, Any

import numpy as np
from fastapi import APIRouter, Depends, Request, Response

from kinematics import api
from kinematics.spatial.transforms import pose_components

from ..calibration_schemas import (CalibrationPosesRequest, CalibrationPosesResponse, CalibrationRequest,
                                   CalibrationResponse)
from ..deps import ModelId, RegistryDep, SettingsDep, media_type, read_body, require_read_key, require_write_key
from ..errors import ProblemError
from ..heavy import run_heavy
from ..responses import FastJSONResponse
from ..schemas import Problem

router = APIRouter(tags=["calibration"])

_ERRORS = {
    400: {"model": Problem, "description": "malformed body"},
    404: {"model": Problem, "description": "unknown model or link"},
    413: {"model": Problem, "description": "body or measurements over the limits"},
    415: {"model": Problem, "description": "unsupported content type"},
    422: {"model": Problem, "description": "measurements a calibration cannot use (too few, NaN, a q of the wrong "
                                           "length, all configurations equal), or invalid options"},
    503: {"model": Problem, "description": "over the time budget KIN_REQUEST_TIMEOUT (time-budget-exceeded)"},
}

_CSV_OPTIONS = {"link", "point", "parameters", "base", "tool", "loss", "holdout", "random_seed", "rotation_weight", "name"}


async def read_calibration_request(request: Request, settings: SettingsDep) -> dict[str, Any]:
    body = await read_body(request, settings.max_request_bytes, "request body")
    kind = media_type(request)
    if kind in ("text/csv", "application/csv"):
        params = dict(request.query_params)
        unknown = sorted(set(params) - _CSV_OPTIONS)
        if unknown:
            raise ProblemError(400, f"unknown query parameter(s) {', '.join(unknown)}; a CSV calibration takes "
                                    f"{', '.join(sorted(_CSV_OPTIONS))}", slug="invalid-query")
        if "point" in params:
            try:
                params["point"] = [float(v) for v in params["point"].split(",")]
            except ValueError:
                raise ProblemError(422, "point: expected x,y,z", slug="invalid-calibration-data") from None
        for key, cast in (("holdout", float), ("rotation_weight", float), ("random_seed", int)):
            if key in params:
                try:
                    params[key] = cast(params[key])
                except ValueError:
                    raise ProblemError(422, f"{key}: {params[key]!r} is not a number", slug="invalid-calibration-data") from None
        params["measurements"] = [{"q": [0.0], "position": [0.0, 0.0, 0.0]}]  # the schema's shape; replaced below
        options = CalibrationRequest.model_validate(params).model_dump()
        options["measurements"] = None
        options["csv"] = body
        return options
    if kind not in ("application/json", ""):
        raise ProblemError(415, f"Content-Type {kind!r} is not supported: send application/json or text/csv",
                           slug="unsupported-media-type")
    options = CalibrationRequest.model_validate_json(body or b"{}").model_dump()
    options["csv"] = None
    return options


def _pose(T: np.ndarray) -> dict:
    c = pose_components(T)
    w, x, y, z = (float(v) for v in c["quaternion"])
    return {"position": [float(v) for v in c["position"]], "quaternion": {"w": w, "x": x, "y": y, "z": z}}


@router.post("/models/{model_id}/calibrate", response_model=CalibrationResponse, status_code=201,
             responses={**_ERRORS, 401: {"model": Problem, "description": "API key required"},
                        507: {"model": Problem, "description": "the data directory cannot be written"}},
             dependencies=[Depends(require_write_key)],
             openapi_extra={"requestBody": {"required": True, "content": {
                 "application/json": {"schema": {"$ref": "#/components/schemas/CalibrationRequest"}, "example": {
                     "link": "tool0", "loss": "huber", "holdout": 0.2, "measurements": [
                         {"q": [0.12, -1.31, 1.77, -0.42, 1.61, 0.05], "position": [-0.612, 0.3051, 0.1183]}]}},
                 "text/csv": {"schema": {"type": "string"},
                              "example": "shoulder_pan_joint,...,wrist_3_joint,x,y,z\n0.1,...,0.3,0.41,0.12,0.33\n"}}}})
async def calibrate(model_id: ModelId, options: Annotated[dict, Depends(read_calibration_request)], request: Request,
                    registry: RegistryDep, settings: SettingsDep):
    """Calibrate the chain to `link` from what a measuring device saw: a model of the robot as built.

    Every joint origin on the path (3 translations, 3 rotations) and zero offset, the device frame
    (`base`, no guess needed: the fit starts from a point-set registration of the nominal model's
    predictions) and the marker point or tool are fitted by Levenberg-Marquardt on the parameter
    combinations the data determine (`identifiable`; the others are listed in `unidentifiable` with the
    reason). The calibrated URDF is registered like an upload: `model` is its id, and every endpoint
    works on it; FK of it with the returned `base` and `point` / `tool` predicts what the device measures.
    """
    return await run_heavy(request, _calibrate, model_id, options, registry, settings)


def _calibrate(model_id: str, options: dict, registry, settings):
    rec = registry.get(model_id)
    measurements = options.pop("measurements")
    if measurements is not None:
        measurements = [{k: v for k, v in m.items() if v is not None} for m in measurements]
    cal = api.calibrate(rec.model, options.pop("link"), measurements, budget=api.Budget(max_batch=settings.max_batch),
                        **options)
    new, _ = registry.add_urdf(cal.urdf.encode("utf-8"), name=cal.model.name)
    body = {
        "model": new.id, "from": rec.id, "link": cal.link, "measure": cal.measure, "base": _pose(cal.base),
        "point": None if cal.point is None else [float(v) for v in cal.point],
        "tool": None if cal.tool is None else _pose(cal.tool),
        "identifiable": cal.identifiable, "parameters": cal.parameters, "unidentifiable": cal.unidentifiable,
        "condition_number": cal.condition_number, "rmse_before": cal.rmse_before, "rmse_after": cal.rmse_after,
        "max_after": cal.max_after, "rotation_rmse_before": cal.rotation_rmse_before,
        "rotation_rmse_after": cal.rotation_rmse_after, "outliers": cal.outliers, "holdout": cal.holdout,
        "holdout_rmse": cal.holdout_rmse, "iterations": cal.iterations,
        "residuals": {"before": cal.residuals_before.tolist(), "after": cal.residuals_after.tolist()},
    }
    return FastJSONResponse(body, status_code=201, headers={"Location": f"/models/{new.id}"})


async def read_poses_request(request: Request, settings: SettingsDep) -> dict[str, Any]:
    body = await read_body(request, settings.max_request_bytes, "request body")
    kind = media_type(request)
    if kind not in ("application/json", ""):
        raise ProblemError(415, f"Content-Type {kind!r} is not supported: send application/json",
                           slug="unsupported-media-type")
    return CalibrationPosesRequest.model_validate_json(body or b"{}").model_dump()


@router.post("/models/{model_id}/calibration/poses", response_model=CalibrationPosesResponse, responses=_ERRORS,
             dependencies=[Depends(require_read_key)],
             openapi_extra={"requestBody": {"required": True, "content": {"application/json": {
                 "schema": {"$ref": "#/components/schemas/CalibrationPosesRequest"},
                 "example": {"link": "tool0", "n": 30, "measure": "position", "random_seed": 0}}}}})
async def calibration_poses(model_id: ModelId, options: Annotated[dict, Depends(read_poses_request)],
                            request: Request, registry: RegistryDep):
    """`n` configurations within the limits where measuring determines the calibration best.

    From a pool of random configurations (`random_seed`), chosen greedily and then by exchange to
    maximise the D-optimality of the identification Jacobian (`log_det`); `measure` also gives the
    condition number and the same figures for `n` random configurations of the pool.
    """
    return await run_heavy(request, _poses, model_id, options, registry)


def _poses(model_id: str, options: dict, registry):
    rec = registry.get(model_id)
    choice = api.calibration_poses(rec.model, options.pop("link"), options.pop("n"), **options)
    return FastJSONResponse({
        "joint_names": list(rec.model.joint_names), "q": choice.q.tolist(),
        "measure": {"criterion": choice.criterion, "log_det": choice.log_det,
                    "condition_number": choice.condition_number, "identifiable": choice.identifiable,
                    "random_log_det": choice.random_log_det, "random_condition_number": choice.random_condition_number},
    })
