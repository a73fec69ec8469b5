# Set-up and the two README commands. Needs only python3 (>= 3.11) on the machine.
PY ?= python3
VENV := .venv
BIN := $(VENV)/bin

.PHONY: setup demo test lint bench model model-boosted model-learned clean

$(BIN)/.installed: pyproject.toml
	$(PY) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --quiet -e ".[dev]"
	# HOTA (evaluation.metrics.clear_mot): TrackEval without its declared dependencies, which would replace the
	# headless OpenCV build with the GUI one (its HOTA needs only numpy and scipy)
	$(BIN)/pip install --quiet --no-deps "trackeval==1.3.0"
	touch $@

setup: $(BIN)/.installed

demo: setup  ## the main job: A/B evaluation of the filters on the built-in scenario
	$(BIN)/pfpeople-eval evaluate

test: setup
	$(BIN)/python -m pytest -q

lint: setup
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .
	$(BIN)/mypy gridbridge pfpeople evaluation

bench: setup
	$(BIN)/python -m evaluation.bench.grid
	$(BIN)/python -m evaluation.bench.particles

model: model-boosted model-learned  ## retrain the shipped laser detectors; needs ../shared/data

model-boosted: setup  ## the boosted classifier (pfpeople/models/boosted_legs.*)
	for s in corridor crowd lobby wheelchair; do \
		$(BIN)/pfpeople-eval simulate-bag $$s --seed 100 --out build/sim-train/$$s --overwrite --no-progress; done
	$(BIN)/pfpeople train-detector --data-dir ../shared/data/leg_tracker --people-bags build/sim-train \
		--out pfpeople/models/

model-learned: setup  ## the learned detector (pfpeople/models/learned_people.*, its fold models in evaluation/models/)
	$(BIN)/pip install --quiet -e ".[train]"
	$(BIN)/python -c "from evaluation.scenarios.scan.training_scenes import learned_training_bags as b; b('build/sim-learned')"
	$(BIN)/pfpeople train-detector --kind learned --data-dir ../shared/data/leg_tracker --people-bags build/sim-learned \
		--weak-bags ../shared/data/leg_tracker/demo_stationary_simple_environment.bag --out pfpeople/models/ \
		--fold-dir evaluation/models/

clean:
	rm -rf $(VENV) build *.egg-info
