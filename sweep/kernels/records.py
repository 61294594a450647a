"""The records the kernels pass around: parameters in, results out (docs/architecture.md).

Every record is a flat `typing.NamedTuple`, which Numba compiles as a heterogeneous tuple: its
fields are read by name inside kernels at no cost, and a record can be captured by a `prange`
loop (a record nested in another record cannot, a limitation of Numba's parallel lowering, so
records hold numbers or arrays, never other records).

An *effect* that a scene may switch on (MODEL 9) is a separate argument: its own parameter
record, whose first field `on` says whether the effect is on. Every scene passes records of the
same types, so one compilation of the kernels serves every scene (a branch on a loop-invariant
flag costs nothing measurable: docs/performance.md); the kernels test `block.on` where the
physics needs the effect. Optional outputs likewise: the contact-force arrays and the
manipulation rows are empty arrays when they were not asked for.
"""
from typing import NamedTuple

import numpy as np

from .jit import entry, inner

#: The fingers' indices in (finger, y, x) arrays. NumPy integers, never Python ones, as every
#: constant a kernel passes to another kernel: Numba compiles a callee once per literal value of
#: a Python constant argument (docs/architecture.md, "One compilation for every scene").
LEFT = np.int64(0)
RIGHT = np.int64(1)


class FingerModel(NamedTuple):
    """One finger closing on the part: geometry, part, joint limits (MODEL 1-5), finger frame."""

    l1: float           # proximal link length
    l2: float           # distal link length
    r1: float           # proximal pulley radius
    r2: float           # distal pulley radius
    r: float            # part (disc) radius
    mu_s: float         # static friction coefficient of the part (0: frictionless): the palm's,
                        # and the links' unless Hand gives a finger another (side_finger)
    theta2_min: float   # distal joint limits (rad); theta1 is always within [0, pi]
    theta2_max: float


class SolverSettings(NamedTuple):
    """Accuracy settings (MODEL 8): of the reconfiguration path (MODEL 5.3) and of the
    trajectories (a run-time choice, one branch per map)."""

    reconfig_step: float    # step of theta1 along the path before bracketing a stop (rad)
    root_tol: float         # width to which the stop is bracketed (rad)
    trajectory: int         # model.TRAJECTORY_SLIDING, TRAJECTORY_GRID8 or TRAJECTORY_CONTINUOUS
    streamline_step: float  # integrator step of the continuous method, in grid steps
    step_resolution: float  # largest gap between the model's evaluations along a step (0: none)


class TipContact(NamedTuple):
    """The tip_contact effect (MODEL 9, model-notes D15): the tip and the distal joint are real
    contacts; a finger whose tip cannot hold follows the tip on the disc, stepped and bracketed
    by the reconfiguration path's accuracy settings (SolverSettings)."""

    on: bool


class JointSprings(NamedTuple):
    """The joint_springs effect (MODEL 6, 9): torsion springs K1 at the proximal joint
    (rest 0) and K2 at the distal joint (rest theta2_min), opposing the tendon.

    `tension` is the tendon tension of the finger being solved: the statics work per unit
    tension, so a finger's spring torque enters as K_i / tension (one block per finger)."""

    on: bool
    k1: float
    k2: float
    tension: float


class FingerCollision(NamedTuple):
    """The finger_collision effect (MODEL 9, model-notes D14): the fingers close together with
    a shared progress and stop where they first meet. The meeting is found by stepping the
    progress (rad of joint travel) and bracketing it to `tol`."""

    on: bool
    progress_step: float
    tol: float


# ---------------------------------------------------------------------------------------------
# The effect blocks: one table, one record of blocks
# ---------------------------------------------------------------------------------------------
#: Each effect's kernel block (model.EFFECTS names the effect): (name, builder, off), the builder
#: `(effects, accuracy, tension) -> block` called when the effect is on (`tension`: the tendon
#: tension of the finger the blocks are for), `off` the block of a scene without it (the same
#: types, so the same compiled kernels). This order is EffectBlocks'.
BLOCKS = (
    # the tip path is stepped and bracketed like the reconfiguration path (D15)
    ("tip_contact", lambda effects, accuracy, tension: TipContact(True), TipContact(False)),
    ("joint_springs", lambda effects, accuracy, tension: JointSprings(
        True, float(effects.spring_k1), float(effects.spring_k2), float(tension)),
     JointSprings(False, 0.0, 0.0, 1.0)),
    # the meeting progress is bracketed like a reconfiguration stop (same accuracy settings)
    ("finger_collision", lambda effects, accuracy, tension: FingerCollision(
        True, float(accuracy.reconfig_step), float(accuracy.root_tol)),
     FingerCollision(False, 0.0, 0.0)),
)
N_BLOCKS = len(BLOCKS)
EffectBlocks = NamedTuple("EffectBlocks", [(name, object) for name, _, _ in BLOCKS])
EffectBlocks.__doc__ = """The parameter block of every effect a scene may switch on (MODEL 9), in
the order of BLOCKS; a block's `on` says whether its effect is on."""

NO_EFFECTS = EffectBlocks(*(off for _, _, off in BLOCKS))


def effect_blocks(effects, accuracy, tension: float = 1.0):
    """The EffectBlocks of a map's `model.Effects` (an effect that is off: its `off` block)."""
    return EffectBlocks(*(build(effects, accuracy, tension) if getattr(effects, name) else off
                          for name, build, off in BLOCKS))


_SPRINGS = [name for name, _, _ in BLOCKS].index("joint_springs")
_AFTER_SPRINGS = _SPRINGS + 1   # Numba slices tuples by constants only


@inner
def with_joint_springs(effects, springs):
    """`effects` with its joint_springs block replaced by `springs`."""
    return EffectBlocks(*(effects[:_SPRINGS] + (springs,) + effects[_AFTER_SPRINGS:]))


class SettledFingers(NamedTuple):
    """What the sweep hands `meeting_search.resolve_collisions` about a map's settled fingers, from
    its cell's shared finger field: the link vectors of every shared point (`links`,
    (4, y, offset): l1 cos t1, l1 sin t1, l2 cos phi, l2 sin phi), where the left and right
    finger of world column i read offset start + stride * i, and `memo` (y, x, 5): per point
    the settled angles (t1 left, t2 left, t1 right, t2 right) last met at this width by the
    same thread, with their meeting (cells of one geometry group share most settled fingers),
    read if `memo_read` (it holds this cell's links) and written if `memo_write` (the sweep
    writes every meeting it computes: the memo is its thread's, kept across its cells).
    `known` False: none of this is known (`no_settled_fingers`), the links are computed from
    the angles."""

    known: bool
    links: np.ndarray
    left_start: int
    left_stride: int
    right_start: int
    right_stride: int
    memo: np.ndarray
    memo_read: bool
    memo_write: bool


@entry
def no_settled_fingers():
    """The SettledFingers of a map without a shared field: nothing known."""
    return SettledFingers(False, np.empty((4, 0, 0)), 0, 0, 0, 0, np.empty((0, 0, 5)), False,
                          False)


class Hand(NamedTuple):
    """What a map adds to two fingers of one geometry: palm width, tendon tensions, grid
    spacing, and the friction coefficient of each finger's contacts with the part (MODEL 10,
    Scenario C: a finger's surface may differ from the part's nominal mu_s, which FingerModel
    carries and the palm keeps; the paper's model has both equal to it)."""

    w: float
    f_left: float
    f_right: float
    h: float
    mu_left: float
    mu_right: float


class CellMaps(NamedTuple):
    """A batch of cells and the layout of their maps at every width of the sweep: what
    `many_maps.summarize_cells` computes (`compute.batch.cell_maps` builds it). The map of cell
    c at width k has columns i = -ncols[c, k] .. ncols[c, k] and rows y_j = r + j h,
    j = 0 .. nys[c] - 1."""

    cells: np.ndarray       # (n, 6) l1 l2 r1 r2 r mu (grid.CELL_COLUMNS), mu the contacts'
    widths: np.ndarray      # (n_w,) palm widths w
    palm_steps: np.ndarray  # (n_w,) int64: width k's palm half-width w/2 in grid steps
    ncols: np.ndarray       # (n, n_w) int64
    nys: np.ndarray         # (n,) int64
    h: float                # grid spacing
    f_left: float           # the command's tendon tensions
    f_right: float
    theta2_min: float       # distal joint limits (rad), as FingerModel's
    theta2_max: float


class MapPlace(NamedTuple):
    """Where the map of one width of a cell sits in what the cell's maps share: world column i
    (-ncol .. ncol) of the map reads offset i - palm_steps of the cell's shared finger field
    for the right finger and -i - palm_steps for the left (a shift and a mirror), at index
    offset - m_lo (the field's first offset); it is column i + ncol_max of the cell's per-pose
    force buffers (PoseForces, on the grid of the cell's widest map)."""

    width: int        # the width's index k
    m_lo: int
    palm_steps: int   # palm half-width in grid steps
    ncol: int
    ncol_max: int


class FieldStatics(NamedTuple):
    """Per offset of a cell's shared finger field (1, y, offset), what every width's map reads of
    it instead of recomputing: the link vectors (4, y, offset: l1 cos t1, l1 sin t1, l2 cos phi,
    l2 sin phi) and the finger's statics per unit tension in its own frame (3, y, offset:
    determined 1 or 0, resultant x, resultant y), (3, 0, 0) when only the links are needed."""

    links: np.ndarray
    statics: np.ndarray


class PoseForces(NamedTuple):
    """A cell's forces per pose for the manipulation metric (MODEL 10), on (y, pose column):
    count[j, a] forces so far, their components fx[j, a, :count], fy[j, a, :count]."""

    count: np.ndarray   # (y, columns) int64
    fx: np.ndarray      # (y, columns, slots)
    fy: np.ndarray


@inner
def new_pose_forces(ny, ncols, slots):
    """Empty PoseForces of ny x ncols poses, room for `slots` forces each."""
    return PoseForces(np.zeros((ny, ncols), dtype=np.int64), np.empty((ny, ncols, slots)),
                      np.empty((ny, ncols, slots)))


@inner
def no_pose_forces():
    """The PoseForces of a cell whose forces are not collected: no poses."""
    return PoseForces(np.zeros((0, 0), dtype=np.int64), np.empty((0, 0, 0)), np.empty((0, 0, 0)))


@inner
def no_field_statics():
    """The FieldStatics of a cell that needs neither links nor statics."""
    return FieldStatics(np.empty((4, 0, 0)), np.empty((3, 0, 0)))


@entry
def cell_finger(cells, c, theta2_min, theta2_max):
    """The FingerModel of row c of `cells` (n, 6): its columns l1 l2 r1 r2 r mu
    (grid.CELL_COLUMNS) are FingerModel's first six fields in their order, mu the contacts'
    friction (compute.layout.cells_as_kernels_read). The one place a FingerModel is made from
    parameters: the sweep's cells here, one map's through compute.layout.kernel_records."""
    return FingerModel(cells[c, 0], cells[c, 1], cells[c, 2], cells[c, 3], cells[c, 4],
                       cells[c, 5], theta2_min, theta2_max)


@inner
def side_finger(finger, hand, side):
    """The FingerModel of one finger of the hand (side LEFT or RIGHT): `finger` with its
    contacts' friction, hand.mu_left or hand.mu_right (MODEL 10, Scenario C). A finger solves
    alone (MODEL 4-5), so its friction is all that differs between the two."""
    return with_friction(finger, hand.mu_left if side == LEFT else hand.mu_right)


@inner
def with_friction(finger, mu):
    """`finger` with its contacts' friction `mu`."""
    return FingerModel(finger.l1, finger.l2, finger.r1, finger.r2, finger.r, mu,
                       finger.theta2_min, finger.theta2_max)


class FingerState(NamedTuple):
    """The configuration a finger ends in (MODEL 4, 5) and the contact it makes.

    mode is a FINGER_MODE code (or an internal code of kernels.finger before settling); k1 and k2
    locate the contacts on the proximal and distal link (0 where there is none, model-notes D6).
    """

    mode: int
    t1: float
    t2: float
    k1: float
    k2: float
    tip_overlap: bool


class FingerStatics(NamedTuple):
    """Contact forces of one finger on the part per unit tendon tension (MODEL 5.1, 5.6).

    Normal forces of the proximal and distal contact, the distal contact's tangential multiplier
    (the proximal one exerts no torque and is 0), the resultant on the part in the finger's own
    frame, and whether statics determine these forces (model-notes D9).
    """

    proximal_normal: float
    distal_normal: float
    distal_multiplier: float
    resultant_x: float
    resultant_y: float
    determined: bool


class FingerArrays(NamedTuple):
    """Per-finger fields on (finger, y, x): the FingerState of every grid point."""

    mode: np.ndarray         # int8
    t1: np.ndarray
    t2: np.ndarray
    k1: np.ndarray
    k2: np.ndarray
    tip_overlap: np.ndarray  # bool
    first_event: np.ndarray  # int8: the closing sequence's first contact (kernels.finger codes)


class OutcomeArrays(NamedTuple):
    """Per-point fields of a map on (y, x) (MODEL 7, 8); end_index is the flat index of the
    point where the trajectory started here ends (-1 where none starts)."""

    energy: np.ndarray
    point_class: np.ndarray   # int8
    equilibrium: np.ndarray   # bool
    contained: np.ndarray     # bool
    l_open: np.ndarray
    crossed: np.ndarray       # bool: the fingers' polylines intersect
    caged: np.ndarray         # bool
    caging_score: np.ndarray
    end_state: np.ndarray     # int8
    end_index: np.ndarray     # int64


class ForceArrays(NamedTuple):
    """Per-finger contact forces on (finger, y, x), per unit tension, world frame resultants."""

    proximal_normal: np.ndarray
    distal_normal: np.ndarray
    distal_multiplier: np.ndarray
    resultant_x: np.ndarray
    resultant_y: np.ndarray
    determined: np.ndarray    # bool
    geometric_cage_score: np.ndarray  # (y, x): S_geo of MODEL 10 at reached points, else 0


class ManipulationOut(NamedTuple):
    """Per-cell outputs of the manipulation metric (MODEL 10), one row per cell of a kernel call.

    Scenario B entries: every counted (pose, width) of the cell: the pose's flat index on the
    part's lattice, the force (f_L + f_R) S_geo of the command F_left = F_right = 1, the width's
    index, whether the fingers cross there; n_entries[c] may exceed the capacity (then the cell
    must be redone with more). Scenario A: a_metric[c] = sum over poses of the inscribed radius of
    the hull of the cell's forces over its widths and the commands F_left + F_right = 2.
    Scenario C (when c_mu_low has its one value, else empty): c_metric[c] the same over A's
    forces and those of each finger switched to the low friction c_mu_low[0] (the four friction
    pairs of MODEL 10)."""

    pose: np.ndarray          # (n_cells, capacity) int64
    fx: np.ndarray            # (n_cells, capacity)
    fy: np.ndarray
    width: np.ndarray         # (n_cells, capacity) int64
    crossed: np.ndarray       # (n_cells, capacity) bool
    n_entries: np.ndarray     # (n_cells,) int64
    a_metric: np.ndarray      # (n_cells,)
    lattice_ncol: np.ndarray  # (n_cells,) int64: the part lattice's columns are -N .. N
    a_commands: np.ndarray    # (n_commands,) F_left of Scenario A (F_right = 2 - F_left)
    a_pose_value: np.ndarray  # (n_cells, rows, columns) per-pose A values on the cell's widest
                              # map's grid when asked for (pictures), else (0, 0, 0)
    c_mu_low: np.ndarray      # (1,) Scenario C's low friction when asked for, else (0,)
    c_metric: np.ndarray      # (n_cells,) with Scenario C, else (0,)
    c_pose_value: np.ndarray  # as a_pose_value, of Scenario C


def no_scenario_c():
    """ManipulationOut's Scenario C fields when C is not asked for: (c_mu_low, c_metric,
    c_pose_value), empty."""
    return np.zeros(0), np.zeros(0), np.zeros((0, 0, 0))


def no_manipulation():
    """The ManipulationOut of a sweep without the manipulation metric: no rows (the same types
    as one with rows, so the same compiled kernels)."""
    return ManipulationOut(np.zeros((0, 0), dtype=np.int64), np.zeros((0, 0)), np.zeros((0, 0)),
                           np.zeros((0, 0), dtype=np.int64), np.zeros((0, 0), dtype=np.bool_),
                           np.zeros(0, dtype=np.int64), np.zeros(0), np.zeros(0, dtype=np.int64),
                           np.zeros(0), np.zeros((0, 0, 0)), *no_scenario_c())


@inner
def wants_manipulation(manip):
    """Whether the manipulation metric is asked for: `manip` has a row per cell."""
    return manip.n_entries.shape[0] > 0


@inner
def wants_scenario_c(manip):
    """Whether Scenario C is asked for with the manipulation metric: `manip` has its low
    friction."""
    return manip.c_mu_low.shape[0] > 0


@entry
def new_finger_arrays(n_fingers, ny, nx):
    shape = (n_fingers, ny, nx)
    return FingerArrays(np.empty(shape, dtype=np.int8), np.empty(shape), np.empty(shape),
                        np.empty(shape), np.empty(shape), np.empty(shape, dtype=np.bool_),
                        np.empty(shape, dtype=np.int8))


@entry
def new_outcome_arrays(ny, nx):
    shape = (ny, nx)
    return OutcomeArrays(np.empty(shape), np.empty(shape, dtype=np.int8),
                         np.empty(shape, dtype=np.bool_), np.empty(shape, dtype=np.bool_),
                         np.empty(shape), np.empty(shape, dtype=np.bool_),
                         np.empty(shape, dtype=np.bool_), np.empty(shape),
                         np.empty(shape, dtype=np.int8), np.empty(shape, dtype=np.int64))


@entry
def new_force_arrays(ny, nx):
    """ForceArrays of a map of ny x nx points; of 0 x 0 where forces were not asked for."""
    shape = (2, ny, nx)
    return ForceArrays(np.empty(shape), np.empty(shape), np.empty(shape), np.empty(shape),
                       np.empty(shape), np.empty(shape, dtype=np.bool_), np.zeros((ny, nx)))


@entry
def no_force_arrays():
    """The ForceArrays of a map whose contact forces are not asked for."""
    return new_force_arrays(np.int64(0), np.int64(0))


@inner
def with_forces(forces):
    """Whether a map's contact forces are asked for: its ForceArrays have room for them."""
    return forces.geometric_cage_score.size > 0
