"""The compiled kernels (kinematics/engine/) equal the straightforward reference (engine/poe.py).

Agreement to KERNEL_TOLERANCE on every catalogue model: FK of all links and the three
Jacobians of every leaf link, at random configurations (continuous joints beyond +-pi),
through the batched (chunked) path and the small-batch path; chunk boundaries, N = 0 and
N = 1, models without moving joints; and the polynomial sine/cosine against numpy's.
"""

from __future__ import annotations

import zlib

import numpy as np
import pytest

from kinematics import compile_model, parse_urdf
from kinematics.engine import buffers, compiled
from kinematics.engine import plans as kernels
from kinematics.spatial import rotations
from kinematics.errors import KinematicsError, UnknownLinkError
from kinematics.spatial.reference import REFERENCES
from tests.paths import FIXTURES

#: Largest entry-wise difference allowed between the kernels and the reference.
KERNEL_TOLERANCE = 1e-12
#: Configurations per model in the catalogue-wide check (the kernels' vectorised loops and
#: their scalar remainders)...
BATCH_N = 25
#: ... and a few.
SMALL_N = 3


def _assert_close(a: np.ndarray, b: np.ndarray, what: str) -> None:
    assert a.shape == b.shape, f"{what}: shape {a.shape} != {b.shape}"
    if a.size:
        err = float(np.max(np.abs(a - b)))
        assert err <= KERNEL_TOLERANCE, f"{what}: max deviation {err:.3e}"


def _catalogue_ids():
    from tests.catalogue_sample import catalogue_ids

    return catalogue_ids()  # a fixed sample; every model with KIN_TEST_FULL_CATALOGUE=1


def _load(catalogue, model_id):
    from kinematics.errors import URDFError

    try:
        return catalogue.get(model_id)
    except URDFError as exc:  # a model the parser refuses
        pytest.skip(f"{model_id}: {exc}")


@pytest.mark.slow
@pytest.mark.parametrize("model_id", _catalogue_ids())
def test_kernels_equal_reference_on_catalogue(catalogue, model_id):
    model = _load(catalogue, model_id)
    poe = compile_model(model)
    rng = np.random.default_rng(zlib.crc32(model_id.encode()))
    for n in (BATCH_N, SMALL_N, 1):  # 1: the single-configuration path of short trees
        Q = model.sample_configurations(n, rng)  # continuous joints drawn in +-2 pi
        _assert_close(poe.fk(Q), poe.fk_reference(Q), f"{model_id} FK N={n}")
        for leaf in model.leaf_links:
            for reference in REFERENCES:
                _assert_close(poe.jacobian(Q, leaf, reference), poe.jacobian_reference(Q, leaf, reference),
                              f"{model_id} J {leaf} {reference} N={n}")


@pytest.mark.parametrize("model_id", ["ur5", "panda", "talos_reduced"])
def test_chunk_boundaries(catalogue, model_id):
    """N not a multiple of the chunk, and several chunks, give the reference's result."""
    model = catalogue.get(model_id)
    poe = compile_model(model)
    Q = model.sample_configurations(50, np.random.default_rng(7))
    ref = poe.fk_reference(Q)
    for chunk in (7, 16, 49, 50, 64):
        _assert_close(poe.kernel.fk(Q, None, chunk=chunk), ref, f"{model_id} FK chunk={chunk}")
    leaf = model.leaf_links[-1]
    li = int(poe.link_indices([leaf])[0])
    for reference in REFERENCES:
        ref_j = poe.jacobian_reference(Q, leaf, reference)
        for chunk in (7, 50):
            _assert_close(poe.kernel.jacobian(Q, li, reference, chunk=chunk), ref_j, f"{model_id} J chunk={chunk}")


def test_single_configurations_equal_their_batch_rows(catalogue):
    """A configuration alone gives its row of a batch bit for bit (the API's single and batch
    answers agree exactly): no fast-math, so the vectorised loop and its scalar remainder agree."""
    for model_id in ("ur5", "panda", "talos_reduced"):  # panda: a mimic finger and a prismatic joint
        model = catalogue.get(model_id)
        poe = compile_model(model)
        Q = model.sample_configurations(37, np.random.default_rng(4))
        batch = poe.fk(Q)
        _assert_close(batch, poe.fk_reference(Q), f"{model_id} batch vs reference")
        leaf = model.leaf_links[-1]
        jb = poe.jacobian(Q, leaf, "local")
        for i in range(Q.shape[0]):
            np.testing.assert_array_equal(poe.fk(Q[i:i + 1]), batch[i:i + 1])
            np.testing.assert_array_equal(poe.jacobian(Q[i:i + 1], leaf, "local"), jb[i:i + 1])


def test_n_zero_and_one(catalogue):
    model = catalogue.get("ur5")
    poe = compile_model(model)
    L = len(poe.link_names)
    assert poe.fk(np.zeros((0, model.dof))).shape == (0, L, 4, 4)
    assert poe.jacobian(np.zeros((0, model.dof)), "tool0", "local").shape == (0, 6, model.dof)
    q = model.sample_configurations(1, np.random.default_rng(1))
    T = poe.fk(q)
    assert T.shape == (1, L, 4, 4)
    _assert_close(T, poe.fk_reference(q), "N=1")
    np.testing.assert_array_equal(T[0, :, 3, :], np.tile([0.0, 0.0, 0.0, 1.0], (L, 1)))


def test_single_configuration_results_are_fresh_and_thread_safe(catalogue):
    """A result is never overwritten by a later call, and concurrent threads (the compiled
    kernel releases the GIL; its scratch is per call) each get their own configuration's poses."""
    from concurrent.futures import ThreadPoolExecutor

    model = catalogue.get("panda")  # a mimic finger and a prismatic joint
    poe = compile_model(model)
    Q = model.sample_configurations(64, np.random.default_rng(11))
    ref = poe.fk_reference(Q)
    first = poe.fk(Q[:1])
    poe.fk(Q[1:2])
    _assert_close(first, ref[:1], "a result after a later call")

    def run(i):
        return [poe.fk(Q[i:i + 1], ["panda_hand_tcp", "panda_rightfinger"]) for _ in range(50)]

    with ThreadPoolExecutor(4) as pool:
        outs = list(pool.map(run, range(Q.shape[0])))
    idx = poe.link_indices(["panda_hand_tcp", "panda_rightfinger"])
    for i, results in enumerate(outs):
        for T in results:
            _assert_close(T, ref[i:i + 1, idx], f"thread result {i}")


def test_planar_2r_closed_form():
    """De Luca's 2R planar arm: p = (l1 c1 + l2 c12, l1 s1 + l2 s12), heading q1 + q2; J (world-aligned)
    closed form."""
    from pathlib import Path

    from kinematics import load_urdf

    model = load_urdf(FIXTURES / "planar_2r.urdf")
    poe = compile_model(model)
    l1, l2 = 0.7, 0.5
    Q = model.sample_configurations(37, np.random.default_rng(9))
    for Qn in (Q, Q[:1]):  # batched and small paths
        T = poe.fk(Qn, ["tool"])[:, 0]
        q1, q2 = Qn[:, 0], Qn[:, 1]
        np.testing.assert_allclose(T[:, 0, 3], l1 * np.cos(q1) + l2 * np.cos(q1 + q2), atol=1e-14)
        np.testing.assert_allclose(T[:, 1, 3], l1 * np.sin(q1) + l2 * np.sin(q1 + q2), atol=1e-14)
        np.testing.assert_allclose(T[:, 0, 0], np.cos(q1 + q2), atol=1e-14)
        np.testing.assert_allclose(T[:, 1, 0], np.sin(q1 + q2), atol=1e-14)
        J = poe.jacobian(Qn, "tool", "local_world_aligned")
        np.testing.assert_allclose(J[:, 0, 0], -l1 * np.sin(q1) - l2 * np.sin(q1 + q2), atol=1e-14)
        np.testing.assert_allclose(J[:, 0, 1], -l2 * np.sin(q1 + q2), atol=1e-14)
        np.testing.assert_allclose(J[:, 1, 0], l1 * np.cos(q1) + l2 * np.cos(q1 + q2), atol=1e-14)
        np.testing.assert_allclose(J[:, 5, :], 1.0, atol=0)


@pytest.mark.parametrize("model_id", ["hector_quadrotor", "iris_simple"])
def test_models_without_moving_joints(catalogue, model_id):
    model = _load(catalogue, model_id)
    assert model.dof == 0
    poe = compile_model(model)
    for n in (0, 1, 40):
        Q = np.zeros((n, 0))
        T = poe.fk(Q)
        assert T.shape == (n, len(poe.link_names), 4, 4)
        _assert_close(T, poe.fk_reference(Q), f"{model_id} N={n}")
        if n:
            np.testing.assert_allclose(T[0], poe.M, atol=0)
        for reference in REFERENCES:
            assert poe.jacobian(Q, model.leaf_links[0], reference).shape == (n, 6, 0)


def test_link_subsets_order_and_duplicates(catalogue):
    model = catalogue.get("talos_reduced")
    poe = compile_model(model)
    Q = model.sample_configurations(40, np.random.default_rng(11))
    links = [model.links[-1], model.root, model.links[5], model.links[-1], model.links[20], model.links[21]]
    for Qn in (Q, Q[:2]):
        _assert_close(poe.fk(Qn, links), poe.fk_reference(Qn, links), "subset")
    with pytest.raises(UnknownLinkError, match="nope"):
        poe.fk(Q, ["nope"])


def test_prismatic_and_mimic_tree():
    """A tree with a prismatic joint, a mimic on another branch, a skewed axis and a continuous joint."""
    urdf = """<robot name="t">
      <link name="base"/><link name="a"/><link name="b"/><link name="c"/><link name="d"/><link name="e"/>
      <joint name="j1" type="continuous"><parent link="base"/><child link="a"/>
        <origin xyz="0.1 0.2 0.3" rpy="0.3 -0.2 0.1"/><axis xyz="0.2 0.5 -0.8"/></joint>
      <joint name="j2" type="prismatic"><parent link="a"/><child link="b"/>
        <origin xyz="0 0 0.4"/><axis xyz="1 0 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
      <joint name="j3" type="revolute"><parent link="a"/><child link="c"/>
        <origin xyz="0.3 0 0" rpy="1.5707963267948966 0 0"/><axis xyz="0 -1 0"/>
        <limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
      <joint name="j4" type="revolute"><parent link="b"/><child link="d"/>
        <origin xyz="0 0.2 0"/><axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/>
        <mimic joint="j3" multiplier="-2.0" offset="0.25"/></joint>
      <joint name="f" type="fixed"><parent link="d"/><child link="e"/><origin xyz="0.05 0 0.1" rpy="0 0.4 0"/></joint>
    </robot>"""
    model = parse_urdf(urdf)
    poe = compile_model(model)
    Q = model.sample_configurations(37, np.random.default_rng(5), continuous_range=50.0)
    for Qn in (Q, Q[:1]):
        _assert_close(poe.fk(Qn), poe.fk_reference(Qn), "FK")
        for reference in REFERENCES:
            _assert_close(poe.jacobian(Qn, "e", reference), poe.jacobian_reference(Qn, "e", reference), reference)


def test_fk_out_buffer(catalogue):
    model = catalogue.get("ur5")
    poe = compile_model(model)
    Q = model.sample_configurations(30, np.random.default_rng(2))
    buf = np.full((30, len(poe.link_names), 4, 4), np.nan)
    assert poe.fk(Q, out=buf) is buf
    _assert_close(buf, poe.fk_reference(Q), "out=")
    with pytest.raises(KinematicsError, match="out must be"):
        poe.fk(Q, out=np.empty((29, len(poe.link_names), 4, 4)))
    with pytest.raises(KinematicsError, match="shape"):
        poe.fk(Q[:, :5])


def test_results_are_cache_line_aligned(catalogue):
    model = catalogue.get("ur5")
    poe = compile_model(model)
    for n in (100, 1000):  # results of at least ALIGN_MIN_ELEMENTS values
        T = poe.fk(model.sample_configurations(n, np.random.default_rng(n)))
        assert T.ctypes.data % buffers.CACHE_LINE == 0 and T.flags.c_contiguous and T.dtype == np.float64
    A = buffers.aligned_empty((30, 50, 7))
    assert A.shape == (30, 50, 7) and A.ctypes.data % buffers.CACHE_LINE == 0 and A.flags.c_contiguous
    small = buffers.aligned_empty((3, 5, 7))  # below ALIGN_MIN_ELEMENTS: numpy's own alignment
    assert small.shape == (3, 5, 7) and small.flags.c_contiguous


def test_large_results_are_recycled_only_when_unreferenced(catalogue):
    """Results of POOL_MIN_BYTES or more come from the pool of recycled buffers: a buffer is
    reused only after the result and every view of it are gone, never while one is alive."""
    model = catalogue.get("talos_reduced")
    poe = compile_model(model)
    L = len(poe.link_names)
    n = buffers.POOL_MIN_BYTES // (L * 128) + 1  # just above the pooling size
    rng = np.random.default_rng(5)
    Q1, Q2 = model.sample_configurations(n, rng), model.sample_configurations(n, rng)
    buffers.POOL.clear()
    T1 = poe.fk(Q1)
    assert isinstance(T1.base, buffers._Lease) and T1.ctypes.data % buffers.CACHE_LINE == 0
    ptr1 = T1.ctypes.data
    expected1 = poe.fk_reference(Q1[-5:])
    view = T1[-5:]  # a view alone keeps the buffer
    del T1
    T2 = poe.fk(Q2)
    assert T2.ctypes.data != ptr1  # still in use by `view`
    _assert_close(view, expected1, "a view after a later call")
    del view
    T3 = poe.fk(Q1)  # the first buffer is free again: reused, and filled with new poses
    assert T3.ctypes.data == ptr1
    _assert_close(T3[:7], poe.fk_reference(Q1[:7]), "a recycled buffer")
    _assert_close(T2[:7], poe.fk_reference(Q2[:7]), "the other result")
    del T2, T3
    assert buffers.POOL.held <= buffers.POOL_BYTES
    buffers.POOL.clear()


def test_pool_keeps_at_most_its_limit():
    pool = buffers._Pool(limit=3 * 8 * 1000)
    held = [pool.take(1000) for _ in range(5)]
    for a in held:
        pool.give_back(a)
    assert pool.held == 3 * 8 * 1000 and len(pool.free[1000]) == 3
    assert pool.take(1000) is held[2] and pool.held == 2 * 8 * 1000
    assert pool.take(999) is not None and pool.allocated == 6


def test_pool_survives_a_finalizer_inside_its_own_critical_section():
    """The cyclic GC may run a lease's finalizer (give_back) while this thread is inside take()
    or give_back(): the pool's lock must be re-entrant, or that thread deadlocks."""
    import threading

    pool = buffers._Pool(limit=1 << 20)
    done = []

    def inside():
        with pool.lock:  # as if take() were running when the finalizer fired
            pool.give_back(np.empty(10))
            done.append(pool.take(10).size)

    t = threading.Thread(target=inside, daemon=True)
    t.start()
    t.join(timeout=10)
    assert done == [10], "the pool deadlocked"


def test_compiled_sincos_matches_numpy():
    """The compiled kernel's own sine/cosine (kinematics.compiled): within 4e-16 of numpy's, and
    numpy's (libm's) values beyond the exactly reduced range and for non-finite arguments."""
    rng = np.random.default_rng(1)
    th = np.concatenate([rng.uniform(-7, 7, 5001), rng.uniform(-1e6, 1e6, 5000),
                         [0.0, -0.0, np.pi / 4, -np.pi / 4, np.pi / 2, np.pi, 3 * np.pi / 2, 1e-300, 7.5e5]])
    s, c = np.empty_like(th), np.empty_like(th)
    compiled.sincos(th, s, c)
    np.testing.assert_allclose(s, np.sin(th), rtol=0, atol=4e-16)
    np.testing.assert_allclose(c, np.cos(th), rtol=0, atol=4e-16)
    odd = np.array([3e6, -1e12, np.nan, np.inf, 0.5])
    s, c = np.empty_like(odd), np.empty_like(odd)
    compiled.sincos(odd, s, c)
    np.testing.assert_array_equal(s[:2], np.sin(odd[:2]))
    np.testing.assert_array_equal(c[:2], np.cos(odd[:2]))
    assert np.isnan(s[2:4]).all() and np.isnan(c[2:4]).all()
    assert abs(s[4] - np.sin(0.5)) <= 1e-16


def test_axis_frames_are_rotations_on_the_axis(catalogue):
    """G_j has z along the joint axis, origin on it, and an orthonormal right-handed rotation."""
    model = catalogue.get("talos_reduced")
    poe = compile_model(model)
    G = poe.kernel.G
    R = G[:, :3, :3]
    np.testing.assert_allclose(R @ np.swapaxes(R, 1, 2), np.broadcast_to(np.eye(3), R.shape), atol=1e-15)
    np.testing.assert_allclose(np.linalg.det(R), 1.0, atol=1e-15)
    np.testing.assert_allclose(R[:, :, 2], poe.w / np.linalg.norm(poe.w, axis=1)[:, None], atol=1e-15)
    np.testing.assert_allclose(G[:, :3, 3], poe.r, atol=0)


def test_warm_up_loads_every_compiled_kernel_a_request_uses():
    """kinematics.warm_up() (run at server start and in the Docker build) leaves FK, the
    Jacobian and rotation -> quaternion compiled in a new process: the first request
    compiles nothing (it took 0.5 s in the container when the quaternion was left out)."""
    import subprocess
    import sys

    code = ("import kinematics; kinematics.warm_up(); from kinematics.engine import compiled; "
            "from kinematics.spatial import rotations; from kinematics.engine import ik, entries; "
            "print(*(len(f.signatures) for f in (compiled.fk, compiled.jacobian, rotations.quaternions, ik.solve, "
            "compiled.fk_rooted, compiled.jacobian_rooted, entries.fk_one, entries.jacobian_one)))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300, check=True)
    assert len(out.stdout.split()) == 8 and all(int(x) >= 1 for x in out.stdout.split()), out.stdout
