"""Engines other than our own integrators, each a runner returning a :class:`~xcheck.trajectory.Trajectory`."""
