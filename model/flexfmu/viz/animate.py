"""An animation of a deformed body: a matplotlib 3-D view of its outer surface (flexfmu.viz.surface), displaced by
u scaled so the largest displacement is a stated fraction of the body's size (or by a given factor), coloured by the
von Mises stress (or |u| when the body has no stress shapes) with one colour scale for every frame.  GIF through
matplotlib's PillowWriter; MP4 only when ffmpeg is installed.

Several series (a model's modes) are drawn side by side, each scaled on its own and coloured relative to its own
largest value (a mode shape's amplitude is arbitrary)."""
from __future__ import annotations

import textwrap
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from flexfmu.errors import ParameterError
from flexfmu.viz.series import DeformedSeries
from flexfmu.viz.surface import outline

#: the largest displacement drawn, as a fraction of the body's size (its bounding box's longest side), by default
DEFAULT_FRACTION = 0.1
ANIMATION_SUFFIXES = (".gif", ".mp4")


@dataclass(frozen=True)
class Animation:
    """What animate wrote: path; frames; scales (one per panel: drawn displacement / true displacement);
    largest_displacement (m, one per panel); body_size (m, one per panel)."""

    path: Path
    frames: int
    scales: tuple
    largest_displacement: tuple
    body_size: tuple


def body_size(nodes) -> float:
    """The longest side of the nodes' bounding box, m (1 for a single node)."""
    nodes = np.asarray(nodes, dtype=float)
    return float(np.max(np.ptp(nodes, axis=0))) or 1.0


def displacement_scale(series: DeformedSeries, fraction: float = DEFAULT_FRACTION) -> float:
    """The factor that draws the series' largest displacement at ``fraction`` of the body's size (1 when nothing
    moves)."""
    largest = float(np.max(np.linalg.norm(series.displacement, axis=2)))
    return fraction * body_size(series.nodes) / largest if largest > 0 else 1.0


def _unit(values_max: float) -> tuple[float, str]:
    """A divisor and unit for stress (Pa) values up to ``values_max``."""
    for divisor, unit in ((1e9, "GPa"), (1e6, "MPa"), (1e3, "kPa")):
        if values_max >= divisor:
            return divisor, unit
    return 1.0, "Pa"


def check_output(out) -> Path:
    """``out`` as a Path when it names an animation this module writes, else ParameterError."""
    out = Path(out)
    suffix = out.suffix.lower()
    if suffix not in ANIMATION_SUFFIXES:
        raise ParameterError("out", f"{out.name}: unknown animation format {suffix or '(no suffix)'}",
                             "a .gif, or a .mp4 when ffmpeg is installed")
    if out.exists() and out.is_dir():
        raise ParameterError("out", f"{out} is a folder", "a .gif or .mp4 file")
    if suffix == ".mp4":
        from matplotlib import animation

        if not animation.FFMpegWriter.isAvailable():
            raise ParameterError("out", f"{out.name}: an MP4 needs ffmpeg, which is not installed here",
                                 "a .gif (written with Pillow), or install ffmpeg for .mp4")
    return out


def _writer(out: Path, fps: int):
    from matplotlib import animation

    if out.suffix.lower() == ".mp4":                  # check_output made sure ffmpeg is there
        return animation.FFMpegWriter(fps=fps)
    return animation.PillowWriter(fps=fps)


def animate(series, out, *, scale: float | None = None, fraction: float = DEFAULT_FRACTION, fps: int = 20,
            title: str = "", relative_colour: bool | None = None, view: tuple = (25.0, -60.0),
            dpi: int = 90, still: tuple | None = None) -> Animation:
    """Animate ``series`` (a DeformedSeries, or a list of them drawn side by side, which must have the same number
    of frames) into ``out`` (.gif; .mp4 with ffmpeg).  scale: the displacement factor (default: each panel's that
    draws its largest displacement at ``fraction`` of the body's size); relative_colour: colour by value / largest
    (default: when there are several panels); view: (elevation, azimuth) degrees; still: (frame, PNG path) also
    saves that frame of the animation as a picture, same scale and colours."""
    panels = [series] if isinstance(series, DeformedSeries) else list(series)
    if not panels:
        raise ParameterError("series", "nothing to animate", "at least one deformed series")
    out = check_output(out)
    frames = panels[0].n_frames
    if any(p.n_frames != frames for p in panels):
        raise ParameterError("series", f"panels of {[p.n_frames for p in panels]} frames", "the same number of frames")
    if scale is not None and not (np.isfinite(scale) and scale > 0):
        raise ParameterError("scale", f"{scale!r}", "a finite factor > 0")
    if not (np.isfinite(fraction) and 0 < fraction <= 1):
        raise ParameterError("fraction", f"{fraction!r}", "0 < fraction <= 1 (of the body's size)")
    if not isinstance(fps, (int, np.integer)) or not 1 <= fps <= 100:
        raise ParameterError("fps", f"{fps!r}", "an integer 1 ... 100 (frames per second)")
    relative = len(panels) > 1 if relative_colour is None else bool(relative_colour)
    if still is not None:
        still_frame, still_path = int(still[0]), Path(still[1])
        if not 0 <= still_frame < frames or still_path.suffix.lower() != ".png":
            raise ParameterError("still", f"frame {still_frame} into {still_path.name}",
                                 f"a frame 0 ... {frames - 1} and a .png file")
    writer = _writer(out, int(fps))

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from mpl_toolkits.mplot3d.art3d import Line3DCollection, Poly3DCollection

    cmap = plt.get_cmap("viridis")
    cols = min(3, len(panels))
    rows = -(-len(panels) // cols)
    fig = plt.figure(figsize=(4.6 * cols + 1.2, 4.2 * rows + 0.8) if cols > 1 else (6.4, 5.4))
    fig.subplots_adjust(left=0.0, right=0.86, bottom=0.02, top=0.84 if rows == 1 else 0.9, wspace=0.05,
                        hspace=0.15)
    drawn, scales, largest, sizes = [], [], [], []
    colour_name, colour_max = "", 0.0
    for j, panel in enumerate(panels):
        size = body_size(panel.nodes)
        factor = displacement_scale(panel, fraction) if scale is None else float(scale)
        u_max = float(np.max(np.linalg.norm(panel.displacement, axis=2)))
        values, colour_name = panel.colour()
        v_max = float(np.max(values)) or 1.0
        colour_max = max(colour_max, v_max)
        shape = outline(panel.cells, panel.nodes.shape[0])
        ax = fig.add_subplot(rows, cols, j + 1, projection="3d")
        ax.view_init(*view)
        reach = factor * u_max
        lo, hi = panel.nodes.min(axis=0) - reach, panel.nodes.max(axis=0) + reach
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
        ax.set_zlim(lo[2], hi[2])
        ax.set_box_aspect(np.maximum(hi - lo, 1e-3 * size), zoom=0.95)
        if len(panels) == 1:
            for axis, name in zip((ax.set_xlabel, ax.set_ylabel, ax.set_zlabel), "xyz"):
                axis(f"{name} (m)", fontsize=8)
            ax.tick_params(labelsize=6)
            ax.locator_params(nbins=4)
        else:                    # side by side: the shapes matter, not the coordinates (and text is most of the time)
            ax.set_axis_off()
        # made with the undeformed body: matplotlib's 3-D collections autoscale on what they hold when added
        if shape.triangles.shape[0]:
            artist = Poly3DCollection(panel.nodes[shape.triangles], linewidths=0.15,
                                      edgecolors=(0.0, 0.0, 0.0, 0.35))
        elif shape.lines.shape[0]:
            artist = Line3DCollection(panel.nodes[shape.lines], linewidths=2.0)
        else:
            artist = ax.scatter(*panel.nodes[shape.points].T, s=6, depthshade=False)
        if shape.triangles.shape[0] or shape.lines.shape[0]:
            ax.add_collection3d(artist, autolim=False)
        text = ax.set_title("", fontsize=9)
        drawn.append((panel, shape, artist, text, factor, values, v_max, ax))
        scales.append(factor)
        largest.append(u_max)
        sizes.append(size)
    divisor, unit = (1.0, "1") if relative else (_unit(colour_max) if colour_name == "von Mises" else (1.0, "m"))
    norm = plt.Normalize(0.0, 1.0 if relative else colour_max / divisor)
    mappable = plt.cm.ScalarMappable(norm=norm, cmap=cmap)
    label = f"{colour_name} / largest" if relative else f"{colour_name} ({unit})"
    fig.colorbar(mappable, cax=fig.add_axes((0.88, 0.2, 0.018, 0.6)), label=label)
    if len(panels) > 1:
        how = (f"each drawn with its largest displacement at {fraction * 100:.3g} % of the body's size"
               if scale is None else f"displacement x {scale:.4g}")
    elif scale is None:
        how = (f"displacement x {scales[0]:.4g}: the largest, {largest[0]:.3g} m, drawn at {fraction * 100:.3g} % of "
               f"the body's {sizes[0]:.3g} m")
    else:
        how = f"displacement x {scale:.4g} (the largest {largest[0]:.3g} m; the body {sizes[0]:.3g} m)"
    lines = [title] if title else []
    lines += textwrap.wrap(f"{how}; colour: {label}", width=int(14 * fig.get_figwidth()))
    fig.suptitle("\n".join(lines), fontsize=9)

    def draw(k: int) -> None:
        for panel, shape, artist, text, factor, values, v_max, ax in drawn:
            moved = panel.nodes + factor * panel.displacement[k]
            shown = values[k] / (v_max if relative else divisor)
            if shape.triangles.shape[0]:
                artist.set_verts(moved[shape.triangles])
                artist.set_facecolor(cmap(norm(shown[shape.triangles].mean(axis=1))))
            elif shape.lines.shape[0]:
                artist.set_segments(moved[shape.lines])
                artist.set_color(cmap(norm(shown[shape.lines].mean(axis=1))))
            else:
                artist._offsets3d = tuple(moved[shape.points].T)
                artist.set_color(cmap(norm(shown[shape.points])))
            text.set_text(f"{panel.name}\n{panel.label(k)}" if len(panels) > 1 or not title else panel.label(k))

    out.parent.mkdir(parents=True, exist_ok=True)
    try:
        with writer.saving(fig, str(out), dpi):
            for k in range(frames):
                draw(k)
                writer.grab_frame()
                if still is not None and k == still_frame:
                    still_path.parent.mkdir(parents=True, exist_ok=True)
                    fig.savefig(still_path, dpi=dpi)
    finally:
        plt.close(fig)
    return Animation(out, frames, tuple(scales), tuple(largest), tuple(sizes))

