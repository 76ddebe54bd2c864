"""Figures for reports: built on Matplotlib's Agg canvas without pyplot's global state, and
rendered to PNG bytes so the caller writes them atomically (``harness.io.atomic.write_bytes``)."""

from __future__ import annotations

import io


def new_figure(width: float, height: float, **kwargs):
    """A ``matplotlib.figure.Figure`` of ``width`` x ``height`` inches with an Agg canvas."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width, height), **kwargs)
    FigureCanvasAgg(fig)
    return fig


def png_bytes(fig, dpi: int, **savefig) -> bytes:
    """The figure rendered as PNG (``savefig``: more options of ``Figure.savefig``, e.g.
    ``bbox_inches="tight"`` to take in a legend placed outside the axes)."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi, **savefig)
    return buf.getvalue()
