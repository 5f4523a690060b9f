"""What a run leaves on disk (rank 0 writes; every file is flushed as it goes):

* history.csv    one row per time level: t, H, supplied, (dissipated,) newton_its, balance_error, observables
                 (`dissipated`, the cumulative sum h d_n, only for a dissipating model)
* summary.json   parameters, versions, elements, dofs, timing, balance errors, status
                 ("running" from the start, replaced at the end by "completed",
                 "newton-failure", "interrupted" or "error")
* centreline/    the deformed centreline as VTK polylines (one .vtu per frame) and
                 centreline.pvd, the time series ParaView opens
* shapes.png, energy.png   pictures of the deformed shapes and the energy history

A run owns its directory (`OutDir`): a lock (``fcntl.flock`` on .rodfem.lock)
refuses a second run into it while the first is running, and a new run first
removes the files a previous run wrote there (the names above; other files are
left alone), so a directory never mixes two runs.  summary.json, the frames,
centreline.pvd and the pictures are written to a temporary file and renamed
(`replace_atomically`): a killed run leaves no half-written file.  A file that
cannot be written ends the run with an InputError naming --out, on every rank.
"""
import csv
import errno
import fcntl
import glob
import json
import os
import xml.etree.ElementTree as ET
from contextlib import contextmanager, suppress

import numpy as np

from . import compat
from .errors import InputError, agreed

OWN_FILES = ("history.csv", "summary.json", "centreline.pvd", "shapes.png", "energy.png",
             "centreline/frame_*.vtu", ".*.tmp", "centreline/.*.tmp", "checkpoint.npz", "checkpoint.npz.tmp*")
LOCK_FILE = ".rodfem.lock"


def replace_atomically(path, write):
    """Create `path` by write(temporary path) in the same directory, then os.replace (never half-written)."""
    tmp = os.path.join(os.path.dirname(path), "." + os.path.basename(path) + ".tmp")
    try:
        write(tmp)
        os.replace(tmp, path)
    finally:
        with suppress(FileNotFoundError):
            os.unlink(tmp)


def json_ready(x):
    """JSON has no NaN or infinity: non-finite numbers become the strings "nan", "inf", "-inf"."""
    if isinstance(x, dict):
        return {k: json_ready(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [json_ready(v) for v in x]
    if isinstance(x, (float, np.floating)):
        return float(x) if np.isfinite(x) else str(float(x))
    return x


def write_json(path, data):
    """`data` as JSON, replacing `path` atomically; on a full disk, overwritten in place
    (which frees its blocks first)."""
    text = json.dumps(json_ready(data), indent=2, default=float)

    def write(target):
        with open(target, "w") as f:
            f.write(text)
    try:
        replace_atomically(path, write)
    except OSError as e:
        if e.errno not in (errno.ENOSPC, errno.EDQUOT, errno.EFBIG) or not os.path.exists(path):
            raise
        write(path)


class OutDir:
    """The --out directory of one run, owned for the run's duration (see the module docstring).

    Rank 0 does the file work; `do` is collective and turns an OSError into an InputError on every rank.
    """

    def __init__(self, path, comm):
        self.path, self.comm = str(path), comm
        self.root = comm.rank == 0
        self._lock = None

    def file(self, name):
        return os.path.join(self.path, name)

    def do(self, what, fn, *args, hint=""):
        """Collective: rank 0 runs fn(*args); an OSError there ends the run on every rank (InputError)."""
        with agreed(self.comm):
            if self.root:
                try:
                    fn(*args)
                except OSError as e:
                    raise InputError(f"--out {self.path!r}: cannot {what} ({e.strerror or e}){hint}") from None

    @contextmanager
    def claimed(self, summary, clear=True):
        """Lock the directory, clear a previous run's files (not when `clear` is false: a run resumed
        from its checkpoint, rodfem/checkpoint.py), write summary.json (status "running");
        release the lock at the end of the block."""
        self.do("create the directory", os.makedirs, os.path.join(self.path, "centreline"), 0o777, True,
                hint="; --out must name a directory that can be created and written")
        try:
            self.do("lock the directory", self._take_lock)
            if clear:
                self.do("remove the previous run's files", self._clear)
            self.do("write summary.json", write_json, self.file("summary.json"), summary)
            yield self
        finally:
            if self._lock is not None:
                os.close(self._lock)
                self._lock = None

    def _take_lock(self):
        fd = os.open(self.file(LOCK_FILE), os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            owner = os.read(fd, 32).decode(errors="replace").strip() or "?"
            os.close(fd)
            raise InputError(f"--out {self.path!r} is in use by another rodfem run (pid {owner}): "
                             f"wait for it to end or choose another directory") from None
        self._lock = fd
        os.ftruncate(fd, 0)
        os.write(fd, f"{os.getpid()}\n".encode())

    def _clear(self):
        for pattern in OWN_FILES:
            for path in glob.glob(os.path.join(glob.escape(self.path), pattern)):
                os.unlink(path)


def frame_levels(n_steps, frames):
    """The time levels (0..n_steps) written as frames: `frames` of them, evenly spaced, t = 0 and t_end
    included; every level if there are fewer; t_end alone for frames = 1."""
    if frames <= 1:
        return {n_steps}
    k = min(frames, n_steps + 1)
    return set(np.floor(np.linspace(0, n_steps, k) + 0.5).astype(int).tolist())


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
    """Writes a run into a claimed OutDir: history rows, centreline frames, and at the end summary and plots."""

    def __init__(self, out, problem, n_steps, frames=100):
        self.out, self.problem = out, problem
        self.levels = frame_levels(n_steps, frames)
        self.count, self.frames, self.snapshots = 0, [], []
        self._file = self._csv = None

    # -- per step (collective) ----------------------------------------------------
    def record(self, row, problem):
        self.out.do("write history.csv", self._append, row)
        if self.count in self.levels:
            self.frame(row["t"])
        self.count += 1

    def _append(self, row):
        if self._csv is None:
            self._file = open(self.out.file("history.csv"), "w", newline="")
            self._csv = csv.DictWriter(self._file, fieldnames=list(row))
            self._csv.writeheader()
        self._csv.writerow({k: repr(v) if isinstance(v, float) else v for k, v in row.items()})
        self._file.flush()

    def frame(self, t):
        bodies = bodies_of(self.problem)
        data = [gather_centreline(body) for _, body in bodies]  # collective
        self.out.do("write a centreline frame", self._write_frame, t, bodies, data)

    def _write_frame(self, t, bodies, data):
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
        mesh = meshio.Mesh(np.concatenate(pts), cells, point_data=point_data)
        replace_atomically(self.out.file(name), lambda tmp: meshio.write(tmp, mesh, file_format="vtu"))
        self.frames.append((t, name))
        self.snapshots.append((t, shapes))
        replace_atomically(self.out.file("centreline.pvd"), self._write_pvd)

    def _write_pvd(self, path):
        root = ET.Element("VTKFile", type="Collection", version="0.1")
        coll = ET.SubElement(root, "Collection")
        for t, name in self.frames:
            ET.SubElement(coll, "DataSet", timestep=repr(t), part="0", file=name)
        ET.ElementTree(root).write(path)

    # -- at the end (also after a failure; collective) ----------------------------------
    def finish(self, summary, result):
        """Close history.csv, write summary.json (replacing "running"), then the plots; each is tried
        even if one before failed (after a full disk, the summary may still fit), the first error raised."""
        errors = []
        for what, fn, *args in (("close history.csv", self._close),
                                ("write summary.json", write_json, self.out.file("summary.json"), summary),
                                ("write the plots", self._plots, result)):
            try:
                self.out.do(what, fn, *args)
            except InputError as e:
                errors.append(e)
        if errors:
            raise errors[0]

    def _close(self):
        if self._file is not None:
            file, self._file, self._csv = self._file, None, None
            file.close()  # closed even when its last flush fails

    def _plots(self, result):
        if result is not None and result.rows:
            plot_energy(self.out.file("energy.png"), result)
        if self.snapshots:
            plot_shapes(self.out.file("shapes.png"), self.snapshots)


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
    replace_atomically(path, lambda tmp: fig.savefig(tmp, dpi=110, format="png"))
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
    replace_atomically(path, lambda tmp: fig.savefig(tmp, dpi=110, format="png"))
    plt.close(fig)
