# vehval: `make demo` and `make test` bootstrap everything on a fresh machine.
PYTHON ?= python3
VENV ?= .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.vehval-installed
DEMO_OUT ?= demo_out

.PHONY: venv demo test test-fast lint golden generate bench browser clean lock screenshots

$(STAMP): pyproject.toml constraints.txt
	@test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip
	$(BIN)/python -m pip install -q -c constraints.txt -e ".[test]"
	@touch $(STAMP)

venv: $(STAMP)

demo: venv
	DEMO_DATA="$(DEMO_DATA)" bash scripts/demo.sh "$(BIN)" "$(DEMO_OUT)"

browser:
	@bash scripts/ensure_chromium.sh

# the workbench's screenshots in docs/workbench/, taken by its browser tests from the real
# pages (virtual tests always; the Cruze pages when ../shared/data is there)
screenshots: venv browser
	VEHVAL_SCREENSHOTS=1 $(BIN)/python -m pytest -q -p no:xdist -m browser tests/serve

# ruff: pyflakes, statement errors, import order and function size/complexity; mypy over the
# whole package (both configured in pyproject.toml)
lint: venv
	$(BIN)/ruff check -q .
	$(BIN)/mypy

test: venv browser lint
	$(BIN)/python -m pytest -q -n 2 --dist loadgroup

test-fast: venv
	$(BIN)/python -m pytest -q -n 2 --dist loadgroup -m "not slow"

# regenerate tests/golden/ (outputs of the demo and Cruze tests) after an intended change
golden: venv
	$(BIN)/python scripts/golden.py --write

# regenerate the generated files after an intended change of their source: docs/architecture.md
# (from the layer table, src/vehval/layers.py) and src/vehval/sim/indices.py (from the
# simulator's layout, src/vehval/sim/layout.py); a test fails while either is stale
generate: venv
	$(BIN)/python scripts/architecture.py --write
	$(BIN)/python scripts/sim_indices.py --write

bench: venv
	@bash scripts/ensure_bench_deps.sh "$(BIN)"
	$(BIN)/python -m benchmarks

lock:
	$(BIN)/python -m pip freeze --exclude-editable | grep -v '^vehval' > constraints.txt

clean:
	rm -rf $(VENV) $(DEMO_OUT) .pytest_cache
