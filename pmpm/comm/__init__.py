"""Everything MPI: the communicator wrapper, slab decomposition, shared-plane sums,
particle migration and sparse exchanges of packed arrays. The only package in pmpm that
imports mpi4py (lazily, on first use, so ``import pmpm`` stays cheap)."""
from .world import World, world
from .slabs import Slabs
from .exchange import sum_shared_planes, migrate_store
from .sparse import exchange_arrays

__all__ = ["World", "world", "Slabs", "sum_shared_planes", "migrate_store",
           "exchange_arrays"]
