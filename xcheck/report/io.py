"""Atomic writes: a file or folder appears under its final name only when complete."""

from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path


def write_text_atomic(path, text: str) -> None:
    """Write ``text`` to a temporary file beside ``path``, then rename it into place."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "w") as f:
            f.write(text)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600; a report is for reading
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def write_json_atomic(path, data) -> None:
    write_text_atomic(path, json.dumps(data, indent=1, allow_nan=False) + "\n")


def write_trajectory_csv(path, comment: str, t, q, omega, attitude_error, euler=None) -> None:
    """A trajectory as CSV: a ``#`` comment line, a header, then ``t, q (4), omega (3), error`` (and three
    Euler angles if given), 17 significant digits; a non-finite value (an error where the reference is
    not defined) is an empty field."""
    import numpy as np

    header = ["t_s", "qw", "qx", "qy", "qz", "wx_rad_s", "wy_rad_s", "wz_rad_s", "attitude_error_rad"]
    cols = [np.asarray(t)[:, None], q, omega, np.asarray(attitude_error)[:, None]]
    if euler is not None:
        header += ["euler1_rad", "euler2_rad", "euler3_rad"]
        cols.append(euler)
    lines = [f"# {comment}", ",".join(header)]
    lines += [",".join("" if not np.isfinite(v) else f"{v:.17g}" for v in row) for row in np.hstack(cols)]
    write_text_atomic(path, "\n".join(lines) + "\n")
