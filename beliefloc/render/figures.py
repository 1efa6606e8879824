"""Pictures: matplotlib figures written as PNG or SVG, and frames written as a GIF.

The one module of ``render/`` that imports matplotlib (the Agg backend, no screen), and only when
a picture is asked for: matplotlib is the optional extra ``beliefloc[plots]``. Output is
deterministic -- the same command writes the same SVG bytes (a fixed ``svg.hashsalt``, no date) --
and written whole or not at all (a temporary file beside the target, renamed into place).
"""

from __future__ import annotations

import io
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Any

from beliefloc.errors import BeliefLocError

if TYPE_CHECKING:
    from matplotlib.figure import Figure

PICTURE_SUFFIXES = (".png", ".svg")
"""What a still picture may be written as."""
INSTALL_HINT = "python -m pip install 'beliefloc[plots]'"
_SVG_SALT = "beliefloc"
_DPI = 110


class PlotsMissingError(BeliefLocError):
    """matplotlib is not installed: pictures need the ``plots`` extra."""


def pyplot() -> Any:
    """matplotlib's pyplot on the Agg backend, with deterministic settings; a clear error naming the
    ``pip install`` line when matplotlib is not installed."""
    try:
        import matplotlib
    except ImportError:
        raise PlotsMissingError(f"pictures need matplotlib, which is not installed: run {INSTALL_HINT}") from None
    matplotlib.use("Agg", force=True)
    matplotlib.rcParams["svg.hashsalt"] = _SVG_SALT
    matplotlib.rcParams["svg.fonttype"] = "path"  # glyphs as paths: the same bytes wherever it runs
    import matplotlib.pyplot as plt

    return plt


@contextmanager
def figure(width: float, height: float) -> Iterator[Figure]:
    """A new figure of ``width x height`` inches, closed afterwards (pyplot keeps no reference)."""
    plt = pyplot()
    fig = plt.figure(figsize=(width, height), dpi=_DPI)
    try:
        yield fig
    finally:
        plt.close(fig)


def figure_bytes(fig: Figure, suffix: str) -> bytes:
    """The figure as PNG or SVG bytes, without the metadata that would change from run to run."""
    buffer = io.BytesIO()
    kind = suffix.lower().lstrip(".")
    metadata: dict[str, Any] = {"Date": None} if kind == "svg" else {"Software": None}
    fig.savefig(buffer, format=kind, metadata=metadata, dpi=_DPI)
    return buffer.getvalue()


def save_figure(fig: Figure, path: Path) -> None:
    """Write ``fig`` to ``path`` (PNG or SVG by its suffix), whole or not at all."""
    from beliefloc.source.atomic_write import write_atomically

    data = figure_bytes(fig, path.suffix)
    write_atomically(path, lambda handle: handle.write(data))


def save_gif(frames: Sequence[bytes], path: Path, *, seconds_per_frame: float = 0.6) -> None:
    """Write PNG frames (``figure_bytes(fig, ".png")``) as an animated GIF with Pillow, whole or not
    at all. Frames of different sizes are padded to the largest, in white."""
    from PIL import Image

    from beliefloc.source.atomic_write import write_atomically

    if not frames:
        raise ValueError("a GIF needs at least one frame")
    images = [Image.open(io.BytesIO(frame)).convert("RGB") for frame in frames]
    width, height = max(i.width for i in images), max(i.height for i in images)
    padded = []
    for image in images:
        canvas = Image.new("RGB", (width, height), "white")
        canvas.paste(image, (0, 0))
        padded.append(canvas.quantize(colors=255, method=Image.Quantize.FASTOCTREE))  # 2.5x faster than ADAPTIVE
    buffer = io.BytesIO()
    padded[0].save(
        buffer, format="GIF", save_all=True, append_images=padded[1:], duration=int(seconds_per_frame * 1000), loop=0
    )
    data = buffer.getvalue()
    write_atomically(path, lambda handle: handle.write(data))


# --- primitives for render/picture_belief.py (belief pictures) -----------------------------------


def add_polygons(
    ax: Any,
    vertices: Any,
    *,
    values: Any = None,
    cmap: str | None = None,
    vmin: float | None = None,
    vmax: float | None = None,
    facecolor: Any = None,
    edgecolor: Any = "none",
    linewidth: float = 0.0,
    hatch: str | None = None,
    zorder: float = 1.0,
    rasterized: bool = False,
    label: str | None = None,
) -> Any:
    """ONE ``PolyCollection`` of ``vertices`` (an array ``(n, k, 2)`` in data coordinates) added to
    ``ax``: shaded by ``values`` on ``cmap`` from ``vmin`` to ``vmax`` (masked values are left
    transparent), or filled with ``facecolor``. Returns the collection (a mappable for a colour bar)."""
    pyplot()
    from matplotlib.collections import PolyCollection

    collection = PolyCollection(
        vertices,
        edgecolors=edgecolor,
        linewidths=linewidth,
        zorder=zorder,
        rasterized=rasterized,
        label=label,
        closed=True,
    )
    if values is not None:
        collection.set_array(values)
        if cmap is not None:
            collection.set_cmap(cmap)
        collection.set_clim(vmin, vmax)
    elif facecolor is not None:
        collection.set_facecolor(facecolor)
    if hatch is not None:
        collection.set_hatch(hatch)
    ax.add_collection(collection, autolim=False)
    return collection


def add_image(
    ax: Any, image: Any, *, width: float, height: float, x: float, y: float, yaw: float, zorder: float = 0.0
) -> Any:
    """An image (``(rows, cols)`` greys in 0..1, or RGB) whose lower-left corner is at map-frame
    ``(x, y)``, ``width x height`` metres, rotated by ``yaw`` (radians, counter-clockwise) about that
    corner. Drawn without smoothing (each pixel a square). Returns the image artist."""
    pyplot()
    from matplotlib.transforms import Affine2D

    artist = ax.imshow(
        image,
        cmap="gray",
        vmin=0.0,
        vmax=1.0,
        origin="upper",
        interpolation="nearest",
        extent=(0.0, width, 0.0, height),
        zorder=zorder,
    )
    artist.set_transform(Affine2D().rotate(yaw).translate(x, y) + ax.transData)
    return artist


# --- primitives for render/picture_search.py and render/picture_macros.py ------------------------


def add_lines(
    ax: Any,
    segments: Any,
    *,
    colors: Any = "black",
    linewidth: float = 1.0,
    linestyle: Any = "solid",
    alpha: float | None = None,
    zorder: float = 2.0,
    label: str | None = None,
    gid: str | None = None,
) -> Any:
    """ONE ``LineCollection`` of ``segments`` (a sequence of polylines, each an array ``(k, 2)`` in
    data coordinates) added to ``ax``, one colour for all or one per polyline. ``gid`` names the
    collection in an SVG and lets a caller find it again. Returns the collection."""
    pyplot()
    from matplotlib.collections import LineCollection

    collection = LineCollection(
        list(segments),
        colors=colors,
        linewidths=linewidth,
        linestyles=linestyle,
        alpha=alpha,
        zorder=zorder,
        label=label,
    )
    if gid is not None:
        collection.set_gid(gid)
    ax.add_collection(collection, autolim=False)
    return collection
