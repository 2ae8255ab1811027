# `make demo` runs the paper's tube protocol end to end (FOM-FOM, train, ROM-FOM, report: runs/demo/);
# `make test` runs the tests.
# Both create .venv and install the project into it on first use.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin

.PHONY: demo demo-flap campaign test bench figures clean

$(BIN)/cosim: pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --quiet -e '.[test,rom,fmu,kratos,sweep]'
	touch $@

demo: $(BIN)/cosim
	COSIM=$(BIN)/cosim bash scripts/tube_demo.sh

# the short double-flap ROM protocol (about ten minutes) and the paper's whole campaign (hours; rerun to resume)
demo-flap: $(BIN)/cosim
	$(BIN)/cosim campaign scenes/double_flap_short.toml --out runs/flap_demo

campaign: $(BIN)/cosim
	$(BIN)/cosim campaign scenes/double_flap_campaign.toml --out runs/campaign

test: $(BIN)/cosim
	$(BIN)/python -m pytest -q

figures: $(BIN)/cosim
	$(BIN)/python scripts/figures.py

bench: $(BIN)/cosim
	$(BIN)/python benchmarks/tube_run.py
	$(BIN)/python benchmarks/rom_call.py

clean:
	rm -rf $(VENV) runs
