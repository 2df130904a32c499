"""Every figure graspjax draws, off-screen, returned as PNG bytes; nothing here needs a display.

This module holds the canvas every figure is drawn on (`new_figure`, `png`); `report.py` the
report's figures, from a run folder's rows alone (no JAX), `titles.py` their titles from its
`config.json`; `views.py` the debug pictures of
one simulated attempt or one real image, like the paper's Figs. 2-5 and 8.
"""

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
