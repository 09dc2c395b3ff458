# Set-up and main jobs. Needs only python3 (>= 3.11) and make.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed-stamp
TESTSTAMP := $(VENV)/.test-stamp

.PHONY: run test bench docs clean

# create the virtual environment and install ltdsim (what `make run` needs)
$(STAMP): pyproject.toml
	@echo "installing ltdsim and its dependencies into $(VENV) (first time only, about 1 min)"
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --disable-pip-version-check --progress-bar off -e .
	touch $(STAMP)

# and the test tools and the documentation site's (what `make test` needs besides)
$(TESTSTAMP): $(STAMP)
	@echo "installing the test and documentation tools into $(VENV) (first time only)"
	$(BIN)/python -m pip install --disable-pip-version-check --progress-bar off -e ".[test]"
	touch $(TESTSTAMP)

## run: reproduce the whole study as one report in report/ (on 2 cores about 2.5 min from a
## fresh clone, install included; under 2 min once installed and the kernels cached)
run: $(STAMP)
	$(BIN)/ltdsim study scenarios/paper.toml --output report

## test: the whole test suite
test: $(TESTSTAMP)
	$(BIN)/python -m pytest

## bench: the maintained benchmarks, tables to benchmarks/results/ (the instruction
## counts need valgrind and are skipped without it)
bench: $(TESTSTAMP)
	$(BIN)/python benchmarks/bench_kernel.py
	$(BIN)/python benchmarks/bench_draftgear.py
	$(BIN)/python benchmarks/bench_sweep.py
	$(BIN)/python benchmarks/bench_study.py
	$(BIN)/python benchmarks/bench_heavy_haul.py
	$(BIN)/python benchmarks/bench_peak_sensitivity.py
	$(BIN)/python benchmarks/bench_held_edges.py
	$(BIN)/python benchmarks/bench_fluid_brake.py
	$(BIN)/python benchmarks/bench_curving.py
	$(BIN)/python benchmarks/bench_first_run.py
	@if command -v valgrind >/dev/null; then \
	  $(BIN)/python benchmarks/bench_kernel_instructions.py && \
	  $(BIN)/python benchmarks/bench_reference_instructions.py; \
	else echo "bench: valgrind not installed, instruction counts skipped"; fi

## docs: the documentation site into site/ (MkDocs Material; warnings are errors)
docs: $(TESTSTAMP)
	$(BIN)/mkdocs build --strict --site-dir site

clean:
	rm -rf $(VENV) results site .pytest_cache .hypothesis
