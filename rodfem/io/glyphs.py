"""Joints, components and supports of a run, drawn as glyphs in a block of their own (joints.pvd).

A `Mark` is one of them: a joint, servo or component (spring, damper, control law) between two
points, each a point of a body (a rod end, a node, a rigid body's point at an offset in its frame)
or of the ground; or a support at a flexible body's end.  At every frame its points are where the
body's state puts them (the model's ``frame(q, offset)``, the one the joints use): a vertex per
point, and a line between the two points of a joint or component when they are apart (a spring,
a guide's ground point and its slider).  Point data: `mark` (the mark's index, for colouring),
`ground` (1 at a ground point); field data `marks`: "index name (what)".  The pictures draw the
same points as markers.
"""
from dataclasses import dataclass

import numpy as np

from rodfem.io.vtk import Array, PolyData


@dataclass
class Mark:
    name: str
    what: str          # "joint", "component", "support clamped", ...
    points: tuple      # ((body name or None for the ground, where, offset, s), ...)


def _point(p):
    return (None if p.body is None else p.body.name, p.where, tuple(p.offset), p.s)


def marks_of(problem):
    """The Marks of a Problem or System: its joints (and servos), components, and supports."""
    out = []
    for kind, items in (("joint", getattr(problem, "joints", [])), ("component", getattr(problem, "components", []))):
        for j in items:
            out.append(Mark(j.name, kind, (_point(j.a), _point(j.b))))
    placed = getattr(problem, "distributed", False)   # (each body on one rank: every rank knows them all)
    for name, body in ([(n, ref.body) for n, ref in problem.bodies.items()] if placed else problem.body_items()):
        for sup in getattr(body, "supports", []):
            label = f"{name}.{sup.end}" if name else sup.end
            out.append(Mark(label, f"support {sup.kind}", ((name, sup.end, (), None),)))
    return out


def locate(point, states, models):
    """The 3D position of a Mark's point in the BodyStates `states` {body name: state}."""
    body, where, offset, s = point
    if body is None:                         # the ground: its offset is the position
        x = np.zeros(3)
        x[:len(offset)] = offset
        return x
    state, model = states[body], models[body]
    i = {"left": 0, "right": -1, "body": 0}.get(where)
    if i is None:                             # a node at s
        i = int(np.argmin(np.abs(state.s - s)))
    dim = state.dim
    q = {model.position: state.position[i, :dim], **{k: v[i] for k, v in state.fields.items()}}
    frame = getattr(model, "frame", None)
    x = np.asarray(frame(q, offset).x if frame is not None and any(offset) else q[model.position], dtype=float)
    out = np.zeros(3)
    out[:len(x)] = x
    return out


def glyphs(marks, states, models):
    """The PolyData of the marks at one frame (see the module docstring)."""
    points, ids, ground, lines = [], [], [], []
    for k, mark in enumerate(marks):
        first = len(points)
        for p in mark.points:
            points.append(locate(p, states, models))
            ids.append(k)
            ground.append(1 if p[0] is None else 0)
        if len(mark.points) == 2 and np.linalg.norm(points[-1] - points[-2]) > 0:
            lines.append(np.array([first, first + 1]))
    poly = PolyData(points=np.array(points).reshape(-1, 3), verts=[np.arange(len(points))] if points else [],
                    lines=lines)
    poly.point_data = {"mark": Array(np.array(ids, dtype=np.int32)), "ground": Array(np.array(ground, dtype=np.int32))}
    poly.active["PointData"] = {"Scalars": "mark"}
    poly.field_data = {"marks": [f"{k} {m.name} ({m.what})" for k, m in enumerate(marks)]}
    return poly
