"""The subproblems on IK-Geo's published test cases (tests/fixtures/ikgeo, see its README) and on
thousands of instances of IK-Geo's own generator recipes (matlab/+subproblem_setups/sp_N.m:
vectors uniform in [-1, 1]³, axes those normalised, angles uniform in [-π, π)): every generating
angle is found, and every answer satisfies its equation within 1e-9 unless it is flagged least
squares. Subproblem 6 also on near-double roots (two solutions whose first angles almost agree),
where it is compared with IK-Geo's algorithm (its sp_6 and solve_2_ellipse_numeric, ported below)."""

from __future__ import annotations

import csv
import os

import numpy as np
import pytest

from kinematics.engine.subproblems import EXACT, LEAST_SQUARES, rot, sp1, sp2, sp3, sp4, sp6
from tests.paths import FIXTURES

IKGEO = FIXTURES / "ikgeo"
RESIDUAL = 1e-9  # an exact answer satisfies its equation within this
FOUND = 1e-6  # rad: a generating angle is found when an answer is this close


def rows(name):
    with open(IKGEO / f"{name}.csv", newline="") as fh:
        return [{k: float(v) for k, v in row.items()} for row in csv.DictReader(fh)]


def vec(row, name, i=0):
    """IK-Geo's column ``name`` (entries name_1, name_2, ...), the i-th 3-vector."""
    return np.array([row[f"{name}_{3 * i + j + 1}"] for j in range(3)])


def ang(a, b):
    return abs((a - b + np.pi) % (2 * np.pi) - np.pi)


# ---- the subproblems' equations -------------------------------------------------------------------

def err1(p1, p2, k, t):
    return np.linalg.norm(rot(k, t) @ p1 - p2)


def err2(p1, p2, k1, k2, t1, t2):
    return np.linalg.norm(rot(k1, t1) @ p1 - rot(k2, t2) @ p2)


def err3(p1, p2, k, d, t):
    return abs(np.linalg.norm(rot(k, t) @ p1 - p2) - d)


def err4(h, p, k, d, t):
    return abs(h @ rot(k, t) @ p - d)


def err6(H, K, P, d1, d2, t1, t2):
    return max(abs(H[0] @ rot(K[0], t1) @ P[0] + H[1] @ rot(K[1], t2) @ P[1] - d1),
               abs(H[2] @ rot(K[2], t1) @ P[2] + H[3] @ rot(K[3], t2) @ P[3] - d2))


# ---- checks ----------------------------------------------------------------------------------------

def check_one(sols, n, flag, errors, generating):
    """``sols`` (n answers, each a tuple of angles), their errors; the generating tuple is among them
    and every answer is exact unless flagged least squares."""
    assert n >= 1
    if flag == EXACT:
        assert max(errors) < RESIDUAL, errors
    else:
        assert flag == LEAST_SQUARES
    assert any(all(ang(s, g) < FOUND for s, g in zip(sol, generating)) for sol in sols), (sols, generating)


def solve1(p1, k, p2, theta):
    t, flag = sp1(p1, p2, k)
    check_one([(t,)], 1, flag, [err1(p1, p2, k, t)], (theta,))


def solve2(p1, k1, k2, p2, t1, t2):
    a, b, n, flag = sp2(p1, p2, k1, k2)
    check_one([(a[i], b[i]) for i in range(n)], n, flag, [err2(p1, p2, k1, k2, a[i], b[i]) for i in range(n)], (t1, t2))


def solve3(p1, p2, k, d, theta):
    t, n, flag = sp3(p1, p2, k, d)
    check_one([(t[i],) for i in range(n)], n, flag, [err3(p1, p2, k, d, t[i]) for i in range(n)], (theta,))


def solve4(h, p, k, d, theta):
    t, n, flag = sp4(h, p, k, d)
    check_one([(t[i],) for i in range(n)], n, flag, [err4(h, p, k, d, t[i]) for i in range(n)], (theta,))


def solve6(H, K, P, d1, d2, *pairs):
    """Every pair in ``pairs`` found; returns the answers."""
    t1, t2, n, flag = sp6(H, K, P, d1, d2)
    sols = [(t1[i], t2[i]) for i in range(n)]
    for pair in pairs:
        check_one(sols, n, flag, [err6(H, K, P, d1, d2, *s) for s in sols], pair)
    return sols, flag


# ---- IK-Geo's published cases ----------------------------------------------------------------------

def test_published_sp1():
    for r in rows("sp_1"):
        solve1(vec(r, "p1"), vec(r, "k"), vec(r, "p2"), r["theta"])


def test_published_sp2():
    for r in rows("sp_2"):
        solve2(vec(r, "p1"), vec(r, "k1"), vec(r, "k2"), vec(r, "p2"), r["theta1"], r["theta2"])


def test_published_sp3():
    for r in rows("sp_3"):
        solve3(vec(r, "p1"), vec(r, "p2"), vec(r, "k"), r["d"], r["theta"])


def test_published_sp4():
    for r in rows("sp_4"):
        solve4(vec(r, "h"), vec(r, "p"), vec(r, "k"), r["d"], r["theta"])


def test_published_sp6():
    cases = rows("sp_6")
    assert len(cases) == 10
    for r in cases:
        H, K, P = (np.array([vec(r, name, i) for i in range(4)]) for name in ("H", "K", "P"))
        solve6(H, K, P, r["d1"], r["d2"], (r["theta1"], r["theta2"]))


# ---- IK-Geo's generator recipes -------------------------------------------------------------------

def rand_vec(rng, n=None):
    return rng.uniform(-1, 1, 3 if n is None else (n, 3))


def rand_normal_vec(rng, n=None):
    v = rand_vec(rng, n)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def rand_angle(rng):
    return rng.uniform(-np.pi, np.pi)


def sp6_recipe(rng):
    H, K, P = rand_normal_vec(rng, 4), rand_normal_vec(rng, 4), rand_vec(rng, 4)
    t1, t2 = rand_angle(rng), rand_angle(rng)
    d1 = H[0] @ rot(K[0], t1) @ P[0] + H[1] @ rot(K[1], t2) @ P[1]
    d2 = H[2] @ rot(K[2], t1) @ P[2] + H[3] @ rot(K[3], t2) @ P[3]
    return H, K, P, d1, d2, (t1, t2)


def test_recipes_sp1_to_sp4():
    rng = np.random.default_rng(30)
    for _ in range(2000):
        p1, k, t = rand_vec(rng), rand_normal_vec(rng), rand_angle(rng)
        solve1(p1, k, rot(k, t) @ p1, t)
        p1, k1, k2, t1, t2 = rand_vec(rng), rand_normal_vec(rng), rand_normal_vec(rng), rand_angle(rng), rand_angle(rng)
        solve2(p1, k1, k2, rot(k2, -t2) @ rot(k1, t1) @ p1, t1, t2)
        p1, p2, k, t = rand_vec(rng), rand_vec(rng), rand_normal_vec(rng), rand_angle(rng)
        solve3(p1, p2, k, np.linalg.norm(p2 - rot(k, t) @ p1), t)
        p, k, h, t = rand_vec(rng), rand_normal_vec(rng), rand_normal_vec(rng), rand_angle(rng)
        solve4(h, p, k, h @ rot(k, t) @ p, t)


# ---- near-double roots, against IK-Geo's algorithm -------------------------------------------------

def ikgeo_sp6(H, K, P, d1, d2):
    """IK-Geo's sp_6 (matlab/+subproblem/sp_6.m and solve_2_ellipse_numeric.m): the four unknowns
    (sin θ1, cos θ1, sin θ2, cos θ2) on the two-dimensional solution set of the linear equations
    (QR), the two unit circles intersected as two ellipses (a quartic in the second coordinate)."""
    A = np.zeros((2, 4))
    for i, (r, c) in enumerate([(0, 0), (0, 2), (1, 0), (1, 2)]):
        kxp = np.cross(K[i], P[i])
        A[r, c:c + 2] = H[i] @ np.column_stack([kxp, -np.cross(K[i], kxp)])
    b = np.array([d1 - H[0] @ K[0] * (K[0] @ P[0]) - H[1] @ K[1] * (K[1] @ P[1]),
                  d2 - H[2] @ K[2] * (K[2] @ P[2]) - H[3] @ K[3] * (K[3] @ P[3])])
    Q, R = np.linalg.qr(A.T, mode="complete")
    xn = Q[:, 2:4]
    xm = Q[:, :2] @ np.linalg.solve(R[:2, :2].T, b)
    A1, A2 = xn[:2].T @ xn[:2], xn[2:].T @ xn[2:]
    a, bb, c, (d, e), f = A1[0, 0], 2 * A1[1, 0], A1[1, 1], 2 * xm[:2] @ xn[:2], xm[:2] @ xm[:2] - 1
    a1, b1, c1, (d1_, e1), fq = A2[0, 0], 2 * A2[1, 0], A2[1, 1], 2 * xm[2:] @ xn[2:], xm[2:] @ xm[2:] - 1
    b = bb
    z0 = f*a*d1_**2+a**2*fq**2-d*a*d1_*fq+a1**2*f**2-2*a*fq*a1*f-d*d1_*a1*f+a1*d**2*fq
    z1 = (e1*d**2*a1-fq*d1_*a*b-2*a*fq*a1*e-f*a1*b1*d+2*d1_*b1*a*f+2*e1*fq*a**2+d1_**2*a*e-e1*d1_*a*d
          - 2*a*e1*a1*f-f*a1*d1_*b+2*f*e*a1**2-fq*b1*a*d-e*a1*d1_*d+2*fq*b*a1*d)
    z2 = (e1**2*a**2+2*c1*fq*a**2-e*a1*d1_*b+fq*a1*b**2-e*a1*b1*d-fq*b1*a*b-2*a*e1*a1*e
          + 2*d1_*b1*a*e-c1*d1_*a*d-2*a*c1*a1*f+b1**2*a*f+2*e1*b*a1*d+e**2*a1**2-c*a1*d1_*d
          - e1*b1*a*d+2*f*c*a1**2-f*a1*b1*b+c1*d**2*a1+d1_**2*a*c-e1*d1_*a*b-2*a*fq*a1*c)
    z3 = (-2*a*a1*c*e1+e1*a1*b**2+2*c1*b*a1*d-c*a1*b1*d+b1**2*a*e-e1*b1*a*b-2*a*c1*a1*e
          - e*a1*b1*b-c1*b1*a*d+2*e1*c1*a**2+2*e*c*a1**2-c*a1*d1_*b+2*d1_*b1*a*c-c1*d1_*a*b)
    z4 = a**2*c1**2-2*a*c1*a1*c+a1**2*c**2-b*a*b1*c1-b*b1*a1*c+b**2*a1*c1+c*a*b1**2
    y = np.roots([z4, z3, z2, z1, z0])
    out = []
    for yy in np.real(y[np.abs(np.imag(y)) < 1e-6]):
        x = -(a*fq+a*c1*yy**2-a1*c*yy**2+a*e1*yy-a1*e*yy-a1*f)/(a*b1*yy+a*d1_-a1*b*yy-a1*d)
        v = xm + xn[:, 0] * x + xn[:, 1] * yy
        out.append((np.arctan2(v[0], v[1]), np.arctan2(v[2], v[3])))
    return out


def near_double(rng, eps):
    """IK-Geo's recipe, then p2 and p4 moved (the least change) so that a second pair
    (θ1 + eps, θ2') solves the same instance: two solutions whose first angles differ by eps."""
    H, K, P, _, _, (t1, t2) = sp6_recipe(rng)
    u1, u2 = t1 + eps, rand_angle(rng)
    for i, j in ((0, 1), (2, 3)):
        g = H[j] @ (rot(K[j], t2) - rot(K[j], u2))
        rhs = H[i] @ (rot(K[i], u1) - rot(K[i], t1)) @ P[i]
        P[j] = P[j] + (rhs - g @ P[j]) / (g @ g) * g
    d1 = H[0] @ rot(K[0], t1) @ P[0] + H[1] @ rot(K[1], t2) @ P[1]
    d2 = H[2] @ rot(K[2], t1) @ P[2] + H[3] @ rot(K[3], t2) @ P[3]
    return H, K, P, d1, d2, (t1, t2), (u1, u2)


def contains_ikgeo(H, K, P, d1, d2, sols):
    """Every solution of IK-Geo's algorithm that satisfies the equations is among ours."""
    theirs = [s for s in ikgeo_sp6(H, K, P, d1, d2) if err6(H, K, P, d1, d2, *s) < RESIDUAL]
    for s in theirs:
        assert any(ang(s[0], o[0]) < FOUND and ang(s[1], o[1]) < FOUND for o in sols), (s, sols)
    return len(theirs)


@pytest.mark.parametrize("eps", [1e-3, 1e-5, 1e-7])
def test_sp6_near_double_roots_made_on_purpose(eps):
    rng = np.random.default_rng(6)
    for _ in range(1000):
        H, K, P, d1, d2, first, second = near_double(rng, eps)
        sols, flag = solve6(H, K, P, d1, d2, first, second)
        assert flag == EXACT
        contains_ikgeo(H, K, P, d1, d2, sols)


#: instances of the recipe test: 20,000 with KIN_TEST_FULL_COUNTS=1 (1.7 min on a busy 2-core machine), a
#: fifth of them by default (the same seed: the first 4,000 of the 20,000)
RECIPE_INSTANCES = 20_000 if os.environ.get("KIN_TEST_FULL_COUNTS", "") not in ("", "0") else 4_000


def test_recipe_sp6_twenty_thousand_and_its_near_double_roots():
    """20,000 instances of the recipe (:data:`RECIPE_INSTANCES`). Before the roots were polished, 8 of
    these answers claimed exact had errors from 1e-10 to 2.4e-8; now every answer is exact to rounding.
    Among them, the instances whose solutions (by IK-Geo's algorithm) include two first angles within
    1e-3: every one of IK-Geo's solutions is among ours."""
    rng = np.random.default_rng(0)
    worst, near = 0.0, 0
    for _ in range(RECIPE_INSTANCES):
        H, K, P, d1, d2, pair = sp6_recipe(rng)
        sols, flag = solve6(H, K, P, d1, d2, pair)
        assert flag == EXACT
        worst = max(worst, max(err6(H, K, P, d1, d2, *s) for s in sols))
        theirs = [s for s in ikgeo_sp6(H, K, P, d1, d2) if err6(H, K, P, d1, d2, *s) < RESIDUAL]
        if any(ang(theirs[i][0], theirs[j][0]) < 1e-3 for i in range(len(theirs)) for j in range(i)):
            near += 1
        contains_ikgeo(H, K, P, d1, d2, sols)
    assert worst < 1e-13
    assert near >= 50 * RECIPE_INSTANCES // 20_000  # (77 of 20,000 with this seed; 16 of the first 4,000)
