"""`sweep report`: the paper's experiments from one results store, or two scenes side by side
(`sweep.report`).
"""
from __future__ import annotations


import click

from .common import FOLDER_OUT, STORE, WAIT, SweepCommand, UserError


@click.command("report", cls=SweepCommand,
               short_help="The paper's experiments from one results store, or two scenes.")
@click.argument("stores", type=STORE, nargs=-1, required=True)
@click.option("--out", type=FOLDER_OUT, required=True, help="Directory for the report's files.")
@click.option("--top-k", type=int, default=None,
              help="Scenario A candidates per part [default: the store's "
                   "manipulation_scenario_a_top_k].")
@click.option("--overwrite", is_flag=True,
              help="Replace a report in DIR made from another store.")
@WAIT
def report(stores, out, top_k, overwrite, wait):
    """Turn a results store into the paper's four experiments: best_caging.png,
    caging_vs_tip.png, manipulation.png, parameter_usage.png, their tables as CSV, and
    report.md (tables, rules, settings, run time, a reading).

    \b
    sweep report results/paper.h5 --out results/
    sweep report results/paper.h5 results/paper-collision.h5 --out results/

    With two stores of the same designs, parts and grid (two scenes: say, as the paper models
    the fingers and with finger_collision), one report puts the scenes side by side
    (best_designs.png, caging_vs_tip.png, manipulation.png, parameter_usage.png, report.md).

    Rerunning on the same store(s) with the same settings is a no-op; a stale report of the
    same store(s) is redone; a report of another store in DIR needs --overwrite. A store
    without the manipulation metric (config option `outputs: {manipulation: true}`) gets the
    caging parts only, with a note in report.md.
    """
    import json

    from ..compute.warm import ensure_compiled
    from ..files import OutputLock, make_parent
    from ..report.build import ALL_FILES, build_report
    from ..report.compare import FILES, build_comparison, comparison_identity, open_pair
    from ..report.data import MARKER, identity, resolve_top_k
    from ..report.stores import open_store

    if len(stores) > 2:
        raise UserError(f"give one store, or two to compare (got {len(stores)})")
    if len(stores) == 1:
        st = open_store(stores[0])
        top_k = resolve_top_k(st, top_k)
        wanted = identity(st, top_k)
        names = ALL_FILES
        what = f"the report of {stores[0]}"
    else:
        pair = open_pair(stores[0], stores[1], top_k)
        top_k = pair[2]
        wanted = comparison_identity(*pair)
        names = tuple(sorted(set(FILES) | set(ALL_FILES)))
        what = f"the report comparing {stores[0]} and {stores[1]}"
    make_parent(out / MARKER)
    with OutputLock(out / MARKER, what=f"the report in {out}").acquire(wait=wait):
        try:
            found = json.loads((out / MARKER).read_text())
        except (OSError, ValueError):
            found = None
        same = found is not None and all(found.get(k) == v for k, v in wanted.items())
        if same and not overwrite and found.get("complete") and all(
                (out / name).exists() for name in found.get("files", [])):
            click.echo(f"{out}: {what} is already complete; nothing to do")
            return
        present = [name for name in names if (out / name).exists()]
        # Like `sweep run`: the report of these stores (same files, same configs) is redone
        # when stale (store rewritten, other --top-k); a report of others needs --overwrite.
        ours = found is not None and all(found.get(k) == wanted[k]
                                         for k in ("store", "config_hash"))
        if present and found is not None and not ours and not overwrite:
            raise UserError(f"--out: {out} holds the report of another store "
                            f"({found.get('store')}); pass --overwrite to replace it")
        if present and found is None and not overwrite:
            raise UserError(f"--out: {out} already holds {present[0]}; pass --overwrite to "
                            "replace it")
        log = lambda msg: click.echo(f"report: {msg}", err=True)  # noqa: E731
        ensure_compiled()
        if len(stores) == 1:
            build_report(stores[0], out, top_k, log=log, st=st)
        else:
            build_comparison(stores[0], stores[1], out, top_k, log=log, pair=pair)
    click.echo(f"wrote {what} to {out}/ (report.md and its figures and tables)")
