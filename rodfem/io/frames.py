"""The two VTK pictures of a body at one frame (rank 0): its centreline and its surface.

centreline  one vtkPolyLine through the nodes in order of s (a rigid body: one vertex), point data:
            s, the nodal state fields (velocities, directors, multipliers, ...), the section frame
            d1, d2, d3 (a planar model's d1, d2 from phi; its d3 is e_z), and the model's derived fields
            (strains, stress resultants) at the nodes: exact inside a cell, the mean of the two
            cells' values at a node between cells (where such a field jumps).
surface     the section swept along the centreline (rodfem/io/sections.py), one ring per node (at
            most MAX_SEGMENTS segments per body: more nodes are thinned evenly), point data s and
            the velocities, cell data the derived fields of the segment, exact at its
            midpoint (strains and stress resultants cell by cell, jumps included); a rigid body: its box.
Planar models are drawn in the plane z = 0 (2-vectors get z = 0).

Active attributes (what ParaView's filters take by default): the centreline's Normals are d2 (a
4-sided Tube then follows the section, Glyph orients by it), Vectors the velocity, Scalars the speed
|v| (s without a velocity); the surface's Vectors and Scalars the same.
"""
import numpy as np

from rodfem.io.sections import Section, box, link, rotation_minimizing, section_points, stride, sweep
from rodfem.io.snapshot import at_midpoints, at_nodes
from rodfem.io.vtk import Array, PolyData

MAX_SEGMENTS = 1000
FRAME_LABEL = "section frame {} (d1: the axis; d2 (width) and d3 (height) span the section)"


def components(labels, name, size):
    """Component names of an array (from the model's labels; x, y, z for an unlabelled 2- or 3-vector)."""
    comps = tuple(labels.get(name, ("", ()))[1])
    if not comps and size in (2, 3):
        comps = ("x", "y", "z")[:size]
    return comps


def _array(labels, name, values):
    values = np.asarray(values, dtype=float)
    values = values[:, 0] if values.ndim == 2 and values.shape[1] == 1 else values
    comps = components(labels, name, 1 if values.ndim == 1 else values.shape[1])
    if values.ndim == 2 and values.shape[1] == 2 and comps == ("x", "y"):   # a planar vector: z = 0
        values, comps = np.column_stack([values, np.zeros(len(values))]), ("x", "y", "z")
    return Array(values, comps)


SPEED = "speed"


def point_arrays(state, labels, rings=None, keep=None, velocity=None):
    """{name: Array} of the nodal fields (and frame) of `state`, at the nodes `rings` (all by default);
    only s and the fields named in `keep`, if given; the speed |velocity| if `velocity` names a field."""
    pick = slice(None) if rings is None else rings
    out = {}
    if state.kind in ("rod", "line"):
        out["s"] = Array(state.s[pick])
    for name, vals in state.fields.items():
        if keep is None or name in keep:
            out[name] = _array(labels, name, vals[pick])
    if velocity in state.fields:
        out[SPEED] = Array(np.linalg.norm(state.fields[velocity][pick], axis=1))
    if state.directors is not None and keep is None:
        for i in range(3 if state.dim == 3 else 2):       # (a planar model's d3 is e_z)
            name = f"d{i + 1}"
            if name not in out:
                out[name] = Array(state.directors[pick, :, i], ("x", "y", "z"))
    return out


def active(point_data, velocity):
    """The active attributes of point data: Normals d2, Vectors the velocity, Scalars the speed (or s)."""
    return {"Normals": "d2", "Vectors": velocity, "Scalars": SPEED if SPEED in point_data else "s"}


def centreline(state, labels, velocity=None, lead=0, total=None):
    """The centreline PolyData of a BodyState (`velocity`: the name of its velocity field, if written).
    Of some of the nodes of a body (snapshot.rows_of): its point rows, `lead` the place of its first node
    among the nodes of its cells, `total` the body's number of nodes (its polyline's)."""
    n = len(state.position)
    poly = PolyData(points=state.position)
    if state.kind in ("rod", "line"):
        poly.lines = [np.arange(total or n)]
    else:
        poly.verts = [np.arange(n)]
    poly.point_data = point_arrays(state, labels, velocity=velocity)
    for name, vals in state.cells.items():
        if name != "s":
            poly.point_data[name] = _array(labels, name, at_nodes(vals, state.degree)[lead:lead + n])
    poly.active["PointData"] = active(poly.point_data, velocity)
    return poly


def drawn_section(model, width, given=0.0):
    """The Section drawn for a rod: the model's (the scene's physical section) unless a drawing width
    is `given` (> 0); else a width x width/2 rectangle."""
    if getattr(model, "section", None) is not None and not given:
        return model.section
    return Section.rectangle(width, 0.5 * width)


def surface(state, labels, width, box_size, keep=(), velocity=None, section=None):
    """The surface PolyData of a BodyState: a rod's `section` (a Section; default a width x width/2
    rectangle), a string's round tube (diameter width/2), a rigid body's box of edges
    box_size(state.box, width) or, if the scene gives its link points (``model.link``), its `section`
    along them.  Point data: s and the nodal fields named in `keep` (the velocities);
    cell data: the derived fields."""
    if state.kind in ("box", "point"):
        frame = state.directors[0] if state.directors is not None else np.eye(3)
        if state.link is not None:          # the scene's drawing: a link through its points
            points, polys = link(state.position[0], frame, state.link, section or Section.round(width / 4))
            return PolyData(points=points, polys=polys)
        points, polys = box(state.position[0], frame, box_size(state.box, width))
        return PolyData(points=points, polys=polys)
    n = len(state.position)
    rings = stride(n, MAX_SEGMENTS)
    centre = state.position[rings]
    fan = False
    if state.kind == "rod":
        e2, e3 = state.directors[rings, :, 1], state.directors[rings, :, 2]
        section = section or Section.rectangle(width, 0.5 * width)
        fan = section.shape == "round"
        section = section.points()
    else:
        e2, e3 = rotation_minimizing(centre)
        section = section_points(0.5 * width, 0.5 * width, round_=True)
    points, polys = sweep(centre, e2, e3, section, caps=state.kind == "rod", fan=fan)
    m = len(section)
    poly = PolyData(points=points, polys=polys)
    centres = [0, -1] if fan else []        # the caps' centre points (fan caps), last
    poly.point_data = {k: Array(np.concatenate([np.repeat(a.values, m, axis=0), a.values[centres]]), a.components)
                       for k, a in point_arrays(state, labels, rings, keep, velocity).items()}
    poly.active["PointData"] = {k: v for k, v in active(poly.point_data, velocity).items() if k != "Normals"}
    # the segment of a surface segment [rings[j], rings[j+1]]: the node segment at its middle
    seg = (rings[:-1] + rings[1:] - 1) // 2
    order = np.repeat(seg, m)
    if state.kind == "rod":                 # the caps take the values of the end segments
        cap = m if fan else 1
        order = np.concatenate([[seg[0]] * cap, order, [seg[-1]] * cap])
    for name, vals in state.cells.items():
        if name != "s":
            poly.cell_data[name] = _array(labels, name, at_midpoints(vals)[order])
    return poly


def describe(state, labels, omitted, keep=(), velocity=None, units=None):
    """What the files hold for this body: {file: {array: {"components", "description", "unit"}}}
    (fields.json); `units`: {array: SI unit} (every array's, rodfem/io/output.py)."""
    def entry(name, arr):
        what = labels.get(name, ("", ()))[0]
        if not what and name.startswith("d") and name[1:] in "123":
            what = FRAME_LABEL.format(name)
        if name == "s":
            what = "arc length of the reference configuration"
        if name == SPEED:
            what = f"speed |{velocity}|"
        return {"components": list(arr.components), "description": what, "unit": (units or {}).get(name, "")}
    cl = centreline(state, labels, velocity)
    nodal = {k: entry(k, a) for k, a in cl.point_data.items()}
    derived = [k for k in state.cells if k != "s"]
    for k in derived:
        nodal[k]["description"] += "; at a node between two cells the mean of their values"
    out = {"kind": state.kind, "centreline point data": nodal,
           "active attributes": {k: v for k, v in cl.active["PointData"].items() if v in nodal}}
    if state.kind in ("rod", "line"):
        out["surface point data"] = {k: v for k, v in nodal.items() if k in ("s", SPEED) or k in keep}
        out["surface cell data"] = {k: dict(nodal[k], description=labels.get(k, ("", ()))[0] +
                                            "; the value at the segment's midpoint") for k in derived}
    if omitted:
        out["omitted"] = {k: "not written: the model has no inertia here (statics through the integrator), "
                             "so its velocities are not the body's motion" for k in omitted}
    return out
