# CD Spectra — every job is a target; each one sets up .venv first if needed.
SHELL := /bin/bash
PYTHON ?= $(shell command -v python3.11 || command -v python3)
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed-$(shell cat requirements.txt | md5sum | cut -c1-8)

# Blender 5.1+ runs Python 3.13 with numpy 2: a second environment tests the add-on there.
# Found on PATH or under pyenv; otherwise set PYTHON313=/path/to/python3.13 (`pyenv install 3.13`).
PYTHON313 ?= $(shell for p in $$(command -v python3.13) $(HOME)/.pyenv/versions/3.13*/bin/python3.13 \
	/root/.pyenv/versions/3.13*/bin/python3.13 /usr/local/bin/python3.13 /usr/bin/python3.13; do \
	[ -x "$$p" ] && "$$p" -c 'import sys; sys.exit(sys.version_info[:2] != (3, 13))' 2>/dev/null \
	&& { echo "$$p"; break; }; done)
VENV313 := .venv313
PY313 := $(VENV313)/bin/python
STAMP313 := $(VENV313)/.installed-$(shell cat requirements-py313.txt | md5sum | cut -c1-8)
# What runs under Python 3.13 / bpy 5.2: the installed extension (install, estimate, light, undo,
# unregister), the packaging rules, the CLI, camera files (rawpy, pillow-heif, 4:2:2 JPEGs, fitted camera
# sensitivities), the planner, measured set-ups, the joint estimate and the numpy core. Training (torch) stays on 3.11.
TESTS313 := tests/test_extension_blender.py tests/test_extension_package.py tests/test_cli.py tests/test_cli_commands.py \
	tests/test_colour.py tests/test_working_space.py tests/test_estimate.py tests/test_inverse_core.py \
	tests/test_spectra_files.py tests/test_grating.py tests/test_spectral_grid.py \
	tests/test_camera_files.py tests/test_camera_pipeline.py tests/test_images.py tests/test_export_formats.py \
	tests/test_core_imports.py tests/test_illuminants.py tests/test_planner.py tests/test_setups.py \
	tests/test_capture_pose.py tests/test_general_pose.py tests/test_pose_recovery.py tests/test_disc_window.py tests/test_camera_fit.py \
	tests/test_jpeg_chroma.py tests/test_measured_setups.py tests/test_capture_advice.py \
	tests/test_cli_joint.py tests/test_joint_estimate.py tests/test_rendition.py tests/test_censoring.py \
	tests/test_rendering_family.py

# The tests run on both cores: pytest-xdist with one worker per core, each test file on one worker
# (--dist loadfile: a module's fixtures, e.g. its rendered capture or the hostile-input runs, are
# built once) and single-threaded BLAS in each worker (two workers each spinning two OpenBLAS
# threads used ~40 % more CPU for no gain). PYTEST_WORKERS=0 runs in one process, as before.
# --durations: CI's log names the slowest tests, where the 10-minute budget is spent.
PYTEST_WORKERS ?= 2
PYTEST_ARGS := -q -n $(PYTEST_WORKERS) --dist loadfile --durations=25

.PHONY: setup setup313 test test311 test313 test-fast demo sample-photo model tune-fusion eval eval-tails eval-camera-files eval-camera-renderings eval-cross-check eval-poses eval-real eval-rendition bench bench-render tune-solver tune-lines reliability extension bake-colour bake-cameras diagrams vector-graphic clean

$(STAMP): requirements.txt
	@$(PYTHON) -c 'import sys; sys.exit(0 if sys.version_info[:2] == (3, 11) else "Python 3.11 is required (Blender 4.5 / bpy 4.5): set PYTHON=/path/to/python3.11")'
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --disable-pip-version-check -r requirements.txt
	rm -f $(VENV)/.installed-*
	touch $(STAMP)

setup: $(STAMP)

$(STAMP313): requirements-py313.txt
	@test -n "$(PYTHON313)" || { echo "Python 3.13 is required for the Blender 5.1+ tests: set PYTHON313=/path/to/python3.13 (e.g. pyenv install 3.13)"; exit 1; }
	@$(PYTHON313) -c 'import sys; sys.exit(0 if sys.version_info[:2] == (3, 13) else "$(PYTHON313) is not Python 3.13: set PYTHON313=/path/to/python3.13")'
	$(PYTHON313) -m venv $(VENV313)
	$(PY313) -m pip install --quiet --disable-pip-version-check -r requirements-py313.txt
	rm -f $(VENV313)/.installed-*
	touch $(STAMP313)

setup313: $(STAMP313)

# Both Blenders: the whole suite in Python 3.11 / bpy 4.5, then the add-on and core in 3.13 / bpy 5.2.
# .venv313 is set up (mostly a download) while the 3.11 suite runs; each one's output is printed whole.
test: setup
	@$(MAKE) --no-print-directory -j2 --output-sync=target test311 setup313
	@$(MAKE) --no-print-directory test313

test311: setup
	OPENBLAS_NUM_THREADS=1 $(PY) -m pytest $(PYTEST_ARGS)

test313: setup313
	OPENBLAS_NUM_THREADS=1 $(PY313) -m pytest $(PYTEST_ARGS) $(TESTS313)

# The inner loop: the core without Blender (bpy) or slow tests; `make test` (CI) runs everything.
# Its tests are short and many: workers steal them from each other (a whole file per worker left
# one core idle for the last ~8 s), at the cost of a few module fixtures built twice.
test-fast: setup
	OPENBLAS_NUM_THREADS=1 $(PY) -m pytest -q -n $(PYTEST_WORKERS) --dist worksteal -m "not slow and not blender"

# The bundled sample photo through the command-line estimator: result JSON, plot and .blend.
demo: setup
	@mkdir -p out/demo
	$(PY) -m cd_spectra_addon estimate samples/cd_photo.jpg --json out/demo/result.json \
		--plot out/demo/spd.png --blend out/demo/scene.blend

# Re-make samples/cd_photo.jpg: CIE FL11 through the Cycles forward model (seeded), in the default
# preset (render_photo's --preset default is the estimator's, so the demo reads it as it was made).
# 1024 px is the loader's working size: the phone's wide lens puts the disc ~420 px across (at 512 px,
# ~210 px, the estimate saw 85 % of 400–700 nm, warned of a cut-off disc and gave confidence 0.73).
sample-photo: setup
	$(PY) -m training.simulation.render_photo --spd samples/demo_lamps.csv --out out/sample --size 1024 \
		--noise 0.005 --format jpg --seed 1
	cp out/sample/CIE_FL11.jpg samples/cd_photo.jpg

# Rebuild models/ from nothing (Cycles basis cubes of the buildable set-ups, dataset, training, ONNX
# export, fusion and per-band choice on synthetic photos), seeded. 300 photos per geometry (17 geometries):
# each photo runs the product's whole inverse path at ~0.8 s per core, so 1000 would take ~2.5 h on 2 cores.
MODEL_SAMPLES_PER_CUBE ?= 300
model: setup
	$(PY) -m training.simulation.render_cubes --set buildable --engine cycles
	$(PY) -m training.learning.train --set buildable --n-per-cube $(MODEL_SAMPLES_PER_CUBE)

# Re-choose the fusion and, per band, network vs physics + prior for the model in models/ (synthetic
# photos of the geometries it was trained on; no retraining), then the real-lamp check of that choice.
tune-fusion: setup
	$(PY) -m training.learning.tune_fusion --write
	OPENBLAS_NUM_THREADS=1 $(PY) -m training.evaluation.band_choice_real --out bench/band_choice_real.md

# Issue 21 items 1-2 before/after: the blind tails from physics and the band rule without islands,
# on held-out synthetic spectra and then the 312 real lamps (cd-default, numpy renderer; ~15 min).
eval-tails: setup
	OPENBLAS_NUM_THREADS=1 $(PY) -m training.evaluation.tails --out bench/tails.md

eval: setup eval-camera-files eval-poses
	$(PY) -m training.evaluation.evaluate --out bench/eval.md
	$(PY) -m training.evaluation.model_card

# Which file to shoot: EXR, TIFF, DNG, in-camera JPEG/HEIC with and without calibration, matched
# vs generic profile, held-out cameras (simulated, 30 real lamps; the rows calibrated from one
# in-camera CIE A shot over 3 draws of its noise; ~15 min on one core, then camera_renderings ~6 min).
# RAW_PAIRS=folder: real cameras' raw files with their JPEGs, whose renderings are learned (not in the repo).
# Five sections: the JPEGs exposed as README's step 5 says (the goal rows), the same exposed for
# the raw with the blinking highlights ignored (--metering raw), from photos 4× the loaded size,
# and written as each camera's other file: the DSLR's 4:2:2 fine JPEG, the phone's HEIC.
CAMERA_RENDERINGS = for args in "--metering rendering" "--metering raw" "--upsample 4" \
	"--file dslr-jpeg --settings dslr" "--file heic --settings phone"; do \
	OPENBLAS_NUM_THREADS=1 $(PY) -m training.evaluation.camera_renderings --write $$args \
	$(if $(RAW_PAIRS),--real-pairs "$(RAW_PAIRS)") || exit 1; done
eval-camera-files: setup
	OPENBLAS_NUM_THREADS=1 $(PY) -m training.evaluation.camera_files --calibration-draws 3 --out bench/camera_files.md
	$(CAMERA_RENDERINGS)

# In-camera JPEGs from renderings the calibration never modelled (issue 20; its section of
# bench/camera_files.md, five of them; ~60 min on one core).
eval-camera-renderings: setup
	$(CAMERA_RENDERINGS)

# Capture pose errors (lamp beside the lens, camera off centre, tilt, ambient, lamp size): numpy twin, minutes.
# Per set-up pose errors at a real photo's resolution (simulator). 12 lamps ≈ 1 h on the shared
# 2-core machine; all 205 (POSE_LAMPS=205) ≈ 15 h single-process — add POSE_JOBS=2 (one process per set-up).
POSE_LAMPS ?= 12
POSE_JOBS ?= 1
# Where the two-lamp cross-check's limit comes from (calibration's own renderings only; ~5 min).
eval-cross-check: setup
	OPENBLAS_NUM_THREADS=1 $(PY) -m training.evaluation.cross_check_family --out bench/cross_check_family.md

eval-poses: setup
	$(PY) -m training.evaluation.pose_errors --lamps $(POSE_LAMPS) --jobs $(POSE_JOBS) --out bench/pose_errors.md

# Real photographs (Kim 2023's CD and DVD series): give the folder holding cd1.gif and dvd1.gif
# (github.com/yongwookkkkim/Diffraction-on-Optical-Disks, unwritten/; no licence, so never in the repo).
eval-real: setup
	@test -n "$(KIM_DIR)" || { echo "make eval-real KIM_DIR=/path/to/folder/with/cd1.gif+dvd1.gif"; exit 2; }
	OPENBLAS_NUM_THREADS=1 $(PY) -m training.evaluation.real_photos --kim-dir "$(KIM_DIR)" --out bench/real_photos.md

# Colour rendition: do the 90 % ranges of Ra, R9, Rf, Rg cover the truth? The draws' correlation length and factor
# on spd_std are chosen on synthetic photos, coverage measured on the real lamps, and the time per estimate (~15 min on 2 shared
# cores once the Cycles cube of the nominal set-up is cached in data/basis/).
eval-rendition: setup
	OPENBLAS_NUM_THREADS=1 $(PY) -m training.evaluation.rendition_coverage --out bench/rendition.md

bench: setup
	$(PY) -m training.evaluation.bench --out bench/bench.md

bench-render: setup
	$(PY) -m training.evaluation.bench_render --out bench/render.md

tune-solver: setup
	$(PY) -m training.learning.tune_solver --out bench/solver_tuning.md

# How far narrow lines may stand out of the Gaussian prior (solve.LINE_ALLOWANCE), synthetic only (~3 min).
tune-lines: setup
	$(PY) -m training.learning.tune_lines --out bench/line_tuning.md

# Hostile inputs, confidence sweeps, a 1000-estimate soak and forward-model extremes.
reliability: setup
	$(PY) -m training.reliability.report --out bench/reliability.md

# Blender extension zips (one per platform) in dist/, validated and smoke-tested; wheels are
# downloaded from PyPI into build/wheels/ (git-ignored) on first use.
extension: setup setup313
	$(PY) tools/build_extension.py --python313 $(PY313)

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

# README's picture of the Result panel's TM-30 colour vector graphic: the demo photo's estimate,
# drawn by the core function the panel draws it with.
vector-graphic: setup
	@mkdir -p out/demo
	$(PY) -m cd_spectra_addon estimate samples/cd_photo.jpg --json out/demo/result.json
	$(PY) tools/draw_vector_graphic.py out/demo/result.json docs/rendition/vector_graphic.png

clean:
	rm -rf out build dist .pytest_cache
