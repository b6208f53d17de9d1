# Two entry points, each creating the virtual environment .venv on first use:
#   make run   [ARGS="task=identification robot=panda"]      the main job: the paper's whole chain (Hydra overrides in ARGS)
#   make test  [ARGS="-m slow"]                              the test suite (pytest arguments in ARGS)
# The fast tests run on one pytest-xdist worker per CPU (-n auto; tests/conftest.py picks the count and
# runs -m slow in one process), a test file's tests on one worker (their module fixtures built once);
# ARGS="-n 0" runs them in one process too.
PYTHON ?= python3
VENV := .venv
STAMP := $(VENV)/.installed

.PHONY: run test clean-venv

$(STAMP): pyproject.toml
	test -x $(VENV)/bin/python || $(PYTHON) -m venv $(VENV)
	$(VENV)/bin/python -m pip install --quiet --upgrade pip
	$(VENV)/bin/python -m pip install --quiet -e ".[test]"
	touch $(STAMP)

run: $(STAMP)
	$(VENV)/bin/lwrlab $(ARGS)

test: $(STAMP)
	$(VENV)/bin/python -m pytest -n auto --dist loadfile $(ARGS)

clean-venv:
	rm -rf $(VENV)
