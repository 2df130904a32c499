"""Matplotlib figures drawn off-screen and returned as PNG bytes (tables' figures and debug
pictures alike); nothing here needs a display."""

from __future__ import annotations

import io

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from PIL import Image


def new_figure(width: float = 6.4, height: float = 4.8, dpi: int = 120) -> Figure:
    """An off-screen figure of `width` x `height` inches."""
    fig = Figure(figsize=(width, height), dpi=dpi)
    FigureCanvasAgg(fig)
    return fig


def png(fig: Figure, title: str = "", laid_out: bool = False) -> bytes:
    """The figure as PNG bytes, with `title` above it if given, laid out tightly (unless
    `laid_out`: the caller placed its parts)."""
    if title:
        fig.suptitle(title)
    if not laid_out:
        fig.tight_layout()
    fig.canvas.draw()
    pixels = np.asarray(fig.canvas.buffer_rgba())[..., :3]  # (H, W, 3) on an opaque face
    buffer = io.BytesIO()  # a 256-colour palette: a plot's flat colours and their edges, in
    # about a third of the bytes of full colour, and quicker to write
    Image.fromarray(pixels).quantize(256, method=Image.Quantize.FASTOCTREE).save(buffer, "png")
    return buffer.getvalue()
