"""Engine mechanics that every model relies on: Newton strategies and the options database."""
import numpy as np
from mpi4py import MPI

from rodfem import run
from rodfem.app.scene import load


def spaghetti(newton_options=None, **overrides):
    scene = load("flying-spaghetti-2d")
    p = scene.values({"t_end": 5.0, **overrides})
    problem = scene.build(p, MPI.COMM_WORLD)
    if newton_options is not None:  # rebuild the Newton solver with other settings
        problem.set_newton_options(newton_options)
    return problem, p


def test_chord_newton_falls_back_to_full_newton_and_agrees(monkeypatch):
    from rodfem.nls.newton import Newton
    retries = []
    full_newton = Newton._solve_full_newton
    monkeypatch.setattr(Newton, "_solve_full_newton", lambda self, *a: retries.append(a) or full_newton(self, *a))
    full, p = spaghetti()
    ref = run(full, p["dt"], p["t_end"])
    # a chord Newton allowed only 3 iterations cannot converge the loaded steps: each such step is
    # repeated with full Newton, and the trajectory is the same to solver tolerance (measured: identical)
    chord, _ = spaghetti({"snes_lag_jacobian": 8, "snes_lag_jacobian_persists": True, "snes_max_it": 3})
    res = run(chord, p["dt"], p["t_end"])
    assert len(retries) >= 25  # at least every loaded step (t <= 2.5) was repeated
    for col in ("H", "tip_x", "tip_y", "L_z"):
        assert np.max(np.abs(res.column(col) - ref.column(col))) <= 1e-11 * np.max(np.abs(ref.column(col)))
    assert res.max_balance_error <= 1e-11 * np.max(res.column("H"))   # measured 2.0e-15


def test_problem_options_do_not_leak_into_the_next_problem():
    a, _ = spaghetti({"snes_max_it": 3})
    b, _ = spaghetti()
    assert a.newton.snes.getTolerances()[3] == 3
    assert b.newton.snes.getTolerances()[3] == 25


def test_material_values_are_constants_not_compiled_in(rodfem, tmp_path):
    """A second run with other stiffness and density values compiles nothing: the JIT cache
    (empty before the first run) gains no file."""
    cache = tmp_path / "cache"
    env = {"XDG_CACHE_HOME": str(cache)}

    def run_with(EA, rhoA):
        p = rodfem("run", "cantilever-2d", "--set", f"EA={EA}", "--set", f"rhoA={rhoA}", "--set", "t_end=0.01",
                   "--quiet", "--out", str(tmp_path / "out"), env=env)
        assert p.returncode == 0, p.stderr[-2000:]
        return sorted(str(f) for f in cache.rglob("*") if f.is_file())
    first = run_with(1e6, 1.0)
    assert first  # the first run compiled its forms into the cache
    assert run_with(3e6, 2.0) == first


def test_material_parameter_checks():
    import pytest
    import ufl

    from rodfem.forms.planar_beam import quadratic
    with pytest.raises(ValueError, match="parameter EI must be a positive number"):
        quadratic(EA=1.0, GA=1.0, EI=0.0)
    quadratic(EA=1.0, GA=1.0, EI=1.0, kappa0=-0.5)                       # signed: any number
    x = ufl.SpatialCoordinate(ufl.Mesh(ufl.VectorElement("Lagrange", ufl.interval, 1)))
    quadratic(EA=1.0, GA=1.0, EI=1.0, kappa0=0.1 * x[0])                 # or a UFL expression
