"""What an engine's own C or C++ code writes to the standard error while it runs (issue 62: DART's coloured
``Warning [BodyNode.cpp:633] ...`` lines went raw into the user's terminal), caught into the run's notes instead.

:func:`engine_said` points file descriptor 2 at a file of this process for the length of the block (Python's own
``sys.stderr`` flushed first), then reads what came: each line once, in order, without its ANSI colour codes. The
file is made once a process and emptied for each block (a run costs a few tens of microseconds more). Only the
standard error: an engine's warnings go there, and the standard output stays the command's own."""

from __future__ import annotations

import os
import re
import sys
import tempfile
from contextlib import contextmanager

__all__ = ["engine_said", "clean_lines"]

_ANSI = re.compile(r"\x1b\[[0-9;?]*[ -/]*[@-~]")
_FILE = None


def clean_lines(text: str) -> list[str]:
    """``text``'s non-empty lines without ANSI escape codes, each once, in order of first appearance."""
    lines = (" ".join(_ANSI.sub("", line).split()) for line in text.splitlines())
    return list(dict.fromkeys(line for line in lines if line))


@contextmanager
def engine_said(lines: list):
    """Within the block, what is written to file descriptor 2 goes to a file; after it, its :func:`clean_lines` are
    appended to ``lines``."""
    global _FILE
    if _FILE is None:
        _FILE = tempfile.TemporaryFile()
    sys.stderr.flush()
    _FILE.seek(0)
    _FILE.truncate()
    saved = os.dup(2)
    try:
        os.dup2(_FILE.fileno(), 2)
        yield lines
    finally:
        sys.stderr.flush()  # Python's own writes in the block (a warning) land in the file too
        os.dup2(saved, 2)
        os.close(saved)
        _FILE.seek(0)
        lines.extend(clean_lines(_FILE.read().decode("utf-8", errors="replace")))
