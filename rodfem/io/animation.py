"""Pictures of the motion: shapes.png (shapes over time) and animation.gif (one picture per frame).

A `Sketch` is what the pictures keep of a body at one frame (a few hundred points at most, so
that a long run at 10^5 elements costs little memory): its centreline, the section direction d2
along it for a rod (drawn as a ribbon with rungs across it, which turn with the section, so
bending, shear and twist show), the edges of a rigid body's box, or a point mass's point.
The GIF is drawn with matplotlib, one figure updated frame by frame, and saved with Pillow.
"""
from dataclasses import dataclass

import numpy as np

from rodfem.io.sections import box_edges, stride

LINE_POINTS = 400     # most centreline points kept per body and frame
RUNGS = 24            # rungs drawn across a rod


@dataclass
class Sketch:
    kind: str                   # "rod", "line", "box", "point"
    line: np.ndarray            # (m, 3) centreline (one point for a rigid body)
    d2: np.ndarray = None       # (m, 3) section direction along a rod
    edges: np.ndarray = None    # (12, 2, 3) a rigid body's box


def sketch(state, width):
    """The Sketch of a BodyState (rodfem/io/snapshot.py); `width`: the section width (box edges of 0)."""
    keep = stride(len(state.position), LINE_POINTS)
    sk = Sketch(state.kind, state.position[keep].copy())
    if state.kind == "rod":
        sk.d2 = state.directors[keep, :, 1].copy()
    elif state.kind in ("box", "point"):
        frame = state.directors[0] if state.directors is not None else np.eye(3)
        sk.edges = box_edges(state.position[0], frame, box_size(state.box, width))
    return sk


def box_size(edges, width):
    """Edges of a rigid body's box; a missing or zero edge (a plate, a point mass) gets width / 2."""
    edges = np.zeros(3) if edges is None else np.asarray(edges, dtype=float)
    return np.where(edges > 0, edges, 0.5 * width)


def _extent(snapshots, dim):
    pts = np.concatenate([np.concatenate([sk.line] + ([sk.edges.reshape(-1, 3)] if sk.edges is not None else []))
                          for _, sketches in snapshots for sk in sketches])[:, :dim]
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    return lo, hi, float(np.max(hi - lo)) or 1.0


def _segments(sk, half, dim):
    """Rungs across a rod (RUNGS of them) and its ribbon's two edges."""
    pick = stride(len(sk.line), RUNGS)
    a, b = sk.line - half * sk.d2, sk.line + half * sk.d2
    return np.stack([a[pick], b[pick]], axis=1)[:, :, :dim], a[:, :dim], b[:, :dim]


class Canvas:
    """A figure with one set of artists per body, redrawn for every frame."""

    def __init__(self, snapshots, dim, width, title, size=(6.4, 5.0)):
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        self.plt, self.dim = plt, dim
        self.fig = plt.figure(figsize=size)
        self.ax = ax = self.fig.add_subplot(projection="3d" if dim == 3 else None)
        lo, hi, span = _extent(snapshots, dim)
        self.half = max(0.5 * width, 0.025 * span)     # half the ribbon's width on the picture
        centre, pad = 0.5 * (lo + hi), 0.55 * span + self.half
        if dim == 3:   # equal scales on the three axes: a cube around the swept region
            for k, setter in enumerate((ax.set_xlim, ax.set_ylim, ax.set_zlim)):
                setter(centre[k] - pad, centre[k] + pad)
            ax.set_zlabel("z")
        else:
            ax.set_xlim(centre[0] - pad, centre[0] + pad)
            ax.set_ylim(centre[1] - pad, centre[1] + pad)
            ax.set_aspect("equal", adjustable="box")
            ax.grid(True, lw=0.3, alpha=0.5)
        ax.set_xlabel("x")
        ax.set_ylabel("y")
        ax.set_title(title)

    def collection(self, segments, **kw):
        if self.dim == 3:
            from mpl_toolkits.mplot3d.art3d import Line3DCollection
            c = Line3DCollection(segments, **kw)
            self.ax.add_collection3d(c)
        else:
            from matplotlib.collections import LineCollection
            c = LineCollection(segments, **kw)
            self.ax.add_collection(c)
        return c

    def draw(self, sketches, colour, artists=None, label=None, ribbons=True, rung_colour="C1"):
        """Draw the bodies' sketches (new artists), or move `artists` made before to them; a rod's ribbon
        in `colour`, its rungs in `rung_colour`."""
        d = self.dim
        new = artists is None
        artists = [] if new else artists
        for b, sk in enumerate(sketches):
            lab = label if b == 0 else None
            if sk.kind in ("rod", "line"):
                parts = [sk.line[:, :d]]
                if sk.kind == "rod" and ribbons:
                    rungs, a, bb = _segments(sk, self.half, d)
                    parts += [a, bb, rungs]
                if new:
                    lines = [self.ax.plot(*parts[0].T, "-", color=colour, lw=2.0, label=lab)[0]]
                    if len(parts) > 1:
                        lines += [self.ax.plot(*p.T, "-", color=colour, lw=0.6, alpha=0.7)[0] for p in parts[1:3]]
                        lines.append(self.collection(parts[3], colors=[rung_colour], linewidths=0.9, alpha=0.9))
                    artists.append(lines)
                else:
                    for art, p in zip(artists[b][:3], parts[:3]):
                        art.set_data(p[:, 0], p[:, 1]) if d == 2 else art.set_data_3d(*p.T)
                    if len(parts) > 1:
                        artists[b][3].set_segments(parts[3])
            else:
                edges = sk.edges[:, :, :d]
                if new:
                    artists.append([self.collection(edges, colors=[colour], linewidths=1.2, label=lab),
                                    self.ax.plot(*sk.line[:, :d].T, "o", color=colour, ms=3)[0]])
                else:
                    artists[b][0].set_segments(edges)
                    p = sk.line[:, :d]
                    artists[b][1].set_data(p[:, 0], p[:, 1]) if d == 2 else artists[b][1].set_data_3d(*p.T)
        return artists

    def save(self, path, dpi=110):
        from rodfem.io.output import replace_atomically
        self.fig.tight_layout()
        replace_atomically(path, lambda tmp: self.fig.savefig(tmp, dpi=dpi, format="png"))

    def close(self):
        self.plt.close(self.fig)


def plot_shapes(path, snapshots, dim, width, max_shapes=16):
    """shapes.png: up to `max_shapes` frames in one picture, colour = time."""
    import matplotlib.pyplot as plt
    idx = np.unique(np.linspace(0, len(snapshots) - 1, min(max_shapes, len(snapshots))).astype(int))
    canvas = Canvas([snapshots[i] for i in idx], dim, width, "deformed shapes (colour = time)", size=(7, 6))
    cmap = plt.get_cmap("viridis")
    for j, i in enumerate(idx):
        t, sketches = snapshots[i]
        label = f"t = {t:.3g}" if j in (0, len(idx) - 1) else None
        canvas.draw(sketches, cmap(j / max(len(idx) - 1, 1)), label=label, ribbons=False)
    canvas.ax.legend(loc="best", fontsize=8)
    canvas.save(path)
    canvas.close()


def write_animation(path, snapshots, dim, width, duration=6.0, dpi=80):
    """animation.gif: one picture per frame (the frames of the .pvd), about `duration` seconds long.
    The axes are drawn once; each frame redraws only the bodies and the time on top of them (blitting)."""
    from PIL import Image
    canvas = Canvas(snapshots, dim, width, " ")
    fig, ax = canvas.fig, canvas.ax
    fig.set_dpi(dpi)
    artists = canvas.draw(snapshots[0][1], "C0")
    moving = [a for body in artists for a in body]
    clock = fig.text(0.5, 0.97, "", ha="center", va="top")
    for a in moving + [clock]:
        a.set_animated(True)
    fig.tight_layout()
    fig.canvas.draw()
    background = fig.canvas.copy_from_bbox(fig.bbox)
    images, palette = [], None
    for t, sketches in snapshots:
        canvas.draw(sketches, "C0", artists)
        clock.set_text(f"t = {t:.6g}")
        fig.canvas.restore_region(background)
        for a in moving:
            if hasattr(a, "do_3d_projection"):     # a 3D collection is projected by the axes' draw only
                a.do_3d_projection()
            ax.draw_artist(a)
        fig.draw_artist(clock)
        rgba = fig.canvas.buffer_rgba()
        img = Image.frombuffer("RGBA", rgba.shape[1::-1], rgba, "raw", "RGBA", 0, 1).convert("RGB")
        if palette is None:   # one palette for all frames (the colours do not change)
            palette = img.quantize(colors=32)
        images.append(img.quantize(palette=palette, dither=Image.Dither.NONE))
    canvas.close()
    ms = int(np.clip(1000 * duration / len(images), 40, 500))

    def save(tmp):
        images[0].save(tmp, format="GIF", save_all=True, append_images=images[1:], duration=ms, loop=0)
    from rodfem.io.output import replace_atomically
    replace_atomically(path, save)
