"""What a run writes for a rod user (issue 15): the files are read back (rodfem.io.vtk.read_vtp, the
standard library's XML) and checked against the model's own values, not against the writer's code.

- centreline/: one polyline per body through the nodes in order of s; its points are the state's;
- surface/: the section's corners at every node are r + a d2 + b d3 with the exported directors;
- the strains and stress resultants are the model's: the state's Gamma, kappa (planar), the
  compatible strains at t = 0, N = dW/dGamma; the 3D rod's C_M M, the helix's exact curvature
  and end moment (tests/io/test_output_physics.py: C_N N and C_M M at every node); a string's stretch |d_s r|;
- frames: the promised number, t = 0 and t_end, the last frame at the history's tip;
- animation.gif has one picture per frame; a massless scene writes no velocities;
- `mpirun -n 2` writes the serial bytes for the same state (and the serial values to round-off later).
"""
import json
import os

import numpy as np
import pytest
from mpi4py import MPI
from processes import ok, rodfem

from rodfem import Problem
from rodfem.analysis.timeloop import run, steps_for
from rodfem.app.scene import load
from rodfem.io.output import OutDir, RunWriter
from rodfem.io.sections import RECTANGLE
from rodfem.io.vtk import read_pvd, read_vtp

COMM = MPI.COMM_WORLD


def write_run(problem, out, dt, t_end, frames, section=0.0):
    """Run `problem` with a RunWriter into `out` (what `rodfem run` does, keeping the problem)."""
    od = OutDir(str(out), COMM)
    with od.claimed({}):
        writer = RunWriter(od, problem, steps_for(dt, t_end), frames, section)
        result = run(problem, dt, t_end, writer=writer)
        writer.finish({}, result)
    return result


def scene_run(name, out, **overrides):
    scene = load(name)
    p = scene.values(overrides)
    problem = scene.build(p, COMM)
    return problem, write_run(problem, out, p["dt"], p["t_end"], p["frames"], p["section"]), p


def series(out, kind="centreline"):
    """[(t, part, PolyData, name)] of a .pvd."""
    return [(t, part, read_vtp(os.path.join(out, f)), name)
            for t, part, f, name in read_pvd(os.path.join(out, kind + ".pvd"))]


def gif_frames(path):
    from PIL import Image
    with Image.open(path) as im:
        return im.n_frames


def corners(centre, d2, d3, width):
    """The section's corners (nodes, 4, 3) the surface must have: r + a d2 + b d3."""
    ab = RECTANGLE * [width, width / 2]
    return centre[:, None, :] + ab[None, :, 0, None] * d2[:, None, :] + ab[None, :, 1, None] * d3[:, None, :]


# -- the planar beam ---------------------------------------------------------------------------------

R_ARC, L_ARC, N_ARC = 2.0, 3.0, 6


def arc_beam():
    """A free planar beam bent into a circular arc (radius 2) at rest, with compatible strains: it
    springs open.  Gamma(0) = A(phi_m)^T (chord / h) - e1 cell by cell (nonzero), kappa = 1/R."""
    from rodfem.forms.planar_beam import PlanarBeam, quadratic
    beam = PlanarBeam(1.0, 0.1, quadratic(EA=100.0, GA=50.0, EI=2.0))
    initial = {"r": lambda x: np.vstack([R_ARC * np.sin(x[0] / R_ARC), R_ARC * (1 - np.cos(x[0] / R_ARC))]),
               "phi": lambda x: x[0] / R_ARC}
    return Problem(beam, L_ARC, N_ARC, initial=initial, comm=COMM)


def test_planar_beam_polyline_surface_strains_and_frames(tmp_path):
    problem = arc_beam()
    result = write_run(problem, tmp_path, 0.01, 0.3, frames=4, section=0.1)
    frames = series(tmp_path)
    times = [t for t, *_ in frames]
    assert len(frames) == 4 and times[0] == 0.0 and times[-1] == result.rows[-1]["t"] == pytest.approx(0.3)
    assert len(os.listdir(tmp_path / "centreline")) == len(os.listdir(tmp_path / "surface")) == 4
    assert gif_frames(tmp_path / "animation.gif") == 4
    h = L_ARC / N_ARC
    for k, (t, _, c, _) in enumerate(frames):
        # one polyline through the nodes in order
        assert len(c.lines) == 1 and list(c.lines[0]) == list(range(N_ARC + 1)) and not c.verts
        s = c.point_data["s"].values
        assert np.allclose(s, h * np.arange(N_ARC + 1), rtol=0, atol=1e-14)
        r, phi = c.points[:, :2], c.point_data["phi"].values
        assert np.all(c.points[:, 2] == 0.0)
        chord = (r[1:] - r[:-1]) / h
        pm = 0.5 * (phi[1:] + phi[:-1])
        # the surface: a 0.1 x 0.05 box section turned by phi, caps at both ends
        surf = read_vtp(tmp_path / "surface" / f"frame_{k:05d}.vtp")
        d2 = np.column_stack([-np.sin(phi), np.cos(phi), 0 * phi])
        d3 = np.tile([0.0, 0.0, 1.0], (len(phi), 1))
        assert np.max(np.abs(surf.points.reshape(-1, 4, 3) - corners(c.points, d2, d3, 0.1))) <= 1e-14
        assert len(surf.polys) == 4 * N_ARC + 2
        G_cells = surf.cell_data["Gamma"].values[1:-1:4]       # one value per element (4 sides each)
        kappa_cells = surf.cell_data["kappa"].values[1:-1:4]
        assert surf.cell_data["Gamma"].components == ("axial", "shear")
        if k == 0:   # compatible strains as the model sets them: Gamma = A(phi_m)^T d_s r - e1, kappa = d_s phi
            A_T = np.stack([np.column_stack([np.cos(pm), np.sin(pm)]), np.column_stack([-np.sin(pm), np.cos(pm)])], 1)
            G = np.einsum("nij,nj->ni", A_T, chord) - [1.0, 0.0]
            assert np.max(np.abs(G_cells - G)) <= 1e-13 and np.max(np.abs(G[:, 0])) > 1e-3
            assert np.max(np.abs(kappa_cells - np.diff(phi) / h)) <= 1e-13
            assert np.allclose(kappa_cells, 1 / R_ARC, rtol=1e-12)
        # the centreline's nodal values: exact inside, the two elements' mean at an inner node
        Gn = c.point_data["Gamma"].values
        assert np.allclose(Gn[1:-1], 0.5 * (G_cells[1:] + G_cells[:-1]), rtol=0, atol=1e-15)
        assert np.allclose(Gn[[0, -1]], G_cells[[0, -1]], rtol=0, atol=1e-15)
        # the stress resultants of the quadratic material: N = (EA, GA) Gamma, M = EI kappa
        N, M = surf.cell_data["N"].values[1:-1:4], surf.cell_data["M"].values[1:-1:4]
        assert np.allclose(N, G_cells * [100.0, 50.0], rtol=1e-13, atol=1e-15)
        assert np.allclose(M, 2.0 * kappa_cells, rtol=1e-13)
    # the last frame is the state: nodes, the state's Gamma (DG0 dofs), the history's tip
    S = problem.space
    assert np.array_equal(c.points[:, :2], S.nodal(problem.x0, "r")[1])
    V, dofs = S.collapse("Gamma")
    order = np.argsort(V.tabulate_dof_coordinates()[:, 0])
    assert np.array_equal(G_cells, problem.x0.x.array[dofs].reshape(-1, 2)[order])
    assert c.points[-1, 0] == pytest.approx(result.rows[-1]["tip_x"], abs=1e-12)
    assert c.points[-1, 1] == pytest.approx(result.rows[-1]["tip_y"], abs=1e-12)
    fields = json.loads((tmp_path / "fields.json").read_text())["bodies"]["body"]
    assert fields["model"] == "PlanarBeam" and fields["centreline point data"]["N"]["components"] == ["axial", "shear"]
    assert set(fields["surface cell data"]) == {"Gamma", "kappa", "N", "M"} and "omitted" not in fields
    assert "v" in c.point_data and c.point_data["v"].values.shape == (N_ARC + 1, 3)


# -- the 3D rod: the helix (statics, zero densities) ------------------------------------------------------

def test_helix_strains_moments_surface_and_no_velocities(tmp_path):
    import rodfem.demos.helix_3d as helix
    problem, result, p = scene_run("helix-3d", tmp_path, frames=3, section=1.0)
    frames = series(tmp_path)
    assert [t for t, *_ in frames] == [0.0, 0.5, 1.0] and gif_frames(tmp_path / "animation.gif") == 3
    c = frames[-1][2]
    n = 2 * p["n_elements"] + 1                  # P2 nodes
    assert len(c.lines) == 1 and list(c.lines[0]) == list(range(n))
    assert np.all(np.diff(c.point_data["s"].values) > 0)
    assert np.allclose(c.points[-1], [result.rows[-1][f"tip_{x}"] for x in "xyz"], rtol=0, atol=1e-9)
    # no inertia: the velocities are not written (said so in fields.json)
    for name in ("v", "w1", "w2", "w3"):
        assert name not in c.point_data
    fields = json.loads((tmp_path / "fields.json").read_text())["bodies"]["body"]
    assert set(fields["omitted"]) == {"v", "w1", "w2", "w3"}
    assert fields["centreline point data"]["lam"]["components"] == ["11", "22", "33", "12", "13", "23"]
    d = [c.point_data[f"d{i}"].values for i in (1, 2, 3)]
    # K of the configuration at the elements' middle nodes, from the exported points and directors
    h = helix.LENGTH / p["n_elements"]
    mid = np.arange(1, n, 2)
    ds = [(di[mid + 1] - di[mid - 1]) / h for di in d]
    K = np.column_stack([0.5 * (np.sum(ds[j] * d[k][mid], 1) - np.sum(ds[k] * d[j][mid], 1))
                         for j, k in ((1, 2), (2, 0), (0, 1))])
    # the exact helix: K = (torsion, 0, curvature) = (c kappa, 0, kappa); M = the end moment (EI = 1 units)
    exact = np.array([helix.C * helix.KAPPA, 0.0, helix.KAPPA])
    assert np.max(np.abs(K - exact)) <= 0.03 * helix.KAPPA              # 16 elements: 2 %
    M = c.point_data["M"].values
    assert np.max(np.abs(M - exact)) <= 5e-3 * helix.KAPPA and np.max(np.ptp(M, axis=0)) <= 1e-5
    # the exported curvature is C_M M : the strain the moments carry
    assert np.max(np.abs(c.point_data["strain_from_M"].values - M * problem.model.C_M)) <= 1e-14
    # the state's N, M (DG1): at the middle node the mean of the element's two end values
    S = problem.space
    V, dofs = S.collapse("M")
    xs = V.tabulate_dof_coordinates()[:, 0]
    vals = problem.x0.x.array[dofs].reshape(-1, 3)
    mids = np.array([vals[V.dofmap.cell_dofs(e)].mean(axis=0) for e in range(p["n_elements"])])
    centres = np.array([xs[V.dofmap.cell_dofs(e)].mean() for e in range(p["n_elements"])])
    assert np.max(np.abs(M[mid] - mids[np.argsort(centres)])) <= 1e-14
    # the surface: the 1.0 x 0.5 section at every node, turned with the exported d2, d3
    surf = read_vtp(tmp_path / "surface" / "frame_00002.vtp")
    assert np.max(np.abs(surf.points.reshape(-1, 4, 3) - corners(c.points, d[1], d[2], 1.0))) <= 1e-12
    assert set(surf.cell_data) == {"strain_from_N", "strain_from_M", "N", "M"} and len(surf.polys) == 4 * (n - 1) + 2
    assert set(surf.point_data) == {"s"}


# -- a system: a string and a rigid body ------------------------------------------------------------

def test_crane_payload_parts_rigid_box_and_string_tube(tmp_path):
    problem, result, p = scene_run("crane-payload", tmp_path, t_end=0.2, frames=3)
    for kind in ("centreline", "surface"):
        parts = read_pvd(tmp_path / f"{kind}.pvd")
        assert [(t, part, name) for t, part, _, name in parts] == [
            (t, k, name) for t in (0.0, 0.1, 0.2) for k, name in enumerate(("cable", "payload"))]
    assert gif_frames(tmp_path / "animation.gif") == 3
    frames = series(tmp_path)
    cable, box = frames[-2][2], frames[-1][2]
    # the payload: one vertex at its centre with its directors; its box along them, edges from m, J
    assert len(box.verts) == 1 and len(box.points) == 1 and not box.lines
    R = np.column_stack([box.point_data[f"d{i}"].values[0] for i in (1, 2, 3)])
    assert np.allclose(R.T @ R, np.eye(3), atol=1e-12)
    payload = problem.body("payload")
    edges = np.array(payload.model.box())
    surf = read_vtp(tmp_path / "surface" / "frame_00002_payload.vtp")
    assert len(surf.polys) == 6 and len(surf.points) == 24
    local = (surf.points - box.points[0]) @ R                             # corners in the body frame
    assert np.allclose(np.abs(local), edges / 2, rtol=1e-12)
    J = np.array([np.sum(edges ** 2) - e ** 2 for e in edges]) * payload.model.parameters.values["m"] / 12
    assert np.allclose(np.sort(J), np.sort(np.array(payload.model.E).sum() - payload.model.E), rtol=1e-12)
    # the cable: a polyline of its P1 nodes, a round tube, the stretch |d_s r| cell by cell
    assert len(cable.lines) == 1 and len(cable.points) == p["n_elements"] + 1
    tube = read_vtp(tmp_path / "surface" / "frame_00002_cable.vtp")
    rings = tube.points.reshape(len(cable.points), -1, 3)
    radius = np.linalg.norm(rings - cable.points[:, None, :], axis=2)
    assert np.allclose(radius, radius[0, 0], rtol=1e-12)
    h = p["L"] / p["n_elements"]
    m = rings.shape[1]
    stretch = tube.cell_data["stretch"].values[::m]
    assert np.allclose(stretch, np.linalg.norm(np.diff(cable.points, axis=0), axis=1) / h, rtol=1e-10)
    assert np.all(tube.cell_data["tension"].values > 0)


# -- the command line: frames, pictures ------------------------------------------------------------------

def test_run_writes_frames_surface_animation(tmp_path):
    from rodfem.app.cli import main
    assert main(["run", "flying-spaghetti-2d", "--set", "n_elements=4", "--set", "t_end=1.5",
                 "--set", "frames=6", "--quiet", "--out", str(tmp_path)]) == 0
    for kind in ("centreline", "surface"):
        times = [t for t, *_ in read_pvd(tmp_path / f"{kind}.pvd")]
        assert len(times) == 6 and times[0] == 0.0 and times[-1] == pytest.approx(1.5)
    assert gif_frames(tmp_path / "animation.gif") == 6
    for name in ("shapes.png", "energy.png", "fields.json"):
        assert (tmp_path / name).stat().st_size > 1000


def test_a_frame_is_appended_raw_binary_that_tiles_its_appended_data(tmp_path):
    """The layout of VTK's appended raw encoding, read by hand (not by read_vtp): every Piece array's
    DataArray has format="appended" and an offset into the bytes after AppendedData's "_"; there a UInt64
    count of tuples x components x 8 bytes, the little-endian values (the centreline's points those read
    back), each block right after the one before, the last followed by the closing tags; field data inline."""
    import xml.etree.ElementTree as ET

    from rodfem.app.cli import main
    assert main(["run", "flying-spaghetti-2d", "--set", "n_elements=6", "--set", "t_end=0.2", "--set", "frames=2",
                 "--quiet", "--out", str(tmp_path)]) == 0
    for kind in ("centreline", "surface"):
        data = (tmp_path / kind / "frame_00001.vtp").read_bytes()
        at = data.index(b'<AppendedData encoding="raw">')
        raw = data[data.index(b"_", at) + 1:]
        root = ET.fromstring(data[:at] + b"</VTKFile>")
        piece = root.find("PolyData/Piece")
        arrays = piece.findall(".//DataArray")
        assert all(a.get("format") == "binary" for a in root.findall("PolyData/FieldData/DataArray"))
        assert arrays and all(a.get("format") == "appended" for a in arrays)
        end = 0
        for a in arrays:
            assert int(a.get("offset")) == end
            count = int(np.frombuffer(raw[end:end + 8], "<u8")[0])
            parent = next(p for p in piece.iter() if a in list(p))
            rows = int(piece.get("NumberOfPoints")) if parent.tag in ("PointData", "Points") else None
            if rows is not None:
                assert count == rows * int(a.get("NumberOfComponents")) * 8
            end += 8 + count
        assert raw[end:] == b"\n  </AppendedData>\n</VTKFile>\n"
        points = next(a for a in arrays if a in list(piece.find("Points")))
        start = int(points.get("offset")) + 8
        n = int(piece.get("NumberOfPoints"))
        xyz = np.frombuffer(raw[start:start + 24 * n], "<f8").reshape(n, 3)
        assert np.array_equal(xyz, read_vtp(tmp_path / kind / "frame_00001.vtp").points)


# -- serial and two ranks ----------------------------------------------------------------------------------

@pytest.mark.mpi
def test_two_ranks_write_the_serial_bytes(tmp_path):
    args = ["run", "flying-spaghetti-3d", "--set", "variant=spatial", "--set", "n_elements=6", "--set", "t_end=1",
            "--set", "frames=3", "--quiet"]
    ok(rodfem(*args, "--out", tmp_path / "s"))
    ok(rodfem(*args, "--out", tmp_path / "p", np=2))
    names = [os.path.join(d, f) for d in ("centreline", "surface") for f in sorted(os.listdir(tmp_path / "s" / d))]
    assert len(names) == 6
    # the initial state is the same on both: so are the bytes (the writer does not see the partition)
    for name in ["centreline/frame_00000.vtp", "surface/frame_00000.vtp", "centreline.pvd", "surface.pvd",
                 "fields.json"]:
        assert (tmp_path / "s" / name).read_bytes() == (tmp_path / "p" / name).read_bytes(), name
    # after steps the two states differ by the linear solver's round-off (1e-16 in r, 1e-13 in lambda)
    for name in names:
        a, b = read_vtp(tmp_path / "s" / name), read_vtp(tmp_path / "p" / name)
        assert [list(c) for c in a.lines + a.polys] == [list(c) for c in b.lines + b.polys]
        assert np.max(np.abs(a.points - b.points)) <= 1e-14, name
        for data in ("point_data", "cell_data"):
            x, y = getattr(a, data), getattr(b, data)
            assert list(x) == list(y)
            for k in x:
                assert np.allclose(x[k].values, y[k].values, rtol=1e-11, atol=1e-11), (name, k)
    assert gif_frames(tmp_path / "p" / "animation.gif") == 3


def test_a_centreline_written_in_rows_has_the_bytes_of_the_whole(tmp_path):
    """A body's centreline file written in rows (as the ranks of a spread body write it: `rows_of`, each
    part's rows by `write_vtp_rows`, the creator first, the others in any order) has the bytes of the file
    written whole, for a P1 planar beam and a P2 rod (derived fields at the nodes between cells: the
    mean of two cells', cut between parts too), cut at a cell's end, inside a cell and next to the ends."""
    from scenes import built

    from rodfem.io.frames import centreline
    from rodfem.io.snapshot import body_views, rows_of
    from rodfem.io.vtk import write_vtp, write_vtp_rows
    for scene_name, n in (("flying-spaghetti-2d", 12), ("flying-spaghetti-3d", 6)):
        problem = built(scene_name, n)
        (view,), gather = body_views(problem)
        state = gather()[0]
        total = len(state.position)
        whole = centreline(state, view.labels, view.velocity)
        write_vtp(tmp_path / "whole.vtp", whole)
        for cuts in ([0, total // 2, total], [0, 1, 2, 7, total - 1, total], [0, 5, 6, total]):
            parts = [rows_of(state, a, b) + (a,) for a, b in zip(cuts[:-1], cuts[1:])]
            polys = [centreline(part, view.labels, view.velocity, lead, total) for part, lead, _ in parts]
            for poly in polys:
                assert list(poly.point_data) == list(whole.point_data)
            path = tmp_path / "rows.vtp"
            write_vtp_rows(path, polys[0], 0, total, create=True)
            for poly, (_, _, first) in reversed(list(zip(polys, parts))):
                write_vtp_rows(path, poly, first, total, create=False)
            assert path.read_bytes() == (tmp_path / "whole.vtp").read_bytes(), (scene_name, cuts)


@pytest.mark.mpi
def test_two_ranks_write_each_their_rows_of_a_long_centreline(tmp_path):
    """A frame of a body spread over two ranks with at least ROWS nodes per rank: each rank writes its rows of
    the centreline file (rank 0 creates it first), the file has the bytes one rank writes (the serial
    run's: the same initial state) and no temporary file is left; a short body's frame rank 0 writes whole."""
    from processes import script_on_ranks
    script = f"""
import hashlib, json, os
from mpi4py import MPI
from rodfem.app.scene import load
from rodfem.io import output
comm = MPI.COMM_WORLD
calls = []
write_rows = output.write_vtp_rows
def counted(path, poly, first, total, create):
    calls.append([int(first), len(poly.points), create])
    write_rows(path, poly, first, total, create)
output.write_vtp_rows = counted
rows = {{}}
for name, n in (("flying-spaghetti-2d", 10000), ("flying-spaghetti-3d", 5000), ("flying-spaghetti-2d", 50)):
    scene = load(name)
    problem = scene.build(scene.values({{"n_elements": n}}), comm)
    out = output.OutDir({str(tmp_path)!r} + f"/{{name}}-{{n}}-np{{comm.size}}", comm)
    with out.claimed({{}}):
        writer = output.RunWriter(out, problem, 1, 2)
        calls.clear()
        writer.frame(0.0)
        data = open(out.file("centreline/frame_00000.vtp"), "rb").read() if comm.rank == 0 else b""
        rows[f"{{name}}-{{n}}"] = {{"calls": comm.allgather(list(calls)), "sha": hashlib.sha256(data).hexdigest(),
                                "left": sorted(f for f in os.listdir(out.file("centreline")) if f.startswith("."))}}
if comm.rank == 0:
    print(json.dumps(rows))
"""
    serial, parallel = script_on_ranks(script, timeout=600)
    for case, nodes in (("flying-spaghetti-2d-10000", 10001), ("flying-spaghetti-3d-5000", 10001)):
        assert parallel[case]["sha"] == serial[case]["sha"], case
        assert serial[case]["calls"] == [[]]
        half = nodes // 2
        assert parallel[case]["calls"] == [[[0, half, True], [0, half, False]], [[half, nodes - half, False]]], case
        assert parallel[case]["left"] == []
    short = "flying-spaghetti-2d-50"
    assert parallel[short]["sha"] == serial[short]["sha"]
    assert parallel[short]["calls"] == [[], []]


def test_a_full_disk_leaves_whole_rows_in_the_history(tmp_path):
    """Files limited to 12 kB (as on a full disk: history.csv reaches it first): the run ends with
    one line (exit 2), and history.csv holds whole rows only, each with every column (the row that
    did not fit is cut off, not left half written)."""
    import subprocess
    import sys

    from processes import environment
    out = tmp_path / "out"
    args = ["run", "flying-spaghetti-2d", "--set", "n_elements=4", "--set", "t_end=10", "--set", "dt=0.01",
            "--quiet", "--out", str(out)]
    code = ("import resource, sys\nfrom rodfem.app.cli import main\n"
            "resource.setrlimit(resource.RLIMIT_FSIZE, (12000, 12000))\n"
            f"sys.exit(main({args!r}))")
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=environment(), timeout=120)
    assert p.returncode == 2 and "cannot write history.csv" in p.stderr, p.stderr[-2000:]
    text = (out / "history.csv").read_text()
    assert text.endswith("\n") and 1000 < len(text) <= 12000
    lines = text.splitlines()
    assert all(len(line.split(",")) == len(lines[0].split(",")) for line in lines)
    np.array([[float(v) for v in line.split(",")] for line in lines[1:]])   # every value a number


def test_planar_stress_resultants_include_the_maxwell_branches(tmp_path):
    """The arc beam with a Maxwell branch (EA1, GA1, EI1 = 30, 20, 0.5; tau = 0.05): the exported
    N and M are the equilibrium spring's plus the branch's, N = (EA, GA) Gamma + (EA1, GA1) Gamma_1,
    M = EI kappa + EI1 kappa_1, from the state's own strains (they left the branch out, while the
    3D rod's included it)."""
    from rodfem.forms.planar_beam import PlanarBeam, maxwell, quadratic
    beam = PlanarBeam(1.0, 0.1, quadratic(EA=100.0, GA=50.0, EI=2.0),
                      branches=[maxwell(0.05, EA=30.0, GA=20.0, EI=0.5)])
    initial = {"r": lambda x: np.vstack([R_ARC * np.sin(x[0] / R_ARC), R_ARC * (1 - np.cos(x[0] / R_ARC))]),
               "phi": lambda x: x[0] / R_ARC}
    problem = Problem(beam, L_ARC, N_ARC, initial=initial, comm=COMM)
    write_run(problem, tmp_path, 0.01, 0.2, frames=2)
    surf = read_vtp(tmp_path / "surface" / "frame_00001.vtp")
    N, M = surf.cell_data["N"].values[1:-1:4], surf.cell_data["M"].values[1:-1:4]
    S = problem.space

    def cells(name, size):
        V, dofs = S.collapse(name)
        order = np.argsort(V.tabulate_dof_coordinates()[:, 0])
        return problem.x0.x.array[dofs].reshape(-1, size)[order]
    G, k, G1, k1 = cells("Gamma", 2), cells("kappa", 1)[:, 0], cells("Gamma_1", 2), cells("kappa_1", 1)[:, 0]
    assert np.max(np.abs(G1)) > 1e-4 and np.max(np.abs(k1)) > 1e-3     # the branch carries stress
    assert np.allclose(N, G * [100.0, 50.0] + G1 * [30.0, 20.0], rtol=1e-12, atol=1e-14)
    assert np.allclose(M, 2.0 * k + 0.5 * k1, rtol=1e-12, atol=1e-14)


def newell_normal(points):
    """The area-weighted normal of a planar polygon (its vertices in order): Newell's formula."""
    p, q = points, np.roll(points, -1, axis=0)
    return 0.5 * np.array([np.sum((p[:, 1] - q[:, 1]) * (p[:, 2] + q[:, 2])),
                           np.sum((p[:, 2] - q[:, 2]) * (p[:, 0] + q[:, 0])),
                           np.sum((p[:, 0] - q[:, 0]) * (p[:, 1] + q[:, 1]))])


def test_section_caps_face_outwards_and_carry_their_end_values(tmp_path):
    """A beam's surface: the cap at s = 0 faces -d1(0), the cap at s = L faces +d1(L) (their
    normals by Newell's formula from the vertex order, area w * w/2), and each cap carries its own end
    element's Gamma, kappa (on a section turned by phi = 0.3 s^2 along a straight line they differ
    from element to element)."""
    from rodfem.forms.planar_beam import PlanarBeam, quadratic
    beam = PlanarBeam(1.0, 0.1, quadratic(EA=100.0, GA=50.0, EI=2.0))
    # a straight centreline with the section turned by phi = 0.3 s^2: Gamma and kappa = 0.6 s vary along s
    problem = Problem(beam, L_ARC, N_ARC, initial={"r": lambda x: np.vstack([x[0], 0 * x[0]]),
                                                   "phi": lambda x: 0.3 * x[0] ** 2}, comm=COMM)
    write_run(problem, tmp_path, 0.01, 0.02, frames=2, section=0.1)
    c = read_vtp(tmp_path / "centreline" / "frame_00000.vtp")
    surf = read_vtp(tmp_path / "surface" / "frame_00000.vtp")
    phi = c.point_data["phi"].values
    d1 = np.column_stack([np.cos(phi), np.sin(phi), 0 * phi])
    polys = [np.asarray(p) for p in surf.polys]
    assert len(polys) == 4 * N_ARC + 2
    for cap, node, sign in ((polys[0], 0, -1.0), (polys[-1], -1, 1.0)):
        n = newell_normal(surf.points[cap])
        assert np.linalg.norm(n) == pytest.approx(0.1 * 0.05, rel=1e-12)
        assert sign * n @ d1[node] / np.linalg.norm(n) >= 1 - 1e-12
    for name in ("Gamma", "kappa"):
        values = surf.cell_data[name].values
        sides = values[1:-1:4]
        assert np.ptp(sides, axis=0).max() > 0.1                  # the element values differ along s
        assert np.array_equal(values[0], sides[0]) and np.array_equal(values[-1], sides[-1])


def test_pictures_name_the_bodies_only_when_there_are_few():
    """A legend for 2 to 12 bodies (and joints); none for one body, and none for a chain of 1000 links
    (its 1000 entries covered shapes.png)."""
    from types import SimpleNamespace

    from rodfem.io.animation import LEGEND, _names
    def bodies(n):
        return [SimpleNamespace(name=f"link{k}", kind="box") for k in range(n)]
    assert _names(bodies(1)) is None and _names(bodies(1000)) is None and _names(bodies(LEGEND + 1)) is None
    assert _names(bodies(3)) == ["link0", "link1", "link2"] and len(_names(bodies(LEGEND))) == LEGEND


@pytest.mark.mpi
def test_the_end_of_run_files_are_shared_out_and_a_failure_reaches_every_rank(tmp_path):
    """OutDir.do_each: serially every task runs on rank 0, on two ranks the second on rank 1 (view.py
    beside the plots); an OSError in a task on either rank ends the collective step with the same one-line
    InputError on every rank, none left waiting (run under a timeout)."""
    from processes import script_on_ranks
    script = f"""
import json, os
from mpi4py import MPI
from rodfem.errors import InputError
from rodfem.io.output import OutDir
comm = MPI.COMM_WORLD
out = OutDir({str(tmp_path)!r} + "/n" + str(comm.size), comm)
os.makedirs(out.path, exist_ok=True)
ran = []
out.do_each([("a", lambda: ran.append("a")), ("b", lambda: ran.append("b"))])
errors = []
for bad in (0, 1):
    def fail():
        raise OSError(28, "No space left on device")
    tasks = [("write the plots", fail if bad == 0 else (lambda: None)),
             ("write view.py", fail if bad == 1 else (lambda: None))]
    try:
        out.do_each(tasks)
    except InputError as e:
        errors.append(str(e))
rows = {{"ran": comm.allgather(ran), "errors": comm.allgather(errors)}}
if comm.rank == 0:
    print(json.dumps(rows))
"""
    serial, parallel = script_on_ranks(script, timeout=300)
    assert serial["ran"] == [["a", "b"]]
    assert parallel["ran"] == [["a"], ["b"]]
    for row in (serial, parallel):
        for errors in row["errors"]:
            assert len(errors) == 2
            assert "cannot write the plots (No space left on device)" in errors[0]
            assert "cannot write view.py (No space left on device)" in errors[1]


def test_many_bodies_share_one_file_per_model_kind_and_frame(tmp_path, monkeypatch):
    """More bodies than a legend shows (the 16-link chain): one centreline and one surface file per frame
    holds every rigid link (field data `bodies`, point array `body`: the index into it); each body's piece
    of it equals, array by array and cell by cell, the file of its own that a run written body by body
    gives (the same run with LEGEND raised); the .pvd lists one part per frame."""
    from rodfem.app.cli import main
    from rodfem.io import output
    from rodfem.io.vtk import piece, read_pvd
    args = ["run", "chain-1000", "--set", "t_end=0.05", "--set", "frames=3", "--quiet", "--out"]
    assert main(args + [str(tmp_path / "kinds")]) == 0
    monkeypatch.setattr(output, "LEGEND", 100)
    assert main(args + [str(tmp_path / "bodies")]) == 0
    names = [f"link{i}" for i in range(16)]
    for kind in ("centreline", "surface"):
        assert sorted(os.listdir(tmp_path / "kinds" / kind)) == [f"frame_{k:05d}_RigidBody.vtp" for k in range(3)]
        assert [(p, n) for _, p, _, n in read_pvd(tmp_path / "kinds" / f"{kind}.pvd")] == [(0, "RigidBody")] * 3
        assert len(os.listdir(tmp_path / "bodies" / kind)) == 3 * 16
        for k in range(3):
            merged = read_vtp(tmp_path / "kinds" / kind / f"frame_{k:05d}_RigidBody.vtp")
            assert merged.field_data["bodies"] == names
            assert merged.field_data["TimeValue"].values[0] == [0.0, 0.025, 0.05][k]
            own = [read_vtp(tmp_path / "bodies" / kind / f"frame_{k:05d}_{name}.vtp") for name in names]
            start = 0
            for j, body in enumerate(own):
                part = piece(merged, j)
                assert np.array_equal(part.points, body.points)
                assert set(part.point_data) == set(body.point_data)
                for a in body.point_data:
                    assert np.array_equal(part.point_data[a].values, body.point_data[a].values), (kind, a)
                for cells in ("verts", "lines", "polys"):   # the same cells, moved by the points before
                    mine = [c for c in getattr(merged, cells)
                            if start <= c.min() < start + len(body.points)]
                    assert [list(c - start) for c in mine] == [list(c) for c in getattr(body, cells)]
                start += len(body.points)
            for a, values in merged.cell_data.items():
                assert np.array_equal(values.values, np.concatenate([b.cell_data[a].values for b in own]))


def test_many_bodies_are_drawn_as_one_artist_per_kind_and_colour():
    """joined: up to LEGEND bodies each keeps its sketch; above, the bodies of one kind and colour become
    one sketch: the links' edges all kept, rods' centrelines and section directions one after the other
    with a NaN row between two bodies (a break in the drawn line, no segment joining them)."""
    from rodfem.io.animation import LEGEND, Sketch, joined
    rng = np.random.default_rng(1)
    links = [Sketch("link", rng.random((1, 3)), edges=rng.random((1, 2, 3))) for _ in range(LEGEND)]
    rods = [Sketch("rod", rng.random((5, 3)), d2=rng.random((5, 3))) for _ in range(4)]
    colours = ["a", "b"] * (LEGEND // 2) + ["a", "a", "b", "b"]
    marks = Sketch("marks", rng.random((3, 3)))
    same, _ = joined(links + [marks], colours[:LEGEND] + ["k"])
    assert same == links + [marks]
    out, cols = joined(links + rods + [marks], colours + ["k"])
    assert [(sk.kind, c) for sk, c in zip(out, cols)] == [("link", "a"), ("link", "b"), ("rod", "a"), ("rod", "b"),
                                                          ("marks", "k")]
    assert np.array_equal(out[0].edges, np.concatenate([sk.edges for sk in links[0::2]]))
    assert np.array_equal(out[1].line, np.concatenate([sk.line for sk in links[1::2]]))
    rod_a = out[2]
    assert rod_a.line.shape == (11, 3) and np.all(np.isnan(rod_a.line[5])) and np.all(np.isnan(rod_a.d2[5]))
    assert np.array_equal(rod_a.line[6:], rods[1].line) and np.array_equal(rod_a.d2[:5], rods[0].d2)


def test_segments_are_drawn_as_one_broken_line():
    """broken: n segments (two points each) become one polyline of 3n rows, each segment's points and then
    a NaN row (where matplotlib lifts the pen); drawn, the line's data are those rows in 2D and 3D."""
    from rodfem.io.animation import Canvas, Layout, Sketch, broken
    rng = np.random.default_rng(2)
    segments = rng.random((4, 2, 3))
    line = broken(segments)
    assert line.shape == (12, 3) and np.all(np.isnan(line[2::3]))
    assert np.array_equal(line[0::3], segments[:, 0]) and np.array_equal(line[1::3], segments[:, 1])
    for dim in (2, 3):
        sk = Sketch("link", rng.random((1, 3)), edges=segments if dim == 3 else segments * [1, 1, 0])
        canvas = Canvas(Layout([(0.0, [sk])], dim, 0.1), "")
        art = canvas.draw([sk], ["tab:blue"])[0][0]
        data = np.column_stack(art.get_data_3d() if dim == 3 else art.get_data())
        assert np.array_equal(data, broken(sk.edges[:, :, list(canvas.axes)]), equal_nan=True)
        canvas.close()
