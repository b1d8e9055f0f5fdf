"""``grid.windows``: locally refined sub-grids tied to the coarse grid (seed 000 Sec. 3).

    grid:
      min: [0, 0, 0]
      max: [100, 6, 6]
      cell: 1.0
      windows:
        - min: [60, 0, 0]     # mm, on coarse grid lines
          max: [100, 6, 6]
          ratio: 4            # cells of cell / ratio inside (integer >= 1)
          follow: rod         # optional: the window moves with this body's centroid

A window's bounds lie on coarse grid lines inside the grid box; windows neither overlap
nor touch (a tied interface needs coarse cells on its far side). Particles inside a
window are filled at the window's spacing, ``cell / ratio / particles_per_cell``.
"""
from .errors import join, unknown_name
from .fields import INVALID, OMIT, Field, at_least, integer, text, valid, vector

WINDOW = {
    "min": Field(vector(), unit="mm",
                 doc="lower corner, on coarse grid lines (grid.min + whole multiples of "
                     "grid.cell), inside the grid box"),
    "max": Field(vector(), unit="mm", doc="upper corner, on coarse grid lines"),
    "ratio": Field(integer(at_least(1)), unit="1",
                   doc="R: the window's cell is grid.cell / R (1: the coarse grid itself, "
                       "accepted so that a parameter can switch refinement off)"),
    "follow": Field(text(), OMIT,
                    doc="a body's name: the window moves with that body's mass centroid, "
                        "in whole coarse cells, staying inside the grid box (Sec. 3.3)"),
}
ON_LINE_TOL = 1e-6          # in cells


def check_windows(grid, path, problems):
    """Bounds on coarse grid lines, min < max, inside the box, no two windows overlapping
    or touching."""
    windows = grid.get("windows", [])
    if windows is INVALID or not valid(grid, "min", "max", "cell"):
        return
    placed = []
    for i, window in enumerate(windows):
        if valid(window, "min", "max"):
            cells = _check_bounds(window, grid, join(join(path, "windows"), i), problems)
            if cells:
                placed.append((i, cells))
            else:
                window["min"] = INVALID
    for a, (i, (lo1, hi1)) in enumerate(placed):
        for j, (lo2, hi2) in placed[a + 1:]:
            if all(lo1[d] <= hi2[d] and lo2[d] <= hi1[d] for d in range(3)):
                problems.add(join(join(path, "windows"), j),
                             f"overlaps or touches {path}.windows[{i}]; leave at least one "
                             f"coarse cell between windows")


def _check_bounds(window, grid, path, problems):
    """(lo, hi) coarse cell indices of the window (hi exclusive), or None after a problem."""
    cell, origin, n_cells = grid["cell"], grid["min"], _cells(grid)
    lo, hi = [], []
    for key, out in (("min", lo), ("max", hi)):
        for d in range(3):
            s = (window[key][d] - origin[d]) / cell
            if abs(s - round(s)) > ON_LINE_TOL:
                problems.add(join(join(path, key), d),
                             f"{window[key][d]:g} is not on a coarse grid line (grid.min "
                             f"{origin[d]:g} + whole multiples of grid.cell {cell:g})")
                return None
            out.append(int(round(s)))
    for d in range(3):
        if lo[d] >= hi[d]:
            problems.add(path, f"min must be < max in every direction ({'xyz'[d]}: "
                         f"{window['min'][d]:g} >= {window['max'][d]:g})")
            return None
        if lo[d] < 0 or hi[d] > n_cells[d]:
            problems.add(path, f"outside the grid box along {'xyz'[d]} ({window['min'][d]:g} "
                         f"to {window['max'][d]:g}, grid {origin[d]:g} to {grid['max'][d]:g})")
            return None
    return lo, hi


def _cells(grid):
    return [int(round((b - a) / grid["cell"])) for a, b in zip(grid["min"], grid["max"])]


def check_window_bodies(grid, body_names, problems):
    """``follow`` names a known body."""
    windows = grid.get("windows", []) if isinstance(grid, dict) else []
    if windows is INVALID:
        return
    for i, window in enumerate(windows):
        if valid(window, "follow") and window["follow"] not in body_names:
            problems.add(f"grid.windows[{i}].follow",
                         unknown_name("body", window["follow"], body_names))
