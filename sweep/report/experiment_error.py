"""Each experiment's numerical error, as the reports print it beside the experiment's numbers.

The error of an output at the screening spacing is measured, not estimated from the store: the
store holds each design at one spacing (the refinement's few excepted), so the error comes from
`scripts/experiment_convergence.py`, which sweeps a slice of a config at h, h/2, h/4 and writes
its table into EXPERIMENT_ERROR_TABLE (docs/accuracy.md, "Each experiment's outputs as h halves").
A table row applies to a store whose scene has the same effects, grid spacing, trajectory method
and step resolution (`scene_key`); for any other store the report says it was not measured.
"""
from __future__ import annotations

import csv
import io
from pathlib import Path

from ..files import write_bytes_atomic
from .data import StoreData, fmt

EXPERIMENT_ERROR_TABLE = Path(__file__).with_name("experiment_error.csv")

#: The outputs the experiments read, the order the reports name them in, with what reads them.
OUTPUTS = (
    ("caging_area", "best caging designs; caging vs tip prehension"),
    ("tip_prehension_area", "caging vs tip prehension"),
    ("manipulation_a_area", "Scenario A (and A against B)"),
    ("manipulation_b_area", "Scenario B (and A against B)"),
    ("parameter_usage", "parameter usage"),
)

COLUMNS = ["scene", "h", "reference_h", "output", "n", "median", "p90", "worst", "within5",
           "within15", "slice", "command"]


def scene_key(effects_on: str, trajectory: str, step_resolution: float) -> str:
    """What a measurement applies to besides the spacing: the effects switched on (as a store
    records them, in any order) and the trajectory settings."""
    effects = " ".join(sorted(str(effects_on).split()))
    return f"{effects}; trajectory {trajectory}; step_resolution {float(step_resolution):g}"


def store_key(st: StoreData) -> tuple[str, float]:
    """(scene_key, grid spacing) of a store."""
    acc = getattr(st.scene, "accuracy", None)
    return (scene_key(st.attrs.get("effects_on", ""), getattr(acc, "trajectory", "?"),
                      getattr(acc, "step_resolution", float("nan"))), float(st.scene.h))


def read_table(path: Path = EXPERIMENT_ERROR_TABLE) -> list[dict]:
    """The table's rows (none where it does not exist)."""
    if not path.exists():
        return []
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def write_rows(rows: list[dict], path: Path = EXPERIMENT_ERROR_TABLE) -> None:
    """Put `rows` into the table, replacing those of the same scene, spacing and output (written
    atomically: a table is never left half-written)."""
    new = {(r["scene"], float(r["h"]), r["output"]) for r in rows}
    kept = [r for r in read_table(path) if (r["scene"], float(r["h"]), r["output"]) not in new]
    out = io.StringIO()
    w = csv.DictWriter(out, fieldnames=COLUMNS, lineterminator="\n")
    w.writeheader()
    for r in sorted(kept + list(rows), key=lambda r: (r["scene"], -float(r["h"]), r["output"])):
        w.writerow({c: r[c] for c in COLUMNS})
    write_bytes_atomic(path, out.getvalue().encode())


def measured_error(st: StoreData, outputs, table: Path = EXPERIMENT_ERROR_TABLE) -> list[dict]:
    """The table's rows for this store's scene and spacing, for the named outputs, in order."""
    key, h = store_key(st)
    rows = {r["output"]: r for r in read_table(table)
            if r["scene"] == key and abs(float(r["h"]) - h) <= 1e-12 * h}
    return [rows[o] for o in outputs if o in rows]


def experiment_error_text(st: StoreData, outputs,
                          table: Path = EXPERIMENT_ERROR_TABLE) -> str:
    """One sentence: the named outputs' numerical error at the store's spacing, or that it was
    not measured for this scene."""
    rows = measured_error(st, outputs, table)
    if not rows:
        return ("Numerical error: not measured for this scene's settings (effects, h = "
                f"{fmt(st.scene.h)}, trajectory method); `scripts/experiment_convergence.py` "
                "measures it.")
    r0 = rows[0]
    parts = [f"`{r['output']}` {float(r['within5']):.0%} within 5 % and "
             f"{float(r['within15']):.0%} within 15 % (median change {float(r['median']):.1%}, "
             f"90th percentile {float(r['p90']):.1%}, worst {float(r['worst']):.0%})"
             for r in rows]
    return (f"Numerical error at h = {fmt(st.scene.h)} against h = {fmt(float(r0['reference_h']))}"
            f", measured on {r0['slice']} of this scene (`{r0['command']}`; "
            "docs/accuracy.md): " + "; ".join(parts) + ".")
