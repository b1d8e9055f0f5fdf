"""Bodies: their materials packed for the kernels, and their initial particles."""
import numpy as np

from ..materials import catalog, layout
from ..particles import COLUMNS, Particles
from ..particles.store import IDENTITY9, empty_column


class BodyTable:
    """Per-body arrays the kernels index by ``particles.body``."""

    def __init__(self, case):
        bodies = case["bodies"]
        self.names = [b["name"] for b in bodies]
        self.codes = np.zeros(len(bodies), np.int64)
        self.params = np.zeros((len(bodies), layout.N_SLOTS))
        for i, body in enumerate(bodies):
            self.codes[i], self.params[i] = catalog.pack(case["materials"][body["material"]])
        self.rigid = (self.codes == layout.RIGID)

    def initial_wave_speed(self, body_index):
        """sqrt((K + 4G/3)/rho0), or the EOS sound speed where larger (or the only one)."""
        prm = self.params[body_index]
        speed = 0.0
        if prm[layout.K] > 0 and np.isfinite(prm[layout.K]):
            speed = np.sqrt((prm[layout.K] + 4 * prm[layout.G] / 3) / prm[layout.RHO0])
        return max(speed, prm[layout.EOS_C0])


def fill_particles(case, table, fill_body, case_dir, grid_case):
    """All particles of all bodies, identical on every rank (ids = fill order)."""
    parts = [_body_particles(i, body, case, table, fill_body, case_dir, grid_case)
             for i, body in enumerate(case["bodies"])]
    columns = {name: np.concatenate([p[name] for p in parts]) for name in COLUMNS}
    columns["id"] = np.arange(len(columns["mass"]), dtype=np.int64)
    return Particles(columns)


def _body_particles(index, body, case, table, fill_body, case_dir, grid_case):
    positions, volumes = fill_body(body, grid_case, case_dir)
    n = len(volumes)
    cols = {name: empty_column(name, n) for name in COLUMNS}
    prm = table.params[index]
    cols["x"][:] = positions
    cols["v"][:] = np.asarray(body.get("velocity", [0, 0, 0]), dtype=np.float64)
    cols["vol0"][:] = volumes
    cols["rho"][:] = prm[layout.RHO0]
    cols["mass"][:] = prm[layout.RHO0] * volumes
    cols["F"][:] = IDENTITY9
    cols["temp"][:] = prm[layout.T_ROOM]
    cols["body"][:] = index
    cols["load"][:] = -1
    return cols


def assign_loads(case, particles, count_global):
    """Mark the particles each load acts on; returns problems (key paths) for loads that
    select nothing. ``count_global`` sums a count over ranks."""
    problems = []
    names = [b["name"] for b in case["bodies"]]
    for i, load in enumerate(case.get("loads", [])):
        selected = _in_region(particles, names.index(load["body"]), load["region"])
        n_global = count_global(int(selected.sum()))
        if n_global == 0:
            problems.append(f"loads[{i}].region: selects no particle of body '{load['body']}'")
            continue
        particles.load[selected] = i
        if load["type"] == "traction":
            particles.load_scale[selected] = particles.vol0[selected] ** (2.0 / 3.0)
        else:
            particles.load_scale[selected] = 1.0 / n_global
    return problems


def _in_region(particles, body_index, region):
    lo, hi = np.asarray(region["min"]), np.asarray(region["max"])
    inside = np.all((particles.x >= lo) & (particles.x <= hi), axis=1)
    return inside & (particles.body == body_index)
