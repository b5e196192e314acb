# Two commands do all set-up: `make demo` and `make test`.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
# One stamp per install: the demo needs the package, its planner, the simulator and the web view (`plan`, `sim`,
# `view`), the tests
# everything in `test` (which holds both, so installing it also satisfies the demo's stamp).
DEMO_STAMP := $(VENV)/.installed-demo
TEST_STAMP := $(VENV)/.installed-test

.PHONY: install demo test lint bench clean browser

$(PY):
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip

$(DEMO_STAMP): pyproject.toml | $(PY)
	$(PY) -m pip install --quiet -e '.[plan,sim,view]'
	touch $@

$(TEST_STAMP): pyproject.toml | $(PY)
	$(PY) -m pip install --quiet -e '.[test]'
	touch $@ $(DEMO_STAMP)

install: $(TEST_STAMP)

demo: $(DEMO_STAMP)
	$(VENV)/bin/skillbank demo --out demo_output --force

lint: $(TEST_STAMP)
	$(PY) -m ruff check .

# The web view's tests drive Debian's headless Chromium (docs/view.md); installed once, when missing.
CHROMIUM := /usr/bin/chromium

browser:
	@if [ ! -x $(CHROMIUM) ]; then \
		if command -v apt-get >/dev/null 2>&1; then \
			apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium chromium-driver; \
		else echo "make: $(CHROMIUM) is missing and apt-get is not here: install Chromium" >&2; fi; \
	fi

# One worker per core (pytest-xdist): every test stands alone, each worker starts its own PostgreSQL and
# Dask cluster in its own temporary folder.
test: $(TEST_STAMP) lint browser
	$(PY) -m pytest -n auto

bench: $(TEST_STAMP)
	$(PY) -m pip install --quiet -e '.[bench]'
	$(PY) benchmarks/bench_segmentation.py
	$(PY) benchmarks/bench_ruptures.py
	$(PY) benchmarks/bench_segmentation_quality.py
	$(PY) benchmarks/bench_segmentation_scale.py
	$(PY) benchmarks/bench_clustering.py
	$(PY) benchmarks/bench_clustering_quality.py --seeds 10
	$(PY) benchmarks/bench_editing.py
	$(PY) benchmarks/bench_ik.py
	$(PY) benchmarks/bench_ik_chain.py
	$(PY) benchmarks/bench_panda_redundancy.py
	$(PY) benchmarks/bench_reuse_robot.py
	$(PY) benchmarks/bench_time_law.py
	$(PY) benchmarks/bench_planning.py
	$(PY) benchmarks/bench_ingest.py
	$(PY) benchmarks/bench_scale.py store
	$(PY) benchmarks/bench_scale.py ingest
	$(PY) benchmarks/bench_scale.py cluster
	$(PY) benchmarks/bench_robosuite.py --episodes 20 --seed 5000
	$(PY) benchmarks/bench_view.py
	$(PY) benchmarks/bench_composition.py --episodes 20 --seed 30

clean:
	rm -rf $(VENV) demo_output .pytest_cache .ruff_cache
