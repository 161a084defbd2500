"""The simulators xcheck cross-checks, by engine name, with the package each needs: its version goes into
every report (:func:`xcheck.versions.versions`). An engine is its module here plus its runners in
:mod:`xcheck.runners`."""

#: engine name -> the distribution whose version a report records
ENGINE_PACKAGES = {"mujoco": "mujoco"}
