# ndrql: two entry points, `make demo` and `make test`. Both create .venv if needed and install the
# package with the CPU torch pin (constraints.txt), which also compiles the C kernels (setup.py); the
# install is skipped while pyproject.toml, constraints.txt, setup.py and the kernels' C source are
# unchanged since the last one (stamp file inside .venv). `make test` runs every
# test (it is the CI command, .ci/run); `make test-fast` leaves out the ones marked slow.

PYTHON ?= python3
VENV   ?= .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.ndrql-install-stamp
PYTEST_ARGS ?= -q

.PHONY: all install demo test test-fast shipped-onnx clean

all: test

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)

$(STAMP): $(BIN)/python pyproject.toml constraints.txt setup.py src/ndrql/maps/_kernels.c
	$(BIN)/python -m pip install --quiet --disable-pip-version-check -c constraints.txt -e '.[test]'
	@touch $(STAMP)

install: $(STAMP)

demo: install
	$(BIN)/ndrql demo

test: install
	$(BIN)/python -m pytest $(PYTEST_ARGS)

test-fast: install
	$(BIN)/python -m pytest -m "not slow" $(PYTEST_ARGS)

# after replacing src/ndrql/data/*.pt: the shipped ONNX graphs and their records (tests/product/test_light_install.py)
shipped-onnx: install
	PYTHONPATH=src $(BIN)/python tools/export_shipped_onnx.py

clean:
	rm -rf out .pytest_cache .hypothesis build dist
