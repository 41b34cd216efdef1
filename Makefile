# compass-manip: every target builds .venv itself if it is missing.
SHELL := /bin/bash
PY := .venv/bin/python
PIP := .venv/bin/pip
export MUJOCO_GL ?= egl
export PYOPENGL_PLATFORM ?= egl
export NUMBA_CACHE_DIR ?= $(CURDIR)/.cache/numba
export MPLBACKEND ?= Agg
# numba's OpenMP workers spin-wait by default; on 2 shared cores that triples integration time
export OMP_WAIT_POLICY ?= PASSIVE

.PHONY: venv demo test bench clean

venv: .venv/.installed

.venv/.installed: pyproject.toml
	test -x $(PY) || python3 -m venv .venv
	$(PIP) install --quiet --upgrade pip
	$(PIP) install --quiet -e '.[test,viz]'
	$(PIP) install --quiet --no-deps dm-robotics-panda==0.4.8
	touch $@

demo: venv
	.venv/bin/compass demo --level 4 --out outputs/demo

test: venv
	$(PY) -m pytest -q -p no:cacheprovider -n 2 --durations=15

bench: venv
	$(PY) benchmarks/run_all.py

clean:
	rm -rf .venv .cache outputs
