"""The packed sparse exchange (pmpm.comm.sparse, issues 24 and 25): packages of several
dtypes and shapes arrive whole and ordered by source rank, empty packages are not sent
(the receiver gets zero rows of its own package's layout), a rank may send to nobody,
consecutive exchanges of different sizes do not mix, and the traffic is counted as
neighbour messages. pytest-mpi on 2 ranks, and on 3 with --oversubscribe; the packing
and the 1-rank path are also tested serially."""
import numpy as np
import pytest

from pmpm.comm import World
from pmpm.comm.sparse import exchange_arrays, pack, unpack


def comm_world():
    """One World for every test, as a run has one: its count of exchanges picks the
    tags, and a fresh count per test gave the first exchange of a test the tag of the
    test before; a rank done with that one sent into a neighbour still probing it
    (seen on 3 ranks, one run in six)."""
    from mpi4py import MPI
    if not WORLD:
        WORLD.append(World(MPI.COMM_WORLD))
    return WORLD[0]


WORLD = []


def package(source, dest, rows, extra=0):
    """What ``source`` sends ``dest``: arrays of four dtypes and shapes whose values say
    who sent them to whom (``rows`` rows; the last array ``rows + extra`` long)."""
    tag = 1000 * source + dest
    return (np.full((rows, 3), tag + 0.5),
            np.arange(rows, dtype=np.int32) + tag,
            np.full((rows, 2, 2), (source + dest) % 2 == 0),
            np.arange(rows + extra, dtype=np.int64) * tag)


def assert_same(got, expected):
    assert len(got) == len(expected)
    for g, e in zip(got, expected):
        assert g.dtype == e.dtype and g.shape == e.shape
        assert np.array_equal(g, e)


# -- serial ----------------------------------------------------------------------------
def test_packing_keeps_dtypes_shapes_and_values():
    arrays = (np.arange(5.0), np.ones((3, 4, 2), np.int32), np.array([True, False]),
              np.zeros((0, 3)), np.arange(7, dtype=np.uint8), np.arange(6, dtype=">i8"))
    buf = pack(arrays)
    got = unpack(buf)
    for a, g in zip(arrays, got):
        assert g.shape == a.shape and g.dtype == a.dtype.newbyteorder("=")
        assert np.array_equal(a, g) and g.flags.aligned
    assert buf.nbytes % 16 == 0


def test_objects_are_refused():
    with pytest.raises(TypeError, match="dtype object"):
        pack((np.array([None, 1], dtype=object),))


class OneRank:
    """A communicator of one rank that fails on anything but its rank and size."""

    def Get_rank(self):
        return 0

    def Get_size(self):
        return 1


def test_one_rank_returns_its_own_package_without_mpi():
    world = World(OneRank())
    own = package(0, 0, 3)
    got = exchange_arrays(world, [own])
    assert len(got) == 1 and got[0] is own
    assert sum(world.traffic.messages.values()) == 0


# -- MPI -------------------------------------------------------------------------------
@pytest.mark.mpi(min_size=2)
def test_packages_arrive_whole_and_by_source():
    """Rank s sends rank d (s + 2 d) % 3 rows (none on some pairs); the last array has
    one more row than the others."""
    world = comm_world()
    me, n = world.rank, world.size
    rows = [[(s + 2 * d) % 3 for d in range(n)] for s in range(n)]
    sent = [package(me, d, rows[me][d], extra=1 if rows[me][d] else 0) for d in range(n)]
    got = exchange_arrays(world, sent)
    assert got[me] is sent[me]
    for s in range(n):
        if s != me:
            r = rows[s][me]
            assert_same(got[s], package(s, me, r, extra=1 if r else 0))


@pytest.mark.mpi(min_size=2)
def test_a_rank_sending_to_nobody_and_dict_packages():
    """Rank 0 sends nothing (None to every other rank); the others send dicts to every
    rank. Rank 0 gets every other rank's dict; the others get zero rows from rank 0,
    with their own package's keys, dtypes and trailing shapes."""
    world = comm_world()
    me, n = world.rank, world.size

    def as_dict(arrays):
        return {"x": arrays[0], ("holders", 2): arrays[2], "id": arrays[3]}

    sent = [as_dict(package(me, d, 2 + d)) if me != 0 or d == 0 else None
            for d in range(n)]
    got = exchange_arrays(world, sent)
    assert list(got[0]) == ["x", ("holders", 2), "id"]
    for s in range(n):
        if s == me:
            assert got[s] is sent[s]
        elif s == 0:
            expected = {k: a[:0] for k, a in sent[me].items()}
            assert_same(list(got[s].values()), list(expected.values()))
        else:
            expected = as_dict(package(s, me, 2 + me))
            assert list(got[s]) == list(expected)
            assert_same(list(got[s].values()), list(expected.values()))


@pytest.mark.mpi(min_size=2)
def test_consecutive_exchanges_of_different_sizes_do_not_mix():
    """Sixty exchanges in a row, the sizes drawn anew each time (some empty, some of
    thousands of rows); each array carries the exchange's number. A rank that is
    done with one exchange goes on to the next while others still receive."""
    world = comm_world()
    me, n = world.rank, world.size
    for k in range(60):
        rng = np.random.default_rng(k)          # the same draws on every rank
        rows = rng.integers(0, 4, size=(n, n)) * rng.integers(0, 1500, size=(n, n))
        sent = [package(me, d, int(rows[me, d])) + (np.full(int(rows[me, d]), k),)
                for d in range(n)]
        got = exchange_arrays(world, sent)
        for s in range(n):
            r = int(rows[s, me])
            assert_same(got[s], package(s, me, r) + (np.full(r, k),))


@pytest.mark.mpi(min_size=2)
def test_traffic_is_counted_as_neighbour_messages():
    """One message per rank that gets a non-empty package, of the packed buffer's bytes,
    and one collective (the barrier); nothing counted as all-to-all."""
    world = comm_world()
    me, n = world.rank, world.size
    sent = [package(me, d, 3 * d + me) if d % 2 == 0 else None for d in range(n)]
    if sent[me] is None:
        sent[me] = package(me, me, 0)
    world.traffic.reset()
    exchange_arrays(world, sent)
    going = [d for d in range(n) if d != me and sent[d] is not None and 3 * d + me > 0]
    assert world.traffic.messages["neighbour"] == len(going)
    assert world.traffic.bytes["neighbour"] == sum(pack(sent[d]).nbytes for d in going)
    assert world.traffic.messages["collective"] == 1
    assert world.traffic.messages["alltoall"] == world.traffic.bytes["alltoall"] == 0


@pytest.mark.mpi(min_size=2)
def test_replies_go_to_the_askers_without_a_barrier():
    """Forty questions and answers in a row, the askers drawn anew each time (some
    rounds nobody asks): each rank answers exactly the ranks that asked it, with the
    question's rows doubled, and gets back the answers of the ranks it asked; no
    collective is counted for the answers, and no message where nobody asked."""
    from pmpm.comm.sparse import exchange_known, sent_to, senders
    world = comm_world()
    me, n = world.rank, world.size
    for k in range(40):
        rng = np.random.default_rng(k)
        rows = rng.integers(0, 3, size=(n, n)) * rng.integers(0, 300, size=(n, n))
        questions = [(np.full(int(rows[me, d]), 1000 * k + me, np.int64),
                      np.arange(int(rows[me, d]), dtype=np.float64)) for d in range(n)]
        asks = exchange_arrays(world, questions)
        askers = senders(asks, me)
        assert askers == [s for s in range(n) if s != me and rows[s, me] > 0]
        assert sent_to(questions, me) == [d for d in range(n) if d != me and rows[me, d] > 0]
        world.traffic.reset()
        back = exchange_known(world, [(a[0], 2.0 * a[1]) for a in asks], askers,
                            sent_to(questions, me))
        assert world.traffic.messages["collective"] == 0
        assert world.traffic.messages["neighbour"] == len(askers)
        for d in range(n):
            if d == me:
                continue
            r = int(rows[me, d])
            assert_same(back[d], (np.full(r, 1000 * k + me, np.int64),
                                  2.0 * np.arange(r, dtype=np.float64)))


@pytest.mark.mpi(min_size=2)
def test_swap_arrays_gives_each_partner_its_own_share():
    """Every rank swaps with every other: each gets the package addressed to it."""
    from pmpm.comm.shared_nodes import swap_arrays
    world = comm_world()
    me, n = world.rank, world.size
    got = swap_arrays(world, {d: package(me, d, 1 + d + me) for d in range(n) if d != me})
    assert sorted(got) == [s for s in range(n) if s != me]
    for s, arrays in got.items():
        assert_same(arrays, package(s, me, 1 + s + me))
