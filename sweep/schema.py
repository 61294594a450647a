"""The output schema: every per-point field of a map and every per-map summary field, declared once.

A `Field` names a quantity, its dtype, its dimensions, its units and CF attributes, and the
output it belongs to. The kernels index the summary row by the positions derived here
(`SUMMARY_INDEX`, frozen into them as constants), `sweep.compute.maps` builds a map's fields from
the point fields, `sweep.storage.mapfile` and `sweep.storage.store` write them with these
attributes; the store's coordinates and its manipulation and refinement variables are declared
here too (`STORE_FIELDS`: a store writes no variable that is not), and docs/outputs.md is
generated from these tables (`python -m sweep.schema`).

Outputs (MODEL 9: work only for what is asked): `energy` (configurations, modes, energy, class),
`equilibrium` (part equilibrium), `caging` (containment, L_open, trajectories, scores) and
`forces` (contact forces per finger, per unit tension; off unless asked for).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .model import EFFECTS, END_STATE_MEANINGS, FINGER_MODE_MEANINGS, POINT_CLASS_MEANINGS

LENGTH = "length (unitless)"
MAP_DIMS = ("y", "x")
FINGER_DIMS = ("finger", "y", "x")


@dataclass(frozen=True)
class Field:
    """One output quantity: what it is, how it is stored and which output switches it on."""

    name: str
    dtype: str
    dims: tuple[str, ...]
    long_name: str
    units: str | None = None
    output: str = "energy"
    flags: tuple[str, ...] | None = None   # meanings of the codes 0..n-1 (CF flag_meanings)
    fill: int | None = None                # CF _FillValue of a categorical field
    comment: str | None = None
    in_map_file: bool = True

    def attrs(self, effects_on=()) -> dict:
        """CF attributes of the stored variable (in a file of a scene with these effects on)."""
        out: dict = dict(long_name=self.long_name)
        flags = self.flags
        if self.name in EFFECT_FLAGS and EFFECT_FLAGS[self.name][0] in effects_on:
            flags = EFFECT_FLAGS[self.name][1]
        if flags is not None:
            out.update(flag_values=np.arange(len(flags), dtype=np.int8),
                       flag_meanings=" ".join(flags))
        if self.units is not None:
            out["units"] = self.units
        if self.fill is not None:
            out["_FillValue"] = np.dtype(self.dtype).type(self.fill)
        if self.comment is not None:
            out["comment"] = self.comment
        return out


# ---------------------------------------------------------------------------------------------
# Per-point fields of a map, in the order a map file stores them
# ---------------------------------------------------------------------------------------------
POINT_FIELDS = (
    Field("energy", "float64", MAP_DIMS,
          "system potential energy V_left + V_right (MODEL 6)", "tension x length (unitless)"),
    Field("point_class", "int8", MAP_DIMS, "class of the grid point (MODEL 8)",
          flags=POINT_CLASS_MEANINGS),
    Field("end_state", "int8", MAP_DIMS,
          "end of the trajectory started here (MODEL 8; method: the accuracy attribute)",
          output="caging",
          flags=END_STATE_MEANINGS),
    Field("equilibrium", "bool", MAP_DIMS,
          "part in force equilibrium (cone hull, MODEL 7); computed for reached points only", "1",
          output="equilibrium"),
    Field("contained", "bool", MAP_DIMS,
          "part centre inside J_L B_L T_L T_R B_R J_R (even-odd)", "1", output="caging"),
    Field("l_open", "float64", MAP_DIMS,
          "L_open: largest part that could escape between the fingers", LENGTH, output="caging"),
    Field("caging_score", "float64", MAP_DIMS,
          "caging score S = 1 - L_open/(2r) where caged, else 0", "1", output="caging"),
    Field("finger_mode", "int8", FINGER_DIMS, "contact mode the finger ends in (MODEL 4, 5)",
          flags=FINGER_MODE_MEANINGS, fill=-1, comment="-1 where the point is infeasible"),
    Field("theta1", "float64", FINGER_DIMS,
          "proximal joint angle, finger's own (mirrored) frame", "rad"),
    Field("theta2", "float64", FINGER_DIMS,
          "distal joint angle, finger's own (mirrored) frame", "rad"),
    Field("k1", "float64", FINGER_DIMS,
          "contact distance from the proximal joint on the proximal link; "
          "0 without a proximal contact", LENGTH),
    Field("k2", "float64", FINGER_DIMS,
          "contact distance from the distal joint on the distal link; "
          "0 without a distal contact", LENGTH),
    Field("tip_overlap", "bool", FINGER_DIMS,
          "the distal link passed through the part on its way to its "
          "limit (paper's answer kept, MODEL 4.3)", "1"),
    # Kept in memory for pictures (sweep.report.plot), not written.
    Field("first_event", "int8", FINGER_DIMS,
          "the closing sequence's first contact (kernels.finger's internal codes): where a "
          "trajectory's step must be sampled (model-notes D36)", "1", in_map_file=False),
    Field("end_index", "int64", MAP_DIMS,
          "flat (y, x) index of the point where the trajectory started here ends; -1 if none",
          "1", output="caging", in_map_file=False),

    # Contact forces (MODEL 5.1, 5.6), only with the `forces` output.
    Field("proximal_normal_force", "float64", FINGER_DIMS,
          "normal force of the proximal contact on the part per unit tendon tension (MODEL 5.6); "
          "0 without a proximal contact", "1", output="forces"),
    Field("distal_normal_force", "float64", FINGER_DIMS,
          "normal force of the distal contact on the part per unit tendon tension (MODEL 5.6); "
          "0 without a distal contact", "1", output="forces"),
    Field("distal_friction_multiplier", "float64", FINGER_DIMS,
          "tangential multiplier mu of the distal contact, least |mu| that holds the finger "
          "(MODEL 5.6); tangent rot90(normal)", "1", output="forces"),
    Field("resultant_force_x", "float64", FINGER_DIMS,
          "x component (world frame) of the finger's resultant force on the part per unit "
          "tendon tension", "1", output="forces"),
    Field("resultant_force_y", "float64", FINGER_DIMS,
          "y component of the finger's resultant force on the part per unit tendon tension",
          "1", output="forces"),
    Field("geometric_cage_score", "float64", MAP_DIMS,
          "geometric cage score S_geo = 1 - L_open/(2r) where the part is reached, contained and "
          "L_open < 2r, else 0, without the stability requirement (MODEL 10)", "1",
          output="forces"),
    Field("forces_determined", "bool", FINGER_DIMS,
          "the finger's contact forces are fixed by its statics (model-notes D9): static mode, "
          "no contact at a joint, contacts + joints on a limit <= 2", "1", output="forces"),
)
POINT = {f.name: f for f in POINT_FIELDS}

#: Categorical fields whose codes grow with an effect: (effect, meanings). Files of scenes without
#: the effect keep the codes they always had.
EFFECT_FLAGS = {field: (spec.name, meanings) for spec in EFFECTS for field, meanings in spec.flags}
FORCE_FIELDS = tuple(f.name for f in POINT_FIELDS if f.output == "forces")

# ---------------------------------------------------------------------------------------------
# Per-map summary fields, in the order of the kernels' summary row and of the stores
# ---------------------------------------------------------------------------------------------
_COUNT = "1"
SUMMARY = (
    Field("Lambda", "float64", (),
          "caging metric Lambda_j: sum of the end point's caging score over the "
          "grid points whose trajectory ends caged (MODEL 8); grows as 1/h^2", "1", "caging"),
    Field("caging_area", "float64", (),
          "resolution-independent caging metric: the caging score of the trajectory's end "
          "integrated over the starts, Lambda_j * h^2 with the palm row's starts at half a "
          "cell (model-notes D36)", "length^2 (model units)", "caging"),
    Field("n_caged", "int32", (), "grid points whose trajectory ends caged", _COUNT, "caging"),
    Field("n_tip_prehension", "int32", (),
          "grid points whose trajectory ends in tip prehension", _COUNT, "caging"),
    Field("tip_prehension_area", "float64", (),
          "area of the starts whose trajectory ends in tip prehension: n_tip_prehension * h^2 "
          "with the palm row's starts at half a cell (model-notes D36)",
          "length^2 (model units)", "caging"),
    Field("n_ejection", "int32", (), "grid points whose trajectory ends in ejection", _COUNT,
          "caging"),
    Field("n_stalled", "int32", (), "grid points whose trajectory stalls before a stable "
          "point: nothing lower to go to (sliding: not even off the grid; grid8: no lower "
          "neighbour)", _COUNT, "caging"),
    Field("n_reached", "int32", (), "grid points of class reached (the set P_j)", _COUNT),
    Field("n_equilibrium", "int32", (), "grid points where the part is in equilibrium", _COUNT,
          "equilibrium"),
    Field("n_vertex", "int32", (),
          "grid points of class vertex (a finger's vertex strikes the part)", _COUNT),
    Field("n_tip_overlap", "int32", (), "feasible grid points where a finger is flagged "
          "tip_overlap (its distal link passed through the part, MODEL 4.3)", _COUNT),
    Field("n_caged_crossed", "int32", (), "caged grid points whose fingers cross each other",
          _COUNT, "caging"),
    Field("n_points", "int32", (), "grid points of the map (whole-reach grid of the design)",
          _COUNT),
    Field("n_infeasible", "int32", (),
          "grid points of class infeasible (part overlaps palm or open fingers)", _COUNT),
    Field("n_unreached", "int32", (), "grid points of class unreached (both fingers free)",
          _COUNT),
    Field("n_eject", "int32", (), "grid points of class eject (a finger slipped)", _COUNT),
    Field("n_caged_points", "int32", (),
          "grid points that are caged themselves (stable, contained, L_open < 2r)", _COUNT,
          "caging"),
) + tuple(
    # Only with their effect (model.EFFECTS, EFFECT_SUMMARY): absent from other maps and stores.
    Field(name, "int32", (), long_name, _COUNT)
    for spec in EFFECTS for name, long_name in spec.summary_fields)

#: Summary fields that exist only when an effect is on (maps and stores of other scenes keep
#: the fields they always had).
EFFECT_SUMMARY = {name: spec.name for spec in EFFECTS for name, _ in spec.summary_fields}


def summary_field_on(name: str, effects_on) -> bool:
    """Whether a summary field is written for a scene with these effects on (names)."""
    return name not in EFFECT_SUMMARY or EFFECT_SUMMARY[name] in effects_on
SUMMARY_FIELDS = tuple(f.name for f in SUMMARY)
SUMMARY_INDEX = {name: k for k, name in enumerate(SUMMARY_FIELDS)}
COUNT_FIELDS = tuple(f.name for f in SUMMARY if f.dtype == "int32")


# ---------------------------------------------------------------------------------------------
# The refinement stage (sweep.runs.refine): per design and part (store dims, like the summaries) and
# per part (r, mu and command when the store has that dimension)
# ---------------------------------------------------------------------------------------------
#: Role of a design in its part's refinement (`refine_role`).
REFINE_ROLE_MEANINGS = ("screened", "eliminated", "near_tie", "best", "audited")
#: Outcome of a part's refinement (`refine_status`).
REFINE_STATUS_MEANINGS = ("not_refined", "certified", "near_tie")
#: The design parameters: config keys, store dimensions and coordinates (l1 l2 r1 r2 w).
DESIGN_KEYS = ("l1", "l2", "r1", "r2", "w")
PART_DIMS = ("part",)   # stands for (r, mu) or (r, mu, command)

REFINE_FIELDS = (
    Field("refined_caging_area", "float64", (),
          "caging area Lambda h^2 of the design at the finest refinement level its equal-R "
          "class reached (grid spacing h / 2**refined_level); NaN where screened only",
          "length^2 (model units)", "refine"),
    Field("refined_level", "int8", (),
          "refinement level of refined_caging_area: recomputed at h / 2**level (h: grid_h); "
          "0 where screened only", "1", "refine"),
    Field("refined_error", "float64", (),
          "error estimate of refined_caging_area: its change from the level before (the "
          "screened caging_area for level 1); NaN where screened only",
          "length^2 (model units)", "refine"),
    Field("refine_role", "int8", (),
          "role of the design in its part's refinement: not a contender (screened), separated "
          "from the best at some level (eliminated), in the part's near-tie set, the best "
          "(all designs of the best's equal-R class), or a non-contender recomputed by the "
          "part's audit (audited, model-notes D37)", output="refine",
          flags=REFINE_ROLE_MEANINGS),
    Field("refine_readmitted", "bool", (),
          "the design was re-admitted by the part's bound check and recomputed at the levels the "
          "part reached: an audited design whose value plus error reached the best's refined "
          "caging area minus its error, a non-contender whose screened caging area raised by "
          "the audit's largest rise (refine_audit_rise) reached it, or a contender eliminated "
          "at an earlier level whose value plus error reached it", "1", "refine"),
    Field("refine_status", "int8", PART_DIMS,
          "outcome of the part's refinement: certified (the best design's lead over every "
          "other contender exceeds the change between the last two levels of both), near_tie "
          "(level cap reached: the designs with refine_role near_tie or best), or not_refined "
          "(no design cages at the screening spacing)", output="refine",
          flags=REFINE_STATUS_MEANINGS),
    Field("refine_finest_h", "float64", PART_DIMS,
          "finest grid spacing the part's refinement reached (grid_h if not refined)", LENGTH,
          "refine"),
    Field("refine_margin", "float64", PART_DIMS,
          "lead of the best design's refined caging area over the runner-up's at the finest "
          "level where both were computed; NaN if not refined", "length^2 (model units)",
          "refine"),
    Field("refine_bound_held", "bool", PART_DIMS,
          "the contender bound held: the best's refined caging area minus its error exceeds "
          "every audited design's value plus error, every other non-contender's screened "
          "caging area raised by the audit's largest rise, and every eliminated contender's "
          "value plus error at its last level (the refinement re-admits what could win until "
          "it holds: refine_widenings; false only in stores refined before it did)", "1",
          "refine"),
    Field("refine_bound_used", "float64", PART_DIMS,
          "the part's contender bound: contenders had a screened caging area of at least "
          "(1 - this) times the part's best (3 times the largest change of its min_contenders "
          "best designs from screening to h/2, at most refine_bound); NaN if not refined", "1",
          "refine"),
    Field("refine_n_contenders", "int32", PART_DIMS,
          "designs recomputed at the first refinement level (equal-R designs counted each), "
          "those re-admitted by the bound check included", "1", "refine"),
    Field("refine_widenings", "int32", PART_DIMS,
          "rounds in which the part's bound check failed and the designs that could win were "
          "re-admitted and recomputed (0: the contender bound held at once)", "1", "refine"),
    Field("refine_n_readmitted", "int32", PART_DIMS,
          "designs re-admitted by the part's bound check (refine_readmitted; equal-R designs "
          "counted each)", "1", "refine"),
    Field("refine_bound_widened", "float64", PART_DIMS,
          "the part's contender bound after the re-admissions: every design with a screened "
          "caging area of at least (1 - this) times the part's best contended or was audited "
          "(the floor aside; an audited design re-admitted by its own value does not move it); "
          "refine_bound_used when no other non-contender was re-admitted, and may exceed "
          "refine_bound; NaN if not refined", "1", "refine"),
    Field("refine_audit_designs", "int32", PART_DIMS,
          "non-contending designs the part's audit recomputed at every level up to its finest "
          "(a stratified random sample, seeded by the config: model-notes D37; equal-R designs "
          "counted each); 0 if not refined", "1", "refine"),
    Field("refine_audit_rise", "float64", PART_DIMS,
          "the audit's largest rise of a design's caging area from screening to the part's "
          "finest level, relative to its screened value (to at least a quarter of the part's "
          "best screened value); every other non-contender is taken to rise at most this much; "
          "NaN if not refined", "1", "refine"),
    Field("refine_audit_h", "float64", PART_DIMS,
          "grid spacing at which the part's audit recomputed its designs (the part's finest); "
          "NaN if not refined", LENGTH, "refine"),
)
REFINE = {f.name: f for f in REFINE_FIELDS}


# ---------------------------------------------------------------------------------------------
# The store's coordinates and its other variables (sweep.storage.store): the summary fields
# above on the store's dimensions, and these
# ---------------------------------------------------------------------------------------------
MODEL_LENGTH = "length (model units)"
_FORCE = "force (per unit tension, unitless)"

STORE_COORDINATES = (
    Field("l1", "float64", ("l1",), "proximal link length l1", MODEL_LENGTH),
    Field("l2", "float64", ("l2",), "distal link length l2", MODEL_LENGTH),
    Field("r1", "float64", ("r1",), "proximal pulley radius r1", MODEL_LENGTH),
    Field("r2", "float64", ("r2",), "distal pulley radius r2", MODEL_LENGTH),
    Field("w", "float64", ("w",), "palm width w", MODEL_LENGTH),
    Field("r", "float64", ("r",), "part (disc) radius r", MODEL_LENGTH),
    Field("mu", "float64", ("mu",),
          "static friction coefficient mu_s between part and links", "1"),
    Field("command", "int32", ("command",),
          "index of the actuation command (see f_left, f_right)", "1"),
)
#: Per command, when a store has several (its `command` dimension).
COMMAND_FIELDS = tuple(
    Field(name, "float64", ("command",), f"tendon tension of the {side} finger",
          "force (model units)")
    for name, side in (("f_left", "left"), ("f_right", "right")))

#: Dimensions of the Scenario A (and C) variables: per candidate (l1, l2, r1, r2) and part.
A_DIMS = ("l1", "l2", "r1", "r2", "r", "mu")
_B_DIMS = ("r", "mu")

#: The manipulation metric's coordinates and variables (`outputs: {manipulation: true}`, MODEL 10).
MANIPULATION_COORDINATES = (
    Field("parameter", "str", ("parameter",), "design parameter of the parameter usage",
          output="manipulation"),
    Field("pose_row", "int32", ("pose_row",), "pose row j: part centre y = r + j h", "1",
          output="manipulation"),
    Field("pose_column", "int32", ("pose_column",), "pose column i: part centre x = i h", "1",
          output="manipulation"),
)
MANIPULATION_FIELDS = (
    Field("manipulation_a", "float64", A_DIMS,
          "Scenario A manipulation metric of the candidate (l1, l2, r1, r2) for the part "
          "(r, mu): sum over poses of the largest origin-centred circle inside the hull "
          "of its forces over every palm width and the commands F_left + F_right = 2 "
          "(MODEL 10); grows as 1/h^2", _FORCE, output="manipulation"),
    Field("manipulation_a_area", "float64", A_DIMS,
          "manipulation_a * h^2 (resolution-independent)", "force x length^2 (unitless)",
          output="manipulation"),
    Field("manipulation_c", "float64", A_DIMS,
          "Scenario C (friction modulation) manipulation metric of the candidate (l1, "
          "l2, r1, r2) for the part (r, mu): as manipulation_a, with each finger's "
          "contact friction switched independently between the part's mu and "
          "manipulation_scenario_c_mu_low (the four friction pairs; the palm keeps mu; "
          "MODEL 10); never below manipulation_a", _FORCE, output="scenario_c"),
    Field("manipulation_c_area", "float64", A_DIMS,
          "manipulation_c * h^2 (resolution-independent)", "force x length^2 (unitless)",
          output="scenario_c"),
    Field("manipulation_b", "float64", _B_DIMS,
          "Scenario B manipulation metric of the part: sum over poses of the largest "
          "origin-centred circle inside the hull of the forces of every geometry of the "
          "sweep at F_left = F_right = 1 (MODEL 10)", "force (unitless)", output="manipulation"),
    Field("manipulation_b_area", "float64", _B_DIMS, "manipulation_b * h^2",
          "force x length^2", output="manipulation"),
    Field("manipulation_b_uncrossed", "float64", _B_DIMS,
          "manipulation_b counting only forces of poses where the fingers do not cross "
          "(the rest comes from crossed fingers, MODEL 10)", "force (unitless)",
          output="manipulation"),
    Field("manipulation_b_poses", "int32", _B_DIMS, "poses with a positive Scenario B value",
          "1", output="manipulation"),
    Field("parameter_usage", "float64", _B_DIMS + ("parameter",),
          "Scenario B parameter usage: per parameter, the range among the geometries "
          "whose forces are hull vertices over its search range, averaged over the poses "
          "with a positive value (MODEL 10); NaN if none", "1", output="manipulation"),
    Field("manipulation_b_pose_value", "float64", _B_DIMS + ("pose_row", "pose_column"),
          "Scenario B value of each pose x = pose_column h, y = r + pose_row h (0 where "
          "no hull surrounds the origin; outside a part's lattice too)",
          "force (unitless)", output="manipulation"),
)
MANIPULATION = {f.name: f for f in MANIPULATION_FIELDS}

#: Every variable a store may hold (coordinates included), by name: what the store writes and
#: what docs/outputs.md lists.
STORE_FIELDS = {f.name: f for f in STORE_COORDINATES + COMMAND_FIELDS + SUMMARY
                + MANIPULATION_COORDINATES + MANIPULATION_FIELDS + REFINE_FIELDS}


def markdown_table() -> str:
    """docs/outputs.md's tables, generated from this module."""
    lines = ["# Outputs", "",
             "Generated by `python -m sweep.schema` from `sweep/schema.py`, where every field is "
             "declared once.", "", "## Per-point fields of a map file", "",
             "| name | dtype | dims | units | output | meaning |", "|---|---|---|---|---|---|"]
    for f in POINT_FIELDS:
        flags = EFFECT_FLAGS[f.name][1] if f.name in EFFECT_FLAGS else f.flags
        meaning = f.long_name + (f" (codes: {', '.join(f'{k} {m}' for k, m in enumerate(flags))})"
                                 if flags else "")
        if f.name in EFFECT_FLAGS:
            meaning += (f"; codes {len(f.flags)} and up only with `{EFFECT_FLAGS[f.name][0]}`")
        if not f.in_map_file:
            meaning += " (in memory only)"
        lines.append(f"| `{f.name}` | {f.dtype} | {', '.join(f.dims)} | {f.units or ''} | "
                     f"{f.output} | {meaning} |")
    lines += ["", "## Per-map summary fields (map file attributes, store variables)", "",
              "| name | dtype | units | output | meaning |", "|---|---|---|---|---|"]
    for f in SUMMARY:
        lines.append(f"| `{f.name}` | {f.dtype} | {f.units or ''} | {f.output} | "
                     f"{f.long_name} |")
    lines += ["", "## Refinement variables of a store (`refine:`, `sweep refine`)", "",
              "Per design and part on the store's dimensions, or per part on (r, mu) (and "
              "command when the store has it).", "",
              "| name | dtype | dims | units | meaning |", "|---|---|---|---|---|"]
    for f in REFINE_FIELDS:
        meaning = f.long_name + (f" (codes: {', '.join(f'{k} {m}' for k, m in enumerate(f.flags))})"
                                 if f.flags else "")
        dims = "part" if f.dims == PART_DIMS else "design, part"
        lines.append(f"| `{f.name}` | {f.dtype} | {dims} | {f.units or ''} | {meaning} |")
    lines += ["", "## Coordinates and per-command variables of a store", "",
              "The summary fields above are variables on the store's dimensions, `l1, l2, r1, "
              "r2, w, r, mu` (plus `command` when a sweep has several commands).", "",
              "| name | dtype | dims | units | meaning |", "|---|---|---|---|---|"]
    for f in STORE_COORDINATES + COMMAND_FIELDS:
        lines.append(f"| `{f.name}` | {f.dtype} | {', '.join(f.dims)} | {f.units or ''} | "
                     f"{f.long_name} |")
    lines += ["", "## Manipulation variables of a store (`outputs: {manipulation: true}`)", "",
              "Output `scenario_c`: only with `outputs: {scenario_c: ...}` as well.", "",
              "| name | dtype | dims | units | output | meaning |", "|---|---|---|---|---|---|"]
    for f in MANIPULATION_COORDINATES + MANIPULATION_FIELDS:
        lines.append(f"| `{f.name}` | {f.dtype} | {', '.join(f.dims)} | {f.units or ''} | "
                     f"{f.output} | {f.long_name} |")
    return "\n".join(lines) + "\n"


if __name__ == "__main__":  # pragma: no cover
    print(markdown_table(), end="")
