# `make demo` runs the paper's tube protocol end to end (FOM-FOM, train, ROM-FOM, report: runs/demo/);
# `make test` runs lint, types, the docs build and the tests.
# Both create .venv and install the project into it on first use, with the versions of constraints.txt
# (the lock: the versions the README's figures were made with). `make lock` upgrades the lock to the
# newest versions the registry serves; `make test-latest` runs the tests against them without touching it.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
# the tube needs none of Kratos nor gmsh: `make demo` installs its extras only (about 0.4 GB); the Kratos cases and
# the test suite install every extra on first use (Kratos and gmsh add about 0.4 GB)
TUBE_EXTRAS := .[rom,fmu]
EXTRAS := .[test,lint,docs,rom,fmu,kratos,mesh,sweep,mpi]
LOCK := constraints.txt
PIP := $(BIN)/pip install --progress-bar on --constraint $(LOCK)
# the project's own modules compiled to bytecode once: pip compiles a package it installs, but not an editable one,
# and where PYTHONDONTWRITEBYTECODE is set every process (each component, participant and test run) would compile
# the modules it imports again; a module edited since is compiled anew where it is imported, as always
TUBE_SOURCES := cosim coupler fluid_component solid_component fmu_component rom_component cases workflow precice_compat \
	scripts
SOURCES := $(TUBE_SOURCES) kratos_solvers kratos_compat benchmarks examples tests
COMPILE = $(BIN)/python -m compileall -q -j 0 $(1) > /dev/null

.PHONY: demo demo-flap demo-mok-rom campaign mok test lint docs test-latest lock bench figures clean

# one stamp per set of extras, newer than the project's files once installed
$(VENV)/.tube: pyproject.toml $(LOCK)
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	@echo "installing the tube's dependencies into $(VENV) (numpy, scipy, pyzmq, h5py, matplotlib, scikit-learn, fmpy)"
	$(PIP) --quiet --upgrade pip
	$(PIP) -e '$(TUBE_EXTRAS)'
	$(call COMPILE,$(TUBE_SOURCES))
	touch $@

$(VENV)/.all: pyproject.toml $(LOCK)
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	@echo "installing every extra into $(VENV): Kratos Multiphysics, gmsh, Dask, the test and lint tools"
	$(PIP) --quiet --upgrade pip
	$(PIP) -e '$(EXTRAS)'
	$(call COMPILE,$(SOURCES))
	touch $@ $(VENV)/.tube

demo: $(VENV)/.tube
	$(call COMPILE,$(TUBE_SOURCES))
	COSIM=$(BIN)/cosim bash scripts/tube_demo.sh

# the short double-flap ROM protocol (about 15 minutes) and the paper's whole campaign (hours; rerun to resume)
demo-flap: $(VENV)/.all
	$(BIN)/cosim campaign campaigns/double_flap_short.toml --out runs/flap_demo

campaign: $(VENV)/.all
	$(BIN)/cosim campaign campaigns/double_flap_campaign.toml --out runs/campaign

# the ROM with memory of Mok's wall: FOM-FOM, training, ROM-FOM and FMU-FOM switching at 12 s, other inflows
# (12 minutes here; runs/mok_rom_demo/report)
demo-mok-rom: $(VENV)/.all
	COSIM=$(BIN)/cosim PYTHON=$(BIN)/python MOK_ROM_DOCS=1 bash scripts/mok_rom_demo.sh

# Mok's benchmark: 250 windows through our coupler and through Kratos's own, side by side (about 10 minutes);
# rewrites its table in docs/mok.md
mok: $(VENV)/.all
	$(BIN)/python -m benchmarks.mok_run 250 --docs

# the suite on two workers, then the tests that race a run against the clock alone (tests/conftest.py: serial)
test: lint docs
	$(call COMPILE,$(SOURCES))
	$(BIN)/python -m pytest -q -n 2 -m "not serial" --durations=15
	$(BIN)/python -m pytest -q -m serial --durations=5

# ruff and mypy (configured in pyproject.toml): no findings
lint: $(VENV)/.all
	$(BIN)/ruff check .
	$(BIN)/mypy

# the documentation site (build/site/); a broken link or a page outside the nav fails it
docs: $(VENV)/.all
	$(BIN)/mkdocs build --strict --quiet

# the suite against the newest versions (a scratch .venv-latest, the lock untouched): drift shows here first
test-latest:
	rm -rf .venv-latest
	$(PYTHON) -m venv .venv-latest
	.venv-latest/bin/pip install --quiet --upgrade pip
	.venv-latest/bin/pip install --quiet -e '$(EXTRAS)'
	grep -v '^#' $(LOCK) > .venv-latest/locked.txt
	.venv-latest/bin/pip freeze --all --exclude-editable | grep -v -i '^setuptools==' \
		| diff .venv-latest/locked.txt - | grep '^[<>]' || echo "the newest versions are the lock's"
	.venv-latest/bin/python -m pytest -q

# write the lock anew from the newest versions; then `rm -rf .venv && make figures` and commit both
lock:
	rm -rf .venv-lock
	$(PYTHON) -m venv .venv-lock
	.venv-lock/bin/pip install --quiet --upgrade pip
	.venv-lock/bin/pip install --quiet -e '$(EXTRAS)'
	{ echo "# The versions the README's figures were made with ($$(.venv-lock/bin/python -c 'import platform; print("Python", platform.python_version() + ",", platform.machine(), platform.system())'))."; \
	  echo "# Installed by make and .ci/run as pip constraints; to upgrade: make lock, then make figures (see README)."; \
	  .venv-lock/bin/pip freeze --all --exclude-editable | grep -v -i '^setuptools=='; } > $(LOCK)
	rm -rf .venv-lock

figures: $(VENV)/.all
	$(call COMPILE,$(SOURCES))
	$(BIN)/python -m scripts.figures

bench: $(VENV)/.all
	$(call COMPILE,$(SOURCES))
	$(BIN)/python -m benchmarks.tube_run
	$(BIN)/python -m benchmarks.rom_call

clean:
	rm -rf $(VENV) .venv-latest .venv-lock runs
