# urdfkb: `make run` sets everything up and serves the sample robot; `make test` runs the suite,
# `make test-fast` all of it but the slow lanes (FAST; markers in pyproject.toml), one worker per core.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
SAMPLE := kb_server/samples/turtlebot3_waffle_pi.urdf
HOST   ?= 127.0.0.1
PORT   ?= 8000
# llama-cpp-python compiles from source once (about 8 minutes on 2 cores); pip's wheel cache
# and the already-installed check mean it is never rebuilt after that.
export CMAKE_BUILD_PARALLEL_LEVEL ?= $(shell nproc 2>/dev/null || echo 2)

FAST   := not (model or reasoner or crash or w3c or browser or slow)

.PHONY: run test test-fast install model bench typecheck lint clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip

$(VENV)/.installed: pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install -q -e '.[test]'
	touch $@

install: $(VENV)/.installed

model: install
	$(BIN)/urdfkb model

run: model
	$(BIN)/urdfkb serve --host $(HOST) --port $(PORT) --populate $(SAMPLE)

test: install
	$(BIN)/python -m pytest -q -ra

# one pytest worker per core (pytest-xdist): the fast lane's tests are independent
test-fast: install
	$(BIN)/python -m pytest -q -ra -n auto -m "$(FAST)"

$(VENV)/.typecheck: pyproject.toml | $(VENV)/.installed
	$(BIN)/python -m pip install -q -e '.[typecheck]'
	touch $@

typecheck: $(VENV)/.typecheck
	$(BIN)/mypy

$(VENV)/.lint: pyproject.toml | $(VENV)/.installed
	$(BIN)/python -m pip install -q -e '.[lint]'
	touch $@

lint: $(VENV)/.lint
	$(BIN)/ruff check .

bench: install
	$(BIN)/python -m benchmarks.ingest_bench
	$(BIN)/python -m benchmarks.llm_bench
	$(BIN)/python -m benchmarks.bench_queries
	$(BIN)/python -m benchmarks.vote_bench
	$(BIN)/python -m benchmarks.ui_bench
	$(BIN)/python -m benchmarks.reasoner_bench

clean:
	rm -rf $(VENV) build *.egg-info
