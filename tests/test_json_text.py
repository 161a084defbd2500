"""The report's JSON files as xcheck writes them (:func:`xcheck.base.files.json_text`): every value back as it was,
the innermost entries one a line, NaN refused."""

from __future__ import annotations

import json
import math

import pytest

from xcheck.base.files import json_text, write_json_atomic


def test_json_text_reads_back_as_the_data_was():
    """Truth: Python's own JSON reader. Nested dicts and lists, floats at full precision (17 digits), keys that are
    not strings written as JSON writes them, empty containers."""
    data = {"schema": "x/1", "runs": [{"dt": 0.1, "error": 1.2345678901234567e-13, "ok": True, "note": None},
                                      {"dt": 0.05, "error": 3e-300, "ok": False, "note": "a \"quoted\" word"}],
            "steps": [0.5, 0.25], 1: [], 2.5: {}, "deep": {"a": {"b": [1, [2, 3], {"c": math.pi}]}}}
    assert json.loads(json_text(data)) == json.loads(json.dumps(data))


def test_json_text_puts_a_runs_metrics_on_one_line_and_refuses_nan(tmp_path):
    text = json_text({"methods": {"m": {"runs": [{"dt": 0.5, "error": 1e-3}, {"dt": 0.25, "error": 2e-4}]}}})
    lines = text.splitlines()
    assert '{"dt":0.5,"error":0.001},' in [line.strip() for line in lines]
    assert len(lines) == 10
    with pytest.raises(ValueError):
        json_text({"error": float("nan")})
    with pytest.raises(ValueError):
        write_json_atomic(tmp_path / "x.json", [float("inf")])
    assert not (tmp_path / "x.json").exists()


def test_trajectory_csv_is_each_value_at_17_digits_and_empty_where_not_finite():
    """Truth: the value-by-value statement (``f"{v:.17g}"``, empty where not finite), which the one-row template
    replaced; random values over 600 decades, a NaN error row, an infinite rate, the Euler angles' columns."""
    import numpy as np

    from xcheck.base.files import trajectory_csv

    rng = np.random.default_rng(61)
    n = 40
    t = np.arange(n) / 256
    q = rng.normal(size=(n, 4)) * 10.0 ** rng.integers(-300, 300, size=(n, 4))
    omega, err, euler = rng.normal(size=(n, 3)), np.abs(rng.normal(size=n)), rng.normal(size=(n, 3))
    err[3], omega[7, 1], euler[9, 2] = np.nan, -np.inf, np.nan
    text = trajectory_csv("a comment", t, q, omega, err, euler)
    lines = text.splitlines()
    assert text.endswith("\n") and lines[0] == "# a comment" and len(lines) == n + 2
    assert lines[1].split(",")[-4:] == ["attitude_error_rad", "euler1_rad", "euler2_rad", "euler3_rad"]
    table = np.hstack([t[:, None], q, omega, err[:, None], euler])
    assert lines[2:] == [",".join("" if not np.isfinite(v) else f"{v:.17g}" for v in row) for row in table]
    assert lines[5].split(",")[8] == "" and lines[9].split(",")[6] == "" and lines[11].split(",")[11] == ""
    assert np.array_equal(np.array([float(v) for v in lines[2].split(",")]), table[0])  # read back exactly
    assert len(trajectory_csv("c", t, q, omega, err).splitlines()[1].split(",")) == 9  # no Euler angles: 9 columns
