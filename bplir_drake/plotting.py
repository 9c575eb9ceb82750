"""Figure helpers shared by the plots.

Every plot function of the analysis package draws computed data on
matplotlib axes and returns the figure: ``plot_x(data, axes=None)``.  With
``axes=None`` it makes a new :class:`matplotlib.figure.Figure` (no pyplot,
no global backend: it works on headless machines, in tests and in
notebooks, where ``display(fig)`` shows it); given axes (as many as the plot
draws, in any array shape) it draws there and leaves the layout to the
caller.  Saving is the caller's job: :func:`save_figure` writes atomically.
"""
from __future__ import annotations

import weakref
from pathlib import Path

import numpy as np

from .io import atomic_path


_MADE_HERE: "weakref.WeakSet" = weakref.WeakSet()  # figures a plot function made itself

#: the height (inches) kept above the axes for a figure's title
TITLE_ROOM = 0.25


def figure_axes(axes=None, nrows: int = 1, ncols: int = 1, *, figsize=(8, 6), **subplots_kw):
    """``(figure, axes)`` to draw on: new ones shaped like
    ``Figure.subplots(nrows, ncols, **subplots_kw)``, or the given ``axes``
    reshaped to that shape (``ValueError`` when their number differs)."""
    from matplotlib.figure import Figure

    if axes is None:
        fig = Figure(figsize=figsize)
        _MADE_HERE.add(fig)
        return fig, fig.subplots(nrows, ncols, **subplots_kw)
    flat = np.asarray(axes, dtype=object).ravel()
    if flat.size != nrows * ncols:
        raise ValueError(f"this plot draws on {nrows * ncols} axes; {flat.size} given")
    if subplots_kw.get("squeeze", True) and flat.size == 1:
        return flat[0].figure, flat[0]
    shape = (nrows, ncols)
    if subplots_kw.get("squeeze", True):
        shape = tuple(n for n in shape if n > 1)
    return flat[0].figure, flat.reshape(shape)


def finish(fig, title: str | None = None, caption: str | None = None):
    """Title, caption (the run's details, in small type under the axes; also
    kept as ``fig.bplir_caption`` and written into the file's metadata by
    :func:`save_figure`) and tight layout for a figure :func:`figure_axes`
    made; a caller's figure is left as it is but keeps the caption as
    metadata.  Returns ``fig``."""
    if caption:
        fig.bplir_caption = caption
    if fig in _MADE_HERE:
        top = 1.0
        if title:
            fig.suptitle(title)
            top = 1.0 - TITLE_ROOM / fig.get_figheight()   # the axes keep clear of the title
        bottom = 0.0
        if caption:
            fig.text(0.005, 0.005, caption, fontsize=7, color="0.35", ha="left", va="bottom")
            bottom = 0.03
        fig.tight_layout(rect=(0, bottom, 1, top))
    return fig


#: how figures keep their text: TrueType fonts embedded whole in PDF and
#: PostScript (Type 42; journals' checks refuse the default Type 3), text
#: left as text in SVG (editable, not paths)
FONT_OUTPUT = {"pdf.fonttype": 42, "ps.fonttype": 42, "svg.fonttype": "none"}


def save_figure(fig, path, dpi: int = 110) -> Path:
    """Write ``fig`` to ``path`` (format from the suffix) atomically: a
    complete figure or none, its text as :data:`FONT_OUTPUT` keeps it."""
    import matplotlib

    path = Path(path)
    fmt = path.suffix.lstrip(".") or "png"
    caption = getattr(fig, "bplir_caption", None)
    key = {"png": "Description", "pdf": "Subject", "svg": "Description"}.get(fmt)
    metadata = {key: caption} if caption and key else None
    with atomic_path(path) as tmp, matplotlib.rc_context(FONT_OUTPUT):
        fig.savefig(tmp, dpi=dpi, format=fmt, metadata=metadata)
    return path
