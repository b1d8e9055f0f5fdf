"""The allocator setting (pmpm.solver.memory): glibc's mmap threshold held at 128 KiB
for particles (freed columns go back to the system), raised with the FE nodes a rank
holds (a step's node temporaries stay in the heap instead of being page-faulted in
afresh), never past glibc's own ceiling."""
import pytest

from pmpm.solver import memory


def test_the_threshold_follows_the_fe_nodes_between_its_bounds():
    assert memory.threshold_for_fe_nodes(0) == memory.MMAP_THRESHOLD
    assert memory.threshold_for_fe_nodes(1000) == memory.MMAP_THRESHOLD   # 96 kB < 128 kB
    assert memory.threshold_for_fe_nodes(44_000) == 4 * 24 * 44_000      # 4.2 MB
    assert memory.threshold_for_fe_nodes(10**7) == memory.LARGEST_THRESHOLD


PROBE = """
import resource, sys
import numpy as np
from pmpm.solver import memory
faults = lambda: resource.getrusage(resource.RUSAGE_SELF).ru_minflt
def copies(v):
    before = faults()
    for _ in range(20):
        w = v.copy()
        del w
    return faults() - before
v = np.ones((44_000, 3))
if not memory.return_freed_memory_to_os():
    print("not glibc"); sys.exit(0)
held = copies(v)
memory.return_freed_memory_to_os(memory.threshold_for_fe_nodes(44_000))
print(held, copies(v))
"""


def test_a_raised_threshold_keeps_a_freed_node_vector_in_the_process():
    """In a fresh process (a long one may serve the copies from free heap space
    whatever the threshold): at 128 KiB each 1 MB copy is a fresh mapping, page-faulted
    in; at the FE nodes' threshold the freed copy is reused."""
    import subprocess
    import sys
    done = subprocess.run([sys.executable, "-c", PROBE], capture_output=True, text=True,
                          check=True)
    if done.stdout.startswith("not glibc"):
        pytest.skip("not glibc")
    held, raised = (int(n) for n in done.stdout.split())
    assert held > 20 * 200               # about 258 pages a copy
    assert raised < held / 10
