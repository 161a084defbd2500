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
