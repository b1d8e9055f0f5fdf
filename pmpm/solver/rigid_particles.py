"""Free rigid particle bodies: a particle body of a `rigid` material whose ``rigid.free``
names axes (pmpm.case.rigid) translates in those under grid contact and gravity (issue 24
Sec. 3; the FEM bodies' counterpart is pmpm.solver.rigid_motion).

Such a body keeps one velocity V_b, the same for all its particles and on every rank. As
a held rigid body does, it imposes V_b on the grid nodes it reaches (the rigid columns
of ``nodal``, pmpm.kernels.mpm), and at contact nodes the other bodies are corrected
against it (pmpm.kernels.contact, ``grid_rigid``). After the contact of a step
(``after_integrate``) V_b changes in its free axes by

    dV_b = (-J_b + M_b g dt) / M_b,

J_b the impulse the contact gave the bodies at the nodes it reaches
(pmpm.kernels.forces.rigid_partner_impulses: their particles' or FE nodes' momentum
change less their own forces, which is what they take), M_b the mass of its particles.
Its particles take V_b before they move (rigid particles move with their own velocity),
so they move with the new velocity, as the grid's points do. What the partners gain the
body loses: the momentum of the free rigid body and the bodies it touches grows by their
weight alone in the free axes; the held axes keep the initial velocity (a support takes
the rest). It does not rotate.

Within a step the partners meet the body as an infinite mass (they stop against its
velocity, then it reacts): right for a body much heavier than the material its contact
nodes reach in a step, as a striker or a dropped weight is; a light free body under a
heavy layer would overshoot (it takes the layer's whole relative momentum at once).

Grid contact is needed (``contact.method`` 1 or 2): without it the rigid body's
particles share their nodes' one field with the others' and the impulse between them is
not measured; the case check refuses that. Rigid particle bodies take no part in
particle-to-surface contact (ICFEMP); they meet FEM bodies by grid coupling (CFEMP),
whose FE nodes are then the partners. The grid's faces do not hold a free rigid body,
and two rigid bodies do not meet (their nodes take their mean velocity).

MPI: each rank adds the impulses of the contact nodes it counts (a shared slab plane by
the lower rank). With exact sums (``grid.exact_sums``, on by default where bodies meet)
the nodes' values are the same bits on any rank count and each rank adds their impulses
into an exact accumulator (pmpm.kernels.exact_sum) whose bins are summed over the ranks,
so J_b, and the body's motion, are the same bits on 1 and N ranks; without, the ranks'
float sums are gathered and added in rank order, so every rank moves the body alike and
1 rank and N differ by round-off. M_b is summed over all ranks in particle id order. A restart reads V_b back from the particles'
velocities, which the checkpoint keeps.
"""
import numpy as np

from ..kernels import exact_sum
from ..kernels import forces as kf
from .contact import start_shares
from .couplings import Coupling
from .forces import counted_planes
from .observe import exact_totals
from .rigid_motion import free_axes, gathered


class FreeRigidParticles(Coupling):
    """The free rigid particle bodies of a run, as a coupling after grid contact.

    Parameters
    ----------
    config : pmpm.case.CaseConfig
    world : comm.World
    points : solver.particle_bodies.ParticleBodies
    grid_contact : solver.contact.GridContact   (its per-body fields)
    """

    def __init__(self, config, world, points, grid_contact):
        self.world, self.points, self.contact = world, points, grid_contact
        self.free = free_axes(config, "particles")
        self.bodies = self.free.any(axis=1)
        self.grid_rigid = np.asarray(points.bodies.grid_rigid, bool)
        self.share = np.asarray(start_shares(config), np.float64)
        self.gravity = np.asarray(config.gravity, np.float64)
        self.exact = bool(config.grid.exact_sums)
        self.mass = self.body_masses()
        self.velocity = self.body_velocities()

    @property
    def active(self):
        return bool(self.bodies.any())

    def body_masses(self):
        """M_b: the masses of each free body's particles, summed in id order over all
        ranks (every rank, any rank count, any distribution gets the same sum)."""
        p = self.points.particles
        on = self.bodies[p.body]
        ids, body, mass = gathered(self.world, (p.id[on], p.body[on], p.mass[on]))
        order = np.argsort(ids, kind="stable")
        total = np.zeros(len(self.bodies))
        np.add.at(total, body[order], mass[order])
        return total

    def body_velocities(self):
        """V_b: the velocity of the body's particles (all alike: the initial velocity of
        a free rigid body is uniform, and the body sets it after every step), read on a
        rank that holds one."""
        p = self.points.particles
        v = np.full((len(self.bodies), 3), -np.inf)
        for b in np.flatnonzero(self.bodies):
            mine = np.flatnonzero(p.body == b)
            if len(mine):
                v[b] = p.v[mine[0]]
        v = self.world.max(v)
        return np.where(np.isfinite(v), v, 0.0)

    # -- the step ---------------------------------------------------------------------
    def after_integrate(self, grids, dt):
        """V_b += P (g dt - J_b / M_b), J_b the impulse on the partners (collective);
        the body's particles take V_b."""
        impulse = self.partner_impulses(grids, dt)
        mass = np.where(self.mass > 0, self.mass, 1.0)
        change = dt * self.gravity[None, :] - impulse / mass[:, None]
        self.velocity += np.where(self.free, change, 0.0)
        self.set_particles()

    def partner_impulses(self, grids, dt):
        """(nb, 3) J_b over all levels and ranks: exactly rounded with exact sums, else
        the ranks' sums added in rank order."""
        shape = (len(self.bodies), 3)
        local = exact_sum.zeros(shape) if self.exact else np.zeros(shape)
        for s in grids:
            f = self.contact.fields[s.index]
            if f.n_slots:
                per_plane, counted = counted_planes(s.block, self.world.rank)
                kf.rigid_partner_impulses(f.slots(), f.real_mass, self.share,
                                          self.grid_rigid, self.bodies, s.nodes.faces,
                                          counted, per_plane, dt, local)
        if self.exact:
            return exact_totals(self.world, [local])[0]
        (parts,) = gathered(self.world, (local[None],))
        total = np.zeros_like(local)
        for part in parts:
            total += part
        return total

    def set_particles(self):
        """Every particle of a free body takes its body's velocity in the free axes."""
        p = self.points.particles
        on = self.bodies[p.body]
        body = p.body[on]
        p.v[on] = np.where(self.free[body], self.velocity[body], p.v[on])


def free_rigid_particles(config, world, points, grid_contact):
    """The coupling of the case's free rigid particle bodies, or None when it has none
    (grid contact is there: the case check refuses such a body without it)."""
    if grid_contact is None:
        return None
    motion = FreeRigidParticles(config, world, points, grid_contact)
    return motion if motion.active else None
