# Luxel: two commands on a fresh machine.
#   make bake   installs Luxel and Blender (the bpy module) into .venv, and bakes
#               sample_blends/cornell_box.blend through the extension in background mode
#   make test   installs the same plus pytest into .venv and runs the tests
#   make view   shows what make bake baked in a web page (glTF, three.js) on 127.0.0.1:8000
#   make test-matrix  installs the extension zip into Blender 4.2, 4.5, 5.0, 5.2 and 5.3 and bakes
PYTHON ?= python3.11
VENV := .venv
BIN := $(VENV)/bin
VERSION := $(shell sed -n 's/^version = "\(.*\)"/\1/p' blender_manifest.toml)

.PHONY: bake test test-matrix compare benchmarks extension extension-check samples clean \
	viewer view chromium babylon

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)

$(VENV)/.runtime: requirements.txt | $(BIN)/python
	$(BIN)/python -m pip install --quiet -r requirements.txt
	touch $@

$(VENV)/.blender: requirements-blender.txt $(VENV)/.runtime
	$(BIN)/python -m pip install --quiet -r requirements-blender.txt
	touch $@

$(VENV)/.dev: requirements-dev.txt $(VENV)/.blender
	$(BIN)/python -m pip install --quiet -r requirements-dev.txt
	touch $@

$(VENV)/.bench: requirements-bench.txt $(VENV)/.blender
	$(BIN)/python -m pip install --quiet -r requirements-bench.txt
	touch $@

bake: $(VENV)/.blender
	$(BIN)/python tools/blender.py -b sample_blends/cornell_box.blend --command luxel bake \
		--density 50 --threshold 0.01 --output out/cornell --preview out/cornell/preview.png \
		--save-as out/cornell/cornell.blend

# The Cornell box that make bake saved, as a GLB in a web page served on 127.0.0.1:8000.
view: viewer
	$(BIN)/python tools/blender.py -b out/cornell/cornell.blend --command luxel view \
		out/cornell/cornell.glb

# The tests that load Blender run in a process of their own: Mesa's GL, used after Blender in
# the same process, aborted in a later test (the deadlock seen in full runs was xatlas's, see
# native/charting.py). Importing the repository's package loads no bpy (__init__.py), since
# pytest imports it as the parent of tests/.
BLENDER_TESTS := $(shell grep -l blender_session tests/test_*.py)

# Two lanes side by side, each mostly one core's work (the solver's GL on llvmpipe; Blender's
# Python and Cycles): the solver's tests then the extension in each Blender, beside the Blender
# tests then the farm's. The first lane's output follows the second's when both are done.
test: $(VENV)/.dev viewer chromium babylon
	mkdir -p out
	( $(BIN)/python -m pytest -q -p no:cacheprovider tests \
		$(addprefix --ignore=,$(BLENDER_TESTS)) \
	  && $(MAKE) --no-print-directory test-matrix MATRIX="4.2 4.5 5.2 5.3" \
	) > out/test-solver.log 2>&1 & solver=$$!; \
	$(BIN)/python -m pytest -q $(BLENDER_TESTS) && $(MAKE) --no-print-directory test-farm; \
	blender=$$?; wait $$solver; solver=$$?; \
	echo "--- the solver's tests and the Blender matrix:"; cat out/test-solver.log; \
	test $$blender -eq 0 && test $$solver -eq 0

# The browser viewer's three.js (viewer/package-lock.json), which native/viewer.py copies.
viewer: viewer/node_modules/.installed

viewer/node_modules/.installed: viewer/package-lock.json
	cd viewer && npm ci --no-audit --no-fund
	touch $@

# Babylon.js for tests/test_babylon.py (tests/web/package-lock.json): the MOZ_lightmap extension
# for Babylon's glTF loader (viewer/babylon_moz_lightmap.js) rendered by Babylon itself.
babylon: tests/web/node_modules/.installed

tests/web/node_modules/.installed: tests/web/package-lock.json
	cd tests/web && npm ci --no-audit --no-fund
	touch $@

# Headless Chromium for the viewer's tests (tests/browser.py), from the system's packages.
SUDO = $(if $(filter 0,$(shell id -u)),,sudo)
chromium:
	@test -x /usr/bin/chromium || { $(SUDO) apt-get update -qq && \
		$(SUDO) apt-get install -y --no-install-recommends chromium; }

# The Flamenco job type's tests (farm/): Node's own test runner, no packages.
.PHONY: test-farm
test-farm:
	node --test farm/test/

# Luxel against Cycles on the Cornell box: out/compare/report.html and report.json.
compare: $(VENV)/.blender
	$(BIN)/python tools/blender.py -b sample_blends/cornell_box.blend --command luxel compare \
		--output out/compare --density 60 --threshold 0.01 --samples 1024 --view-samples 256

# Every study of bench/ re-measured on one commit (bench/run.py: bench/results/STUDY.json),
# then BENCHMARKS.md's tables and bench/results/STUDY.png made again (bench/report.py).
# DEVICE=cpu (the default): sizes for llvmpipe on 2 CPU cores, about 40 minutes in all;
# DEVICE=gpu: the paper's sizes, where a GPU renders OpenGL. One study alone:
# make benchmarks STUDY=table1, or python bench/paper.py table1 (bench/run.py --help lists
# the studies and their scripts); DRY_RUN=1 prints the plan and runs nothing. The real levels
# are read from LEVELS (a folder of LEVEL.obj; the repository does not ship them).
DEVICE ?= cpu
benchmarks: $(VENV)/.bench
	$(if $(LEVELS),LUXEL_LEVELS=$(LEVELS) )$(BIN)/python bench/run.py --device $(DEVICE) \
		$(STUDY) $(if $(DRY_RUN),--dry-run); status=$$?; \
		$(if $(DRY_RUN),exit $$status,$(BIN)/python bench/report.py && exit $$status)

# The installable extension: dist/luxel-<version>.zip with the dependency wheels.
extension: viewer | $(BIN)/python
	$(BIN)/python tools/build_extension.py

# Installs the zip into a fresh Blender profile and bakes with it.
extension-check: extension $(VENV)/.blender
	$(BIN)/python tools/check_extension_install.py dist/luxel-$(VERSION).zip

# The zip in a fresh profile of each Blender line in the manifest's range (the latest bpy of
# each): strict validation, install, the Cornell box baked within 5 % of that Blender's Cycles.
# 5.0 runs in .venv (bpy from requirements-blender.txt); the others in .venv-bpy-<line>/, from
# requirements-bpy-<line>.txt, on Python 3.11 or, for 5.1 and later, 3.13 (PYTHON313).
MATRIX ?= 4.2 4.5 5.0 5.2 5.3
# Python 3.13: python3.13 where it runs, else the newest 3.13 that pyenv has.
PYTHON313 ?= $(shell python3.13 -c '' 2>/dev/null && echo python3.13 || echo "$$(pyenv root \
	2>/dev/null)/versions/$$(pyenv versions --bare 2>/dev/null | grep '^3\.13' | tail -1)/bin/python3")

test-matrix: $(addprefix test-matrix-,$(MATRIX))

test-matrix-5.0: extension $(VENV)/.blender
	$(BIN)/python tools/check_extension_install.py --cornell-box dist/luxel-$(VERSION).zip

test-matrix-%: extension .venv-bpy-%/.installed
	.venv-bpy-$*/bin/python tools/check_extension_install.py --cornell-box dist/luxel-$(VERSION).zip

.PRECIOUS: .venv-bpy-%/.installed  # kept, though only a pattern rule names it
.venv-bpy-%/.installed: requirements-bpy-%.txt
	rm -rf .venv-bpy-$*
	$(if $(filter 4.% 5.0,$*),$(PYTHON),$(PYTHON313)) -m venv .venv-bpy-$*
	.venv-bpy-$*/bin/python -m pip install --quiet -r $<
	touch $@

# Regenerates the scenes in sample_blends/.
samples: $(VENV)/.blender
	$(BIN)/python sample_blends/generate.py

clean:
	rm -rf $(VENV) .venv-bpy-* out dist
