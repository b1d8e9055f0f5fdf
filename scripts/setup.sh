#!/usr/bin/env bash
# Install everything pmpm needs on a fresh Debian machine (run as root), idempotently.
#   Debian: Open MPI and HDF5 built against it.
#   .venv/ in the repo root: numpy, numba, mpi4py, meshio, pyyaml, pytest, pytest-mpi,
#   h5py built from source against the parallel HDF5 (h5py.get_config().mpi is True),
#   at the versions in constraints.txt.
# Usage: scripts/setup.sh            install only
#        scripts/setup.sh --example  install, then run runs/taylor_bar.yaml on 2 ranks
set -euo pipefail
cd "$(dirname "$0")/.."

DEBS=(openmpi-bin libopenmpi-dev libhdf5-openmpi-dev pkg-config)
missing=()
for deb in "${DEBS[@]}"; do
    dpkg-query -W -f='${Status}' "$deb" 2>/dev/null | grep -q "ok installed" || missing+=("$deb")
done
if [ ${#missing[@]} -gt 0 ]; then
    echo "setup: installing Debian packages: ${missing[*]}"
    apt-get update -q
    DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends "${missing[@]}"
fi

if [ ! -x .venv/bin/python ]; then
    echo "setup: creating .venv"
    python3 -m venv .venv
fi
PY=.venv/bin/python
$PY -m pip install -q --upgrade pip "setuptools>=77" wheel
$PY -m pip install -q -c constraints.txt numpy numba mpi4py meshio pyyaml pytest pytest-mpi matplotlib

# pmpm's kernels for the hats and the default shape functions compile into Numba's cache
# (a few minutes the first time, a second after) on one core while h5py builds on another
NUMBA_NUM_THREADS=1 $PY -c "from pmpm.kernels.warmup import warm_up_defaults as w; w()" &
compiling=$!

if ! $PY -c "import h5py, sys; sys.exit(0 if h5py.get_config().mpi else 1)" 2>/dev/null; then
    echo "setup: building h5py against parallel HDF5 (about 5 minutes the first time; pip caches the wheel)"
    $PY -m pip uninstall -q -y h5py 2>/dev/null || true
    $PY -m pip install -q "Cython>=3" pkgconfig
    CC=mpicc HDF5_MPI=ON HDF5_PKGCONFIG_NAME=hdf5-openmpi \
        $PY -m pip install -c constraints.txt --no-binary=h5py --no-build-isolation h5py
fi
$PY -c "import h5py; assert h5py.get_config().mpi, 'h5py is not built with MPI'"
$PY -m pip install -q --no-deps -e .
# Byte-compile pmpm: where PYTHONDONTWRITEBYTECODE is set no run writes .pyc files, and
# each would compile the package's sources again (0.3 s of CPU per start).
$PY -m compileall -q pmpm > /dev/null || echo "setup: byte-compiling pmpm failed; runs compile its sources"
wait "$compiling" || echo "setup: compiling the kernels ahead failed; they compile on first use"
echo "setup: environment ready in .venv"

if [ "${1:-}" = "--example" ]; then
    export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
    out=results/taylor_bar
    echo "setup: running runs/taylor_bar.yaml on 2 ranks into $out"
    mpirun -n 2 --oversubscribe .venv/bin/python -m pmpm runs/taylor_bar.yaml --out "$out" --force
    echo "setup: done. Results in $out (summary.json, history.csv, particles.h5, particles.xdmf for ParaView)"
fi
