"""The segments a contact searches, kept from step to step
(pmpm.solver.surface_contact.SegmentRows): own rows gathered in place, halo rows after
them, holder lists padded with -1, and nothing of this step's own rows lost when the
arrays grow."""
import numpy as np

from pmpm.solver.surface_contact import SegmentRows


def fixed_fields(n, width, first_gid):
    gid = np.arange(first_gid, first_gid + 4 * n, dtype=np.int64).reshape(n, 4)
    return {"gid": gid, "inv_m": np.full((n, 4), 0.5), "body": np.ones(n, np.int64),
            "key": gid[:, 0] * 6, "holders": np.zeros((n, 4, width), np.int64)}


def halo(n, width, first_gid):
    out = fixed_fields(n, width, first_gid)
    out["holders"][:] = 1
    out.update({k: np.full((n, 4, 3), float(first_gid)) for k in ("x", "x0", "v")})
    return out


def joined_by_hand(own, halos):
    width = max(part["holders"].shape[2] for part in [own] + halos)
    out = {}
    for k in own:
        parts = []
        for part in [own] + halos:
            column = part[k]
            if k == "holders":
                padded = np.full(column.shape[:2] + (width,), -1, np.int64)
                padded[:, :, :column.shape[2]] = column
                column = padded
            parts.append(column)
        out[k] = np.concatenate(parts)
    return out


def test_the_joined_rows_are_the_own_rows_then_the_halos():
    rng = np.random.default_rng(3)
    nodes_x, nodes_v = rng.random((40, 3)), rng.random((40, 3))
    start_x = nodes_x - 0.01
    rows = SegmentRows()
    fixed = fixed_fields(5, 1, 0)
    faces = rng.integers(0, 40, (5, 4))
    for step, halo_rows in enumerate((0, 3, 120, 2)):     # the third one grows the arrays
        nodes_x += 0.1
        own = rows.own(fixed, nodes_x, start_x, nodes_v, faces)
        np.testing.assert_array_equal(own["x"], nodes_x[faces])
        np.testing.assert_array_equal(own["x0"], start_x[faces])
        own_copy = {k: np.array(c) for k, c in own.items()}
        halos = [halo(halo_rows, 2, 1000)] if halo_rows else []
        got = rows.joined(halos + [halo(0, 1, 0)])
        expected = joined_by_hand(own_copy, halos)
        for k, column in expected.items():
            np.testing.assert_array_equal(got[k][..., :column.shape[-1]]
                                          if k == "holders" else got[k], column, err_msg=k)
            if k == "holders":                  # wider than needed: padding only
                assert (got[k][..., column.shape[-1]:] == -1).all()


def test_new_faces_replace_the_fixed_rows():
    rows = SegmentRows()
    x = np.arange(30.0).reshape(10, 3)
    rows.own(fixed_fields(2, 1, 0), x, x, x, np.zeros((2, 4), np.int64))
    refreshed = fixed_fields(3, 1, 500)
    got = rows.own(refreshed, x, x, x, np.ones((3, 4), np.int64))
    np.testing.assert_array_equal(got["gid"], refreshed["gid"])
    np.testing.assert_array_equal(got["x"], np.broadcast_to(x[1], (3, 4, 3)))


def test_a_refresh_with_more_faces_than_room_keeps_nothing_stale():
    """Conversion frees faces: a refresh may bring more own faces than the arrays hold
    (the growth then has no own rows of this step to keep)."""
    rows = SegmentRows()
    x = np.arange(30.0).reshape(10, 3)
    rows.own(fixed_fields(2, 1, 0), x, x, x, np.zeros((2, 4), np.int64))
    rows.joined([halo(0, 1, 0)])
    refreshed = fixed_fields(300, 2, 500)
    got = rows.own(refreshed, x, x, x, np.full((300, 4), 2, np.int64))
    np.testing.assert_array_equal(got["gid"], refreshed["gid"])
    np.testing.assert_array_equal(got["holders"][..., :2], refreshed["holders"])
    np.testing.assert_array_equal(got["x"], np.broadcast_to(x[2], (300, 4, 3)))
    joined = rows.joined([halo(5, 1, 9000)])
    np.testing.assert_array_equal(joined["gid"][:300], refreshed["gid"])
    assert (joined["holders"][300:, :, 1:] == -1).all()
