"""The nightly and what it remembers: the history store (:mod:`~xcheck.history.store`: SQLite or PostgreSQL, its
schema and the regression rules), the nightly run (:mod:`~xcheck.history.nightly`: report, compare, record) and
the MuJoCo version matrix (:mod:`~xcheck.history.matrix`: one environment per release). See docs/nightly.md."""
