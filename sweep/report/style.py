"""The report's figure style, in one place: PNG rendering, colours, the unitless note."""
from __future__ import annotations

import io
import multiprocessing
import os
from typing import Callable

from matplotlib.figure import Figure


REPRESENTATIVE_COLOURS = {"caging focused": "#ff2d7a", "tip focused": "#ff9f1c",
                          "compromise": "#1f77b4"}


def png(fig: Figure) -> bytes:
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    return buf.getvalue()


#: The figures being drawn by `pngs` (name -> a function that builds the figure): forked
#: processes find them here.
_PENDING: dict[str, Callable[[], Figure]] = {}


def _draw(name: str) -> bytes:
    return png(_PENDING[name]())


def pngs(figures: dict[str, Callable[[], Figure]]) -> dict[str, bytes]:
    """Each figure built and rendered to PNG bytes, several at once in forked processes (a
    report's figures are independent, and matplotlib holds the GIL while it draws); in this
    process where there is one figure, one core, or no fork. Same bytes either way."""
    workers = min(len(figures), os.cpu_count() or 1)
    if workers <= 1 or "fork" not in multiprocessing.get_all_start_methods():
        return {name: png(make()) for name, make in figures.items()}
    _PENDING.update(figures)
    try:
        with multiprocessing.get_context("fork").Pool(workers) as pool:
            # (the largest figure first: they are given out in this order)
            return dict(zip(figures, pool.map(_draw, list(figures), chunksize=1)))
    finally:
        for name in figures:
            _PENDING.pop(name, None)


NOTE_UNITLESS = "all quantities unitless (model units)"

#: The two scenes of a comparison (`compare.py`), scene 1 and scene 2, in every figure.
SCENE_COLOURS = ("#1f77b4", "#d62728")
