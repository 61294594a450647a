# One-command set-up: every target that needs Python first builds the local virtual environment.
PYTHON ?= python3
VENV   ?= .venv
PY     := $(VENV)/bin/python
# What the commands need (`make run` and the other jobs), and that plus the test extras (pytest,
# hypothesis, ruff, pytest-xdist: the tests, lint, benchmarks); one environment, one stamp each.
RUN_STAMP := $(VENV)/.installed-run
STAMP     := $(VENV)/.installed

.PHONY: install run friction optimize variable map test test-long explore coverage lint \
	test-slurm bench paper clean

# pip byte-compiles every file it installs on one core (6,155 here, 2,571 of them the packages'
# own tests); compileall on every core, without those tests, takes a third of that
# (docs/performance.md). Compiled, not left to the first import: with PYTHONDONTWRITEBYTECODE
# set, every start would compile numpy, numba and scipy again (1.4 s against 4.5 s).
define install_into_venv
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --no-compile -e '$(1)'
	$(PY) -m compileall -q -j 0 -x '/tests?/' \
		"$$($(PY) -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])')" > /dev/null
	touch $@
endef

$(RUN_STAMP): pyproject.toml
	$(call install_into_venv,.)

$(STAMP): pyproject.toml
	$(call install_into_venv,.[test])

install: $(STAMP)

# The main job: the paper's sweep with the manipulation metric in two scenes, as the paper
# models the fingers (they may cross) and as a gripper's work (finger_collision), 86,400 maps
# each (resumes if killed, a no-op when complete), then one report that puts the two side by
# side (figures, tables, report.md; a no-op when up to date). One scene after the other: side
# by side, each on every core, the whole job took 0.75x de6810f's time on a fresh clone
# against 0.63x one after the other (docs/performance-log.md, 2026-11-27 night).
run: $(RUN_STAMP)
	$(VENV)/bin/sweep run configs/paper.yaml --out results/paper.h5
	$(VENV)/bin/sweep run configs/paper-collision.yaml --out results/paper-collision.h5
	$(VENV)/bin/sweep report results/paper.h5 results/paper-collision.h5 --out results/

# Friction modulation (Scenario C, MODEL 10; the paper's future work) beside variable geometry:
# the two scenes of `make run` with `outputs.scenario_c` (each finger on the part's mu or on a
# low friction), then one report of both (friction.png, caging under modulation). Its own
# target: Scenario C costs 1.2-1.3x the manipulation sweep (docs/performance.md).
friction: $(RUN_STAMP)
	$(VENV)/bin/sweep run configs/paper-friction.yaml --out results/paper-friction.h5
	$(VENV)/bin/sweep run configs/paper-collision-friction.yaml \
		--out results/paper-collision-friction.h5
	$(VENV)/bin/sweep report results/paper-friction.h5 results/paper-collision-friction.h5 \
		--out results/friction/

# Beyond the grid (docs/optimisation.md): per part of the collision scene, the best design of the
# continuous design box against the grid's certified best (verdict, box-limited parameters,
# robustness), and one gripper for all 16 parts (the worst part's caging area relative to its own
# optimum); from the store `make run` wrote, into results/paper-collision.optimize.h5 (resumes if
# killed, a no-op when done); then `make run`'s two-scene report again, now with the section and
# figure of the optimised scene (optimization_2.png; redone only when the results changed).
optimize: $(RUN_STAMP)
	$(VENV)/bin/sweep optimize results/paper-collision.h5 --parts all --objective worst
	$(VENV)/bin/sweep report results/paper.h5 results/paper-collision.h5 --out results/

# Variable geometry in the grasp (docs/variable-geometry.md, MODEL 12): on the stores `make run`
# wrote, per part every schedule "draw in with one setting (R, w), hold with another" of its
# best chassis and of (2.0, 1.6), the best against the best fixed setting with its error
# (ladder h, h/2, h/4), into results/paper.schedule.h5 and results/paper-collision.schedule.h5
# (resumes if killed, a no-op when done); then `make run`'s report again, now with section 7
# and variable_geometry_1.png, _2.png. Its own target: it costs 0.22-0.26x the screening of a
# scene (docs/performance.md), above the 0.2x `make run` may take.
variable: $(RUN_STAMP)
	$(VENV)/bin/sweep schedule results/paper.h5
	$(VENV)/bin/sweep schedule results/paper-collision.h5
	$(VENV)/bin/sweep report results/paper.h5 results/paper-collision.h5 --out results/

# One energy map of the issue's reference design, with its plot.
map: $(RUN_STAMP)
	$(VENV)/bin/sweep map --l1 2.0 --l2 1.6 --r1 0.2 --r2 0.14 --w 0.8 --r 0.4 --mu 0.4 \
		--out results/map.h5 --plot results/map.png --overwrite

# The test suite at its bounded size: every kind of check (oracle comparisons with the slow
# references of tests/naive*.py, Hypothesis properties, fuzz, faults and kill-and-resume, golden
# files, the recipe), a few minutes on 2 cores. TEST_WORKERS processes (pytest-xdist) share the
# tests, a test file each at a time (its module fixtures computed once); the kernels are
# compiled once, before the workers start (tests/conftest.py).
TEST_WORKERS ?= $(shell n=$$(nproc 2>/dev/null || echo 2); [ $$n -gt 8 ] && n=8; echo $$n)
PYTEST_PARALLEL = -n $(TEST_WORKERS) --dist loadfile
test: $(STAMP)
	$(PY) -m pytest -q $(PYTEST_PARALLEL)

# The same suite with every long profile on (tests/profiles.py): Hypothesis properties with their
# large example counts, the fuzz campaign's 23,000 cases, the end-to-end oracle comparisons at
# full size and the recipe's toy effect compiled. The same draws on every run, so a pass is
# reproducible; the slowest tests are listed at the end. Not in CI (.ci/run): about half an hour
# on 2 cores (CONTRIBUTING.md, "Tests").
LONG_PROFILES = SWEEP_LONG_PROPERTIES=1 SWEEP_LONG_FUZZ=1 SWEEP_LONG_ORACLES=1 \
	SWEEP_LONG_RECIPE=1 SWEEP_LONG_COMPILE=1
test-long: $(STAMP)
	$(LONG_PROFILES) $(PY) -m pytest -q $(PYTEST_PARALLEL) --durations=10

# The long profiles as a random search: fresh draws on every run (SWEEP_EXPLORE=1). A find is
# printed with its case; make it an explicit test (docs/stability.md, docs/sweeps.md).
# Every module with a Hypothesis property, at the long counts.
explore: $(STAMP)
	SWEEP_LONG_PROPERTIES=1 SWEEP_LONG_FUZZ=1 SWEEP_EXPLORE=1 $(PY) -m pytest -q \
		$(PYTEST_PARALLEL) --durations=10 $$(grep -l '@given' tests/test_*.py)

# make test under branch coverage of the runs, the stores and the reports (pytest-cov; the jitted
# kernels are out of its reach, the references cover them); the figure and the branches left
# uncovered, with why: docs/stability.md, "Branch coverage".
COVERED = --cov=sweep.runs --cov=sweep.storage --cov=sweep.report --cov-branch
coverage: $(STAMP)
	$(PY) -m pytest -q $(PYTEST_PARALLEL) $(COVERED) --cov-report=term-missing:skip-covered

# pyflakes, pycodestyle and bugbear checks (configuration in pyproject.toml), the layers that
# imports obey (tests/test_layers.py, docs/architecture.md), docs/model.md's references to the
# code, every store variable declared in the schema (tests/test_store_schema.py), and every
# decision cited ("model-notes D14") one that exists (tests/test_model_notes.py); CI runs it.
LINT_TESTS = tests/test_layers.py tests/test_model_references.py tests/test_store_schema.py \
             tests/test_model_notes.py
lint: $(STAMP)
	$(VENV)/bin/ruff check .
	$(PY) -m pytest -q -p no:cacheprovider $(LINT_TESTS)

# The sweep as a SLURM array job on a real single-node cluster (as root; installs slurm-wlm and
# munge if missing; stops its daemons and removes its files whatever happens). Under 2 minutes.
test-slurm: $(STAMP)
	$(PY) -m pytest -q -p no:cacheprovider tests/slurm

# Benchmarks, one subcommand each (docs/performance.md): `make bench` runs the kernels against the
# paper-style baseline; `make bench ARGS="collision --repeats 7"`, `make bench ARGS=--help`.
ARGS ?= baseline
bench: $(STAMP)
	$(PY) scripts/bench.py $(ARGS)

# The paper's whole design-space search: 86,400 maps (a few minutes on 2 cores); resumes if killed.
paper: $(RUN_STAMP)
	$(VENV)/bin/sweep run configs/paper.yaml --out results/paper.h5
	$(VENV)/bin/sweep show results/paper.h5

clean:
	rm -rf $(VENV) results .pytest_cache
