"""Sweep configs from YAML: loading, validation and expansion into a `Scene` (`load_scene`,
`scene_from_dict`), each error a one-line `SceneError` naming its key. The rules of the values
(ranges, lists, exact decimal expansion, work order) are in `sweep/config/scene.py`'s docstring.
"""
from __future__ import annotations

import contextlib
import dataclasses
import json
import math
import re
from decimal import Decimal, InvalidOperation
from pathlib import Path

import yaml

from ..grid import cell_bytes, cell_extent
from ..files import StoreError
from ..model import (DEFAULT_MU_LOW, DEFAULT_STEP_RESOLUTION, EFFECTS, IMPLEMENTED_EFFECTS,
                     RECONFIG_STEP_RANGE, ROOT_TOL_RANGE, STEP_RESOLUTION_RANGE,
                     TRAJECTORY_METHODS, Accuracy, Command, Design, Effects, Limits,
                     ModelInputError, Outputs, Part, step_resolution_ok, validate_inputs)
from .scene import (ACCURACY_KEYS, COMMAND_KEYS, DESIGN_KEYS, EFFECT_KEYS, GRID_BOUNDS, GRID_KEYS,
                    LIMIT_KEYS, MAP_OUTPUT_KEYS, MAX_MAP_BYTES, MAX_REFINE_LEVELS,
                    MAX_VALUES_PER_PARAMETER, MIN_POINTS_PER_AXIS, OUTPUT_KEYS, PART_KEYS,
                    RANGE_KEYS, REFINE_KEYS, RUN_KEYS, RefineSettings, SAVE_MAP_KEYS,
                    SCENARIO_C_KEYS, STORE_DIMS, Scene, SceneError, TOO_MANY_POINTS, TOP_KEYS,
                    grid_points, grid_shape, index_of)

_NAME_RE = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]*$")


# ---------------------------------------------------------------------------------------------
# Loading
# ---------------------------------------------------------------------------------------------
class _UniqueKeyLoader(yaml.SafeLoader):
    """SafeLoader that refuses duplicate mapping keys (PyYAML silently keeps the last one)."""


def _construct_mapping(loader, node, deep=False):
    seen = set()
    for key_node, _ in node.value:
        key = loader.construct_object(key_node, deep=deep)
        if key in seen:
            raise SceneError(f"{key}: duplicate key (line {key_node.start_mark.line + 1})")
        seen.add(key)
    return yaml.SafeLoader.construct_mapping(loader, node, deep=deep)


_UniqueKeyLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _construct_mapping)
# YAML 1.1 (PyYAML) reads 1e-12 (no dot) as a string; read it as the number YAML 1.2 and every
# reader means, so that numbers can be checked strictly (a quoted "0.2" is refused).
_UniqueKeyLoader.add_implicit_resolver(
    "tag:yaml.org,2002:float", re.compile(r"^[-+]?(?:[0-9][0-9_]*)(?:\.[0-9_]*)?[eE][-+]?[0-9]+$"),
    list("-+0123456789"))


def load_scene(path: str | Path) -> Scene:
    """Read, validate and expand a YAML config. Raises SceneError naming the bad key."""
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise SceneError(f"{path}: cannot read config ({exc.strerror or exc})") from None
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:   # e.g. an HDF5 store given where the config goes
        raise SceneError(f"{path}: not a YAML config (byte {exc.start} is not UTF-8 text); "
                         "give the sweep's .yaml file") from None
    try:
        raw = yaml.load(text, Loader=_UniqueKeyLoader)
    except yaml.YAMLError as exc:
        where = getattr(exc, "problem_mark", None)
        line = f" (line {where.line + 1})" if where is not None else ""
        problem = str(getattr(exc, "problem", None) or exc).splitlines()[0]
        raise SceneError(f"{path.name}: not valid YAML{line}: {problem}") from None
    except RecursionError:
        raise SceneError(f"{path.name}: not a config: nested too deeply") from None
    return dataclasses.replace(scene_from_dict(raw, default_name=path.stem), path=str(path))


#: `looks_like_config`: a top-level key every config has, at the start of a line.
_CONFIG_KEY = re.compile(rb"^(designs|parts)\s*:", re.M)


def looks_like_config(head: bytes, name: str) -> bool:
    """Whether a file looks like a sweep config from its name and first bytes: a .yaml or .yml
    name, or text with a top-level `designs:` or `parts:` key (what `load_scene` requires)."""
    return Path(name).suffix.lower() in (".yaml", ".yml") or bool(_CONFIG_KEY.search(head))


def scene_from_dict(raw, default_name: str = "sweep") -> Scene:
    """Validate and expand a parsed config mapping."""
    raw = _mapping(raw, "config", TOP_KEYS, required=("designs", "parts"))

    name = raw.get("name", default_name)
    if not isinstance(name, str):
        raise SceneError(f"name: must be text, got the {type(name).__name__} {name!r}; quote it "
                         f"(name: \"{name}\")")
    if not _NAME_RE.match(name):
        raise SceneError(f"name: must start with a letter or digit and hold only letters, "
                         f"digits, '_', '.' or '-' (used in file and job names), got {name!r}")

    values = {}
    designs = _mapping(raw["designs"], "designs", DESIGN_KEYS, required=DESIGN_KEYS)
    parts = _mapping(raw["parts"], "parts", PART_KEYS, required=PART_KEYS)
    for k in DESIGN_KEYS:
        values[k] = _expand(designs[k], f"designs.{k}")
    for k in PART_KEYS:
        values[k] = _expand(parts[k], f"parts.{k}")
    _check_physical(values)

    commands = _commands(raw.get("commands", [dict(f_left=1.0, f_right=1.0)]))

    grid = _mapping(raw.get("grid", {}), "grid", GRID_KEYS)
    h = _number(grid.get("h", 0.05), "grid.h")
    if not h > 0:
        raise SceneError(f"grid.h: must be > 0, got {h!r}")
    bounds = grid.get("bounds", "reach")
    if bounds not in GRID_BOUNDS:
        raise SceneError(f"grid.bounds: must be one of {', '.join(GRID_BOUNDS)} (the whole reach "
                         f"of each design, MODEL 8), got {bounds!r}")

    lim = _mapping(raw.get("limits", {}), "limits", LIMIT_KEYS)
    limits = Limits(
        theta2_min_deg=_number(lim.get("theta2_min_deg", -5.0), "limits.theta2_min_deg"),
        theta2_max_deg=_number(lim.get("theta2_max_deg", 90.0), "limits.theta2_max_deg"))
    if not -90.0 < limits.theta2_min_deg <= 0.0:
        raise SceneError(f"limits.theta2_min_deg: must be in (-90, 0] (MODEL 1), "
                         f"got {limits.theta2_min_deg!r}")
    if not limits.theta2_min_deg < limits.theta2_max_deg <= 180.0:
        raise SceneError(f"limits.theta2_max_deg: must be in (theta2_min_deg, 180], "
                         f"got {limits.theta2_max_deg!r}")

    acc = _mapping(raw.get("accuracy", {}), "accuracy", ACCURACY_KEYS)
    accuracy = Accuracy(
        reconfig_step=_number(acc.get("reconfig_step", 0.01), "accuracy.reconfig_step"),
        root_tol=_number(acc.get("root_tol", 1e-12), "accuracy.root_tol"),
        trajectory=acc.get("trajectory", Accuracy.trajectory),
        step_resolution=_number(acc.get("step_resolution", DEFAULT_STEP_RESOLUTION),
                                "accuracy.step_resolution"))
    for key, (low, high) in (("reconfig_step", RECONFIG_STEP_RANGE),
                             ("root_tol", ROOT_TOL_RANGE)):
        value = getattr(accuracy, key)
        if not (math.isfinite(value) and low <= value <= high):
            raise SceneError(f"accuracy.{key}: must be in [{low:g}, {high:g}] rad, "
                             f"got {value!r}")
    if not step_resolution_ok(accuracy.step_resolution):
        low, high = STEP_RESOLUTION_RANGE
        raise SceneError(f"accuracy.step_resolution: must be 0 (off) or in [{low:g}, {high:g}], "
                         f"got {accuracy.step_resolution!r}")
    if accuracy.trajectory not in TRAJECTORY_METHODS:
        raise SceneError(f"accuracy.trajectory: {accuracy.trajectory!r} is not implemented "
                         f"(valid: {', '.join(TRAJECTORY_METHODS)}; 'discrete' means grid8)")

    switches, params = _effect_switches(raw.get("effects", {}))
    effects = effects_from_switches(switches, params, values["mu"])

    # Backstop: the model's own edge validation on the extreme corners of the sweep.
    for pick in (min, max):
        design = Design(**{k: pick(values[k]) for k in DESIGN_KEYS})
        part = Part(r=pick(values["r"]), mu=pick(values["mu"]))
        for c in commands:
            try:
                validate_inputs(design, part, c, limits, accuracy, effects)
            except ModelInputError as exc:
                raise SceneError(f"config: {exc}") from None

    _check_countable(values, h)
    _check_coarse(values, h)

    outputs = _mapping(raw.get("outputs", {}) or {}, "outputs", OUTPUT_KEYS)
    map_outputs = {}
    for k in MAP_OUTPUT_KEYS:
        v = outputs.get(k, getattr(Outputs(), k))
        if not isinstance(v, bool):
            raise SceneError(f"outputs.{k}: must be true or false, got {v!r}")
        map_outputs[k] = v
    map_outputs = Outputs(**map_outputs)
    try:
        map_outputs.validate()
    except ModelInputError as exc:
        raise SceneError(str(exc)) from None
    if not map_outputs.caging:
        # the store's summaries are caging summaries (Lambda ranks the designs); an energy-only
        # map is `sweep map --outputs energy`
        raise SceneError("outputs.caging: a sweep stores caging summaries and needs it on; for "
                         "energy-only maps use `sweep map --outputs energy`")
    save_maps = _save_maps(outputs.get("save_maps", []) or [], values, len(commands))
    manipulation = outputs.get("manipulation", False)
    if not isinstance(manipulation, bool):
        raise SceneError(f"outputs.manipulation: must be true or false, got {manipulation!r}")
    top_k = outputs.get("scenario_a_top_k", 10)
    if isinstance(top_k, bool) or not isinstance(top_k, int) or top_k < 1:
        raise SceneError(f"outputs.scenario_a_top_k: must be a whole number >= 1, got {top_k!r}")
    if manipulation:
        if len(commands) != 1:
            raise SceneError("outputs.manipulation: needs exactly one command (the caging "
                             "sweep's); Scenarios A and B use their own (MODEL 10)")
        for w in values["w"]:
            s = w / (2.0 * h)
            if abs(s - round(s)) > 1e-9:
                raise SceneError(f"outputs.manipulation: every palm width must be a multiple of "
                                 f"2h = {2 * h:g} (poses are shared lattice points); w = {w:g}")

    mu_low = _scenario_c(outputs.get("scenario_c", False), manipulation, effects)

    _check_memory(values, h, manipulation, mu_low is not None)

    if effects.joint_springs:
        if any((c.f_left, c.f_right) != (1.0, 1.0) for c in commands):
            # the sweep solves one finger field for both fingers at unit tension
            raise SceneError("effects.joint_springs: a sweep with springs needs the command "
                             "f_left = f_right = 1 (scale K1, K2 instead)")

    for spec in EFFECTS:
        if (spec.sweep_refusal and getattr(effects, spec.name)
                and (map_outputs.forces or manipulation)):
            raise SceneError(f"effects.{spec.name}: {spec.sweep_refusal}")

    refine = refine_settings(raw.get("refine", False), values, h)

    run = _mapping(raw.get("run", {}) or {}, "run", RUN_KEYS)
    sub = run.get("sub_chunk_cells")
    if sub is not None and (isinstance(sub, bool) or not isinstance(sub, int) or sub < 1):
        raise SceneError(f"run.sub_chunk_cells: must be a whole number >= 1, got {sub!r}")

    return Scene(name=name, values=values, commands=commands, h=h, bounds=bounds, limits=limits,
                 accuracy=accuracy, effects=effects, save_maps=save_maps, sub_chunk_cells=sub,
                 outputs=map_outputs, manipulation=manipulation, scenario_a_top_k=top_k,
                 scenario_c_mu_low=mu_low, refine=refine, source=_jsonable(raw))


def _scenario_c(raw, manipulation: bool, effects) -> float | None:
    """`outputs.scenario_c` (MODEL 10, friction modulation): false (off), true (on with the
    default low friction) or `{mu_low: value}`; the low friction, None when off. One-line
    SceneError naming the key."""
    if raw is False or raw is None:
        return None
    if raw is True:
        raw = {}
    elif not isinstance(raw, dict):
        raise SceneError(f"outputs.scenario_c: must be true, false or a mapping such as "
                         f"{{mu_low: 0.0}}, got {raw!r}")
    given = _mapping(raw, "outputs.scenario_c", SCENARIO_C_KEYS)
    mu_low = given.get("mu_low", DEFAULT_MU_LOW)
    if (isinstance(mu_low, bool) or not isinstance(mu_low, (int, float))
            or not math.isfinite(mu_low) or mu_low < 0):
        raise SceneError(f"outputs.scenario_c.mu_low: must be a number >= 0, got {mu_low!r}")
    if not manipulation:
        raise SceneError("outputs.scenario_c: is part of the manipulation metric; set "
                         "outputs.manipulation: true")
    if not effects.friction:
        raise SceneError("outputs.scenario_c: switches the fingers' friction and needs the "
                         "friction effect (effects.friction is false: every contact is "
                         "frictionless)")
    return float(mu_low)


# ---------------------------------------------------------------------------------------------
# Pieces
# ---------------------------------------------------------------------------------------------
def _effect_switches(eff) -> tuple[dict, dict]:
    """A config's `effects:` mapping -> the effects it switches on or off (name -> bool) and the
    parameters it gives (name -> {key: value}); `NAME: {KEY: value, ...}` switches NAME on."""
    eff = _mapping(eff, "effects", EFFECT_KEYS)
    switches, params = {}, {}
    for spec in EFFECTS:
        given = eff.get(spec.name, spec.name == "friction")
        if spec.params and isinstance(given, dict):
            keys = tuple(key for key, _ in spec.params)
            params[spec.name] = _mapping(given, f"effects.{spec.name}", keys, required=keys)
            given = True
        if not isinstance(given, bool):
            raise SceneError(f"effects.{spec.name}: must be true or false, got {given!r}")
        switches[spec.name] = given
    return switches, params


def effects_from_switches(switches: dict, params: dict, mus, cli: bool = False) -> Effects:
    """The one check of effect switches and parameters (model.EFFECTS), for a config's
    `effects:` and for `sweep map`'s `--effects` and parameter flags (`cli`: the messages name
    the flags). switches: name -> on; params: name -> {key: value} as given; mus: the friction
    coefficients of the parts. A one-line SceneError naming the key or flag."""
    flags = {}
    for spec in EFFECTS:
        on, given = switches.get(spec.name, False), params.get(spec.name)
        keys = tuple(key for key, _ in spec.params)
        if on and spec.name not in IMPLEMENTED_EFFECTS:
            raise SceneError(f"effects.{spec.name}: not implemented yet (implemented: "
                             f"{', '.join(sorted(IMPLEMENTED_EFFECTS))}); set it to false")
        if on and keys and (given is None or set(given) != set(keys)):
            raise SceneError(f"--effects {spec.name} needs {' and '.join('--' + k for k in keys)}"
                             if cli else f"effects.{spec.name}: give the {spec.params_text}")
        if given is not None and not on:   # only flags give parameters apart from the switch
            raise SceneError(f"{'/'.join('--' + k for k in keys)} are {spec.name}'s parameters: "
                             f"add {spec.name} to --effects")
        for key, field in spec.params if on else ():
            where = f"--{key}" if cli else f"effects.{spec.name}.{key}"
            value = _number(given[key], where)
            if not value >= 0:
                raise SceneError(f"{where}: must be >= 0, got {value!r}")
            flags[field] = value
        flags[spec.name] = on
    effects = Effects(**flags)
    if not effects.friction and any(m != 0 for m in mus):
        raise SceneError(f"--effects lists every effect on and friction is not among them, so "
                         f"--mu must be 0 (got {mus[0]}); add friction to keep it" if cli else
                         "effects.friction: false, but parts.mu has values other than 0; for a "
                         "frictionless sweep write parts.mu: [0.0]")
    return effects


def _mapping(obj, key: str, valid, required=()) -> dict:
    if not isinstance(obj, dict):
        raise SceneError(f"{key}: must be a mapping with keys {', '.join(valid)}, "
                         f"got {type(obj).__name__} {obj!r}")
    for k in obj:
        if k not in valid:
            raise SceneError(f"{_join(key, k)}: unknown key (valid: {', '.join(valid)})")
    for k in required:
        if k not in obj:
            raise SceneError(f"{_join(key, k)}: missing (required: {', '.join(required)})")
    return obj


def _join(prefix: str, k) -> str:
    return str(k) if prefix == "config" else f"{prefix}.{k}"


def _number(v, key: str) -> float:
    """A finite number. Quoted strings are refused, as a strict schema would (the loader reads
    YAML 1.1's unquoted ``1e-12`` as a number)."""
    if isinstance(v, bool):
        raise SceneError(f"{key}: must be a number, got {v!r}")
    if isinstance(v, str):
        hint = ""
        with contextlib.suppress(ValueError):
            float(v)
            hint = " (a quoted string: write the number without quotes)"
        raise SceneError(f"{key}: must be a number, got {v!r}{hint}")
    if not isinstance(v, (int, float)) or not math.isfinite(v):
        raise SceneError(f"{key}: must be a finite number, got {v!r}")
    return float(v)


def _decimal(v: float) -> Decimal:
    return Decimal(repr(float(v)))


def _expand(spec, key: str) -> tuple[float, ...]:
    """A parameter spec -> strictly increasing tuple of floats (see the module docstring)."""
    if isinstance(spec, dict):
        _mapping(spec, key, RANGE_KEYS, required=RANGE_KEYS)
        lower, upper, step = (_number(spec[k], f"{key}.{k}") for k in RANGE_KEYS)
        if not step > 0:
            raise SceneError(f"{key}.step: must be > 0, got {spec['step']!r}")
        if lower > upper:
            raise SceneError(f"{key}: empty range, lower ({lower!r}) > upper ({upper!r})")
        lo, up, st = _decimal(lower), _decimal(upper), _decimal(step)
        try:
            n = int((up - lo) // st) + 1
        except InvalidOperation:
            n = MAX_VALUES_PER_PARAMETER + 1
        if n > MAX_VALUES_PER_PARAMETER:
            raise SceneError(f"{key}.step: {step!r} gives {n} values, more than "
                             f"{MAX_VALUES_PER_PARAMETER}")
        return tuple(float(lo + i * st) for i in range(n))
    if isinstance(spec, list):
        if not spec:
            raise SceneError(f"{key}: empty list")
        vals = tuple(_number(v, f"{key}[{i}]") for i, v in enumerate(spec))
        for i in range(1, len(vals)):
            if not vals[i] > vals[i - 1]:
                raise SceneError(f"{key}[{i}]: list must be strictly increasing, got "
                                 f"{vals[i]!r} after {vals[i - 1]!r}")
        return vals
    if isinstance(spec, (int, float, str)) and not isinstance(spec, bool):
        return (_number(spec, key),)
    raise SceneError(f"{key}: must be {{lower, upper, step}}, a list or a number, got {spec!r}")


_PHYSICAL = dict(l1="designs.l1", l2="designs.l2", r1="designs.r1", r2="designs.r2",
                 w="designs.w", r="parts.r", mu="parts.mu")


def _check_physical(values: dict) -> None:
    for k, key in _PHYSICAL.items():
        lo = values[k][0]
        if k in ("w", "mu"):
            if lo < 0:
                raise SceneError(f"{key}: must be >= 0, got {lo!r}")
        elif not lo > 0:
            raise SceneError(f"{key}: must be > 0, got {lo!r}")


def _commands(spec) -> tuple[Command, ...]:
    if not isinstance(spec, list) or not spec:
        raise SceneError(f"commands: must be a non-empty list of {{f_left, f_right}}, got {spec!r}")
    out = []
    for i, c in enumerate(spec):
        key = f"commands[{i}]"
        _mapping(c, key, COMMAND_KEYS, required=COMMAND_KEYS)
        fl, fr = (_number(c[k], f"{key}.{k}") for k in COMMAND_KEYS)
        for k, v in (("f_left", fl), ("f_right", fr)):
            if v < 0:
                raise SceneError(f"{key}.{k}: must be >= 0, got {v!r}")
        if fl == 0 and fr == 0:
            raise SceneError(f"{key}: f_left and f_right are both 0 (nothing closes)")
        cmd = Command(f_left=fl, f_right=fr)
        if cmd in out:
            raise SceneError(f"{key}: duplicate of commands[{out.index(cmd)}]")
        out.append(cmd)
    return tuple(out)


def _check_countable(values: dict, h: float) -> None:
    l1, l2, w, r = (max(values[k]) for k in ("l1", "l2", "w", "r"))
    if grid_points(l1, l2, w, r, h) == TOO_MANY_POINTS:
        raise SceneError(f"grid.h: {h!r} gives the largest design (l1={l1}, l2={l2}, w={w}, "
                         f"r={r}) too many grid points to count (over 1e9 per axis), far above "
                         f"the {MAX_MAP_BYTES / 1024**3:.0f} GiB limit; use a larger grid.h or "
                         f"smaller designs")


def _check_memory(values: dict, h: float, manipulation: bool, scenario_c: bool = False) -> None:
    """One thread's largest cell (its maps, its shared finger field and, with the manipulation
    metric, its force buffers: grid.cell_bytes) within MAX_MAP_BYTES."""
    l1, l2, w, r = (max(values[k]) for k in ("l1", "l2", "w", "r"))
    ny, nx_max, n_shared = cell_extent(l1, l2, r, values["w"], h)
    need = cell_bytes(ny, nx_max, n_shared, len(values["w"]), manipulation, scenario_c)
    if need > MAX_MAP_BYTES:
        points = grid_points(l1, l2, w, r, h)
        raise SceneError(
            f"grid.h: {h!r} gives {points:,} grid points for the largest design (l1={l1}, "
            f"l2={l2}, w={w}, r={r}), about {need / 1024**3:.1f} GiB per thread (its maps, "
            f"shared finger field{' and manipulation buffers' if manipulation else ''}), above "
            f"the {MAX_MAP_BYTES / 1024**3:.0f} GiB limit; use a larger grid.h")


def _check_coarse(values: dict, h: float) -> None:
    """Every map of the sweep has at least MIN_POINTS_PER_AXIS grid points along x and y."""
    for l1 in values["l1"]:
        for l2 in values["l2"]:
            for w in values["w"]:
                for r in values["r"]:
                    ny, nx = grid_shape(l1, l2, w, r, h)
                    if min(ny, nx) < MIN_POINTS_PER_AXIS:
                        raise SceneError(
                            f"grid.h: {h!r} gives the map of l1={l1}, l2={l2}, w={w}, r={r} only "
                            f"{nx} x {ny} grid points (x by y), fewer than "
                            f"{MIN_POINTS_PER_AXIS} along an axis; use a smaller grid.h")


def refine_settings(spec, values: dict, h: float) -> RefineSettings | None:
    """`refine:` false (or absent): off; true: the defaults; a mapping: those keys (validated,
    the finest level's memory too)."""
    if spec is False or spec is None:
        return None
    if spec is True:
        spec = {}
    spec = _mapping(spec, "refine", REFINE_KEYS)
    default = RefineSettings()
    levels = spec.get("levels", default.levels)
    if isinstance(levels, bool) or not isinstance(levels, int) or \
            not 1 <= levels <= MAX_REFINE_LEVELS:
        raise SceneError(f"refine.levels: must be a whole number from 1 to {MAX_REFINE_LEVELS}, "
                         f"got {levels!r}")
    bound = _number(spec.get("bound", default.bound), "refine.bound")
    if not 0.0 <= bound <= 1.0:
        raise SceneError(f"refine.bound: must be in [0, 1] (a fraction of the part's best "
                         f"screened caging area), got {bound!r}")
    floor = spec.get("min_contenders", default.min_contenders)
    if isinstance(floor, bool) or not isinstance(floor, int) or floor < 2:
        raise SceneError(f"refine.min_contenders: must be a whole number >= 2 (the best and a "
                         f"runner-up), got {floor!r}")
    settings = RefineSettings(levels=levels, bound=bound, min_contenders=floor)
    finest = settings.level_h(h, levels)
    try:
        _check_memory(values, finest, manipulation=False)  # refinement recomputes summaries only
    except SceneError as exc:
        raise SceneError(f"refine.levels: the finest level h/2^{levels} = {finest:g}: "
                         f"{str(exc).removeprefix('grid.h: ')}") from None
    return settings


def _save_maps(spec, values: dict, n_commands: int) -> tuple[dict, ...]:
    if not isinstance(spec, list):
        raise SceneError(f"outputs.save_maps: must be a list of designs, got {spec!r}")
    out = []
    for i, entry in enumerate(spec):
        key = f"outputs.save_maps[{i}]"
        _mapping(entry, key, SAVE_MAP_KEYS, required=STORE_DIMS)
        point = {}
        for k in STORE_DIMS:
            v = _number(entry[k], f"{key}.{k}")
            try:
                point[k] = values[k][index_of(values[k], v)]
            except KeyError:
                raise SceneError(f"{key}.{k}: {v!r} is not one of the sweep's {k} values "
                                 f"{_short(values[k])}") from None
        c = entry.get("command", 0)
        if isinstance(c, bool) or not isinstance(c, int) or not 0 <= c < n_commands:
            raise SceneError(f"{key}.command: must be an index 0..{n_commands - 1}, got {c!r}")
        point["command"] = c
        if point not in out:
            out.append(point)
    return tuple(out)


def _short(vals) -> str:
    s = ", ".join(f"{v:g}" for v in vals[:8])
    return f"({s}{', ...' if len(vals) > 8 else ''})"


def _jsonable(obj):
    return json.loads(json.dumps(obj, default=str))


def scene_from_frozen(frozen: dict) -> Scene:
    """Rebuild the Scene recorded in a file (from the config as written)."""
    scene = scene_from_dict(frozen["source"], default_name=frozen.get("name", "sweep"))
    if scene.config_hash != frozen["config_hash"]:
        raise StoreError("recorded config does not reproduce its hash "
                         f"({scene.config_hash[:12]} != {frozen['config_hash'][:12]}); "
                         "written by another sweep version?")
    return scene
