# Two commands do all set-up: `make demo` and `make test`.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed

.PHONY: install demo test lint bench clean

$(STAMP): pyproject.toml
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[test]'
	touch $(STAMP)

install: $(STAMP)

demo: $(STAMP)
	$(VENV)/bin/skillbank demo --out demo_output

lint: $(STAMP)
	$(PY) -m ruff check .

test: $(STAMP) lint
	$(PY) -m pytest

bench: $(STAMP)
	$(PY) -m pip install --quiet -e '.[bench]'
	$(PY) benchmarks/bench_segmentation.py
	$(PY) benchmarks/bench_ruptures.py
	$(PY) benchmarks/bench_segmentation_quality.py
	$(PY) benchmarks/bench_clustering.py
	$(PY) benchmarks/bench_clustering_quality.py --seeds 10
	$(PY) benchmarks/bench_editing.py
	$(PY) benchmarks/bench_ik.py
	$(PY) benchmarks/bench_reuse_robot.py
	$(PY) benchmarks/bench_planning.py
	$(PY) benchmarks/bench_ingest.py
	$(PY) benchmarks/bench_scale.py store
	$(PY) benchmarks/bench_scale.py ingest
	$(PY) benchmarks/bench_scale.py cluster

clean:
	rm -rf $(VENV) demo_output .pytest_cache .ruff_cache
