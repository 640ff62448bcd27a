# vehval: `make demo` and `make test` bootstrap everything on a fresh machine.
PYTHON ?= python3
VENV ?= .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.vehval-installed
DEMO_OUT ?= demo_out

.PHONY: venv demo test bench browser clean lock

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

test: venv browser
	$(BIN)/python -m pytest -q -n 2 --dist loadgroup

bench: venv
	@bash scripts/ensure_bench_deps.sh "$(BIN)"
	$(BIN)/python -m benchmarks

lock:
	$(BIN)/python -m pip freeze --exclude-editable | grep -v '^vehval' > constraints.txt

clean:
	rm -rf $(VENV) $(DEMO_OUT) .pytest_cache
