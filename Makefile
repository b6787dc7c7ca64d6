# `make run` and `make test` create the virtual environment on first use.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: run test test-long lint typecheck bench clean

$(STAMP): pyproject.toml requirements.lock
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --quiet -c requirements.lock -e '.[test,interop]'
# Bytecode for the project's packages (pyproject.toml's), also where PYTHONDONTWRITEBYTECODE is set: every
# `vil` start would compile what it imports again (~0.4 s, the generated dialect alone ~0.3 s);
# compileall writes .pyc regardless.
	$(BIN)/python -m compileall -q $$($(BIN)/python -c "import tomllib; print(*sorted({p.split('.')[0] for p in tomllib.load(open('pyproject.toml', 'rb'))['tool']['setuptools']['packages']}))")
	touch $(STAMP)

run: $(STAMP)
	$(BIN)/vil run

test: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/mypy
# The browser tests (tests/browser) need the system's Chromium; without it they are skipped.
	@command -v chromium >/dev/null 2>&1 || command -v chromium-browser >/dev/null 2>&1 || [ -n "$$VIL_CHROMIUM" ] || \
	  echo "make test: Chromium is not installed, so the browser tests are skipped; install it with: apt-get install chromium"
# Two workers, a test file each at a time (module fixtures stay shared): many tests wait on real
# processes and sockets in real time, and overlap well on 2 cores.
# The long variants (-m long) are left to `make test-long`: their short variants run here.
	$(BIN)/pytest -q -n 2 --dist loadfile -m "not long"

test-long: $(STAMP)
	$(BIN)/pytest -q -n 2 --dist loadfile -m long

lint: $(STAMP)
	$(BIN)/ruff check .

typecheck: $(STAMP)
	$(BIN)/mypy

bench: $(STAMP)
	for b in bench/*.py; do $(BIN)/python $$b || exit 1; done

clean:
	rm -rf $(VENV)
