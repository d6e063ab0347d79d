# Set-up and the two entry points of README.md. Every target installs what is missing first and
# does nothing more when all is there (a second `make test` starts testing within seconds).
SHELL := /bin/bash
VENV := .venv
PYTHON := $(VENV)/bin/python
# FreeFEM with its plugins, gmsh (its package brings the libGL and libGLU the gmsh Python module
# loads; nothing of the project renders with EGL: images are matplotlib's Agg, and pyvista only
# filters, which loads no GL library), the single-threaded OpenBLAS (CHOLMOD's back-substitutions 1.5-2x faster than with the reference
# BLAS; one thread keeps runs deterministic and leaves the cores to parallel runs), and what
# builds the project's own FreeFEM plugins (ff-c++ with FreeFEM's headers, SuiteSparse's for
# factorsplit, and g++).
APT_PACKAGES := freefem++ libfreefem++ libfreefem++-dev libsuitesparse-dev g++ gmsh libopenblas0-serial
SUDO := $(shell [ "$$(id -u)" = 0 ] || echo sudo)

.PHONY: setup system-packages plugins paper test test-fast gallery

setup: system-packages $(VENV)/.installed plugins

system-packages:
	@missing=""; \
	for package in $(APT_PACKAGES); do \
	  dpkg-query -W -f='$${Status}' $$package 2>/dev/null | grep -q "install ok installed" || missing="$$missing $$package"; \
	done; \
	python3 -c "import ensurepip" 2>/dev/null || missing="$$missing python3-venv"; \
	if [ -n "$$missing" ]; then \
	  echo "installing Debian packages:$$missing"; \
	  $(SUDO) apt-get update -qq && DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq $$missing; \
	fi

$(VENV)/.installed: pyproject.toml
	python3 -m venv $(VENV)
	$(VENV)/bin/pip install -q --upgrade pip
	$(VENV)/bin/pip install -q -e ".[test]"
	touch $@

# The project's FreeFEM plugins (edp/plugins: blocksolve, many right-hand sides at once;
# factorsplit, the halves of CHOLMOD's solves; strainoperators, a body's strain operators in compact
# form), compiled unless built from their source as it is for the FreeFem++ installed (bin/plugins).
plugins: system-packages
	bin/plugins build

# The run goes to build/paper and is checked against the committed results/paper/summary.json, so
# the tree stays clean on any machine; a run that does not reproduce it fails. To renew the
# committed figures: `orchestrate run scenes/paper.toml --out results/paper --force`.
paper: setup
	$(PYTHON) -m orchestrate run scenes/paper.toml --out build/paper --force --check-against results/paper

# Into the committed results/gallery: --force replaces its run folders (only folders of runs).
gallery: setup
	$(PYTHON) -m orchestrate gallery --force

# The whole suite on both cores (pytest-xdist; each test in one tier: unit, solver, physics, runs,
# pyproject.toml), and the tests that start no FreeFem++ and no gmsh, for a Python-only change.
test: setup
	$(PYTHON) -m pytest -q -n 2 tests

test-fast: setup
	$(PYTHON) -m pytest -q -m unit tests
