"""Model-swap sweeps: a spec (:mod:`~xcheck.sweep.spec`: the base scenario, the axes and how each applies to a
cell) and its run (:mod:`~xcheck.sweep.run`: cells in chunks on local processes or a Dask cluster, the resume
log, the sweep report through :mod:`xcheck.report.sweep`). See docs/sweeps.md."""
