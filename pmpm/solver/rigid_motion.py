"""Free rigid FEM bodies: translation driven by contact impulses and gravity (seed 004
Sec. 4.4, the falling wedge; ``shared/seeds/004_NOTES.md`` Sec. 1.3: "a rigid master
uses m_c = body mass").

A body of a `rigid` material moves with its initial velocity, except in the axes its
``rigid.free`` names (pmpm.case.rigid). In those its velocity V_b is a state of its own,
one per body, the same on every rank: every node of the body takes V_b. No rotation:
a free rigid body translates only (the wedge's drop needs no more; a moment would need
the body's inertia tensor and the nodes' positions about its centre).

In each step:

* ``integrate`` (after the mesh's trial update): V_b += dt g in the free axes, and the
  nodes take V_b (their element forces are zero, as for any rigid body);
* surface coupling (ICFEMP, pmpm.solver.surface_contact): pair k on body b meets the
  share s_k = w_k / W_b of its mass M_b, w_k = m_p u_k |P n|^2 its particle's mass times
  its closing speed times the share of its normal n in the free axes (P the projection
  on them), W_b the sum over b's approaching pairs on all ranks, as the phi-shares
  of a deformable face lend a node's mass (a layer of n equal particles moving alike
  meets M_b / n each, which is one inelastic collision of the layer with the body,
  n m_p M_b/(n m_p + M_b); the body is never pushed beyond its pairs' fastest closing
  speed); the mass it meets along its normal n is s_k M_b / |P n|^2 (the held axes
  are an infinite mass). Then
  ``take_impulses``: V_b += P (sum of the pairs' impulses on b) / M_b, the nodes take
  the change on their velocities and dt times it on their positions (the particles' own
  correction moves them so too);
* grid coupling (CFEMP, pmpm.solver.fem_grid): the body meets the particles on the grid
  as a deformable body of its nodes' lumped masses (not through the grid's rigid slots),
  and ``take_velocity_changes``: V_b += P sum_K m_K dv_K / M_b over the body's nodes'
  contact corrections dv_K, which then give way to the body's change.

Momentum: what the particles lose in a free axis the body gains exactly; the held axes
take the rest (a support). The sums over ranks gather every contribution to every rank
and add them in (particle id) or (node id) order, so the body's velocity is bitwise the
same on every rank and on any rank count.
"""
import numpy as np

from ..kernels import exact_sum
from .observe import exact_totals


class RigidMotion:
    """The free rigid FEM bodies of a run.

    Parameters
    ----------
    config : pmpm.case.CaseConfig
    elements : solver.fem_bodies.FemBodies   (this rank's nodes; set-up reads them)
    world : comm.World
    """

    def __init__(self, config, elements, world):
        self.world = world
        nb = len(config.bodies)
        self.free = free_axes(config, "fem")
        self.gravity = np.asarray(config.gravity, np.float64)
        self.exact = bool(config.grid.exact_sums)
        self.mass = self.body_masses(elements, nb)
        self.velocity = self.body_velocities(elements, nb)

    @property
    def active(self):
        return bool(self.free.any())

    def body_masses(self, elements, nb):
        """M_b: the lumped node masses of each free body, summed in node id order over
        all ranks (each node counted once, by its lowest sharer)."""
        on = self.nodes(elements) & elements.owned
        rows = gathered(self.world, (elements.node_id[on], elements.node_body[on],
                                     elements.mass[on]))
        ids, body, mass = rows
        order = np.argsort(ids, kind="stable")
        total = np.zeros(nb)
        np.add.at(total, body[order], mass[order])
        return total

    def body_velocities(self, elements, nb):
        """V_b: the velocity of the body's nodes (all equal: a rigid body's initial
        velocity is uniform), read on a rank that holds one."""
        v = np.full((nb, 3), -np.inf)
        free_nodes = np.flatnonzero(self.nodes(elements))
        for b in np.flatnonzero(self.free.any(axis=1)):
            mine = free_nodes[elements.node_body[free_nodes] == b]
            if len(mine):
                v[b] = elements.v[mine[0]]
        v = self.world.max(v)
        return np.where(np.isfinite(v), v, 0.0)

    def nodes(self, elements):
        """Which of ``elements``' nodes belong to a free rigid body."""
        return self.free.any(axis=1)[elements.node_body]

    # -- the step ---------------------------------------------------------------------
    def integrate(self, elements, dt):
        """Gravity on the free axes, then every node takes its body's velocity."""
        self.velocity += dt * np.where(self.free, self.gravity[None, :], 0.0)
        self.set_nodes(elements)

    def set_nodes(self, elements):
        on = self.nodes(elements)
        elements.v[on] = self.velocity[elements.node_body[on]]

    def lent_inverse_mass(self, bodies, normals, lent, closing):
        """Per pair, (k, 4) the inverse masses its master face's nodes lend it (``lent``,
        from the deformable rule), those of free rigid faces replaced by
        |P n|^2 / (s_k M_b): pair k meets the share s_k = w_k / W_b of its body's mass,
        w_k = ``closing`` |P n|^2 (m_p times its closing speed, times the share of its
        normal in the free axes), W_b the sum of w over the pairs on b over all ranks
        (collective). A pair whose normal has no free component cannot move the body,
        weighs nothing and meets it as rigid; without the |P n|^2 it took a share that
        the pairs that push along the free axes then missed, and those met less than the
        whole body. n pairs alike share M_b / n; a pair that barely
        approaches takes a share that vanishes with its speed, so no pair changes the
        others' shares by a jump when it comes or goes (a plain count n_b did: 1 rank and
        2 ranks, apart by round-off in one pair's closing speed, split by 0.2 %)."""
        on = self.free.any(axis=1)[bodies]
        free_n = np.where(self.free[bodies], normals, 0.0)
        along = np.einsum("kd,kd->k", free_n, free_n)
        weight = np.where(on, closing * along, 0.0)
        total = self.weight_totals(bodies[on], weight[on])
        if not on.any():
            return lent
        mass = np.where(self.mass > 0, self.mass, 1.0)[bodies]
        inverse = np.divide(total[bodies] * along, mass * weight,
                            out=np.zeros(len(bodies)), where=weight > 0)
        out = lent.copy()
        out[on] = inverse[on, None]
        return out

    def weight_totals(self, bodies, weight):
        """(nb,) W_b, the sums of ``weight`` per body over all ranks (collective):
        exactly rounded with exact sums, the same bits on any rank count (the pairs'
        weights are), else each rank's sums added by one reduction."""
        if self.exact:
            acc = exact_sum.zeros(len(self.mass))
            for b in np.unique(bodies):
                exact_sum.add_terms(acc, b, weight[bodies == b])
            return exact_totals(self.world, [acc])[0]
        total = np.zeros(len(self.mass))
        np.add.at(total, bodies, weight)
        return self.world.sum(total)

    def take_impulses(self, elements, bodies, ids, impulses, dt):
        """V_b += P (sum over all ranks' pairs on b, in particle id order, of their
        impulses) / M_b; the nodes take the change on v and dt times it on x
        (collective)."""
        on = self.free.any(axis=1)[bodies]
        change = self.summed_change(bodies[on], ids[on], impulses[on])
        self.shift_nodes(elements, change, dt)

    def take_velocity_changes(self, elements, change):
        """Grid coupling: V_b += P (sum over the body's nodes, each once, in node id order,
        of m_K dv_K) / M_b; the nodes' own changes ``change`` (n, 3) are replaced by
        their body's (collective)."""
        on = self.nodes(elements)
        mine = on & elements.owned
        momentum = elements.mass[mine, None] * change[mine]
        dv = self.summed_change(elements.node_body[mine], elements.node_id[mine], momentum)
        self.velocity += dv
        change[on] = dv[elements.node_body[on]]

    def summed_change(self, bodies, ids, rows):
        """(nb, 3) P sum_b(rows) / M_b, the rows of all ranks added in ``ids`` order."""
        bodies, ids, rows = gathered(self.world, (bodies, ids, rows))
        order = np.argsort(ids, kind="stable")
        total = np.zeros_like(self.velocity)
        np.add.at(total, bodies[order], rows[order])
        mass = np.where(self.mass > 0, self.mass, 1.0)
        return np.where(self.free, total / mass[:, None], 0.0)

    def shift_nodes(self, elements, change, dt):
        self.velocity += change
        on = self.nodes(elements)
        dv = change[elements.node_body[on]]
        elements.v[on] += dv
        elements.x[on] += dt * dv


def free_axes(config, method=None):
    """(nb, 3) bool: the free axes of each rigid body (pmpm.case.rigid), of the bodies
    of ``method`` only ("fem" or "particles") when given."""
    free = np.zeros((len(config.bodies), 3), bool)
    for b, body in enumerate(config.bodies):
        if method is not None and body.is_fem != (method == "fem"):
            continue
        for axis in body.free_axes:
            free[b, "xyz".index(axis)] = True
    return free


def gathered(world, columns):
    """The columns of every rank, concatenated in rank order (one allgather)."""
    if world.size == 1:
        return tuple(np.asarray(c) for c in columns)
    parts = world.allgather(tuple(np.asarray(c) for c in columns))
    return tuple(np.concatenate([p[i] for p in parts]) for i in range(len(columns)))
