"""Reading a trajectory file: a CSV of one sample a row, with a header naming its columns (``#`` comment lines
before it are skipped), read a block of lines at a time, keeping only the columns its :class:`Convention` uses.

Memory: reading holds 8 bytes per row for each column read (the time, 3 to 9 attitude columns and 3 rates: 64 MB
for a million rows of quaternions and rates) plus one block of text (:data:`BLOCK` lines, at most :data:`BLOCK_CHARS`
characters), whatever else the file holds; scoring the rows holds :data:`BYTES_PER_ROW` a row in all (the
reference at every row, the errors, the invariants, the detective's readings). A file whose lines (counted first, a
megabyte at a time) would need more than half the memory available is refused before any of it is parsed. A line is at most :data:`MAX_LINE` characters: a longer one (a file with no line
breaks, read as one header of gigabytes: 8.6 GB for a 2 GB file, issue 58) is refused as it is met, in one line.

Bad input is refused with the file, the line and the column named (:class:`TrajectoryFileError`, exit 2): a file
that is not UTF-8 text, no header, a missing column, a row with too few fields or a field that is not a number, a
value that is not finite, times that repeat or go back, times outside the scenario's duration, fewer than two
rows, Euler angles declared in radians that only degrees explain.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..base.errors import UserError
from ..paths import input_problem
from .convention import MAX_FILE_BYTES, Convention, columns_of

__all__ = ["TrajectoryFileError", "Samples", "read_samples", "read_header", "check_rows", "BLOCK", "BYTES_PER_ROW"]

#: Lines parsed at a time, and their characters at most.
BLOCK = 65536
BLOCK_CHARS = 16 * 2**20
#: The longest line read [characters]: a header of 3000 columns, or a row of hundreds of numbers.
MAX_LINE = 65536
#: Peak memory of scoring a file, per row [bytes] (measured with tracemalloc: 320 B for quaternions and rates, passed
#: or failed and investigated; 4.0 GB of resident memory for 1e7 rows, issue 58), with a margin.
BYTES_PER_ROW = 640


class TrajectoryFileError(UserError):
    """A trajectory file that cannot be scored; the message names the file, the line and the column."""


@dataclass
class Samples:
    """The columns a file's convention reads: times (the file's unit), attitude ``(n, k)``, rates ``(n, 3)`` or None;
    ``lines[i]`` is the file's line number of row ``i`` (1-based, as an editor shows it)."""

    t: np.ndarray
    attitude: np.ndarray
    rates: np.ndarray | None
    lines: np.ndarray
    time_column: str
    attitude_columns: tuple
    rate_columns: tuple | None


def _fail(path, message: str):
    raise TrajectoryFileError(f"{path}: {message}")


def read_samples(conv: Convention, *, duration: float | None = None, path: Path | None = None) -> Samples:
    """Read ``conv.file`` (or ``path``) as ``conv`` declares it; ``duration``: the scenario's [s], which no time may
    pass."""
    path = Path(path or conv.file)
    problem = input_problem(path, "trajectory file", limit=MAX_FILE_BYTES)
    if problem:
        raise TrajectoryFileError(problem)
    check_rows(path)
    try:
        with open(path, encoding="utf-8-sig", newline="") as f:
            return _read(f, path, conv, duration)
    except UnicodeDecodeError as exc:
        _fail(path, f"not UTF-8 text (byte {exc.start} of a block): a trajectory file is a CSV")
    except OSError as exc:
        _fail(path, f"cannot be read ({exc.strerror or exc})")


def check_rows(path) -> int:
    """The lines of the file at ``path`` (counted in binary, a megabyte at a time), or a :class:`TrajectoryFileError`
    where scoring as many rows (:data:`BYTES_PER_ROW` each) would need more than half the memory available."""
    from ..trajectory import available_memory

    lines, last = 0, b"\n"
    try:
        with open(path, "rb") as f:
            while chunk := f.read(2**20):
                lines += chunk.count(b"\n")
                last = chunk[-1:]
    except OSError as exc:
        _fail(path, f"cannot be read ({exc.strerror or exc})")
    lines += last != b"\n"
    need, avail = lines * BYTES_PER_ROW, available_memory()
    if avail is not None and need > avail / 2:
        _fail(path, f"{lines:,} lines: scoring as many rows needs about {need / 2**30:.3g} GiB ({BYTES_PER_ROW} bytes a "
                    f"row), more than half of the {avail / 2**30:.3g} GiB available here: score a part of it, or every "
                    "n-th row")
    return lines


def _lines(f, path):
    """The lines of ``f``, each read with a bound (:data:`MAX_LINE`): a longer one is refused as it is met."""
    number = 0
    while True:
        line = f.readline(MAX_LINE + 1)
        if not line:
            return
        number += 1
        if len(line) > MAX_LINE and not line.endswith(("\n", "\r")):
            _fail(path, f"line {number} is longer than {MAX_LINE} characters (no line break within them): a trajectory "
                        "file is a CSV of one sample a line")
        yield line


def _blocks(lines):
    """The lines in blocks of at most :data:`BLOCK` lines and :data:`BLOCK_CHARS` characters."""
    block, chars = [], 0
    for line in lines:
        block.append(line)
        chars += len(line)
        if len(block) >= BLOCK or chars >= BLOCK_CHARS:
            yield block
            block, chars = [], 0
    if block:
        yield block


def _header(lines, path) -> tuple[list[str], int]:
    """The file's header (its first line that is neither blank nor a ``#`` comment) as column names, and its line
    number; refused where there is none."""
    for line_no, raw in enumerate(lines, 1):
        text = raw.strip()
        if text and not text.startswith("#"):
            return [h.strip() for h in text.split(",")], line_no
    _fail(path, "no header: expected a line of column names (e.g. t_s,qw,qx,qy,qz,wx_rad_s,wy_rad_s,wz_rad_s)")


def read_header(path) -> list[str]:
    """The column names of the trajectory file ``path`` (its header), read with the bounds of :func:`read_samples`;
    a :class:`TrajectoryFileError` naming the file where it cannot be read or has none."""
    path = Path(path)
    problem = input_problem(path, "trajectory file", limit=MAX_FILE_BYTES)
    if problem:
        raise TrajectoryFileError(problem)
    try:
        with open(path, encoding="utf-8-sig", newline="") as f:
            return _header(_lines(f, path), path)[0]
    except UnicodeDecodeError as exc:
        _fail(path, f"not UTF-8 text (byte {exc.start} of a block): a trajectory file is a CSV")
    except OSError as exc:
        _fail(path, f"cannot be read ({exc.strerror or exc})")


def _read(f, path, conv: Convention, duration):
    lines = _lines(f, path)
    header, line_no = _header(lines, path)
    try:
        time_col, att_cols, rate_cols = columns_of(conv, header, str(path))
    except ValueError as exc:
        raise TrajectoryFileError(str(exc)) from None
    names = [time_col, *att_cols, *(rate_cols or ())]
    use = [header.index(c) for c in names]
    blocks, line_blocks = [], []
    for chunk in _blocks(lines):
        kept = [k for k, s in enumerate(chunk) if s.strip() and not s.lstrip().startswith("#")]
        rows = [chunk[k] for k in kept]
        if rows:
            try:
                values = np.loadtxt(rows, delimiter=",", usecols=use, ndmin=2, dtype=float, comments=None)
            except ValueError:
                _explain(path, rows, [line_no + 1 + k for k in kept], use, names, header)
            blocks.append(values)
            line_blocks.append(np.asarray(kept, dtype=np.int64) + line_no + 1)
        line_no += len(chunk)
    data = np.concatenate(blocks) if blocks else np.empty((0, len(names)))
    lines = np.concatenate(line_blocks) if line_blocks else np.empty(0, dtype=np.int64)
    if len(data) < 2:
        _fail(path, f"{len(data)} row(s) of samples: a trajectory needs at least two")
    bad = ~np.isfinite(data)
    if bad.any():
        r, c = np.argwhere(bad)[0]
        _fail(path, f"line {lines[r]}, column {names[c]!r}: {float(data[r, c])!r} is not a finite number")
    t = data[:, 0]
    scale = 1e-3 if conv.time_unit == "ms" else 1.0
    step = np.diff(t)
    if (step <= 0).any():
        k = int(np.argmax(step <= 0)) + 1
        how = "repeats" if t[k] == t[k - 1] else "goes back from"
        _fail(path, f"line {lines[k]}, column {time_col!r}: the time {float(t[k])!r} {how} {float(t[k - 1])!r} (line {lines[k - 1]}):"
                    " times must increase")
    if t[0] * scale < 0:
        _fail(path, f"line {lines[0]}, column {time_col!r}: the time {float(t[0])!r} is before the start (0)")
    if duration is not None and t[-1] * scale > duration * (1 + 1e-9) + 1e-12:
        k = int(np.argmax(t * scale > duration * (1 + 1e-9) + 1e-12))
        hint = '; is the time in ms? declare time_unit = "ms"' if conv.time_unit == "s" else ""
        _fail(path, f"line {lines[k]}, column {time_col!r}: the time {float(t[k])!r} {conv.time_unit} is past the scenario's "
                    f"duration ({duration:g} s){hint}")
    attitude = data[:, 1:1 + len(att_cols)]
    if conv.attitude == "euler" and conv.angle_unit == "rad":
        big = np.abs(attitude) > 2 * math.pi + 1e-6
        if big.any():
            r, c = np.argwhere(big)[0]
            _fail(path, f"line {lines[r]}, column {att_cols[c]!r}: the angle {float(attitude[r, c])!r} is beyond 2 pi: are the "
                        "angles in degrees? declare angle_unit = \"deg\"")
    rates = data[:, 1 + len(att_cols):] if rate_cols else None
    return Samples(t=t, attitude=attitude, rates=rates, lines=lines, time_column=time_col,
                   attitude_columns=tuple(att_cols), rate_columns=tuple(rate_cols) if rate_cols else None)


def _explain(path, rows, line_numbers, use, names, header):
    """Find the first row numpy could not read and say why (line and column)."""
    need = max(use) + 1
    for row, line in zip(rows, line_numbers):
        fields = row.rstrip("\r\n").split(",")
        if len(fields) < need:
            _fail(path, f"line {line}: {len(fields)} field(s), but the header has {len(header)} columns (column "
                        f"{header[len(fields)] if len(fields) < len(header) else need!r} is missing)")
        for i, name in zip(use, names):
            try:
                if "_" in fields[i]:  # Python's float takes 0_5 as 5, a CSV reader does not (issue 64)
                    raise ValueError
                float(fields[i])
            except ValueError:
                _fail(path, f"line {line}, column {name!r}: {fields[i].strip()!r} is not a number")
    _fail(path, f"lines {line_numbers[0]}-{line_numbers[-1]}: could not be read as numbers")
