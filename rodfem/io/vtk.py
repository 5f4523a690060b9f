"""VTK XML files written with numpy and the standard library: PolyData (.vtp) and time series (.pvd).

A .vtp piece holds points and any of vertices, polylines and polygons, with point and cell data;
its arrays are appended raw binary (the file's AppendedData: for each array a UInt64 byte count
followed by the little-endian values, at the `offset` its DataArray element gives), field data
inline binary (base64 of the same): encodings VTK and ParaView read without an extension and that
`read_vtp` (below, for tests and scripts) reads back.  (Inline base64 for every array took twice as
long to write and a third more disk: a frame of 10^5 planar elements 80 ms and 23 MB, 40 and 17 raw.)
Arrays may name their components (ComponentName0, ...: ParaView shows them).
The point and cell data may name their active attributes (``<PointData Normals="d2" Vectors="v"
Scalars="speed">``: what Glyph, Tube and colouring take by default).  Field data (one set per
file) holds numbers, e.g. TimeValue (the frame's time: a series of .vtp files opened without the
.pvd gets its times from it), and lists of strings (a String array of null-terminated strings).
The bytes depend on the values only: the same state gives the same file on any number of ranks.
"""
import base64
import os
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from xml.sax.saxutils import quoteattr

import numpy as np

_TYPES = {np.dtype("float64"): "Float64", np.dtype("float32"): "Float32", np.dtype("int64"): "Int64",
          np.dtype("int32"): "Int32", np.dtype("uint8"): "UInt8"}
_DTYPES = {v: k for k, v in _TYPES.items()}


@dataclass
class Array:
    """A data array: values (n,) or (n, components), optional component names."""
    values: np.ndarray
    components: tuple = ()


@dataclass
class PolyData:
    """points (n, 3); verts, lines, polys: lists of index arrays (one per cell, in that VTK order);
    point_data, cell_data: dict name -> Array (cell data in the order verts, lines, polys)."""
    points: np.ndarray
    verts: list = field(default_factory=list)
    lines: list = field(default_factory=list)
    polys: list = field(default_factory=list)
    point_data: dict = field(default_factory=dict)
    cell_data: dict = field(default_factory=dict)
    active: dict = field(default_factory=dict)        # {"PointData" | "CellData": {"Normals": name, ...}}
    field_data: dict = field(default_factory=dict)    # name -> numbers (Array) or a list of strings

ATTRIBUTES = ("Scalars", "Vectors", "Normals", "Tensors", "TCoords")


def _encode(values):
    data = np.ascontiguousarray(values).astype(values.dtype.newbyteorder("<"), copy=False).tobytes()
    return base64.b64encode(np.uint64(len(data)).tobytes() + data)


def _strings(name, strings, indent=6):
    """A String DataArray: the strings' UTF-8 bytes, each ended by a null byte."""
    data = b"".join(s.encode() + b"\0" for s in strings)
    return (b" " * indent + f'<DataArray type="String" Name={quoteattr(name)} NumberOfTuples="{len(strings)}" '
            f'format="binary">'.encode() + base64.b64encode(np.uint64(len(data)).tobytes() + data)
            + b"</DataArray>\n")


@dataclass
class Block:
    """One array of a file's appended data: `data` the bytes at hand (a file written in rows: this rank's
    rows), `size` the array's whole byte count, `row` the bytes of one of its rows (0: not written in rows)."""
    data: memoryview
    size: int
    row: int = 0


def _array(name, arr, components=(), indent=8, tuples=False, appended=None, rows=None):
    """The bytes of one DataArray element (`tuples`: with NumberOfTuples, as field data needs); `appended`
    (a list of the file's appended Blocks): its values appended there, the element giving their offset
    (`rows`: the array's whole number of rows, of which `arr` holds some)."""
    values = np.asarray(arr)
    if values.dtype.kind == "f":
        values = values.astype(np.float64, copy=False)
    elif values.dtype.kind in "iu" and values.dtype not in _TYPES:
        values = values.astype(np.int64)
    ncomp = 1 if values.ndim == 1 else values.shape[1]
    attrs = {"type": _TYPES[values.dtype], "NumberOfComponents": str(ncomp),
             "format": "binary" if appended is None else "appended"}
    if appended is not None:
        attrs["offset"] = str(sum(8 + b.size for b in appended))
    if name:
        attrs["Name"] = name
    if tuples:
        attrs["NumberOfTuples"] = str(len(values))
    for i, c in enumerate(components[:ncomp] if ncomp > 1 else ()):
        attrs[f"ComponentName{i}"] = str(c)
    head = " ".join(f'{k}={quoteattr(v)}' for k, v in attrs.items())
    if appended is None:
        return b" " * indent + f"<DataArray {head}>".encode() + _encode(values) + b"</DataArray>\n"
    data = memoryview(np.ascontiguousarray(values).astype(values.dtype.newbyteorder("<"), copy=False)).cast("B")
    row = values.dtype.itemsize * ncomp
    appended.append(Block(data, row * rows if rows is not None else len(data), row if rows is not None else 0))
    return b" " * indent + f"<DataArray {head}/>\n".encode()


def _cells(tag, cells, appended):
    sizes = np.array([len(c) for c in cells], dtype=np.int64)
    conn = np.concatenate(cells).astype(np.int64) if cells else np.zeros(0, np.int64)
    return (f"      <{tag}>\n".encode() + _array("connectivity", conn, appended=appended)
            + _array("offsets", np.cumsum(sizes), appended=appended) + f"      </{tag}>\n".encode())


def merge(polys, index="body"):
    """One PolyData of several with the same arrays: their points and cells one after the other (cell data
    kept in VTK's order: all vertices, then all lines, then all polygons) and a point array `index`, the
    number of the PolyData each point came from (`piece` takes one back out)."""
    starts = np.cumsum([0] + [len(p.points) for p in polys])
    out = PolyData(points=np.concatenate([np.asarray(p.points, dtype=np.float64).reshape(-1, 3) for p in polys]),
                   active=polys[0].active)
    kinds = ("verts", "lines", "polys")
    for kind in kinds:
        setattr(out, kind, [c + start for p, start in zip(polys, starts) for c in getattr(p, kind)])
    out.point_data = {name: Array(np.concatenate([p.point_data[name].values for p in polys]), a.components)
                      for name, a in polys[0].point_data.items()}
    for name, a in polys[0].cell_data.items():
        parts = {kind: [] for kind in kinds}
        for p in polys:
            bounds = np.cumsum([0] + [len(getattr(p, kind)) for kind in kinds])
            for j, kind in enumerate(kinds):
                parts[kind].append(p.cell_data[name].values[bounds[j]:bounds[j + 1]])
        out.cell_data[name] = Array(np.concatenate([v for kind in kinds for v in parts[kind]]), a.components)
    out.point_data[index] = Array(np.repeat(np.arange(len(polys), dtype=np.int32), np.diff(starts)))
    return out


def piece(poly, k, index="body"):
    """The points and point data of the k-th PolyData of a `merge` (no cells)."""
    mine = np.asarray(poly.point_data[index].values) == k
    return PolyData(points=np.asarray(poly.points)[mine],
                    point_data={name: Array(np.asarray(a.values)[mine], a.components)
                                for name, a in poly.point_data.items() if name != index})


def _layout(poly, total=None):
    """(head, blocks, tail) of the file of `poly`: the bytes before the appended data, its appended arrays
    (Blocks, in order) and the bytes after them.  `total`: the whole file's number of points, of which
    poly holds the point rows (points and point data; its cells are the whole file's, its cell data none)."""
    rows = total if total is not None else len(poly.points)
    parts = [b'<?xml version="1.0" encoding="utf-8"?>\n'
             b'<VTKFile type="PolyData" version="1.0" byte_order="LittleEndian" header_type="UInt64">\n'
             b"  <PolyData>\n"]
    if poly.field_data:
        parts.append(b"    <FieldData>\n")
        parts += [_strings(name, v) if isinstance(v, (list, tuple)) else
                  _array(name, np.atleast_1d(v.values), v.components, indent=6, tuples=True)
                  for name, v in poly.field_data.items()]
        parts.append(b"    </FieldData>\n")
    appended = []   # the Piece's arrays, in the order of their elements
    parts += [f'    <Piece NumberOfPoints="{rows}" NumberOfVerts="{len(poly.verts)}" '
              f'NumberOfLines="{len(poly.lines)}" NumberOfStrips="0" NumberOfPolys="{len(poly.polys)}">\n'.encode()]
    for tag, data in (("PointData", poly.point_data), ("CellData", poly.cell_data)):
        active = "".join(f" {k}={quoteattr(v)}" for k, v in poly.active.get(tag, {}).items() if v in data)
        parts.append(f"      <{tag}{active}>\n".encode())
        parts += [_array(name, a.values, a.components, appended=appended, rows=rows if tag == "PointData" else None)
                  for name, a in data.items()]
        parts.append(f"      </{tag}>\n".encode())
    parts += [b"      <Points>\n",
              _array("", np.asarray(poly.points, dtype=np.float64).reshape(-1, 3), appended=appended, rows=rows),
              b"      </Points>\n"]
    parts += [_cells(tag, cells, appended) for tag, cells in (("Verts", poly.verts), ("Lines", poly.lines),
                                                              ("Strips", []), ("Polys", poly.polys))]
    parts.append(b'    </Piece>\n  </PolyData>\n  <AppendedData encoding="raw">\n   _')
    return b"".join(parts), appended, b"\n  </AppendedData>\n</VTKFile>\n"


def write_vtp(path, poly):
    """Write `poly` (a PolyData) to `path` as a VTK XML PolyData file."""
    head, blocks, tail = _layout(poly)
    with open(path, "wb") as f:
        f.write(head)
        for block in blocks:   # (the arrays' own memory: no copy of the whole file)
            f.write(np.uint64(block.size).tobytes())
            f.write(block.data)
        f.write(tail)


def _pwrite(fd, data, at):
    data = memoryview(data).cast("B")
    while len(data):
        n = os.pwrite(fd, data, at)
        data, at = data[n:], at + n


def write_vtp_rows(path, poly, first, total, create):
    """Write the point rows first, first + 1, ... of a file of `total` points, held by `poly` (its points and
    point data; every writer's poly has the same arrays, field data and cells).  `create` (one writer, before
    the others): the file, sized to its whole length, its text, byte counts and cells; then each writer
    (the creator too) its rows, at their places.  The writers together write the bytes `write_vtp` writes."""
    head, blocks, tail = _layout(poly, total)
    fd = os.open(path, os.O_WRONLY | (os.O_CREAT | os.O_TRUNC if create else 0), 0o644)
    try:
        at = len(head)
        if create:
            _pwrite(fd, head, 0)
        for block in blocks:
            if create:
                _pwrite(fd, np.uint64(block.size).tobytes(), at)
                if not block.row:
                    _pwrite(fd, block.data, at + 8)
            elif block.row:
                _pwrite(fd, block.data, at + 8 + first * block.row)
            at += 8 + block.size
        if create:
            _pwrite(fd, tail, at)
    finally:
        os.close(fd)


def write_pvd(path, datasets):
    """A time series: datasets = [(t, part, file, name)], one entry per time and part (block)."""
    root = ET.Element("VTKFile", type="Collection", version="0.1")
    coll = ET.SubElement(root, "Collection")
    for t, part, file, name in datasets:
        attrs = {"timestep": repr(float(t)), "part": str(part), "file": file}
        if name:
            attrs["name"] = name
        ET.SubElement(coll, "DataSet", attrs)
    ET.indent(root) if hasattr(ET, "indent") else None
    ET.ElementTree(root).write(path, encoding="utf-8", xml_declaration=True)


# -- reading back (tests, scripts) ---------------------------------------------------------

def _decode(el, appended=b""):
    if el.get("format") == "appended":
        start = int(el.get("offset"))
        n = int(np.frombuffer(appended[start:start + 8], dtype="<u8")[0])
        raw = appended[start:start + 8 + n]
    elif el.get("format") == "binary":
        raw = base64.b64decode(el.text.strip()) if el.text else b""
    else:
        raise ValueError("read_vtp reads the binary and appended raw arrays write_vtp writes")
    n = int(np.frombuffer(raw[:8], dtype="<u8")[0])
    if el.get("type") == "String":
        return [t.decode() for t in raw[8:8 + n].split(b"\0")[:-1]]
    values = np.frombuffer(raw[8:8 + n], dtype=_DTYPES[el.get("type")].newbyteorder("<"))
    ncomp = int(el.get("NumberOfComponents", "1"))
    values = values.reshape(-1, ncomp) if ncomp > 1 else values
    comps = tuple(el.get(f"ComponentName{i}") for i in range(ncomp) if el.get(f"ComponentName{i}") is not None)
    return Array(values.copy(), comps)


def read_vtp(path):
    """The PolyData of a file written by `write_vtp`."""
    with open(path, "rb") as f:
        text = f.read()
    at = text.find(b"<AppendedData")
    appended = b""
    if at >= 0:   # (the XML before it, closed; the raw blocks after its "_")
        appended = memoryview(text)[text.index(b"_", at) + 1:]
        text = text[:at] + b"</VTKFile>"
    root = ET.fromstring(text)
    piece = root.find("PolyData/Piece")
    out = PolyData(points=_decode(piece.find("Points/DataArray"), appended).values)
    for tag, attr in (("Verts", "verts"), ("Lines", "lines"), ("Polys", "polys")):
        el = piece.find(tag)
        if el is None:
            continue
        arrays = {a.get("Name"): _decode(a, appended).values for a in el.findall("DataArray")}
        ends = arrays["offsets"]
        starts = np.concatenate([[0], ends[:-1]]).astype(int)
        setattr(out, attr, [arrays["connectivity"][a:b] for a, b in zip(starts, ends)])
    for tag, attr in (("PointData", "point_data"), ("CellData", "cell_data")):
        for a in piece.findall(f"{tag}/DataArray"):
            getattr(out, attr)[a.get("Name")] = _decode(a, appended)
        el = piece.find(tag)
        if el is not None and any(k in el.attrib for k in ATTRIBUTES):
            out.active[tag] = {k: v for k, v in el.attrib.items() if k in ATTRIBUTES}
    for a in root.findall("PolyData/FieldData/DataArray"):
        out.field_data[a.get("Name")] = _decode(a)
    return out


def read_pvd(path):
    """[(t, part, file, name)] of a .pvd file."""
    root = ET.parse(path).getroot()
    return [(float(d.get("timestep")), int(d.get("part", 0)), d.get("file"), d.get("name", ""))
            for d in root.iter("DataSet")]
