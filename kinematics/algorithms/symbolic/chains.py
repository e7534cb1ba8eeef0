"""Serial chains of closed forms: the steps from a model's root to a tip link (URDF joints), or
of a DH table (standard or modified), with their joint variables and parameters (see the
package docstring for the frames)."""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Sequence

import numpy as np
import sympy as sp

from ...errors import SymbolicError, UnknownLinkError, did_you_mean
from ...model.robot import RobotModel
from .parser import MAX_SYMBOLIC_JOINTS, SymbolicDHRow, exact_angle, exact_number

VARIABLE_STYLES = ("q", "names")


@dataclass(frozen=True, eq=False)
class Step:
    """One joint of a chain: the constant origin ``[rotation, translation]``, then the motion
    (``revolute``: about ``axis`` by ``value``; ``prismatic``: along ``axis`` by ``value``)."""

    kind: str  # fixed | revolute | prismatic
    rotation: sp.Matrix
    translation: sp.Matrix
    axis: sp.Matrix | None = None
    value: sp.Expr | None = None
    joint: str | None = None


@dataclass(frozen=True, eq=False)
class SymbolicChain:
    """A serial chain ready for :func:`closed_forms`.

    ``variables`` are the joint variables (symbols), ``joints`` the joint each one is (the
    order of q on the chain), ``parameters`` the other symbols. ``factors[i]`` are the steps of
    ``A_{i+1}``; ``base`` and ``tool`` constant steps; ``frames`` the names of frames 1..n.
    """

    name: str
    source: str  # dh-standard | dh-modified | urdf
    variables: tuple[sp.Symbol, ...]
    joints: tuple[str, ...]
    parameters: tuple[sp.Symbol, ...]
    base: tuple[Step, ...]
    factors: tuple[tuple[Step, ...], ...]
    tool: tuple[Step, ...]
    root: str
    tip: str
    frames: tuple[str, ...]

    @property
    def dof(self) -> int:
        return len(self.variables)


def _unit(axis) -> sp.Matrix:
    return sp.Matrix([exact_number(v) for v in axis])


def _rot_x(a: sp.Expr) -> sp.Matrix:
    c, s = sp.cos(a), sp.sin(a)
    return sp.Matrix([[1, 0, 0], [0, c, -s], [0, s, c]])


def _rot_z(a: sp.Expr) -> sp.Matrix:
    c, s = sp.cos(a), sp.sin(a)
    return sp.Matrix([[c, -s, 0], [s, c, 0], [0, 0, 1]])


_Z = sp.Matrix([0, 0, 1])
_ZERO3 = sp.zeros(3, 1)


def _variables(names: Sequence[str], style: str) -> tuple[sp.Symbol, ...]:
    if style not in VARIABLE_STYLES:
        raise SymbolicError(f"variables: {style!r} is not one of {list(VARIABLE_STYLES)}")
    if style == "q":
        return tuple(sp.Symbol(f"q{i + 1}", real=True) for i in range(len(names)))
    out, seen = [], {}
    for name in names:
        ident = re.sub(r"[^A-Za-z0-9_]", "_", name)
        if not ident or ident[0].isdigit():
            ident = "j_" + ident
        if ident in seen:
            raise SymbolicError(f"variables: joints {seen[ident]!r} and {name!r} give the same symbol {ident!r}; "
                                "use variables 'q'")
        try:
            parsed = sp.sympify(ident)
        except (sp.SympifyError, SyntaxError, TypeError, AttributeError):
            parsed = None
        if not (isinstance(parsed, sp.Symbol) and parsed.name == ident):
            raise SymbolicError(f"variables: joint {name!r} cannot be a symbol name ({ident!r} means something else "
                                "to sympy); use variables 'q'")
        seen[ident] = name
        out.append(sp.Symbol(ident, real=True))
    return tuple(out)


def _check_parameters(parameters: Sequence[sp.Symbol], variables: Sequence[sp.Symbol]) -> None:
    clash = {s.name for s in parameters} & {v.name for v in variables}
    if clash:
        raise SymbolicError(f"parameter {sorted(clash)[0]!r} has the name of a joint variable; rename it")


def _const_step(T: np.ndarray) -> Step:
    T = np.asarray(T, dtype=float)
    return Step("fixed", sp.Matrix(3, 3, [exact_number(v) for v in T[:3, :3].ravel()]),
                sp.Matrix([exact_number(v) for v in T[:3, 3]]))


def _is_identity(step: Step) -> bool:
    return step.rotation == sp.eye(3) and step.translation == _ZERO3


def chain_from_table(table, variables: str = "q") -> SymbolicChain:
    """The chain of a DH table (:class:`~kinematics.io.dh_table.DHTable` or :class:`SymbolicDHTable`):
    frame i is DH frame i, ``A_i`` the DH matrix of row i, ``T = base A_1 ... A_n tool``."""
    if len(table.rows) > MAX_SYMBOLIC_JOINTS:
        raise SymbolicError(f"the table has {len(table.rows)} rows; closed forms are derived for at most "
                            f"{MAX_SYMBOLIC_JOINTS}")
    degrees = getattr(table, "angles", "radians") == "degrees"
    qs = _variables(table.joint_names, variables)
    factors = []
    params: set[sp.Symbol] = set()
    for row, q in zip(table.rows, qs):
        if isinstance(row, SymbolicDHRow):
            a, alpha, d, theta = row.a, row.alpha, row.d, row.theta
        else:
            a, d = exact_number(row.a), exact_number(row.d)
            alpha, theta = exact_angle(row.alpha, degrees), exact_angle(row.theta, degrees)
        for e in (a, alpha, d, theta):
            params |= e.free_symbols
        revolute = row.type == "revolute"
        if table.convention == "standard":  # Rot_z(theta) Trans_z(d) Trans_x(a) Rot_x(alpha)
            if revolute:
                steps = (Step("revolute", sp.eye(3), _ZERO3, _Z, q + theta, row.name),
                         Step("fixed", _rot_x(alpha), sp.Matrix([a, 0, d])))
            else:
                steps = (Step("prismatic", _rot_z(theta), _ZERO3, _Z, q + d, row.name),
                         Step("fixed", _rot_x(alpha), sp.Matrix([a, 0, 0])))
        else:  # Rot_x(alpha) Trans_x(a) Rot_z(theta) Trans_z(d)
            if revolute:
                steps = (Step("revolute", _rot_x(alpha), sp.Matrix([a, 0, 0]), _Z, q + theta, row.name),
                         Step("fixed", sp.eye(3), sp.Matrix([0, 0, d])))
            else:
                steps = (Step("prismatic", _rot_x(alpha) * _rot_z(theta), sp.Matrix([a, 0, 0]), _Z, q + d, row.name),)
        factors.append(steps)
    parameters = tuple(sorted(params, key=lambda s: s.name))
    _check_parameters(parameters, qs)
    base = _const_step(table.base)
    tool = _const_step(table.tool)
    n = len(table.rows)
    return SymbolicChain(
        name=table.name, source=f"dh-{table.convention}", variables=qs, joints=tuple(table.joint_names),
        parameters=parameters, base=() if _is_identity(base) else (base,), factors=tuple(factors),
        tool=() if _is_identity(tool) else (tool,), root="world", tip="tool",
        frames=tuple(f"frame_{i}" for i in range(1, n + 1)))


def chain_tip(model: RobotModel, tip: str | None) -> str:
    """``tip``, or the model's only leaf link (a tree needs a tip)."""
    if tip is None:
        if len(model.leaf_links) != 1:
            shown = ", ".join(repr(l) for l in model.leaf_links[:8]) + (" ..." if len(model.leaf_links) > 8 else "")
            raise SymbolicError(f"model {model.name!r} has {len(model.leaf_links)} leaf links ({shown}); "
                                "choose the tip of the chain")
        return model.leaf_links[0]
    if tip != model.root and tip not in model.parent_joint:
        raise UnknownLinkError(f"model {model.name!r} has no link {tip!r}"
                               + did_you_mean(tip, model.links, "link names"))
    return tip


def chain_from_model(model: RobotModel, tip: str | None = None, variables: str = "q") -> SymbolicChain:
    """The chain from ``model.root`` to ``tip`` (default: the only leaf link), from the URDF joints.

    Joint variables: the independent joints that move the chain, in chain order (a mimic
    joint's value is ``multiplier * q_leader + offset``).
    """
    tip = chain_tip(model, tip)
    path = model.path_joints(tip)
    drivers: list[str] = []
    for j in path:
        if j.moving:
            resolved = model.resolve_mimic(j)
            leader = j.name if resolved is None else resolved[0]
            if leader not in drivers:
                drivers.append(leader)
    if not drivers:
        raise SymbolicError(f"the chain from {model.root!r} to {tip!r} has no moving joint")
    if len(drivers) > MAX_SYMBOLIC_JOINTS:
        raise SymbolicError(f"the chain to {tip!r} has {len(drivers)} joint variables; closed forms are derived "
                            f"for at most {MAX_SYMBOLIC_JOINTS}")
    qs = _variables(drivers, variables)
    symbol = dict(zip(drivers, qs))
    factors, current, frames = [], [], []
    for j in path:
        origin = _const_step(j.origin)
        if not j.moving:
            current.append(origin)
            continue
        resolved = model.resolve_mimic(j)
        if resolved is None:
            value = symbol[j.name]
        else:
            leader, mult, off = resolved
            value = exact_number(mult) * symbol[leader] + (exact_angle(off) if j.type != "prismatic" else exact_number(off))
        kind = "prismatic" if j.type == "prismatic" else "revolute"
        current.append(Step(kind, origin.rotation, origin.translation, _unit(j.axis), value, j.name))
        factors.append(tuple(current))
        frames.append(j.child)
        current = []
    return SymbolicChain(
        name=model.name, source="urdf", variables=qs, joints=tuple(drivers), parameters=(), base=(),
        factors=tuple(factors), tool=tuple(current), root=model.root, tip=tip, frames=tuple(frames))
