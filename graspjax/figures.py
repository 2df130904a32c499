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


def png(fig: Figure, title: str = "") -> bytes:
    """The figure as PNG bytes, laid out tightly, with `title` above it if given."""
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png")
    return buffer.getvalue()
