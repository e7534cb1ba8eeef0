"""Schemathesis hooks of the live conformance test (``SCHEMATHESIS_HOOKS=tests.app.schemathesis_hooks``).

Four checks are registered, each run *instead of* a built-in one (the test excludes those):

:func:`positive_data_acceptance_semantic` replaces ``positive_data_acceptance`` (ST202). The built-in one fails every schema-valid request that is
not answered 2xx/401/403/404/409/429. Part of this service's validation cannot be written in
an OpenAPI document, because it depends on *which* model the path names or on what a document
says, not on the shape of the request:

* ``q`` must hold ``dof`` values of *that* model (``invalid-joint-values``), names must be its
  joints; a chain must exist (``no-dh-form``, ``invalid-symbolic-request``), ...;
* a URDF / xacro / MJCF / DH / PoE / axes body must describe a robot (``invalid-urdf``,
  ``invalid-dh-table``, ...), which JSON Schema cannot check of an XML string or a matrix;
* budgets (``result-too-large``, ``ik-work-too-large``, ``verify-too-large``) bound products of
  sizes (targets x restarts x iterations, configurations x links x 16) or one field given another
  against the server's settings; a time budget (503 ``time-budget-exceeded``: a closed form over
  ``KIN_SYMBOLIC_TIMEOUT``) depends on the machine. The budgets that bound one field alone
  (``samples`` and ``max_workspace_samples``, batches and ``max_batch``) are in the document
  (``maximum``, ``maxItems``), so their refusals are not excused here.

Those answers are 413/422/503 problems whose ``type`` is one of the library's problem types
(:data:`app.errors.KINEMATICS_ERRORS`, the budgets). Only they are accepted here; every other
refusal of a schema-valid request is still a failure -- in particular the app's own
``validation-error`` (which would mean the document and the server disagree about the shape
of a request), ``unsupported-media-type``, ``bad-request`` and ``invalid-npy``.

:func:`resource_availability_of_models` replaces ``ensure_resource_availability`` (ST302, stateful
phase: a 404 right after ``POST /models`` created a model means the model is not available). A
404 whose problem is ``unknown-link`` *names the created model* (``model``: its id): the model
was found and a link named in the body (``tip``, ``link``, ``links``) is not one of its links --
an example written for the UR5 sent to a two-link arm. That answer does not show the created
resource missing, so it is not counted; every other 404 still is.
"""

from __future__ import annotations

import schemathesis
from schemathesis.checks import not_a_server_error
from schemathesis.specs.openapi.checks import (ensure_resource_availability, negative_data_rejection,
                                               positive_data_acceptance)

from app.errors import KINEMATICS_ERRORS, PROBLEM_TYPE_PREFIX

BUDGETS = ("verify", "result", "ik-work")
#: the budgets the document states (``maximum``, ``maxItems``): their refusals of schema-invalid requests
LIMIT_TYPES = frozenset(PROBLEM_TYPE_PREFIX + f"{budget}-too-large"
                        for budget in ("batch", "workspace-samples", "trajectory-rate", "trajectory-samples"))
#: problem types that depend on the model or on the content of a description (see the docstring)
SEMANTIC_TYPES = frozenset(
    {PROBLEM_TYPE_PREFIX + slug for _, status, slug, _ in KINEMATICS_ERRORS if status == 422}
    | {PROBLEM_TYPE_PREFIX + f"{budget}-too-large" for budget in BUDGETS}
    # a trajectory's samples follow from its duration (the path and the limits); its rate is over the settings' limit
    | {PROBLEM_TYPE_PREFIX + "trajectory-rate-too-large", PROBLEM_TYPE_PREFIX + "trajectory-samples-too-large"}
    | {PROBLEM_TYPE_PREFIX + "model-too-large", PROBLEM_TYPE_PREFIX + "expansion-too-large",
       PROBLEM_TYPE_PREFIX + "archive-too-large", PROBLEM_TYPE_PREFIX + "time-budget-exceeded"}
)


def _problem_type(response) -> str | None:
    if response.status_code not in (413, 422, 503):
        return None
    try:
        body = response.json()
    except Exception:
        return None
    return body.get("type") if isinstance(body, dict) else None


@schemathesis.check
def negative_data_rejection_of_limits(ctx, response, case):
    """``negative_data_rejection`` (ST201), except that a request over a limit the document states from
    the server's settings (``samples`` over its ``maximum``, a batch over its ``maxItems``) is refused
    with the budget's own answer, 413 ``workspace-samples-too-large`` / ``batch-too-large`` naming the
    setting and its limit, rather than a generic 422: a refusal all the same."""
    if response.status_code == 413 and _problem_type(response) in LIMIT_TYPES:
        return None
    return negative_data_rejection(ctx, response, case)


@schemathesis.check
def not_a_server_error_but_time_budgets(ctx, response, case):
    """``not_a_server_error`` (ST101), except the documented 503 ``time-budget-exceeded``: a request
    (a closed form over ``KIN_SYMBOLIC_TIMEOUT`` or its own shorter ``timeout``, heavy work over
    ``KIN_REQUEST_TIMEOUT``) that ran out of its time budget, answered as the operation documents it."""
    if response.status_code == 503 and _problem_type(response) == PROBLEM_TYPE_PREFIX + "time-budget-exceeded":
        return None
    return not_a_server_error(ctx, response, case)


@schemathesis.check
def positive_data_acceptance_semantic(ctx, response, case):
    """``positive_data_acceptance``, except for the model- and content-dependent refusals above."""
    if _problem_type(response) in SEMANTIC_TYPES:
        return None
    return positive_data_acceptance(ctx, response, case)


@schemathesis.check
def resource_availability_of_models(ctx, response, case):
    """``ensure_resource_availability``, except for a 404 that found the model and not a link of it."""
    if response.status_code == 404:
        try:
            body = response.json()
        except Exception:
            body = None
        if (isinstance(body, dict) and body.get("type") == PROBLEM_TYPE_PREFIX + "unknown-link"
                and body.get("model") in (case.path_parameters or {}).values()):
            return None
    return ensure_resource_availability(ctx, response, case)
