"""The model's vocabulary: parameters, categorical codes, tolerances (docs/model.md 1, 5.5, 8).

Everything here is plain Python. Kernels receive these values as arguments (never read module
globals at run time except the integer codes and the true constants below, which Numba freezes at
compile time on purpose).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

# ---------------------------------------------------------------------------------------------
# Categorical codes (stored with CF flag_values / flag_meanings)
# ---------------------------------------------------------------------------------------------
# point_class (MODEL 8: "first that applies": infeasible, eject, vertex, unreached, reached)
INFEASIBLE, UNREACHED, EJECT, VERTEX_POINT, REACHED = 0, 1, 2, 3, 4
POINT_CLASS_MEANINGS = ("infeasible", "unreached", "eject", "vertex", "reached")

# end_state of the trajectory started at a point (MODEL 8)
END_NONE, END_CAGED, END_TIP_PREHENSION, END_EJECTION, END_STALLED = 0, 1, 2, 3, 4
END_STATE_MEANINGS = ("none", "caged", "tip_prehension", "ejection", "stalled")

# finger_mode: the contact a finger ends in (MODEL 4, 5)
FREE, PROXIMAL_ONLY, TWO_PHALANX, DISTAL_ONLY, SLIPPED, VERTEX = 0, 1, 2, 3, 4, 5
FINGER_MODE_MEANINGS = ("free", "proximal_only", "two_phalanx", "distal_only", "slipped", "vertex")
# Only with the tip_contact effect (model-notes D15): the tip is the finger's only contact, or the
# tip and a proximal edge contact. Files of scenes without the effect keep the six codes above.
TIP_ONLY, PROXIMAL_TIP = 6, 7
TIP_FINGER_MODE_MEANINGS = FINGER_MODE_MEANINGS + ("tip", "proximal_tip")

# Per-map summary fields and per-point fields are declared in sweep.schema.

LEFT, RIGHT = 0, 1
FINGER_NAMES = ("left", "right")

# ---------------------------------------------------------------------------------------------
# Tolerances that are part of the model (MODEL 5.5, 7, 8). True constants: frozen into kernels.
# ---------------------------------------------------------------------------------------------
TOUCH_REL = 1e-12   # |d|^2 >= r^2 (1 - TOUCH_REL) counts as touching, tangent length 0
RANGE_TOL = 1e-12   # inclusive slack of every validity range check (k in [0, l], angle limits)
GAP_TOL = 1e-9      # cone-hull test: equilibrium iff no angular gap exceeds pi + GAP_TOL
PALM_TOL = 1e-9     # palm contact: |y - r| <= PALM_TOL and |x| <= w/2 + PALM_TOL
GRID_TOL = 1e-9     # grid index rounding: N = floor(X/h + GRID_TOL)


@dataclass(frozen=True)
class Design:
    """Gripper geometry: link lengths, pulley radii, palm width (MODEL 1)."""

    l1: float
    l2: float
    r1: float
    r2: float
    w: float

    @property
    def R(self) -> float:
        return self.r2 / self.r1


@dataclass(frozen=True)
class Part:
    """A disc of radius r with static friction coefficient mu against the links."""

    r: float
    mu: float


@dataclass(frozen=True)
class Command:
    """Tendon tensions of the left and right fingers."""

    f_left: float = 1.0
    f_right: float = 1.0


@dataclass(frozen=True)
class Limits:
    """Joint limits in degrees at the edge; radians inside (MODEL 1)."""

    theta1_min_deg: float = 0.0
    theta1_max_deg: float = 180.0
    theta2_min_deg: float = -5.0
    theta2_max_deg: float = 90.0

    @property
    def theta2_min(self) -> float:
        return math.radians(self.theta2_min_deg)

    @property
    def theta2_max(self) -> float:
        return math.radians(self.theta2_max_deg)


#: The step resolution of the trajectories (Accuracy.step_resolution): the largest gap between
#: samples of a step. Walls of vertex strikes are about 0.034 wide on the paper's largest
#: fingers, so samples 0.025 apart find every one a step crosses (model-notes D36).
DEFAULT_STEP_RESOLUTION = 0.025


def step_resolution_ok(value) -> bool:
    """0 (the checks off), or a finite value in STEP_RESOLUTION_RANGE."""
    low, high = STEP_RESOLUTION_RANGE
    return isinstance(value, (int, float)) and (value == 0 or (math.isfinite(value)
                                                               and low <= value <= high))


@dataclass(frozen=True)
class Accuracy:
    """Accuracy settings (MODEL 8): reconfiguration step (rad), root tolerance (rad), the
    trajectory method (TRAJECTORY_METHODS; "discrete" is read as "grid8") and the step
    resolution (model length; 0: off): on a grid coarser than it, grid8 and sliding sample a
    step at this spacing where it could cross a wall or a band of equilibrium narrower than
    the grid (model-notes D36)."""

    reconfig_step: float = 0.01
    root_tol: float = 1e-12
    trajectory: str = "sliding"
    step_resolution: float = DEFAULT_STEP_RESOLUTION

    def __post_init__(self):
        if isinstance(self.trajectory, str) and self.trajectory in TRAJECTORY_ALIASES:
            object.__setattr__(self, "trajectory", TRAJECTORY_ALIASES[self.trajectory])


@dataclass(frozen=True)
class Grid:
    """Grid spacing and optional window; None bounds mean the whole reach (MODEL 8)."""

    h: float = 0.05
    xlim: tuple[float, float] | None = None
    ylim: tuple[float, float] | None = None


@dataclass(frozen=True)
class Effects:
    """Effects a scene may switch on (MODEL 9). `spring_k1`, `spring_k2` are the joint springs'
    stiffnesses K1, K2 (torque per radian, model units), used only with `joint_springs`."""

    friction: bool = True
    tip_contact: bool = False
    joint_springs: bool = False
    finger_collision: bool = False
    spring_k1: float = 0.0
    spring_k2: float = 0.0

    def names_on(self) -> list[str]:
        return [k for k in EFFECT_NAMES if getattr(self, k)]

#: What a map may compute (MODEL 9). energy: V and the finger configurations (always);
#: equilibrium: part equilibrium; caging: containment, L_open, trajectories, caging scores and
#: Lambda (needs equilibrium); forces: contact forces (MODEL 5.6).
OUTPUT_NAMES = ("energy", "equilibrium", "caging", "forces")


@dataclass(frozen=True)
class Outputs:
    """The outputs a map computes; the default is the paper's map (everything but forces)."""

    energy: bool = True
    equilibrium: bool = True
    caging: bool = True
    forces: bool = False

    def names_on(self) -> list[str]:
        return [k for k in OUTPUT_NAMES if getattr(self, k)]

    @classmethod
    def from_names(cls, names) -> "Outputs":
        """Outputs from a list of names; raises ModelInputError naming an unknown or missing one."""
        names = list(names)
        unknown = [n for n in names if n not in OUTPUT_NAMES]
        if unknown:
            raise ModelInputError(f"unknown output {unknown[0]!r} (valid: "
                                  f"{', '.join(OUTPUT_NAMES)})")
        out = cls(**{k: k in names for k in OUTPUT_NAMES})
        out.validate()
        return out

    def validate(self) -> None:
        # every map is an energy map; caged points are stable points, so caging needs equilibrium
        if not self.energy:
            raise ModelInputError("outputs: energy cannot be off (every map is an energy map)")
        if self.caging and not self.equilibrium:
            raise ModelInputError("outputs: caging needs equilibrium (a caged point is stable)")


#: The paper's map, the default outputs (files that have them say nothing of outputs).
DEFAULT_OUTPUTS = tuple(Outputs().names_on())


# Accepted accuracy settings. A step resolution below 1e-4 would sample a step of the coarsest
# grid thousands of times (a practical hang); 0 switches the step checks off.
STEP_RESOLUTION_RANGE = (1e-4, 1.0)
# A smaller reconfiguration step would take more than pi / 1e-6 = 3e6 path
# evaluations per point (a practical hang); a root tolerance below 1e-15 is below float
# resolution on [0, pi].
RECONFIG_STEP_RANGE = (1e-6, 0.5)
ROOT_TOL_RANGE = (1e-15, 0.1)
# MODEL 8 trajectory methods (model-notes D16): "sliding" (the default) is steepest descent on
# the grid that, where every neighbour is uphill, slides along the crease on the true energy;
# "grid8" is the paper-like 8-neighbour descent alone; "continuous" streamlines on the
# interpolated energy. The kernels receive the code (the index in this tuple).
TRAJECTORY_METHODS = ("sliding", "grid8", "continuous")
TRAJECTORY_SLIDING, TRAJECTORY_GRID8, TRAJECTORY_CONTINUOUS = 0, 1, 2
# Earlier versions called the 8-neighbour rule "discrete" (configs and stores say so).
TRAJECTORY_ALIASES = {"discrete": "grid8"}
# The continuous method's integrator step in grid steps (kernels/streamline.py): half a step
# resolves a turn within one grid cell.
STREAMLINE_STEP = 0.5


#: Scenario C's low friction when a config does not give it (MODEL 10: a near-frictionless
#: surface, as in variable-friction fingers).
DEFAULT_MU_LOW = 0.0


class ModelInputError(ValueError):
    """Bad user input, caught once at the edge (CLI exit code 2)."""


#: Lengths the model accepts (model units), and how far apart in scale the finger's and the
#: part's lengths (l1, l2, r, w > 0), and the two pulley radii, may be.
LENGTH_RANGE = (1e-100, 1e100)
LENGTH_SPAN = 1e12


def validate_inputs(design: Design, part: Part, command: Command, limits: Limits,
                    accuracy: Accuracy, effects: Effects | None = None) -> None:
    """Raise ModelInputError with a one-line message naming the bad value."""

    def positive(name, value):
        if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
            raise ModelInputError(f"{name} must be a positive number, got {value!r}")

    for name in ("l1", "l2", "r1", "r2"):
        positive(name, getattr(design, name))
    if not (math.isfinite(design.w) and design.w >= 0):
        raise ModelInputError(f"w must be >= 0, got {design.w!r}")
    positive("r", part.r)
    # Lengths far apart in scale (a denormal l2 = 5e-324 against l1 = 1) overflow or vanish in
    # the kernels' products: one scale within LENGTH_SPAN.
    lengths = {"l1": design.l1, "l2": design.l2, "r": part.r, "r1": design.r1,
               "r2": design.r2, **({"w": design.w} if design.w > 0 else {})}
    for name, value in lengths.items():
        if not LENGTH_RANGE[0] <= value <= LENGTH_RANGE[1]:
            raise ModelInputError(f"{name} must be in [{LENGTH_RANGE[0]:g}, "
                                  f"{LENGTH_RANGE[1]:g}] (model units), got {value!r}")
    for group in (("l1", "l2", "r", "w"), ("r1", "r2")):
        vals = {k: lengths[k] for k in group if k in lengths}
        small, large = min(vals, key=vals.get), max(vals, key=vals.get)
        if vals[large] > LENGTH_SPAN * vals[small]:
            raise ModelInputError(f"{small} = {vals[small]!r} and {large} = {vals[large]!r} "
                                  f"differ by more than a factor {LENGTH_SPAN:g}: give "
                                  f"lengths of one scale")
    if not (math.isfinite(part.mu) and part.mu >= 0):
        raise ModelInputError(f"mu must be >= 0, got {part.mu!r}")
    for name in ("f_left", "f_right"):
        v = getattr(command, name)
        if not (math.isfinite(v) and v >= 0):
            raise ModelInputError(f"{name} must be >= 0, got {v!r}")
    if command.f_left == 0 and command.f_right == 0:
        raise ModelInputError("f_left and f_right are both 0: nothing closes the fingers")
    # r1 == r2 (R = 1) is accepted: the kernels never divide by 1 - R (MODEL 5.4, model-notes D8).
    if limits.theta1_min_deg != 0.0 or limits.theta1_max_deg != 180.0:
        raise ModelInputError("theta1 limits other than [0, 180] deg are not supported")
    if not (-90.0 < limits.theta2_min_deg <= 0.0):
        raise ModelInputError(
            f"theta2_min must be in (-90, 0] deg (MODEL 1), got {limits.theta2_min_deg!r}")
    if not (limits.theta2_min_deg < limits.theta2_max_deg <= 180.0):
        raise ModelInputError(
            f"theta2_max must be in (theta2_min, 180] deg, got {limits.theta2_max_deg!r}")
    for name, (low, high) in (("reconfig_step", RECONFIG_STEP_RANGE),
                              ("root_tol", ROOT_TOL_RANGE)):
        value = getattr(accuracy, name)
        if not (math.isfinite(value) and low <= value <= high):
            raise ModelInputError(f"{name} must be in [{low:g}, {high:g}] rad, got {value!r}")
    if not step_resolution_ok(accuracy.step_resolution):
        low, high = STEP_RESOLUTION_RANGE
        raise ModelInputError(f"step_resolution must be 0 (off) or in [{low:g}, {high:g}], "
                              f"got {accuracy.step_resolution!r}")
    if accuracy.trajectory not in TRAJECTORY_METHODS:
        raise ModelInputError(f"trajectory method must be one of {', '.join(TRAJECTORY_METHODS)} "
                              f"(or 'discrete' for grid8), got {accuracy.trajectory!r}")
    if effects is not None:
        unsupported = set(effects.names_on()) - IMPLEMENTED_EFFECTS
        if unsupported:
            raise ModelInputError(f"effects not implemented yet: {', '.join(sorted(unsupported))}")
        for spec in EFFECTS:
            if spec.validate is not None and getattr(effects, spec.name):
                spec.validate(design, command, limits, effects)



def validate_finger_friction(effects: Effects, mu_left: float | None,
                             mu_right: float | None) -> None:
    """Each finger's own contact friction (MODEL 10, Scenario C; None: the part's mu): a
    number >= 0, and none above 0 without the friction effect (which makes every contact
    frictionless). One-line ModelInputError."""
    for name, value in (("mu_left", mu_left), ("mu_right", mu_right)):
        if value is None:
            continue
        if not (isinstance(value, (int, float)) and not isinstance(value, bool)
                and math.isfinite(value) and value >= 0):
            raise ModelInputError(f"{name} must be >= 0, got {value!r}")
        if value > 0 and not effects.friction:
            raise ModelInputError(f"{name} = {value!r} needs the friction effect (without it "
                                  "every contact is frictionless)")


def validate_springs(design: Design, command: Command, limits: Limits, effects: Effects) -> None:
    """Joint springs weaker than the tendon over the whole joint range (model-notes D13): then
    the tendon still closes both joints everywhere and the closing sequence (MODEL 4) holds."""
    for name in ("spring_k1", "spring_k2"):
        value = getattr(effects, name)
        if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
            raise ModelInputError(f"K{name[-1]} (joint_springs) must be >= 0, got {value!r}")
    tension = min(command.f_left, command.f_right)
    if tension <= 0:
        raise ModelInputError("joint_springs: both tendon tensions must be > 0 (a slack finger "
                              f"would be opened by its springs), got f_left = "
                              f"{command.f_left:g}, f_right = {command.f_right:g}")
    span2 = limits.theta2_max - limits.theta2_min
    for k, span, radius, joint in ((effects.spring_k1, math.pi, design.r1, "K1 pi < F r1"),
                                   (effects.spring_k2, span2, design.r2,
                                    "K2 (theta2_max - theta2_min) < F r2")):
        if not k * span < tension * radius:
            raise ModelInputError(f"joint_springs: the springs must be weaker than the tendon "
                                  f"over the joint range ({joint}), got K = {k!r}, "
                                  f"F = {tension!r}, r = {radius!r}")


def validate_scene(effects: Effects, outputs: Outputs) -> None:
    """Combinations of effects and outputs that are not implemented (one-line ModelInputError)."""
    outputs.validate()
    for spec in EFFECTS:
        for output, why in spec.no_outputs:
            if getattr(effects, spec.name) and getattr(outputs, output):
                raise ModelInputError(f"{output} with {spec.name} are not implemented ({why})")


# ---------------------------------------------------------------------------------------------
# The effects, one home each (MODEL 9)
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class EffectSpec:
    """One effect, declared once: what the model, the config, `sweep map`, the schema and the
    files know of it. Its switch is the `Effects` field `name`; its kernel block, if any, is
    declared beside its record in `sweep/kernels/records.py` (`BLOCKS`, the fields of
    `EffectBlocks`), docs/architecture.md's recipe."""

    name: str               # YAML key under `effects:`, name in `--effects`, `Effects` field
    #: its parameters, (YAML key and file attribute key, `Effects` field): given in the config
    #: as a mapping `NAME: {KEY: value, ...}` (each >= 0), written to every file as that mapping
    params: tuple = ()
    params_text: str = ""   # what the parameters are, for the config's "give the ..." message
    params_help: tuple = ()  # each parameter's `sweep map` flag help (the flag is --KEY)
    #: map outputs it cannot be combined with: (output, why) -> `validate_scene`'s message
    no_outputs: tuple = ()
    #: why the config refuses it with forces or the manipulation metric ("" if it does not)
    sweep_refusal: str = ""
    #: the validation of its parameters, `(design, command, limits, effects) -> None`, raising
    #: ModelInputError (`validate_inputs` calls it when the effect is on)
    validate: object = None
    #: summary counts stored only with it, (name, long_name): sweep.schema declares them (int32,
    #: after the other summary fields: the kernels' summary row), absent from other files
    summary_fields: tuple = ()
    #: categorical fields whose codes grow with it: field -> meanings of all its codes
    flags: tuple = ()

    def attributes(self, effects: "Effects") -> dict:
        """Its parameters as a file or resolved-config attribute (empty when off or none)."""
        if not (self.params and getattr(effects, self.name)):
            return {}
        return {self.name: {key: getattr(effects, field) for key, field in self.params}}


EFFECTS = (
    EffectSpec("friction"),
    EffectSpec("tip_contact",
               no_outputs=(("forces", "the contact forces of MODEL 5.6 have no tip contacts; "
                                      "model-notes D15"),),
               sweep_refusal="forces and the manipulation metric have no tip contacts "
                             "(model-notes D15); switch them off",
               flags=(("finger_mode", TIP_FINGER_MODE_MEANINGS),)),
    EffectSpec("joint_springs", params=(("K1", "spring_k1"), ("K2", "spring_k2")),
               params_text="stiffnesses, e.g. joint_springs: {K1: 0.01, K2: 0.01}",
               params_help=("Proximal joint spring stiffness", "Distal joint spring stiffness"),
               no_outputs=(("forces", "the contact forces of MODEL 5.6 leave the springs out"),),
               sweep_refusal="forces and the manipulation metric leave the springs out; switch "
                             "them off",
               validate=validate_springs),
    EffectSpec("finger_collision", summary_fields=(
        ("n_collision_changed", "feasible grid points where finger_collision changed a finger's "
                                "configuration (the fingers met while closing, model-notes D14)"),
    )),
)
EFFECT_NAMES = tuple(spec.name for spec in EFFECTS)
IMPLEMENTED_EFFECTS = frozenset(EFFECT_NAMES)


def effect_attributes(effects: Effects) -> dict:
    """Every effect's parameters that are on, as written to files and resolved configs."""
    out = {}
    for spec in EFFECTS:
        out.update(spec.attributes(effects))
    return out
