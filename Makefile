# One-command set-up: every target that needs Python first builds the local virtual environment.
PYTHON ?= python3
VENV   ?= .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed

.PHONY: install run map test bench paper clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[test]'
	touch $(STAMP)

install: $(STAMP)

# The main job: the paper's sweep with the manipulation metric (86,400 maps; resumes if killed,
# a no-op when complete), then its report (figures, tables, report.md; a no-op when up to date).
run: $(STAMP)
	$(VENV)/bin/sweep run configs/paper.yaml --out results/paper.h5
	$(VENV)/bin/sweep report results/paper.h5 --out results/

# One energy map of the issue's reference design, with its plot.
map: $(STAMP)
	$(VENV)/bin/sweep map --l1 2.0 --l2 1.6 --r1 0.2 --r2 0.14 --w 0.8 --r 0.4 --mu 0.4 \
		--out results/map.h5 --plot results/map.png --overwrite

test: $(STAMP)
	$(PY) -m pytest -q

bench: $(STAMP)
	$(PY) scripts/bench.py

# The paper's whole design-space search: 86,400 maps (a few minutes on 2 cores); resumes if killed.
paper: $(STAMP)
	$(VENV)/bin/sweep run configs/paper.yaml --out results/paper.h5
	$(VENV)/bin/sweep show results/paper.h5

clean:
	rm -rf $(VENV) results .pytest_cache
