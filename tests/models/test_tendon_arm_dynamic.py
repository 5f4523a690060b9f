"""tendon-arm-dynamic (demos/tendon_arm_dynamic.py): the soromox tendon benchmark on small meshes.

Oracles: the exact discrete balance (tendons + gravity supplied, dashpots dissipated), the mirror
symmetry x = y of the two equal tendons, the static equilibria of the strong-form shooting solution
(forms/actuators.py shooting_statics) -- the fallen arm as the long-time limit of the damped run, the
upright (unstable) one as the FE statics solve --, and the damping ratio zeta_1 = tau omega_1 / 2 of the
first mode (log decrement, omega_1 from the linearization).
"""

import numpy as np
import pytest
from mpi4py import MPI
from processes import ok, rodfem_lines, summary

from rodfem import run
from rodfem.analysis.linearize import Linearization, natural_modes
from rodfem.analysis.statics import Statics
from rodfem.demos import tendon_arm_dynamic as arm
from rodfem.forms import damping

COMM = MPI.COMM_WORLD


def build(**overrides):
    p = arm.scene.values(overrides)
    return arm.scene.build(p, COMM), p


def tip(row):
    return np.array([row[f"tip_{c}"] for c in "xyz"])


def centreline(P, x):
    s, r = P.space.nodal(x, "r")
    s, r = np.concatenate(COMM.allgather(s)), np.concatenate(COMM.allgather(r))
    order = np.argsort(s)
    s, r = s[order], r[order]
    keep = np.concatenate([[True], np.diff(s) > 1e-12])
    return s[keep], r[keep]


def test_tau_kv_is_soromox_eta_over_G():
    """soromox D = eta diag(J, 3I, 3I, 3A, A, A), eta = 1e4 Pa s, equals tau_kv diag(GJ, EI, EI, EA, GA, GA)."""
    p = arm.scene.values({})
    (EA, GA, _), (GJ, EI, _), _, _ = arm.section(p)
    A, I = np.pi * p["radius"] ** 2, np.pi * p["radius"] ** 4 / 4
    eta = 1e4
    D_soromox = eta * np.array([2 * I, 3 * I, 3 * I, 3 * A, A, A])
    assert np.allclose(p["tau_kv"] * np.array([GJ, EI, EI, EA, GA, GA]), D_soromox, rtol=1e-14)


def test_falls_over_with_the_exact_balance():
    """6 elements, dt = 0.02, to t = 2 s: H_{n+1} - H_n = h y.u - h d_n to 1e-12 max|H| (discrete gradient),
    dissipation monotone, x = y by symmetry, and the arm has fallen (tip below 0.45 m, 0.2 m out)."""
    P, p = build(n_elements=6, dt=0.02, t_end=2.0)
    res = run(P, p["dt"], p["t_end"])
    H = res.column("H")
    err = np.max(np.abs(res.column("balance_error"))) / np.max(np.abs(H))
    print(f"balance {err:.2e} of max|H|, tip {tip(res.rows[-1])}")
    assert err <= 1e-12
    assert np.all(np.diff(res.column("dissipated")) >= 0) and res.column("dissipated")[-1] > 0.05
    assert np.allclose(res.column("tip_x"), res.column("tip_y"), atol=1e-12)
    x, _, z = tip(res.rows[-1])
    assert z < 0.45 and x > 0.2


def test_long_time_limit_is_the_fallen_static_equilibrium():
    """With extra mass-proportional damping (which changes no equilibrium) the run settles by t = 10; its tip is
    the shooting solution's fallen equilibrium (Newton started from the run's centreline) to the mesh error."""
    P, p = build(n_elements=8, dt=0.1, t_end=10.0, rayleigh_alpha=4.0)
    res = run(P, p["dt"], p["t_end"])
    _, r = centreline(P, P.x0)
    ref = arm.static_tip(p, r)
    got = tip(res.rows[-1])
    print(f"settled tip {got}, shooting {ref}, |diff| {np.linalg.norm(got - ref):.2e}")
    assert np.linalg.norm(got - ref) <= 4e-4 * p["L"]        # measured 2.2e-4; 16 elements: 1.35e-5 (order 4)
    assert ref[2] < 0.4 and ref[0] == pytest.approx(ref[1], abs=1e-9)        # fallen, on the diagonal


def test_statics_finds_the_upright_equilibrium_of_the_shooting():
    """Straight start, full load: FE statics and shooting (from G(0) = 0) agree on the upright (unstable) state."""
    P, p = build(n_elements=12)
    st = Statics(P)
    st.solve(p["t_end"])
    _, r = centreline(P, P.x0)
    ref = arm.static_tip(p, np.zeros((2, 3)))
    print(f"upright: FE {r[-1]}, shooting {ref}")
    assert np.linalg.norm(r[-1] - ref) <= 1e-5 * p["L"]
    assert ref[2] > 0.59 and ref[0] < 0                 # bent away from the tendons, still upright


def test_first_mode_damping_ratio():
    """g = 0: the tendons switched on at t = 0 set the arm swinging about its bent state; mode 1 decays with
    zeta_1 = tau_kv omega_1 / 2 (omega_1 of the undamped linearization)."""
    P0, _ = build(n_elements=6, g=0.0, tau_kv=0.0, tension1=0.0, tension2=0.0)
    omega = np.asarray(natural_modes(Linearization(P0), 4, "dense")[0])
    P, p = build(n_elements=6, g=0.0, dt=0.02, t_end=5.0)
    res = run(P, p["dt"], p["t_end"])
    t, y = res.column("t"), res.column("tip_x")
    rest = arm.static_tip(p, np.zeros((2, 3)))[0]       # the bent arm at rest (shooting; g = 0: one pass)
    keep = t > 0.3
    zeta = damping.log_decrement_zeta(t[keep], y[keep] - rest)
    theory = p["tau_kv"] * omega[0] / 2
    print(f"omega {omega}, zeta {zeta:.4f}, theory {theory:.4f}")
    assert zeta == pytest.approx(theory, rel=0.02)


def test_bad_input_is_one_line(capsys):
    from rodfem.app.cli import main
    for name, value, what in (("tau_kv", "-1", "tau_kv"), ("rayleigh_alpha", "nan", "rayleigh_alpha"),
                              ("offset", "0.04", "leaves the cross-section"), ("tension1", "-1", "tension")):
        capsys.readouterr()
        assert main(["run", "tendon-arm-dynamic", "--set", f"{name}={value}", "--set", "t_end=0.02",
                     "--quiet"]) == 2
        err = rodfem_lines(capsys.readouterr().err)
        assert len(err) == 1 and what in err[0], err


@pytest.mark.mpi
def test_serial_and_two_ranks_agree(tmp_path, rodfem):
    """6 elements, 30 steps of the falling arm: mpirun -n 2 = serial to solver tolerance."""
    args = ["run", "tendon-arm-dynamic", "--set", "n_elements=6", "--set", "dt=0.05", "--set", "t_end=1.5", "--quiet"]
    ok(rodfem(*args, "--out", tmp_path / "s"))
    ok(rodfem(*args, "--out", tmp_path / "p", np=2))
    s, q = summary(tmp_path / "s"), summary(tmp_path / "p")
    assert q["mpi_ranks"] == 2
    for k in ("H", "supplied", "dissipated", "tip_x", "tip_y", "tip_z", "length_tendon1", "length_tendon2"):
        assert abs(s["final"][k] - q["final"][k]) <= 1e-9 * max(1e-3, abs(s["final"][k])), k
    assert s["final"]["tip_x"] > 0.1            # it fell
