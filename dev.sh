#!/usr/bin/env bash
# The project's commands (the README's two are `./dev.sh demo` and `./dev.sh test`).
# Each sets up whatever is missing first (.ci/setup: Debian packages, .venv, the project).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")"
PY=.venv/bin/python
case "${1:-}" in
  demo)      # the paper's in-plane case (case A) -> ${OUT:-output}/paper_inplane
    bash .ci/setup
    exec "$PY" demos/demo_paper_inplane.py --output "${OUT:-output}/paper_inplane" ;;
  demo-spatial)
    bash .ci/setup
    exec "$PY" demos/demo_paper_spatial.py --output "${OUT:-output}/paper_spatial" ;;
  demo-large)  # a 108 360-dof cable-net roof on ${NP:-2} MPI ranks -> output/roof_large
    bash .ci/setup
    [ -f meshes/roof_large.msh ] || "$PY" meshes/make_roof.py --n 42 --k 10 --out meshes/roof_large.msh
    export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
    exec mpirun -n "${NP:-2}" .venv/bin/cablefem run demos/roof_large.toml --output "${OUT:-output}/roof_large" ;;
  test)      # serial suite, then on 2 MPI ranks the tests where parallelism can change something
    bash .ci/setup
    "$PY" -m pytest -q -p no:cacheprovider tests
    exec bash .ci/mpitest -q --color=no -p no:cacheprovider -m "not serial and not slow and not single_rank" tests ;;
  test-slow)
    bash .ci/setup
    rc=0; "$PY" -m pytest -q -p no:cacheprovider -m slow tests || rc=$?
    if [ "$rc" = 5 ]; then echo "no test is marked slow"; rc=0; fi
    exit "$rc" ;;
  bench)
    bash .ci/setup
    exec "$PY" benchmarks/bench_string.py ;;
  *)
    echo "usage: ./dev.sh demo|demo-spatial|demo-large|test|test-slow|bench" >&2
    exit 2 ;;
esac
