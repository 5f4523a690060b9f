"""What a run leaves on disk (rank 0 writes; every file is flushed as it goes):

* history.csv    one row per time level: t, H, supplied, (dissipated,) newton_its, balance_error, observables
                 (`dissipated`, the cumulative sum h d_n, only for a dissipating model)
* summary.json   parameters, versions, elements, dofs, timing, balance errors, status
* centreline/    the deformed centreline as VTK polylines (one .vtu per frame) and
                 centreline.pvd, the time series ParaView opens
* shapes.png, energy.png   pictures of the deformed shapes and the energy history
"""
import csv
import json
import os
import xml.etree.ElementTree as ET

import numpy as np

from . import compat


def bodies_of(problem):
    """[(name, body)]: the bodies of a System, or the single body of a Problem."""
    refs = getattr(problem, "bodies", None)
    return [(name, ref.body) for name, ref in refs.items()] if refs else [("", problem)]


def gather_centreline(problem):
    """(s, position[npoints, dim], {field: values}) of the nodal fields of a body, on rank 0 (None elsewhere)."""
    S = problem.space
    pos = S.field(problem.model.position)
    names = [f.name for f in S.fields if f.family == pos.family and f.degree == pos.degree]
    local = {n: S.nodal(problem.x0, n) for n in names}
    gathered = problem.comm.gather(local, root=0)
    if problem.comm.rank != 0:
        return None
    s = np.concatenate([g[pos.name][0] for g in gathered])
    order = np.argsort(s)
    data = {n: np.concatenate([g[n][1] for g in gathered])[order] for n in names}
    return s[order], data.pop(pos.name), data


class RunWriter:
    def __init__(self, out, problem, n_steps, frames=100):
        self.out, self.problem = out, problem
        self.root = problem.comm.rank == 0
        self.every = max(1, int(np.ceil(n_steps / max(frames, 1))))
        self.count, self.frames, self.snapshots = 0, [], []
        self._csv = None
        if self.root:
            os.makedirs(os.path.join(out, "centreline"), exist_ok=True)

    # -- per step -------------------------------------------------------------
    def record(self, row, problem):
        if self.root:
            if self._csv is None:
                self._file = open(os.path.join(self.out, "history.csv"), "w", newline="")
                self._csv = csv.DictWriter(self._file, fieldnames=list(row))
                self._csv.writeheader()
            self._csv.writerow({k: repr(v) if isinstance(v, float) else v for k, v in row.items()})
            self._file.flush()
        if self.count % self.every == 0:
            self.frame(row["t"])
        self.count += 1

    def frame(self, t):
        bodies = bodies_of(self.problem)
        data = [gather_centreline(body) for _, body in bodies]  # collective
        if not self.root:
            return
        import meshio
        pts, cells, point_data, shapes = [], [], {}, []
        single = len(bodies) == 1
        for k, ((_, body), (s, pos, fields)) in enumerate(zip(bodies, data)):
            start = sum(len(p) for p in pts)
            p3 = np.zeros((len(s), 3))
            p3[:, : pos.shape[1]] = pos
            pts.append(p3)
            idx = start + np.arange(len(s))
            cells.append(("vertex", idx[:, None]) if len(s) == 1 else ("line", np.column_stack([idx[:-1], idx[1:]])))
            columns = {"s": s, "body": np.full(len(s), float(k))}
            if single:   # one body: its nodal fields too (a system's bodies have different fields)
                for name, vals in fields.items():
                    if vals.shape[1] == 2:
                        vals = np.column_stack([vals, np.zeros(len(vals))])
                    columns[name] = vals if vals.shape[1] > 1 else vals[:, 0]
            for name, vals in columns.items():
                point_data.setdefault(name, []).append(vals)
            shapes.append(pos.copy())
        point_data = {k: np.concatenate(v) for k, v in point_data.items()}
        name = f"centreline/frame_{len(self.frames):05d}.vtu"
        meshio.write(os.path.join(self.out, name), meshio.Mesh(np.concatenate(pts), cells, point_data=point_data))
        self.frames.append((t, name))
        self.snapshots.append((t, shapes))
        self._write_pvd()

    def _write_pvd(self):
        root = ET.Element("VTKFile", type="Collection", version="0.1")
        coll = ET.SubElement(root, "Collection")
        for t, name in self.frames:
            ET.SubElement(coll, "DataSet", timestep=repr(t), part="0", file=name)
        ET.ElementTree(root).write(os.path.join(self.out, "centreline.pvd"))

    # -- at the end (also after a failure) -----------------------------------------
    def finish(self, summary, result):
        if not self.root:
            return
        if self._csv is not None:
            self._file.close()
        with open(os.path.join(self.out, "summary.json"), "w") as f:
            json.dump(summary, f, indent=2, default=float)
        if result is not None and result.rows:
            plot_energy(os.path.join(self.out, "energy.png"), result)
        if self.snapshots:
            plot_shapes(os.path.join(self.out, "shapes.png"), self.snapshots)


def summarize(scene_name, params, problem, result, status="completed", failure=None):
    """summary.json content."""
    H = result.column("H") if result.rows else np.array([0.0])
    its = result.column("newton_its")[1:] if len(result.rows) > 1 else np.array([0])
    Hmax = float(np.max(np.abs(H))) or 1.0
    return {
        "scene": scene_name, "status": status, "failure": failure, "parameters": params,
        "dolfinx_version": compat.dolfinx_version, "integrator": problem.integrator,
        "elements": problem.describe_elements(), "n_elements": problem.n_elements, "dofs": problem.dofs,
        "mpi_ranks": problem.comm.size, "linear_solver": problem.newton.linear_solver, "steps": result.steps, "wall_time_s": result.wall_time,
        "time_per_step_ms": 1e3 * result.wall_time / max(result.steps, 1),
        "newton_its_mean": float(its.mean()), "newton_its_max": int(its.max()),
        "max_balance_error": result.max_balance_error,
        "max_balance_error_relative": result.max_balance_error / Hmax,
        "H_initial": float(H[0]), "H_final": float(H[-1]), "max_abs_H": Hmax,
        "ports": [load.name for load in problem.loads], "supports": [f"{s.kind}@{s.end}" for s in problem.supports],
        "joints": [f"{j.name}: {j.a.describe()} - {j.b.describe()}" for j in getattr(problem, "joints", [])],
        "final": {k: v for k, v in (result.rows[-1].items() if result.rows else [])},
    }


def plot_energy(path, result):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    t, H, W = result.column("t"), result.column("H"), result.column("supplied")
    err = np.abs(result.column("balance_error"))[1:]
    dissipates = "dissipated" in result.rows[0]
    fig, ax = plt.subplots(3 if dissipates else 2, 1, figsize=(7, 8 if dissipates else 6), sharex=True)
    ax[0].plot(t, H, label="H (Hamiltonian)")
    ax[0].plot(t, W, "--", label="supplied work  sum h y.u")
    if dissipates:   # the dissipated energy also on its own scale (middle panel)
        D = result.column("dissipated")
        ax[0].plot(t, D, "-.", label="dissipated  sum h d_n")
        ax[0].plot(t, H + D - W, ":", label="H + dissipated - supplied (constant)")
        ax[1].plot(t, D, "-.", color="C2")
        ax[1].set_ylabel("dissipated  sum h d_n")
        balance = "|H_{n+1} - H_n + h d_n - h y.u|"
    else:
        ax[0].plot(t, H - W, ":", label="H - supplied (constant)")
        balance = "|H_{n+1} - H_n - h y.u|"
    ax[0].set_ylabel("energy")
    ax[0].legend()
    floor = 1e-17 * max(np.max(np.abs(H)), 1e-300)  # below round-off: drawn at the floor
    ax[-1].semilogy(t[1:], np.maximum(err, floor), ".", ms=3)
    ax[-1].set_ylabel(balance)
    ax[-1].set_xlabel("t")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_shapes(path, snapshots, max_shapes=16):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    idx = np.unique(np.linspace(0, len(snapshots) - 1, min(max_shapes, len(snapshots))).astype(int))
    cmap = plt.get_cmap("viridis")
    dim = max(p.shape[1] for p in snapshots[0][1])
    fig = plt.figure(figsize=(7, 6))
    ax = fig.add_subplot(projection="3d" if dim == 3 else None)
    for j, i in enumerate(idx):
        t, shapes = snapshots[i]
        c = cmap(j / max(len(idx) - 1, 1))
        for b, p in enumerate(shapes):   # one line per body (a marker for a rigid body)
            label = f"t = {t:.3g}" if j in (0, len(idx) - 1) and b == 0 else None
            ax.plot(*[p[:, k] for k in range(dim)], "o" if len(p) == 1 else "-", color=c, lw=1.5, ms=4, label=label)
    if dim == 2:
        ax.set_aspect("equal", adjustable="datalim")
    else:  # equal scales on the three axes: a cube around the swept region
        pts = np.concatenate([p for i in idx for p in snapshots[i][1]])
        centre, half = 0.5 * (pts.max(0) + pts.min(0)), 0.5 * np.max(np.ptp(pts, axis=0)) or 1.0
        ax.set_xlim(centre[0] - half, centre[0] + half)
        ax.set_ylim(centre[1] - half, centre[1] + half)
        ax.set_zlim(centre[2] - half, centre[2] + half)
        ax.set_zlabel("z")
    ax.set_xlabel("x")
    ax.set_ylabel("y")
    ax.legend()
    ax.set_title("deformed centreline (colour = time)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
