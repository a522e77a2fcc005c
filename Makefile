# motionlab: `make lab` opens the course, `make test` runs every test (what CI runs).
PYTHON ?= python3
VENV   ?= .venv
# The CPU wheel of this exact version is what the course is tested with; CI pins it so it
# never downloads a CUDA build. Override on your machine, e.g. `make lab TORCH=torch`.
TORCH  ?= torch==2.13.0
BIN     = $(VENV)/bin

.PHONY: setup lab test clean

setup: $(VENV)/.installed

$(VENV)/.installed: pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet "$(TORCH)"
	$(BIN)/python -m pip install --quiet -e ".[dev]"
	touch $@

lab: setup
	$(BIN)/jupyter lab notebooks

test: setup
	$(BIN)/python -m pytest

clean:
	rm -rf $(VENV) build *.egg-info
