# The two commands of the README:
#   make demo  -- set up whatever is missing, then run the paper's in-plane case (case A)
#   make test  -- set up whatever is missing, then run the tests (serial, then 2 MPI ranks)
PY := .venv/bin/python
OUT ?= output

.PHONY: setup demo test test-serial test-mpi test-slow bench lint
setup:
	@bash .ci/setup

demo: setup
	$(PY) demos/demo_paper_inplane.py --output $(OUT)/paper_inplane

test: setup
	$(PY) -m pytest -q -p no:cacheprovider tests
	bash .ci/mpitest -q --color=no -p no:cacheprovider -m "not serial and not slow" tests

test-slow: setup
	$(PY) -m pytest -q -p no:cacheprovider -m slow tests

bench: setup
	$(PY) benchmarks/bench_string.py

lint:
	ruff check cablefem tests demos benchmarks
