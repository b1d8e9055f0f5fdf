"""The step's transfer hook: material that moves from one body kind to another once the
points and the FE nodes have moved, before the windows split particles and the points
migrate (:meth:`pmpm.solver.step.Stepper.step`).

A transfer (:class:`Transfer`, built from a ``TRANSFER`` entry of pmpm.solver.registry)
decides *what* moves and what it becomes; the kinds do the moving with general
operations that do not know the rule: :class:`ElementsToParticles` takes the chosen
elements out of the mesh (``FemBodies.remove_elements``: the nodes' mass shares in
element id order, nodes left without elements dropped, halos found again, and the kind's
``elements_changed`` event, on which the couplings rebuild their free faces) and hands
the particles to the particle bodies (``ParticleBodies.add_particles``), all collective.
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
    """

    def __init__(self, world, elements, points):
        self.world, self.elements, self.points = world, elements, points

    def move(self, chosen, born):
        """Replace this rank's elements ``chosen`` (bool) by the particle columns ``born``.

        Returns (the number of elements moved over all ranks, this rank's kinetic energy
        the nodes lost beyond what ``born`` carries: the velocity field's variation over
        the elements)."""
        fem = self.elements
        before = fem.kinetic_energy_of_nodes()
        fem.remove_elements(chosen)
        loss = before - fem.kinetic_energy_of_nodes() - kinetic(born)
        self.points.add_particles(born)
        return int(self.world.sum(int(chosen.sum()))), loss


def kinetic(columns):
    """The kinetic energy of particle columns."""
    v = columns["v"]
    return 0.5 * float(columns["mass"] @ np.einsum("ij,ij->i", v, v))
