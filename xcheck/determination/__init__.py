"""Attitude determination (seed 002): the static methods (:mod:`~xcheck.determination.methods`: TRIAD, the
q-method, QUEST, SVD, and the predicted accuracy), seed 002's tables reproduced
(:mod:`~xcheck.determination.seed002`), the sensors and a scenario's ``[determination]`` table
(:mod:`~xcheck.determination.sensors`), and the study on a scenario's run (:mod:`~xcheck.determination.study`).
The first two are core (no engine, no plotting); the study runs an engine."""
