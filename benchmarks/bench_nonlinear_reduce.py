"""The nonlinear reduced model (issue 29): cantilever-2d at large deflection, POD rank r = 4, 8, 16, with and
without ECSW hyper-reduction.

    .venv/bin/python benchmarks/bench_nonlinear_reduce.py          # -> benchmarks/nonlinear_reduce.{csv,md}
    .venv/bin/python benchmarks/bench_nonlinear_reduce.py damped   # -> benchmarks/nonlinear_reduce_damped.{csv,md}

`rodfem reduce cantilever-2d --nonlinear` (rodfem/app/nonlinear_reduction.py, rodfem/analysis/galerkin.py,
rodfem/analysis/ecsw.py): the steel strip of cantilever-2d (1 m, EI = 175 N m^2) at degree 2 (the efforts N, M
are fields), its tip load fy ramped over 0.2 s to -150 N and held (training: the tip swings about a deflection
of 0.26 m, a quarter of the length), 500 steps of 1 ms; the test input: fy = -100 N with a horizontal fx = 30 N
the training never had.  Three meshes (40, 160, 640 elements).  Per order and input: the reduced model without
hyper-reduction (full-order assembly, projected) and with ECSW (the default tolerance 1e-3; at 640 elements also
1e-2): the sampled cells, the configuration and tip errors against the full model, the largest energy-balance
residual / max H, the wall time per step of the full and reduced time loops, the reduced model's time split,
the speed-up.
"""
import sys

from report import write_report

from rodfem.analysis.ecsw import DEFAULT_TOL
from rodfem.app.nonlinear_reduction import run_nonlinear_reduce

SETS = {"degree": 2, "fy": -150.0, "t_ramp": 0.2, "t_load": 1.0, "t_end": 0.5, "dt": 1e-3}
TEST = {"fy": -100.0, "fx": 30.0}
ORDERS = (4, 8, 16)
MESHES = (40, 160, 640)
OTHER_TOL = 1e-2   # also at the finest mesh: a looser fit


def rows_of(info, n, tol, galerkin):
    rows = []
    for r in ORDERS:
        o = info["orders"][str(r)]
        models = ([("none", o["galerkin"])] if galerkin else []) + [(f"ecsw {tol:g}", o)]
        for hyper, m in models:
            for name in ("train", "test"):
                e, run = m[name], info["runs"][name]
                split = {k: 1e3 * v / run["steps"] for k, v in e["time_split_s"].items()}
                if hyper == "none":
                    text = "F {assemble_F:.3f} / J {assemble_J:.3f} / project {project:.3f} / solve {solve:.3f}".format(**split)
                else:
                    text = ("state {state:.3f} / F {assemble_F:.3f} / J {assemble_J:.3f} / solve {solve:.3f} / "
                            "H, work, tip {outputs:.3f}").format(**split)
                rows.append({"elements": n, "dofs": run["dofs"], "r": r, "unknowns": o["reduced_unknowns"],
                             "energy_modes": o["modes_per_block"]["energy"], "hyper": hyper,
                             "sampled": o["ecsw"]["sampled"] if hyper != "none" else n,
                             "fit": o["ecsw"]["fit_residual"] if hyper != "none" else 0.0,
                             "training_s": o["ecsw"]["training_s"] if hyper != "none" else 0.0, "input": name,
                             "config_error": e["errors"]["configuration"], "tip_y_error": e["errors"]["tip_y"],
                             "tip_x_error": e["errors"]["tip_x"], "balance": e["errors"]["balance_relative"],
                             "H_w_error": e["errors"].get("energy_weighted_vs_full", 0.0),
                             "full_balance": run["full_balance_relative"],
                             "full_ms": run["full_ms_per_step"], "rom_ms": e["ms_per_step"], "speed_up": e["speed_up"],
                             "newton": e["newton_iterations_per_step"], "jacobians": e["jacobians_per_step"],
                             "split": text, **{f"{k}_ms": v for k, v in split.items()}})
    return rows


def main(meshes=MESHES):
    rows = []
    for n in meshes:
        info = run_nonlinear_reduce("cantilever-2d", {**SETS, "n_elements": n}, test=TEST, orders=ORDERS,
                                    ecsw_tol=DEFAULT_TOL, compare=True)
        rows += rows_of(info, n, DEFAULT_TOL, galerkin=True)
        if n == max(meshes):
            info = run_nonlinear_reduce("cantilever-2d", {**SETS, "n_elements": n}, test=TEST, orders=ORDERS,
                                        ecsw_tol=OTHER_TOL)
            rows += rows_of(info, n, OTHER_TOL, galerkin=False)
    columns = [("elements", "{}"), ("dofs", "{}", "full dofs"), ("r", "{}", "r"), ("unknowns", "{}", "reduced unknowns"),
               ("hyper", "{}", "hyper-reduction"), ("sampled", "{}", "cells assembled"), ("input", "{}"),
               ("config_error", "{:.2e}", "configuration error"), ("tip_y_error", "{:.2e}", "tip_y error"),
               ("balance", "{:.1e}", "balance / max H (reduced)"), ("H_w_error", "{:.1e}", "max abs(H_w - H) / max H"),
               ("full_ms", "{:.3f}", "full ms/step"),
               ("rom_ms", "{:.3f}", "reduced ms/step"), ("speed_up", "{:.2f}", "speed-up"),
               ("split", "{}", "reduced: time split, ms per step"), ("newton", "{:.2f}", "Newton its/step"),
               ("jacobians", "{:.2f}", "Jacobians/step")]
    write_report("nonlinear_reduce", rows, columns,
                 title="Nonlinear reduced model (rodfem reduce --nonlinear): cantilever-2d at large deflection",
                 intro=["Training: tip load fy ramped over 0.2 s to -150 N, held; 500 steps of 1 ms (the tip swings about "
                        "0.26 m below the axis, 30 % of the length at its lowest).  Test: fy = -100 N, fx = 30 N.  Degree 2 "
                        "(efforts as fields), midpoint rule, Hooke's law.  r: POD modes per block; reduced unknowns "
                        "2 r (configuration, velocity) + 2 r_e (strains, efforts), r_e = r POD modes + the r strain images "
                        "of the configuration modes.  Errors: max over the steps of |q_r - q| / max |q - q_0| over all "
                        "configuration dofs, and of |tip_y,r - tip_y| / max |tip_y - tip_y(0)|.",
                        "",
                        "Hyper-reduction: `none` assembles the full residual and Jacobian and projects them (V^T F, "
                        "V^T J V); `ecsw TOL` assembles only the sampled cells with their weights (rodfem/analysis/ecsw.py, "
                        "trained on 40 states of the training run to the relative fit residual TOL; the tip load exact), "
                        "the energy and outputs too; its balance is that of the weighted Hamiltonian H_w."],
                 notes=["Speed-up = full / reduced wall time of the time loop (500 steps, one core of a shared 2-core "
                        "machine at a load average of 12 to 13 during the run: the full model's time at 640 elements "
                        "ranged from 10 to 24 ms per step between runs minutes apart).  "
                        "Time split of `none`: full assembly of F and J, the projections, the small solve; of `ecsw`: "
                        "forming the state on the sampled cells' dofs, the sampled residual and Jacobian (kernel and "
                        "projection in one C loop), the solves, and H_w, the work and the tip.  The ECSW Newton keeps its "
                        "factorized reduced Jacobian while the residual falls tenfold per iteration (more iterations, "
                        "fewer Jacobians); the converged solution is the same.",
                        "The energy balance of both reduced models is exact to Newton's tolerance (the structure kept); "
                        "the full model's is of the same size (full_balance in the CSV).  The ECSW training time "
                        "(training_s in the CSV) is a one-off cost of the set-up."])


DAMPED = {"tau_kv": 1e-3, "rayleigh_alpha": 2.0}


def damped(n=640, orders=(8,)):
    """The same at one mesh with Kelvin-Voigt (tau_kv = 1 ms) and Rayleigh (alpha = 2/s) damping:
    benchmarks/nonlinear_reduce_damped.{csv,md}."""
    global ORDERS
    ORDERS = orders
    info = run_nonlinear_reduce("cantilever-2d", {**SETS, **DAMPED, "n_elements": n}, test=TEST, orders=orders,
                                ecsw_tol=DEFAULT_TOL, compare=True)
    rows = rows_of(info, n, DEFAULT_TOL, galerkin=True)
    columns = [("elements", "{}"), ("r", "{}", "r"), ("unknowns", "{}", "reduced unknowns"), ("hyper", "{}", "hyper-reduction"),
               ("sampled", "{}", "cells assembled"), ("input", "{}"), ("config_error", "{:.2e}", "configuration error"),
               ("balance", "{:.1e}", "balance / max H (with dissipation)"), ("full_ms", "{:.3f}", "full ms/step"),
               ("rom_ms", "{:.3f}", "reduced ms/step"), ("speed_up", "{:.2f}", "speed-up")]
    write_report("nonlinear_reduce_damped", rows, columns,
                 title="Nonlinear reduced model of the damped cantilever (Kelvin-Voigt tau_kv = 1 ms, Rayleigh alpha = 2/s)",
                 intro=["The runs of nonlinear_reduce.md with damping; the energy basis split by strain component (its "
                        "unknowns grow), the balance H_r(n+1) - H_r(n) + h d_n - h y.u."])


if __name__ == "__main__":
    if sys.argv[1:2] == ["damped"]:
        damped()
    else:
        main(tuple(int(a) for a in sys.argv[1:]) or MESHES)
