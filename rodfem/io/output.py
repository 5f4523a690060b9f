"""What a run leaves on disk (rank 0 writes; every file is flushed as it goes):

* history.csv    one row per time level: t, H, supplied, (dissipated,) newton_its, balance_error, observables
                 (`dissipated`, the cumulative sum h d_n, only for a dissipating model)
* summary.json   parameters, versions, elements, dofs, timing, balance errors, status
                 ("running" from the start, replaced at the end by "completed",
                 "newton-failure", "interrupted" or "error")
* centreline.pvd, centreline/   each body as one VTK polyline (.vtp, one per frame and body:
                 the nodes in order, nodal fields, section frame, strains and stress resultants;
                 a system of more than LEGEND = 12 bodies: one file per frame and model kind,
                 e.g. frame_00007_RigidBody.vtp, with a point array `body`, the index into its
                 field data `bodies`: 1000 links write 2 files a frame, not 2000)
* surface.pvd, surface/         each body's surface: its section swept along the centreline and
                 turned with the directors (rods), a tube (strings), a box (rigid bodies), with the
                 strains and stress resultants cell by cell (rodfem/io/frames.py)
* joints.pvd, joints/   the joints, components and supports as points (and lines between a
                 joint's two points when apart), one block (rodfem/io/glyphs.py); none without any
* fields.json    what every array of those files is (components, description), per body
* view.py        a ParaView script that opens the run (`paraview --script=view.py`; rodfem/io/paraview.py)
* shapes.png, energy.png, animation.gif   pictures: shapes over time, energy history, the motion
                 (one GIF frame per .pvd frame; rodfem/io/animation.py)

A rod's surface shows the scene's physical cross-section (the model's ``section``, a
rodfem.io.sections.Section: round with a marker fin along d2, or rectangular) unless the `section`
parameter gives a drawing width.  The frames are at the `frames` evenly spaced times t_j = j t_end / (frames - 1) (t = 0 and t_end
included; `frame_plan`): a time on a time level is that level's state; a time between two levels
t_n < t_j < t_{n+1} gets the state interpolated linearly between them (`snapshot.blend`: the
midpoint rule moves q on a straight line over a step); adaptive steps land on the t_j.  Every
frame file carries its time (field data TimeValue, the .pvd's timestep), written as the shortest
decimal of 12 significant digits (`clean_time`: 2.4, not n dt = 2.4000000000000004), and the SI
units of its arrays (field data `units`, "name [unit]"; also in fields.json).  The
section's width is the scene's `section` (0: a 25th of the longest body).  The frames are
computed from the state gathered on rank 0 (rodfem/io/snapshot.py): the same on any number of ranks.
A long body spread over ranks (one flexible body, at least ROWS nodes per rank) has its centreline
file written by every rank: rank 0 sends each rank a block of the gathered nodes (`_rows`), creates
the file (its text, byte counts and polyline), every rank writes its rows at their places
(vtk.write_vtp_rows: the bytes one writer writes) and rank 0 renames it and writes the rest.

A run owns its directory (`OutDir`): a lock (``fcntl.flock`` on .rodfem.lock)
refuses a second run into it while the first is running, and a new run first
removes the files a previous run wrote there (the names above; other files are
left alone), so a directory never mixes two runs.  summary.json, the frames,
the .pvd files and the pictures are written to a temporary file and renamed
(`replace_atomically`): a killed run leaves no half-written file.  A file that
cannot be written ends the run with an InputError naming --out, on every rank.
"""
import csv
import errno
import fcntl
import glob
import json
import os
from contextlib import contextmanager, suppress

import numpy as np

from rodfem.errors import InputError, agreed
from rodfem.fem import compat
from rodfem.io.animation import LEGEND, box_size, marks_sketch, plot_shapes, sketch, write_animation
from rodfem.io.frames import centreline, describe, drawn_section, surface
from rodfem.io.glyphs import glyphs, marks_of
from rodfem.io.paraview import RunFacts, run_facts, write_script
from rodfem.io.snapshot import BodyState, blend, body_views, rows_of
from rodfem.io.vtk import Array, merge, write_pvd, write_vtp, write_vtp_rows

OWN_FILES = ("history.csv", "summary.json", "centreline.pvd", "surface.pvd", "fields.json", "shapes.png",
             "energy.png", "animation.gif", "centreline/frame_*.vtp", "surface/frame_*.vtp",
             "centreline/frame_*.vtu", ".*.tmp", "centreline/.*.tmp", "surface/.*.tmp",
             "joints.pvd", "joints/frame_*.vtp", "joints/.*.tmp", "view.py",
             "checkpoint.npz", "checkpoint.npz.tmp*",
             # the analyses' files (rodfem static / linearize / modes): a later run of any command clears them
             "loadsteps.csv", "modes.csv", "modes.json", "modes.png", "mode_shapes.npz", "linear.mat", "linear.json",
             "states.csv", *(f"{k}.npz" for k in ("E", "J", "R", "Q", "B", "C", "A", "Hess", "E_modes", "A_modes")))
LOCK_FILE = ".rodfem.lock"
# nodes per rank from which every rank writes its rows of a spread body's centreline file (below that, rank 0
# writes it whole: a frame of 10^5 planar elements takes rank 0 ~45 ms, its centreline half of it)
ROWS = 5000


def temporary(path):
    """The hidden temporary file beside `path` that becomes `path` when whole (OWN_FILES' ".*.tmp")."""
    return os.path.join(os.path.dirname(path), "." + os.path.basename(path) + ".tmp")


def replace_atomically(path, write):
    """Create `path` by write(temporary path) in the same directory, then os.replace (never half-written)."""
    tmp = temporary(path)
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

    def __init__(self, path, comm, subdir="centreline"):
        self.path, self.comm, self.subdir = str(path), comm, subdir   # subdir: made with the directory
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

    def do_each(self, tasks, every=False):
        """Collective: the k-th of tasks [(what, fn, *args)] runs on rank k mod size (a second rank draws what
        rank 0 would draw after its own work; `every`: each task on every rank); an OSError on any rank ends
        the run on every rank (InputError)."""
        with agreed(self.comm):
            for k, (what, fn, *args) in enumerate(tasks):
                if every or k % self.comm.size == self.comm.rank:
                    try:
                        fn(*args)
                    except OSError as e:
                        raise InputError(f"--out {self.path!r}: cannot {what} ({e.strerror or e})") from None

    @contextmanager
    def claimed(self, summary, clear=True):
        """Lock the directory, clear a previous run's files (not when `clear` is false: a run resumed
        from its checkpoint, rodfem/io/checkpoint.py), write summary.json (status "running");
        release the lock at the end of the block."""
        self.do("create the directory", os.makedirs, os.path.join(self.path, self.subdir or ""), 0o777, True,
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


PACKED = ("s", "position", "directors")


def _packing(state):
    """What travels of a BodyState of some of a body's nodes (`RunWriter._rows`): its plain facts, and
    the names ("s", "position", "directors", "field:NAME", "cells:NAME") and shapes of its arrays."""
    arrays = [(n, getattr(state, n).shape) for n in PACKED if getattr(state, n) is not None]
    arrays += [(f"field:{n}", v.shape) for n, v in state.fields.items()]
    arrays += [(f"cells:{n}", v.shape) for n, v in state.cells.items()]
    return (state.name, state.kind, state.dim, state.degree), arrays


def _array_of(state, name):
    kind, _, key = name.partition(":")
    return getattr(state, name) if not key else (state.fields if kind == "field" else state.cells)[key]


def _packed(state, buffer):
    """The arrays of `state` one after the other in `buffer` (as `_packing` lists them)."""
    at = 0
    for name, shape in _packing(state)[1]:
        size = int(np.prod(shape))
        buffer[at:at + size].reshape(shape)[...] = _array_of(state, name)
        at += size
    return buffer


def _unpacked(buffer, packing):
    """The BodyState of `_packing`'s facts and arrays (views of `buffer`)."""
    (name, kind, dim, degree), arrays = packing
    values, at = {}, 0
    for key, shape in arrays:
        size = int(np.prod(shape))
        values[key] = buffer[at:at + size].reshape(shape)
        at += size
    return BodyState(name, kind, dim, values["s"], values["position"],
                     {k[6:]: v for k, v in values.items() if k.startswith("field:")}, values.get("directors"),
                     {k[6:]: v for k, v in values.items() if k.startswith("cells:")}, degree)


def frame_plan(n_steps, frames):
    """The frames of a run of n_steps fixed steps: [(n, theta)], frame j at t_n + theta h, evenly
    spaced with t = 0 and t_end (j n_steps / (frames - 1) levels, in exact integer arithmetic: theta
    = 0 on a level); every level if there are fewer; t_end alone for frames = 1."""
    if frames <= 1:
        return [(n_steps, 0.0)]
    k = min(frames, n_steps + 1) - 1
    return [(j * n_steps // k, (j * n_steps % k) / k) for j in range(k + 1)]


def frame_levels(n_steps, frames):
    """The time levels whose states are frames as they are (theta = 0 in `frame_plan`)."""
    return {n for n, theta in frame_plan(n_steps, frames) if theta == 0}


def clean_time(t):
    """t to 12 significant digits (the step sum's round-off gone: 2.4000000000000004 -> 2.4)."""
    return float(f"{t:.12g}")


def units_list(poly, units):
    """The field data `units` of a frame: "name [unit]" for its points and every array."""
    names = ["points", *poly.point_data, *(k for k in poly.cell_data if k not in poly.point_data)]
    return [f"{name} [{units.get(name, '')}]" for name in names] + ["TimeValue [s]"]


def plotting():
    """matplotlib.pyplot with the Agg backend; InputError if it cannot be loaded (e.g. no memory left).
    (Its warning about an unwritable config directory, e.g. XDG_CACHE_HOME on a file, stays unsaid:
    a cache rodfem needs is reported by rodfem, in one line.)"""
    import logging
    logging.getLogger("matplotlib").setLevel(logging.ERROR)
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except (ImportError, MemoryError) as e:
        raise InputError(f"cannot load matplotlib for the pictures ({type(e).__name__}: {e})") from None
    return plt


class RunWriter:
    """Writes a run into a claimed OutDir: history rows, frames (centreline, surface), and at the end
    summary and pictures.  `section`: the width of the drawn cross-section (0: automatic)."""

    def __init__(self, out, problem, n_steps, frames=100, section=0.0, times=None):
        plotting()   # before the run, not after its last step
        self.out, self.problem = out, problem
        # adaptive steps (n_steps None): the frames at the `times` the steps land on
        plan = frame_plan(n_steps, frames) if times is None else []
        self.levels = {n for n, theta in plan if theta == 0}
        self.between = {n: theta for n, theta in plan if theta > 0}   # frames between level n and n + 1
        self._held = None                                               # (n, t_n, states at n)
        self.times = None if times is None else set(times)
        self.views, self._gather = body_views(problem)   # (every body's, also those built on other ranks)
        self.marks = marks_of(problem)          # joints, components, supports (joints.pvd)
        self.mark_frames = []                   # [(t, file)]
        self.section, self.width = float(section), None
        self.count, self.frames, self.snapshots = 0, [], []
        self.groups = model_groups(self.views) if len(self.views) > LEGEND else None
        self.dim = max(v.dim for v in self.views)
        self._file = self._csv = None
        self.facts = RunFacts()   # view.py's ranges and bounds, frame by frame (None: read back at the end)

    # -- per step (collective) ----------------------------------------------------
    def record(self, row, problem):
        self.out.do("write history.csv", self._append, row)
        n = self.count
        if n in self.levels or (self.times is not None and row["t"] in self.times):
            self.frame(row["t"])
        if self._held is not None and self._held[0] == n - 1:     # a frame between level n - 1 and n
            _, t0, before = self._held
            theta, self._held = self.between[n - 1], None
            after = self._gather()      # collective
            self.frame(t0 + theta * (row["t"] - t0), [blend(a, b, theta) for a, b in zip(before, after)])
        self.hold(n, row["t"])
        self.count += 1

    def hold(self, n, t):
        """Keep the state of level n if a frame lies between it and the next level (collective)."""
        if n in self.between:
            self._held = (n, t, self._gather())

    def _append(self, row):
        """One whole row of history.csv: a write that fails (a full disk) leaves the file at the end of
        the last whole row, never half a row."""
        if self._csv is None:
            self._file = open(self.out.file("history.csv"), "w", newline="")
            self._csv = csv.DictWriter(self._file, fieldnames=list(row))
            self._csv.writeheader()
            self._file.flush()
            self._whole = self._file.tell()
        try:
            # float(v): numpy 2 writes a np.float64's repr as "np.float64(...)"
            self._csv.writerow({k: repr(float(v)) if isinstance(v, float) else v for k, v in row.items()})
            self._file.flush()
        except OSError:
            file, self._file, self._csv = self._file, None, None
            with suppress(OSError):
                file.close()   # (writes what it can of the row left in its buffer: cut off next)
            with open(self.out.file("history.csv"), "r+") as f:
                f.truncate(self._whole)
            raise
        self._whole = self._file.tell()

    def frame(self, t, states=None):
        """Write the frame of time t: the current state, or `states` (BodyStates on rank 0).  Collective."""
        if states is None:
            states = self._gather()
        t = clean_time(t)
        rows = self._rows(states)
        if rows is None:
            self.out.do("write a frame", self._write_frame, t, states)
            return
        # a long body spread over ranks: every rank makes and writes its rows of the centreline file (its
        # bytes are those of one writer), then rank 0 puts it in place and writes the rest of the frame
        part, lead, first, total, k = rows
        view = self.views[0]
        poly = self._with_fields(centreline(part, view.labels, view.velocity, lead, total), t, [0])
        tmp = temporary(self.out.file(self.file_name("centreline", k, self.parts[0])))
        try:
            self.out.do("write a frame", write_vtp_rows, tmp, poly, first, total, True)
            self.out.do_each([("write a frame", write_vtp_rows, tmp, poly, first, total, False)], every=True)
            self.out.do("write a frame", self._write_frame, t, states, tmp)
        finally:
            if self.out.root:
                with suppress(FileNotFoundError):
                    os.unlink(tmp)

    def _rows(self, states):
        """This rank's rows of the frame's centreline file, if one flexible body is spread over the ranks and
        has at least ROWS nodes per rank: (its nodes' BodyState, lead, first node, the body's nodes, frame
        number); None: rank 0 writes the whole frame.  Collective."""
        comm = self.out.comm
        if comm.size == 1 or len(self.views) != 1 or self.views[0].kind not in ("rod", "line"):
            return None
        parts = [None] * comm.size
        if comm.rank == 0 and len(states[0].position) >= ROWS * comm.size:
            total = len(states[0].position)
            cuts = np.linspace(0, total, comm.size + 1).astype(int)
            parts = [(*rows_of(states[0], a, b), a, total, len(self.frames)) for a, b in zip(cuts[:-1], cuts[1:])]
        # the parts' arrays travel as one float buffer each (MPI Send; pickled, a half of 10^5 planar
        # elements took rank 0 20 ms a frame), their shapes pickled
        heads = [None if p is None else (_packing(p[0]),) + p[1:] for p in parts]
        head = comm.scatter(heads, root=0)
        if head is None:
            return None
        if comm.rank == 0:
            for r in range(1, comm.size):
                comm.Send(_packed(parts[r][0], self._buffer(heads[r][0])), dest=r)
            return parts[0]
        comm.Recv(self._buffer(head[0]), source=0)
        return (_unpacked(self._buffer(head[0]), head[0]),) + head[1:]

    def _buffer(self, packing):
        """A float buffer for a packed part, kept from frame to frame (fresh memory is slow to touch)."""
        size = sum(int(np.prod(shape)) for _, shape in packing[1])
        if getattr(self, "_rows_buffer", None) is None or len(self._rows_buffer) < size:
            self._rows_buffer = np.empty(size)
        return self._rows_buffer[:size]

    @property
    def parts(self):
        """The names of a frame's files: the body's (one body: ""), or its model kind's (`groups`)."""
        return [name for name, _ in self.groups] if self.groups else [view.name for view in self.views]

    @property
    def members(self):
        """The body numbers in each of `parts`' files."""
        return [b for _, b in self.groups] if self.groups else [[b] for b in range(len(self.views))]

    def file_name(self, kind, k, part):
        """centreline/frame_00007.vtp (one body), centreline/frame_00007_crank.vtp (a system's body) or
        centreline/frame_00007_RigidBody.vtp (all rigid bodies of a system of more than LEGEND bodies)."""
        return f"{kind}/frame_{k:05d}{'_' + part if len(self.parts) > 1 or self.groups else ''}.vtp"

    def _poly(self, i, view, state):
        """The centreline (i = 0) or surface (i = 1) PolyData of one body's state."""
        if i == 0:
            return centreline(state, view.labels, view.velocity)
        return surface(state, view.labels, self.width, box_size, view.rates, view.velocity,
                       drawn_section(view.model, self.width, self.section))

    def _with_fields(self, poly, t, bodies):
        """`poly` with its field data: the time, the arrays' units and (a model kind's file) its bodies."""
        units = dict(self.views[bodies[0]].units, body="1")
        poly.field_data = {"TimeValue": Array(np.array([t])), "units": units_list(poly, units)}
        if self.groups:   # point array body: the index into this list
            poly.field_data["bodies"] = [self.views[b].name for b in bodies]
        return poly

    def _write_frame(self, t, states, written=None):
        """The frame's files (rank 0); `written`: its centreline file, written in rows by every rank (`frame`)."""
        k = len(self.frames)
        if k == 0:
            self._first_frame(states)
        names = []
        for part, bodies in zip(self.parts, self.members):
            files = (self.file_name("centreline", k, part), self.file_name("surface", k, part))
            for i, name in enumerate(files):
                if i == 0 and written is not None:
                    os.replace(written, self.out.file(name))
                    if self.facts is not None:
                        self.facts.centreline(t, states[bodies[0]].position)
                    continue
                polys = [self._poly(i, self.views[b], states[b]) for b in bodies]
                poly = self._with_fields(merge(polys) if self.groups else polys[0], t, bodies)
                if self.facts is not None:
                    (self.facts.surface(poly) if i else
                     self.facts.centreline(t, np.asarray(poly.points, dtype=np.float64).reshape(-1, 3)))
                replace_atomically(self.out.file(name), lambda tmp, p=poly: write_vtp(tmp, p))
            names.append(files)
        self.frames.append((t, names))
        sketches = [sketch(state, self.width) for state in states]
        if self.marks:
            name = f"joints/frame_{k:05d}.vtp"
            poly = glyphs(self.marks, {v.name: st for v, st in zip(self.views, states)},
                          {v.name: v.model for v in self.views})
            poly.field_data.update({"TimeValue": Array(np.array([t])), "units": ["points [m]", "TimeValue [s]"]})
            replace_atomically(self.out.file(name), lambda tmp: write_vtp(tmp, poly))
            self.mark_frames.append((t, name))
            replace_atomically(self.out.file("joints.pvd"),
                               lambda tmp: write_pvd(tmp, [(tf, 0, f, "joints") for tf, f in self.mark_frames]))
            sketches.append(marks_sketch(poly.points))
        self.snapshots.append((t, sketches))
        for i, kind in enumerate(("centreline", "surface")):
            series = [(tf, b, files[b][i], part) for tf, files in self.frames for b, part in enumerate(self.parts)]
            replace_atomically(self.out.file(kind + ".pvd"), lambda tmp, d=series: write_pvd(tmp, d))

    def _first_frame(self, states):
        """The section's width (the parameter, or a 25th of the longest body), surface/, fields.json."""
        lengths = [np.ptp(s.s) for s in states if s.kind in ("rod", "line")]
        boxes = [np.max(s.box) for s in states if s.box is not None]
        self.width = self.section or (max(lengths) / 25 if lengths else max(boxes, default=4.0) / 4)
        os.makedirs(self.out.file("surface"), exist_ok=True)
        if self.marks:
            os.makedirs(self.out.file("joints"), exist_ok=True)
        fields = {"section": {"width (along d2)": self.width, "height (along d3)": 0.5 * self.width,
                              "string diameter": 0.5 * self.width},
                  "time": {"unit": "s", "frames": "field data TimeValue and the .pvd's timestep: the frame's "
                           "time t_j = j t_end / (frames - 1) (12 significant digits); the state of "
                           "that time level, or interpolated linearly between the two levels around it"},
                  "bodies": {view.name or "body": dict(model=type(view.model).__name__,
                                                       **describe(state, view.labels, view.omitted,
                                                                  view.rates, view.velocity, view.units),
                                                       **({"section": drawn_section(view.model, self.width,
                                                                                    self.section).describe()}
                                                          if state.kind == "rod" else {}))
                             for view, state in zip(self.views, states)}}
        write_json(self.out.file("fields.json"), fields)

    # -- at the end (also after a failure; collective) ----------------------------------
    def finish(self, summary, result):
        """Close history.csv, write summary.json (replacing "running"), then the pictures; each is tried
        even if one before failed (after a full disk, the summary may still fit), the first error raised."""
        errors = []
        for what, fn, *args in (("close history.csv", self._close),
                                ("write summary.json", write_json, self.out.file("summary.json"), summary)):
            try:
                self.out.do(what, fn, *args)
            except InputError as e:
                errors.append(e)
        default = "body" if self.groups else "blocks" if len(self.views) > 1 else None
        # (rank 0 writes the frames and gathers their facts)
        framed, facts = self.out.comm.bcast((bool(self.frames), self.facts and self.facts.facts(default,
                                                                                              bool(self.mark_frames))))
        try:   # the pictures of the frames on rank 0 (it holds them), energy.png and view.py beside them on a second rank
            self.out.do_each([("write the pictures", self._pictures),
                              ("write energy.png and view.py", self._energy_and_view, result, framed, facts, default)])
        except InputError as e:
            errors.append(e)
        if errors:
            raise errors[0]

    def _close(self):
        if self._file is not None:
            file, self._file, self._csv = self._file, None, None
            file.close()  # closed even when its last flush fails

    def _pictures(self):
        """shapes.png and animation.gif, from the frames' sketches (rank 0)."""
        if self.snapshots:
            plot_shapes(self.out.file("shapes.png"), self.snapshots, self.dim, self.width)
            write_animation(self.out.file("animation.gif"), self.snapshots, self.dim, self.width)

    def _energy_and_view(self, result, framed, facts, default):
        """energy.png (the history: on every rank) and view.py: ParaView's view of the run, with the colour ranges
        and bounds of all its frames (`facts`, or read back from the frames' files when None)."""
        if result is not None and result.rows:
            plot_energy(self.out.file("energy.png"), result)
        if framed:
            units = {k: u for v in self.views for k, u in v.units.items()}
            facts = facts or run_facts(self.out.path, default)
            replace_atomically(self.out.file("view.py"), lambda tmp: write_script(tmp, facts, units))


def model_groups(views):
    """[(name, [body numbers])]: the bodies by model kind (class and fields: the same arrays in their files), in
    the order met; a name is the class's (RigidBody), numbered from the second kind of one class on (String_2)."""
    keys, groups = {}, []
    for b, view in enumerate(views):
        model = view.model
        key = (type(model).__name__, tuple(f.name for f in model.fields), bool(getattr(model, "massless", False)))
        if key not in keys:
            same = sum(k[0] == key[0] for k in keys)
            keys[key] = len(groups)
            groups.append((key[0] + (f"_{same + 1}" if same else ""), []))
        groups[keys[key]][1].append(b)
    return groups


def summarize(scene_name, params, problem, result, status="completed", failure=None):
    """summary.json content."""
    H = result.column("H") if result.rows else np.array([0.0])
    its = result.column("newton_its")[1:] if len(result.rows) > 1 else np.array([0])
    Hmax = float(np.max(np.abs(H))) or 1.0
    return {
        "scene": scene_name, "status": status, "failure": failure, "parameters": params,
        "dolfinx_version": compat.dolfinx_version, "integrator": problem.integrator,
        "elements": problem.describe_elements(), "n_elements": problem.n_elements, "dofs": problem.dofs,
        "mpi_ranks": problem.comm.size, "linear_solver": problem.newton.linear_solver, "steps": result.steps,
        "wall_time_s": result.wall_time,
        "time_per_step_ms": 1e3 * result.wall_time / max(result.steps, 1),
        "newton_its_mean": float(its.mean()), "newton_its_max": int(its.max()),
        "step_control": {k: result.stepping[k] for k in ("adaptive", "rejected", "split_steps", "substeps",
                                                          "max_substep_balance", "dt_min", "solves", "iterations")
                         if k in result.stepping},
        "max_balance_error": result.max_balance_error,
        "max_balance_error_relative": result.max_balance_error / Hmax,
        "H_initial": float(H[0]), "H_final": float(H[-1]), "max_abs_H": Hmax,
        "ports": [load.name for load in problem.loads], "supports": [f"{s.kind}@{s.end}" for s in problem.supports],
        "joints": [f"{j.name}: {j.a.describe()} - {j.b.describe()}" for j in getattr(problem, "joints", [])],
        "final": {k: v for k, v in (result.rows[-1].items() if result.rows else [])},
    }


def plot_energy(path, result):
    plt = plotting()
    t, H, W = result.column("t"), result.column("H"), result.column("supplied")
    err = np.abs(result.column("balance_error"))[1:]
    dissipates = "dissipated" in result.rows[0]
    fig, ax = plt.subplots(3 if dissipates else 2, 1, figsize=(7, 8 if dissipates else 6), sharex=True)
    ax[0].plot(t, H, label=r"$H$ (Hamiltonian)")
    ax[0].plot(t, W, "--", label=r"supplied work $\sum h\,y\cdot u$")
    if dissipates:   # the dissipated energy also on its own scale (middle panel)
        D = result.column("dissipated")
        ax[0].plot(t, D, "-.", label=r"dissipated $\sum h\,d_n$")
        ax[0].plot(t, H + D - W, ":", label=r"$H + \sum h\,d_n - \sum h\,y\cdot u$ (constant)")
        ax[1].plot(t, D, "-.", color="C2")
        ax[1].set_ylabel(r"dissipated $\sum h\,d_n$")
        balance = r"$|H_{n+1} - H_n + h\,d_n - h\,y\cdot u|$"
    else:
        ax[0].plot(t, H - W, ":", label=r"$H - \sum h\,y\cdot u$ (constant)")
        balance = r"$|H_{n+1} - H_n - h\,y\cdot u|$"
    ax[0].set_ylabel("energy")
    ax[0].legend()
    floor = 1e-17 * max(np.max(np.abs(H)), 1e-300)  # below round-off: drawn at the floor
    ax[-1].semilogy(t[1:], np.maximum(err, floor), ".", ms=3)
    ax[-1].set_ylabel(balance)
    ax[-1].set_xlabel("t")
    fig.tight_layout()
    replace_atomically(path, lambda tmp: fig.savefig(tmp, dpi=110, format="png"))
    plt.close(fig)
