"""Issue 27: a heavy top on a ball joint through every layer — the body (inertia about the pivot, by hand), the
MuJoCo engine (a ball joint's relative qpos at its boundary), the torque (gravity's about the pivot) and what it
conserves (the energy with its potential, the angular momentum about the vertical), our methods and MuJoCo's
against DOP853, Basilisk where it can represent the attitude equations, and the refusals."""

from __future__ import annotations

import numpy as np
import pytest

from xcheck import rotations as rot
from xcheck.metrics import invariant_changes, observed_order
from xcheck.models import ModelError, load_body
from xcheck.paths import BUNDLED_MODELS
from xcheck.runners import RUNNERS
from xcheck.scenario import ScenarioError, resolve_scenario
from xcheck.study.context import run_context

TOP = BUNDLED_MODELS / "heavy_top.xml"
# the notes a model's loading gives (parts welded, a top's pivot): said once per file, and tested in test_models
pytestmark = pytest.mark.filterwarnings("ignore:.*(welded into one rigid body|a top on the ball joint).*:UserWarning")

TILTED = """<mujoco>
  <compiler angle="radian"/>
  <option gravity="0 0 -9.81"/>
  <worldbody>
    <body name="stand" pos="0 0 1" quat="{stand}">
      <body name="top" quat="{quat}">
        <joint name="pivot" type="ball" pos="0.01 0 0" {extra}/>
        <inertial pos="0.02 -0.01 0.3" mass="1.5" diaginertia="0.01 0.02 0.03"/>
      </body>
    </body>
  </worldbody>
  {tail}
</mujoco>"""


def _tilted(tmp_path, extra="", tail=""):
    stand = rot.rotvec_to_quat([0.2, 0.0, 0.3])
    quat = rot.rotvec_to_quat([0.0, 0.5, -0.1])
    path = tmp_path / "tilted.xml"
    path.write_text(TILTED.format(stand=" ".join(map(repr, stand.tolist())), quat=" ".join(map(repr, quat.tolist())),
                                  extra=extra, tail=tail))
    return path, rot.quat_mul(stand, quat)


def test_the_bundled_top_is_its_parts_about_the_pivot_by_hand():
    """Disk 2 kg at 1 cm above the pivot, axle 0.02 kg centred 1.5 cm above it: the composite's centre of mass and
    its inertia about the pivot by the parallel-axis theorem, written out."""
    b = load_body(TOP)
    m_d, m_a, z_d, z_a = 2.0, 0.02, 0.01, 0.015
    c = (m_d * z_d + m_a * z_a) / (m_d + m_a)
    assert b.joint == "ball" and b.mass == pytest.approx(2.02, rel=1e-15)
    np.testing.assert_allclose(b.centre, [0, 0, c], rtol=1e-14, atol=0)
    transverse = 0.0028125 + m_d * z_d**2 + 1.50667e-06 + m_a * z_a**2
    np.testing.assert_allclose(b.inertia, np.diag([transverse, transverse, 0.005625 + 4e-08]), rtol=1e-14, atol=1e-18)
    np.testing.assert_array_equal(b.gravity, [0.0, 0.0, -9.81])
    torque = b.own_torque()
    R = rot.quat_to_dcm(rot.rotvec_to_quat([0.3, -0.4, 0.2]))
    np.testing.assert_allclose(torque(0.0, rot.dcm_to_quat(R), np.zeros(3)),
                               np.cross(b.centre, b.mass * R.T @ np.array(b.gravity)), rtol=1e-13, atol=1e-18)


def test_a_ball_joints_reference_orientation_and_pivot_reach_mujocos_run(tmp_path):
    """A top whose stand and body are both turned, its pivot off the body origin: MuJoCo's run starts at the world
    attitude asked for (its qpos written relative to the body's reference orientation) and agrees with lie-rkmk4,
    the same scheme, to round-off; both against DOP853 at fourth order."""
    path, reference = _tilted(tmp_path)
    b = load_body(path)
    np.testing.assert_allclose(b.reference_quat, reference * np.sign(reference[0]) * np.sign(b.reference_quat[0]),
                               atol=1e-15)
    np.testing.assert_allclose(b.centre, [0.01, -0.01, 0.3], atol=1e-15)
    from xcheck.runners import RunContext

    q0 = rot.quat_normalize([0.9, 0.2, -0.3, 0.1])
    ctx = RunContext(inertia=b.inertia, model_path=str(path), q0=q0, omega0=np.array([0.5, -1.0, 8.0]), duration=2.0,
                     torque=b.own_torque(), engine_torque=None)
    mj = RUNNERS["mujoco-rk4"].run(ctx, 1 / 512)
    ours = RUNNERS["lie-rkmk4"].run(ctx, 1 / 512)
    assert rot.attitude_error(mj.q[0], q0) < 1e-15 and np.array_equal(mj.omega[0], ctx.omega0)
    assert np.max(rot.attitude_error(mj.q, ours.q)) < 1e-11  # the same scheme: round-off apart
    from xcheck.reference import dop853_solution

    ref = dop853_solution(ctx.inertia, q0, ctx.omega0, ctx.duration, torque=ctx.torque)
    errors = []
    steps = (1 / 256, 1 / 512, 1 / 1024)
    for dt in steps:
        run = RUNNERS["mujoco-rk4"].run(ctx, dt)
        errors.append(float(np.max(rot.attitude_error(run.q, ref(run.t)[0]))))
    assert observed_order(steps, errors).order == pytest.approx(4.0, abs=0.15), errors  # 4.16, 4.08: nearly there


def test_what_gravity_conserves_is_conserved_by_rk4_to_its_order():
    """Truth: E = 1/2 w.I_O w - m g.(R c), H.z and (symmetric) C w3 are constants of the heavy top. lie-rkmk4's
    drifts of the first two shrink 16x a halving of the step, the third is round-off; the potential is -m g.(R c)
    written out."""
    sc = resolve_scenario("heavy-top")
    ctx = run_context(sc)
    q = rot.quat_normalize(np.random.default_rng(1).normal(size=(5, 4)))
    c, m, g = np.array(load_body(TOP).centre), 2.02, np.array([0.0, 0.0, -9.81])
    np.testing.assert_allclose(ctx.torque.potential(q), [-m * g @ (rot.quat_to_dcm(qk) @ c) for qk in q], rtol=1e-13)
    np.testing.assert_allclose(ctx.torque.momentum_axis(), [0.0, 0.0, -1.0])
    drifts = [invariant_changes(ctx.inertia, RUNNERS["lie-rkmk4"].run(ctx, dt), ctx.torque)
              for dt in (1 / 64, 1 / 128)]
    for key in ("energy_change", "momentum_change"):  # bounded oscillations: their largest is of either sign
        assert 10 < abs(drifts[0][key] / drifts[1][key]) < 24, (key, drifts)
    assert drifts[0]["momentum_turn"] is None  # a top keeps L's vertical component only, not its direction
    # the spin momentum C w3 of a symmetric top: Euler's third equation has no term left (A = B, c x F along no
    # axis of c), so every RK4 keeps it to round-off at any step
    assert max(abs(d["spin_change"]) for d in drifts) < 1e-14, drifts
    # torque free (no potential, no axis): nothing is claimed under a field that changes in time
    rax = run_context(resolve_scenario("rax1-orbit-field"))
    d = invariant_changes(rax.inertia, RUNNERS["lie-rkmk4"].run(rax, 0.5), rax.torque)
    assert d["energy_change"] is None and d["momentum_change"] is None and d["momentum_turn"] is None
    assert d["norm_drift"] < 1e-14


def test_the_heavy_top_scenario_passes_with_every_method_and_mujocos_ball_joint_is_fourth_order():
    from xcheck.study import run_study

    st = run_study(resolve_scenario("heavy-top"), quick=True, workers=1, timing=False)
    assert st.passed, [c.to_json() for c in st.checks if not c.passed]
    assert st.methods["mujoco-rk4"].observed_order == pytest.approx(4.0, abs=0.05)
    # MuJoCo's RK4 on the ball joint is lie-rkmk4's scheme: the same errors to round-off at every step
    for a, b in zip(st.methods["mujoco-rk4"].runs, st.methods["lie-rkmk4"].runs):
        assert a.max_attitude_error == pytest.approx(b.max_attitude_error, rel=1e-6)
    finest = st.methods["lie-rkmk4"].runs[-1]
    assert abs(finest.energy_change) < 1e-12 and abs(finest.momentum_change) < 1e-11 and abs(finest.spin_change) < 1e-11


def test_basilisk_runs_the_tops_attitude_equations():
    """A hub is not pinned, but the top's attitude obeys Euler's equation with the inertia about the pivot and
    gravity's torque about it: Basilisk's hub with that inertia and that torque (its MtbEffector in a uniform field,
    the dipole c, mu0 H = m g) is RK4 on MRPs, mrp-rk4, to round-off."""
    pytest.importorskip("Basilisk", reason="Basilisk is not installed (pip install 'xcheck[basilisk]')")
    if "basilisk-rk4" not in RUNNERS:
        pytest.skip("Basilisk is installed but left out here ($XCHECK_WITHOUT names it)")
    ctx = run_context(resolve_scenario("heavy-top"))
    a, b = RUNNERS["basilisk-rk4"].run(ctx, 1 / 256), RUNNERS["mrp-rk4"].run(ctx, 1 / 256)
    assert np.max(rot.attitude_error(a.q, b.q)) < 1e-11


def test_refusals_name_the_file_and_the_reason(tmp_path):
    path, _ = _tilted(tmp_path, extra='limited="true" range="0 0.5"')
    with pytest.raises(ModelError, match="has a range: a limit is a constraint force"):
        load_body(path)
    path, _ = _tilted(tmp_path, extra='damping="0.1"')
    with pytest.raises(ModelError, match="the ball joint has damping"):
        load_body(path)
    scenario = tmp_path / "top.toml"
    base = (f'name = "top"\nmodel = "{TOP}"\nduration = 1.0\n[initial]\nquaternion = [1, 0, 0, 0]\n'
            'angular_velocity = [0, 0, 10]\n')
    scenario.write_text(base + '[study]\nreference = "exact"\n')
    with pytest.raises(ScenarioError, match="'exact' is the torque-free solution, Lagrange's top or the axisymmetric "
                                            "gyrostat, and the body is under gravity.*within 0 deg of the vertical"):
        resolve_scenario(str(scenario))
    # a [torque] beside the model's gravity composes (a magnetised top: test_a_magnetised_top_composes_...)
    scenario.write_text(base + '[torque]\nkind = "constant"\ntorque = [0, 0, 1e-3]\n[study]\nreference = "dop853"\n')
    from xcheck.fields import SumTorque

    assert isinstance(run_context(resolve_scenario(str(scenario))).torque, SumTorque)


# ------------------------------------------------------------------------------------------------------
# Lagrange's top: the exact reference
# ------------------------------------------------------------------------------------------------------
def _top_case(theta_deg, rates):
    """The bundled top (A = 3.0185e-3, C = 5.625e-3 kg m^2 about the pivot, m g l = 0.199 N m) from Z-Y-Z angles
    [0, theta, 0] and Euler rates [psi', theta', phi'] [rad/s]."""
    b = load_body(TOP)
    angles = np.radians([0.0, theta_deg, 0.0])
    return b, rot.euler_to_quat(angles, "323"), rot.euler_rates_to_omega(angles, np.asarray(rates, float), "323")


CASES = {  # name: (theta0 [deg], Euler rates [rad/s], duration [s])
    "fast top": (30.0, [0.0, 0.0, 100.0], 2.0),
    "looping nutation": (30.0, [-1.5, 0.0, 15.71], 3.0),   # psi' changes sign: the axis draws loops
    "nearly sleeping": (3.0, [0.0, 0.0, 40.0], 3.0),      # above the sleeping limit (C w3)^2 > 4 A m g l
}


@pytest.mark.parametrize("name", CASES)
def test_the_lagrange_top_agrees_with_dop853(name):
    """Truth: scipy's DOP853 at rtol 1e-13 on the same equations: within 1e-11 rad and 1e-10 rad/s over the run;
    the exact motion keeps the energy with its potential and the vertical momentum to 1e-13."""
    from xcheck.reference import dop853_solution, lagrange_top

    theta, rates, T = CASES[name]
    b, q0, w0 = _top_case(theta, rates)
    torque = b.own_torque()
    t = np.linspace(0.0, T, 2001)
    q, w = lagrange_top(b.inertia, q0, w0, t, centre=b.centre, force=b.mass * np.array(b.gravity))
    qr, wr = dop853_solution(b.inertia, q0, w0, T, torque=torque)(t)
    assert np.max(rot.attitude_error(q, qr)) < 1e-11 and np.max(np.abs(w - wr)) < 1e-10
    from xcheck.trajectory import Trajectory

    drift = invariant_changes(b.inertia, Trajectory(t=t, q=q, omega=w), torque)
    assert abs(drift["energy_change"]) < 1e-13 and abs(drift["momentum_change"]) < 1e-13, drift
    if name == "looping nutation":
        psi = rot.quat_to_euler(q, "323", warn=False)[:, 0]
        assert np.any(np.diff(np.unwrap(psi)) > 0) and np.any(np.diff(np.unwrap(psi)) < 0)


def test_a_fast_top_has_the_gyroscopic_limits():
    """Truth: the gyroscopic approximation (Goldstein, Classical Mechanics, section 5.7). For a fast top started
    without precession, eps = A m g l / (C w3)^2 = 3.8e-5 here: the nutation's angular frequency is C w3 / A and
    the mean precession rate m g l / (C w3), each to O(eps) relative; the nutation's depth 2 A m g l sin(theta0) /
    (C w3)^2 to O(eps) too."""
    from xcheck.reference import lagrange_top

    b, q0, w0 = _top_case(30.0, [0.0, 0.0, 300.0])
    A, C = b.inertia[0, 0], b.inertia[2, 2]
    mgl = b.mass * 9.81 * np.linalg.norm(b.centre)
    w3 = w0[2]
    eps = A * mgl / (C * w3) ** 2
    t = np.linspace(0.0, 0.5, 200001)
    q, _ = lagrange_top(b.inertia, q0, w0, t, centre=b.centre, force=b.mass * np.array(b.gravity))
    psi, theta, _ = rot.quat_to_euler(q, "323", warn=False).T
    psi = np.unwrap(psi)
    # the nutation: theta's returns to its starting value (its minima), their spacing the period
    lows = np.flatnonzero((theta[1:-1] < theta[:-2]) & (theta[1:-1] <= theta[2:])) + 1
    period = np.mean(np.diff(t[lows]))
    assert 2 * np.pi / period == pytest.approx(C * w3 / A, rel=5 * eps + 1e-4)
    # the mean precession over whole nutation periods
    rate = (psi[lows[-1]] - psi[lows[0]]) / (t[lows[-1]] - t[lows[0]])
    assert rate == pytest.approx(mgl / (C * w3), rel=10 * eps + 1e-4)
    depth = theta.max() - theta.min()
    assert depth == pytest.approx(2 * A * mgl * np.sin(np.radians(30.0)) / (C * w3) ** 2, rel=0.01)


def test_the_lagrange_top_refuses_what_it_cannot_do():
    from xcheck.reference import ReferenceFailure, exact_why_not, lagrange_top

    b, q0, w0 = _top_case(0.5, [0.0, 0.0, 40.0])  # within 0.6 deg of the vertical: 1 - u^2 < 1e-4
    with pytest.raises(ReferenceFailure, match="of the vertical, where its precession rate loses digits"):
        lagrange_top(b.inertia, q0, w0, np.linspace(0, 1, 11), centre=b.centre, force=b.mass * np.array(b.gravity))
    lopsided = b.inertia + np.diag([1e-4, 0.0, 0.0])
    assert "not symmetric about the axis through the centre of mass" in exact_why_not(lopsided, b.own_torque())
    assert exact_why_not(b.inertia, b.own_torque()) is None and exact_why_not(b.inertia, None) is None


def test_the_cubesat_built_from_parts_is_its_parts_by_hand():
    """models/cubesat_parts.xml: the bus, two panels at y = +-0.2 m and the antenna at x = 0.3 m, each its own
    solid about its centre; the composite by the parallel-axis theorem written out, about the composite's centre of
    mass; and MuJoCo's four bodies against lie-rkmk4 on the composite, in the orbit field: the same scheme."""
    b = load_body(BUNDLED_MODELS / "cubesat_parts.xml")
    parts = [  # mass, centre [m], own principal moments [kg m^2]
        (3.4, [0, 0, 0], [3.4 / 12 * (0.01 + 0.1156), 3.4 / 12 * (0.01 + 0.1156), 3.4 / 12 * 0.02]),
        (0.15, [0, 0.2, 0], [0.002570, 0.00144505, 0.00112505]),
        (0.15, [0, -0.2, 0], [0.002570, 0.00144505, 0.00112505]),
        (0.02, [0.3, 0, 0], [1e-08, 0.0004166716666666667, 0.0004166716666666667]),
    ]
    mass = sum(m for m, _, _ in parts)
    com = sum(m * np.array(c, float) for m, c, _ in parts) / mass
    inertia = sum(np.diag(J) + m * ((d := np.array(c, float) - com) @ d * np.eye(3) - np.outer(d, d))
                  for m, c, J in parts)
    assert b.mass == pytest.approx(mass, rel=1e-15) and b.joint == "free"
    np.testing.assert_allclose(b.inertia, inertia, rtol=1e-13, atol=1e-18)
    sc = resolve_scenario("cubesat-parts-orbit-field")
    ctx = run_context(sc)
    a, o = RUNNERS["mujoco-rk4"].run(ctx, 1 / 64), RUNNERS["lie-rkmk4"].run(ctx, 1 / 64)
    assert np.max(rot.attitude_error(a.q, o.q)) < 1e-12


def test_simo_and_wongs_heavy_symmetrical_top():
    """The heavy top of Simo & Wong, 'Unconditionally stable algorithms for rigid body dynamics that exactly preserve
    energy and momentum', Int. J. Numer. Methods Eng. 31 (1991) 19-52, as its parameters are printed: inertia about
    the fixed point J = diag(5, 5, 1), M g l = 20 (M = 20, g = 1, l = 1), Lambda(0) = exp([0.05, 0, 0]^), W(0) =
    [0, 0, 50] rad/s; so its Hamiltonian is 1/2 W.JW + M g l cos(0.05) = 1269.97500520790. Over their [0, 10] s,
    Lagrange's closed form keeps that Hamiltonian to 1e-13 and agrees with DOP853 to 1e-10 rad. (Their top is no
    MJCF body: its inertia about the centre of mass would be diag(-15, -15, 1).) The rotation a step that paper
    quotes, about 26 deg at h = 0.009 s and 3 deg at h = 0.001 s, is |W| h: 25.8 and 2.86 deg."""
    from xcheck.fields import GravityTorque
    from xcheck.reference import dop853_solution, lagrange_top
    from xcheck.trajectory import Trajectory

    J, q0, w0 = np.diag([5.0, 5.0, 1.0]), rot.rotvec_to_quat([0.05, 0.0, 0.0]), np.array([0.0, 0.0, 50.0])
    torque = GravityTorque([0.0, 0.0, 1.0], 20.0, [0.0, 0.0, -1.0])
    t = np.linspace(0.0, 10.0, 4001)
    q, w = lagrange_top(J, q0, w0, t, centre=[0.0, 0.0, 1.0], force=[0.0, 0.0, -20.0])
    H = 0.5 * np.einsum("ni,ij,nj->n", w, J, w) + torque.potential(q)
    assert H[0] == pytest.approx(1250.0 + 20.0 * np.cos(0.05), rel=1e-15)
    assert 1250.0 + 20.0 * np.cos(0.05) == pytest.approx(1269.97500520790, abs=1e-10)
    assert np.max(np.abs(H - H[0])) / H[0] < 1e-13
    assert abs(invariant_changes(J, Trajectory(t=t, q=q, omega=w), torque)["momentum_change"]) < 1e-13
    qr, _ = dop853_solution(J, q0, w0, 10.0, torque=torque)(t)
    assert np.max(rot.attitude_error(q, qr)) < 1e-10
    assert np.degrees(50.0 * 0.009) == pytest.approx(26.0, abs=0.5) and np.degrees(50.0 * 0.001) == pytest.approx(3.0, abs=0.2)



# ------------------------------------------------------------------------------------------------------
# torques that compose
# ------------------------------------------------------------------------------------------------------
def test_a_sum_of_torques_is_its_terms_added():
    """Two constant torques summed run bit for bit as the one constant torque that is their sum (the kernel adds the
    terms from zero, in order); a sum's P names each term's kind and slice; refusals named."""
    from xcheck.fields import ConstantTorque, MagneticTorque, SumTorque, UniformField
    from xcheck.fields.models import BodyFieldTable
    from xcheck.runners import RunContext

    a, b = ConstantTorque([1e-3, 0.0, 2e-3]), ConstantTorque([0.0, -1e-3, 5e-4])
    both = SumTorque([a, b])
    np.testing.assert_array_equal(both.P[:8], [2, 0, 1, 8, 3, 1, 11, 3])  # n, attitude-dependent, (kind, start, length)
    kw = dict(inertia=np.diag([1.0, 2.0, 3.0]), model_path="", q0=np.array([1.0, 0, 0, 0]),
              omega0=np.array([0.1, 1.0, 0.2]), duration=5.0)
    one = ConstantTorque([1e-3, -1e-3, 2.5e-3])
    for method in ("lie-rkmk4", "formulation-2", "euler-rk4"):
        x = RUNNERS[method].run(RunContext(torque=both, **kw), 1 / 64)
        y = RUNNERS[method].run(RunContext(torque=one, **kw), 1 / 64)
        assert np.array_equal(x.q, y.q) and np.array_equal(x.omega, y.omega), method
    assert SumTorque([both, a]).terms == [a, b, a]  # a sum of sums is flat
    with pytest.raises(ValueError, match="a sum needs two torques or more"):
        SumTorque([a])
    table = np.array([[0.0, 1.0, 0.0, 0.0], [10.0, 1.0, 0.0, 0.0]])
    tabled = [MagneticTorque([1.0, 0, 0], BodyFieldTable(table, source="t")) for _ in range(2)]
    with pytest.raises(ValueError, match="2 of them read a table"):
        SumTorque(tabled)
    field = MagneticTorque([0.0, 0.0, 0.5], UniformField([2e4, 0.0, 0.0]))
    assert SumTorque([a, field]).potential(np.array([[1.0, 0, 0, 0]])) is None  # a constant torque has none
    assert SumTorque([a, field]).momentum_axis() is None


def test_a_magnetised_top_composes_gravity_and_its_field_in_every_engine():
    """The bundled top with a dipole of 0.5 A m^2 along its axis in a horizontal uniform field: gravity's torque
    (the model's, MuJoCo's own) plus the field's (applied). Truth: DOP853 on the sum. MuJoCo's RK4 (gravity its
    own, the field through the control callback at the world attitude of the ball joint) is lie-rkmk4 to round-off,
    Basilisk's (two MtbEffectors: two uniform fields) mrp-rk4; what the sum conserves: the energy with both
    potentials (no common axis: no momentum)."""
    from xcheck.fields import MagneticTorque, SumTorque, UniformField
    from xcheck.reference import dop853_solution
    from xcheck.runners import RunContext

    b = load_body(TOP)
    field = MagneticTorque([0.0, 0.0, 0.5], UniformField([2e4, 0.0, 0.0]))
    torque = SumTorque([b.own_torque(), field])
    q0, w0 = rot.euler_to_quat(np.radians([0.0, 15.0, 0.0]), "323"), np.array([0.0, 0.0, 15.71])
    ctx = RunContext(inertia=b.inertia, model_path=str(TOP), q0=q0, omega0=w0, duration=3.0, torque=torque,
                     engine_torque=field)
    ref = dop853_solution(b.inertia, q0, w0, 3.0, torque=torque)
    runs = {m: RUNNERS[m].run(ctx, 1 / 512) for m in ("lie-rkmk4", "mujoco-rk4", "mrp-rk4")}
    for m, r in runs.items():
        assert np.max(rot.attitude_error(r.q, ref(r.t)[0])) < 1e-7, m
    assert np.max(rot.attitude_error(runs["mujoco-rk4"].q, runs["lie-rkmk4"].q)) < 1e-12
    drift = invariant_changes(b.inertia, runs["lie-rkmk4"], torque)
    assert abs(drift["energy_change"]) < 1e-10 and drift["momentum_change"] is None
    if "basilisk-rk4" in RUNNERS:
        basilisk = RUNNERS["basilisk-rk4"].run(ctx, 1 / 512)
        assert np.max(rot.attitude_error(basilisk.q, runs["mrp-rk4"].q)) < 1e-11


def test_a_top_given_alone_takes_the_exact_reference_where_it_reaches_the_motion(tmp_path):
    """xcheck init / report MODEL.xml on a top: tilted by its keyframe, Lagrange's closed form (stated); upright at
    the default rate (the axis at the vertical), DOP853, saying why; either way the model's own torque is named."""
    from xcheck.model_scenario import model_scenario_text

    text = TOP.read_text().replace("</worldbody>", "</worldbody>\n  <keyframe><key name='tilted' qpos='0.9914448613738104 "
                                   "0 0.13052619222005157 0' qvel='0 0 15.71'/></keyframe>")
    tilted = tmp_path / "tilted_top.xml"
    tilted.write_text(text)
    toml, assumptions = model_scenario_text(tilted)
    assert 'reference = "exact"' in toml and any("Lagrange's" in a for a in assumptions)
    assert any("the model's own torque only: gravity" in a for a in assumptions)
    toml, assumptions = model_scenario_text(TOP)
    assert 'reference = "dop853"' in toml and any("within 0 deg of the vertical" in a for a in assumptions)
