"""Every MuJoCo release (issue 29): the bisection's search, and the release table and bisection run for real on two
releases. Truth: MuJoCo's changelog and our measurement, recorded in docs/mujoco-releases.md: free-body RK4 is second
order before 4.0.0 and fourth order from it (``RK4_FOURTH_ORDER_FROM``); the installed release is at least that."""

import math
import os
import subprocess
import sys

import pytest

from xcheck.history.matrix import installed_mujoco
from xcheck.engines.findings import RK4_FOURTH_ORDER_FROM, release_key, release_note
from xcheck.league.releases import RELEASES, bisect

OLD = "3.2.7"


@pytest.mark.parametrize("first", [None, *RELEASES])
def test_the_bisection_finds_the_first_good_release_in_few_probes(first):
    """A made-up history with its first good release at each place (or none): found, in at most ceil(log2 n) + 2
    probes, and never probing a release twice."""
    asked = []

    def good(v):
        asked.append(v)
        return first is not None and release_key(v) >= release_key(first)

    found, seen = bisect(reversed(RELEASES), good, log=lambda *a: None)
    assert found == first
    assert len(asked) == len(set(asked)) == len(seen) <= math.ceil(math.log2(len(RELEASES))) + 2


def test_the_releases_are_every_minor_release_from_3_2_to_4_0():
    """The newest patch of each minor release (PyPI), and the keyword of xcheck nightly --mujoco."""
    from xcheck.history.matrix import parse_versions

    minors = [tuple(map(int, v.split(".")[:2])) for v in RELEASES]
    assert minors == [(3, k) for k in range(2, 18)] + [(4, 0)]
    assert parse_versions("releases") == list(RELEASES)


def test_the_finding_is_named_for_older_releases_only():
    assert release_note(RK4_FOURTH_ORDER_FROM) is None and release_note("4.1.0") is None
    assert release_note("not installed") is None
    note = release_note("3.17.0")
    assert "MuJoCo 3.17.0's RK4 is second order" in note and f"from MuJoCo {RK4_FOURTH_ORDER_FROM}" in note


def _xcheck(*args, python=sys.executable, cwd=None):
    return subprocess.run([python, "-m", "xcheck", *map(str, args)], capture_output=True, text=True, cwd=cwd,
                          timeout=900)


def _main(tmp_path, *args):
    """The command in this process (as ``xcheck``'s entry runs it): its exit code and what it printed."""
    import contextlib
    import io
    import os

    from xcheck.cli import main

    out, cwd = io.StringIO(), os.getcwd()
    os.chdir(tmp_path)
    try:
        with contextlib.redirect_stdout(out):
            code = main([str(a) for a in args])
    finally:
        os.chdir(cwd)
    return code, out.getvalue()


@pytest.fixture(scope="module")
def two_releases(package_index):
    installed = installed_mujoco()
    assert release_key(installed) >= release_key(RK4_FOURTH_ORDER_FROM)
    return OLD, installed


def test_the_bisection_on_two_releases(two_releases, tmp_path):
    """MuJoCo 3.2.7 probed and found second order, the installed release fourth order: the first good one."""
    old, new = two_releases
    code, out = _main(tmp_path, "releases", "--mujoco", f"{old},{new}", "--bisect", "--json", tmp_path / "b.json")
    assert code == 0
    assert f"fourth order from: {new} (2 of 2 releases probed: {old} not 4th, {new} 4th)" in out


def test_the_release_table_on_two_releases(two_releases, tmp_path):
    """The table's rows: the old release's RK4 at order 2 on the free tumbler, the gyroscope and the ball-joint top,
    failing its order checks; the installed release passing every scenario at order 4."""
    old, new = two_releases
    out = tmp_path / "docs" / "mujoco-releases.md"
    three = ("tumbler-intermediate-axis", "gyroscope-nonsingular", "heavy-top")
    code, _ = _main(tmp_path, "releases", *three, "--mujoco", f"{old},{new}", "--out", out)
    assert code == 0
    text = out.read_text()
    assert f"Made by `xcheck releases {' '.join(three)} --mujoco {old},{new} --out mujoco-releases.md`" in text
    rows = {line.split("|")[1].strip(): [c.strip() for c in line.strip("|").split("|")] for line in text.splitlines()
            if line.startswith(f"| {old} ") or line.startswith(f"| {new} ")}
    assert [float(c) for c in rows[old][2:5]] == pytest.approx([2.0, 2.0, 2.0], abs=0.1)
    assert [float(c) for c in rows[new][2:5]] == pytest.approx([4.0, 4.0, 4.0], abs=0.1)
    n = rows[new][1].split(" of ")[1]
    assert rows[new][1] == f"{n} of {n}" and rows[old][1] != rows[new][1]
    assert f"**Free-body RK4 is fourth order from MuJoCo {new} on**" in text
    assert f"- **{old}**: order:mujoco-rk4 in 3" in text and f"- **{new}**: nothing" in text


def test_an_old_releases_failed_order_check_names_the_finding(two_releases):
    """Run in MuJoCo 3.2.7's environment, the study still fails (that is the point), and says why."""
    from xcheck.history.matrix import ensure_env

    py = ensure_env(OLD, log=lambda *a: None)
    p = _xcheck("converge", "tumbler-intermediate-axis", "--quick", "--methods", "mujoco-rk4", python=py)
    assert p.returncode == 1
    assert ("FAILED order:mujoco-rk4: observed order 2; expected 4 (allowed 3.70 … 5.00); median of the local orders"
            in p.stdout
            and f"a known finding: MuJoCo {OLD}'s RK4 is second order" in p.stdout
            and f"fourth order from MuJoCo {RK4_FOURTH_ORDER_FROM} on" in p.stdout), p.stdout


def test_xcheck_releases_refuses_bad_arguments(tmp_path, monkeypatch, capsys):
    from xcheck.cli import main

    monkeypatch.chdir(tmp_path)
    for args, said in ((["--mujoco", "3.2"], "--mujoco: '3.2' is not a release number like 3.2.7"),
                       (["--bisect", "--out", "x.md"], "--out: a bisection probes only some releases"),
                       (["--out", "x.txt"], "--out: x.txt must end in .md"),
                       (["no-such-scenario"], "no-such-scenario")):
        code = main(["releases", *args])
        err = capsys.readouterr().err
        assert code == 2 and said in err and "Traceback" not in err, err


def test_a_release_the_index_does_not_hold_is_refused_before_any_work(package_index, tmp_path, monkeypatch, capsys):
    """Issue 37, 8: `--mujoco 99.0.0` made nothing and exited 0. Truth: the package index (pip index versions)."""
    from xcheck.cli import main

    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr("xcheck.history.matrix.ensure_env", lambda *a, **k: pytest.fail("work before the refusal"))
    for command in (["releases", "--mujoco", f"{OLD},99.0.0"], ["nightly", "--mujoco", "99.0.0", "--out", "r"]):
        code = main(command)
        err = capsys.readouterr().err
        assert code == 2 and "--mujoco: 99.0.0 is not on the package index (its newest: " in err, err
    assert not (tmp_path / "r").exists()


def test_each_running_environment_has_its_own_release_environments(monkeypatch):
    """Issue 37, 8: a release's environment reads the packages of the environment that made it (its .pth file); the
    cache was keyed by Python and MuJoCo alone, so a second virtual environment ran the first's xcheck (or, that one
    deleted, nothing). Keyed by that environment and its pins now."""
    from xcheck.history import matrix

    here = matrix.env_dir("3.2.7")
    monkeypatch.setattr(matrix, "_parent", lambda: "/elsewhere/venv/lib/python3.11/site-packages")
    there = matrix.env_dir("3.2.7")
    assert here != there and here.parent == there.parent
    assert here.name.startswith(f"py{sys.version_info[0]}.{sys.version_info[1]}-mujoco-3.2.7-")


def test_release_environments_of_gone_environments_and_half_made_ones_are_deleted(tmp_path):
    """Issue 37, 8: a maker killed outright left a 47 MB half-made folder for ever; an environment whose running one
    was deleted was kept. Kept: the live ones and a folder being made by a process that runs (this one)."""
    from xcheck.history import matrix

    def env(name, parent):
        site = tmp_path / name / "lib" / "python3.11" / "site-packages"
        site.mkdir(parents=True)
        (site / "xcheck_parent_environment.pth").write_text(f"import site; site.addsitedir({str(parent)!r})\n")

    (tmp_path / "venv-alive").mkdir()
    env("py3.11-mujoco-3.2.7-aaaa", tmp_path / "venv-alive")
    env("py3.11-mujoco-3.2.7-bbbb", tmp_path / "venv-deleted")
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    (tmp_path / f".py3.11-mujoco-3.6.0-cccc.{int(dead.stdout)}").mkdir()
    (tmp_path / f".py3.11-mujoco-3.6.0-dddd.{os.getpid()}").mkdir()
    gone = matrix.prune_envs(tmp_path)
    assert sorted(p.name for p in gone) == sorted(["py3.11-mujoco-3.2.7-bbbb", f".py3.11-mujoco-3.6.0-cccc.{int(dead.stdout)}"])
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        [".py3.11-mujoco-3.6.0-dddd." + str(os.getpid()), "py3.11-mujoco-3.2.7-aaaa", "venv-alive"])
