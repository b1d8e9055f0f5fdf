"""The step's transfer hook: material that moves from one body kind to another once the
points and the FE nodes have moved, before the windows split particles and the points
migrate (:meth:`pmpm.solver.step.Stepper.step`).

A transfer (:class:`Transfer`) decides *what* moves (conversion's criteria and the
particles it makes, pmpm.solver.conversion); :class:`ElementsToParticles` does the
moving that any such rule needs, so that the rule's module holds the rule alone: every
rank's elements' shares of their nodes' masses gathered and taken off in element id order
(every copy of a shared node, and 1 rank against N, agree), the elements and the nodes
no element uses dropped, the particles added, and the couplings told that the mesh changed
(``after_elements_changed``: surface contact's free faces), all collective.
"""
import numpy as np

__all__ = ["ElementsToParticles", "Transfer"]


class Transfer:
    """The base of the transfers: nothing moves, nothing is kept.

    ``transfer()`` moves what its rule chooses this step and returns how much moved over
    all ranks (collective); ``reserved_ids`` is how many particle ids above the run's
    initial particles it may give (the refined windows' splitting counts ids from above
    them, pmpm.solver.simulation); a transfer registered with a checkpoint key
    (pmpm.solver.registry) answers ``state()`` and ``restore(state)``.
    """

    reserved_ids = 0

    def transfer(self):
        return 0


class ElementsToParticles:
    """Moves chosen FEM elements' material into particles (collective).

    Parameters
    ----------
    world : comm.World
    elements : solver.fem_bodies.FemBodies   (the elements are removed there)
    points : solver.particle_bodies.ParticleBodies   (the particles are added there)
    couplings : list of solver.couplings.Coupling   (told ``after_elements_changed``; the
        list the step runs, filled by the time a step moves anything)
    """

    def __init__(self, world, elements, points, couplings):
        self.world, self.elements, self.points = world, elements, points
        self.couplings = couplings

    def move(self, chosen, born):
        """Replace this rank's elements ``chosen`` (bool) by the particle columns ``born``.

        Returns (the number of elements moved over all ranks, this rank's kinetic energy
        the nodes lost beyond what ``born`` carries: the velocity field's variation over
        the elements)."""
        fem = self.elements
        before = fem.kinetic_energy_of_nodes()
        shares = self.world.allgather(fem.mass_shares(chosen))
        fem.remove_elements(chosen, merge_shares(shares))
        loss = before - fem.kinetic_energy_of_nodes() - kinetic(born)
        self.points.particles.append(born)
        for coupling in self.couplings:
            coupling.after_elements_changed()
        return int(self.world.sum(int(chosen.sum()))), loss


def merge_shares(parts):
    """Every rank's (element ids, node ids (m, 8), mass shares (m,)) as one set of
    rows, in element id order."""
    ids = np.concatenate([p[0] for p in parts])
    order = np.argsort(ids, kind="stable")
    nodes = np.concatenate([p[1] for p in parts])[order]
    shares = np.concatenate([p[2] for p in parts])[order]
    return ids[order], nodes, shares


def kinetic(columns):
    """The kinetic energy of particle columns."""
    v = columns["v"]
    return 0.5 * float(columns["mass"] @ np.einsum("ij,ij->i", v, v))
