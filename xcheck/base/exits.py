"""How a stopped command ends, said once: the exit code and the one line of Ctrl-C and SIGTERM.

It imports nothing, so the command's entry (:mod:`xcheck.__main__`) uses it before anything else is loaded, and
:mod:`xcheck.cli` uses it once the command runs.
"""

EXIT_INTERRUPTED, EXIT_TERMINATED = 130, 143  # 128 + SIGINT, 128 + SIGTERM: a shell's convention
_WORD = {EXIT_INTERRUPTED: "interrupted", EXIT_TERMINATED: "terminated"}


def stopped_line(code: int, written=None) -> str:
    """The one line a stopped command prints (``code``: :data:`EXIT_INTERRUPTED` or :data:`EXIT_TERMINATED`);
    ``written``, the report that was complete when the signal came, if any."""
    what = f"the report {written} is complete" if written else "no report was written"
    return f"\nxcheck: {_WORD[code]}; {what}"
