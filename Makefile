# Two entry points, each creating the virtual environment .venv on first use:
#   make run   [ARGS="task=identification robot=panda"]      the main job: the paper's whole chain (Hydra overrides in ARGS)
#   make test  [ARGS="-m slow"]                              the test suite (pytest arguments in ARGS)
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
	$(VENV)/bin/python -m pytest $(ARGS)

clean-venv:
	rm -rf $(VENV)
