"""The column store (serial): the particle table, the material group, take / append /
replace, sizes, and an element-like store with its own columns sharing the group."""
import numpy as np
import pytest

from pmpm.materials.state import MATERIAL_COLUMNS, MaterialState
from pmpm.particles import COLUMNS, MATERIAL_GROUP, ColumnStore, Particles, column_table
from pmpm.particles.store import IDENTITY9, empty_column

OLD_ORDER = ["x", "v", "mass", "rho", "vol0", "stress", "F", "eps_p", "e_int", "temp", "q",
             "load_scale", "id", "body", "load", "refine", "affine", "x0", "damage", "w_p"]


class Elements(ColumnStore):
    COLUMNS = column_table([("nodes", np.int64, 8), ("volume", np.float64, 1)],
                           groups=[MATERIAL_GROUP])


def numbered(n, cls=Particles):
    """A store whose every value encodes its row, so reorderings show in every column."""
    store = cls.empty(n)
    for name, column in store.columns().items():
        width = column[0].size if n else 1
        values = np.arange(n)[:, None] * 100 + np.arange(width)
        store.replace_column(name, values.reshape(column.shape))
    return store


def test_particle_columns_keep_their_order_and_types():
    assert list(COLUMNS) == OLD_ORDER
    assert COLUMNS["stress"] == (np.float64, 6) and COLUMNS["F"] == (np.float64, 9)
    assert COLUMNS["id"] == (np.int64, 1) and COLUMNS["refine"] == (np.int32, 1)
    assert COLUMNS["affine"] == (np.float64, 9)
    assert list(Particles.empty(3).columns()) == OLD_ORDER
    assert tuple(MATERIAL_GROUP) == MATERIAL_COLUMNS


def test_empty_store_and_columns():
    p = Particles.empty(4)
    assert p.n == 4 and p.x.shape == (4, 3) and p.mass.shape == (4,)
    assert p.id.dtype == np.int64 and p.body.dtype == np.int32
    assert empty_column("F", 2).shape == (2, 9)
    assert IDENTITY9.reshape(3, 3).tolist() == np.eye(3).tolist()
    assert Particles.empty().n == 0


def test_material_is_a_record_of_the_current_columns():
    p = numbered(5)
    m = p.material
    assert isinstance(m, MaterialState) and m._fields == MATERIAL_COLUMNS
    assert all(getattr(m, name) is getattr(p, name) for name in MATERIAL_COLUMNS)
    p.take([4, 0])
    assert p.material.rho is p.rho and p.material.rho.tolist() == [400, 0]


def test_take_with_mask_integers_and_negative_indices():
    p = numbered(6)
    p.take(np.array([True, False, True, True, False, True]))
    assert p.id.tolist() == [0, 200, 300, 500]
    assert p.stress[1].tolist() == list(200.0 + np.arange(6))
    p.take(np.array([-1, 0]))
    assert p.id.tolist() == [500, 0] and p.x[0].tolist() == [500, 501, 502]
    assert all(c.flags.c_contiguous for c in p.columns().values())
    with pytest.raises(IndexError):
        p.take([2])
    with pytest.raises(IndexError):
        p.take(np.array([True]))


def test_take_between_rows():
    p, other = numbered(5), numbered(4)
    rows = other.rows(np.array([3, 1, 2]))
    assert rows.dtype == Particles.row_dtype() and rows["id"].tolist() == [300, 100, 200]
    p.take(np.array([True, False, False, True, False]), before=rows[:1], after=rows[1:])
    assert p.id.tolist() == [300, 0, 300, 100, 200]
    assert p.F[:, 4].tolist() == [304, 4, 304, 104, 204]
    assert p.body.dtype == np.int32 and p.n == 5


def test_append_and_replace_column():
    p = numbered(2)
    p.append(numbered(3).columns())
    assert p.id.tolist() == [0, 100, 0, 100, 200] and p.x.shape == (5, 3)
    p.replace_column("mass", [1, 2, 3, 4, 5])
    assert p.mass.dtype == np.float64 and p.mass.tolist() == [1, 2, 3, 4, 5]


def test_sizes():
    per = 8 * (3 + 3 + 1 + 1 + 1 + 6 + 9 + 1 + 1 + 1 + 1 + 1 + 9 + 3 + 2) + 8 + 3 * 4  # x0; damage, w_p
    assert Particles.bytes_per_particle() == per == Particles.bytes_per_row()
    assert Particles.empty(7).nbytes() == 7 * per
    assert Particles.row_dtype().itemsize >= per


def test_old_checkpoints_without_refine_load_as_coarse():
    columns = Particles.empty(3).columns()
    del columns["refine"]
    assert Particles(columns).refine.tolist() == [1, 1, 1]
    del columns["x"]
    with pytest.raises(ValueError, match="x"):
        Particles(columns)


def test_an_element_store_shares_the_material_group():
    e = numbered(3, Elements)
    assert list(Elements.COLUMNS) == ["nodes", "volume"] + list(MATERIAL_COLUMNS)
    assert e.nodes.shape == (3, 8) and e.material.F.shape == (3, 9)
    e.take([2, 1])
    assert e.material.stress[:, 0].tolist() == [200, 100] and e.nodes[0, 7] == 207
    assert Elements.bytes_per_row() == 8 * 8 + 8 + 8 * (6 + 9 + 7)


def test_column_tables_are_checked():
    with pytest.raises(ValueError):
        column_table(["rho"])                               # not in any group
    with pytest.raises(ValueError):
        column_table([("rho", np.float64, 1)], groups=[MATERIAL_GROUP])
    with pytest.raises(ValueError):
        column_table([("a", np.float64, 1), ("a", np.float64, 1)])
    with pytest.raises(TypeError):
        type("Bad", (ColumnStore,), {"COLUMNS": {"n": (np.float64, 1)}})


def spliced_copy(columns, keep, before=None, after=None):
    """What take(keep, before, after) must give, column by column, from plain copies."""
    out = {}
    for name, column in columns.items():
        parts = [] if before is None else [np.asarray(before[name])]
        parts.append(column[keep])
        parts += [] if after is None else [np.asarray(after[name])]
        out[name] = np.concatenate(parts).astype(column.dtype)
    return out


def assert_same_rows(store, expected):
    for name, column in store.columns().items():
        assert column.flags.c_contiguous, name
        np.testing.assert_array_equal(column, expected[name], err_msg=name)


def test_migration_steps_move_rows_in_place_and_keep_the_order():
    """Rows leaving near either end and in the middle, arrivals before and after, appends
    and a sort in between: every column as a fresh copy would have it, and, once the
    store has its spare rows, the steps that keep rows in order reuse the buffers."""
    rng = np.random.default_rng(4)
    p, source = numbered(400), numbered(300)
    source.replace_column("id", source.id + 10_000)
    for step in range(30):
        n = p.n
        keep = np.ones(n, bool)
        keep[rng.choice(np.r_[0:8, n - 8:n], 3, replace=False)] = False
        if step % 5 == 4:
            keep[rng.integers(0, n)] = False                      # one from the middle
        arrivals = source.rows(rng.integers(0, source.n, rng.integers(0, 6)))
        lower = rng.integers(0, len(arrivals) + 1)
        expected = spliced_copy({k: v.copy() for k, v in p.columns().items()}, keep,
                                arrivals[:lower], arrivals[lower:])
        x_before = p.x
        p.take(keep, before=arrivals[:lower], after=arrivals[lower:])
        assert_same_rows(p, expected)
        if step > 0:
            assert np.shares_memory(p.x, x_before) and p.x is not x_before
        if step == 12:
            extra = numbered(5).columns()
            expected = spliced_copy(p.columns(), np.arange(p.n), after=extra)
            p.append(extra)
            assert_same_rows(p, expected)
        if step == 20:                                    # a sort: a fresh copy
            order = np.argsort(-p.id, kind="stable")
            expected = spliced_copy(p.columns(), order)
            x_before = p.x
            p.take(order)
            assert_same_rows(p, expected)
            assert not np.shares_memory(p.x, x_before)


def test_a_replaced_column_is_never_written_in_place():
    """A column set from outside (replace_column keeps the caller's array where it has
    the right type) is copied, not overwritten, by the next take."""
    p = numbered(200)
    p.take(np.arange(1, 200))                                    # now in spare-row buffers
    mine = np.arange(p.n, dtype=np.float64)
    p.replace_column("mass", mine)
    p.take(np.r_[1:p.n], after=numbered(2).columns())
    assert mine.tolist() == list(range(199)) and p.mass.tolist() == list(range(1, 199)) + [0, 100]
    assert p.id.tolist() == [100 * i for i in range(2, 200)] + [0, 100]


def test_arrivals_that_are_views_of_the_store_itself():
    p = numbered(100)
    p.take(np.arange(100))
    own = {name: column[:3] for name, column in p.columns().items()}
    expected = spliced_copy(p.columns(), np.arange(3, 100), own, own)
    p.take(np.arange(3, 100), before=own, after=own)
    assert_same_rows(p, expected)


def test_spare_rows_do_not_outgrow_the_store():
    """A store that loses most of its rows (a rebalance) gets buffers of its new size."""
    from pmpm.particles.columns import spare_rows
    p = numbered(5000)
    p.take(np.arange(5000))
    p.take(np.arange(4000, 5000))
    assert p._buffers.capacity <= p.n + 4 * spare_rows(p.n)
    assert p.id.tolist() == [100 * i for i in range(4000, 5000)]
