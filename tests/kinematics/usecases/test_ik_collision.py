"""Collision-free IK, paths and workspaces (``avoid_collisions``, ``collision_free``), re-checked
with Pinocchio and coal on the same geometry and pairs; every solution of a calibrated UR5."""

from __future__ import annotations

import numpy as np
import pytest

from kinematics import usecases
from kinematics.algorithms import self_collision
from kinematics.algorithms.ik import middle_of_limits
from kinematics.algorithms.workspace import sampling_bounds
from kinematics.engine.poe import compile_model
from kinematics.errors import CollisionError
from kinematics.io.catalogue import example_robot_data_dir
from kinematics.verify.pinocchio import PinocchioCollision, reference_for

#: the allowed-collision matrix of these tests (small, so that it is quick to sample)
SAMPLES = 300

CASES = {"ur5": ("tool0", None), "panda": ("panda_hand", {"panda_joint7": 0.3})}


def _pinocchio(model) -> PinocchioCollision:
    pairs = self_collision.matrix(model, SAMPLES).enabled()
    return PinocchioCollision(model, pairs, [example_robot_data_dir().parent.parent])


def _mixed_targets(model, link, locked, n=4, seed=0):
    """Poses of ``link`` at random configurations whose solution sets hold both colliding and free
    solutions (picked by sampling): ``(targets (n, 4, 4), the unfiltered answer on them)``."""
    rng = np.random.default_rng(seed)
    Q = model.sample_configurations(60, rng)
    for name, v in (locked or {}).items():
        Q[:, model.q_index[name]] = v
    T = compile_model(model).fk(Q, [link])[:, 0]
    every = usecases.ik(model, T, link=link, solutions="all", locked=locked, limits="ignore")
    free = usecases.ik(model, T, link=link, solutions="all", locked=locked, limits="ignore", avoid_collisions=True,
                       collision_samples=SAMPLES)
    mixed = np.flatnonzero((free.colliding > 0) & (free.count > 0))
    assert mixed.size >= n, "the sample holds too few targets with colliding and free solutions"
    return T[mixed[:n]]


@pytest.mark.parametrize("model_id", list(CASES))
def test_collision_free_solutions_are_free_for_pinocchio_and_the_rest_collide(catalogue, model_id):
    model = catalogue.get(model_id)
    link, locked = CASES[model_id]
    T = _mixed_targets(model, link, locked)
    pc = _pinocchio(model)
    every = usecases.ik(model, T, link=link, solutions="all", locked=locked, limits="ignore")
    free = usecases.ik(model, T, link=link, solutions="all", locked=locked, limits="ignore", avoid_collisions=True,
                       collision_samples=SAMPLES, verify=True)
    assert free.verification["max_position_error"] < 1e-9 and free.verification["max_rotation_error"] < 1e-9
    mid = middle_of_limits(model)
    poe = compile_model(model)
    on_path = set(poe.kernel.path_columns(int(poe.link_indices([link])[0])).tolist())
    off = [c for c in range(model.dof) if c not in on_path]
    for n in range(len(T)):
        listed = free.q[n, :free.count[n]]
        assert 0 < free.count[n] < every.count[n] and free.count[n] + free.colliding[n] == every.count[n]
        for q in listed:
            assert pc.collisions(q) == []  # free for Pinocchio's computeCollisions too
        # every solution of the full set that is not listed collides, for Pinocchio
        for q in every.q[n, :every.count[n]]:
            q = q.copy()
            q[off] = mid[off]  # off the chain: the middle of the limits, as the filtered answer holds them
            for name, v in (locked or {}).items():
                q[model.q_index[name]] = v
            is_listed = np.any(np.all(np.abs(listed - q) < 1e-12, axis=1))
            assert is_listed == (pc.collisions(q) == []), q


@pytest.mark.parametrize("model_id", list(CASES))
def test_one_solution_searches_on_until_it_is_free(catalogue, model_id):
    """Targets whose plain numerical answer collides: with avoid_collisions the answer is free (for
    Pinocchio), on its target and inside the limits wherever the full set holds a free solution
    inside the limits, and no success where it holds none."""
    model = catalogue.get(model_id)
    link, locked = CASES[model_id]
    rng = np.random.default_rng(4)
    Q = model.sample_configurations(40, rng)
    for name, v in (locked or {}).items():
        Q[:, model.q_index[name]] = v
    T = compile_model(model).fk(Q, [link])[:, 0]
    plain = usecases.ik(model, T, link=link, locked=locked)
    hit = usecases.collision_free(model, plain.solution.q, samples=SAMPLES)
    colliding = np.flatnonzero(plain.solution.success & ~hit)
    assert colliding.size, "no target's plain answer collides in this sample"
    a = usecases.ik(model, T[colliding], link=link, locked=locked, avoid_collisions=True, collision_samples=SAMPLES,
                    verify=locked is None)
    pc = _pinocchio(model)
    frames = reference_for(model).frames([link])
    full = usecases.ik(model, T[colliding], link=link, locked=locked, solutions="all", avoid_collisions=True,
                       collision_samples=SAMPLES)
    assert full.count.max() > 0
    for n, q in enumerate(a.solution.q):
        if full.count[n] == 0:  # every solution inside the limits collides: none is claimed
            assert not a.solution.success[n]
            continue
        assert a.solution.success[n] and a.collision_free[n]
        assert pc.collisions(q) == []
        theirs = frames.poses(q)[link]
        assert np.abs(theirs[:3, 3] - T[colliding[n], :3, 3]).max() < 1e-6
        assert np.all(q >= model.lower_limits - 1e-9) and np.all(q <= model.upper_limits + 1e-9)


def test_a_path_into_self_collision_stops_at_the_first_colliding_row(catalogue):
    model = catalogue.get("ur5")
    q0 = np.array([0, -1.0, 1.5, 0, 0, 0.0])
    q1 = np.array([0, -1.0, 2.9, 0, 0, 0.0])  # the elbow shut: the wrist inside the upper arm
    W = compile_model(model).fk(np.array([q0, q1]), ["tool0"])[:, 0]
    step = {"position": 0.01, "rotation": 0.05}
    plain = usecases.ik_path(model, W, link="tool0", seed=q0, step=step)
    pc = _pinocchio(model)
    hits = [i for i, q in enumerate(plain.q) if pc.collisions(q)]
    assert plain.complete and hits, "the plain path must run into self-collision"
    first = hits[0]
    a = usecases.ik_path(model, W, link="tool0", seed=q0, step=step, avoid_collisions=True, collision_samples=SAMPLES)
    assert a.stopped == {"index": first, "reason": "collision"} and not a.complete
    np.testing.assert_array_equal(a.q, plain.q[:first])  # the same continuation up to there
    assert 0 < a.fraction < 1 and len(a.position_error) == first


@pytest.mark.parametrize("model_id, link", [("ur5", "tool0"), ("panda", "panda_hand")])
def test_a_collision_free_workspace_drops_exactly_the_colliding_samples(catalogue, model_id, link):
    model = catalogue.get(model_id)
    n = 1500
    plain = usecases.workspace(model, link, samples=n, random_seed=3)
    free = usecases.workspace(model, link, samples=n, random_seed=3, collision_free=True, collision_samples=SAMPLES)
    assert free.collision_free and 0 < free.dropped < n and free.samples + free.dropped == n
    # the same draws as the sampler (one chunk): which of them Pinocchio finds colliding
    poe = compile_model(model)
    cols = poe.kernel.path_columns(int(poe.link_indices([link])[0]))
    lo, hi = sampling_bounds(model, cols)
    Q = np.tile(middle_of_limits(model), (n, 1))
    Q[:, cols] = np.random.default_rng(3).uniform(lo, hi, (n, len(cols)))
    pc = _pinocchio(model)
    theirs = np.array([pc.collisions(q) == [] for q in Q])
    assert int((~theirs).sum()) == free.dropped
    np.testing.assert_array_equal(free.points, plain.points[theirs])  # the free samples, none colliding
    assert free.points.shape[0] < plain.points.shape[0]


def test_a_model_without_collision_geometry_is_refused_by_name(catalogue):
    puma = catalogue.get("puma560_standard")
    T = compile_model(puma).fk(np.zeros((1, puma.dof)), ["tool"])[:, 0]
    calls = [lambda: usecases.ik(puma, T, link="tool", solutions="all", avoid_collisions=True),
             lambda: usecases.ik(puma, T, link="tool", avoid_collisions=True),
             lambda: usecases.ik_path(puma, [T[0], T[0]], link="tool", avoid_collisions=True),
             lambda: usecases.workspace(puma, "tool", samples=10, collision_free=True)]
    for call in calls:
        with pytest.raises(CollisionError, match="puma560_standard.*no collision geometry"):
            call()


# ---------------------------------------------------------------------------------------------- calibrated
@pytest.fixture(scope="module")
def calibrated_ur5():
    from kinematics import default_catalogue
    from kinematics.algorithms.calibration.synthetic import experiment

    model = default_catalogue().get("ur5")
    rng = np.random.default_rng(11)
    truth, Q, P = experiment(model, "tool0", "position", 60, rng)
    cal = usecases.calibrate(usecases.Query(model, link="tool0"), [{"q": q.tolist(), "position": p.tolist()} for q, p in zip(Q, P)])
    return model, cal


def test_a_calibrated_ur5_gets_every_solution(calibrated_ur5):
    """The calibrated UR5 is no exact family any more: every generating configuration is found and
    every solution is exact for Pinocchio's FK of the calibrated URDF."""
    nominal, cal = calibrated_ur5
    model = cal.model
    assert model.urdf != nominal.urdf
    fam = usecases.ik_family(model, link="tool0")
    assert fam["family"] == "three_parallel" and fam["near"]
    rng = np.random.default_rng(5)
    Q = model.sample_configurations(200, rng)
    T = compile_model(model).fk(Q, ["tool0"])[:, 0]
    a = usecases.ik(model, T, link="tool0", solutions="all", limits="respect", verify=True)
    assert a.verification["max_position_error"] < 1e-9 and a.verification["max_rotation_error"] < 1e-9
    for n, q in enumerate(Q):
        d = np.abs(a.q[n, :a.count[n]] - q).max(axis=1)
        assert d.min() < 1e-7, (n, d.min())  # the generating configuration is listed
    # no branch lost: an independent multistart search of the real (calibrated) chain finds no more,
    # on the first targets and wherever the real chain has fewer solutions than its ideal family
    # (``complete`` false: near the edge of the reach, a branch pair of the ideal chain is gone)
    pick = np.union1d(np.arange(20), np.flatnonzero(~a.complete))
    search = usecases.ik(model, T[pick], link="tool0", solutions="all", limits="ignore", method="numeric")
    closed = usecases.ik(model, T[pick], link="tool0", solutions="all", limits="ignore")
    assert np.all(closed.count >= search.count) and closed.count.min() > 0


def test_one_solution_on_a_chain_without_closed_form_takes_fresh_seeds(catalogue):
    """The 7-joint Panda (nothing locked: no full set to fall back on): targets whose plain answer
    collides are searched again from fresh seeds; every success is free for Pinocchio and on target."""
    model = catalogue.get("panda")
    Q = model.sample_configurations(40, np.random.default_rng(8))
    T = compile_model(model).fk(Q, ["panda_hand"])[:, 0]
    plain = usecases.ik(model, T, link="panda_hand")
    hit = usecases.collision_free(model, plain.solution.q, samples=SAMPLES)
    colliding = np.flatnonzero(plain.solution.success & ~hit)
    assert colliding.size, "no target's plain answer collides in this sample"
    a = usecases.ik(model, T[colliding], link="panda_hand", avoid_collisions=True, collision_samples=SAMPLES,
                    verify=True)
    assert a.solution.success.any()
    pc = _pinocchio(model)
    for n in np.flatnonzero(a.solution.success):
        assert a.collision_free[n] and pc.collisions(a.solution.q[n]) == []
        assert a.verification["position_error"][n] < 1e-6 and a.verification["rotation_error"][n] < 1e-6
    assert np.array_equal(a.collision_free[~a.solution.success],
                          usecases.collision_free(model, a.solution.q[~a.solution.success], samples=SAMPLES))
