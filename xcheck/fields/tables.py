"""Field tables as CSV files: ``#`` comment lines, an optional header line, rows ``t, Hx, Hy, Hz``."""

from __future__ import annotations

from pathlib import Path

import numpy as np


def load_field_table(path) -> np.ndarray:
    """Read a field table: ``#`` comment lines, an optional header line, then rows ``t, Hx, Hy, Hz``
    (comma-separated; t [s] strictly increasing, H [A/m]). Errors name the file and the line."""
    from ..paths import input_problem

    path = Path(path)
    problem = input_problem(path, "field table")
    if problem:
        raise ValueError(problem)
    try:
        lines = path.read_bytes().decode("utf-8-sig").splitlines()
    except OSError as exc:
        raise ValueError(f"{path}: cannot read the field table ({exc.strerror})") from None
    except UnicodeDecodeError as exc:
        raise ValueError(f"{path}: not UTF-8 text (offset {exc.start}); a field table is a CSV text file") from None
    rows = []
    for number, line in enumerate(lines, start=1):
        text = line.strip()
        if not text or text.startswith("#"):
            continue
        parts = [p.strip() for p in text.split(",")]
        try:
            values = [float(p) for p in parts]
        except ValueError:
            if not rows and any(c.isalpha() for c in text):
                continue  # a header line
            raise ValueError(f"{path}, line {number}: expected 4 numbers (t [s], Hx, Hy, Hz [A/m]), got {text!r}") \
                from None
        if len(values) != 4:
            raise ValueError(f"{path}, line {number}: expected 4 columns (t [s], Hx, Hy, Hz [A/m]), got {len(values)}")
        if not all(np.isfinite(values)):
            raise ValueError(f"{path}, line {number}: non-finite value in {text!r}")
        rows.append(values)
    table = np.array(rows, dtype=float).reshape(-1, 4)
    if len(table) < 2:
        raise ValueError(f"{path}: a field table needs at least 2 rows, found {len(table)}")
    bad = np.nonzero(np.diff(table[:, 0]) <= 0)[0]
    if len(bad):
        raise ValueError(f"{path}: the time column must be strictly increasing (row {bad[0] + 2} of the data)")
    return table


def write_field_table(path, table, header_lines=()) -> None:
    """Write a field table (see :func:`load_field_table`) with ``#`` header lines, 12 significant digits."""
    with open(path, "w") as f:
        for line in header_lines:
            f.write(f"# {line}\n")
        f.write("t_s,Hx_A_per_m,Hy_A_per_m,Hz_A_per_m\n")
        for row in np.asarray(table, dtype=float):
            f.write(",".join(f"{v:.12g}" for v in row) + "\n")
