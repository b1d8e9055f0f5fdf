"""A particle frame's columns are made one at a time as the writer reads them
(pmpm.io.derived.Deferred, pmpm.io.particles_h5.BodyMajor): the derived columns, the
float32 copies and the body-major order are not all held at once beside the state (the
steel ball's peak memory was its frame's: 946 bytes a particle, 777 now, the frames the
same bytes)."""
import numpy as np

from pmpm.io.derived import Deferred, deferred_frame_columns, stress_invariants
from pmpm.io.particles_h5 import by_body


def columns(n=7, seed=3):
    rng = np.random.default_rng(seed)
    return {"x": rng.random((n, 3)), "stress": rng.random((n, 6)),
            "body": np.array([1, 0, 1, 0, 0, 1, 0], np.int32)[:n],
            "id": np.arange(n, dtype=np.int64)}


def test_a_deferred_column_is_computed_only_when_read():
    calls = []
    lazy = Deferred(lambda: calls.append(1) or np.ones((4, 3)), (4, 3), np.float64)
    assert (lazy.shape, lazy.ndim, len(lazy), lazy.dtype) == ((4, 3), 2, 4, np.float64)
    frame = by_body({"a": lazy, "body": np.array([1, 0, 1, 0])}, np.array([1, 0, 1, 0]))
    assert not calls
    assert np.array_equal(frame["a"], np.ones((4, 3))) and len(calls) == 1


def test_columns_read_body_major_and_derived_as_before():
    c = columns()
    frame = by_body(deferred_frame_columns(c), c["body"])
    order = np.argsort(c["body"], kind="stable")
    pressure, von_mises = stress_invariants(c["stress"])
    assert np.array_equal(frame["x"], c["x"][order])
    assert np.array_equal(frame["pressure"], pressure[order])
    assert np.array_equal(frame["von_mises"], von_mises[order])
    assert frame["x"] is not frame["x"]               # a fresh copy each read
    assert list(frame) == ["x", "stress", "body", "id", "pressure", "von_mises"]


def test_float32_frames_cast_each_column_as_it_is_read():
    c = columns()
    frame = deferred_frame_columns(c, "float32")
    assert frame["x"].dtype == np.float32 and frame["id"].dtype == np.int64
    assert np.array_equal(np.asarray(frame["x"]), c["x"].astype(np.float32))
    assert np.array_equal(np.asarray(frame["pressure"]),
                          stress_invariants(c["stress"])[0].astype(np.float32))
