"""The report's figure style, in one place: PNG rendering, colours, the unitless note."""
from __future__ import annotations

import io
import os
import threading

from matplotlib.figure import Figure


REPRESENTATIVE_COLOURS = {"caging focused": "#ff2d7a", "tip focused": "#ff9f1c",
                          "compromise": "#1f77b4"}


def png(fig: Figure) -> bytes:
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    return buf.getvalue()


class BackgroundPng:
    """`png(fig)` rendered by a forked child while this process goes on: matplotlib renders on
    one core, and the report's largest figure (the best designs' 32 maps) took 3 of its 8 s
    (docs/performance.md). The same bytes as `png(fig)`: the child renders the very figure.
    Rendered here instead, at `result()`, where fork is unavailable, where this process runs
    other threads (a fork copies only the calling thread: a lock another one held would never
    be released in the child), or if the child fails."""

    def __init__(self, fig: Figure):
        self.fig, self.pid, self.pipe = fig, None, None
        if not hasattr(os, "fork") or threading.active_count() > 1:
            return
        read_end, write_end = os.pipe()
        pid = os.fork()
        if pid == 0:       # the child: render, hand the bytes over, leave without clean-up
            code = 1
            try:
                os.close(read_end)
                with os.fdopen(write_end, "wb") as out:
                    out.write(png(fig))
                code = 0
            finally:
                os._exit(code)
        os.close(write_end)
        self.pid, self.pipe = pid, read_end

    def result(self) -> bytes:
        """The PNG bytes (waits for the child)."""
        if self.pid is None:
            return png(self.fig)
        with os.fdopen(self.pipe, "rb") as rendered:
            data = rendered.read()
        _, status = os.waitpid(self.pid, 0)
        self.pid = None
        return data if status == 0 and data else png(self.fig)


NOTE_UNITLESS = "all quantities unitless (model units)"

#: The two scenes of a comparison (`compare.py`), scene 1 and scene 2, in every figure.
SCENE_COLOURS = ("#1f77b4", "#d62728")
