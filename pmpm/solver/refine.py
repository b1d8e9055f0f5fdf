"""The refined windows at the end of a step (seed 000 Secs. 3.3-3.4): windows that follow
a body move with its centroid in whole coarse cells, and coarse particles that are now
inside a window are split to the window's spacing."""
import numpy as np

from ..particles.split import split


class Refiner:
    """Moves the windows of a :class:`Stepper` and splits the particles entering them.

    ``id_base`` is above every particle id at the start of the run; split particles get
    ids from their parent's (``pmpm.particles.split``).
    """

    def __init__(self, stepper, id_base):
        self.stepper = stepper
        self.id_base = int(id_base)
        ratios = [w.ratio for w in stepper.windows]
        self.id_stride = max(ratios + [1]) ** 3
        self.ratios = np.array([1] + ratios, np.int64)
        self.followers = [w for w in stepper.windows if w.follow >= 0]
        self.centroids = self.followed_centroids()

    def followed_centroids(self):
        """Mass centroid of each followed body, (n_followers, 3), over all ranks (one SUM
        reduction; none when no window follows a body)."""
        if not self.followers:
            return np.zeros((0, 3))
        p = self.stepper.particles
        local = np.zeros((len(self.followers), 4))
        for i, window in enumerate(self.followers):
            mine = p.body == window.follow
            local[i, :3] = p.mass[mine] @ p.x[mine]
            local[i, 3] = p.mass[mine].sum()
        total = self.stepper.world.sum(local)
        mass = np.where(total[:, 3] > 0, total[:, 3], 1.0)
        return total[:, :3] / mass[:, None]

    def move_windows_and_split(self):
        if not self.stepper.windows:
            return
        if self.followers:
            grid = self.stepper.grid
            now = self.followed_centroids()
            for window, before, after in zip(self.followers, self.centroids, now):
                window.move(after - before, grid.h, grid.n_cells)
            self.centroids = now
        self.split_entering()

    def split_entering(self):
        """Split every particle whose spacing is coarser than the window it is in: a
        particle of ``refine`` r in a window of ratio R becomes (R // r)^3 particles."""
        st = self.stepper
        level_of = st.assign_levels()
        p = st.particles
        factors = self.ratios[level_of] // p.refine
        parents = np.flatnonzero(factors >= 2)
        if len(parents):
            split(p, parents, factors[parents], self.id_base, self.id_stride)

    def state(self):
        return {"windows": [w.state() for w in self.stepper.windows],
                "centroids": self.centroids.tolist(), "id_base": self.id_base}

    def restore(self, state):
        for window, saved in zip(self.stepper.windows, state["windows"]):
            window.restore(saved)
        self.centroids = np.asarray(state["centroids"], np.float64).reshape(-1, 3)
        self.id_base = int(state["id_base"])
