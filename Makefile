# Two commands on a fresh machine (Python 3.11 and make):
#   make demo   runs the whole identification graph and writes a bag and a report
#   make test   runs the test suite
# Both create or reuse the virtual environment .venv and install everything into it.

PYTHON ?= $(shell command -v python3.11 || command -v python3)
VENV ?= .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.scara_ident_ros-installed

# Keep DDS on this machine unless the user chose otherwise.
export ROS_AUTOMATIC_DISCOVERY_RANGE ?= LOCALHOST

DEMO_DURATION ?= 60
DEMO_OUT ?= out/demo

.PHONY: demo test bench venv clean

venv: $(STAMP)

$(STAMP): requirements.txt constraints.txt setup.py setup.cfg package.xml
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade 'pip>=24'
	$(PY) -m pip install --quiet -r requirements.txt -c constraints.txt
	$(PY) -m pip install --quiet --no-deps --no-build-isolation -e .
	touch $(STAMP)

demo: $(STAMP)
	@if [ -e $(DEMO_OUT) ]; then \
	  kept=$(DEMO_OUT)-$$(date +%Y%m%d-%H%M%S); mv $(DEMO_OUT) $$kept; \
	  echo "previous demo kept as $$kept"; fi
	$(VENV)/bin/scara-ident run --duration $(DEMO_DURATION) --out $(DEMO_OUT)

test: $(STAMP)
	$(PY) -m pytest test

bench: $(STAMP)
	$(PY) -m pip install --quiet -r requirements-bench.txt -c constraints.txt
	$(PY) benchmarks/run_all.py

clean:
	rm -rf build install log out .pytest_cache
