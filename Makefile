# `make demo` runs the tube FOM-FOM scene end to end; `make test` runs the tests.
# Both create .venv and install the project into it on first use.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin

.PHONY: demo test bench clean

$(BIN)/cosim: pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --quiet -e '.[test,rom]'
	touch $@

demo: $(BIN)/cosim
	$(BIN)/cosim run scenes/tube_fom.toml --out runs/fom_mu1

test: $(BIN)/cosim
	$(BIN)/python -m pytest -q

bench: $(BIN)/cosim
	$(BIN)/python benchmarks/tube_run.py

clean:
	rm -rf $(VENV) runs
