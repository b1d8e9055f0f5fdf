"""The update orders of one explicit step: which phases run, in which order. A scheme
asks the :class:`pmpm.solver.step.Stepper` for its named phases; the phases ask every
body kind and coupling for their part."""


class UpdateStressFirst:
    """USF (seed 000 Sec. 4, seed 001 Sec. 4): stresses from the start-of-step nodal
    velocities, nodal forces from them in the same pass."""

    name = "usf"

    def advance(self, step, dt):
        step.map_to_grid()
        step.nodal_velocities()
        step.stress_and_forces(dt)
        step.integrate(dt)
        step.update_points(dt)


class ModifiedUpdateStressLast:
    """MUSL: nodal forces from the stresses of the start of the step; after the points
    move, their new velocities are mapped back to the grid from the start-of-step
    positions (boundary conditions, ties and method 2's contact correction applied
    again) and the stresses are updated from those nodal velocities."""

    name = "musl"

    def advance(self, step, dt):
        step.map_to_grid()
        step.nodal_velocities()
        step.nodal_forces(dt)
        step.integrate(dt)
        step.remember_start_positions()
        step.update_points(dt)
        step.back_to_start_positions()
        step.map_to_grid()
        step.nodal_velocities()
        step.update_stresses(dt)
        step.on_to_moved_positions()


SCHEMES = {scheme.name: scheme for scheme in (UpdateStressFirst, ModifiedUpdateStressLast)}


def make_scheme(name):
    return SCHEMES[name]()
