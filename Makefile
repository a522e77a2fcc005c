# motionlab: `make lab` opens the course, `make test` runs every test (what CI runs).
PYTHON ?= python3
VENV   ?= .venv
# The CPU wheel of this exact version is what the course is tested with; CI pins it so it
# never downloads a CUDA build. Override on your machine, e.g. `make lab TORCH=torch`.
TORCH  ?= torch==2.13.0
BIN     = $(VENV)/bin

.PHONY: setup lab test clean checkpoints

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

# The trained weights shipped in data/checkpoints (notebook 06 loads them; about 7 minutes on
# 2 CPU cores). Each is the command line's checkpoint, weights stored as float16.
MOGLOW = $(BIN)/python -m motionlab.train moglow --epochs 40 --lr 3e-3 --batch-size 32 --half
checkpoints: setup
	$(MOGLOW) --out data/checkpoints/moglow_dropout.pt
	$(MOGLOW) --set dropout=0.0 --out data/checkpoints/moglow_no_dropout.pt
	$(MOGLOW) --set recurrent=false --out data/checkpoints/moglow_markov.pt
	$(MOGLOW) --set recurrent=false hidden=205 --out data/checkpoints/moglow_markov_matched.pt

clean:
	rm -rf $(VENV) build *.egg-info
