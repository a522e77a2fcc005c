# motionlab: `make lab` opens the course, `make test` runs every test, `make test-fast` the
# quick unit tests, `make test-laptop` the CPU-dependent ones on a capped CPU (CI runs both).
PYTHON ?= python3
VENV   ?= .venv
# The CPU wheel of this exact version is what the course is tested with; CI pins it so it
# never downloads a CUDA build. Override on your machine, e.g. `make lab TORCH=torch`.
TORCH  ?= torch==2.13.0
BIN     = $(VENV)/bin

.PHONY: setup lab test test-fast test-laptop html clean checkpoints

setup: $(VENV)/.installed

$(VENV)/.installed: pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet "$(TORCH)"
	$(BIN)/python -m pip install --quiet -e ".[dev]"
	touch $@

lab: setup
	$(BIN)/jupyter lab notebooks

test: setup
	$(BIN)/python -m pytest --durations=15

# The edit loop: the unit tests without the notebooks and the slow ones (under 2 minutes).
test-fast: setup
	$(BIN)/python -m pytest tests -m "not slow" -q

# The tests whose code path depends on the CPU (bfloat16, oneDNN's LSTM, the stream's
# kernels, the speed benchmark, notebooks 06 and 08) again with oneDNN and ATen capped to
# what most laptops and GitHub's runners have: AVX2, no AVX-512, no native bfloat16.
LAPTOP_CPU = ONEDNN_MAX_CPU_ISA=AVX2 ATEN_CPU_CAPABILITY=avx2
CPU_TESTS  = tests/test_cpu.py tests/test_precision.py tests/test_recurrent.py tests/test_moglow.py \
             tests/test_moglow_speed.py notebooks/06_moglow.ipynb notebooks/08_comparison.ipynb
test-laptop: setup
	$(LAPTOP_CPU) $(BIN)/python -m pytest $(CPU_TESTS) -q

# The committed notebooks, outputs and all, as static pages in build/html (nothing is run):
# what a reader sees on GitHub or nbviewer. tests/test_static_view.py checks them in Chromium.
html: setup
	$(BIN)/jupyter nbconvert --to html --output-dir build/html notebooks/*.ipynb

# The trained weights shipped in motionlab/checkpoints (notebooks 03 to 08 load them), each made
# by its named recipe in motionlab/recipes.py (`python -m motionlab.recipes --list` prints
# them); weights stored as float16, times in data/README.md.
checkpoints: setup
	$(BIN)/python -m motionlab.recipes --folder motionlab/checkpoints

clean:
	rm -rf $(VENV) build *.egg-info
