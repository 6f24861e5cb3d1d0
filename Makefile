# Two commands set everything up on a fresh machine:
#   make demo   creates .venv, installs the pinned dependencies, renders the default scene to out/demo.png
#               and replays the shipped gaze trace over it at 15 FPS to out/demo.mp4 + out/stats.csv
#   make test   same set-up, then the whole test suite (CPU device)
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed-stamp
export WARP_HYBRID_KERNEL_CACHE ?= $(CURDIR)/build/warp-cache

.PHONY: demo test bench scenes clean

$(STAMP): pyproject.toml requirements.lock
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -r requirements.lock
	$(PY) -m pip install --quiet --no-deps --no-build-isolation -e .
	touch $(STAMP)

demo: $(STAMP)
	$(VENV)/bin/warp-hybrid render scenes/cornell_glass.usda -o out/demo.png \
		--mode hybrid --gaze trace:scenes/traces/demo_gaze.csv --window 0.25 \
		--aov-dir out/aovs --stats-json out/stats.json
	$(VENV)/bin/warp-hybrid replay scenes/cornell_glass.usda --gaze trace:scenes/traces/demo_gaze.csv \
		--fps 15 --duration 4 --size 320x240 --overlay \
		--out out/demo.mp4 --stats out/stats.csv --summary-json out/summary.json

test: $(STAMP)
	$(PY) -m pytest

bench: $(STAMP)
	$(PY) scripts/bench_raster.py

scenes: $(STAMP)
	$(PY) scripts/make_scenes.py

clean:
	rm -rf build out
