"""The allocator setting (pmpm.solver.memory): glibc's mmap threshold held at 128 KiB
for particles (freed columns go back to the system), raised with the FE nodes a rank
holds (a step's node temporaries stay in the heap instead of being page-faulted in
afresh), never past glibc's own ceiling."""
import numpy as np
import pytest

from pmpm.solver import memory


def test_the_threshold_follows_the_fe_nodes_between_its_bounds():
    assert memory.threshold_for_fe_nodes(0) == memory.MMAP_THRESHOLD
    assert memory.threshold_for_fe_nodes(1000) == memory.MMAP_THRESHOLD   # 96 kB < 128 kB
    assert memory.threshold_for_fe_nodes(44_000) == 4 * 24 * 44_000      # 4.2 MB
    assert memory.threshold_for_fe_nodes(10**7) == memory.LARGEST_THRESHOLD


@pytest.mark.skipif(not memory.return_freed_memory_to_os(), reason="not glibc")
def test_a_raised_threshold_keeps_a_freed_node_vector_in_the_process():
    resource = pytest.importorskip("resource")
    faults = lambda: resource.getrusage(resource.RUSAGE_SELF).ru_minflt
    v = np.ones((44_000, 3))

    def copies():
        before = faults()
        for _ in range(20):
            w = v.copy()
            del w
        return faults() - before

    try:
        held = copies()                  # 128 KiB: each copy a fresh mapping
        memory.return_freed_memory_to_os(memory.threshold_for_fe_nodes(44_000))
        raised = copies()
    finally:
        memory.return_freed_memory_to_os()
    assert held > 20 * 200               # about 258 pages a copy
    assert raised < held / 10
