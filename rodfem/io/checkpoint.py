"""Checkpoint and restart: a run continued from its last checkpoint repeats the uninterrupted one bit by bit.

``rodfem run SCENE --set checkpoint_every=N --out DIR`` writes DIR/checkpoint.npz
after every N-th step (written to a temporary file and renamed, so a kill at
any moment leaves the previous checkpoint whole) and summary.json with status
"running" and the step reached.  It
holds everything the next step depends on:

* the state x_n of every body (all fields) and the system's multipliers,
* x_{n-1}, from which Newton starts (x_{n+1}^0 = 2 x_n - x_{n-1}),
* the step n, t_n (n dt, or the adaptive run's own time), H(x_n), the supplied work so far, the LU
  package Newton has switched to (PETSc's LU -> SuperLU/MUMPS after a zero pivot), the step
  control's state (rodfem/analysis/stepping.py: the last step h_{n-1} for the predictor, the number of
  sub-steps a fixed step starts with, an adaptive run's next step and its counts),
* the scene, its parameters, N and the rodfem version,

stored independently of the partition (each dof by field, component and
position s; DG dofs also by their cell's midpoint), so a checkpoint written
by ``mpirun -n 2`` restarts on one process (to round-off: the sums of the
assembly run in another order) and the reverse.  There is no random state.

``rodfem run --resume DIR`` (or ``rodfem run SCENE --resume DIR``) rebuilds the
scene with the stored parameters, loads the checkpoint and continues: the
rows of history.csv after the checkpoint (and a partly written last row) are
dropped, the following rows appended, so history.csv equals that of the
uninterrupted run; so do the frames (the .pvd entries after the checkpoint
dropped, the later frames written again under the same names) and the
pictures (the frames before the checkpoint read back from their files).
Only ``t_end`` (to run further) may be changed.
Everything is checked before DIR is touched (a refused resume leaves its
summary.json and history.csv as they were): the checkpoint must fit the
scene's mesh, and be of the run in DIR (the scene and parameters of its
summary.json, the t and H of its history row at the checkpoint's step), not
one copied in from another run.

Newton itself keeps state across steps when it reuses its Jacobian (the
chord Newton of the 3D rod scenes, ``snes_lag_jacobian`` persisting): a run
that writes checkpoints starts a fresh solver after each checkpoint, as the
resumed run does, so both compute the same iterates (such a run differs
from one without checkpoints at Newton's tolerance, not beyond).

Under MPI the run keeps its solver: the parallel interface Schur complement
(rodfem/la/schur.py) is a fixed sequence of local factorizations and
allreduces, the same from run to run (measured: identical histories of
repeated `mpirun -n 2` runs), so a checkpointed run and its resumption
compute the same numbers, and summary.json names the solver that ran.
"""
import csv
import io
import json
import os
import xml.etree.ElementTree as ET
from types import SimpleNamespace

import numpy as np

from rodfem.errors import InputError, ParameterError, agreed
from rodfem.fem import compat
from rodfem.la.lu_chain import LU_CHAIN, lu_name

FORMAT = 1
NAME = "checkpoint.npz"
CHANGEABLE = ("t_end", "checkpoint_every")


# -- partition-independent state --------------------------------------------------------------

def _bodies(problem):
    return problem.body_items()


def _field_keys(body, name):
    """(W-local dofs [nodes, bs], integer keys [nodes, 2], number of owned nodes) of a field:
    key = (cell midpoint for DG fields else 0, s), both in units of 1e-9 L (exact integers)."""
    S = body.space
    Vi, dofs = S.collapse(name)
    bs = Vi.dofmap.index_map_bs
    dofs = np.asarray(dofs).reshape(-1, bs)
    xs = Vi.tabulate_dof_coordinates()[:, 0]
    mid = np.zeros(len(xs))
    if S.field(name).family == "DG":
        m = body.mesh
        tdim = m.topology.dim
        ncells = m.topology.index_map(tdim).size_local + m.topology.index_map(tdim).num_ghosts
        x = m.geometry.x[:, 0]
        xdofs = compat.geometry_dofmap(m)
        for c in range(ncells):
            nodes = Vi.dofmap.cell_dofs(c)
            mid[nodes] = x[xdofs[c]].mean()
    unit = body.length * 1e-9
    keys = np.column_stack([np.rint(mid / unit), np.rint(xs / unit)]).astype(np.int64)
    return dofs, keys, Vi.dofmap.index_map.size_local


def _rigid_dofs(body, name):
    return body.space.field_dofs(name)


def _pack(problem, arrays, comm):
    """{body/field: (keys, values)} of the owned dofs of `arrays` (body name -> W-local array),
    gathered on rank 0 (None elsewhere)."""
    out = {}
    for bname, body in _bodies(problem):
        arr = arrays[bname]
        for f in body.space.fields:
            if body.rigid:
                dofs = _rigid_dofs(body, f.name)
                keys = np.zeros((1 if len(dofs) else 0, 2), np.int64)
                vals = arr[dofs].reshape(1, -1) if len(dofs) else np.zeros((0, f.size))
            else:
                dofs, keys, nloc = _field_keys(body, f.name)
                keys, vals = keys[:nloc], arr[dofs[:nloc]]
            parts = comm.gather((keys, vals), root=0)
            if comm.rank == 0:
                k = np.concatenate([p[0] for p in parts])
                v = np.concatenate([p[1] for p in parts])
                order = np.lexsort((k[:, 1], k[:, 0]))
                out[f"{bname}/{f.name}"] = (k[order], v[order])
    return out if comm.rank == 0 else None


def _unpack(problem, data, arrays):
    """Fill `arrays` (body name -> W-local array, ghosts included) from the saved fields.

    Returns None, or what does not fit (a field missing, or saved at other nodes: another mesh);
    every rank goes through every field all the same (collective: `restore` agrees on the verdict)."""
    misfit = None
    for bname, body in _bodies(problem):
        arr = arrays[bname]
        for f in body.space.fields:
            what = f"field {f.name} of body {bname or 'the scene'}"
            if f"{bname}/{f.name}" not in data:
                misfit = misfit or f"the checkpoint has no {what} (another scene?)"
                continue
            keys, vals = data[f"{bname}/{f.name}"]
            if body.rigid:
                dofs = _rigid_dofs(body, f.name)
                if len(dofs) and vals.size == len(dofs):
                    arr[dofs] = vals.reshape(-1)
                elif len(dofs):
                    misfit = misfit or f"the checkpoint does not fit {what} (another model?)"
                continue
            dofs, mykeys, _ = _field_keys(body, f.name)
            index = {(int(a), int(b)): i for i, (a, b) in enumerate(keys)}
            rows = [index.get((int(a), int(b))) for a, b in mykeys]
            if None in rows or (len(rows) and vals.shape[1:] != arr[dofs].shape[1:]):
                misfit = misfit or f"the checkpoint does not fit {what} (another mesh?)"
                continue
            arr[dofs] = vals[np.array(rows, dtype=int)] if len(rows) else arr[dofs]
    return misfit


class Layout:
    """The time loop's state vector of a system (its block vector X0: bodies, then multipliers)
    as per-body W-local arrays and the multipliers, and back."""

    def __init__(self, problem):
        self.problem = problem.build()
        if getattr(problem, "distributed", False):   # (each rank would save or restore its own bodies only)
            raise InputError(f"checkpoints of a system whose bodies are placed whole on ranks (distribute=True, "
                             f"{problem.comm.size} ranks) are not written or read yet: run it without "
                             "checkpoint_every and --resume, or serially")
        self.layout = problem.layout

    def current(self):
        return self.problem.X0.getArray(readonly=True)

    def split(self, vec):
        """(body arrays, multipliers owned here) of a state vector `vec` in the loop's layout."""
        out, off = {}, self.layout.offsets
        for i, (bname, body) in enumerate(_bodies(self.problem)):
            full = np.zeros_like(body.x0.x.array)
            full[: off[i + 1] - off[i]] = vec[off[i]:off[i + 1]]
            out[bname] = full
        return out, np.asarray(vec[off[-2]:off[-1]])

    def join(self, arrays, lam):
        """A state vector in the loop's layout."""
        off = self.layout.offsets
        vec = np.zeros(off[-1])
        for i, (bname, body) in enumerate(_bodies(self.problem)):
            vec[off[i]:off[i + 1]] = arrays[bname][: off[i + 1] - off[i]]
        if len(lam):
            vec[off[-2]:off[-1]] = lam
        return vec


def _gather_lam(comm, lam):
    parts = comm.gather(np.asarray(lam), root=0)
    return np.concatenate(parts) if comm.rank == 0 else None


# -- writing -------------------------------------------------------------------------------------

class Saver:
    """`after_step` of the time loop: the checkpoint after every `every`-th step (only there: a
    resumed run restarts Newton where the uninterrupted one did)."""

    def __init__(self, outdir, scene_name, params, problem, every, n_steps):
        self.outdir, self.out = outdir, outdir.path
        self.scene, self.params, self.problem = scene_name, params, problem
        self.every, self.n_steps = int(every), n_steps
        self.layout = Layout(problem)
        self.comm = problem.comm
        self.last = None

    def __call__(self, n, previous, H, supplied, dissipated=0.0, stepping=None):
        """After step n; `stepping`: the step control's state and t (an adaptive run calls this after every
        second step: the checkpoint is written at the first call past each multiple of `every`)."""
        last, self.last = (n - 1 if self.last is None else self.last), n
        if n // self.every == last // self.every:
            return
        t = stepping["t"] if stepping else n * self.problem.dt
        save(self.outdir, self.problem, self.layout, n, previous, H, supplied,
             {"scene": self.scene, "parameters": self.params, "checkpoint_every": self.every},
             dissipated=dissipated, stepping=stepping)
        self.problem.newton.restart()
        if n != self.n_steps and not (stepping and t >= self.params["t_end"]):   # how far it got, if killed now
            from rodfem.io.output import write_json
            status = {"scene": self.scene, "status": "running", "steps": n, "t": t,
                      "n_steps": self.n_steps, "checkpoint": {"step": n, "file": NAME},
                      "resume": f"rodfem run --resume {self.out}", "parameters": self.params,
                      "mpi_ranks": self.comm.size, "pid": os.getpid()}
            self.outdir.do("write summary.json", write_json, self.outdir.file("summary.json"), status)


def save(out, problem, layout, n, previous, H, supplied, meta, dissipated=0.0, stepping=None):
    """Write the checkpoint of step n into `out` (an OutDir or a directory path; collective).  `stepping`:
    the step control's state (rodfem/analysis/stepping.py) with the time t of step n (else t = n dt)."""
    from rodfem._version import __version__
    comm = problem.comm
    dt = problem.dt
    stepping = dict(stepping or {})
    t = stepping.pop("t", n * dt)
    arrays, lam = layout.split(layout.current())
    data = {"x": _pack(problem, arrays, comm), "x_lam": _gather_lam(comm, lam)}
    if previous is not None:
        parrays, plam = layout.split(previous)
        data["previous"] = _pack(problem, parrays, comm)
        data["previous_lam"] = _gather_lam(comm, plam)
    info = dict(meta, format=FORMAT, rodfem_version=__version__, step=n, t=t, dt=dt, stepping=stepping, H=H,
                supplied=supplied,
                dissipated=dissipated, control_states=_control_states(problem),
                has_previous=previous is not None, mpi_ranks=comm.size,
                linear_solver=lu_name(problem.newton.settings))
    if hasattr(out, "do"):
        out.do("write the checkpoint", _write, out.path, info, data)
    elif comm.rank == 0:
        _write(out, info, data)


def _control_states(problem):
    """The states of the stateful control laws (forms/components.py: PID's integral), by name."""
    return {c.name: list(c.law.state) for c in getattr(problem, "components", ()) if getattr(c, "stateful", False)}


def _write(out, info, data):
    flat = {"meta": np.frombuffer(json.dumps(info, default=float).encode(), dtype=np.uint8)}
    for which in ("x", "previous"):
        if which in data:
            for key, (k, v) in data[which].items():
                flat[f"{which}:{key}:keys"], flat[f"{which}:{key}:values"] = k, v
            flat[f"{which}:lam"] = data[which + "_lam"]
    path = os.path.join(out, NAME)
    tmp = path + f".tmp{os.getpid()}"
    with open(tmp, "wb") as f:
        np.savez(f, **flat)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


# -- reading ---------------------------------------------------------------------------------------

def read(directory):
    """(meta, arrays) of DIR/checkpoint.npz; ParameterError for a missing or unreadable one."""
    path = os.path.join(directory, NAME)
    if not os.path.isfile(path):
        raise ParameterError(f"{directory} has no checkpoint ({NAME}): start the run with "
                             "--set checkpoint_every=N to write one")
    try:
        with np.load(path, allow_pickle=False) as z:
            arrays = {k: z[k] for k in z.files}
        meta = json.loads(arrays.pop("meta").tobytes().decode())
    except Exception as e:  # noqa: BLE001  (a damaged file: one line, whatever numpy raised)
        raise ParameterError(f"the checkpoint {path} is unreadable ({type(e).__name__}): "
                             "resume from another directory or start again") from None
    return meta, arrays


def check(meta, directory, scene_name=None):
    """Refuse a checkpoint of another format, rodfem version or scene (one line)."""
    from rodfem._version import __version__
    if meta.get("format") != FORMAT or meta.get("rodfem_version") != __version__:
        raise ParameterError(f"the checkpoint in {directory} was written by rodfem "
                             f"{meta.get('rodfem_version', '?')} (format {meta.get('format', '?')}); this is "
                             f"rodfem {__version__}: it cannot continue it, start the run again")
    if scene_name is not None and meta.get("scene") != scene_name:
        raise ParameterError(f"the checkpoint in {directory} is of scene {meta.get('scene')}, not {scene_name}")


def _fields(arrays, which):
    out = {}
    for k in arrays:
        parts = k.split(":")
        if parts[0] == which and len(parts) == 3 and parts[2] == "keys":
            out[parts[1]] = (arrays[k], arrays[f"{which}:{parts[1]}:values"])
    return out


def restore(problem, meta, arrays):
    """Put the checkpoint's x_n into the problem; returns the loop's start (step, H, supplied, previous)."""
    layout = Layout(problem)
    comm = problem.comm

    def vector(which):
        bodies, lam = layout.split(layout.current())
        misfit = _unpack(problem, _fields(arrays, which), bodies)
        lam_all = arrays.get(f"{which}:lam", np.zeros(0))
        if len(lam_all) < layout.layout.sizes[-1]:
            misfit = misfit or "the checkpoint does not fit the joints' multipliers (another mechanism?)"
        with agreed(comm):
            if misfit:
                raise ParameterError(f"{misfit}: it cannot be resumed")
        lam = np.asarray(lam_all[: layout.layout.sizes[-1]], dtype=float)   # all on rank 0
        return layout.join(bodies, lam)

    x = vector("x")
    previous = vector("previous") if meta.get("has_previous") else None
    X = problem.layout.create_vector()
    X.getArray()[:] = x
    problem.set_state(X)
    solver = meta.get("linear_solver")    # a switch after a zero pivot (same number of ranks only)
    if solver in LU_CHAIN and meta.get("mpi_ranks") == comm.size and solver != lu_name(problem.newton.settings):
        problem.newton.use_lu(solver)
        problem.newton.restart()
    comm.Barrier()
    saved = meta.get("control_states", {})
    for c in getattr(problem, "components", ()):
        if getattr(c, "stateful", False):
            if c.name not in saved or len(saved[c.name]) != len(c.law.state):
                raise ParameterError(f"the checkpoint has no state of the control law {c.name}: it cannot be resumed")
            c.law.state = [float(x) for x in saved[c.name]]
    problem.t = float(meta["t"])
    return SimpleNamespace(step=int(meta["step"]), H=float(meta["H"]), supplied=float(meta["supplied"]),
                           dissipated=float(meta.get("dissipated", 0.0)), previous=previous, t=float(meta["t"]),
                           stepping=meta.get("stepping") or None)


def resume_parameters(meta, directory, overrides):
    """The checkpoint's parameters with the allowed changes (t_end, checkpoint_every)."""
    bad = sorted(set(overrides or {}) - set(CHANGEABLE))
    if bad:
        raise ParameterError(f"--resume continues with the checkpoint's parameters: only {', '.join(CHANGEABLE)} "
                             f"may be set (got {', '.join(bad)})")
    return dict(meta["parameters"])


# -- the output directory of a resumed run ------------------------------------------------------------

def history_lines(directory, meta, comm):
    """The lines (header and steps 0..step) of DIR/history.csv a resumed run keeps, on rank 0 ([] elsewhere),
    after checking that the checkpoint is of the run in DIR (collective; nothing is written):
    its summary.json's scene and parameters, and its history row at the checkpoint's step."""
    lines, error = [], None
    if comm.rank == 0:
        try:
            _same_run(directory, meta)
            lines = _kept_lines(directory, meta)
        except ParameterError as e:
            error = str(e)
    error = comm.bcast(error, root=0)
    if error:
        raise ParameterError(error)
    return lines


def _same_run(directory, meta):
    """Refuse a checkpoint whose scene or parameters are not those of DIR/summary.json (a copy of another run's)."""
    try:
        with open(os.path.join(directory, "summary.json")) as f:
            summary = json.load(f)
    except (OSError, ValueError):
        return   # no summary (deleted, or killed while writing it): history.csv decides
    copied = "(copied from another run?): resume in the directory it was written in"
    if summary.get("scene") != meta.get("scene"):
        raise ParameterError(f"the checkpoint in {directory} is of scene {meta.get('scene')}, but {directory}/"
                             f"summary.json is of scene {summary.get('scene')} {copied}")
    mine, theirs = meta.get("parameters", {}), summary.get("parameters", {})
    for name in sorted(set(mine) | set(theirs)):
        if name not in CHANGEABLE and mine.get(name) != theirs.get(name):
            raise ParameterError(f"the checkpoint in {directory} has {name} = {mine.get(name)!r}, but {directory}/"
                                 f"summary.json has {name} = {theirs.get(name)!r} {copied}")


def _kept_lines(directory, meta):
    step = int(meta["step"])
    path = os.path.join(directory, "history.csv")
    if not os.path.isfile(path):
        raise ParameterError(f"{directory} has a checkpoint but no history.csv: cannot continue it")
    with open(path, newline="") as f:
        lines = f.read().splitlines(keepends=True)[: step + 2]
    if len(lines) < step + 2 or not lines[-1].endswith("\n"):
        raise ParameterError(f"{path} has fewer rows than the checkpoint's step {step}: cannot continue it")
    row = next(csv.DictReader(io.StringIO(lines[0] + lines[-1])))
    try:
        t, H = float(row["t"]), float(row["H"])
    except (KeyError, TypeError, ValueError):
        t = H = float("nan")
    if not (_close(t, meta["t"]) and _close(H, meta["H"])):
        raise ParameterError(f"the checkpoint in {directory} (step {step}, t = {meta['t']:.6g}, H = {meta['H']:.6g}) "
                             f"is not of the run in {path} (its step {step}: t = {t:.6g}, H = {H:.6g}) "
                             "(copied from another run?): resume in the directory it was written in")
    return lines


def _close(a, b):
    return abs(a - b) <= 1e-12 * max(abs(a), abs(b), 1e-300)


def truncate_history(outdir, lines):
    """history.csv in the OutDir cut to `lines` (from `history_lines`; collective); returns its rows
    (dicts) on rank 0, [] elsewhere."""
    outdir.do("cut history.csv at the checkpoint", _rewrite, outdir.file("history.csv"), "".join(lines))
    rows = list(csv.DictReader(io.StringIO("".join(lines))))
    return [{k: (int(float(v)) if k == "newton_its" else float(v)) for k, v in r.items()} for r in rows]


def _rewrite(path, text):
    tmp = path + f".tmp{os.getpid()}"
    with open(tmp, "w", newline="") as f:
        f.write(text)
    os.replace(tmp, path)


def writer_for(outdir, problem, n_steps, frames, step, t, section=0.0, times=None):
    """A RunWriter that appends to history.csv and keeps the frames up to the checkpoint, their
    pictures read back from their centreline files (shapes.png and the animation show every frame,
    also for a run resumed from a checkpoint at t_end: killed before its summary and pictures)."""
    from rodfem.io.animation import marks_sketch
    from rodfem.io.output import RunWriter
    from rodfem.io.vtk import piece, read_vtp

    class ResumedWriter(RunWriter):
        def __init__(self):
            super().__init__(outdir, problem, n_steps, frames, section, times)
            self.count = step + 1
            self.facts = None      # (view.py's facts read back at the end: the frames before the checkpoint with them)
            self.hold(step, t)     # a frame between the checkpoint's level and the next one (collective)
            if problem.comm.rank != 0:
                return
            path = outdir.file("history.csv")
            with open(path, newline="") as f:
                header = next(csv.reader(f))
            self._file = open(path, "a", newline="")
            self._csv = csv.DictWriter(self._file, fieldnames=header)
            fields = outdir.file("fields.json")
            if os.path.isfile(fields):
                with open(fields) as f:
                    self.width = json.load(f)["section"]["width (along d2)"]
            pvd = outdir.file("centreline.pvd")
            if os.path.isfile(pvd) and self.width is not None:
                kept = {}
                for ds in ET.parse(pvd).getroot().iter("DataSet"):
                    tf = float(ds.get("timestep"))
                    if tf <= t * (1 + 1e-12) + 1e-300:
                        name = ds.get("file")
                        kept.setdefault(tf, []).append((name, name.replace("centreline/", "surface/", 1)))
                self.frames = sorted(kept.items())
                marks = outdir.file("joints.pvd")
                if self.marks and os.path.isfile(marks):
                    self.mark_frames = [(float(ds.get("timestep")), ds.get("file"))
                                        for ds in ET.parse(marks).getroot().iter("DataSet")
                                        if float(ds.get("timestep")) <= t * (1 + 1e-12) + 1e-300]
                joints = dict(self.mark_frames)
                for tf, names in self.frames:
                    try:
                        polys = {}   # body number -> its centreline (a piece of its kind's file, `groups`)
                        for files, bodies in zip(names, self.members):
                            poly = read_vtp(outdir.file(files[0]))
                            for j, b in enumerate(bodies):
                                polys[b] = piece(poly, j) if self.groups else poly
                        sketches = [kept_sketch(polys[b], view, self.width) for b, view in enumerate(self.views)]
                        if self.marks:
                            sketches.append(marks_sketch(read_vtp(outdir.file(joints[tf])).points))
                        self.snapshots.append((tf, sketches))
                    except (OSError, ValueError, KeyError, ET.ParseError):
                        pass   # a frame file gone or damaged: the pictures go without it
    return ResumedWriter()


def kept_sketch(poly, view, width):
    """The picture's Sketch of a body (its BodyView) at a frame written before the restart, from its
    centreline `poly` (read back): its points and section frame d1, d2 (, d3) are those of the state (a
    planar model's d3 is e_z), the box that of the model: the Sketch of the uninterrupted run."""
    from rodfem.io.animation import sketch
    directors = None
    if view.has_frame:
        d = [poly.point_data[f"d{i}"].values for i in (1, 2, 3) if f"d{i}" in poly.point_data]
        if len(d) == 2:
            d.append(np.tile([0.0, 0.0, 1.0], (len(poly.points), 1)))
        directors = np.stack(d, axis=-1)
    box = tuple(view.model.box()) if view.body.rigid and hasattr(view.model, "box") else None
    link = getattr(view.model, "link", None) if view.body.rigid else None
    return sketch(SimpleNamespace(name=view.name, kind=view.kind, position=poly.points, directors=directors, box=box,
                                  link=link), width)
