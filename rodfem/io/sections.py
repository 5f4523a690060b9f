"""Surfaces of bodies for pictures (numbers only): a section swept along a centreline, a box.

A rod's section is the physical one where the scene gives it (`Section`, the model's ``section``:
a circle of the rod's radius with a marker fin along d2, so that twist shows, or a width x height
rectangle along d2, d3), otherwise a rectangle of width `width` along d2 and height `width`/2
along d3; it is placed at every ring (a node of the centreline) and oriented by the directors
there, so that bending, shear and twist show on the surface itself.  A string, which has no section frame, gets a round
tube oriented by a rotation-minimizing frame.  A rigid body is a box along its directors.
Polygons are quads between consecutive rings (and a cap at each end of a rod), wound so that
their normals point outwards.
"""
from dataclasses import dataclass

import numpy as np

RECTANGLE = np.array([[1.0, 1.0], [-1.0, 1.0], [-1.0, -1.0], [1.0, -1.0]]) * 0.5   # (d2, d3) corners
CIRCLE_SIDES = 12
ROUND_SIDES = 24      # a round rod section: 24 points on the circle ...
FIN = 1.25            # ... the one along d2 moved out to FIN x radius: a marker fin along the rod


@dataclass(frozen=True)
class Section:
    """A rod's cross-section as drawn: "round" (diameter `width`; `height` = `width`) or "rectangle"
    (`width` along d2, `height` along d3), in m.  A scene gives its rod's physical section as the
    model's ``section`` attribute: ``model.section = Section.round(radius)``."""
    shape: str
    width: float
    height: float

    @classmethod
    def round(cls, radius):
        return cls("round", 2.0 * float(radius), 2.0 * float(radius))

    @classmethod
    def rectangle(cls, width, height):
        return cls("rectangle", float(width), float(height))

    def points(self):
        """(m, 2) section coordinates along (d2, d3): the rectangle's corners, or the circle's points
        (the first, on d2, at FIN x radius: the marker fin)."""
        if self.shape == "rectangle":
            return RECTANGLE * [self.width, self.height]
        a = 2 * np.pi * np.arange(ROUND_SIDES) / ROUND_SIDES
        r = np.full(ROUND_SIDES, 0.5 * self.width)
        r[0] *= FIN
        return np.column_stack([r * np.cos(a), r * np.sin(a)])

    def describe(self):
        """For fields.json."""
        if self.shape == "round":
            return {"shape": "round", "diameter": self.width, "unit": "m",
                    "marker": f"a fin along +d2 to {FIN:g} x the radius (twist shows)"}
        return {"shape": "rectangle", "width (along d2)": self.width, "height (along d3)": self.height, "unit": "m"}


def section_points(width, height, round_):
    """(m, 2) section coordinates along (d2, d3): a width x height rectangle or a round section."""
    if round_:
        a = 2 * np.pi * np.arange(CIRCLE_SIDES) / CIRCLE_SIDES
        return 0.5 * np.column_stack([width * np.cos(a), height * np.sin(a)])
    return RECTANGLE * [width, height]


def sweep(centre, e2, e3, section, caps=True, fan=False):
    """Points (rings * m, 3) and quads of `section` (m, 2) swept along `centre` (rings, 3) with section
    axes e2, e3 (rings, 3) at every ring; caps close both ends: one polygon each, or (`fan`: a section
    that is not convex) m triangles each about the ring's centre (two points more, last).
    Returns (points, polys)."""
    n, m = len(centre), len(section)
    a, b = section[None, :, 0, None], section[None, :, 1, None]
    points = centre[:, None, :] + a * e2[:, None, :] + b * e3[:, None, :]
    i = np.arange(n - 1)[:, None] * m
    j = np.arange(m)[None, :]
    jn = (j + 1) % m
    quads = np.stack([i + j, i + jn, i + m + jn, i + m + j], axis=-1).reshape(-1, 4)
    polys = list(quads)
    points = points.reshape(-1, 3)
    if caps and n > 1 and fan:
        c0, c1 = n * m, n * m + 1
        first = [np.array([c0, (k + 1) % m, k]) for k in range(m)]
        last = [np.array([c1, (n - 1) * m + k, (n - 1) * m + (k + 1) % m]) for k in range(m)]
        return np.concatenate([points, centre[[0, -1]]]), first + polys + last
    if caps and n > 1:
        polys = [np.arange(m)[::-1]] + polys + [(n - 1) * m + np.arange(m)]
    return points, polys


def rotation_minimizing(centre):
    """Section axes (e2, e3) along a polyline without a frame of its own (a string): the double
    reflection method (Wang et al. 2008) from a normal to the first tangent."""
    t = np.gradient(centre, axis=0) if len(centre) > 1 else np.array([[1.0, 0.0, 0.0]])
    t /= np.maximum(np.linalg.norm(t, axis=1, keepdims=True), 1e-300)
    e2 = np.empty_like(t)
    ref = np.eye(3)[np.argmin(np.abs(t[0]))]
    e2[0] = np.cross(t[0], ref)
    e2[0] /= np.linalg.norm(e2[0])
    for i in range(len(t) - 1):
        v1 = centre[i + 1] - centre[i]
        c1 = v1 @ v1
        if c1 == 0:
            e2[i + 1] = e2[i]
            continue
        rL = e2[i] - 2 / c1 * (v1 @ e2[i]) * v1
        tL = t[i] - 2 / c1 * (v1 @ t[i]) * v1
        v2 = t[i + 1] - tL
        c2 = v2 @ v2
        e2[i + 1] = rL - 2 / c2 * (v2 @ rL) * v2 if c2 > 0 else rL
    e3 = np.cross(t, e2)
    return e2, e3


def link(centre, frame, offsets, section):
    """A rigid body drawn as a link: `section` (a Section) swept straight from point to point of
    `offsets` (k, 3, in the body frame: the columns of `frame`, about `centre`), each piece turned
    with the director most across it.  Returns (points, polys) (each piece capped)."""
    pts = centre + np.asarray(offsets, dtype=float) @ np.asarray(frame).T
    points, polys, n = [], [], 0
    for a, b in zip(pts[:-1], pts[1:]):
        t = (b - a) / max(np.linalg.norm(b - a), 1e-300)
        d = frame[:, np.argmin(np.abs(frame.T @ t))]
        e2 = d - (d @ t) * t
        e2 /= np.linalg.norm(e2)
        e3 = np.cross(t, e2)
        p, q = sweep(np.array([a, b]), np.array([e2, e2]), np.array([e3, e3]), section.points(),
                     fan=section.shape == "round")
        points.append(p)
        polys += [c + n for c in q]
        n += len(p)
    return np.concatenate(points), polys


def box(centre, frame, edges):
    """Points (24, 3) and 6 quads of a box centred at `centre` with axes the columns of `frame`
    (3, 3) and edge lengths `edges` (3,): four points per face, so that each face is flat-shaded."""
    corners = np.array([[i, j, k] for i in (-0.5, 0.5) for j in (-0.5, 0.5) for k in (-0.5, 0.5)])
    pts = centre + (corners * edges) @ np.asarray(frame).T
    faces = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    points = np.concatenate([pts[list(f)] for f in faces])
    return points, [np.arange(4 * q, 4 * q + 4) for q in range(6)]


def box_edges(centre, frame, edges):
    """The 12 edges of that box as segments (12, 2, 3) (for line drawings)."""
    corners = np.array([[i, j, k] for i in (-0.5, 0.5) for j in (-0.5, 0.5) for k in (-0.5, 0.5)])
    pts = centre + (corners * edges) @ np.asarray(frame).T
    pairs = [(a, b) for a in range(8) for b in range(a + 1, 8) if bin(a ^ b).count("1") == 1]
    return np.array([[pts[a], pts[b]] for a, b in pairs])


def stride(n, most):
    """Indices 0 = i_0 < ... < i_m = n - 1 of at most `most` + 1 evenly spread rings of n nodes."""
    if n <= most + 1:
        return np.arange(n)
    return np.unique(np.linspace(0, n - 1, most + 1).round().astype(int))
