"""Calibration: ``POST /models/{id}/calibrate`` and ``POST /models/{id}/calibration/poses``.

``calibrate`` takes the measurements as JSON (a ``CalibrationRequest``) or as a CSV body
(``Content-Type: text/csv``: joint columns by name, then ``x,y,z`` or ``x,y,z,qw,qx,qy,qz``;
the other fields as query parameters, ``point`` as ``x,y,z``). The calibrated model is
registered like an upload (the corrected URDF, under its content's id) and the answer is 201
with its id; bad measurements are a 422 naming the problem and register nothing.
"""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Depends, Request

from kinematics import usecases
from kinematics.io.pose_records import pose_record

from ..adapter import budget, error_responses, execute, parse_point, read_request, request_body_doc
from ..deps import ModelId, RegistryDep, SettingsDep, media_type, read_body, require_read_key, require_write_key
from ..errors import ProblemError
from ..responses import FastJSONResponse
from ..schemas import (CALIBRATION_EXAMPLES, CALIBRATION_POSES_EXAMPLES, CalibrationPosesRequest,
                       CalibrationPosesResponse, CalibrationRequest, CalibrationResponse, Problem)

router = APIRouter(tags=["calibration"])

_ERRORS = error_responses({
    404: "unknown model or link",
    413: "body or measurements over the limits",
    415: "unsupported content type (JSON, or text/csv for the measurements)",
    422: "measurements a calibration cannot use (too few, NaN, a q of the wrong length, all configurations equal), "
         "or invalid options",
})
_CSV_MEDIA = ("text/csv", "application/csv")
#: what a CSV calibration takes as query parameters, and how each is read
_CSV_OPTIONS = {"link": str, "point": parse_point, "parameters": str, "base": str, "tool": str, "loss": str,
                "holdout": float, "random_seed": int, "rotation_weight": float, "name": str, "verify": None}


def _csv_options(request: Request) -> dict:
    params = dict(request.query_params)
    unknown = sorted(set(params) - set(_CSV_OPTIONS))
    if unknown:
        raise ProblemError(400, f"unknown query parameter(s) {', '.join(unknown)}; a CSV calibration takes "
                                f"{', '.join(sorted(_CSV_OPTIONS))}", slug="invalid-query")
    out = {}
    for key, value in params.items():
        read = _CSV_OPTIONS[key]
        if read is None:  # a flag
            if value.lower() not in ("true", "false"):
                raise ProblemError(422, f"{key}: {value!r}; give true or false", slug="validation-error", field=key)
            out[key] = value.lower() == "true"
            continue
        try:
            out[key] = read(value)
        except ValueError:
            raise ProblemError(422, f"{key}: {value!r} is not a number", slug="validation-error", field=key) from None
    return out


async def read_calibration_request(request: Request, settings: SettingsDep) -> tuple[CalibrationRequest, bytes | None]:
    """The request, and the CSV body when the measurements came as CSV (then ``measurements`` is empty)."""
    if media_type(request) in _CSV_MEDIA:
        body = await read_body(request, settings.max_request_bytes, "request body")
        options = _csv_options(request)
        # validated by the same schema (one placeholder measurement stands for the CSV's rows)
        req = CalibrationRequest.model_validate({**options, "measurements": [{"q": [0.0], "position": [0.0] * 3}]})
        return req.model_copy(update={"measurements": None}), body
    req = await read_request(request, settings, CalibrationRequest, empty=('{"link": ..., "measurements": [...]}',
                                                                           "measurements"), batch=None)
    return req, None


_BODY_DOC = request_body_doc("CalibrationRequest", CALIBRATION_EXAMPLES)
_BODY_DOC["requestBody"]["content"]["text/csv"] = {
    "schema": {"type": "string", "description": "a header naming every joint, then x,y,z or x,y,z,qw,qx,qy,qz; "
                                                "one row per measurement; the options as query parameters"}}


@router.post("/models/{model_id}/calibrate", response_model=CalibrationResponse, status_code=201,
             responses={**_ERRORS, 401: {"model": Problem, "description": "API key required"},
                        507: {"model": Problem, "description": "the data directory cannot be written"}},
             dependencies=[Depends(require_write_key)], openapi_extra=_BODY_DOC)
async def calibrate(model_id: ModelId, body: Annotated[tuple, Depends(read_calibration_request)], request: Request,
                    registry: RegistryDep, settings: SettingsDep):
    """Calibrate the chain to `link` from what a measuring device saw: a model of the robot as built.

    Every joint origin on the path (3 translations, 3 rotations) and zero offset, the device frame
    (`base`, no guess needed: the fit starts from a point-set registration of the nominal model's
    predictions) and the marker point or tool are fitted by Levenberg-Marquardt on the parameter
    combinations the data determine (`identifiable`; the others are listed in `unidentifiable` with the
    reason). The calibrated URDF is registered like an upload: `model` is its id, and every endpoint
    works on it; FK of it with the returned `base` and `point` / `tool` predicts what the device measures.
    """
    req, csv = body
    return await execute(request, _calibrate, model_id, req, csv, registry, settings)


def _calibrate(model_id: str, req: CalibrationRequest, csv: bytes | None, registry, settings):
    rec = registry.get(model_id)
    query = req.to_query(rec.model, budget(settings), base=None, tool=None)
    measurements = None
    if req.measurements is not None:
        measurements = [{k: v for k, v in m.items() if v is not None} for m in
                        (m if isinstance(m, dict) else m.model_dump() for m in req.measurements)]
    cal = usecases.calibrate(query, measurements, csv=csv, name=req.name, **req.fit_fields())
    new, _ = registry.add_urdf(cal.urdf.encode("utf-8"), name=cal.model.name)
    out = {
        "model": new.id, "from": rec.id, "link": cal.link, "measure": cal.measure, "base": pose_record(cal.base),
        "point": None if cal.point is None else [float(v) for v in cal.point],
        "tool": None if cal.tool is None else pose_record(cal.tool),
        "identifiable": cal.identifiable, "parameters": cal.parameters, "unidentifiable": cal.unidentifiable,
        "condition_number": cal.condition_number, "rmse_before": cal.rmse_before, "rmse_after": cal.rmse_after,
        "max_before": cal.max_before, "max_after": cal.max_after, "rotation_rmse_before": cal.rotation_rmse_before,
        "rotation_rmse_after": cal.rotation_rmse_after, "outliers": cal.outliers, "holdout": cal.holdout,
        "holdout_rmse": cal.holdout_rmse, "iterations": cal.iterations,
        "residuals": {"before": cal.residuals_before.tolist(), "after": cal.residuals_after.tolist()},
        "verification": cal.verification.as_dict() if cal.verification is not None else None,
    }
    return FastJSONResponse(out, status_code=201, headers={"Location": f"/models/{new.id}"})


async def read_poses_request(request: Request, settings: SettingsDep) -> CalibrationPosesRequest:
    return await read_request(request, settings, CalibrationPosesRequest, empty=('{"link": ..., "n": 30}', "n"),
                              batch=None)


@router.post("/models/{model_id}/calibration/poses", response_model=CalibrationPosesResponse, responses=_ERRORS,
             dependencies=[Depends(require_read_key)],
             openapi_extra=request_body_doc("CalibrationPosesRequest", CALIBRATION_POSES_EXAMPLES))
async def calibration_poses(model_id: ModelId, req: Annotated[CalibrationPosesRequest, Depends(read_poses_request)],
                            request: Request, registry: RegistryDep, settings: SettingsDep):
    """`n` configurations within the limits where measuring determines the calibration best.

    From a pool of random configurations (`random_seed`), chosen greedily and then by exchange to
    maximise the D-optimality of the identification Jacobian (`log_det`); `measure` also gives the
    condition number and the same figures for `n` random configurations of the pool.
    """
    return await execute(request, _poses, model_id, req, registry, settings)


def _poses(model_id: str, req: CalibrationPosesRequest, registry, settings):
    rec = registry.get(model_id)
    choice = usecases.calibration_poses(req.to_query(rec.model, budget(settings)), req.n, measure=req.measure,
                                        random_seed=req.random_seed, parameters=req.parameters)
    return FastJSONResponse({
        "joint_names": list(rec.model.joint_names), "q": choice.q.tolist(),
        "measure": {"criterion": choice.criterion, "log_det": choice.log_det,
                    "condition_number": choice.condition_number, "identifiable": choice.identifiable,
                    "random_log_det": choice.random_log_det, "random_condition_number": choice.random_condition_number},
    })
