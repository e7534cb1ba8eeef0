"""The canonical subproblems on random instances: every returned solution satisfies its equation,
the count is right, and the least-squares and degenerate cases are flagged."""

import numpy as np
import pytest

from kinematics.engine.subproblems import DEGENERATE, EXACT, LEAST_SQUARES, rot, rotate, sp1, sp2, sp3, sp4, sp6, trig_solve

RNG = np.random.default_rng(7)
TRIALS = 300


def unit(rng):
    v = rng.normal(size=3)
    return v / np.linalg.norm(v)


def test_rot_is_rodrigues_and_rotate_agrees():
    for _ in range(50):
        k, p, t = unit(RNG), RNG.normal(size=3), RNG.uniform(-4, 4)
        R = rot(k, t)
        assert np.allclose(R.T @ R, np.eye(3), atol=1e-14) and np.isclose(np.linalg.det(R), 1.0)
        assert np.allclose(R @ k, k, atol=1e-14)
        assert np.allclose(rotate(k, t, p), R @ p, atol=1e-14)
        assert np.isclose(np.trace(R), 1 + 2 * np.cos(t))


def test_trig_solve_counts():
    sols, n, f = trig_solve(1.0, 0.0, 0.5)
    assert (n, f) == (2, EXACT) and np.allclose(np.cos(sols), 0.5)
    assert trig_solve(1.0, 0.0, 1.0)[1:] == (1, EXACT)
    assert trig_solve(1.0, 0.0, 2.0)[1:] == (1, LEAST_SQUARES)
    assert trig_solve(0.0, 0.0, 0.0)[2] == DEGENERATE
    assert trig_solve(0.0, 0.0, 1.0)[2] == LEAST_SQUARES


def test_sp1_random():
    for _ in range(TRIALS):
        k, p1, t = unit(RNG), RNG.normal(size=3), RNG.uniform(-np.pi, np.pi)
        p2 = rot(k, t) @ p1
        theta, flag = sp1(p1, p2, k)
        assert flag == EXACT
        assert np.allclose(rot(k, theta) @ p1, p2, atol=1e-12)
        assert abs(np.mod(theta - t + np.pi, 2 * np.pi) - np.pi) < 1e-9


def test_sp1_least_squares_and_degenerate():
    k = np.array([0.0, 0, 1])
    theta, flag = sp1(np.array([1.0, 0, 0]), np.array([0.0, 2, 0]), k)
    assert flag == LEAST_SQUARES and np.isclose(theta, np.pi / 2)
    assert sp1(np.array([0.0, 0, 1]), np.array([0.0, 1, 0]), k)[1] == DEGENERATE


def test_sp2_random():
    for _ in range(TRIALS):
        k1, k2, p1 = unit(RNG), unit(RNG), RNG.normal(size=3)
        t1, t2 = RNG.uniform(-np.pi, np.pi, 2)
        p2 = rot(k2, -t2) @ rot(k1, t1) @ p1
        a, b, n, flag = sp2(p1, p2, k1, k2)
        assert flag == EXACT and n == 2
        for i in range(n):
            assert np.allclose(rot(k1, a[i]) @ p1, rot(k2, b[i]) @ p2, atol=1e-10)
        found = [abs(np.mod(a[i] - t1 + np.pi, 2 * np.pi) - np.pi) < 1e-8 and
                 abs(np.mod(b[i] - t2 + np.pi, 2 * np.pi) - np.pi) < 1e-8 for i in range(n)]
        assert any(found)


def test_sp2_least_squares_and_parallel_axes():
    k1, k2 = np.array([0.0, 0, 1]), np.array([1.0, 0, 0])
    # heights 0.9 along both axes with |p| = 1: no common image
    p1, p2 = np.array([0.43588989, 0, 0.9]), np.array([0.9, 0.43588989, 0])
    assert sp2(p1, p2, k1, k2)[3] == LEAST_SQUARES
    assert sp2(p1, p2, k1, k1)[3] == DEGENERATE


def test_sp3_random():
    for _ in range(TRIALS):
        k, p1, p2 = unit(RNG), RNG.normal(size=3), RNG.normal(size=3)
        t = RNG.uniform(-np.pi, np.pi)
        d = np.linalg.norm(rot(k, t) @ p1 - p2)
        sols, n, flag = sp3(p1, p2, k, d)
        assert flag == EXACT and n in (1, 2)
        for i in range(n):
            assert abs(np.linalg.norm(rot(k, sols[i]) @ p1 - p2) - d) < 1e-9
        assert min(abs(np.mod(sols[i] - t + np.pi, 2 * np.pi) - np.pi) for i in range(n)) < 1e-6


def test_sp3_out_of_reach_is_least_squares():
    k, p1, p2 = np.array([0.0, 0, 1]), np.array([1.0, 0, 0]), np.array([2.0, 0, 0])
    sols, n, flag = sp3(p1, p2, k, 5.0)
    assert flag == LEAST_SQUARES and n == 1 and np.isclose(np.cos(sols[0]), -1.0)  # the farthest point
    assert sp3(np.array([0.0, 0, 1]), p2, k, 1.0)[2] in (DEGENERATE, LEAST_SQUARES)


def test_sp4_random():
    for _ in range(TRIALS):
        h, k, p = unit(RNG), unit(RNG), RNG.normal(size=3)
        t = RNG.uniform(-np.pi, np.pi)
        d = h @ rot(k, t) @ p
        sols, n, flag = sp4(h, p, k, d)
        assert flag == EXACT and n in (1, 2)
        for i in range(n):
            assert abs(h @ rot(k, sols[i]) @ p - d) < 1e-10
        assert min(abs(np.mod(sols[i] - t + np.pi, 2 * np.pi) - np.pi) for i in range(n)) < 1e-6


def test_sp4_degenerate_when_the_axis_is_h():
    k = np.array([0.0, 0, 1])
    p = np.array([1.0, 2, 3])
    assert sp4(k, p, k, 3.0)[2] == DEGENERATE  # every θ
    assert sp4(k, p, k, 1.0)[2] == LEAST_SQUARES  # none


@pytest.mark.parametrize("f", [sp3, sp4])
def test_two_solutions_are_distinct(f):
    k = np.array([0.0, 0, 1])
    if f is sp3:
        sols, n, _ = f(np.array([1.0, 0, 0]), np.array([1.0, 1, 0]), k, 1.0)
    else:
        sols, n, _ = f(np.array([1.0, 0, 0]), np.array([1.0, 0, 0]), k, 0.5)
    assert n == 2 and abs(sols[0] - sols[1]) > 0.1


def sp6_sides(h, k, p, t1, t2):
    """The two left-hand sides of subproblem 6 at angles (t1, t2): ``h0ᵀR(k0, t1)p0 + h1ᵀR(k1, t2)p1``
    and ``h2ᵀR(k2, t1)p2 + h3ᵀR(k3, t2)p3`` (h, k, p of shape (4, 3))."""
    return (h[0] @ rot(k[0], t1) @ p[0] + h[1] @ rot(k[1], t2) @ p[1],
            h[2] @ rot(k[2], t1) @ p[2] + h[3] @ rot(k[3], t2) @ p[3])


def sp6_instance(rng):
    """A random subproblem 6 with a known solution: unit axes h, k (4, 3), points p (4, 3), the angles
    (a, b) drawn from ``rng`` in that order, and the right-hand sides d1, d2 they give."""
    h = np.array([unit(rng) for _ in range(4)])
    k = np.array([unit(rng) for _ in range(4)])
    p = rng.normal(size=(4, 3))
    a, b = rng.uniform(-np.pi, np.pi, 2)
    return (h, k, p, a, b, *sp6_sides(h, k, p, a, b))


def test_sp6_random():
    found_all = 0
    for _ in range(TRIALS):
        h, k, p, a, b, d1, d2 = sp6_instance(RNG)
        t1, t2, n, flag = sp6(h, k, p, d1, d2)
        assert flag == EXACT and 1 <= n <= 4
        for i in range(n):
            s1, s2 = sp6_sides(h, k, p, t1[i], t2[i])
            e1, e2 = s1 - d1, s2 - d2
            assert abs(e1) < 1e-9 and abs(e2) < 1e-9
        close = [abs(np.mod(t1[i] - a + np.pi, 2 * np.pi) - np.pi) < 1e-5 and
                 abs(np.mod(t2[i] - b + np.pi, 2 * np.pi) - np.pi) < 1e-5 for i in range(n)]
        found_all += any(close)
    assert found_all == TRIALS


def test_sp6_counts_every_root_of_a_known_instance():
    # the unit circle x1 and x2 = x1 rotated: with h = k-perpendicular projections, 2 solutions
    z = np.array([0.0, 0, 1])
    x, y = np.array([1.0, 0, 0]), np.array([0.0, 1, 0])
    h = np.array([x, x, y, y]); k = np.array([z, z, z, z]); p = np.array([x, x, x, x])
    # cos θ1 + cos θ2 = 1, sin θ1 + sin θ2 = 0: θ1 = ±60°, θ2 = ∓60°
    t1, t2, n, flag = sp6(h, k, p, 1.0, 0.0)
    assert n == 2 and np.allclose(sorted(np.abs(t1[:n])), [np.pi / 3] * 2)
    assert np.allclose(t1[:n], -t2[:n])


def test_sp6_misses_no_root_of_a_dense_scan():
    """The number of solutions equals the sign changes of |x2(θ1)|² − 1 over a fine grid of θ1."""
    rng = np.random.default_rng(3)
    grid = np.linspace(-np.pi, np.pi, 200_001)
    c, s = np.cos(grid), np.sin(grid)

    def terms(hh, kk, pp):  # hᵀ R(k, θ) p = a cos θ + b sin θ + e
        kp = kk @ pp
        return hh @ pp - (hh @ kk) * kp, hh @ np.cross(kk, pp), (hh @ kk) * kp

    for _ in range(60):
        h, k, p, a, b, d1, d2 = sp6_instance(rng)
        T = [terms(h[i], k[i], p[i]) for i in range(4)]
        B = np.array([[T[1][0], T[1][1]], [T[3][0], T[3][1]]])
        rhs = np.stack([d1 - T[0][2] - T[1][2] - T[0][0] * c - T[0][1] * s,
                        d2 - T[2][2] - T[3][2] - T[2][0] * c - T[2][1] * s])
        x2 = np.linalg.solve(B, rhs)
        f = np.sum(x2 * x2, axis=0) - 1.0
        changes = int(np.sum(np.sign(f[1:]) != np.sign(f[:-1])))
        n = sp6(h, k, p, d1, d2)[2]
        assert n == changes, (n, changes)
