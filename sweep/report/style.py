"""The report's figure style, in one place: PNG rendering, colours, the unitless note."""
from __future__ import annotations

import io

from matplotlib.figure import Figure


REPRESENTATIVE_COLOURS = {"caging focused": "#ff2d7a", "tip focused": "#ff9f1c",
                          "compromise": "#1f77b4"}


def png(fig: Figure) -> bytes:
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    return buf.getvalue()


NOTE_UNITLESS = "all quantities unitless (model units)"

#: The two scenes of a comparison (`compare.py`), scene 1 and scene 2, in every figure.
SCENE_COLOURS = ("#1f77b4", "#d62728")
