"""Closed forms (sympy) of a model's chain or of a symbolic DH table, and numeric task vectors.

``POST /models/{id}/symbolic`` and ``POST /symbolic/dh`` answer ``A_i``, ``T``, Jacobians and
task vectors in LaTeX, text, Python or C (:func:`kinematics.symbolic`); the derivation runs
in a worker process stopped after ``KIN_SYMBOLIC_TIMEOUT`` seconds (or the request's shorter
``timeout``): 503 ``time-budget-exceeded`` naming the setting (or the field) and its limit, as every
time budget, suggesting ``simplify: false``; or as soon as the client disconnects (``app.heavy``).
``POST /models/{id}/task`` gives ``r = (p, phi)`` and the analytic Jacobian ``J_r`` numerically
(:func:`kinematics.task`).
"""

from __future__ import annotations

from fastapi import APIRouter, Body, Depends, Request

from kinematics import usecases

from ..adapter import budget, error_responses, one_or_all
from ..deps import ModelId, RegistryDep, SettingsDep, require_read_key
from ..heavy import run_heavy
from ..schemas import (SYMBOLIC_DH_EXAMPLES, SYMBOLIC_EXAMPLES, SymbolicDHRequest, SymbolicRequest,
                       SymbolicResponse, TaskRequest, TaskResponse)

router = APIRouter(tags=["closed forms"], dependencies=[Depends(require_read_key)])

_ERRORS = error_responses({422: "invalid input, or no closed form",
                           503: "over the time limit KIN_SYMBOLIC_TIMEOUT (or the request's timeout), or the time "
                                "budget KIN_REQUEST_TIMEOUT (time-budget-exceeded)"}, statuses=(404,))

#: the setting that bounds a derivation, as its time-budget problem names it
SETTING = "KIN_SYMBOLIC_TIMEOUT"


def _timeout(settings, requested: float | None) -> tuple[float, str]:
    """The derivation's time limit and where it comes from: the setting, or the request's shorter ``timeout``."""
    limit = settings.symbolic_timeout
    if requested is None or float(requested) >= limit:
        return limit, SETTING
    return float(requested), "timeout"


def _options(req, settings) -> dict:
    timeout, setting = _timeout(settings, req.timeout)
    return dict(what=req.what, fmt=req.format, simplify=req.simplify, representation=req.representation,
                components=req.components, variables=req.variables, prefix=req.prefix,
                timeout=timeout, timeout_setting=setting)


@router.post("/models/{model_id}/symbolic", response_model=SymbolicResponse, response_model_exclude_none=True,
             responses=_ERRORS)
async def symbolic(model_id: ModelId, request: Request, registry: RegistryDep, settings: SettingsDep,
                   req: SymbolicRequest = Body(openapi_examples=SYMBOLIC_EXAMPLES)) -> dict:
    """Closed forms of the chain from the root to `tip`: the factors `A_i`, `T(q)`, the Jacobians
    (`local_world_aligned`, `world`; 6 x n, linear rows first) and task vectors `r(q)`, `J_r = dr/dq`.

    Joint variables `q1..qn` follow the chain (`joint_variables` names their joints). For a DH
    preset or DH-built model the factors are the table's DH matrices. Formats: `latex` (the textbooks'
    `c_{12}`, `s_{1}`), `text` (strings `sympy.sympify` reads), `python` (a numpy module, batched),
    `c` (C99 functions such as `void fk(const double *q, double *T)`).
    """
    rec = registry.get(model_id)
    answer = await run_heavy(request, lambda: usecases.symbolic(rec.model, tip=req.tip, dh_table=rec.dh_table,
                                                           **_options(req, settings)), waits=True)
    return {"model": rec.id, **answer.output}


@router.post("/symbolic/dh", response_model=SymbolicResponse, response_model_exclude_none=True, responses=_ERRORS)
async def symbolic_dh(request: Request, settings: SettingsDep,
                      req: SymbolicDHRequest = Body(openapi_examples=SYMBOLIC_DH_EXAMPLES)) -> dict:
    """Closed forms of a DH table whose entries may be parameter names or expressions (`"a1"`,
    `"-d4"`, `"pi/2"`); nothing is registered. `parameters` lists the symbols (the order of `p` in C)."""
    answer = await run_heavy(request, lambda: usecases.symbolic_dh(req.table, **_options(req, settings)), waits=True)
    return {"model": None, **answer.output}


@router.post("/models/{model_id}/task", response_model=TaskResponse, responses=_ERRORS)
def task(model_id: ModelId, req: TaskRequest, registry: RegistryDep, settings: SettingsDep) -> dict:
    """Task vectors `r = (p, phi)` of `link` and analytic Jacobians `J_r = dr/dq = blockdiag(I, E(phi)^-1) J`
    (J: the geometric Jacobian, local_world_aligned). At a singularity of the representation (Euler
    angles at their gimbal lock, ...) the answer is 422 `representation-singularity`."""
    rec = registry.get(model_id)
    answer = usecases.task(req.to_query(rec.model, budget(settings)), req.q, representation=req.representation,
                           components=req.components)
    one = one_or_all(answer.is_batch)
    return {"model": rec.id, "link": answer.link, "representation": answer.representation.name,
            "components": list(answer.representation.labels), "joint_names": list(rec.model.joint_names),
            "r": one(answer.r.tolist()), "J_r": one(answer.J_r.tolist()), "out_of_limits": one(answer.out_of_limits())}
