"""The single-configuration entries (kinematics/engine/single.py) equal the batch rows bit for bit."""

from __future__ import annotations

import threading

import numpy as np
import pytest

from kinematics import compile_model
from kinematics.engine.single import fk_function, jacobian_function
from kinematics.errors import KinematicsError
from kinematics.spatial.reference import REFERENCES

MODELS = ["ur5", "panda", "talos_reduced", "scara", "rpr_example", "planar_2r"]


@pytest.mark.parametrize("model_id", MODELS)
def test_single_equals_batch_row_bit_for_bit(catalogue, model_id):
    model = catalogue.get(model_id)
    poe = compile_model(model)
    Q = model.sample_configurations(300, np.random.default_rng(21))  # a batch: the vectorised loops
    Q[-3:] *= 1e5  # far turns; beyond the polynomial's range the kernels use libm (both paths)
    Q[-1] = 3e6
    fk_all = fk_function(poe, list(model.links))
    T = poe.fk(Q)
    for i in range(Q.shape[0]):
        assert np.array_equal(fk_all(Q[i]), T[i])
    for leaf in model.leaf_links:
        fk1 = fk_function(poe, leaf)
        Tl = poe.fk(Q, [leaf])[:, 0]
        for reference in REFERENCES:
            J1 = jacobian_function(poe, leaf, reference)
            J = poe.jacobian(Q, leaf, reference)
            for i in range(0, Q.shape[0], 7):
                assert np.array_equal(fk1(Q[i]), Tl[i])
                assert np.array_equal(J1(Q[i]), J[i]), (leaf, reference, i)


def test_tool_out_and_coercion(catalogue):
    model = catalogue.get("ur5")
    poe = compile_model(model)
    tool = np.eye(4)
    tool[:3, 3] = [0.0, 0.0, 0.1]
    q = [0.1, 0.2, -0.3, 0.4, 0.5, -0.6]
    fk1 = fk_function(poe, "tool0", tool=tool)
    out = np.empty((4, 4))
    assert fk1(q, out) is out
    assert np.array_equal(out, poe.fk(np.array([q]), ["tool0"], tool=tool)[0, 0])
    J1 = jacobian_function(poe, "tool0", "local_world_aligned", tool=tool)
    assert np.array_equal(J1(q), poe.jacobian(np.array([q]), "tool0", "local_world_aligned", tool=tool)[0])
    assert np.array_equal(J1(np.array([0, 1, 0, 0, 1, 0])), J1([0.0, 1.0, 0.0, 0.0, 1.0, 0.0]))  # ints
    assert np.array_equal(J1(np.array(q)[::1]), J1(q))
    with pytest.raises(KinematicsError, match="vector of 6"):
        fk1([0.0] * 5)
    with pytest.raises(KinematicsError, match="vector of 6"):
        fk1(np.zeros(7))  # a float64 vector of the wrong length: refused by the compiled entry itself
    with pytest.raises(KinematicsError, match="vector of 6"):
        J1(np.zeros((1, 6)))
    with pytest.raises(KinematicsError, match=r"shape \(4, 4\)"):
        fk1(q, np.empty((3, 3)))  # the entry writes a (4, 4): never past a smaller out
    with pytest.raises(KinematicsError):
        jacobian_function(poe, "tool0", "sideways")


def test_threads_sharing_a_bound_function_get_their_own_answers(catalogue):
    """The entries hold the GIL and share one scratch: threads calling one function at once must still
    each get their own configuration's pose."""
    model = catalogue.get("panda")
    poe = compile_model(model)
    fk1 = fk_function(poe, "panda_hand_tcp")
    Q = model.sample_configurations(2000, np.random.default_rng(5))
    want = poe.fk(Q, ["panda_hand_tcp"])[:, 0]
    bad = []

    def run(offset):
        for i in range(offset, Q.shape[0], 2):
            if not np.array_equal(fk1(Q[i]), want[i]):
                bad.append(i)

    threads = [threading.Thread(target=run, args=(k,)) for k in (0, 1)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert bad == []


@pytest.mark.parametrize("model_id", MODELS)
def test_a_batch_of_one_takes_the_single_entry_and_equals_its_row_bit_for_bit(catalogue, model_id):
    """``PoEModel.fk`` / ``jacobian`` with one row run the single-configuration entry (engine/plans.py):
    the same bits as that row of a larger batch, for every link list and reference."""
    model = catalogue.get(model_id)
    poe = compile_model(model)
    Q = model.sample_configurations(40, np.random.default_rng(5))
    Q[-2:] *= 1e5
    leaves = list(model.leaf_links)
    T_all, T_leaves = poe.fk(Q), poe.fk(Q, leaves)
    for i in range(Q.shape[0]):
        assert np.array_equal(poe.fk(Q[i:i + 1]), T_all[i:i + 1])
        assert np.array_equal(poe.fk(Q[i:i + 1], leaves), T_leaves[i:i + 1])
        assert np.array_equal(poe.fk(Q[i:i + 1].tolist(), tuple(leaves)), T_leaves[i:i + 1])  # lists, a tuple of names
    for reference in REFERENCES:
        J = poe.jacobian(Q, leaves[-1], reference)
        for i in range(0, Q.shape[0], 3):
            assert np.array_equal(poe.jacobian(Q[i:i + 1], leaves[-1], reference), J[i:i + 1])


def test_a_batch_of_one_is_still_cancellable_and_names_unknown_links(catalogue):
    from kinematics import api
    from kinematics.errors import CancelledError, UnknownLinkError

    model = catalogue.get("ur5")
    poe = compile_model(model)
    q = np.zeros((1, 6))
    token = api.Cancellation(None)
    token.cancel("stop")
    with api.cancellable(token), pytest.raises(CancelledError):
        poe.fk(q, ["tool0"])
    with api.cancellable(token), pytest.raises(CancelledError):
        poe.jacobian(q, "tool0")
    for _ in range(2):  # a failed look-up is not cached
        with pytest.raises(UnknownLinkError, match="tool9"):
            poe.fk(q, ["tool9"])
        with pytest.raises(UnknownLinkError, match="tool9"):
            poe.jacobian(q, "tool9")


def test_every_form_of_q_gives_the_contiguous_vectors_answer(catalogue):
    """A contiguous float64 vector takes the compiled function directly (no dispatcher); a strided,
    read-only, Fortran-ordered or sliced-from-a-matrix q must give the same bits, never a read of the
    wrong elements."""
    poe = compile_model(catalogue.get("ur5"))
    fk1, J1 = fk_function(poe, "tool0"), jacobian_function(poe, "tool0", "world")
    q = np.array([0.1, 0.2, -0.3, 0.4, 0.5, -0.6])
    wide = np.zeros(12)
    wide[::2] = q
    readonly = q.copy()
    readonly.setflags(write=False)
    column = np.asfortranarray(np.stack([q, -q], axis=1))[:, 0]
    for form in (wide[::2], readonly, column, q[::-1][::-1], list(q)):
        assert np.array_equal(fk1(form), fk1(q)) and np.array_equal(J1(form), J1(q))
    assert np.array_equal(fk1(q), poe.fk(q[None], ["tool0"])[0, 0])
