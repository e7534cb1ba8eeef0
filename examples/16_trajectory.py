"""Time a UR5 path through four configurations: time-optimal, then jerk-limited, every limit held
(judged from the returned q at 1 kHz), and plot velocities and accelerations against the limits.

Run: python examples/16_trajectory.py [picture.png]
"""

import sys

import numpy as np

import kinematics

ur5 = kinematics.default_catalogue().get("ur5")
waypoints = [[0.0, -1.57, 1.57, 0.0, 1.57, 0.0], [0.5, -1.2, 1.2, 0.3, 1.57, 0.0],
             [1.0, -1.0, 0.8, 0.0, 1.2, 0.5], [1.4, -1.3, 1.1, -0.4, 1.0, 0.9]]
limits = kinematics.TrajectoryLimits(velocity=1.0, acceleration=3.0)  # rad/s, rad/s^2 for every joint
fast = kinematics.trajectory(ur5, waypoints, limits, rate=1000)
smooth = kinematics.trajectory(ur5, waypoints, kinematics.TrajectoryLimits(velocity=1.0, acceleration=3.0, jerk=20.0),
                               rate=1000)


def worst(answer, limits_per_order):
    """The largest |k-th finite difference| / h^k / limit of the returned q (the last, shorter step left out)."""
    h = answer.t[1] - answer.t[0]
    q = answer.q[:-1]
    return max(float(np.max(np.abs(np.diff(q, k, axis=0)) / h**k / lim))
               for k, lim in enumerate(limits_per_order, start=1))


print(f"time-optimal: {fast.duration:.3f} s, {len(fast.t)} samples")
print(f"jerk-limited: {smooth.duration:.3f} s ({smooth.duration / smooth.optimal_duration:.3f} x the optimum)")
print(f"largest limit ratio at 1 kHz, time-optimal: {worst(fast, [1.0, 3.0]):.6f}")
print(f"largest limit ratio at 1 kHz, jerk-limited: {worst(smooth, [1.0, 3.0, 20.0]):.6f}")
print(f"at rest at both ends: {bool(np.abs(fast.qd[[0, -1]]).max() < 1e-9)}")

if len(sys.argv) > 1:  # the picture of the documentation
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 2, figsize=(11, 6), sharex="col")
    for col, (answer, title) in enumerate([(fast, "time-optimal"), (smooth, "jerk-limited (20 rad/s³)")]):
        for row, (values, limit, unit) in enumerate([(answer.qd, 1.0, "rad/s"), (answer.qdd, 3.0, "rad/s²")]):
            ax = axes[row, col]
            ax.plot(answer.t, values, lw=1.2)
            ax.axhline(limit, color="k", ls="--", lw=0.8)
            ax.axhline(-limit, color="k", ls="--", lw=0.8)
            ax.set_ylabel(("velocity " if row == 0 else "acceleration ") + unit)
        axes[0, col].set_title(f"{title}: {answer.duration:.2f} s")
        axes[1, col].set_xlabel("t (s)")
    axes[0, 0].legend(ur5.joint_names, fontsize=7, ncol=2)
    fig.tight_layout()
    fig.savefig(sys.argv[1], dpi=90)
    print(f"picture: {sys.argv[1]}")
