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

# The trained weights shipped in data/checkpoints (notebooks 03 to 07 load them).
# Each is the command line's checkpoint, weights stored as float16; times in data/README.md.
TRAIN  = $(BIN)/python -m motionlab.train
MOGLOW = $(TRAIN) moglow --synthetic-clips 200 --epochs 60 --lr 3e-3 --batch-size 32 --half
# Motegi's conv AE and VAE on its features (notebook 03's data and config).
MOTEGI  = --synthetic-clips 100 --stride 1.0 --normalization shared_pose --half
# Habibie's VAE-LSTM and its LSTM-3LR baselines: one budget for all four (notebook 04).
HABIBIE = --synthetic-clips 120 --epochs 20 --lr 3e-3 --half
checkpoints: setup
	$(TRAIN) conv_ae $(MOTEGI) --set depool=linear input_dropout=0.0 l1=0.0 --epochs 40 --lr 2e-3 \
		--out data/checkpoints/conv_ae.pt
	$(TRAIN) vae --conv-ae data/checkpoints/conv_ae.pt $(MOTEGI) --set latent=16 beta=32.0 --epochs 60 \
		--lr 1e-3 --out data/checkpoints/vae.pt
	$(TRAIN) vae_lstm $(HABIBIE) --set observation_std=3.0 contact_weight=1.0 --out data/checkpoints/vae_lstm.pt
	$(TRAIN) vae_lstm $(HABIBIE) --set observation_std=3.0 free_running=0.0 --out data/checkpoints/vae_lstm_paper_objective.pt
	$(TRAIN) lstm $(HABIBIE) --set hidden=64 control=predicted --out data/checkpoints/lstm_no_control.pt
	$(TRAIN) lstm $(HABIBIE) --set hidden=64 control=given --out data/checkpoints/lstm_control.pt
	$(MOGLOW) --out data/checkpoints/moglow_dropout.pt
	$(MOGLOW) --set dropout=0.0 --out data/checkpoints/moglow_no_dropout.pt
	$(MOGLOW) --set recurrent=false --out data/checkpoints/moglow_markov.pt
	$(MOGLOW) --set recurrent=false hidden=205 --out data/checkpoints/moglow_markov_matched.pt
	$(MOGLOW) --set foot_anchor=true --out data/checkpoints/moglow_foot_anchor.pt
	$(TRAIN) glow --synthetic-clips 200 --stride 1.0 --epochs 20 --lr 2e-3 --batch-size 32 --half \
		--out data/checkpoints/glow.pt
	$(TRAIN) dfn --synthetic-clips 120 --stride 0.5 --stage-epochs frame=10 sequence=10 dynamics=20 \
		--lr 3e-3 --batch-size 64 --half --out data/checkpoints/dfn.pt

clean:
	rm -rf $(VENV) build *.egg-info
