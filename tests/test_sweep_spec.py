"""Sweep specs (issue 12, first step): parsing, refusals naming file and key, the cells of a product and of a
seeded sample, uniform random attitudes."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from xcheck.scenario import SCENARIO_DIR
from xcheck.sweep import spec as S


def _spec(tmp_path, text: str, name="spec.toml"):
    path = tmp_path / name
    path.write_text(text)
    return path


PRODUCT = """
base = "rax1-orbit-field"
methods = ["formulation-2", "lie-rkmk4"]
[axes.dipole_scale]
values = [0.5, 1.0, 2.0]
[axes.inertia_scale]
range = [0.5, 2.0]
num = 4
spacing = "log"
[axes.dt]
values = [0.03125, 0.125, 0.0625]
"""


def test_a_product_makes_every_combination(tmp_path):
    """Truth: by construction, 3 x 4 cells, the log range is 0.5 * 4^(k/3)."""
    spec = S.load_sweep(_spec(tmp_path, PRODUCT))
    assert spec.base.name == "rax1-orbit-field" and spec.methods == ["formulation-2", "lie-rkmk4"]
    assert spec.steps == (0.125, 0.0625, 0.03125)  # the dt axis: every cell's steps, coarsest first
    assert len(spec.cells) == 12 and len({c["id"] for c in spec.cells}) == 12
    scales = sorted({c["params"]["inertia_scale"] for c in spec.cells})
    np.testing.assert_allclose(scales, 0.5 * 4.0 ** (np.arange(4) / 3), rtol=1e-15)
    assert {c["params"]["dipole_scale"] for c in spec.cells} == {0.5, 1.0, 2.0}
    again = S.load_sweep(_spec(tmp_path, PRODUCT))
    assert [c["id"] for c in again.cells] == [c["id"] for c in spec.cells]  # ids are stable: --resume


SAMPLE = """
base = "gyroscope-nonsingular"
combine = "sample"
samples = 200
seed = {seed}
[axes.attitude]
random = "so3"
[axes.rate_scale]
range = [0.1, 10.0]
distribution = "log-uniform"
{extra}
"""


def test_a_sample_is_reproducible_from_its_seed(tmp_path):
    a = S.load_sweep(_spec(tmp_path, SAMPLE.format(seed=7, extra=""), "a.toml"))
    b = S.load_sweep(_spec(tmp_path, SAMPLE.format(seed=7, extra=""), "b.toml"))
    c = S.load_sweep(_spec(tmp_path, SAMPLE.format(seed=8, extra=""), "c.toml"))
    d = S.load_sweep(_spec(tmp_path, SAMPLE.format(seed=7, extra="[axes.rate_direction]\nrandom = \"sphere\""),
                           "d.toml"))
    assert len(a.cells) == 200 and [x["params"] for x in a.cells] == [x["params"] for x in b.cells]
    assert a.cells[0]["params"] != c.cells[0]["params"]
    # another axis leaves the draws of the others as they were (each axis draws from seed and its name)
    assert [x["params"]["attitude"] for x in d.cells] == [x["params"]["attitude"] for x in a.cells]
    rates = np.array([x["params"]["rate_scale"] for x in a.cells])
    assert rates.min() >= 0.1 and rates.max() <= 10.0
    # log-uniform: log10 uniform on [-1, 1]; Kolmogorov-Smirnov at the 0.1 % level (fixed seed: deterministic)
    assert stats.kstest(np.log10(rates), stats.uniform(-1, 2).cdf).pvalue > 1e-3
    q = np.array([x["params"]["attitude"] for x in a.cells])
    np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-15)


def test_random_attitudes_are_uniform_on_so3():
    """Truth: under the Haar measure the rotation angle θ has density (1 - cos θ)/π on [0, π], CDF
    (θ - sin θ)/π, and the rotation axis is uniform (E[x²] = 1/3). Kolmogorov-Smirnov at the 0.1 % level."""
    q = S.random_quaternions(20000, np.random.default_rng(1))
    theta = 2 * np.arccos(np.clip(q[:, 0], -1, 1))
    assert stats.kstest(theta, lambda t: (t - np.sin(t)) / np.pi).pvalue > 1e-3
    axis = q[:, 1:] / np.linalg.norm(q[:, 1:], axis=1, keepdims=True)
    np.testing.assert_allclose((axis ** 2).mean(axis=0), 1 / 3, atol=0.015)
    assert np.all(q[:, 0] >= 0)


@pytest.mark.parametrize("text, words", [
    ('base = "rax1-orbit-field"\n[axes.spin_rate]\nvalues = [1.0]', "[axes.spin_rate] unknown axis"),
    ('base = "rax1-orbit-field"\ncolour = "red"\n[axes.dipole_scale]\nvalues = [1.0]', "colour: unknown key"),
    ('base = "rax1-orbit-field"\n[axes.dipole_scale]\nvalues = []', "[axes.dipole_scale] values: an empty list"),
    ('base = "rax1-orbit-field"\n[axes.dipole_scale]\nrange = [2.0, 2.0]\nnum = 3',
     "[axes.dipole_scale] range: expected [low, high] with low < high"),
    ('base = "rax1-orbit-field"\n[axes.dipole]\nrange = [0.0, 1.0]\nnum = 3', "[axes.dipole] range: a range needs"),
    ('base = "gyroscope-nonsingular"\n[axes.dipole_scale]\nvalues = [1.0]',
     "[axes.dipole_scale] the base scenario gyroscope-nonsingular has no magnetic torque"),
    ('base = "rax1-orbit-field"\n[axes."field.colour"]\nvalues = [1.0]',
     "[axes.field.colour] the base's field model 'orbit-dipole' has no key 'colour'"),
    ('base = "no-such-scenario"\n[axes.dt]\nvalues = [0.1]', "base: the base scenario cannot be used"),
    ('base = "rax1-orbit-field"\n[axes.attitude]\nvalues = [[1.0, 0.1, 0.0, 0.0]]',
     "[axes.attitude] values: expected unit quaternions"),
    ('base = "rax1-orbit-field"\n[axes.model]\nvalues = ["missing.xml"]', "[axes.model] values: no such file"),
    ('base = "rax1-orbit-field"\nsamples = 3\n[axes.dipole_scale]\nvalues = [1.0]', "samples: only with"),
    ('base = "rax1-orbit-field"\n[axes."field.altitude_km"]\nmean = 600.0\nstd = 50.0',
     "[axes.field.altitude_km] mean: mean and std describe a distribution"),
    ('base = "rax1-orbit-field"\n[axes.attitude]\nrandom = "so3"', "[axes.attitude] count: missing"),
    ('base = "rax1-orbit-field"\n[axes.field]\nvalues = ["plasma"]', "[axes.field] values: unknown field model"),
    ('base = "rax1-orbit-field"\n[axes]', "axes: no axis"),
    ('base = "rax1-orbit-field"\nmethods = ["rk5"]\n[axes.dt]\nvalues = [0.1]', "methods: unknown method 'rk5'"),
    ('base = "rax1-orbit-field"\n[axes.dipole_scale]\nvalues = [1.0', "not valid TOML"),
    # issue 24, item 2: sizes counted from the spec, before anything is built
    ('base = "gyroscope-nonsingular"\n[axes.rate_scale]\nrange = [0.5, 2]\nnum = 1000\n[axes.inertia_scale]\n'
     'range = [0.5, 2]\nnum = 1000\n[axes.attitude]\nrandom = "so3"\ncount = 1000',
     "axes: 1,000,000,000 cells (rate_scale 1,000 x inertia_scale 1,000 x attitude 1,000), more than the limit "
     "of 100,000: give --max-cells 1000000000"),
    ('base = "gyroscope-nonsingular"\n[axes.rate_scale]\nrange = [0.5, 2]\nnum = 1000000000',
     "axes: 1,000,000,000 cells (rate_scale 1,000,000,000)"),
    ('base = "gyroscope-nonsingular"\ncombine = "sample"\nsamples = 1000000000\n[axes.rate_scale]\n'
     'range = [0.5, 2]', "samples: 1,000,000,000 cells (samples = 1,000,000,000)"),
    ('base = "gyroscope-nonsingular"\n[axes.dt]\nrange = [0.001, 0.01]\nnum = 1000000000', "dt 1,000,000,000"),
    # issue 24, item 6: every value a spec can produce, checked before the first cell
    ('base = "gyroscope-nonsingular"\n[axes.rate_direction]\nvalues = [[0, 0, 0]]',
     "[axes.rate_direction] [0.0, 0.0, 0.0] is no direction"),
    ('base = "rax1-orbit-field"\ncombine = "sample"\nsamples = 50\n[axes."field.altitude_km"]\nmean = 100.0\n'
     'std = 200.0', "[axes.field.altitude_km] -"),
    ('base = "rax1-orbit-field"\n[axes.dipole]\nvalues = [[1e30, 0, 1]]', "dipole: |m| = 1e+30 A m^2, beyond"),
    ('base = "rax1-orbit-field"\n[axes.dipole_scale]\nrange = [1, 1e30]\nnum = 3', "beyond the 1e+04 A m^2"),
    ('base = "rax1-orbit-field"\nseed = -1\n[axes.dipole_scale]\nvalues = [1.0]',
     "seed: expected a non-negative integer, got -1"),
])
def test_a_bad_spec_is_refused_naming_file_and_key(tmp_path, text, words):
    path = _spec(tmp_path, text)
    with pytest.raises(S.SweepError) as info:
        S.load_sweep(path)
    assert str(info.value).startswith(f"{path}: ") and words in str(info.value), str(info.value)


def test_the_base_may_be_a_scenario_file_beside_the_spec(tmp_path):
    scenario = (SCENARIO_DIR / "gyroscope-nonsingular.toml").read_text().replace(
        'model = "../gyroscope.xml"', f'model = "{(SCENARIO_DIR.parent / "gyroscope.xml").as_posix()}"')
    (tmp_path / "mine.toml").write_text(scenario)
    spec = S.load_sweep(_spec(tmp_path, 'base = "mine.toml"\n[axes.rate_scale]\nvalues = [1.0, 2.0]'))
    assert spec.base.path == tmp_path / "mine.toml" and len(spec.cells) == 2


def test_the_cell_limit_is_lifted_by_max_cells(tmp_path):
    path = _spec(tmp_path, 'base = "gyroscope-nonsingular"\n[axes.rate_scale]\nrange = [0.5, 2]\nnum = 7')
    with pytest.raises(S.SweepError, match="7 cells .* more than the limit of 6: give --max-cells 7"):
        S.load_sweep(path, max_cells=6)
    assert len(S.load_sweep(path, max_cells=7).cells) == 7
