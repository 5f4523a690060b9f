"""Pictures of the motion: shapes.png (shapes over time) and animation.gif (one picture per frame).

A `Sketch` is what the pictures keep of a body at one frame (a few hundred points at most, so
that a long run at 10^5 elements costs little memory): its centreline, the section direction d2
along it for a rod (drawn as a ribbon with rungs across it, which turn with the section, so
bending, shear and twist show), the edges of a rigid body's box, or a point mass's point.

What is drawn (`Layout`): a planar model, or a 3D model whose motion stays in a coordinate plane
(a coordinate constant to 1e-9 of the extent; z first), in 2D on the other two axes; otherwise in 3D.
The axes have equal scales and name their coordinate with its unit (m).  The animation's window
has one size for all frames, the largest extent of the bodies in one frame (plus a margin): it is
fixed when the whole motion fits in 2.5 times that size, and otherwise follows the bodies' centre
frame by frame (the tick labels then move with it: the scale stays).  Every body has its colour
(named in a legend when there are 2 to 12), the time is written on every frame.  shapes.png
overlays up to 16 frames (8 for several bodies) in the window of the whole motion, their time as
the shade of each body's colour, with a time colour bar.
The GIF is drawn with matplotlib, one figure updated frame by frame, and saved with Pillow.
"""
from dataclasses import dataclass

import numpy as np

from rodfem.io.sections import box_edges, stride

LINE_POINTS = 400     # most centreline points kept per body and frame
RUNGS = 24            # rungs drawn across a rod
FOLLOW = 2.5          # the window follows the bodies when the motion spans more than FOLLOW windows
COLOURS = ("tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple", "tab:brown", "tab:pink", "tab:olive")
SHADES = ("Blues", "Oranges", "Greens", "Reds", "Purples", "YlOrBr", "RdPu", "Greys")


@dataclass
class Sketch:
    kind: str                   # "rod", "line", "box", "point"
    line: np.ndarray            # (m, 3) centreline (one point for a rigid body)
    d2: np.ndarray = None       # (m, 3) section direction along a rod
    edges: np.ndarray = None    # (12, 2, 3) a rigid body's box
    name: str = ""


def sketch(state, width):
    """The Sketch of a BodyState (rodfem/io/snapshot.py); `width`: the section width (box edges of 0)."""
    keep = stride(len(state.position), LINE_POINTS)
    sk = Sketch(state.kind, state.position[keep].copy(), name=getattr(state, "name", "") or "")
    if state.kind == "rod":
        sk.d2 = state.directors[keep, :, 1].copy()
    elif state.kind in ("box", "point"):
        frame = state.directors[0] if state.directors is not None else np.eye(3)
        if getattr(state, "link", None) is not None:       # a link: the segments between its points
            pts = state.position[0] + np.asarray(state.link) @ np.asarray(frame).T
            sk.kind, sk.edges = "link", np.stack([pts[:-1], pts[1:]], axis=1)
        else:
            sk.edges = box_edges(state.position[0], frame, box_size(state.box, width))
    return sk


def marks_sketch(points):
    """The Sketch of the joints, components and supports at a frame (rodfem/io/glyphs.py): their points."""
    return Sketch("marks", np.asarray(points, dtype=float).reshape(-1, 3).copy(), name="joints")


def box_size(edges, width):
    """Edges of a rigid body's box; a missing or zero edge (a plate, a point mass) gets width / 2."""
    edges = np.zeros(3) if edges is None else np.asarray(edges, dtype=float)
    return np.where(edges > 0, edges, 0.5 * width)


def _points(sketches):
    return np.concatenate([np.concatenate([sk.line] + ([sk.edges.reshape(-1, 3)] if sk.edges is not None else []))
                           for sk in sketches])


class Layout:
    """The drawn axes (2 or 3 of x, y, z) and the window of every frame (see the module docstring)."""

    def __init__(self, snapshots, dim, width):
        frames = [_points(sketches) for _, sketches in snapshots]
        every = np.concatenate(frames)
        lo, hi = every.min(axis=0), every.max(axis=0)
        span = float(np.max(hi - lo)) or 1.0
        if dim == 2:
            self.axes = (0, 1)
        else:
            flat = [k for k in range(3) if hi[k] - lo[k] <= 1e-9 * span]
            self.axes = tuple(k for k in range(3) if k != flat[-1]) if flat else (0, 1, 2)
        ax = list(self.axes)
        extent = max(float(np.max(f[:, ax].max(axis=0) - f[:, ax].min(axis=0))) for f in frames) or span
        self.half = max(0.5 * width, 0.02 * extent)      # half a rod ribbon's width on the picture
        self.size = 1.1 * extent + 4 * self.half         # the window's side
        whole = float(np.max(hi[ax] - lo[ax]))
        self.follows = whole + 4 * self.half > FOLLOW * self.size
        if not self.follows:
            self.size = max(self.size, 1.1 * whole + 4 * self.half)
        self.centres = [0.5 * (f[:, ax].min(axis=0) + f[:, ax].max(axis=0)) for f in frames]
        self.centre = 0.5 * (lo[ax] + hi[ax])
        self.whole = 1.1 * whole + 4 * self.half        # shapes.png: the window of the whole motion

    def window(self, k=None, size=None):
        """(lo, hi) of frame k's window (None: the whole motion's centre)."""
        c = self.centre if k is None or not self.follows else self.centres[k]
        half = 0.5 * (size or self.size)
        return c - half, c + half


class Canvas:
    """A figure with one set of artists per body, redrawn for every frame."""

    def __init__(self, layout, title, size=(6.4, 5.0)):
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        self.plt, self.layout, self.axes = plt, layout, list(layout.axes)
        self.dim = len(self.axes)
        self.fig = plt.figure(figsize=size)
        self.ax = ax = self.fig.add_subplot(projection="3d" if self.dim == 3 else None)
        if self.dim == 2:
            ax.set_aspect("equal", adjustable="box")
            ax.grid(True, lw=0.3, alpha=0.5)
        setters = (ax.set_xlabel, ax.set_ylabel, getattr(ax, "set_zlabel", None))
        for setter, k in zip(setters, self.axes):
            setter(f"{'xyz'[k]} [m]")
        ax.set_title(title)

    def limits(self, lo, hi):
        setters = (self.ax.set_xlim, self.ax.set_ylim, getattr(self.ax, "set_zlim", None))
        for k, setter in enumerate(setters[:self.dim]):
            setter(lo[k], hi[k])
        if self.dim == 3:
            self.ax.set_box_aspect((1, 1, 1))

    def segments(self, segments, **kw):
        """One line artist of separate segments (n, 2, dim): matplotlib breaks a line at a NaN row.  (A 3D
        collection projects its segments one by one in Python: 20 times slower for a chain of 256 links.)"""
        return self.ax.plot(*broken(segments).T, "-", **kw)[0]

    def _set(self, art, p):
        art.set_data(p[:, 0], p[:, 1]) if self.dim == 2 else art.set_data_3d(*p.T)

    def draw(self, sketches, colours, artists=None, labels=None, ribbons=True, rung_colour="0.25"):
        """Draw the bodies' sketches (new artists), or move `artists` made before to them; body b in
        colours[b] (its rungs in `rung_colour`), named labels[b] in a legend.  More than LEGEND bodies:
        the bodies of one kind and colour drawn as one (`joined`)."""
        sketches, colours = joined(sketches, colours)
        ax_ = self.axes
        new = artists is None
        artists = [] if new else artists
        for b, sk in enumerate(sketches):
            colour, lab = colours[b], (labels[b] if labels else None)
            if sk.kind == "marks":         # joints, components, supports: hollow black circles on top
                if new:
                    artists.append([self.ax.plot(*sk.line[:, ax_].T, "o", mfc="white", mec="black", ms=5, mew=1.2,
                                                 zorder=5, **({"label": lab} if lab else {}))[0]])
                else:
                    self._set(artists[b][0], sk.line[:, ax_])
                continue
            if sk.kind in ("rod", "line"):
                parts = [sk.line[:, ax_]]
                if sk.kind == "rod" and ribbons:
                    half = self.layout.half
                    a, c = sk.line - half * sk.d2, sk.line + half * sk.d2
                    pick = stride(len(sk.line), RUNGS)
                    parts += [a[:, ax_], c[:, ax_], np.stack([a[pick], c[pick]], axis=1)[:, :, ax_]]
                if new:
                    lines = [self.ax.plot(*parts[0].T, "-", color=colour, lw=2.0, label=lab)[0]]
                    if len(parts) > 1:
                        lines += [self.ax.plot(*p.T, "-", color=colour, lw=0.6, alpha=0.7)[0] for p in parts[1:3]]
                        lines.append(self.segments(parts[3], color=rung_colour, lw=0.8, alpha=0.8))
                    artists.append(lines)
                else:
                    for art, p in zip(artists[b][:3], parts[:3]):
                        self._set(art, p)
                    if len(parts) > 1:
                        self._set(artists[b][3], broken(parts[3]))
            else:
                edges = sk.edges[:, :, ax_]
                if new:
                    thick = 3.0 if sk.kind == "link" else 1.2
                    artists.append([self.segments(edges, color=colour, lw=thick, label=lab),
                                    self.ax.plot(*sk.line[:, ax_].T, "o", color=colour, ms=3)[0]])
                else:
                    self._set(artists[b][0], broken(edges))
                    self._set(artists[b][1], sk.line[:, ax_])
        return artists

    def save(self, path, dpi=110):
        from rodfem.io.output import replace_atomically
        self.fig.tight_layout()
        replace_atomically(path, lambda tmp: self.fig.savefig(tmp, dpi=dpi, format="png"))

    def close(self):
        self.plt.close(self.fig)


def broken(segments):
    """Segments (n, 2, dim) as one polyline (3n, dim): each segment's two points, then a row of NaN."""
    segments = np.asarray(segments, dtype=float)
    gaps = np.full((len(segments), 1, segments.shape[2]), np.nan)
    return np.concatenate([segments, gaps], axis=1).reshape(-1, segments.shape[2])


LEGEND = 12   # at most this many entries in a legend (a chain of 1000 links: none, it would hide the picture)


def _names(sketches):
    """The bodies' names for a legend (None for one body and no joints, or more than LEGEND entries)."""
    return [sk.name or f"body {b + 1}" for b, sk in enumerate(sketches)] if 1 < len(sketches) <= LEGEND else None


def joined(sketches, colours):
    """(sketches, colours) with, for more than LEGEND bodies, the sketches of one kind and colour joined into
    one (rods and lines apart by a row of NaN, where matplotlib breaks a line; boxes' and links' edges
    together): a chain of 1000 links is ~10 artists, not 2000 (matplotlib's cost is per artist)."""
    if _bodies(sketches) <= LEGEND:
        return sketches, colours
    groups, marks = {}, []
    for sk, colour in zip(sketches, colours):
        if sk.kind == "marks":
            marks.append((sk, colour))
        else:
            key = (sk.kind, colour if isinstance(colour, str) else tuple(np.ravel(colour)))
            groups.setdefault(key, (colour, []))[1].append(sk)
    gap = np.full((1, 3), np.nan)
    out = []
    for (kind, _), (colour, sks) in groups.items():
        if kind in ("rod", "line"):
            line = np.concatenate([part for sk in sks for part in (sk.line, gap)][:-1])
            d2 = (np.concatenate([part for sk in sks for part in (sk.d2, gap)][:-1]) if kind == "rod" else None)
            out.append((Sketch(kind, line, d2=d2), colour))
        else:
            out.append((Sketch(kind, np.concatenate([sk.line for sk in sks]),
                               edges=np.concatenate([sk.edges for sk in sks])), colour))
    out += marks
    return [sk for sk, _ in out], [c for _, c in out]


def _bodies(sketches):
    """The number of bodies among the sketches (the joints' sketch is not one)."""
    return sum(sk.kind != "marks" for sk in sketches)


def plot_shapes(path, snapshots, dim, width, max_shapes=16, time_label="t [s]"):
    """shapes.png: up to `max_shapes` frames (half as many for several bodies) in one picture, the time
    as the shade of each body's colour, a time colour bar."""
    import matplotlib.pyplot as plt
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import LinearSegmentedColormap, Normalize
    from matplotlib.lines import Line2D
    bodies, drawn = _bodies(snapshots[0][1]), len(snapshots[0][1])
    most = max_shapes if bodies == 1 else max(2, max_shapes // 2)
    idx = np.unique(np.linspace(0, len(snapshots) - 1, min(most, len(snapshots))).astype(int))
    layout = Layout([snapshots[i] for i in idx], dim, width)
    canvas = Canvas(layout, "deformed shapes", size=(7, 6))
    canvas.limits(*layout.window(size=layout.whole))
    maps = [plt.get_cmap("viridis")] if bodies == 1 else [plt.get_cmap(SHADES[b % len(SHADES)]) for b in range(bodies)]
    times = [snapshots[i][0] for i in idx]
    t0, t1 = times[0], times[-1]
    for j, i in enumerate(idx):
        x = j / max(len(idx) - 1, 1)
        shade = x if bodies == 1 else 0.3 + 0.7 * x       # (the lightest shades are invisible on white)
        last = j == len(idx) - 1                          # the joints: at the last shape only
        sketches = [sk for sk in snapshots[i][1] if last or sk.kind != "marks"]
        canvas.draw(sketches, [maps[b % len(maps)](shade) for b in range(drawn)], ribbons=False)
    names = _names(snapshots[0][1])
    if names:
        handles = [Line2D([], [], color=maps[b % len(maps)](0.85), lw=2) if sk.kind != "marks" else
                   Line2D([], [], ls="", marker="o", mfc="white", mec="black") for b, sk in enumerate(snapshots[0][1])]
        canvas.ax.legend(handles, names, loc="best", fontsize=8)
    grey = plt.get_cmap("Greys")
    shades = maps[0] if bodies == 1 else LinearSegmentedColormap.from_list("time", [grey(0.3), grey(1.0)])
    bar = ScalarMappable(norm=Normalize(t0, t1 if t1 > t0 else t0 + 1), cmap=shades)
    canvas.fig.colorbar(bar, ax=canvas.ax, label=time_label, shrink=0.8)
    canvas.save(path)
    canvas.close()


def write_animation(path, snapshots, dim, width, duration=6.0, dpi=80):
    """animation.gif: one picture per frame (the frames of the .pvd), about `duration` seconds long.
    A fixed window: the axes are drawn once and each frame redraws only the bodies and the time on top
    of them (blitting); a window that follows the bodies: every frame is drawn whole."""
    from PIL import Image
    layout = Layout(snapshots, dim, width)
    canvas = Canvas(layout, " ")
    fig, ax = canvas.fig, canvas.ax
    fig.set_dpi(dpi)
    drawn = len(snapshots[0][1])
    colours = [COLOURS[b % len(COLOURS)] for b in range(drawn)]
    canvas.limits(*layout.window(0))
    names = _names(snapshots[0][1])
    artists = canvas.draw(snapshots[0][1], colours, labels=names)
    if names:
        ax.legend(loc="upper right", fontsize=7)
    moving = [a for body in artists for a in body]
    clock = fig.text(0.5, 0.97, "", ha="center", va="top")
    blit = not layout.follows
    if blit:
        for a in moving + [clock]:
            a.set_animated(True)
    fig.tight_layout()
    fig.canvas.draw()
    background = fig.canvas.copy_from_bbox(fig.bbox) if blit else None
    images, palette = [], None
    for k, (t, sketches) in enumerate(snapshots):
        canvas.draw(sketches, colours, artists)
        clock.set_text(f"t = {t:.4g} s")
        if blit:
            fig.canvas.restore_region(background)
            for a in moving:
                ax.draw_artist(a)
            fig.draw_artist(clock)
        else:
            canvas.limits(*layout.window(k))
            fig.canvas.draw()
        rgba = fig.canvas.buffer_rgba()
        img = Image.frombuffer("RGBA", rgba.shape[1::-1], rgba, "raw", "RGBA", 0, 1).convert("RGB")
        if palette is None:   # one palette for all frames (the colours do not change)
            palette = img.quantize(colors=64)
        images.append(img.quantize(palette=palette, dither=Image.Dither.NONE))
    canvas.close()
    ms = int(np.clip(1000 * duration / len(images), 40, 500))

    def save(tmp):
        images[0].save(tmp, format="GIF", save_all=True, append_images=images[1:], duration=ms, loop=0)
    from rodfem.io.output import replace_atomically
    replace_atomically(path, save)
