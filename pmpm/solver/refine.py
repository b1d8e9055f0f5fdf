"""The refined windows at the end of a step (seed 000 Secs. 3.3-3.4): windows that follow
a body move with its centroid in whole coarse cells, and coarse particles that are now
inside a window are split to the window's spacing."""
import numpy as np


class Refiner:
    """Moves the windows and splits the particles entering them.

    Parameters
    ----------
    world : comm.World
    grid : grid.CoarseGrid
    windows : list of grid.Window   (moved in place)
    kinds : list of body kinds   (their points' levels and centroids; particle kinds split)
    id_base : int   above every particle id at the start of the run; split particles get
        ids from their parent's (``pmpm.particles.split``)
    layer_axis : int or None   with layer-ordered sums (``grid.exact_sums``) the slab
        axis: a followed body's centroid is then summed by cell layers along it, in
        layer order, the same bits on any rank count
    """

    def __init__(self, world, grid, windows, kinds, id_base, layer_axis=None):
        self.world, self.grid, self.windows, self.kinds = world, grid, windows, kinds
        self.layer_axis = layer_axis
        self.id_base = int(id_base)
        ratios = [w.ratio for w in windows]
        self.id_stride = max(ratios + [1]) ** 3
        self.ratios = np.array([1] + ratios, np.int64)
        self.followers = [w for w in windows if w.follow >= 0]
        self.centroids = self.followed_centroids()

    def followed_centroids(self):
        """Mass centroid of each followed body, (n_followers, 3), over all ranks (one SUM
        reduction; none when no window follows a body)."""
        if not self.followers:
            return np.zeros((0, 3))
        if self.layer_axis is not None:
            return self.centroids_by_layer()
        local = np.zeros((len(self.followers), 4))
        for i, window in enumerate(self.followers):
            for kind in self.kinds:
                moment, mass = kind.mass_moments(window.follow)
                local[i, :3] += moment
                local[i, 3] += mass
        total = self.world.sum(local)
        mass = np.where(total[:, 3] > 0, total[:, 3], 1.0)
        return total[:, :3] / mass[:, None]

    def centroids_by_layer(self):
        """The followed centroids from each body's per-layer moments (one SUM
        reduction: each layer's row comes from one rank), folded in layer order."""
        rows = np.stack([sum(kind.layer_moments(w.follow, self.grid, self.layer_axis)
                             for kind in self.kinds) for w in self.followers])
        rows = self.world.sum(rows)
        total = np.zeros((len(self.followers), 4))
        for layer in range(rows.shape[1]):
            total += rows[:, layer]
        mass = np.where(total[:, 3] > 0, total[:, 3], 1.0)
        return total[:, :3] / mass[:, None]

    def move_windows_and_split(self):
        if not self.windows:
            return
        if self.followers:
            now = self.followed_centroids()
            for window, before, after in zip(self.followers, self.centroids, now):
                window.move(after - before, self.grid.h, self.grid.n_cells)
            self.centroids = now
        for kind in self.kinds:
            kind.assign_levels(self.grid, self.windows)
            kind.split_entering(self.ratios, self.id_base, self.id_stride)

    def state(self):
        return {"windows": [w.state() for w in self.windows],
                "centroids": self.centroids.tolist(), "id_base": self.id_base}

    def restore(self, state):
        for window, saved in zip(self.windows, state["windows"]):
            window.restore(saved)
        self.centroids = np.asarray(state["centroids"], np.float64).reshape(-1, 3)
        self.id_base = int(state["id_base"])
