"""Paths and time parameterisation of trajectories (kinematics.algorithms.trajectory): the spline
equals SciPy's, the blended path keeps its promises, every limit holds at every instant (exact
derivatives on a dense grid, finite differences of q at 1 kHz), the motion stays on the path,
starts and ends at rest, and is as short as TOPP-RA's."""

from __future__ import annotations

import numpy as np
import pytest

from kinematics.algorithms.trajectory.jerk import FilteredProfile, jerk_limited, motion_bound, proven_scale
from kinematics.algorithms.trajectory.path import linear_path, poly_range, spline_path
from kinematics.algorithms.trajectory.plan import plan, sample_times
from kinematics.algorithms.trajectory.topp import ToolRate, joint_motion, topp
from kinematics.spatial.reference import Reference

RNG_SEED = 7
V = np.array([2.0, 1.5, 2.5, 3.0, 3.0, 3.5])
A = np.array([5.0, 4.0, 6.0, 8.0, 8.0, 10.0])
J = np.array([50.0, 40.0, 60.0, 80.0, 80.0, 100.0])
#: relative slack of the checks: rounding of the finite differences of q
SLACK = 1e-7


def waypoints(m: int, dof: int = 6, seed: int = RNG_SEED) -> np.ndarray:
    return np.random.default_rng(seed).uniform(-2.0, 2.0, (m, dof))


def finite_difference_ratios(q: np.ndarray, h: float, limits) -> list[float]:
    """Largest |k-th difference| / h^k / limit of q sampled every h (k = 1, 2, 3 for the limits given)."""
    return [float(np.max(np.abs(np.diff(q, k, axis=0)) / h**k / lim)) for k, lim in enumerate(limits, start=1)]


@pytest.mark.parametrize("m", [2, 3, 4, 5, 9])
def test_spline_equals_scipy(m):
    interpolate = pytest.importorskip("scipy.interpolate")
    W = waypoints(m)
    path = spline_path(W)
    ref = interpolate.CubicSpline(np.linspace(0, 1, m), W)
    s = np.linspace(0, 1, 777)
    for order in range(4):
        np.testing.assert_allclose(path.derivative(s, order), ref(s, order), atol=1e-9 * 10**order)


def test_poly_range_is_exact():
    rng = np.random.default_rng(1)
    c = rng.normal(size=(50, 4, 3))
    t1 = rng.uniform(0.1, 2.0, (50, 1))
    lo, hi = poly_range(c, np.zeros_like(t1), t1)
    t = np.linspace(0, 1, 20001)[None, :, None] * t1[:, :, None]  # (50, K, 1)
    v = sum(c[:, None, k, :] * t**k for k in range(4))
    np.testing.assert_allclose(lo, v.min(axis=1), atol=1e-7)
    np.testing.assert_allclose(hi, v.max(axis=1), atol=1e-7)
    assert np.all(lo <= v.min(axis=1) + 1e-12) and np.all(hi >= v.max(axis=1) - 1e-12)


def test_linear_blends_keep_their_promises():
    W = waypoints(6)
    blend = 0.4
    path = linear_path(W, blend)
    s = np.linspace(0, path.breaks[-1], 200001)
    q = path.q(s)
    dist = np.linalg.norm(q[:, None, :] - W[None, 1:-1, :], axis=2).min(axis=1)
    far = dist > blend + 1e-12
    # far from every inner corner the point lies on a straight segment between consecutive waypoints
    seg = W[1:] - W[:-1]
    on_segment = np.zeros(len(s), bool)
    for a, d in zip(W[:-1], seg):
        lam = np.clip(((q - a) @ d) / (d @ d), 0, 1)
        on_segment |= np.linalg.norm(q - (a + lam[:, None] * d), axis=1) < 1e-9
    assert on_segment[far].all()
    assert not on_segment.all()  # the corners are cut
    # C2 at every breakpoint
    b = path.breaks[1:-1]
    for order in range(3):
        np.testing.assert_allclose(path.derivative(b - 1e-13, order), path.derivative(b + 1e-13, order), atol=1e-9)
    assert path.stops == ()
    assert linear_path(W, 0.0).stops == tuple(np.r_[0.0, np.cumsum(np.linalg.norm(seg, axis=1))][1:-1])


def check_motion(timing, path, v, a, j=None, rate=1000.0):
    """Every limit at 1 kHz (exact derivatives and finite differences of q), on the path, at rest at both ends."""
    t = sample_times(timing.duration, rate)
    q, qd, qdd, qddd = timing.sample(t)
    assert np.max(np.abs(qd) / v) <= 1 + SLACK
    assert np.max(np.abs(qdd) / a) <= 1 + SLACK
    uniform = t[:-1]  # the last step may be shorter
    ratios = finite_difference_ratios(q[:len(uniform)], 1 / rate, [v, a] + ([j] if j is not None else []))
    assert max(ratios) <= 1 + SLACK, ratios
    if j is not None:
        assert np.max(np.abs(qddd) / j) <= 1 + SLACK
    np.testing.assert_allclose(q[0], path.q(np.array([path.breaks[0]]))[0], atol=1e-12)
    np.testing.assert_allclose(q[-1], path.q(np.array([path.breaks[-1]]))[0], atol=1e-9)
    assert np.abs(qd[[0, -1]]).max() < 1e-6
    return t, q, qd, qdd, qddd


def dense_limits(prof, path, v, a, n=400001):
    tt = np.linspace(0, prof.duration, n)
    s, sd, sdd = prof.at(tt)
    _, qd, qdd = joint_motion(path, s, sd, sdd)
    return np.max(np.abs(qd) / v), np.max(np.abs(qdd) / a)


@pytest.mark.parametrize("m", [2, 4, 7])
def test_time_optimal_spline_holds_limits_everywhere(m):
    path = spline_path(waypoints(m))
    timing = plan(path, V, A)
    check_motion(timing, path, V, A)
    rv, ra = dense_limits(timing.parts[0][1], path, V, A)
    assert rv <= 1 and ra <= 1
    assert max(rv, ra) > 0.999  # some limit is reached: not a slow, trivially safe answer


def test_coarse_grid_is_still_safe_between_grid_points():
    path = spline_path(waypoints(5))
    prof = topp(path, V, A, n=20)  # 20 intervals: the constraints are bounded over each whole interval
    rv, ra = dense_limits(prof, path, V, A)
    assert rv <= 1 and ra <= 1


def test_motion_stays_on_the_path():
    path = spline_path(waypoints(5))
    timing = plan(path, V, A)
    prof = timing.parts[0][1]
    t = np.linspace(0, timing.duration, 1001)
    s, sd, _ = prof.at(t)
    q = timing.sample(t)[0]
    np.testing.assert_allclose(q, path.q(s), atol=1e-12)
    assert np.all(np.diff(s) >= 0) and s[0] == 0 and abs(s[-1] - 1) < 1e-9


def test_linear_without_blend_stops_at_each_corner():
    W = waypoints(4)
    path = linear_path(W, 0.0)
    timing = plan(path, V, A)
    assert len(timing.parts) == 3
    q, qd, _, _ = timing.sample(timing.starts)
    np.testing.assert_allclose(q, W[:3], atol=1e-9)
    assert np.abs(qd).max() < 1e-9
    check_motion(timing, path, V, A)


def test_tool_speed_is_held():
    # a "tool" whose speed is |M q'| for a fixed matrix: the bound must hold at every sample
    # (|d^2p/ds^2| = |M q''| <= |M|_2 sum |q''|)
    Mx = np.random.default_rng(3).normal(size=(3, 6))
    tool = ToolRate(lambda Q, Qp: np.linalg.norm(Qp @ Mx.T, axis=1), 0.5, np.linalg.norm(Mx, 2), np.ones(6))
    path = spline_path(waypoints(4))
    timing = plan(path, V, A, tool=tool)
    free = plan(path, V, A)
    t = np.linspace(0, timing.duration, 100001)
    _, qd, _, _ = timing.sample(t)
    speed = np.linalg.norm(qd @ Mx.T, axis=1)
    assert speed.max() <= 0.5 * (1 + SLACK)
    assert speed.max() > 0.49 and timing.duration > free.duration


@pytest.mark.parametrize("kind", ["spline", "linear"])
def test_jerk_limited(kind):
    W = waypoints(5)
    path = spline_path(W) if kind == "spline" else linear_path(W, 0.3)
    timing = plan(path, V, A, J)
    t, q, qd, qdd, qddd = check_motion(timing, path, V, A, J)
    assert np.abs(qdd[[0, -1]]).max() < 1e-9  # zero acceleration at both ends
    # continuous acceleration: on a fine grid its steps shrink with the step (no jump)
    tt = np.linspace(0, timing.duration, 200001)
    qdd_fine = timing.sample(tt)[2]
    assert np.max(np.abs(np.diff(qdd_fine, axis=0))) <= np.max(J) * (tt[1] - tt[0]) * (1 + 1e-6)
    optimum = plan(path, V, A).duration
    assert optimum < timing.duration < 2 * optimum


def test_jerk_limited_motion_keeps_the_path():
    path = spline_path(waypoints(4))
    prof = jerk_limited(path, V, A, J, n=300)
    t = np.linspace(0, prof.duration, 3001)
    s = prof.at(t)[0]
    assert np.all(np.diff(s) >= -1e-12) and abs(s[0]) < 1e-12 and abs(s[-1] - 1) < 1e-9


def fine_peaks(timing, path, limits, uniform=400001, per_piece=100001):
    """The largest |qd| / v, |qdd| / a, |qddd| / j over a uniform sampling of ``timing`` 400 times finer
    than 1 kHz on a few-second motion, and far finer over each piece of the path (the blends, where
    the jerk peaks)."""
    worst = np.zeros(3)

    def at(t):
        values = timing.sample(t)[1:]
        worst[:] = np.maximum(worst, [np.max(np.abs(x) / lim) for x, lim in zip(values, limits)])

    t = np.linspace(0, timing.duration, uniform)
    at(t)
    s = timing.parts[0][1].at(t)[0]
    for a, b in zip(path.breaks[:-1], path.breaks[1:]):
        i0, i1 = max(np.searchsorted(s, a) - 2, 0), min(np.searchsorted(s, b) + 2, len(t) - 1)
        at(np.linspace(t[i0], t[i1], per_piece))
    return worst


@pytest.mark.parametrize("kind", ["spline", "linear"])
def test_motion_bound_encloses_every_instant(kind):
    # a coarse profile (20 grid intervals): long intervals between breakpoints, each sampled densely
    W = waypoints(5)
    path = spline_path(W) if kind == "spline" else linear_path(W, 0.3)
    f = FilteredProfile(topp(path, V, 0.6 * A, n=20), 0.05)
    t = np.unique(np.r_[0.0, f.breakpoints(), f.duration])
    ta, tb = t[:-1], t[1:]
    bounds = motion_bound(path, f, ta, tb)
    inner = ta[:, None] + (tb - ta)[:, None] * np.linspace(1e-9, 1 - 1e-9, 201)  # the jerk jumps at the ends
    values = joint_motion(path, *f.at(inner.ravel()))[1:]
    for bound, x in zip(bounds, values):
        peak = np.abs(x).reshape(len(ta), 201, -1).max(axis=1)
        assert np.all(peak <= bound * (1 + 1e-12) + 1e-12)
    # and the scale proven from them is the peak's, within its tolerance
    k = proven_scale(path, f, (V, A, J))
    sampled = max(np.max(np.abs(x) / lim) ** (1 / order) for order, (x, lim) in enumerate(zip(values, (V, A, J)), 1))
    assert sampled <= k <= sampled * (1 + 1e-3)


def test_jerk_limit_holds_where_sampling_misses_the_peak():
    # straight segments with small blends: the jerk peaks for a few milliseconds in each blend,
    # between the samples of a time scale judged from samples (the 1 kHz answer reads it lower)
    W = waypoints(4, seed=0)
    path = linear_path(W, 0.01)
    timing = plan(path, V, A, J)
    worst = fine_peaks(timing, path, (V, A, J))
    assert np.all(worst <= 1 + 1e-9), worst
    assert worst[2] > 0.999  # the jerk limit is reached: the scale is not a slow, trivially safe one
    t = sample_times(timing.duration, 1000.0)
    kilohertz = np.max(np.abs(timing.sample(t)[3]) / J)
    assert kilohertz < 0.99 * worst[2]  # plain sampling at the answer's rate misses the peak
    check_motion(timing, path, V, A, J)


def test_against_toppra():
    ta = pytest.importorskip("toppra")
    from toppra import algorithm, constraint

    ta.setup_logging("WARNING")
    for seed, m in [(1, 3), (2, 5)]:
        W = waypoints(m, seed=seed)
        path = ta.SplineInterpolator(np.linspace(0, 1, m), W)
        inst = algorithm.TOPPRA([constraint.JointVelocityConstraint(np.c_[-V, V]),
                                 constraint.JointAccelerationConstraint(np.c_[-A, A])], path,
                                gridpoints=np.linspace(0, 1, 2001), parametrizer="ParametrizeConstAccel")
        theirs = inst.compute_trajectory().duration
        ours = plan(spline_path(W), V, A).duration
        assert ours <= 1.005 * theirs
        assert ours >= 0.99 * theirs  # the same problem: not shorter than the optimum by more than its grid error


def test_still_path_has_zero_duration():
    W = np.zeros((3, 6))
    timing = plan(spline_path(W), V, A)
    assert timing.duration == 0.0
    np.testing.assert_array_equal(sample_times(0.0, 100.0), [0.0])


def robot_tool(model_id: str, link: str, point, path, W, limit: float = 0.5):
    """A real robot's tool rate along ``path`` (the use case's :class:`ToolRate`)."""
    from kinematics.io import default_catalogue
    from kinematics.usecases.query import Query
    from kinematics.usecases.trajectory import ToolSpeed, tool_rate

    return tool_rate(Query.of(default_catalogue().get(model_id)), ToolSpeed(link, limit, point), path, W)


@pytest.mark.parametrize("model_id, link, point", [
    ("ur5", "tool0", [1.0, 0.0, 0.0]),
    ("stanford_arm", "tool", [0.0, 0.3, 0.2]),  # a prismatic joint in the chain
    ("tiago_no_hand", "arm_tool_link", [0.2, 0.0, 0.0]),  # prismatic torso; wheels and head off the chain
])
def test_tool_rate_bound_encloses_dense_samples(model_id, link, point):
    from kinematics.algorithms.trajectory.topp import grid, interval_rows, tool_bound
    from kinematics.io import default_catalogue

    model = default_catalogue().get(model_id)
    W = model.sample_configurations(4, np.random.default_rng(1), continuous_range=4.0)
    path = spline_path(W)
    lo, hi = poly_range(path.coeffs, np.zeros((3, 1)), np.diff(path.breaks)[:, None])
    if np.any(lo < model.lower_limits) or np.any(hi > model.upper_limits):  # keep the path in its limits
        path = linear_path(W, 0.2)  # blended: q' continuous (a part as the planner times it)
    tool = robot_tool(model_id, link, point, path, W)
    chain = {j.name for j in model.path_joints(link) if j.moving}
    assert tool.weights.tolist() == [float(name in chain) for name in model.joint_names]
    s, piece = grid(path, 30)
    _, _, _, ranges = interval_rows(path, s, piece, np.ones(path.dof))
    a, b, e = (r @ tool.weights for r in ranges)
    L, M = tool.reach * (b + a * a), tool.reach * (e + 3 * a * b + a**3)  # |d2p/ds2|, |d3p/ds3| bounds
    dense = s[:-1, None] + np.diff(s)[:, None] * np.linspace(0.0, 1.0, 2049)
    w = tool.rate(path.q(dense.ravel()), path.derivative(dense.ravel(), 1)).reshape(dense.shape)
    h = np.diff(s)[:, None]
    for k in (1, 4, 64):  # w within each of k sub-intervals: its larger end plus either margin
        sub = w[:, :-1].reshape(len(h), k, -1)
        ends = np.maximum(sub[:, :, 0], np.r_["1", sub[:, 1:, 0], w[:, -1:]])
        rise = (sub.max(axis=2) - ends).max(axis=1)
        assert np.all(rise <= L * h[:, 0] / k / 2) and np.all(rise <= M * (h[:, 0] / k) ** 2 / 8)
        assert np.all(w.max(axis=1) <= tool.bound(path, s[:-1], s[1:], ranges, k))
    # the speed cap of each interval keeps the dense samples within the limit
    cap = tool_bound(path, s, tool, ranges, np.full(len(s) - 1, np.inf))
    assert np.all(w.max(axis=1) * np.sqrt(cap) <= tool.max * (1 + 1e-12))


#: a fast turn of the UR5's last joint with a tool point 1 m off its axis, and a turn of the base:
#: the tool's speed peaks between the samples of a coarse grid
WRIST_TURN = np.array([[-0.711, 1.187, -1.099, -0.551, -0.33, 0.166], [-3.035, 1.187, -1.099, -0.551, -0.33, -4.167]])
FAST = (np.full(6, 20.0), np.full(6, 40.0), np.full(6, 400.0))


def dense_tool_ratio(path, prof, tool, n: int = 400001) -> float:
    """The largest tool speed over its limit at ``n`` uniform times of ``prof``."""
    s, sd = prof.at(np.linspace(0.0, prof.duration, n))[:2]
    return float(np.max(tool.rate(path.q(s), path.derivative(s, 1)) * sd) / tool.max)


def test_tool_speed_held_where_sampling_misses_the_peak(monkeypatch):
    import kinematics.algorithms.trajectory.topp as topp_module

    path = spline_path(WRIST_TURN)
    tool = robot_tool("ur5", "tool0", [1.0, 0.0, 0.0], path, WRIST_TURN)
    V_, A_, _ = FAST
    for n in (4, 50, 2000):
        ratio = dense_tool_ratio(path, topp(path, V_, A_, n, tool), tool)
        assert 0.98 < ratio <= 1.0, (n, ratio)
    # the interval bound from samples alone (5 per interval, 0.1 % over them) goes over the limit here
    monkeypatch.setattr(topp_module, "tool_bound", lambda path, s, tool, *_: topp_module.speed_cap(
        tool.sampled(path, s[:-1], s[1:], 4) * 1.001, tool.max))
    assert dense_tool_ratio(path, topp(path, V_, A_, 4, tool), tool) > 1.0005


@pytest.mark.parametrize("n", [20, 200])
def test_jerk_limited_tool_speed_held_at_every_instant(n):
    path = spline_path(WRIST_TURN)
    tool = robot_tool("ur5", "tool0", [1.0, 0.0, 0.0], path, WRIST_TURN)
    f = jerk_limited(path, *FAST, n, tool)
    ratio = dense_tool_ratio(path, f, tool)
    assert 0.99 < ratio <= 1.0, ratio  # the tool's speed is what limits it, and never over its limit
    # per interval between breakpoints, the proven bound of the tool's speed encloses fine samples
    bp = np.unique(np.r_[0.0, f.breakpoints(), f.duration])
    bp = bp[bp <= f.duration]
    ta, tb = bp[:-1], bp[1:]
    tool_speed = motion_bound(path, f, ta, tb, tool)[3][:, 0]
    inner = ta[:, None] + (tb - ta)[:, None] * np.linspace(0.0, 1.0, 101)
    s, sd = f.at(inner.ravel())[:2]
    fine = (tool.rate(path.q(s), path.derivative(s, 1)) * sd).reshape(inner.shape).max(axis=1)
    assert np.all(fine <= tool_speed * (1 + 1e-12))


@pytest.mark.parametrize("jerk", [None, 400.0])
def test_use_case_tool_speed_judged_densely(jerk):
    # the whole use case on a real arm: |J_v(q) qd| from the answer's own timing at 200,001 instants
    from kinematics.engine.poe import compile_model
    from kinematics.io import default_catalogue
    from kinematics.usecases.trajectory import ToolSpeed, TrajectoryLimits, trajectory

    ur5 = default_catalogue().get("ur5")
    W = np.r_[WRIST_TURN[:1], [[-1.9, 1.0, -1.3, -0.4, -0.2, -2.0]], WRIST_TURN[1:]]
    limits = TrajectoryLimits(20.0, 40.0, jerk, ToolSpeed("tool0", 0.5, [1.0, 0.0, 0.0]))
    answer = trajectory(ur5, W, limits, rate=100.0, grid_points=200)
    q, qd, _, _ = answer.timing.sample(np.linspace(0.0, answer.duration, 200001))
    point = np.eye(4)
    point[0, 3] = 1.0
    Jv = compile_model(ur5).jacobian(q, "tool0", Reference.LOCAL_WORLD_ALIGNED, tool=point)[:, :3, :]
    speed = np.linalg.norm(np.einsum("kij,kj->ki", Jv, qd), axis=1)
    assert 0.99 * 0.5 < speed.max() <= 0.5
