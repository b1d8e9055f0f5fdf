#!/usr/bin/env bash
# Run every pmpm test: installs what is missing (scripts/setup.sh, idempotent), then the
# serial tests, then the MPI tests on 2 ranks (pytest-mpi). Extra arguments go to pytest.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export OMPI_MCA_rmaps_base_oversubscribe=1 PRTE_MCA_rmaps_default_mapping_policy=:oversubscribe
export NUMBA_NUM_THREADS=1 OMP_NUM_THREADS=1
PY=.venv/bin/python
echo "== serial tests"
$PY -m pytest -q --color=no "$@" tests
echo "== MPI tests on 2 ranks"
mpirun -n 2 --oversubscribe $PY -m pytest -q --color=no --with-mpi -m mpi -p no:cacheprovider "$@" tests
