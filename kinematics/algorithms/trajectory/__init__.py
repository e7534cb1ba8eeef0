"""Trajectories: geometric paths through waypoints (:mod:`.path`) and their time parameterisation,
time-optimal under velocity, acceleration and tool-speed limits (:mod:`.topp`) or jerk-limited
(:mod:`.jerk`); :mod:`.plan` puts them together."""
