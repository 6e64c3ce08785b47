"""Animated GIFs of a matplotlib figure whose changing artists are redrawn over a fixed background (Agg, Pillow).

The figure is drawn once without its animated artists; each frame restores that background, draws only the
artists the frame returns and takes the pixels. Every frame is mapped to one palette (made from the first and
the last frame) without dithering, so that flat colours stay flat and frame-to-frame differences stay small.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path

from matplotlib.artist import Artist
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from PIL import Image

from bracekit.errors import InputError

#: Colours of the GIF palette (≤ 256).
PALETTE_COLORS = 128


def render_frames(fig: Figure, frames: int, draw: Callable[[int], Sequence[Artist]]) -> list[Image.Image]:
    """RGB images of `frames` frames of `fig`: frame i is the background plus the artists `draw(i)` returns.

    Args:
        fig: the figure; its changing artists must be marked animated (left out of the background).
        frames: number of frames, ≥ 1.
        draw: updates the artists for frame i and returns those to draw, in drawing order.
    """
    if frames < 1:
        raise InputError(f"an animation needs at least one frame, got {frames}")
    canvas = fig.canvas if isinstance(fig.canvas, FigureCanvasAgg) else FigureCanvasAgg(fig)
    canvas.draw()
    background = canvas.copy_from_bbox(fig.bbox)
    renderer = canvas.get_renderer()
    size = canvas.get_width_height(physical=True)
    images = []
    for i in range(frames):
        canvas.restore_region(background)
        for artist in draw(i):
            artist.draw(renderer)
        images.append(Image.frombuffer("RGBA", size, canvas.buffer_rgba(), "raw", "RGBA", 0, 1).convert("RGB"))
    return images


def quantize(
    images: Sequence[Image.Image], colors: int = PALETTE_COLORS, keep: Sequence[str] = ()
) -> list[Image.Image]:
    """The images in palette mode, all with one palette made from the first and the last image.

    Args:
        images: RGB images of one size.
        colors: palette size, ≤ 256.
        keep: matplotlib colours the palette must hold (flat areas and markers keep their exact colour).
    """
    from matplotlib.colors import to_rgb

    first, last = images[0], images[-1]
    block = 24
    swatches = Image.new("RGB", (max(first.width, block * max(len(keep), 1)), block), "white")
    for i, color in enumerate(keep):
        rgb = tuple(round(255 * c) for c in to_rgb(color))
        swatches.paste(Image.new("RGB", (block, block), rgb), (i * block, 0))
    source = Image.new("RGB", (swatches.width, first.height + last.height + block), "white")
    source.paste(first, (0, 0))
    source.paste(last, (0, first.height))
    source.paste(swatches, (0, first.height + last.height))
    palette = source.quantize(colors=colors, method=Image.Quantize.MEDIANCUT, dither=Image.Dither.NONE)
    return [im.quantize(palette=palette, dither=Image.Dither.NONE) for im in images]


def save_gif(images: Sequence[Image.Image], path: Path, fps: float) -> None:
    """Write palette images as a looping GIF at `fps` frames per second."""
    if not images:
        raise InputError("an animation needs at least one frame")
    if not fps > 0:
        raise InputError(f"fps must be > 0, got {fps!r}")
    with open(path, "wb") as fh:
        images[0].save(
            fh,
            format="GIF",
            save_all=True,
            append_images=list(images[1:]),
            duration=round(1000.0 / fps),
            loop=0,
            optimize=False,
        )
