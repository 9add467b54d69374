# Two commands on a fresh machine (Python 3.11 and make):
#   make demo   runs the whole identification graph and writes a bag and a report
#   make test   runs the test suite (make test-all: with the long tests)
# Both create or reuse the virtual environment .venv and install everything into it.
# While working on the maths, make test-core runs the pure-numpy tests alone, in seconds.
# make lint runs ruff and mypy on the package, as CI (.ci/run) does before make test.
# make docs writes docs/parameters.md from the nodes' parameter tables.

PYTHON ?= $(shell command -v python3.11 || command -v python3)
VENV ?= .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.scara_ident_ros-installed
ROS_ENV := $(VENV)/.scara_ident_ros-ros-env

# The project runs on its venv's own ROS libraries whatever the calling shell holds: the
# venv's interpreter restarts itself on them (scara_ident_ros/nodes/rosenv.py, installed as
# a .pth by make venv), and the ROS wheels' bootstrap mark another venv's process passed on
# is not passed to ours.
unexport _ROS_WHEELS_BOOTSTRAP_COMPLETE

# Keep DDS on this machine unless the user chose otherwise.
export ROS_AUTOMATIC_DISCOVERY_RANGE ?= LOCALHOST

DEMO_DURATION ?= 60
DEMO_OUT ?= out/demo

.PHONY: demo test test-all test-core lint docs bench venv clean

venv: $(ROS_ENV)

$(STAMP): requirements.txt constraints.txt setup.py setup.cfg package.xml
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade 'pip>=24'
	$(PY) -m pip install --quiet -r requirements.txt -c constraints.txt
	$(PY) -m pip install --quiet --no-deps --no-build-isolation -e .
	touch $(STAMP)

$(ROS_ENV): $(STAMP) scara_ident_ros/nodes/rosenv.py
	$(PY) -c 'from scara_ident_ros.nodes.rosenv import install_pth; install_pth()'
	touch $(ROS_ENV)

demo: $(ROS_ENV)
	@if [ -e $(DEMO_OUT) ]; then \
	  kept=$(DEMO_OUT)-$$(date +%Y%m%d-%H%M%S); mv $(DEMO_OUT) $$kept; \
	  echo "previous demo kept as $$kept"; fi
	$(VENV)/bin/scara-ident run --duration $(DEMO_DURATION) --out $(DEMO_OUT)

# make test runs the suite on TEST_WORKERS xdist processes (each claims a ROS domain of its
# own: test/conftest.py), a module's tests on one worker so that its fixtures are built once;
# in a random order (pytest-randomly; the header prints the seed, --randomly-seed=N repeats
# it). Tests marked long (measurements, and runs that repeat what faster tests check) are
# left to make test-all.
TEST_WORKERS ?= 2
PARALLEL := -n $(TEST_WORKERS) --dist loadscope

# A crash of the test process itself (a signal: once, a segmentation fault in an in-process
# rclpy listener, not reproduced since) runs the suite once more and says so; a test that
# fails (exit 1) is never run again. A worker that crashes fails the test it was running.
test: $(ROS_ENV)
	@$(PY) -m pytest $(PARALLEL) -m 'not long' test; status=$$?; \
	if [ $$status -gt 128 ]; then \
	  echo "make test: pytest was killed by signal $$((status - 128)); running the suite again"; \
	  $(PY) -m pytest $(PARALLEL) -m 'not long' test; status=$$?; fi; \
	exit $$status

# Everything, the long tests included.
test-all: $(ROS_ENV)
	$(PY) -m pytest $(PARALLEL) test

# The pure-numpy tests: every test not marked ros (a module that imports rclpy, joins DDS or
# starts ROS processes says so with pytestmark = pytest.mark.ros; test/test_core_selection.py
# checks that no other module brings rclpy in) and not slow (make test runs those too).
# test/conftest.py holds BLAS to one thread in every test run, whichever command starts it.
test-core: $(ROS_ENV)
	$(PY) -m pytest $(PARALLEL) -m 'not ros and not slow and not long' test

# ruff (ruff.toml) and mypy (mypy.ini), as .ci/run runs them before the tests.
lint: $(ROS_ENV)
	$(VENV)/bin/ruff check .
	$(PY) -m mypy

# docs/parameters.md from the nodes' ParamSpec tables (a test checks it is up to date).
docs: $(ROS_ENV)
	$(PY) -m scara_ident_ros.nodes.parameter_reference docs/parameters.md

bench: $(ROS_ENV)
	$(PY) -m pip install --quiet -r requirements-bench.txt -c constraints.txt
	$(PY) benchmarks/run_all.py

clean:
	rm -rf build install log out .pytest_cache
