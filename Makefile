# CD Spectra — every job is a target; each one sets up .venv first if needed.
SHELL := /bin/bash
PYTHON ?= $(shell command -v python3.11 || command -v python3)
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed-$(shell cat requirements.txt | md5sum | cut -c1-8)

.PHONY: setup test demo sample-photo model eval eval-camera-files eval-poses bench bench-render tune-solver reliability extension bake-colour bake-cameras diagrams clean

$(STAMP): requirements.txt
	@$(PYTHON) -c 'import sys; sys.exit(0 if sys.version_info[:2] == (3, 11) else "Python 3.11 is required (Blender 4.5 / bpy 4.5): set PYTHON=/path/to/python3.11")'
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --disable-pip-version-check -r requirements.txt
	rm -f $(VENV)/.installed-*
	touch $(STAMP)

setup: $(STAMP)

test: setup
	$(PY) -m pytest -q

# The inner loop: the core without Blender (bpy) or slow tests; `make test` (CI) runs everything.
.PHONY: test-fast
test-fast: setup
	$(PY) -m pytest -q -m "not slow and not blender"

# The bundled sample photo through the command-line estimator: result JSON, plot and .blend.
demo: setup
	@mkdir -p out/demo
	$(PY) -m cd_spectra_addon estimate samples/cd_photo.jpg --json out/demo/result.json \
		--plot out/demo/spd.png --blend out/demo/scene.blend
	@echo "wrote out/demo/result.json, out/demo/spd.png, out/demo/scene.blend"

# Re-make samples/cd_photo.jpg: CIE FL11 through the Cycles forward model (seeded).
sample-photo: setup
	$(PY) -m training.simulation.render_photo --spd samples/demo_lamps.csv --out out/sample --size 512 \
		--noise 0.005 --format jpg --seed 1
	cp out/sample/CIE_FL11.jpg samples/cd_photo.jpg

# Rebuild models/ from nothing (Cycles basis cubes, dataset, training, ONNX export), seeded.
model: setup
	$(PY) -m training.simulation.render_cubes --set full --engine cycles
	$(PY) -m training.learning.train --set full

eval: setup eval-camera-files eval-poses
	$(PY) -m training.evaluation.evaluate --out bench/eval.md
	$(PY) -m training.evaluation.model_card

# Which file to shoot: EXR, TIFF, DNG, in-camera JPEG/HEIC with and without calibration, matched
# vs generic profile, held-out cameras (simulated, 30 real lamps; a few minutes on one core).
eval-camera-files: setup
	OPENBLAS_NUM_THREADS=1 $(PY) -m training.evaluation.camera_files --out bench/camera_files.md

# Capture pose errors (lamp beside the lens, camera off centre, tilt, ambient, lamp size): numpy twin, minutes.
eval-poses: setup
	$(PY) -m training.evaluation.pose_errors --out bench/pose_errors.md

bench: setup
	$(PY) -m training.evaluation.bench --out bench/bench.md

bench-render: setup
	$(PY) -m training.evaluation.bench_render --out bench/render.md

tune-solver: setup
	$(PY) -m training.learning.tune_solver --out bench/solver_tuning.md

# Hostile inputs, confidence sweeps, a 1000-estimate soak and forward-model extremes.
reliability: setup
	$(PY) -m training.reliability.report --out bench/reliability.md

# Blender extension zips (one per platform) in dist/, validated and smoke-tested; wheels are
# downloaded from PyPI into build/wheels/ (git-ignored) on first use.
extension: setup
	$(PY) tools/build_extension.py

# Shipped tables baked once from their sources (outputs committed; re-run when a source changes).
bake-colour: setup
	$(PY) -m tools.bake_colour

bake-cameras: setup
	$(PY) -m tools.bake_cameras

# The buildable capture set-ups: presets re-designed by the planner (fails if they moved), then
# their side-view diagrams in docs/setups/ and the README table (printed).
diagrams: setup
	$(PY) tools/design_setups.py --check
	$(PY) tools/draw_setups.py --out docs/setups

clean:
	rm -rf out build dist .pytest_cache
