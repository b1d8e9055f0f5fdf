"""Where the FEM ogive rod's momentum goes (issue 24 Sec. 5): runs a case like
``python -m pmpm`` on ONE rank and splits the rod's loss of momentum along its flight
(-z) by mechanism, step by step:

* ``node_rs``: node-to-surface impulses with the rod's nodes as slaves on plate faces,
* ``node_pm``: node-to-surface impulses with the plate's nodes as slaves on rod faces,
* ``icfemp``: particle-to-surface contact (ICFEMP: converted plate particles on the
  rod's faces, converted rod particles on the plate's faces), as the rod's change of
  momentum across the coupling (its grid side moves every particle of a node at a face,
  so its impulses are not one pair's),
* ``grid``: the rest (particles meeting particles on the grid; internal forces and the
  conversions keep the rod's momentum).

    python scripts/ogive_fem_budget.py CASE.yaml --out DIR [--set KEY=VALUE ...] [--every US]

Prints, every ``--every`` microseconds (default 5), the time, the rod's speed along -z
(nodes and its converted particles, mass-weighted), the cumulative speed each mechanism
took (its impulse over the rod's mass; ``node_rs_shank`` the part of ``node_rs`` on the
rod's nodes behind the nose), the kinetic energy each contact's impulses took from all
nodes and particles (``node_loss``, ``icfemp_loss``, mJ), the plate elements converted
so far, how many plate elements are left below half their initial volume
(``squeezed``), the largest plastic strain of the plate's elements left and of the
rod's, and the energies of the plate, the rod and the converted particles; writes the
rows to DIR/budget.json (one rank only: the sums are one rank's). A diagnosis tool,
not a test: it wraps the contact kernels' Python entry points and does not change a result."""
import json
import os
import sys

import numpy as np

ROD, PLATE = 0, 1
#: the 3-CRH ogive's nose length (mm): d sqrt(crh - 1/4), for d = 12.9
NOSE = 12.9 * (3.0 - 0.25) ** 0.5


class Budget:
    def __init__(self):
        self.sums = {"node_rs": 0.0, "node_pm": 0.0, "icfemp": 0.0, "grid": 0.0,
                     "node_rs_shank": 0.0, "node_loss": 0.0, "icfemp_loss": 0.0}
        self.fem = self.points = None
        self.t, self.rows, self.next_row = 0.0, [], 0.0

    def rod_momentum(self):
        """(rod mass, rod momentum along z) of nodes and converted particles."""
        fem, mass, pz = self.fem, 0.0, 0.0
        if fem is not None:
            on = (fem.node_body == ROD) & fem.owned
            mass += fem.mass[on].sum()
            pz += fem.mass[on] @ fem.v[on, 2]
        if self.points is not None:
            p = self.points.particles
            on = p.body == ROD
            mass += p.mass[on].sum()
            pz += p.mass[on] @ p.v[on, 2]
        return mass, pz


BUDGET = Budget()
CONTACT = ("node_rs", "node_pm", "icfemp")


def kinetic_energy():
    """The kinetic energy (mJ) of all FE nodes and particles: what a contact's impulses
    take from it is what the contact dissipates (its position shifts do no work)."""
    fem, energy = BUDGET.fem, 0.0
    if fem is not None:
        m, v = fem.mass[fem.owned], fem.v[fem.owned]
        energy += 0.5 * float(m @ np.einsum("ij,ij->i", v, v))
    if BUDGET.points is not None:
        p = BUDGET.points.particles
        energy += 0.5 * float(p.mass @ np.einsum("ij,ij->i", p.v, p.v))
    return energy


def wrap_kernels():
    from pmpm.kernels import node_contact as knc
    node_impulses = knc.node_pair_impulses

    def node_pair_impulses(pair_n, pair_s, geo, lent, v, node_body, seg_v, seg_inv_m,
                           seg_body, friction, dt, impulses, depth):
        node_impulses(pair_n, pair_s, geo, lent, v, node_body, seg_v, seg_inv_m,
                      seg_body, friction, dt, impulses, depth)
        if BUDGET.fem is None:                         # the kernels' warm-up
            return
        rod_slave = node_body[pair_n] == ROD           # the slave takes -I
        rod_face = seg_body[pair_s] == ROD             # the face's nodes take +I
        BUDGET.sums["node_rs"] += float(-impulses[rod_slave, 2].sum())
        fem = BUDGET.fem
        rod_x = fem.x[fem.node_body == ROD, 2]
        behind = fem.x[pair_n, 2] > rod_x.min() + NOSE    # on the shank, past the nose
        BUDGET.sums["node_rs_shank"] += float(-impulses[rod_slave & behind, 2].sum())
        BUDGET.sums["node_pm"] += float(impulses[rod_face, 2].sum())

    knc.node_pair_impulses = node_pair_impulses


def wrap_couplings():
    from pmpm.solver.node_contact import NodeContact
    from pmpm.solver.surface_contact import SurfaceContact
    from pmpm.solver.step import Stepper
    from pmpm.solver.conversion import Conversion
    node_step, surface_step = NodeContact.after_update_points, SurfaceContact.after_update_points

    def node_after(self, dt):
        BUDGET.fem = self.elements
        before = kinetic_energy()
        node_step(self, dt)
        BUDGET.sums["node_loss"] += before - kinetic_energy()

    def surface_after(self, dt):
        BUDGET.fem, BUDGET.points = self.elements, self.points
        before, (_, p0) = kinetic_energy(), BUDGET.rod_momentum()
        surface_step(self, dt)
        BUDGET.sums["icfemp_loss"] += before - kinetic_energy()
        BUDGET.sums["icfemp"] += BUDGET.rod_momentum()[1] - p0

    NodeContact.after_update_points, SurfaceContact.after_update_points = node_after, surface_after
    step, transfer = Stepper.step, Conversion.transfer

    def transfer_(self):
        count = transfer(self)
        BUDGET.converted = self.converted
        return count

    Conversion.transfer = transfer_
    BUDGET.converted = 0

    def stepped(self, dt):
        mass0, p0 = BUDGET.rod_momentum()
        before = sum(v for k, v in BUDGET.sums.items() if k in CONTACT)
        step(self, dt)
        mass, p1 = BUDGET.rod_momentum()
        contact = sum(v for k, v in BUDGET.sums.items() if k in CONTACT) - before
        if BUDGET.fem is not None and mass0 > 0.0:
            BUDGET.sums["grid"] += (p1 - p0) - contact
        BUDGET.t += dt
        if BUDGET.fem is not None and BUDGET.t >= BUDGET.next_row:
            record(mass, p1)
            BUDGET.next_row += BUDGET.every

    Stepper.step = stepped


def record(mass, pz):
    fem = BUDGET.fem
    plate = fem.body == PLATE
    ratio = fem.volumes()[plate] / fem.vol0[plate]
    eps = fem.state.eps_p[plate]
    row = {"t_us": 1e3 * BUDGET.t, "v_rod": -pz / mass,
           **{k: v / mass for k, v in BUDGET.sums.items() if not k.endswith("_loss")},
           **{k: v for k, v in BUDGET.sums.items() if k.endswith("_loss")},
           "converted": int(BUDGET.converted),
           "squeezed": int(np.count_nonzero(ratio < 0.5)),
           "max_eps_left": float(eps.max(initial=0.0)),
           "rod_max_eps": float(fem.state.eps_p[fem.body == ROD].max(initial=0.0)),
           **plate_energies(fem), **particle_energies(BUDGET.points)}
    BUDGET.rows.append(row)
    print(" ".join(f"{k} {v:.4g}" if isinstance(v, float) else f"{k} {v}"
                   for k, v in row.items()), flush=True)


def plate_energies(fem):
    """The plate's elements' hourglass (with the converted ones'), internal and
    kinetic energies (mJ), and the rod's kinetic, internal and hourglass energies (its
    elements)."""
    stats = fem.body_stats(fem.world)
    plate, rod = stats["plate"]["energy"], stats["rod"]["energy"]
    return {"plate_hg": plate["hourglass"] + fem.removed_hourglass,  # rod's too, if any
            "plate_int": plate["internal"], "plate_kin": plate["kinetic"],
            "rod_kin": rod["kinetic"], "rod_int": rod["internal"],
            "rod_hg": rod["hourglass"]}


def particle_energies(points):
    """The kinetic and internal energies (mJ) of the converted particles, all bodies."""
    if points is None:
        return {"part_kin": 0.0, "part_int": 0.0}
    p = points.particles
    return {"part_kin": 0.5 * float(p.mass @ np.einsum("ij,ij->i", p.v, p.v)),
            "part_int": float(p.mass @ p.e_int)}


def main():
    argv = sys.argv[1:]
    every = 5.0
    if "--every" in argv:
        at = argv.index("--every")
        every = float(argv[at + 1])
        del argv[at:at + 2]
    BUDGET.every = every * 1e-3
    out = argv[argv.index("--out") + 1]
    from mpi4py import MPI
    if MPI.COMM_WORLD.size > 1:
        sys.exit("ogive_fem_budget.py: run it on one rank (its sums are one rank's)")
    wrap_kernels()
    wrap_couplings()
    from pmpm.__main__ import main as pmpm_main
    status = pmpm_main(argv + ["--quiet"])
    os.makedirs(out, exist_ok=True)
    with open(os.path.join(out, "budget.json"), "w", encoding="utf-8") as handle:
        json.dump(BUDGET.rows, handle, indent=1)
    return status


if __name__ == "__main__":
    sys.exit(main())
