"""The output shows the physics truthfully (issue 27): the files are read back (rodfem.io.vtk.read_vtp, the
standard library's XML) and checked against the model's state, not against the writer's code.

- the 3D rod's exported strains are the strains its stress resultants carry, C_N N and C_M M (the full
  compliance of a coupled quadratic material), or the state's strain fields of a non-quadratic material:
  DG1 fields, linear on every cell (no node-to-node zig-zag), averaged only at a node between two cells;
- frames exactly at the requested times (interpolated between levels, against a run with a frame per
  level), clean times, TimeValue per file; active attributes (Normals d2, Vectors v, Scalars speed) and
  units in every file and fields.json;
- the drawn section is the scene's (rings vs directors and radius, the fin along d2; square corners);
  the slider crank's links end at their joints; the joints block puts each joint where its bodies are;
- the pictures: the plane of a planar motion, a window that follows a travelling body, a colour per
  body; view.py's colour ranges over all frames; serial == two ranks with interpolated frames and joints.
"""
import numpy as np
import pytest
from mpi4py import MPI

from rodfem.analysis.timeloop import run, steps_for
from rodfem.app.scene import load
from rodfem.io.output import OutDir, RunWriter
from rodfem.io.vtk import read_pvd, read_vtp

COMM = MPI.COMM_WORLD


def scene_run(name, out, **overrides):
    """Build a scene and run it with a RunWriter into `out` (what `rodfem run` does, keeping the problem)."""
    scene = load(name)
    p = scene.values(overrides)
    problem = scene.build(p, COMM)
    od = OutDir(str(out), COMM)
    with od.claimed({}):
        writer = RunWriter(od, problem, steps_for(p["dt"], p["t_end"]), p["frames"], p.get("section", 0.0),
                           **writer_options(scene, p))
        result = run(problem, p["dt"], p["t_end"], writer=writer)
        writer.finish({}, result)
    return problem, result, p


def writer_options(scene, p):
    return {}


def last_frame(out, kind="centreline"):
    t, _, f, _ = read_pvd(out / f"{kind}.pvd")[-1]
    return t, read_vtp(out / f)


def cell_ends(problem, name):
    """The DG1 field `name` of the state at the two ends of every cell, cells in order of s: (cells, 2, size)."""
    V, dofs = problem.space.collapse(name)
    bs = V.dofmap.index_map_bs
    xs = V.tabulate_dof_coordinates()[:, 0]
    vals = problem.x0.x.array[dofs].reshape(-1, bs)
    ncells = problem.mesh.topology.index_map(1).size_local
    ends = []
    for e in range(ncells):
        cd = V.dofmap.cell_dofs(e)
        cd = cd[np.argsort(xs[cd])]
        ends.append((xs[cd].mean(), vals[cd]))
    ends.sort(key=lambda c: c[0])
    return np.array([v for _, v in ends])


def nodal_p2(ends):
    """The P2 nodal values of a DG1 field given at the cells' ends: the value inside a cell (its middle
    node: the mean of the ends), the mean of the two cells' values at a node between them."""
    n = len(ends)
    out = np.empty((2 * n + 1, ends.shape[2]))
    out[1::2] = 0.5 * (ends[:, 0] + ends[:, 1])
    out[0], out[-1] = ends[0, 0], ends[-1, 1]
    out[2:-1:2] = 0.5 * (ends[1:, 0] + ends[:-1, 1])
    return out


def test_3d_rod_strains_are_the_stress_resultants_strains(tmp_path):
    """flying-spaghetti-3d at t = 2.4 (the end load still on): strain_from_N = C_N N, strain_from_M =
    C_M M of the state to 1e-12 at every node; inside every cell the field is linear (the middle node is
    the mean of its cell's ends), while the configuration's Gamma(q) at the exported nodes is not."""
    problem, result, p = scene_run("flying-spaghetti-3d", tmp_path, n_elements=6, t_end=2.4, frames=4)
    t, c = last_frame(tmp_path)
    assert abs(t - 2.4) < 1e-12
    N, M = cell_ends(problem, "N"), cell_ends(problem, "M")
    C_N = np.array([p["C_N1"], p["C_N2"], p["C_N3"]])
    C_M = np.array([p["C_M1"], p["C_M2"], p["C_M3"]])
    eN, eM = c.point_data["strain_from_N"].values, c.point_data["strain_from_M"].values
    assert c.point_data["strain_from_N"].components == ("axial", "shear2", "shear3")
    assert np.max(np.abs(eN - nodal_p2(N * C_N))) <= 1e-12 * np.max(np.abs(eN))
    assert np.max(np.abs(eM - nodal_p2(M * C_M))) <= 1e-12 * np.max(np.abs(eM))
    assert np.max(np.abs(eN[:, 0])) > 1e-4 and np.max(np.abs(eM)) > 1e-3      # the rod is loaded
    assert "Gamma" not in c.point_data and "K" not in c.point_data
    # the configuration's axial strain at the middle nodes (from the exported points and d1) departs
    # from the stress's by more than the stress strain itself: what a nodal Gamma(q) would have shown
    h = np.ptp(c.point_data["s"].values) / p["n_elements"]
    mid = np.arange(1, len(c.points), 2)
    d1 = c.point_data["d1"].values
    axial = np.sum(d1[mid] * (c.points[mid + 1] - c.points[mid - 1]) / h, axis=1) - 1.0
    assert np.max(np.abs(axial - eN[mid, 0])) > np.max(np.abs(eN[:, 0]))
    # the surface: the segment values at the middle of each half cell, linear between the cell's ends
    surf = read_vtp(tmp_path / "surface" / "frame_00003.vtp")
    m = (len(surf.polys) - 2) // (len(c.points) - 1)
    seg = surf.cell_data["strain_from_N"].values[1:-1:m]
    quarter = np.stack([0.75 * N[:, 0] + 0.25 * N[:, 1], 0.25 * N[:, 0] + 0.75 * N[:, 1]], 1).reshape(-1, 3)
    assert np.max(np.abs(seg - quarter * C_N)) <= 1e-12 * np.max(np.abs(seg))


def test_coupled_and_nonquadratic_materials_export_their_strains(tmp_path):
    """The stretch-twist material (a full 6 x 6 compliance C): (strain_from_N, strain_from_M) = C (N, M)
    of the state; the stiffening material (non-quadratic): the state's strain fields gamma, kappa."""
    problem, _, p = scene_run("flying-spaghetti-3d", tmp_path / "st", n_elements=4, t_end=0.6, frames=2,
                              variant="spatial", material="stretch-twist")
    _, c = last_frame(tmp_path / "st")
    C = np.asarray(problem.model.material.compliance(), dtype=float)
    assert abs(C[0, 3]) > 0                                         # axial strain and twist coupled
    NM = np.concatenate([cell_ends(problem, "N"), cell_ends(problem, "M")], axis=2)
    strains = nodal_p2(NM @ C.T)
    got = np.column_stack([c.point_data["strain_from_N"].values, c.point_data["strain_from_M"].values])
    assert np.max(np.abs(got - strains)) <= 1e-12 * np.max(np.abs(got))
    assert np.max(np.abs(got - nodal_p2(NM * np.diag(C)))) > 1e-3 * np.max(np.abs(got))   # not the diagonal
    problem, _, p = scene_run("flying-spaghetti-3d", tmp_path / "sf", n_elements=4, t_end=0.6, frames=2,
                              material="stiffening")
    _, c = last_frame(tmp_path / "sf")
    for name in ("gamma", "kappa"):
        want = nodal_p2(cell_ends(problem, name))
        assert np.max(np.abs(c.point_data[name].values - want)) <= 1e-14 + 1e-12 * np.max(np.abs(want))
    assert "strain_from_N" not in c.point_data


# -- active attributes, units, times ------------------------------------------------------------------------

def test_frames_on_the_requested_times_interpolated_between_levels(tmp_path):
    """10 steps of 0.1 s, 4 frames: t = 0, 1/3, 2/3, 1 (written 0.333333333333, ...: 12 digits), the middle
    two between levels 3, 4 and 6, 7.  The same run with a frame at every level is the oracle: an
    interpolated frame is (1 - theta) x_n + theta x_{n+1} of its points and every array (theta = 1/3,
    2/3), a frame on a level is that level's; every file's TimeValue is its .pvd time."""
    scene_run("flying-spaghetti-3d", tmp_path / "a", n_elements=4, t_end=1.0, frames=4)
    scene_run("flying-spaghetti-3d", tmp_path / "b", n_elements=4, t_end=1.0, frames=11)
    for kind in ("centreline", "surface"):
        a, b = read_pvd(tmp_path / "a" / f"{kind}.pvd"), read_pvd(tmp_path / "b" / f"{kind}.pvd")
        assert [t for t, *_ in a] == [0.0, 0.333333333333, 0.666666666667, 1.0]
        assert [t for t, *_ in b] == [0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0]   # clean: not 0.30000000000000004
        levels = [read_vtp(tmp_path / "b" / f) for _, _, f, _ in b]
        for (t, _, f, _), (n, theta) in zip(a, [(0, 0.0), (3, 1 / 3), (6, 2 / 3), (10, 0.0)]):
            got = read_vtp(tmp_path / "a" / f)
            assert got.field_data["TimeValue"].values.tolist() == [t]
            x, y = levels[n], levels[min(n + 1, 10)]
            assert np.max(np.abs(got.points - ((1 - theta) * x.points + theta * y.points))) <= 1e-14
            for data in ("point_data", "cell_data"):
                for k, arr in getattr(got, data).items():
                    want = (1 - theta) * getattr(x, data)[k].values + theta * getattr(y, data)[k].values
                    if k == "speed":     # the speed of the interpolated velocity
                        want = np.linalg.norm(got.point_data["v"].values, axis=1)
                    assert np.max(np.abs(arr.values - want)) <= 1e-13 * max(np.max(np.abs(want)), 1.0), (k, t)
        for t, _, f, _ in b:
            assert read_vtp(tmp_path / "b" / f).field_data["TimeValue"].values.tolist() == [t]


def test_active_attributes_and_units_of_every_file(tmp_path):
    """A rod (planar and 3D), a string and a rigid body: the centreline's Normals are d2, Vectors the
    velocity, Scalars the speed |v|; the surface's Vectors and Scalars the same; every array, the
    points and TimeValue have a unit in the field data `units`, the same as fields.json's."""
    import json
    runs = {"flying-spaghetti-2d": dict(n_elements=4, t_end=0.2, dt=0.1, frames=2),
            "flying-spaghetti-3d": dict(n_elements=2, t_end=0.2, frames=2),
            "crane-payload": dict(t_end=0.2, frames=2)}
    for scene, params in runs.items():
        out = tmp_path / scene
        scene_run(scene, out, **params)
        bodies = json.loads((out / "fields.json").read_text())["bodies"]
        for t, _, f, name in read_pvd(out / "centreline.pvd") + read_pvd(out / "surface.pvd"):
            poly = read_vtp(out / f)
            body = bodies[name or "body"]
            surface = f.startswith("surface")
            units = dict(u[:-1].split(" [") for u in poly.field_data["units"])
            if surface and body["kind"] in ("box", "point"):      # a rigid body's box: points only
                assert not poly.point_data and units == {"points": "m", "TimeValue": "s"}
                continue
            active = poly.active["PointData"]
            v = poly.point_data["v"].values
            assert active["Vectors"] == "v" and active["Scalars"] == "speed"
            assert np.array_equal(poly.point_data["speed"].values, np.linalg.norm(v, axis=1))
            if body["kind"] in ("rod", "box") and not surface:
                assert active["Normals"] == "d2"
            else:
                assert "Normals" not in active
            assert set(units) == {"points", "TimeValue", *poly.point_data, *poly.cell_data}
            assert units["points"] == "m" and units["TimeValue"] == "s" and units["v"] == "m/s"
            listed = {**body["centreline point data"], **body.get("surface cell data", {})}
            for k in [*poly.point_data, *poly.cell_data]:
                assert units[k] == listed[k]["unit"] != "", (scene, k)
        assert json.loads((out / "fields.json").read_text())["time"]["unit"] == "s"
    units = dict(u[:-1].split(" [") for u in read_vtp(tmp_path / "flying-spaghetti-3d" / "centreline" /
                                                         "frame_00001.vtp").field_data["units"])
    assert units["strain_from_N"] == "1" and units["strain_from_M"] == "1/m" and units["M"] == "N m"


# -- the drawn section is the physical one --------------------------------------------------------------------

def test_round_section_of_the_scene_turns_with_the_directors(tmp_path):
    """viscoelastic-cantilever-3d (a rod of radius 2 mm): every ring of the surface is r + R (cos a d2 +
    sin a d3) at 24 angles with the exported directors, the point at a = 0 (along d2) at 1.25 R (the
    marker fin); the caps are fans about the end points facing -d1(0) and +d1(L); fields.json names the
    section.  With the `section` parameter (a drawing width) the rectangle is drawn instead."""
    import json

    from rodfem.io.sections import FIN, ROUND_SIDES
    _, _, p = scene_run("viscoelastic-cantilever-3d", tmp_path / "a", n_elements=4, dt=0.005, t_end=0.03, frames=2)
    R = p["radius"]
    for t, _, f, _ in read_pvd(tmp_path / "a" / "centreline.pvd"):
        c = read_vtp(tmp_path / "a" / f)
        surf = read_vtp(tmp_path / "a" / f.replace("centreline", "surface"))
        n = len(c.points)
        d1, d2, d3 = (c.point_data[f"d{i}"].values for i in (1, 2, 3))
        a = 2 * np.pi * np.arange(ROUND_SIDES) / ROUND_SIDES
        rad = np.where(np.arange(ROUND_SIDES) == 0, FIN * R, R)
        want = (c.points[:, None, :] + (rad * np.cos(a))[None, :, None] * d2[:, None, :]
                + (rad * np.sin(a))[None, :, None] * d3[:, None, :])
        rings = surf.points[:-2].reshape(n, ROUND_SIDES, 3)
        assert np.max(np.abs(rings - want)) <= 1e-15 and np.array_equal(surf.points[-2:], c.points[[0, -1]])
        assert np.max(np.abs(np.linalg.norm(rings[:, 1:] - c.points[:, None], axis=2) - R)) <= 1e-15
        assert np.max(np.abs(np.einsum("ni,ni->n", rings[:, 0] - c.points, d2) - FIN * R)) <= 1e-15
        polys = [np.asarray(q) for q in surf.polys]
        assert len(polys) == ROUND_SIDES * (n - 1) + 2 * ROUND_SIDES
        for cap, node, sign in ((polys[:ROUND_SIDES], 0, -1.0), (polys[-ROUND_SIDES:], -1, 1.0)):
            for tri in cap:
                q = surf.points[tri]
                normal = np.cross(q[1] - q[0], q[2] - q[0])
                assert sign * normal @ d1[node] > 0.99 * np.linalg.norm(normal)
        assert len(surf.cell_data["N"].values) == len(polys)
    section = json.loads((tmp_path / "a" / "fields.json").read_text())["bodies"]["body"]["section"]
    assert section["shape"] == "round" and section["diameter"] == 2 * R and section["unit"] == "m"
    scene_run("viscoelastic-cantilever-3d", tmp_path / "b", n_elements=4, dt=0.005, t_end=0.01, frames=1,
              section=0.1)
    surf = read_vtp(tmp_path / "b" / "surface" / "frame_00000.vtp")
    assert len(surf.points) == 4 * 9 and len(surf.polys) == 4 * 8 + 2


def test_four_bar_beams_have_their_square_section(tmp_path):
    """four-bar-2d (5 cm square steel beams): each body's surface corners are r +- w/2 d2 +- w/2 e_z."""
    _, _, p = scene_run("four-bar-2d", tmp_path, t_end=0.02, frames=1)
    w = p["width"]
    for t, _, f, name in read_pvd(tmp_path / "centreline.pvd"):
        c = read_vtp(tmp_path / f)
        surf = read_vtp(tmp_path / f.replace("centreline", "surface"))
        d2 = c.point_data["d2"].values
        corners = surf.points.reshape(len(c.points), 4, 3) - c.points[:, None, :]
        local = np.stack([np.einsum("nki,ni->nk", corners, d2), corners[:, :, 2]], axis=2)
        assert np.allclose(np.abs(local), w / 2, rtol=1e-12, atol=0), name


# -- pictures -----------------------------------------------------------------------------------------------

def rod_sketch(points, name=""):
    from rodfem.io.animation import Sketch
    points = np.asarray(points, dtype=float)
    d2 = np.tile([0.0, 1.0, 0.0], (len(points), 1))
    return Sketch("rod", points, d2=d2, name=name)


def test_picture_layout_plane_and_window():
    """A 3D rod moving in the plane z = 2: drawn in 2D on (x, y); in y = -1: on (x, z); else 3D.  A rod of length 1
    flying 20 m: the window (one size, the rod's extent plus margins) follows it and holds every frame;
    swinging within its own size: one fixed window holding all frames."""
    from rodfem.io.animation import Layout
    s = np.linspace(0, 1, 11)
    fly = [(t, [rod_sketch(np.column_stack([s + 2 * t, 0 * s, 0 * s + 2.0]))]) for t in range(11)]
    lay = Layout(fly, 3, 0.01)
    assert lay.axes == (0, 1) and lay.follows
    for k, (_, sk) in enumerate(fly):
        lo, hi = lay.window(k)
        pts = sk[0].line[:, [0, 1]]
        assert np.all(pts >= lo) and np.all(pts <= hi)
        assert np.allclose(hi - lo, lay.size) and lay.size < 2.0
    tilt = [(t, [rod_sketch(np.column_stack([s, t * s ** 2, t * s]))]) for t in (0.0, 0.5)]
    assert Layout(tilt, 3, 0.01).axes == (0, 1, 2)
    in_xz = [(t, [rod_sketch(np.column_stack([s, 0 * s - 1.0, t * s]))]) for t in (0.0, 0.5)]
    assert Layout(in_xz, 3, 0.01).axes == (0, 2)
    swing = [(a, [rod_sketch(np.column_stack([np.cos(a) * s, np.sin(a) * s]))]) for a in np.linspace(0, 3, 7)]
    lay = Layout([(t, [rod_sketch(np.column_stack([sk[0].line, 0 * s]))]) for t, sk in swing], 2, 0.01)
    assert lay.axes == (0, 1) and not lay.follows
    assert all(np.array_equal(lay.window(k)[0], lay.window(0)[0]) for k in range(7))
    lo, hi = lay.window(0)
    every = np.concatenate([sk[0].line[:, :2] for _, sk in swing])
    assert np.all(every >= lo) and np.all(every <= hi)


def test_animation_and_shapes_colour_each_body(tmp_path):
    """Two bodies: every GIF frame shows both bodies' colours (tab:blue, tab:orange), one frame per
    snapshot; shapes.png draws with a time colour bar (a wider figure than the axes alone)."""
    from PIL import Image

    from rodfem.io.animation import plot_shapes, write_animation
    s = np.linspace(0, 1, 11)
    snaps = [(0.1 * k, [rod_sketch(np.column_stack([s, 0.1 * k * s, 0 * s]), "a"),
                        rod_sketch(np.column_stack([s, 1 + 0 * s, 0 * s]) + [0.0, 0.05 * k, 0.0], "b")])
             for k in range(5)]
    write_animation(tmp_path / "a.gif", snaps, 2, 0.02)
    with Image.open(tmp_path / "a.gif") as gif:
        assert gif.n_frames == 5
        for k in range(5):
            gif.seek(k)
            rgb = np.asarray(gif.convert("RGB")).reshape(-1, 3).astype(int)
            for colour in ((31, 119, 180), (255, 127, 14)):
                assert np.min(np.abs(rgb - colour).sum(axis=1)) <= 12, (k, colour)
    plot_shapes(tmp_path / "s.png", snaps, 2, 0.02)
    with Image.open(tmp_path / "s.png") as png:
        assert png.size[0] > png.size[1]


# -- joints, components, supports -------------------------------------------------------------------------------

def test_joints_block_puts_each_joint_where_its_bodies_are(tmp_path):
    """slider-crank-3d: joints.pvd has a frame per frame; each joint's two points (from the bodies' exported
    centres and directors with the joints' offsets) are where the bodies carry them: the ball and the
    cardan joint's two sides meet (the constraints hold to round-off), the bearing's crank side is at the
    ground point A; four-bar-2d: its pinned supports sit on the beams' ends."""
    import json

    from rodfem.io.glyphs import marks_of
    problem, _, p = scene_run("slider-crank-3d", tmp_path / "sc", t_end=0.1, frames=3)
    frames = read_pvd(tmp_path / "sc" / "joints.pvd")
    assert [t for t, *_ in frames] == [t for t, *_ in read_pvd(tmp_path / "sc" / "centreline.pvd")][::3]
    marks = marks_of(problem)
    names = [m.name for m in marks]
    for t, _, f, _ in frames:
        poly = read_vtp(tmp_path / "sc" / f)
        assert poly.field_data["marks"] == [f"{k} {m.name} ({m.what})" for k, m in enumerate(marks)]
        ids = poly.point_data["mark"].values
        x = {name: poly.points[ids == k] for k, name in enumerate(names)}
        for joint in ("ball_B", "cardan_C"):
            assert np.linalg.norm(x[joint][0] - x[joint][1]) <= 1e-10
        k = names.index("bearing_A")
        ground = [q for q in marks[k].points if q[0] is None][0]
        assert np.allclose(x["bearing_A"], np.asarray(ground[2]), rtol=0, atol=1e-10)
        # the crank side from the exported crank: centre + offset along its directors
        c = read_vtp(tmp_path / "sc" / f.replace("joints/", "centreline/").replace(".vtp", "_crank.vtp"))
        side = [q for q in marks[k].points if q[0] == "crank"][0]
        R = np.column_stack([c.point_data[f"d{i}"].values[0] for i in (1, 2, 3)])
        assert np.allclose(c.points[0] + R @ np.asarray(side[2]), x["bearing_A"][1], rtol=0, atol=1e-14)
    assert poly.active["PointData"]["Scalars"] == "mark"
    scene_run("four-bar-2d", tmp_path / "fb", t_end=0.02, frames=1)
    poly = read_vtp(tmp_path / "fb" / "joints" / "frame_00000.vtp")
    labels = [m.split(" ")[1] for m in poly.field_data["marks"]]
    for body, end in (("crank", 0), ("rocker", -1)):
        c = read_vtp(tmp_path / "fb" / "centreline" / f"frame_00000_{body}.vtp")
        k = labels.index(f"{body}.{'left' if end == 0 else 'right'}")
        assert np.array_equal(poly.points[poly.point_data["mark"].values == k][0], c.points[end])
    assert "joints" not in json.dumps(json.loads((tmp_path / "fb" / "fields.json").read_text())["bodies"])


# -- the ParaView script -------------------------------------------------------------------------------------

def test_view_script_has_the_ranges_of_all_frames(tmp_path):
    """view.py is Python; its RUN holds every surface array's range per component over ALL frames (here
    the flying spaghetti starts at rest: the first frame's range of the strains is [0, 0]), the box of
    the motion of the centrelines, the frames' times, the default array (the first strain, a rod) and
    the planar flag (the 3D rod moves in z = 0).  (benchmarks/bench_paraview.py opens it in ParaView.)"""
    import ast
    scene_run("flying-spaghetti-3d", tmp_path, n_elements=4, t_end=1.0, frames=5)
    text = (tmp_path / "view.py").read_text()
    compile(text, "view.py", "exec")
    line = next(x for x in text.splitlines() if x.startswith("RUN = "))
    run_ = ast.literal_eval(line[len("RUN = "):])
    surfaces = [read_vtp(tmp_path / f) for _, _, f, _ in read_pvd(tmp_path / "surface.pvd")]
    lines = [read_vtp(tmp_path / f) for _, _, f, _ in read_pvd(tmp_path / "centreline.pvd")]
    strain = np.concatenate([s.cell_data["strain_from_N"].values for s in surfaces])
    assert np.ptp(surfaces[0].cell_data["strain_from_N"].values) == 0
    assert [r[1:] for r in run_["ranges"]["strain_from_N"]] == [(strain[:, k].min(), strain[:, k].max()) for k in range(3)]
    assert run_["ranges"]["strain_from_N"][0][0] == "CELLS" and run_["ranges"]["speed"][0][0] == "POINTS"
    points = np.concatenate([c.points for c in lines])
    assert run_["bounds"] == [points.min(axis=0).tolist(), points.max(axis=0).tolist()]
    assert run_["times"] == [0.0, 0.25, 0.5, 0.75, 1.0] and run_["array"] == "strain_from_N" and run_["planar"]
    assert run_["units"]["strain_from_M"] == "1/m" and not run_["joints"]


@pytest.mark.parametrize("name, overrides, default", [("four-bar-2d", {"t_end": 0.02, "frames": 3}, "blocks"),
                                                     ("chain-1000", {"n_links": 14, "t_end": 0.02, "frames": 3}, "body")])
def test_view_script_facts_are_those_of_the_files(tmp_path, name, overrides, default):
    """The writer gathers view.py's facts as it writes the frames; they are those read back from the
    files (`run_facts`, what a run resumed from a checkpoint does), in a mechanism with joints (one file
    per body) and in a chain of more than LEGEND links (one file per model kind: default array body)."""
    import ast

    from rodfem.io.paraview import run_facts
    scene_run(name, tmp_path, **overrides)
    line = next(x for x in (tmp_path / "view.py").read_text().splitlines() if x.startswith("RUN = "))
    run_ = ast.literal_eval(line[len("RUN = "):])
    units = run_.pop("units")
    assert run_ == run_facts(str(tmp_path), default)
    assert run_["joints"] and run_["array"] == default and len(run_["times"]) >= 2 and units


def test_slider_crank_links_run_between_their_joints(tmp_path):
    """slider-crank-3d gives its crank and rod as links (1 cm bars between their joint points): the rod's
    surface is two caps' centres at the ball and the cardan joint (joints.pvd), every ring 5 mm around
    the axis (the fin at 6.25 mm); the slider stays its box (6 faces)."""
    from rodfem.io.sections import FIN, ROUND_SIDES
    scene_run("slider-crank-3d", tmp_path, t_end=0.1, frames=2)
    joints = read_vtp(tmp_path / "joints" / "frame_00001.vtp")
    names = [m.split(" ")[1] for m in joints.field_data["marks"]]
    at = {n: joints.points[joints.point_data["mark"].values == k] for k, n in enumerate(names)}
    rod = read_vtp(tmp_path / "surface" / "frame_00001_rod.vtp")
    ends = rod.points[-2:]
    assert np.linalg.norm(ends[0] - at["ball_B"][0]) <= 1e-12 and np.linalg.norm(ends[1] - at["cardan_C"][0]) <= 1e-12
    axis = (ends[1] - ends[0]) / np.linalg.norm(ends[1] - ends[0])
    rings = rod.points[:-2].reshape(2, ROUND_SIDES, 3) - ends[:, None, :]
    assert np.max(np.abs(rings @ axis)) <= 1e-15
    r = np.linalg.norm(rings, axis=2)
    assert np.allclose(r[:, 1:], 0.005, rtol=1e-12) and np.allclose(r[:, 0], FIN * 0.005, rtol=1e-12)
    assert len(read_vtp(tmp_path / "surface" / "frame_00001_slider.vtp").polys) == 6


@pytest.mark.mpi
def test_two_ranks_write_the_serial_interpolated_frames_and_joints(tmp_path):
    """four-bar-2d over 5 steps with 4 frames (two of them between levels) by `mpirun -n 2`: the same
    .pvd files, frame times, joints and view.py ranges as the serial run, every array to solver round-off."""
    import ast

    from processes import ok, rodfem
    args = ["run", "four-bar-2d", "--set", "t_end=0.1", "--set", "dt=0.02", "--set", "frames=4", "--quiet"]
    ok(rodfem(*args, "--out", tmp_path / "s"))
    ok(rodfem(*args, "--out", tmp_path / "p", np=2))
    for pvd in ("centreline.pvd", "surface.pvd", "joints.pvd"):
        a, b = read_pvd(tmp_path / "s" / pvd), read_pvd(tmp_path / "p" / pvd)
        assert a == b and [t for t, *_ in a][::len(a) // 4] == [0.0, 0.0333333333333, 0.0666666666667, 0.1]
        for _, _, f, _ in a:
            x, y = read_vtp(tmp_path / "s" / f), read_vtp(tmp_path / "p" / f)
            assert np.allclose(x.points, y.points, rtol=0, atol=1e-13) and x.field_data == y.field_data
            for data in ("point_data", "cell_data"):
                for k, arr in getattr(x, data).items():
                    assert np.allclose(arr.values, getattr(y, data)[k].values, rtol=1e-10, atol=1e-10), (f, k)
    runs = [ast.literal_eval(next(x for x in (tmp_path / d / "view.py").read_text().splitlines()
                                  if x.startswith("RUN = "))[6:]) for d in ("s", "p")]
    assert runs[0]["times"] == runs[1]["times"] and runs[0]["array"] == runs[1]["array"] == "blocks"
