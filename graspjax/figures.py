"""Matplotlib figures drawn off-screen and returned as PNG bytes (tables' figures and debug
pictures alike); nothing here needs a display."""

from __future__ import annotations

import io

from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure


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
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png")
    return buffer.getvalue()
