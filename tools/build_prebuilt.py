"""Make the compiled code the release ships (:mod:`xcheck._prebuilt`, issue 61): run after any change to a compiled
source (``xcheck._jit.COMPILED_SOURCES``; ``tests/test_prebuilt.py`` says when), then commit the archive.

    python tools/build_prebuilt.py            # the full report and the test suite: every function they compile
    python tools/build_prebuilt.py --quick    # the quick report only (a trial: fewer functions)

Into an empty cache folder (``XCHECK_CACHE_DIR``, a temporary folder), with xcheck's generic CPU, it runs the main job
(``xcheck report``, every bundled scenario) and the test suite, then packs the folder as
``xcheck/prebuilt/<folder>.<Python tag>.numba-<version>.<machine>.tar.xz`` and removes the other archives there. About
ten minutes on two cores. A test that fails meanwhile is reported, not fatal: what it compiled is packed all the same.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="the quick report only")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="xcheck-prebuilt-") as tmp:
        env = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_") and k != "XCHECK_NATIVE"}
        env["XCHECK_CACHE_DIR"] = str(Path(tmp) / "cache")
        steps = [[sys.executable, "-m", "xcheck", "report", *(["--quick"] if args.quick else []),
                  "--out", str(Path(tmp) / "reports")]]
        if not args.quick:
            steps.append([sys.executable, "-m", "pytest", "-q", "-n", "auto", "--dist", "loadfile", "-p",
                          "no:cacheprovider", "--ignore", "tests/test_prebuilt.py"])
        for cmd in steps:
            start = time.monotonic()
            print("+", " ".join(cmd[1:]), flush=True)
            code = subprocess.run(cmd, cwd=ROOT, env=env).returncode
            print(f"  exit {code} in {time.monotonic() - start:.0f} s", flush=True)
            if code and cmd is steps[0]:
                return code
        probe = ("import numba; from xcheck import _jit, _prebuilt; assert _jit.GENERIC; "
                 "print(_jit.cache_root(), _prebuilt.archive_name(_jit.cache_root().name, numba.__version__))")
        root, name = subprocess.run([sys.executable, "-c", probe], cwd=ROOT, env=env, capture_output=True, text=True,
                                    check=True).stdout.split()
        sys.path.insert(0, str(ROOT))
        from xcheck import _prebuilt

        for old in _prebuilt.FOLDER.glob("*.tar.xz"):
            if old.name != name:
                old.unlink()
        n = _prebuilt.pack(Path(root), _prebuilt.FOLDER / name)
        size = (_prebuilt.FOLDER / name).stat().st_size
        print(f"{n} files packed: xcheck/prebuilt/{name}, {size / 1e6:.1f} MB")
    return 0


if __name__ == "__main__":
    sys.exit(main())
