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
# The serial tests run as one share of the test files per core, side by side (at most
# two: the MPI tests among them take both cores); the kernels are compiled (or loaded)
# once first. PMPM_TEST_SHARES=1 runs them in one process.
cores=$(OMP_NUM_THREADS= OMP_THREAD_LIMIT= nproc)      # nproc obeys OMP_NUM_THREADS
shares=${PMPM_TEST_SHARES:-$(( cores > 1 ? 2 : 1 ))}
run_share() {   # share i of $shares; a share that "$@" leaves empty (pytest's 5) passes
    local rc=0
    $PY -m pytest -q --color=no -p no:cacheprovider --shard "$1/$shares" "${@:2}" tests || rc=$?
    [ "$rc" -eq 5 ] && rc=0
    return "$rc"
}
echo "== serial tests ($shares shares of the test files side by side)"
# Compile (or load) the step kernels of every shape once, two sets side by side, before
# the shares start: otherwise on a fresh clone each share compiles the ones it meets,
# the same ones twice where both meet them. The stale-cache check runs once, first.
warm() { NUMBA_NUM_THREADS=1 $PY -c "from pmpm.kernels.warmup import warm_up
from pmpm.kernels.shape import SHAPE_CODES as S
for name in '$1'.split(): warm_up(S[name.rstrip('+')], apic=name.endswith('+'))"; }
$PY -c "from pmpm.kernels.cache import refresh_kernel_caches as r; r()"
warm "linear bspline+" &
compiling=$!
warm "gimp+" || echo "pmpm: warm-up of the gimp kernels failed; the tests compile them"
wait "$compiling" || echo "pmpm: warm-up of the linear and bspline kernels failed"
logs=$(mktemp -d)
pids=()
for i in $(seq 2 "$shares"); do
    run_share "$i" "$@" > "$logs/share$i.log" 2>&1 &
    pids+=($!)
done
status=0
run_share 1 "$@" || status=$?
for i in $(seq 2 "$shares"); do
    wait "${pids[$((i - 2))]}" || status=$?
    echo "== serial tests, share $i of $shares"
    cat "$logs/share$i.log"
done
rm -rf "$logs"
[ "$status" -eq 0 ] || exit "$status"
echo "== MPI tests on 2 ranks"
mpirun -n 2 --oversubscribe $PY -m pytest -q --color=no --with-mpi -m mpi -p no:cacheprovider "$@" tests
