"""Test configuration: one deterministic Hypothesis profile for the whole suite, the kernels
compiled once per session, and what several modules share (session scope).

The suite's two sizes, `make test` and `make test-long`, are tests/profiles.py's switches."""
from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import HealthCheck, settings

from profiles import EXPLORE

# The same draws on every run (a pass is reproducible); `make explore` draws fresh ones.
settings.register_profile(
    "sweep",
    deadline=None,
    max_examples=60,
    derandomize=not EXPLORE,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much],
)
settings.load_profile("sweep")

DATA = Path(__file__).parent / "data"
#: Modules whose tests compute nothing (`make lint` runs them alone: the Makefile's LINT_TESTS):
#: a session of only these does not compile the kernels.
COMPUTE_FREE = {"test_layers.py", "test_model_references.py", "test_store_schema.py",
                "test_model_notes.py"}


def _xdist_worker(config) -> bool:
    return hasattr(config, "workerinput")


def pytest_sessionstart(session):
    """With several workers (`make test`: pytest-xdist), the kernels are compiled here, in the
    controller, before the workers start, so that no two workers compile them at once; each
    worker then loads them from the cache (the fixture below finds them compiled)."""
    config = session.config
    if getattr(config.option, "numprocesses", None) and not _xdist_worker(config):
        from sweep.compute import warm

        warm.ensure_compiled()


def pytest_terminal_summary(terminalreporter, exitstatus, config):
    """Lines tests leave for the summary (the fuzz campaign's count of cases), from this
    process and, under pytest-xdist, from every worker (pytest_testnodedown)."""
    for line in getattr(config, "sweep_summary_lines", []):
        terminalreporter.write_line(line)


def pytest_sessionfinish(session):
    """A worker hands its summary lines to the controller."""
    config = session.config
    if _xdist_worker(config):
        config.workeroutput["sweep_summary_lines"] = getattr(config, "sweep_summary_lines", [])


@pytest.hookimpl(optionalhook=True)
def pytest_testnodedown(node, error):
    lines = getattr(node, "workeroutput", {}).get("sweep_summary_lines", [])
    if lines:
        config = node.config
        if not hasattr(config, "sweep_summary_lines"):
            config.sweep_summary_lines = []
        config.sweep_summary_lines.extend(lines)


@pytest.fixture(scope="session", autouse=True)
def compiled_kernels(request):
    """Every kernel of the sweep compiled (or loaded) once, before the first test, the way a
    command does it (`sweep.compute.warm.ensure_compiled`: on an empty cache the maps' kernels
    here and the manipulation metric's in a second process at the same time, saying so in one
    line). Tests then load them from the cache; the few kernels only tests call (reference
    searches, one position's outcome, tests/incremental_hull.py) compile when a
    test first calls them."""
    if all(Path(str(item.fspath)).name in COMPUTE_FREE for item in request.session.items):
        return
    from sweep.compute import warm

    # (also when compiled: this process then never looks at the cache folder again, which the
    # fuzz campaign's commands, run as another user, could not read)
    reporter = request.config.pluginmanager.get_plugin("terminalreporter")
    warm.ensure_compiled(say=(lambda line: reporter.write_line(f"\n{line}"))
                         if reporter is not None else None)


@pytest.fixture(scope="session")
def manipulation_store(tmp_path_factory) -> Path:
    """tests/data/manipulation.yaml run once on one machine (`sweep run`), for the modules that
    read its store (test_report, test_merge_stream, test_manipulation's long profile). Read it,
    or take a copy to write beside it."""
    from click.testing import CliRunner

    from sweep.cli import main

    out = tmp_path_factory.mktemp("manipulation-store") / "tiny.h5"
    res = CliRunner().invoke(main, ["run", str(DATA / "manipulation.yaml"), "--out", str(out),
                                    "--no-progress"])
    assert res.exit_code == 0, res.output
    return out
