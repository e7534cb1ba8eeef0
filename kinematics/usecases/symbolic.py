"""Closed forms (sympy, in a worker process) of a model's chain or of a symbolic DH table."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Sequence

from ..engine.poe import require_one_dof
from ..errors import SymbolicTimeoutError
from ..model.robot import RobotModel

#: what a symbolic request may ask for, and its formats (kinematics.algorithms.symbolic)
SYMBOLIC_WHAT = ("transforms", "jacobian", "task")
SYMBOLIC_FORMATS = ("latex", "python", "c", "text")
#: time limit of a symbolic request when the caller gives none (seconds)
DEFAULT_SYMBOLIC_TIMEOUT = 60.0


@dataclass(frozen=True, eq=False)
class SymbolicAnswer:
    """Closed forms: ``forms`` (:class:`~kinematics.algorithms.symbolic.ClosedForms`, sympy
    matrices) and ``output`` (them rendered in the requested format, a JSON-ready dict)."""

    forms: Any
    output: dict[str, Any]

    @property
    def seconds(self) -> float:
        return float(self.forms.seconds)


def _task_layout(what: Sequence[str], representation: str | None, components: Sequence[str] | None):
    if "task" not in what:
        return None
    from ..algorithms.task import task_representation

    return task_representation(representation or "rpy", components)


def _derive(chain, what, fmt, simplify, representation, components, prefix, timeout,
            timeout_setting: str | None = None) -> SymbolicAnswer:
    from ..algorithms import symbolic as _symbolic

    what = tuple(dict.fromkeys(what))  # each entry once: a repeated one is computed once
    try:
        forms, output = _symbolic.derive(chain, what=what, simplify=simplify, fmt=fmt, prefix=prefix, timeout=timeout,
                                         task=_task_layout(what, representation, components))
    except SymbolicTimeoutError as exc:
        if timeout_setting is None:
            raise
        raise SymbolicTimeoutError(str(exc), timeout=exc.timeout, setting=timeout_setting) from None
    output["seconds"] = round(forms.seconds, 6)
    return SymbolicAnswer(forms, output)


def symbolic(model: RobotModel, *, tip: str | None = None, dh_table: dict | None = None,
             what: Sequence[str] = ("transforms",), fmt: str = "latex", simplify: bool = True,
             representation: str | None = None, components: Sequence[str] | None = None, variables: str = "q",
             prefix: str = "", timeout: float | None = DEFAULT_SYMBOLIC_TIMEOUT,
             timeout_setting: str | None = None) -> SymbolicAnswer:
    """Closed forms of the chain from the model's root to ``tip`` (default: the only leaf link).

    ``dh_table``: the table the model was built from (a DH preset or DH-built model); then, for
    its tool (``tip`` None or ``"tool"``), the factors are the table's DH matrices. ``what``:
    ``transforms``, ``jacobian``, ``task`` (``representation`` and ``components`` of
    :mod:`kinematics.algorithms.task`); ``fmt``: ``latex``, ``python``, ``c``, ``text``;
    ``variables``: ``q`` (q1..qn) or ``names`` (the joint names); ``timeout`` (seconds, None:
    unbounded) bounds the whole derivation (:class:`~kinematics.errors.SymbolicTimeoutError`, a
    :class:`~kinematics.errors.TimeBudgetError` naming ``timeout_setting`` when given: the setting the
    caller took the limit from). Repeated entries of ``what`` are derived once.
    """
    from ..algorithms import symbolic as _symbolic
    from ..io.dh_table import table_from_dict

    require_one_dof(model, "closed forms")
    if dh_table is not None and tip in (None, "tool"):
        chain = _symbolic.chain_from_table(table_from_dict(dh_table), variables=variables)
    else:
        chain = _symbolic.chain_from_model(model, tip=tip, variables=variables)
    return _derive(chain, what, fmt, simplify, representation, components, prefix, timeout, timeout_setting)


def symbolic_dh(table: dict, *, what: Sequence[str] = ("transforms",), fmt: str = "latex", simplify: bool = True,
                representation: str | None = None, components: Sequence[str] | None = None, variables: str = "q",
                prefix: str = "", timeout: float | None = DEFAULT_SYMBOLIC_TIMEOUT,
                timeout_setting: str | None = None) -> SymbolicAnswer:
    """Closed forms of a DH table whose entries may be parameter names or expressions
    (``{"a": "a1", "d": "-d4", "alpha": "pi/2"}``; :func:`~kinematics.algorithms.symbolic.symbolic_table_from_dict`);
    options as :func:`symbolic`. No model is built."""
    from ..algorithms import symbolic as _symbolic

    chain = _symbolic.chain_from_table(_symbolic.symbolic_table_from_dict(table), variables=variables)
    return _derive(chain, what, fmt, simplify, representation, components, prefix, timeout, timeout_setting)
