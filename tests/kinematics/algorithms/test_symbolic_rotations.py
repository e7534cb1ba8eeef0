"""Symbolic task vectors with quaternion (qw >= 0 branch) and rotation-vector orientation: the
generated Python and C, and the sympy expressions themselves, agree with the numeric task vectors
and analytic Jacobians of kinematics.algorithms.task to 1e-12 where the closed forms are valid
(qw > 0.1; rotation angle below pi - 0.2), and the rotation vector's series branch near the identity."""

from __future__ import annotations

import ctypes
import shutil
import subprocess
import types

import numpy as np
import pytest
import sympy as sp

from kinematics import api
from kinematics.algorithms import symbolic as sym
from kinematics.algorithms.task import task, task_representation, task_vector
from kinematics.io import default_catalogue

CASES = [("planar_2r", "tool"), ("rpr_example", "tool"), ("stanford_arm", "tool"), ("ur5", "tool0")]


def _valid_configurations(model, tip, rng, n=40):
    """Random configurations where the quaternion's qw > 0.1 (angle below ~168.5 degrees)."""
    Q = model.sample_configurations(8 * n, rng)
    T = api.fk(model, Q, links=[tip]).poses[:, 0]
    qw = task_vector(T, task_representation("quaternion"))[:, 3]
    Q = Q[qw > 0.1][:n]
    assert len(Q) >= n // 2
    return Q


def _generated(forms):
    code, _ = sym.python_code(forms)
    module = types.ModuleType("generated")
    exec(compile(code, "generated", "exec"), module.__dict__)
    return module


@pytest.mark.parametrize("rep", ["quaternion", "rotvec"])
@pytest.mark.parametrize("model_id, tip", CASES)
def test_generated_expressions_equal_the_numeric_task(model_id, tip, rep, rng):
    model = default_catalogue().get(model_id)
    chain = sym.chain_from_model(model, tip)
    forms = sym.closed_forms(chain, ("task",), simplify=True, task=task_representation(rep))
    assert forms.task.r.shape == (7 if rep == "quaternion" else 6, 1)
    idx = [model.joint_names.index(j) for j in chain.joints]
    Q = _valid_configurations(model, tip, rng)
    r, J_r = task(model, Q, tip, task_representation(rep))
    module = _generated(forms)
    err_r = np.abs(module.task(Q[:, idx]) - r).max()
    err_J = np.abs(module.task_jacobian(Q[:, idx]) - J_r[:, :, idx]).max()
    # the sympy expressions themselves, not only the code printed from them
    f_r = sp.lambdify([chain.variables], forms.task.r, "numpy")
    f_J = sp.lambdify([chain.variables], forms.task.J_r, "numpy")
    err_r = max(err_r, max(np.abs(np.array(f_r(q[idx]), float)[:, 0] - r[k]).max() for k, q in enumerate(Q[:8])))
    err_J = max(err_J, max(np.abs(np.array(f_J(q[idx]), float) - J_r[k][:, idx]).max() for k, q in enumerate(Q[:8])))
    print(f"{model_id} {rep}: {len(Q)} configurations, |r - r_num| <= {err_r:.1e}, |J_r - J_r,num| <= {err_J:.1e}")
    assert err_r < 1e-12 and err_J < 1e-12


def test_quaternion_closed_form_of_the_2r_arm():
    """A rotation by u = q1 + q2 about z: qw = sqrt(2 + 2 cos u)/2 = cos(u/2), qz = sin(u) / (2 qw) = sin(u/2)."""
    chain = sym.chain_from_model(default_catalogue().get("planar_2r"), "tool")
    forms = sym.closed_forms(chain, ("task",), simplify=True, task=task_representation("quaternion", ["qw", "qz"]))
    u = sp.Symbol("u", real=True)
    q1, q2 = chain.variables
    qw, qz = (e.subs(q2, u - q1) for e in forms.task.r)
    for value in (0.3, -1.2, 2.5):
        assert abs(float(qw.subs(u, value)) - np.cos(value / 2)) < 1e-15
        assert abs(float(qz.subs(u, value)) - np.sin(value / 2)) < 1e-15


def test_rotation_vector_is_finite_at_and_near_the_identity():
    model = default_catalogue().get("planar_2r")
    chain = sym.chain_from_model(model, "tool")
    forms = sym.closed_forms(chain, ("task",), simplify=True, task=task_representation("rotvec"))
    module = _generated(forms)
    # u = q1 + q2: exactly 0 (series branch), 1e-6 (series), 1e-3 (atan2 branch), 0.5
    Q = np.array([[0.0, 0.0], [0.4, -0.4], [0.2, -0.2 + 1e-6], [0.1, -0.1 - 1e-3], [0.2, 0.3]])
    with np.errstate(all="ignore"):  # numpy.select evaluates both branches
        r, J = module.task(Q), module.task_jacobian(Q)
    r_num, J_num = task(model, Q, "tool", task_representation("rotvec"))
    assert np.isfinite(r).all() and np.isfinite(J).all()
    np.testing.assert_allclose(r, r_num, atol=1e-15)
    np.testing.assert_allclose(J, J_num, atol=1e-12)
    assert forms.task.r[5].has(sp.Piecewise)


def test_formats_render():
    chain = sym.chain_from_model(default_catalogue().get("planar_2r"), "tool")
    for rep in ("quaternion", "rotvec"):
        _, out = sym.derive(chain, what=("task",), task=task_representation(rep), fmt="latex", timeout=60)
        assert out["representation"] == rep and "\\begin{bmatrix}" in out["r"]
        _, out = sym.derive(chain, what=("task",), task=task_representation(rep), fmt="text", timeout=60)
        back = [sp.sympify(row[0]) for row in out["r"]]
        assert len(back) == (7 if rep == "quaternion" else 6)


@pytest.mark.skipif(shutil.which("cc") is None, reason="no C compiler")
def test_generated_c_of_a_rotation_vector_task(tmp_path, rng):
    model = default_catalogue().get("ur5")
    chain = sym.chain_from_model(model, "tool0")
    forms = sym.closed_forms(chain, ("task",), simplify=True, task=task_representation("rotvec"))
    code, _ = sym.c_code(forms)
    (tmp_path / "t.c").write_text(code)
    subprocess.run(["cc", "-std=c99", "-O1", "-Wall", "-Werror", "-Wno-unused-variable", "-shared", "-fPIC",
                    "-o", str(tmp_path / "t.so"), str(tmp_path / "t.c"), "-lm"], check=True, timeout=300)
    lib = ctypes.CDLL(str(tmp_path / "t.so"))
    Q = _valid_configurations(model, "tool0", rng, 8)
    r, J_r = task(model, Q, "tool0", task_representation("rotvec"))
    for k in range(len(Q)):
        qa = (ctypes.c_double * 6)(*Q[k])
        out_r, out_J = (ctypes.c_double * 6)(), (ctypes.c_double * 36)()
        lib.task(qa, out_r)
        lib.task_jacobian(qa, out_J)
        np.testing.assert_allclose(np.array(out_r), r[k], atol=1e-12)
        np.testing.assert_allclose(np.array(out_J).reshape(6, 6), J_r[k], atol=1e-12)
