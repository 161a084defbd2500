"""The README's set-up contract and the command line's basics."""

import re
import subprocess
import sys
from pathlib import Path

from xcheck import __version__
from xcheck.cli import main

ROOT = Path(__file__).resolve().parents[1]


def test_readme_opens_with_exactly_two_setup_commands():
    text = (ROOT / "README.md").read_text()
    first_block = re.search(r"```bash\n(.*?)```", text, re.S)
    assert first_block and text.index("```bash") < text.index("\n## "), "the set-up block must come first"
    lines = [line for line in first_block.group(1).splitlines() if line.strip()]
    assert len(lines) == 2
    assert lines[0].endswith("xcheck report") and "pip install" in lines[0]
    assert "pytest" in lines[1] and ".[test,basilisk,engines]" in lines[1]  # the test extra and the engines


def test_version_and_list(capsys):
    proc = subprocess.run([sys.executable, "-m", "xcheck", "--version"], capture_output=True, text=True)
    assert proc.returncode == 0 and proc.stdout.strip() == f"xcheck {__version__}"
    assert main(["list"]) == 0
    assert "gyroscope-nonsingular" in capsys.readouterr().out


def test_the_command_leaves_at_once_with_everything_said(tmp_path):
    """cli.entry leaves with os._exit once a command ran to its end (the interpreter's teardown cost 0.3 s): what
    it printed to a pipe and a file is all there, and its exit code is the command's."""
    import subprocess
    import sys

    out = tmp_path / "out.txt"
    with out.open("w") as f:
        proc = subprocess.run([sys.executable, "-m", "xcheck", "converge", "gyroscope-singular", "--quick", "--methods",
                               "euler-rk4,formulation-2", "--workers", "1"], stdout=f, stderr=subprocess.PIPE, text=True)
    text = out.read_text()
    assert proc.returncode == 0 and "euler-rk4" in text and text.rstrip().splitlines()[-1].startswith("wall time"), text
    listed = subprocess.run([sys.executable, "-m", "xcheck", "list"], capture_output=True, text=True)
    assert listed.returncode == 0 and "tumbler-intermediate-axis" in listed.stdout
