# Set-up and the two README commands. Needs only python3 (>= 3.11) on the machine.
PY ?= python3
VENV := .venv
BIN := $(VENV)/bin

.PHONY: setup ros demo test lint bench model model-boosted model-learned clean

# ROS 1 from Debian's packages: `pfpeople node` and its end-to-end test (pfpeople.ros1.system.APT_PACKAGES)
ROS_APT := ros-core python3-rospy python3-rosbag python3-tf2-ros python3-std-msgs python3-sensor-msgs \
	python3-nav-msgs python3-geometry-msgs python3-visualization-msgs python3-tf2-msgs

$(BIN)/.installed: pyproject.toml
	$(PY) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --quiet -e ".[dev]"
	# HOTA (evaluation.metrics.clear_mot): TrackEval without its declared dependencies, which would replace the
	# headless OpenCV build with the GUI one (its HOTA needs only numpy and scipy)
	$(BIN)/pip install --quiet --no-deps "trackeval==1.3.0"
	touch $@

setup: $(BIN)/.installed ros

# Installs ROS 1 where apt-get runs as root (CI, a container); elsewhere says what to install and goes on: without
# it only `pfpeople node` (and its test, skipped) is missing.
ros:
	@if /usr/bin/python3 -c "import rospy" 2>/dev/null && command -v rosmaster >/dev/null; then :; \
	elif ! command -v apt-get >/dev/null; then \
		echo "ROS 1 not installed (no apt-get here): 'pfpeople node' needs Debian's $(ROS_APT)"; \
	elif [ "$$(id -u)" != 0 ]; then \
		echo "ROS 1 not installed: for 'pfpeople node', sudo apt-get install $(ROS_APT)"; \
	else \
		echo "installing ROS 1 from Debian's packages (for 'pfpeople node')"; \
		export DEBIAN_FRONTEND=noninteractive; \
		( apt-get update -qq && apt-get install -y -qq --no-install-recommends $(ROS_APT) >/dev/null ) \
			|| echo "ROS 1 could not be installed (apt-get failed): 'pfpeople node' and its test are unavailable"; \
	fi

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
	$(BIN)/python -c "from evaluation.scenarios.scan import training_scenes as t; \
		t.learned_training_bags('build/sim-learned'); t.calibration_bags('build/sim-calibration')"
	$(BIN)/pfpeople train-detector --kind learned --data-dir ../shared/data/leg_tracker --people-bags build/sim-learned \
		--weak-bags ../shared/data/leg_tracker/demo_stationary_simple_environment.bag \
		--calibration-bags build/sim-calibration --out pfpeople/models/ --fold-dir evaluation/models/

clean:
	rm -rf $(VENV) build *.egg-info
