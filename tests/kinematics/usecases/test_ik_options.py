"""IK's options as objects, the selection strategies and the family / kernel registries."""

import dataclasses

import numpy as np
import pytest

import kinematics
from kinematics.algorithms import ik_families, ik_kernels
from kinematics.algorithms.ik import IKSolution
from kinematics.errors import KinematicsError
from kinematics.usecases.ik_options import DEFAULT_SETTINGS, CollisionAvoidance, IKOptions, IKSettings, SolutionSet
from kinematics.usecases.ik_select import NearestOfSet, Numerical, RetryUntilFree, selection


@pytest.fixture(scope="module")
def ur5(catalogue):
    return catalogue.get("ur5")


def _targets(model, n=3, seed=5):
    Q = np.random.default_rng(seed).uniform(-2.0, 2.0, (n, 6))
    return kinematics.fk(model, Q, links=["tool0"]).poses[:, 0]


def test_keywords_become_the_objects_and_the_rest_is_the_query():
    options, rest = IKOptions.split(None, {"restarts": 3, "mode": "position", "limits": "ignore", "locked": {"a": 1.0},
                                           "avoid_collisions": True, "collision_samples": 200, "link": "tool0"})
    assert options.settings == dataclasses.replace(DEFAULT_SETTINGS, restarts=3, mode="position")
    assert options.solutions.solution_limits == "ignore" and options.solutions.locked_map == {"a": 1.0}
    assert options.collisions == CollisionAvoidance(samples=200)
    assert rest == {"link": "tool0"}
    # keywords over given options: replaced field by field; avoid_collisions=False drops the avoidance
    again, _ = IKOptions.split(options, {"random_seed": 9, "avoid_collisions": False})
    assert again.settings.random_seed == 9 and again.settings.restarts == 3 and again.collisions is None


@pytest.mark.parametrize("build, message", [
    (lambda: IKSettings(mode="orientation"), "mode: 'orientation' is not one of pose, position"),
    (lambda: IKSettings(position_tolerance=0.0), "tolerance.position: 0.0"),
    (lambda: IKSettings(max_iterations=0), "max_iterations must be at least 1"),
    (lambda: SolutionSet(solutions="some"), "solutions: 'some' is not one of one, all"),
    (lambda: SolutionSet(solution_limits="report"), "limits: 'report' is not one of respect, ignore"),
])
def test_options_are_validated_when_built(build, message):
    with pytest.raises(KinematicsError, match=message.replace("(", r"\(").replace(".", r"\.")):
        build()


def test_the_locked_map_of_a_solution_set_is_frozen():
    wanted = SolutionSet(locked={"j": 0.5})
    with pytest.raises(TypeError):
        wanted.locked["j"] = 1.0  # type: ignore[index]


def test_options_object_and_keywords_give_the_same_answer(ur5):
    T = _targets(ur5)
    options = IKOptions(IKSettings(restarts=2, max_iterations=40, random_seed=3), SolutionSet(method="analytic"))
    a = kinematics.ik(ur5, T, link="tool0", options=options)
    b = kinematics.ik(ur5, T, link="tool0", restarts=2, max_iterations=40, random_seed=3, method="analytic")
    assert np.array_equal(a.solution.q, b.solution.q) and a.solution.success.all()
    every = kinematics.ik(ur5, T, link="tool0", options=dataclasses.replace(options, solutions=SolutionSet("all")))
    assert isinstance(every, kinematics.IKAllAnswer) and (every.count > 0).all()


def test_the_strategy_follows_the_options():
    assert type(selection(IKOptions())) is Numerical
    assert type(selection(IKOptions(collisions=CollisionAvoidance()))) is RetryUntilFree
    assert type(selection(IKOptions(solutions=SolutionSet(method="analytic")))) is NearestOfSet
    assert type(selection(IKOptions(solutions=SolutionSet(locked={"j": 0.0})))) is NearestOfSet


def test_a_caller_strategy_chooses_the_answer(ur5):
    """A strategy of one's own (here: the last solution of the full set) is what ik answers."""

    class Farthest(NearestOfSet):
        def select(self, problem):
            sol, _ = problem.solution_set(problem.start)
            last = sol.count - 1
            q = sol.q[np.arange(len(last)), last]
            return IKSolution(q, sol.count > 0, sol.position_error[np.arange(len(last)), last],
                              sol.rotation_error[np.arange(len(last)), last], np.zeros(len(last), np.int64)), None

    T = _targets(ur5)
    nearest = kinematics.ik(ur5, T, link="tool0", method="analytic")
    farthest = kinematics.ik(ur5, T, link="tool0", method="analytic", select=Farthest())
    every = kinematics.ik(ur5, T, link="tool0", solutions="all")
    assert farthest.solution.success.all()
    assert not np.allclose(nearest.solution.q, farthest.solution.q)  # another member of the set
    p = kinematics.fk(ur5, farthest.solution.q, links=["tool0"]).poses[:, 0]
    assert np.abs(p - T).max() < 1e-9
    assert (every.count > 1).all()


def test_a_registered_family_is_detected_first(ur5):
    chain = ik_families.reduce_chain(ur5, "tool0")
    saved = list(ik_families.DETECTORS)
    try:
        ik_families.register_family("test_family", lambda ch: ik_families.Family("test_family", (), False, 1, ch),
                                    before="subproblems")
        assert ik_families.detect(chain).name == "test_family"
    finally:
        ik_families.DETECTORS[:] = saved
    assert ik_families.detect(chain).name == "three_parallel"


def test_every_family_kernel_is_registered(ur5, catalogue):
    fam = ik_families.detect(ik_families.reduce_chain(ur5, "tool0"))
    kernel = ik_kernels.kernel_of(fam)
    assert kernel.compiled and kernel.candidates == 8 and kernel.bind is not None
    assert ik_kernels.kernel_of(ik_families.Family("general", (), False, None, fam.chain)) is None
    from kinematics.algorithms import ik_general

    assert set(ik_general.KERNELS) | {"three_parallel", "spherical_wrist", "spherical_wrist_search"} == set(
        ik_kernels.KERNELS)
