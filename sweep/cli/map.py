"""`sweep map`: one energy map (`sweep.compute.maps.compute_map`), written to a map file and
optionally drawn.

Input is validated once, here at the edge, before anything is written: a bad value gives a
one-line message and exit code 2 (`sweep.cli.common.user_errors`, which every command runs in).
"""
from __future__ import annotations

import contextlib

import click

from ..model import (  # plain Python: cheap
    EFFECT_NAMES, EFFECTS, TRAJECTORY_ALIASES, TRAJECTORY_METHODS, Accuracy,
)
from .common import MAP_OUT, PICTURE_OUT, THREADS, WAIT, SweepCommand, UserError, real_path


def effect_parameter_options(command):
    """One option per effect parameter of model.EFFECTS (`--K1`, `--K2`), into the command's
    `effect_params` keyword (`Effects` field -> value or None)."""
    for spec in reversed(EFFECTS):
        for (key, field), text in reversed(tuple(zip(spec.params, spec.params_help))):
            command = click.option(f"--{key}", field, type=float, default=None,
                                   help=f"{text} (with --effects ...,{spec.name}).")(command)
    return command


@click.command("map", cls=SweepCommand)
@click.option("--l1", type=float, required=True, help="Proximal link length.")
@click.option("--l2", type=float, required=True, help="Distal link length.")
@click.option("--r1", type=float, required=True, help="Proximal pulley radius.")
@click.option("--r2", type=float, required=True, help="Distal pulley radius (R = r2/r1).")
@click.option("--w", "w", type=float, required=True, help="Palm width (finger bases at +-w/2).")
@click.option("--r", "r", type=float, required=True, help="Part (disc) radius.")
@click.option("--mu", type=float, required=True,
              help="Static friction coefficient of the part: against the palm, and against each "
                   "finger unless --mu-left/--mu-right say otherwise.")
@click.option("--mu-left", type=float, default=None,
              help="Friction coefficient of the left finger's contacts [default: --mu] (a "
                   "switched finger surface, MODEL 10 Scenario C; the palm keeps --mu).")
@click.option("--mu-right", type=float, default=None,
              help="Friction coefficient of the right finger's contacts [default: --mu].")
@click.option("--h", "h", type=float, default=0.05, show_default=True, help="Grid spacing.")
@click.option("--xlim", type=(float, float), default=None, metavar="XMIN XMAX",
              help="Window in x (default: the whole reach, mirror-symmetric).")
@click.option("--ylim", type=(float, float), default=None, metavar="YMIN YMAX",
              help="Window in y (default: from the palm row y = r to the whole reach).")
@click.option("--f-left", type=float, default=1.0, show_default=True,
              help="Left tendon tension.")
@click.option("--f-right", type=float, default=1.0, show_default=True,
              help="Right tendon tension.")
@click.option("--theta2-min", type=float, default=-5.0, show_default=True,
              help="Distal lower joint limit (deg, <= 0).")
@click.option("--theta2-max", type=float, default=90.0, show_default=True,
              help="Distal upper joint limit (deg).")
@click.option("--reconfig-step", type=float, default=Accuracy.reconfig_step, show_default=True,
              help="Reconfiguration step in theta1 (rad) before bracketing the stop.")
@click.option("--root-tol", type=float, default=Accuracy.root_tol, show_default=True,
              help="Root tolerance of the reconfiguration stop (rad).")
@click.option("--trajectory", type=click.Choice(TRAJECTORY_METHODS + tuple(TRAJECTORY_ALIASES)),
              default=Accuracy.trajectory, show_default=True,
              help="Trajectory method (MODEL 8, docs/model-notes.md D16): sliding follows "
                   "creases of the energy; grid8 is the paper-like 8-neighbour descent "
                   "('discrete' is its old name); continuous, streamlines.")
@THREADS
@click.option("--out", type=MAP_OUT, required=True,
              help="Map file to write (HDF5; opens with xarray, engine='h5netcdf').")
@click.option("--plot", "plot_path", type=PICTURE_OUT, default=None,
              help="Also draw the map to this PNG.")
@click.option("--forces/--no-forces", default=False, show_default=True,
              help="Also store each finger's contact forces on the part per unit tendon tension "
                   "(normal forces, distal friction multiplier, resultant; MODEL 5.1, 5.6).")
@click.option("--outputs", "outputs_spec", default=None, metavar="NAMES",
              help="Comma-separated outputs to compute: energy, equilibrium, caging, forces "
                   "[default: energy,equilibrium,caging]; only these are computed (MODEL 9).")
@click.option("--effects", "effects_spec", default=None, metavar="NAMES",
              help=f"Comma-separated effects on (all of them, friction included): "
                   f"{', '.join(EFFECT_NAMES)} [default: friction]; 'none' for the "
                   f"frictionless base model.")
@effect_parameter_options
@click.option("--overwrite", is_flag=True, help="Replace existing --out / --plot files.")
@WAIT
def map_command(l1, l2, r1, r2, w, r, mu, mu_left, mu_right, h, xlim, ylim, f_left, f_right,
                theta2_min, theta2_max, reconfig_step, root_tol, trajectory, threads, out,
                plot_path, forces, outputs_spec, effects_spec, overwrite, wait, **effect_params):
    """Compute one energy map and write it to --out (and optionally a picture to --plot).

    Per grid point of part centres: finger configurations and modes, energy, class, part
    equilibrium, containment, L_open, trajectory end state and caging score. Example:

        sweep map --l1 2.0 --l2 1.6 --r1 0.2 --r2 0.14 --w 0.8 --r 0.4 --mu 0.4 --out map.h5

    With --mu-left/--mu-right each finger touches the part with its own friction (a finger
    switched to a low-friction surface, as in Scenario C of the manipulation metric):

        sweep map ... --mu 0.4 --mu-left 0 --out switched.h5
    """
    from ..compute.layout import map_grid
    from ..compute.maps import compute_map
    from ..compute.warm import ensure_compiled
    from ..grid import map_bytes_per_point
    from ..model import (
        Command, Design, Grid, Limits, ModelInputError, Part, validate_finger_friction,
        validate_inputs, validate_scene,
    )
    from ..files import check_output_file, claim_output
    from ..runs.runner import RunError, numba_threads, resolve_threads

    design = Design(l1, l2, r1, r2, w)
    part = Part(r, mu)
    command = Command(f_left, f_right)
    grid = Grid(h=h, xlim=tuple(xlim) if xlim else None, ylim=tuple(ylim) if ylim else None)
    limits = Limits(theta2_min_deg=theta2_min, theta2_max_deg=theta2_max)
    accuracy = Accuracy(reconfig_step=reconfig_step, root_tol=root_tol, trajectory=trajectory)
    try:
        outputs = _outputs_from_flags(outputs_spec, forces)
        effects = _effects_from_flags(effects_spec, effect_params, mu)
        validate_inputs(design, part, command, limits, accuracy, effects)
        try:
            validate_finger_friction(effects, mu_left, mu_right)
        except ModelInputError as err:
            raise ModelInputError(f"--{str(err).replace('_', '-', 1)}") from None
        try:
            validate_scene(effects, outputs)
        except ModelInputError as err:
            raise ModelInputError(f"--outputs with --effects: {err}") from None
        # sizes the grid and checks that its arrays and the file image fit in memory
        map_grid(design, part, grid, map_bytes_per_point(outputs.forces, written=True))
        _check_window_meets_reach(design, part, grid)
        threads = resolve_threads(threads)
    except (ModelInputError, RunError) as err:   # SceneError is a ModelInputError
        raise UserError(str(err)) from None
    if plot_path is not None and not outputs.caging:
        raise UserError("--plot draws trajectories and caging scores: it needs the caging "
                        "output (--outputs energy,equilibrium,caging)")
    if plot_path is not None and real_path(plot_path) == real_path(out):
        raise UserError(f"--plot: {plot_path} is also --out; the picture would replace the map")

    from ..storage.mapfile import describe, write_map

    # Both outputs are checked and locked before the map is computed.
    # (In path order, so two waiting commands with swapped --out/--plot cannot deadlock.)
    outputs_in_order = sorted({out, plot_path} - {None}, key=lambda p: str(real_path(p)))
    for path in outputs_in_order:       # all refusals before any folder is created
        check_output_file(path, overwrite=overwrite)
    with contextlib.ExitStack() as claimed:
        for path in outputs_in_order:
            claimed.enter_context(claim_output(path, overwrite=overwrite, wait=wait))
        with numba_threads(threads):
            # the first time, the kernels compile (one line says so), so that the timing
            # reported for the map is the computation alone
            ensure_compiled()
            m = compute_map(design, part, command, grid, limits, accuracy, effects,
                            outputs=outputs, mu_left=mu_left, mu_right=mu_right)
        write_map(out, m)
        click.echo(describe(m))
        if m.attrs["n_infeasible"] + m.attrs["n_unreached"] == m.attrs["n_points"]:
            click.echo(f"warning: no grid point of this map has a finger touching the part "
                       f"({m.attrs['n_infeasible']} infeasible, {m.attrs['n_unreached']} "
                       "unreached): widen --xlim/--ylim or check the design", err=True)
        click.echo(f"wrote {out}")
        if plot_path is not None:
            from ..report.plot import plot_map

            plot_map(m, plot_path)
            click.echo(f"wrote {plot_path}")


def _check_window_meets_reach(design, part, grid):
    """A window wholly outside the reach would give a map with no point to speak of (every
    point unreached, or below the palm row and infeasible): refused, ModelInputError."""
    from ..grid import reach
    from ..model import PALM_TOL, ModelInputError

    X, Y = reach(design, part)
    if grid.xlim is not None and (grid.xlim[1] < -X or grid.xlim[0] > X):
        raise ModelInputError(f"--xlim {grid.xlim[0]:g} {grid.xlim[1]:g} lies outside the "
                              f"fingers' reach (|x| <= {X:g}): every point would be unreached; "
                              "move the window or drop --xlim")
    if grid.ylim is not None and grid.ylim[1] < part.r - PALM_TOL:
        raise ModelInputError(f"--ylim {grid.ylim[0]:g} {grid.ylim[1]:g} lies below the palm row "
                              f"y = r = {part.r:g}: every point would be infeasible; move the "
                              "window up or drop --ylim")
    if grid.ylim is not None and grid.ylim[0] > Y:
        raise ModelInputError(f"--ylim {grid.ylim[0]:g} {grid.ylim[1]:g} lies above the fingers' "
                              f"reach (y <= {Y:g}): every point would be unreached; move the "
                              "window or drop --ylim")


def _outputs_from_flags(spec, forces):
    """The Outputs of `--outputs` (and the older `--forces`); ModelInputError if bad."""
    from ..model import ModelInputError, Outputs

    if spec is None:
        return Outputs(forces=forces)
    names = [n.strip() for n in spec.split(",") if n.strip()]
    try:
        return Outputs.from_names(names + (["forces"] if forces else []))
    except ModelInputError as err:
        msg = str(err).removeprefix("outputs: ")
        raise ModelInputError(f"--outputs: {msg}") from None


def _effects_from_flags(spec, effect_params, mu):
    """The Effects of `--effects` and the effect parameters' flags, checked by the config's own
    `effects_from_switches`; ModelInputError (SceneError) if bad."""
    from ..config.parse import effects_from_switches
    from ..model import ModelInputError

    if spec is None:
        names = ["friction"]
    elif spec.strip() == "none":
        names = []
    else:
        names = [n.strip() for n in spec.split(",") if n.strip()]
    unknown = [n for n in names if n not in EFFECT_NAMES]
    if unknown:
        raise ModelInputError(f"--effects: unknown effect {unknown[0]!r} "
                              f"(valid: {', '.join(EFFECT_NAMES)}, or none)")
    params = {}
    for effect in EFFECTS:
        given = {key: effect_params[field] for key, field in effect.params
                 if effect_params.get(field) is not None}
        if given:
            params[effect.name] = given
    return effects_from_switches({n: n in names for n in EFFECT_NAMES}, params, (mu,), cli=True)
