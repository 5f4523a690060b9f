"""`rodfem reduce SCENE --order r [r ...]`: structure-preserving reduced models of a scene's linear PH model
(rodfem/analysis/reduce.py), written like `rodfem linearize` writes the full one.

Into `out`: r<r>/E.npz J.npz R.npz Q.npz B.npz C.npz (scipy.sparse.save_npz) and V.npy (x ~ V x_r) and
reduced.mat per order; reduce.json (the interpolation points and directions, the passivity checks, the
frequency-response errors on the grid, the reduced natural frequencies against the full model's modes),
bode.png (|G|_2 of the full and the reduced models and the error on the line s = alpha + i omega) and
summary.json.  The grid: GRID points log-spaced in omega over [omega_1 / 10, omega_K], omega_K the
highest interpolation frequency of the largest order; 'in_band' errors over [omega_1 / 10, omega_{r/2}]
(the band order r interpolates).
"""
import json
import os
import time

import numpy as np
from mpi4py import MPI

from rodfem.analysis.linearize import natural_modes
from rodfem.analysis.reduce import ALPHA, FullModel, frequency_error, interpolation_points, plot_bode, reduce, response
from rodfem.app.analyses import check_linearizable, finite_time, heading, linearization, owned, resolve
from rodfem.errors import ParameterError
from rodfem.io.output import write_json

GRID = 400


def run_reduce(scene, overrides=None, out=None, orders=(8,), about="static", t=0.0, alpha=ALPHA):
    """Reduce the scene's linear model to each order in `orders` (see the module docstring); returns the
    content of reduce.json (and the Reduced models under the key 'models', not written)."""
    from rodfem._version import __version__
    comm = MPI.COMM_WORLD
    t = finite_time(t)
    orders = sorted({int(r) for r in orders})
    for r in orders:
        if r < 2 or r % 2:
            raise ParameterError(f"--order must be even integers >= 2 (got {r})")
    if not (np.isfinite(alpha) and alpha > 0):
        raise ParameterError(f"--alpha must be a number > 0 (a fraction of the first natural frequency; got {alpha})")
    check_linearizable(about, comm)
    scene, p = resolve(scene, overrides)
    t0 = time.perf_counter()
    started = heading(scene, p, "reduce", comm, about=about, t=t, orders=orders)
    with owned(out, started, comm) as outdir:
        lin = linearization(scene, p, about, t, comm)
        full = FullModel(lin.E, lin.J, lin.R, lin.Q, lin.B, lin.C)
        if orders[-1] > full.n:
            raise ParameterError(f"--order must be at most the full model's {full.n} states (got {orders[-1]})")
        K = orders[-1] // 2
        omega, _, _ = natural_modes(lin, max(K, 2))
        if len(omega) < K:
            raise ParameterError(f"reduce: order {orders[-1]} needs {K} natural frequencies of the full model, it has "
                                 f"{len(omega)} verified ones; ask for a lower --order")
        shift = alpha * omega[0]
        w = np.geomspace(omega[0] / 10, omega[K - 1], GRID)
        grid = shift + 1j * w
        G = response(full, grid)
        models, results, curves = {}, {}, {}
        for r in orders:
            red = reduce(full, r, interpolation_points(omega, r // 2, shift))
            Gr = response(red, grid)
            errors, mag_full, err = frequency_error(G, Gr)
            band = w <= omega[r // 2 - 1] * (1 + 1e-12)
            in_band, _, _ = frequency_error(G[band], Gr[band])
            at_points = [float(np.linalg.norm(red.transfer(s) @ b - full.transfer(s) @ b)
                               / np.linalg.norm(full.transfer(s) @ b)) for s, b in zip(red.points, red.directions)]
            f_red = red.frequencies()
            k = min(len(f_red), r // 2)
            results[r] = {"order": r, "points": [[float(s.real), float(s.imag)] for s in red.points],
                          "directions": [[[float(x.real), float(x.imag)] for x in b] for b in red.directions],
                          "interpolation_error": max(at_points), "error": errors, "error_in_band": in_band,
                          "frequencies_rad_s": [float(x) for x in f_red[:r]],
                          "frequency_error_relative": [float(abs(a - b) / b) for a, b in zip(f_red[:k], omega[:k])],
                          "checks": red.checks}
            models[r] = red
            curves[r] = (np.array([np.linalg.norm(x, 2) for x in Gr]), err, red.points)
        info = {"scene": scene.name, "rodfem_version": __version__, "parameters": p, "about": about, "t": t,
                "n_states": full.n, "n_inputs": full.m, "inputs": lin.inputs, "alpha": shift,
                "full_frequencies_rad_s": [float(x) for x in omega],
                "grid": {"points": GRID, "omega_min": float(w[0]), "omega_max": float(w[-1]), "real_part": shift},
                "method": "effort-constraint Petrov-Galerkin projection W = Q V, V: tangential rational Krylov "
                          "directions (Polyuga & van der Schaft 2010; Gugercin, Polyuga, Beattie & van der Schaft 2012)",
                "form": "E dx' = (J - R) Q dx + B du, dy = B^T Q dx = C dx (Q = I)",
                "orders": {str(r): v for r, v in results.items()}, "wall_time_s": time.perf_counter() - t0}
        if outdir:
            outdir.do("write the reduced models", write_reduced, out, models, info)
            outdir.do("write bode.png", plot_bode, outdir.file("bode.png"), w, curves,
                      np.array([np.linalg.norm(x, 2) for x in G]), shift,
                      f"{scene.name}: full ({full.n} states) and reduced PH models")
            outdir.do("write summary.json", write_json, outdir.file("summary.json"),
                      dict(started, status="completed", n_states=full.n, orders=orders,
                           wall_time_s=time.perf_counter() - t0))
    info["models"] = models
    return info


def write_reduced(out, models, info):
    """r<r>/{E,J,R,Q,B,C}.npz, V.npy, reduced.mat and reduce.json."""
    import scipy.io
    import scipy.sparse as sp
    for r, red in models.items():
        d = os.path.join(out, f"r{r}")
        os.makedirs(d, exist_ok=True)
        for k, M in red.matrices().items():
            sp.save_npz(os.path.join(d, f"{k}.npz"), sp.csr_matrix(M))
        np.save(os.path.join(d, "V.npy"), red.V)
        scipy.io.savemat(os.path.join(d, "reduced.mat"), {**red.matrices(), "V": red.V})
    with open(os.path.join(out, "reduce.json"), "w") as fh:
        json.dump(info, fh, indent=2, default=float)
