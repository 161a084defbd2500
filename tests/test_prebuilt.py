"""The compiled code a release ships (xcheck/_prebuilt.py, issue 61): this commit's, found by a first run on a machine
that never compiled it, unpacked whole or not at all, for a target chosen as documented, and the same numbers as the
host's own compile."""

from __future__ import annotations

import os
import subprocess
import sys
import tarfile
import types

import numba
import numpy as np
import pytest

import xcheck
from xcheck import _jit, _prebuilt

REBUILD = "python tools/build_prebuilt.py (about ten minutes), then commit xcheck/prebuilt/"


def _ours() -> str:
    return f"numba-{xcheck.__version__}-{_jit.sources_digest()}-{_prebuilt.TARGET}"


def test_the_shipped_code_is_this_commits_compiled_sources():
    """One archive, made from today's compiled sources (their hash is in its name): else a newcomer compiles
    everything again, the cold start of issue 61 silently lost."""
    names = sorted(p.name for p in _prebuilt.FOLDER.glob("*.tar.xz"))
    assert len(names) == 1 and names[0].startswith(_ours() + "."), (
        f"xcheck/prebuilt/ holds {names}, not the code of today's compiled sources ({_ours()}): {REBUILD}")


def _fits():
    archive = _prebuilt.archive_for(_ours(), numba.__version__)
    if archive is None:
        pytest.skip(f"no shipped compiled code for this interpreter and numba "
                    f"({_prebuilt.archive_name(_ours(), numba.__version__)}): xcheck compiles on its first run here")
    return archive


def test_a_first_run_loads_the_shipped_code_and_compiles_nothing(tmp_path):
    """Truth: numba's own cache log (NUMBA_DEBUG_CACHE). An empty cache folder (a machine that never ran xcheck): a
    study's kernels, the batch lanes, the reference's DOP853 and the metrics are loaded, none compiled or saved."""
    _fits()
    script = ("import numpy as np\n"
              "from xcheck.integrators import compile_cache_is_cold, precompile, integrate_batch\n"
              "from xcheck import _jit\n"
              "cold = compile_cache_is_cold()\n"
              "precompile(['formulation-2', 'lie-rkmk4', 'euler-rk4', 'split-yoshida4', 'lie-lgvi'])\n"
              "integrate_batch('formulation-2', np.diag([1., 2., 3.]), np.tile([1., 0, 0, 0], (4, 1)),"
              " np.full((4, 3), 0.1), dt=0.1, duration=0.5)\n"
              "print('ROOT', _jit.cache_root(), cold)")
    env = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_") and k != "XCHECK_NATIVE"}
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=300,
                         env={**env, "XCHECK_CACHE_DIR": str(tmp_path), "NUMBA_DEBUG_CACHE": "1"})
    assert out.returncode == 0, out.stderr[-3000:]
    log = out.stdout.splitlines()
    assert log[-1] == f"ROOT {tmp_path / _ours()} False"  # unpacked before anything asked: warm from the start
    loaded = [line for line in log if "data loaded" in line]
    assert len(loaded) >= 6 and any("loops.run_formulation_2" in line for line in loaded)
    assert not [line for line in log if "saved" in line]  # nothing compiled


def test_the_archive_unpacks_whole_or_not_at_all(tmp_path):
    """Truth: the packed files' bytes. Packed and unpacked, the folder is the same; a folder already there (another
    process was first) is kept as it was; a damaged archive leaves nothing, hidden or not."""
    src = tmp_path / "src"
    (src / "integrators" / "kernels").mkdir(parents=True)
    files = {"metrics._errors-91.py311.nbi": b"index", "integrators/kernels/loops.run-1.py311.1.nbc": os.urandom(5000)}
    for rel, data in files.items():
        (src / rel).write_bytes(data)
    (src / "notes.txt").write_text("not numba's")  # not packed
    archive = tmp_path / "a.tar.xz"
    assert _prebuilt.pack(src, archive) == 2
    with tarfile.open(archive) as tar:
        assert sorted(tar.getnames()) == sorted(files) and {m.mtime for m in tar.getmembers()} == {0}

    root = tmp_path / "cache" / "numba-x"
    assert _prebuilt.unpack(archive, root)
    assert {p.relative_to(root).as_posix(): p.read_bytes() for p in root.rglob("*") if p.is_file()} == files

    (root / "metrics._errors-91.py311.nbi").write_bytes(b"theirs")
    assert not _prebuilt.unpack(archive, root)  # there already: kept
    assert (root / "metrics._errors-91.py311.nbi").read_bytes() == b"theirs"

    damaged = tmp_path / "d.tar.xz"
    damaged.write_bytes(archive.read_bytes()[:200])
    other = tmp_path / "cache" / "numba-y"
    assert not _prebuilt.unpack(damaged, other)
    assert sorted(p.name for p in (tmp_path / "cache").iterdir()) == ["numba-x"]  # no half folder, no hidden one


def test_an_archive_for_another_python_or_numba_is_not_used(tmp_path):
    name = _prebuilt.archive_name("numba-1-abc-generic", "0.68.1")
    assert name.endswith(f".{sys.implementation.cache_tag}.numba-0.68.1.{__import__('platform').machine()}.tar.xz")
    (tmp_path / name).write_bytes(b"")
    assert _prebuilt.archive_for("numba-1-abc-generic", "0.68.1", tmp_path) == tmp_path / name
    assert _prebuilt.archive_for("numba-1-abc-generic", "0.69.0", tmp_path) is None
    assert _prebuilt.archive_for("numba-1-abd-generic", "0.68.1", tmp_path) is None  # other sources


@pytest.mark.parametrize("env, context_made, generic", [
    ({}, False, True),
    ({"NUMBA_CPU_NAME": "generic", "NUMBA_CPU_FEATURES": ""}, False, True),  # handed down by an xcheck parent
    ({"XCHECK_NATIVE": "1"}, False, False),
    ({"XCHECK_NATIVE": "1", "NUMBA_CPU_NAME": "generic", "NUMBA_CPU_FEATURES": ""}, False, False),
    ({"NUMBA_CPU_NAME": "skylake"}, False, False),
    ({"NUMBA_CPU_FEATURES": "+avx2"}, False, False),
    ({"NUMBA_CACHE_DIR": "/tmp/theirs"}, False, False),
    ({}, True, False),  # numba compiled before xcheck was imported: its CPU is fixed
])
def test_the_target_is_generic_unless_the_user_chose(monkeypatch, env, context_made, generic):
    """Truth: the module docstring's rules. Where generic, numba's config and the environment say so (children
    inherit it); XCHECK_NATIVE=1 undoes a generic CPU handed down; a user's own choice is left as it was."""
    for key in ("NUMBA_CPU_NAME", "NUMBA_CPU_FEATURES", "NUMBA_CACHE_DIR", "XCHECK_NATIVE"):
        monkeypatch.delenv(key, raising=False)
    for key, value in env.items():
        monkeypatch.setenv(key, value)
    config = types.SimpleNamespace(CPU_NAME=env.get("NUMBA_CPU_NAME"), CPU_FEATURES=env.get("NUMBA_CPU_FEATURES"),
                                   CACHE_DIR=env.get("NUMBA_CACHE_DIR", ""))
    assert _prebuilt.choose_target(config, context_made) is generic
    if generic:
        assert (config.CPU_NAME, config.CPU_FEATURES) == ("generic", "")
        assert (os.environ["NUMBA_CPU_NAME"], os.environ["NUMBA_CPU_FEATURES"]) == ("generic", "")
    elif "XCHECK_NATIVE" in env:
        assert config.CPU_NAME is None and "NUMBA_CPU_NAME" not in os.environ
    else:
        assert (config.CPU_NAME, config.CPU_FEATURES) == (env.get("NUMBA_CPU_NAME"), env.get("NUMBA_CPU_FEATURES"))


def test_this_process_compiles_for_the_generic_cpu():
    from numba.core.registry import cpu_target

    assert _jit.GENERIC
    assert cpu_target.target_context.codegen().magic_tuple()[1:] == ("generic", "")


def test_the_generic_code_gives_the_hosts_numbers_bit_for_bit():
    """Truth: the host CPU's own compile of the same source (XCHECK_NATIVE=1, in a process of its own). A torqued
    asymmetric body, two schemes and the batch lanes: every float of the trajectories equal."""
    from xcheck.fields import ConstantTorque
    from xcheck.integrators import integrate, integrate_batch

    script = ("import sys, numpy as np\n"
              "from xcheck import _jit\n"
              "from xcheck.fields import ConstantTorque\n"
              "from xcheck.integrators import integrate, integrate_batch\n"
              "assert not _jit.GENERIC\n"
              "J, q0, w0 = np.diag([0.7, 1.3, 1.9]), np.array([0.6, 0.0, 0.8, 0.0]), np.array([0.9, -0.4, 0.3])\n"
              "tq = ConstantTorque([1e-3, -2e-3, 5e-4])\n"
              "parts = [integrate(m, J, q0, w0, dt=0.01, duration=2.0, torque=tq) for m in ('formulation-2', 'lie-lgvi')]\n"
              "b = integrate_batch('lie-rkmk4', J, np.tile(q0, (3, 1)), w0 * np.arange(1, 4)[:, None], dt=0.01,"
              " duration=2.0, save='all')\n"
              "np.save(sys.stdout.buffer, np.concatenate([np.ravel(x) for p in parts for x in (p.q, p.omega)]"
              " + [np.ravel(b.q), np.ravel(b.omega)]))\n")
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, timeout=300,
                         env={**os.environ, "XCHECK_NATIVE": "1"})
    assert out.returncode == 0, out.stderr[-3000:].decode()
    import io

    host = np.load(io.BytesIO(out.stdout))
    J, q0, w0 = np.diag([0.7, 1.3, 1.9]), np.array([0.6, 0.0, 0.8, 0.0]), np.array([0.9, -0.4, 0.3])
    tq = ConstantTorque([1e-3, -2e-3, 5e-4])
    parts = [integrate(m, J, q0, w0, dt=0.01, duration=2.0, torque=tq) for m in ("formulation-2", "lie-lgvi")]
    b = integrate_batch("lie-rkmk4", J, np.tile(q0, (3, 1)), w0 * np.arange(1, 4)[:, None], dt=0.01, duration=2.0, save="all")
    ours = np.concatenate([np.ravel(x) for p in parts for x in (p.q, p.omega)] + [np.ravel(b.q), np.ravel(b.omega)])
    assert host.shape == ours.shape and host.size > 2000
    assert np.array_equal(host, ours)  # bit for bit
