"""The formats of closed forms: LaTeX in the textbooks' compact notation, text sympy reads back,
a numpy-only Python module and a C99 translation unit (:func:`render`)."""

from __future__ import annotations

import re
from typing import Any

import numpy as np
import sympy as sp
from sympy.printing.c import C99CodePrinter
from sympy.printing.numpy import NumPyPrinter

from ...errors import SymbolicError
from .chains import SymbolicChain
from .composition import ClosedForms

FORMATS = ("latex", "python", "c", "text")


def _compact_names(chain: SymbolicChain, expr_atoms) -> dict[sp.Expr, sp.Symbol]:
    """``cos(q1 + q2 + q4) -> c_{124}``, ``sin(q1) -> s_{1}`` (the textbooks' notation), for
    sines and cosines of sums of joint variables (``q`` style only)."""
    index = {v: i + 1 for i, v in enumerate(chain.variables)}
    if not all(v.name == f"q{i}" for v, i in index.items()):
        return {}
    out = {}
    for atom in expr_atoms:
        terms = sp.Add.make_args(atom.args[0])
        if all(t in index for t in terms):
            ids = sorted(index[t] for t in terms)
            sub = ("," if max(ids) > 9 else "").join(str(i) for i in ids)
            out[atom] = sp.Symbol(("c" if isinstance(atom, sp.cos) else "s") + "_{" + sub + "}")
    return out


def _latex_symbol_names(chain: SymbolicChain) -> dict[sp.Symbol, str]:
    names = {}
    for v in chain.variables:
        if not re.match(r"^q\d+$", v.name):
            names[v] = r"\mathrm{" + v.name.replace("_", r"\_") + "}"
    return names


def latex_matrix(M: sp.Matrix, chain: SymbolicChain) -> str:
    """LaTeX of a matrix or vector in the textbooks' compact notation (``c_{12}``, ``s_{1}``)."""
    compact = _compact_names(chain, M.atoms(sp.sin, sp.cos))
    return sp.latex(M.xreplace(compact), mat_str="bmatrix", mat_delim="",
                    symbol_names=_latex_symbol_names(chain))


def _text_matrix(M: sp.Matrix) -> list[list[str]]:
    return [[sp.sstr(M[i, j]) for j in range(M.cols)] for i in range(M.rows)]


def _variables_info(forms: ClosedForms) -> list[dict[str, str]]:
    return [{"symbol": v.name, "joint": j} for v, j in zip(forms.chain.variables, forms.chain.joints)]


def _matrices(forms: ClosedForms) -> dict[str, Any]:
    out: dict[str, Any] = {"T": forms.T, "A": forms.A, "base": forms.base, "tool": forms.tool}
    if forms.jacobians:
        out["jacobian"] = dict(forms.jacobians)
    if forms.task is not None:
        out["r"] = forms.task.r
        out["J_r"] = forms.task.J_r
    return out


def render(forms: ClosedForms, fmt: str, prefix: str = "") -> dict[str, Any]:
    """The closed forms in ``fmt``: ``latex`` (a LaTeX ``bmatrix`` per matrix), ``text``
    (nested lists of strings ``sympy.sympify`` reads), ``python`` or ``c`` (``code``: a module or
    a translation unit with the functions :func:`python_code` / :func:`c_code` describe).

    Always: ``joint_variables`` (``[{symbol, joint}]``, the order of q), ``parameters`` (names, the
    order of ``p`` in C), ``tip``, ``root``, ``simplified``; for a task, ``components``.
    """
    if fmt not in FORMATS:
        raise SymbolicError(f"format: {fmt!r} is not one of {list(FORMATS)}")
    out: dict[str, Any] = {
        "joint_variables": _variables_info(forms), "parameters": [p.name for p in forms.chain.parameters],
        "root": forms.chain.root, "tip": forms.chain.tip, "frames": list(forms.chain.frames),
        "simplified": forms.simplified, "format": fmt,
    }
    if forms.task is not None:
        out["representation"] = forms.task.representation.name
        out["components"] = list(forms.task.representation.labels)
    if fmt in ("latex", "text"):
        conv = (lambda M: latex_matrix(M, forms.chain)) if fmt == "latex" else _text_matrix
        for key, value in _matrices(forms).items():
            if isinstance(value, list):
                out[key] = [conv(M) for M in value]
            elif isinstance(value, dict):
                out[key] = {k: conv(M) for k, M in value.items()}
            else:
                out[key] = conv(value)
    elif fmt == "python":
        out["code"], out["functions"] = python_code(forms)
    else:
        out["code"], out["functions"] = c_code(forms, prefix)
    return out


_PY_RESERVED = {"q", "p", "numpy", "math", "out", "single", "T", "J"}


def _code_symbols(forms: ClosedForms) -> dict[sp.Symbol, sp.Symbol]:
    """Joint variables as ``q1 .. qn`` in generated code, whatever their display names."""
    return {v: sp.Symbol(f"q{i + 1}", real=True) for i, v in enumerate(forms.chain.variables)}


def _functions(forms: ClosedForms) -> list[tuple[str, str, sp.Matrix, tuple[int, ...]]]:
    """(name, what it returns, matrix, shape) of every generated function."""
    n = forms.chain.dof
    fs = [("fk", "T_world_tip = base A_1 ... A_n tool", forms.T, (4, 4))]
    frames = sp.Matrix.vstack(*forms.frames) if forms.frames else sp.zeros(0, 4)
    fs.append(("frames", f"T_world_frame_i for i = 1..{n}", frames, (n, 4, 4)))
    for ref, J in forms.jacobians.items():
        fs.append((f"jacobian_{ref}", f"6 x {n} Jacobian ({ref}, linear rows first)", J, (6, n)))
    if forms.task is not None:
        m = forms.task.r.rows
        labels = ", ".join(forms.task.representation.labels)
        fs.append(("task", f"task vector r = ({labels})", forms.task.r, (m,)))
        fs.append(("task_jacobian", f"{m} x {n} analytic Jacobian dr/dq", forms.task.J_r, (m, n)))
    return fs


def _check_code_names(forms: ClosedForms, reserved: set[str]) -> None:
    import keyword

    for p in forms.chain.parameters:
        if p.name in reserved or keyword.iskeyword(p.name) or p.name.startswith("_"):
            raise SymbolicError(f"parameter {p.name!r} cannot be a name in generated code; rename it")


def python_code(forms: ClosedForms) -> tuple[str, list[dict[str, str]]]:
    """A Python module (numpy only) with batched functions of the closed forms.

    Each function takes ``q`` (N, n) or (n,) in the order of ``joint_variables`` (and the
    parameters as keyword arguments, scalars or (N,) arrays) and returns (N, ...) arrays (no
    leading N for a single q): ``fk`` (4, 4), ``frames`` (n, 4, 4), ``jacobian_local_world_aligned``
    and ``jacobian_world`` (6, n), ``task`` (m,), ``task_jacobian`` (m, n).
    """
    _check_code_names(forms, _PY_RESERVED)
    chain = forms.chain
    n = chain.dof
    rename = _code_symbols(forms)
    printer = NumPyPrinter({"fully_qualified_modules": True, "inline": True})
    params = [p.name for p in chain.parameters]
    sig = "q" + (", *, " + ", ".join(params) if params else "")
    joints = "\n".join(f"    q{i + 1}: {j}" for i, j in enumerate(chain.joints))
    lines = [
        f'"""Closed forms of {chain.name} from {chain.root!r} to {chain.tip!r}, generated by kinematics',
        f"(kinematics.algorithms.symbolic). Joint variables, the columns of q:\n\n{joints}",
        "",
        ("Parameters (keyword arguments): " + ", ".join(params) if params else "No parameters."),
        '"""',
        "",
        "import numpy",
        "",
    ]
    functions = []
    for name, doc, M, shape in _functions(forms):
        entries = [e.xreplace(rename) for e in M]
        temps, reduced = sp.cse(entries, symbols=sp.numbered_symbols("_t"), order="none")
        lines += [
            "",
            f"def {name}({sig}):",
            f'    """{doc}: shape (N, {", ".join(map(str, shape))}) for q (N, {n}); no N for one q."""',
            "    q = numpy.asarray(q, dtype=float)",
            "    single = q.ndim == 1",
            "    q = numpy.atleast_2d(q)",
            f"    if q.ndim != 2 or q.shape[1] != {n}:",
            f'        raise ValueError(f"q must have {n} columns, got shape {{q.shape}}")',
        ]
        lines += [f"    q{i + 1} = q[:, {i}]" for i in range(n)]
        lines += [f"    {s} = {printer.doprint(e)}" for s, e in temps]
        lines.append(f"    out = numpy.zeros((q.shape[0], {', '.join(map(str, shape))}))")
        for flat, e in enumerate(reduced):
            if e != 0:
                idx = np.unravel_index(flat, shape) if shape else ()
                lines.append(f"    out[:, {', '.join(map(str, idx))}] = {printer.doprint(e)}")
        lines.append("    return out[0] if single else out")
        lines.append("")
        functions.append({"name": name, "signature": f"{name}({sig})", "returns": doc})
    return "\n".join(lines).rstrip() + "\n", functions


_C_RESERVED = {"q", "p", "T", "J", "r", "out", "M_PI", "main"} | {
    "auto", "break", "case", "char", "const", "continue", "default", "do", "double", "else", "enum", "extern",
    "float", "for", "goto", "if", "inline", "int", "long", "register", "restrict", "return", "short", "signed",
    "sizeof", "static", "struct", "switch", "typedef", "union", "unsigned", "void", "volatile", "while",
    "y0", "y1", "yn", "j0", "j1", "jn", "fabs", "round", "trunc"}


def c_code(forms: ClosedForms, prefix: str = "") -> tuple[str, list[dict[str, str]]]:
    """A C99 translation unit (``math.h`` only) with one function per closed form:

    ``void <prefix>fk(const double *q, double *T)`` (``T``: 16 doubles, row-major), ``frames``
    (n x 16), ``jacobian_local_world_aligned`` and ``jacobian_world`` (``J``: 6 x n, row-major),
    ``task`` (m) and ``task_jacobian`` (m x n). With parameters every function takes
    ``const double *p`` after ``q`` (in the order of ``parameters``). Compile with ``cc -O2 -c``
    (link ``-lm``).
    """
    if not re.match(r"^[A-Za-z_]?[A-Za-z0-9_]*$", prefix or "") or len(prefix) > 64:
        raise SymbolicError(f"prefix: {prefix!r} is not a C identifier prefix")
    _check_code_names(forms, _C_RESERVED)
    chain = forms.chain
    n = chain.dof
    rename = _code_symbols(forms)
    printer = C99CodePrinter()
    params = [p.name for p in chain.parameters]
    pdecl = "const double *p, " if params else ""
    joints = "\n".join(f" *   q[{i}] = q{i + 1}: {j}" for i, j in enumerate(chain.joints))
    lines = [
        f"/* Closed forms of {chain.name} from '{chain.root}' to '{chain.tip}', generated by kinematics",
        " * (kinematics.algorithms.symbolic). Matrices are row-major; Jacobians have the linear rows first.",
        " * Joint values:",
        joints,
    ]
    if params:
        lines.append(" * Parameters: " + ", ".join(f"p[{i}] = {name}" for i, name in enumerate(params)))
    lines += [" */", "#include <math.h>", "#ifndef M_PI", "#define M_PI 3.14159265358979323846", "#endif", ""]
    functions = []
    for name, doc, M, shape in _functions(forms):
        out_name = {"fk": "T", "frames": "T"}.get(name, "J" if "jacobian" in name else "r")
        entries = [e.xreplace(rename) for e in M]
        temps, reduced = sp.cse(entries, symbols=sp.numbered_symbols("_t"), order="none")
        signature = f"void {prefix}{name}(const double *q, {pdecl}double *{out_name})"
        size = int(np.prod(shape)) if shape else 1
        lines += [f"/* {doc}: {size} doubles */", signature, "{"]
        lines += [f"    const double q{i + 1} = q[{i}];" for i in range(n)]
        lines += [f"    const double {name_} = p[{i}];" for i, name_ in enumerate(params)]
        lines += [f"    const double {s} = {printer.doprint(e)};" for s, e in temps]
        lines += [f"    {out_name}[{k}] = {printer.doprint(e)};" for k, e in enumerate(reduced)]
        lines += ["}", ""]
        functions.append({"name": prefix + name, "signature": signature, "returns": doc})
    return re.sub(r"\n\n\n+", "\n\n", "\n".join(lines)).rstrip() + "\n", functions
