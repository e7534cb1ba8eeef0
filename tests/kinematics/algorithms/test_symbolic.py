"""Closed forms (kinematics.algorithms.symbolic): the textbook examples come out equal, every DH
preset and the UR5 / Panda chains agree with the numeric FK and Jacobians, and so do the
generated Python and C; the time limit; the symbolic table's validation."""

from __future__ import annotations

import ctypes
import shutil
import subprocess
import time
import types

import numpy as np
import pytest
import sympy as sp

from kinematics import api
from kinematics.algorithms import symbolic as sym
from kinematics.algorithms.task import task_representation
from kinematics.errors import DHError, SymbolicError, SymbolicTimeoutError
from kinematics.io import default_catalogue, parse_urdf
from kinematics.io.dh_table import load_table
from tests.paths import FIXTURES

q1, q2, q3, q4, q5, q6 = sp.symbols("q1:7", real=True)
c, s = sp.cos, sp.sin


def equal(a: sp.Matrix, b: sp.Matrix) -> bool:
    return a.shape == b.shape and all(sp.simplify(x - y) == 0 for x, y in zip(a, b))


def forms_of(joints, what=("transforms", "jacobian"), simplify=True, rep=None, **table):
    t = sym.symbolic_table_from_dict({"joints": joints, **table})
    return sym.closed_forms(sym.chain_from_table(t), what, simplify=simplify,
                            task=task_representation(rep) if rep else None)


def row(kind, a, alpha, d, theta):
    return {"type": kind, "a": a, "alpha": alpha, "d": d, "theta": theta}


# ------------------------------------------------------------------- the textbook examples
def test_rpr_example_T2_0_and_T3_0_equal_the_textbook():
    """Spong-convention RPR example: T2_0 and T3_0 of its MATLAB session (d2 is the joint variable q2)."""
    d1, d2, d3 = sp.symbols("d1 d2 d3", real=True)
    f = forms_of([row("R", 0, 90, "d1", 0), row("P", 0, 0, 0, 0), row("R", 0, 0, "d3", 0)], angles="degrees")
    at = {q2: d2}
    T2_0 = sp.Matrix([[c(q1), 0, s(q1), s(q1) * d2], [s(q1), 0, -c(q1), -c(q1) * d2], [0, 1, 0, d1], [0, 0, 0, 1]])
    T3_0 = sp.Matrix([[c(q1) * c(q3), -c(q1) * s(q3), s(q1), s(q1) * (d2 + d3)],
                      [s(q1) * c(q3), -s(q1) * s(q3), -c(q1), -c(q1) * (d2 + d3)],
                      [s(q3), c(q3), 0, d1], [0, 0, 0, 1]])
    assert equal(f.frames[1].subs(at), T2_0)
    assert equal(f.T.subs(at), T3_0)
    assert equal((f.A[0] * f.A[1]).subs(at), T2_0)
    assert [p.name for p in f.chain.parameters] == ["d1", "d3"]


def test_planar_2r_T_and_J():
    """De Luca's 2R planar arm: p = (l1 c1 + l2 c12, l1 s1 + l2 s12), phi = q1 + q2; J of the tip."""
    l1, l2 = sp.symbols("l1 l2", real=True)
    f = forms_of([row("R", "l1", 0, 0, 0), row("R", "l2", 0, 0, 0)])
    T = sp.Matrix([[c(q1 + q2), -s(q1 + q2), 0, l1 * c(q1) + l2 * c(q1 + q2)],
                   [s(q1 + q2), c(q1 + q2), 0, l1 * s(q1) + l2 * s(q1 + q2)], [0, 0, 1, 0], [0, 0, 0, 1]])
    J = sp.Matrix([[-l1 * s(q1) - l2 * s(q1 + q2), -l2 * s(q1 + q2)], [l1 * c(q1) + l2 * c(q1 + q2), l2 * c(q1 + q2)],
                   [0, 0], [0, 0], [0, 0], [1, 1]])
    assert equal(f.T, T)
    assert equal(f.jacobians["local_world_aligned"], J)
    assert f.T[0, 3] == l1 * c(q1) + l2 * c(q1 + q2)  # the sum of angles, as De Luca writes it
    # the space Jacobian's column 2 is the screw of joint 2: (-w x r, w) with r = (l1 c1, l1 s1, 0)
    assert equal(f.jacobians["world"][:, 1], sp.Matrix([l1 * s(q1), -l1 * c(q1), 0, 0, 0, 1]))


def test_scara_T04_and_task_vector():
    """De Luca's SCARA: T_04 and r(q) = (a1 c1 + a2 c12, a1 s1 + a2 s12, d1 + q3 + d4, q1 + q2 + q4), d4 < 0."""
    a1, a2, d1, d4 = sp.symbols("a1 a2 d1 d4", real=True)
    f = forms_of([row("R", "a1", 0, "d1", 0), row("R", "a2", 0, 0, 0), row("P", 0, 0, 0, 0),
                  row("R", 0, "pi", "d4", 0)], what=("transforms", "task"), rep="scara")
    T04 = sp.Matrix([[c(q1 + q2 + q4), s(q1 + q2 + q4), 0, a1 * c(q1) + a2 * c(q1 + q2)],
                     [s(q1 + q2 + q4), -c(q1 + q2 + q4), 0, a1 * s(q1) + a2 * s(q1 + q2)],
                     [0, 0, -1, d1 + q3 + d4], [0, 0, 0, 1]])
    r = sp.Matrix([a1 * c(q1) + a2 * c(q1 + q2), a1 * s(q1) + a2 * s(q1 + q2), d1 + q3 + d4, q1 + q2 + q4])
    assert equal(f.T, T04)
    assert f.task.r == r  # alpha_z = atan2(s124, c124) is q1 + q2 + q4 itself
    assert equal(f.task.J_r, r.jacobian([q1, q2, q3, q4]))
    assert f.task.representation.labels == ("px", "py", "pz", "alpha_z")
    # with the preset's numbers, d4 = -0.1 < 0: the quill's tip is below the shoulder plane
    preset = sym.closed_forms(sym.chain_from_table(load_table(default_catalogue().entry("scara").path)),
                              ("transforms",))
    assert preset.T[2, 3] == q3 + sp.Rational(3, 10)


def test_stanford_arm_equals_spong():
    """The Stanford arm (Spong's table: d1 = 0, theta3 = 0) against its textbook closed form."""
    d2, d3, d6 = sp.symbols("d2 d3 d6", real=True)
    f = forms_of([row("R", 0, -90, 0, 0), row("R", 0, 90, "d2", 0), row("P", 0, 0, 0, 0),
                  row("R", 0, -90, 0, 0), row("R", 0, 90, 0, 0), row("R", 0, 0, "d6", 0)], angles="degrees")
    c1, s1, c2, s2, c4, s4, c5, s5, c6, s6 = (fn(q) for q in (q1, q2, q4, q5, q6) for fn in (c, s))
    r11 = c1 * (c2 * (c4 * c5 * c6 - s4 * s6) - s2 * s5 * c6) - s1 * (s4 * c5 * c6 + c4 * s6)
    r21 = s1 * (c2 * (c4 * c5 * c6 - s4 * s6) - s2 * s5 * c6) + c1 * (s4 * c5 * c6 + c4 * s6)
    r31 = -s2 * (c4 * c5 * c6 - s4 * s6) - c2 * s5 * c6
    r12 = c1 * (-c2 * (c4 * c5 * s6 + s4 * c6) + s2 * s5 * s6) - s1 * (-s4 * c5 * s6 + c4 * c6)
    r22 = s1 * (-c2 * (c4 * c5 * s6 + s4 * c6) + s2 * s5 * s6) + c1 * (-s4 * c5 * s6 + c4 * c6)
    r32 = s2 * (c4 * c5 * s6 + s4 * c6) + c2 * s5 * s6
    r13 = c1 * (c2 * c4 * s5 + s2 * c5) - s1 * s4 * s5
    r23 = s1 * (c2 * c4 * s5 + s2 * c5) + c1 * s4 * s5
    r33 = -s2 * c4 * s5 + c2 * c5
    dx = c1 * s2 * q3 - s1 * d2 + d6 * (c1 * c2 * c4 * s5 + c1 * c5 * s2 - s1 * s4 * s5)
    dy = s1 * s2 * q3 + c1 * d2 + d6 * (c1 * s4 * s5 + c2 * c4 * s1 * s5 + c5 * s1 * s2)
    dz = c2 * q3 + d6 * (c5 * c2 - c4 * s2 * s5)
    T = sp.Matrix([[r11, r12, r13, dx], [r21, r22, r23, dy], [r31, r32, r33, dz], [0, 0, 0, 1]])
    assert equal(f.T, T)


def test_latex_uses_the_compact_notation():
    f = forms_of([row("R", "a1", 0, "d1", 0), row("R", "a2", 0, 0, 0), row("P", 0, 0, 0, 0),
                  row("R", 0, "pi", "d4", 0)], what=("transforms",))
    tex = sym.latex_matrix(f.T, f.chain)
    assert tex.startswith(r"\begin{bmatrix}c_{124} & s_{124} & 0 & a_{1} c_{1} + a_{2} c_{12}")
    assert r"d_{1} + d_{4} + q_{3}" in tex


def test_text_format_reads_back_with_sympify():
    f = forms_of([row("R", 0, 90, "d1", 0), row("P", 0, 0, 0, 0), row("R", 0, 0, "d3", 0)], angles="degrees")
    out = sym.render(f, "text")
    back = sp.Matrix([[sp.sympify(e) for e in r] for r in out["T"]])
    assert equal(back.subs({sp.Symbol(n): sp.Symbol(n, real=True) for n in ("q1", "q2", "q3", "d1", "d3")}), f.T)
    assert out["joint_variables"] == [{"symbol": "q1", "joint": "joint_1"}, {"symbol": "q2", "joint": "joint_2"},
                                      {"symbol": "q3", "joint": "joint_3"}]
    assert out["parameters"] == ["d1", "d3"]


# ---------------------------------------------------------------------- agreement with the numeric FK
def _compare(model, chain, tip, forms, rng, n=8):
    idx = [model.q_index[j] for j in chain.joints]
    Q = model.sample_configurations(n, rng, continuous_range=np.pi)
    T = api.fk(model, Q, links=[tip]).poses[:, 0]
    worst = 0.0
    fT = sp.lambdify([chain.variables], forms.T, "numpy")
    worst = max(np.abs(np.array(fT(Q[k, idx]), float) - T[k]).max() for k in range(n))
    for ref, J in forms.jacobians.items():
        Jn = api.jacobian(model, Q, link=tip, reference=ref).jacobians[:, :, idx]
        fJ = sp.lambdify([chain.variables], J, "numpy")
        worst = max(worst, max(np.abs(np.array(fJ(Q[k, idx]), float) - Jn[k]).max() for k in range(n)))
    return worst


PRESETS = [e.id for e in default_catalogue().entries.values() if e.source == "preset"]


@pytest.mark.slow
@pytest.mark.parametrize("preset", PRESETS)
def test_every_dh_preset_agrees_with_fk(preset, rng):
    catalogue = default_catalogue()
    model = catalogue.get(preset)
    chain = sym.chain_from_table(load_table(catalogue.entry(preset).path))
    forms = sym.closed_forms(chain, ("transforms", "jacobian"), simplify=True)
    assert _compare(model, chain, "tool", forms, rng) < 1e-12
    assert not forms.T.atoms(sp.Float)  # the presets' numbers are all simple: exact forms


def test_dh_presets_from_their_urdf_agree_with_fk(rng):
    """The same presets through their generated URDF (motion_i helper links), unsimplified."""
    catalogue = default_catalogue()
    for preset in ("rpr_example", "scara", "stanford_arm", "puma560_modified", "rhino"):
        model = catalogue.get(preset)
        chain = sym.chain_from_model(model)
        forms = sym.closed_forms(chain, ("transforms", "jacobian"), simplify=False)
        assert _compare(model, chain, "tool", forms, rng) < 1e-12, preset


@pytest.mark.parametrize("model_id, tip", [("ur5", "tool0"), ("panda", "panda_hand_tcp")])
def test_ur5_and_panda_closed_forms_agree_with_fk(model_id, tip, rng):
    model = default_catalogue().get(model_id)
    chain = sym.chain_from_model(model, tip)
    start = time.perf_counter()
    forms = sym.closed_forms(chain, ("transforms", "jacobian"), simplify=True)
    seconds = time.perf_counter() - start
    assert _compare(model, chain, tip, forms, rng) < 1e-12
    print(f"{model_id}: simplified T and both Jacobians in {seconds:.2f} s")
    if model_id == "panda":  # the hand's fixed -pi/4 about joint 7's axis joins q7
        assert forms.T.has(sp.cos(q5.func("q7", real=True) + sp.pi / 4))


def test_ur5_keeps_what_its_urdf_says():
    """rpy = 1.57079632679 is not pi/2: the closed form keeps the 4.9e-12 difference (as the
    numeric FK does), while exact values (0.425 -> 17/40) stay exact."""
    forms = sym.closed_forms(sym.chain_from_model(default_catalogue().get("ur5"), "tool0"), ("transforms",))
    floats = [abs(float(f)) for f in forms.T.atoms(sp.Float)]
    assert floats and max(floats) < 1e-11
    assert sp.Rational(17, 40) in forms.T[0, 3].atoms(sp.Rational) or forms.T[0, 3].has(sp.Rational(17, 40))


def test_mimic_joints_and_joint_names_as_variables(rng):
    model = parse_urdf((FIXTURES / "tree_mimic.urdf").read_text())
    for tip in ("right_finger", "head"):  # right_finger_joint mimics left_elbow, on the other branch
        chain = sym.chain_from_model(model, tip, variables="names")
        assert [v.name for v in chain.variables] == [j.replace("-", "_") for j in chain.joints]
        forms = sym.closed_forms(chain, ("transforms", "jacobian"))
        assert _compare(model, chain, tip, forms, rng) < 1e-12
    assert sym.chain_from_model(model, "right_finger").joints == ("torso_joint", "right_shoulder",
                                                                   "right_slide_joint", "left_elbow")


# ---------------------------------------------------------------------- generated code
def _rpr_symbolic():
    return sym.chain_from_table(sym.symbolic_table_from_dict({"angles": "degrees", "joints": [
        row("R", 0, 90, "d1", 0), row("P", 0, 0, 0, 0), row("R", "a3", 0, "d3", 30)]}))


def test_generated_python_is_batched_and_agrees(rng):
    chain = _rpr_symbolic()
    forms = sym.closed_forms(chain, ("transforms", "jacobian", "task"), simplify=True,
                             task=task_representation("zyx"))
    code, functions = sym.python_code(forms)
    assert [f["name"] for f in functions] == ["fk", "frames", "jacobian_local_world_aligned", "jacobian_world",
                                             "task", "task_jacobian"]
    module = types.ModuleType("generated")
    exec(compile(code, "generated", "exec"), module.__dict__)
    Q = rng.uniform(-1, 1, (16, 3))
    params = dict(a3=0.2, d1=0.3, d3=0.1)
    T = module.fk(Q, **params)
    J = module.jacobian_world(Q, **params)
    assert T.shape == (16, 4, 4) and J.shape == (16, 6, 3) and module.fk(Q[0], **params).shape == (4, 4)
    subs = {sp.Symbol(k, real=True): v for k, v in params.items()}
    fT = sp.lambdify([chain.variables], forms.T.subs(subs), "numpy")
    fJ = sp.lambdify([chain.variables], forms.jacobians["world"].subs(subs), "numpy")
    fR = sp.lambdify([chain.variables], forms.task.J_r.subs(subs), "numpy")
    for k in range(16):
        np.testing.assert_allclose(T[k], np.array(fT(Q[k]), float), atol=1e-14)
        np.testing.assert_allclose(J[k], np.array(fJ(Q[k]), float), atol=1e-14)
        np.testing.assert_allclose(module.task_jacobian(Q[k], **params), np.array(fR(Q[k]), float), atol=1e-13)


@pytest.mark.skipif(shutil.which("cc") is None, reason="no C compiler")
@pytest.mark.parametrize("model_id, tip", [("ur5", "tool0"), ("rpr", None)])
def test_generated_c_compiles_and_agrees(model_id, tip, tmp_path, rng):
    if model_id == "rpr":
        chain, p = _rpr_symbolic(), [0.2, 0.3, 0.1]  # a3, d1, d3
        model = api.model_from_description("dh", {"angles": "degrees", "joints": [
            row("R", 0, 90, 0.3, 0), row("P", 0, 0, 0, 0), row("R", 0.2, 0, 0.1, 30)]})[0]
        tip = "tool"
    else:
        model = default_catalogue().get(model_id)
        chain, p = sym.chain_from_model(model, tip), []
    forms = sym.closed_forms(chain, ("transforms", "jacobian"), simplify=True)
    code, functions = sym.c_code(forms, prefix="k_")
    assert functions[0]["signature"] == ("void k_fk(const double *q, const double *p, double *T)" if p
                                         else "void k_fk(const double *q, double *T)")
    (tmp_path / "fk.c").write_text(code)
    subprocess.run(["cc", "-std=c99", "-O1", "-Wall", "-Werror", "-Wno-unused-variable", "-shared", "-fPIC",
                    "-o", str(tmp_path / "fk.so"), str(tmp_path / "fk.c"), "-lm"], check=True, timeout=120)
    lib = ctypes.CDLL(str(tmp_path / "fk.so"))
    n = chain.dof
    Q = model.sample_configurations(8, rng)
    T = api.fk(model, Q, links=[tip]).poses[:, 0]
    Jw = api.jacobian(model, Q, link=tip, reference="world").jacobians
    pa = (ctypes.c_double * max(len(p), 1))(*p)
    for k in range(len(Q)):
        qa = (ctypes.c_double * n)(*Q[k])
        out_T, out_J = (ctypes.c_double * 16)(), (ctypes.c_double * (6 * n))()
        (lib.k_fk(qa, pa, out_T), lib.k_jacobian_world(qa, pa, out_J)) if p else \
            (lib.k_fk(qa, out_T), lib.k_jacobian_world(qa, out_J))
        np.testing.assert_allclose(np.array(out_T).reshape(4, 4), T[k], atol=1e-12)
        np.testing.assert_allclose(np.array(out_J).reshape(6, n), Jw[k], atol=1e-12)


# ---------------------------------------------------------------------- time limit, validation
def test_time_limit_raises_and_suggests_simplify_false():
    chain = sym.chain_from_model(default_catalogue().get("panda"), "panda_hand_tcp")
    with pytest.raises(SymbolicTimeoutError, match="simplify: false") as info:
        sym.derive(chain, what=("transforms", "jacobian"), simplify=True, timeout=0.05)
    assert info.value.timeout == 0.05


def test_worker_process_answers_and_reports_errors():
    forms, out = sym.derive(_rpr_symbolic(), what=("transforms",), fmt="text", timeout=60)
    assert out["T"][3] == ["0", "0", "0", "1"] and "d1" in out["T"][2][3] and forms.simplified
    with pytest.raises(SymbolicError, match="representation"):
        sym.derive(_rpr_symbolic(), what=("task",), task=None, timeout=60)


@pytest.mark.parametrize("entry, message", [
    ("a1 +", "ends too early"),
    ("cos(a1)", "functions"),
    ("q2", "reserved for a joint variable"),
    ("E", "means something else"),
    ("a1 ^ 99", "exponents"),
    ("a1; import os", "cannot read"),
    ("1/0", "division by zero"),
    (True, "expected a number"),
])
def test_symbolic_table_entries_are_validated(entry, message):
    with pytest.raises(DHError, match=message) as info:
        sym.symbolic_table_from_dict({"joints": [row("R", entry, 0, 0, 0)]})
    assert "joints[0].a" in str(info.value)


def test_symbolic_table_keeps_the_numeric_checks():
    with pytest.raises(DHError, match=r"joints\[1\].type"):
        sym.symbolic_table_from_dict({"joints": [row("R", 1, 0, 0, 0), row("X", 1, 0, 0, 0)]})
    with pytest.raises(DHError, match="unknown field"):
        sym.symbolic_table_from_dict({"joints": [row("R", 1, 0, 0, 0)], "units": "mm"})
    t = sym.symbolic_table_from_dict({"angles": "degrees", "joints": [
        {**row("R", "l/2", "alpha1", 0.5, 90), "offset": 15}]})
    r = t.rows[0]
    l, alpha1 = sp.Symbol("l", real=True), sp.Symbol("alpha1", real=True)
    assert (r.a, r.alpha, r.d, r.theta) == (l / 2, sp.pi * alpha1 / 180, sp.Rational(1, 2), 7 * sp.pi / 12)


def test_a_tree_needs_a_tip():
    with pytest.raises(SymbolicError, match="choose the tip"):
        sym.chain_from_model(default_catalogue().get("ur5"))
