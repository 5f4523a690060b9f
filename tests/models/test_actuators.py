"""Actuators as ports (forms/actuators.py): tendons and pneumatic chambers on the 3D rod and the planar beam.

Oracles: the closed forms of a free arm under uniform actuation (a circular
arc, a helix; forms/actuators.py uniform_equilibrium / uniform_centreline,
derived there and checked against an independent strong-form shooting
solution), the exact discrete balance of the ports, and bit-for-bit
equality with the unactuated rod.  Every run is small (4-16 elements).
"""

import numpy as np
import pytest
from mpi4py import MPI
from processes import ok, rodfem, rodfem_lines, summary

from rodfem import Load, Problem, Support, run
from rodfem.analysis.statics import Statics
from rodfem.demos import soft_arm_pneumatic, soft_arm_swing, tendon_arm
from rodfem.demos._rod3d import NEWTON, smooth_ramp, straight
from rodfem.errors import ParameterError
from rodfem.forms import actuators as act
from rodfem.forms.cosserat_rod import CosseratRod
from rodfem.forms.planar_beam import PlanarBeam, quadratic

COMM = MPI.COMM_WORLD


def build(scene, **overrides):
    p = scene.values(overrides)
    return scene.build(p, COMM), p


def tip(row):
    return np.array([row[f"tip_{c}"] for c in "xyz"])


def gathered(P, name):
    s, v = P.space.nodal(P.x0, name)
    s_all = np.concatenate(COMM.allgather(s))
    v_all = np.concatenate(COMM.allgather(v))
    order = np.argsort(s_all)
    return s_all[order], v_all[order]


# -- closed forms: arcs and the helix ---------------------------------------------------------------

def test_straight_tendon_gives_the_circular_arc():
    """Rucker-Webster robot without gravity, 15 N at d = 15.06 mm: every node on the arc of curvature
    tau d / EI with axial strain -tau/EA (B(i)); the stress resultants are N_1 = -tau, M = tau d."""
    P, p = build(tendon_arm.scene, g=0.0, n_elements=8)
    res = run(P, p["dt"], p["t_end"])
    (EA, GA, _), (GJ, EI, _), _ = tendon_arm.section(p)
    tau, d, L = p["tension1"], p["offset"], p["L"]
    kappa, eps = tau * d / EI, -tau / EA
    Gamma, K = act.uniform_equilibrium((EA, GA, GA), (GJ, EI, EI), tendons=[(tau, (d, 0.0))])
    assert np.allclose(Gamma, [eps, 0, 0], rtol=1e-12, atol=1e-18) and np.allclose(K, [0, 0, kappa], rtol=1e-12)
    R0 = np.column_stack(tendon_arm.DIRECTORS)
    s, r = gathered(P, "r")
    exact, _ = act.uniform_centreline(Gamma, K, s, R0=R0)
    err = np.max(np.linalg.norm(r - exact, axis=1))
    assert err <= 3e-6 * L, err                                   # measured 6.7e-7 L
    # it bends toward the tendon (+x), in the plane y = 0
    assert tip(res.rows[-1])[0] > 0.17 and abs(tip(res.rows[-1])[1]) < 1e-12
    # the resultants (DG1) are the constants of the closed form
    _, N = gathered(P, "N")
    _, M = gathered(P, "M")
    assert np.max(np.abs(N[:, 0] + tau)) <= 1e-4 * tau and np.max(np.abs(M[:, 2] - tau * d)) <= 1e-3 * tau * d
    # the tendon's length column is the arc length of the fibre at d
    assert res.rows[-1]["length_tendon1"] == pytest.approx(L * (1 + eps - d * kappa), rel=1e-6)


def test_planar_beam_tendon_gives_the_circular_arc():
    """Planar beam, tendon at offset d: kappa = tau d / EI, Gamma_1 = -tau/EA (DG0 states), tip on the arc."""
    EA, GA, EI, L, d = 1e4, 1e4, 1.0, 1.0, 0.05
    tau = 1.0 / d                                          # kappa L = 1
    beam = PlanarBeam(0.0, 0.0, quadratic(EA, GA, EI))
    T = act.Tendon(smooth_ramp(tau, 1.0), act.straight(d), radius=0.1, name="t")
    P = Problem(beam, L, 8, loads=[T], supports=[Support("left", "clamped")],
                initial={"r": lambda x: np.vstack([x[0], 0 * x[0]])})
    res = run(P, 1 / 64, 1.0)          # load stepping: error O(dt^4), 9e-6 at dt = 1/32, 6e-7 at 1/64
    kappa, eps = tau * d / EI, -tau / EA
    _, k = gathered(P, "kappa")
    _, G = gathered(P, "Gamma")
    assert np.max(np.abs(k - kappa)) <= 1e-6 * kappa and np.max(np.abs(G[:, 0] - eps)) <= 1e-6 * abs(eps)
    assert np.max(np.abs(G[:, 1])) <= 1e-12
    # the P1 centreline: nodes on the arc up to the element's O(h^2) (measured 1.25e-3 L at 8 elements)
    rho = (1 + eps) / kappa
    exact = np.array([rho * np.sin(kappa * L), rho * (1 - np.cos(kappa * L))])
    assert np.linalg.norm([res.rows[-1]["tip_x"] - exact[0], res.rows[-1]["tip_y"] - exact[1]]) <= 2e-3 * L


def test_chambers_give_the_arc_and_a_segment_bends_only_there():
    """(a) The soft arm's three chambers at the end of the pressure ramp (t = 0.5): the tip of the exact arc
    (B(iii): N_1 = sum p A, M = sum p A y x e_1), away from the most inflated chamber.
    (b) One chamber on the segment [0, L/2]: that half is an arc, the other half straight."""
    P, p = build(soft_arm_pneumatic.scene, n_elements=8, dt=0.0125, t_end=0.5)   # load stepping: O(dt^4)
    res = run(P, p["dt"], p["t_end"])
    exact = soft_arm_pneumatic.quasi_static_tip(p, 0.5)
    assert np.linalg.norm(tip(res.rows[-1]) - exact) <= 1e-5 * p["L"], (tip(res.rows[-1]), exact)
    assert exact[0] < -0.08                   # chamber 1 (30 deg) is the most inflated: the tip goes to 180 deg
    r, h = soft_arm_pneumatic.circle(p)
    assert r == pytest.approx(0.08406, abs=1e-5) and h == pytest.approx(0.15303, abs=1e-5)

    # (b) a single chamber along [0, L/2] of a rod with unit stiffnesses
    L, Ac, y, pr = 1.0, 0.01, (0.03, 0.04), 20.0
    rod = CosseratRod(0.0, (0.0, 0.0, 0.0), [1e-3, 1e-3, 1e-3], [1.0, 1.0, 1.0])
    ch = act.Chamber(smooth_ramp(pr, 1.0), y, radius=0.1, area=Ac, segment=(0.0, L / 2), name="c")
    P = Problem(rod, L, 8, loads=[ch], supports=[Support("left", "clamped")], initial=straight((0, 0, 0), np.eye(3)),
                newton_options=NEWTON)
    res = run(P, 1 / 32, 1.0)
    Gamma, K = act.uniform_equilibrium((1e3, 1e3, 1e3), (1.0, 1.0, 1.0), chambers=[(pr, Ac, y)])
    assert K[2] == pytest.approx(-pr * Ac * y[0]) and K[1] == pytest.approx(pr * Ac * y[1])
    r_half, E_half = act.uniform_centreline(Gamma, K, [L / 2])
    exact = r_half[-1] + E_half[-1] @ np.array([L / 2, 0.0, 0.0])
    assert np.linalg.norm(tip(res.rows[-1]) - exact) <= 1e-5 * L, (tip(res.rows[-1]), exact)
    # the swept volume A int (1 + Gamma_1 + y_b K_2 - y_a K_3) ds of the inflated half
    V = Ac * L / 2 * (1 + Gamma[0] + y[1] * K[1] - y[0] * K[2])
    assert res.rows[-1]["volume_c"] == pytest.approx(V, rel=1e-7) and V > Ac * L / 2 * (1 + 1.1 * Gamma[0])


def test_three_chambers_sweep_a_constant_circle_quasi_statically():
    """The published programme in static mode: during the sweep the tip keeps the radius and height of
    the closed-form circle up to the load-stepping error, which falls as dt^2 (measured 6.4e-4 R at
    dt = 0.02, 1.6e-4 R at 0.01); the tip goes once around and comes back to the start."""
    deviation = []
    for dt in (0.02, 0.01):
        P, p = build(soft_arm_pneumatic.scene, n_elements=4, dt=dt)
        res = run(P, p["dt"], p["t_end"])
        R, Hc = soft_arm_pneumatic.circle(p)
        t = res.column("t")
        x, y, z = (res.column(f"tip_{c}") for c in "xyz")
        sweep = (t >= 0.5 - 1e-9) & (t <= 3.5 + 1e-9)
        deviation.append(max(np.max(np.abs(np.hypot(x, y)[sweep] - R)) / R, np.max(np.abs(z[sweep] - Hc)) / Hc))
        azimuth = np.unwrap(np.arctan2(y[sweep], x[sweep]))
        assert abs(azimuth[-1] - azimuth[0]) == pytest.approx(2 * np.pi, abs=1e-6)
        assert np.linalg.norm(tip(res.rows[-1]) - [0, 0, p["L"]]) <= 1e-6 * p["L"]   # back at the start
        assert res.max_balance_error <= 1e-9 * np.max(np.abs(res.column("H")))
    assert deviation[1] <= 3e-4 and deviation[0] / deviation[1] > 3.5, deviation


def test_helical_tendon_gives_the_helix():
    """Helical routing (one turn over L), no gravity: every node on the exact helix (constant strains in
    the frame co-rotating with the routing, B(ii)); it twists (torsion) as well as bends."""
    P, p = build(tendon_arm.scene, g=0.0, routing="helical", n_elements=16)
    run(P, p["dt"], p["t_end"])
    (EA, GA, _), (GJ, EI, _), _ = tendon_arm.section(p)
    f = 2 * np.pi / p["L"]
    Gamma, K = act.uniform_equilibrium((EA, GA, GA), (GJ, EI, EI), tendons=[(p["tension1"], (p["offset"], 0.0))],
                                       rate=f)
    assert abs(K[0]) > 0.1                   # torsion: the helical tendon twists the rod
    s, r = gathered(P, "r")
    exact, _ = act.uniform_centreline(Gamma, K, s, rate=f, R0=np.column_stack(tendon_arm.DIRECTORS))
    err = np.max(np.linalg.norm(r - exact, axis=1))
    assert err <= 5e-6 * p["L"], err        # measured 1.8e-6 L (time stepping 1e-6, space 1e-6)
    # it is a helix, not an arc: the tip leaves the plane of the first bend
    assert abs(exact[-1][1]) > 0.05


def test_tendon_arm_with_gravity_matches_the_shooting_solution():
    """Rucker-Webster robot with gravity along x: FE statics vs the independent strong-form shooting solution."""
    P, p = build(tendon_arm.scene, n_elements=8)
    res = run(P, p["dt"], p["t_end"])
    ref = tendon_arm.reference(p)
    assert np.linalg.norm(tip(res.rows[-1]) - [ref[f"tip_{c}"] for c in "xyz"]) <= 5e-6 * p["L"]
    assert ref["tip_x"] == pytest.approx(0.18221, abs=1e-5) and ref["tip_z"] == pytest.approx(0.45323, abs=1e-5)


# -- the balance -------------------------------------------------------------------------------------

def actuated_rod(tension, pressure, gravity=True, n=4):
    rod = CosseratRod(1.0, [0.02, 0.01, 0.01], [1e-3, 1e-3, 1e-3], [2.0, 2.0, 2.0])
    loads = [act.Tendon(tension, act.helical(0.08, 4.0), radius=0.1, name="t", end=0.75),
             act.Chamber(pressure, (0.0, 0.05), radius=0.1, area=0.01, name="c", segment=(0.25, 1.0))]
    if gravity:
        loads.append(Load("v", [0.0, 0.0, -9.81], "domain", "gravity"))
    return Problem(rod, 1.0, n, loads=loads, supports=[Support("left", "clamped")],
                   initial=straight((0, 0, 0), np.eye(3)), newton_options=NEWTON)


def test_exact_balance_with_time_varying_inputs():
    """tau(t), p(t) and gravity: |H_{n+1} - H_n - h y.u| <= 1e-12 max|H| every step (measured 1e-14; the
    issue's bound is 1e-9), and the work of each actuator is the exact change of its own potential:
    h y.u = -tau_{n+1/2} (l_{n+1} - l_n) + p_{n+1/2} (V_{n+1} - V_n) (discrete gradient of the length)."""
    tension = lambda t: 3.0 * np.sin(3 * t) ** 2          # noqa: E731
    pressure = lambda t: 400.0 * np.sin(2 * t)             # noqa: E731
    dt = 0.01
    P = actuated_rod(tension, pressure, gravity=False)
    res = run(P, dt, 1.5)
    H = res.column("H")
    assert np.ptp(res.column("tip_y")) > 0.05 and np.max(np.abs(H)) > 0.03        # the actuators did work
    assert np.max(np.abs(res.column("balance_error"))) <= 1e-12 * np.max(np.abs(H))
    tm = res.column("t")[1:] - dt / 2
    l, V = res.column("length_t"), res.column("volume_c")
    port = -np.array([tension(t) for t in tm]) * np.diff(l) + np.array([pressure(t) for t in tm]) * np.diff(V)
    assert np.max(np.abs(np.diff(res.column("supplied")) - port)) <= 1e-12 * np.max(np.abs(H))
    assert np.ptp(l) > 0.01 and np.ptp(V) > 1e-4
    print(f"balance {np.max(np.abs(res.column('balance_error'))) / np.max(np.abs(H)):.2e} of max|H|")


def test_planar_beam_ports_balance():
    """Planar beam (k = 1, straight offsets): tendon and chamber, time-varying: balance per step, and the
    work equals -tau dl + p dV (exact there: g and y are cellwise constant)."""
    tension = lambda t: 2.0 * np.sin(4 * t) ** 2           # noqa: E731
    pressure = lambda t: 30.0 * np.sin(3 * t)              # noqa: E731
    beam = PlanarBeam(1.0, 0.01, quadratic(1e3, 1e3, 1.0))
    loads = [act.Tendon(tension, act.straight(0.05), radius=0.1, name="t"),
             act.Chamber(pressure, -0.04, radius=0.1, area=0.005, name="c", segment=(0.0, 0.5)),
             Load("v", [0.0, -9.81], "domain", "gravity")]
    P = Problem(beam, 1.0, 8, loads=loads, supports=[Support("left", "clamped")],
                initial={"r": lambda x: np.vstack([x[0], 0 * x[0]])})
    dt = 0.01
    res = run(P, dt, 1.0)
    H = res.column("H")
    assert np.max(np.abs(res.column("balance_error"))) <= 1e-12 * np.max(np.abs(H))
    # the actuators' work alone: a run without gravity
    tm = res.column("t")[1:] - dt / 2
    P2 = Problem(beam, 1.0, 8, loads=loads[:2], supports=[Support("left", "clamped")],
                 initial={"r": lambda x: np.vstack([x[0], 0 * x[0]])})
    res2 = run(P2, dt, 1.0)
    W2 = (-np.array([tension(t) for t in tm]) * np.diff(res2.column("length_t"))
          + np.array([pressure(t) for t in tm]) * np.diff(res2.column("volume_c")))
    assert np.max(np.abs(np.diff(res2.column("supplied")) - W2)) <= 1e-12 * np.max(np.abs(res2.column("H")))
    assert np.ptp(res2.column("tip_y")) > 0.05


def test_zero_inputs_change_nothing():
    """tau = 0 and p = 0 (as numbers and as functions of t): the history and the state equal the
    unactuated rod's to round-off (gravity on, 50 steps).  (Not bit for bit: the actuators' terms
    are possible nonzeros of the Jacobian, rodfem/fem/fastassembly.py, so its pattern and the LU's
    elimination order differ.)"""
    rod = CosseratRod(1.0, [0.02, 0.01, 0.01], [1e-3, 1e-3, 1e-3], [1e-1, 1e-1, 1e-1])
    gravity = Load("v", [0.0, 0.0, -9.81], "domain", "gravity")

    def make(actuated):
        loads = [gravity]
        if actuated:
            loads += [act.Tendon(0.0, act.helical(0.08, 4.0), radius=0.1, name="t"),
                      act.Chamber(lambda t: 0.0, (0.0, 0.05), radius=0.1, area=0.01, name="c")]
        P = Problem(rod, 1.0, 4, loads=loads, supports=[Support("left", "clamped")],
                    initial=straight((0, 0, 0), np.eye(3)), newton_options=NEWTON)
        return P, run(P, 0.01, 0.5)
    P0, r0 = make(False)
    P1, r1 = make(True)
    x0, x1 = P0.x0.x.array, P1.x0.x.array
    assert np.max(np.abs(x0 - x1)) <= 1e-13 * np.max(np.abs(x0))
    assert np.array_equal(r0.column("newton_its"), r1.column("newton_its"))
    for k in ("H", "supplied", "tip_x", "tip_y", "tip_z"):
        assert np.max(np.abs(r0.column(k) - r1.column(k))) <= 1e-13 * np.max(np.abs(r0.column(k))), k
    assert max(np.max(np.abs(r.column("balance_error"))) for r in (r0, r1)) <= 1e-13 * np.max(np.abs(r0.column("H")))
    assert np.ptp(r1.column("tip_z")) > 0.1


def test_only_used_actuators_are_assembled():
    """Scenes assemble only the actuators whose input is not identically zero; other scenes none."""
    from rodfem.demos import roll_up_3d
    P, _ = build(tendon_arm.scene)
    assert [ld.name for ld in P.loads] == ["tendon1", "gravity"]
    P, _ = build(tendon_arm.scene, tension1=0.0, tension3=5.0, g=0.0)
    assert [ld.name for ld in P.loads] == ["tendon3"]
    P, _ = build(soft_arm_pneumatic.scene, amplitude=0.0)
    assert P.loads == [] and P.work is None
    P, _ = build(soft_arm_swing.scene, tau_max=0.0)
    assert [ld.name for ld in P.loads] == ["chamber", "gravity"]
    P, _ = build(roll_up_3d.scene)
    assert not any(isinstance(ld, (act.Tendon, act.Chamber)) for ld in P.loads)
    assert not any(k.startswith(("length_", "volume_")) for k in P.observables_compiled)


# -- bad input -----------------------------------------------------------------------------------------

def test_bad_input_one_line_errors():
    with pytest.raises(ParameterError, match="tension must be >= 0"):
        act.Tendon(-1.0, (0.01, 0.0), radius=0.02)
    with pytest.raises(ParameterError, match="leaves the cross-section"):
        act.Tendon(1.0, (0.03, 0.0), radius=0.02)
    with pytest.raises(ParameterError, match="chamber area"):
        act.Chamber(1e3, (0.005, 0.0), radius=0.01, area=0.0)
    with pytest.raises(ParameterError, match="chamber area"):
        act.Chamber(1e3, (0.005, 0.0), radius=0.01, area=-1e-5)
    rod = CosseratRod(0.0, (0.0, 0.0, 0.0), [1e-3] * 3, [1.0] * 3)
    # a converging routing that crosses the axis and leaves the section beyond s = 0.5 (checked at bind)
    with pytest.raises(ParameterError, match="leaves the cross-section"):
        Problem(rod, 1.0, 2, loads=[act.Tendon(1.0, act.converging((0.01, 0.0), 0.25), radius=0.015)],
                supports=[Support("left", "clamped")], initial=straight((0, 0, 0), np.eye(3)))
    with pytest.raises(ParameterError, match="mesh node"):
        Problem(rod, 1.0, 2, loads=[act.Tendon(1.0, (0.01, 0.0), radius=0.02, end=0.3)],
                supports=[Support("left", "clamped")], initial=straight((0, 0, 0), np.eye(3)))
    # a tension history that turns negative: one line at the step where it does
    P = Problem(rod, 1.0, 2, loads=[act.Tendon(lambda t: 1.0 - 10 * t, (0.01, 0.0), radius=0.02, name="t1")],
                supports=[Support("left", "clamped")], initial=straight((0, 0, 0), np.eye(3)), newton_options=NEWTON)
    with pytest.raises(ParameterError, match=r"t1: tension must be >= 0.*t = 0\.1"):
        run(P, 0.05, 1.0)
    # statics reads the same checked input (a number or a history) at its time
    with pytest.raises(ParameterError, match=r"t1: tension must be >= 0.*t = 0\.5"):
        Statics(P).solve(0.5)


def test_cli_bad_input_one_line(rodfem):
    for sets, what in ((["tension1=-1"], "tension1"), (["offset=0.03"], "leaves the cross-section"),
                       (["r_chamber=0"], "r_chamber")):
        scene = "soft-arm-pneumatic" if sets[0].startswith("r_chamber") else "tendon-arm"
        args = ["run", scene, "--quiet", "--set", "t_end=0.05", "--set", "dt=0.025"]
        for s in sets:
            args += ["--set", s]
        out = rodfem(*args)
        assert out.returncode == 2, out.stderr
        lines = rodfem_lines(out.stderr)
        assert len(lines) == 1 and what in lines[0], out.stderr


# -- serial vs 2 ranks -----------------------------------------------------------------------------------

@pytest.mark.mpi
def test_serial_and_two_ranks_agree(tmp_path):
    """soft-arm-swing (chamber + tendon + gravity, dynamics), 6 elements, 40 steps: np 2 = serial."""
    args = ["run", "soft-arm-swing", "--set", "n_elements=6", "--set", "t_end=0.2", "--set", "t_on=0.05", "--quiet"]
    ok(rodfem(*args, "--out", tmp_path / "s"))
    ok(rodfem(*args, "--out", tmp_path / "p", np=2))
    s, q = summary(tmp_path / "s"), summary(tmp_path / "p")
    assert q["mpi_ranks"] == 2 and s["ports"] == ["chamber", "tendon", "gravity"]
    for k in ("H", "supplied", "tip_x", "tip_y", "tip_z", "volume_chamber", "length_tendon"):
        assert abs(s["final"][k] - q["final"][k]) <= 1e-9 * max(1e-3, abs(s["final"][k])), k
    assert abs(s["final"]["tip_y"]) > 1e-3          # it moved
