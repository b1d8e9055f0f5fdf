"""Particle splitting (seed 000 Sec. 3.4): a coarse particle that enters a refined window
becomes n^3 particles of the window's spacing.

The parent stands for a cube of edge L0 = vol0^(1/3) in the initial configuration, which
its deformation gradient F has carried to the current one. The children sit at the
centres of the n^3 sub-cubes of that cube, mapped by F: x_child = x + F (offset L0), the
offsets ((a + 1/2)/n - 1/2, ...) for a, b, c = 0..n-1. With F diagonal this is Eq. 25,
L_i = L0 (1 + eps_i); F also carries shear and rotation. Mass, volume and the share of a
load are divided among the children (the specific internal energy e_int, per unit mass,
is then divided with the mass); stress, F, density, plastic strain, temperature and every
other history variable are copied, and so is the APIC matrix ``affine`` (stored per cell
of the particle's level, so the children keep the parent's velocity gradient; their
velocities are the parent's, which keeps linear momentum exactly).

Children get new global ids that depend only on the parent's id, so they are unique
across ranks and the same on any number of ranks: ``id_base + parent_id * id_stride + k``
(k = 0..n^3 - 1), with ``id_base`` above every id in use and ``id_stride`` at least the
largest n^3.
"""
import numpy as np

from ..kernels.portable import cube_roots


DIVIDED = ("mass", "vol0", "load_scale")


def sub_cube_offsets(n):
    """(n^3, 3) centres of the n^3 sub-cubes of the unit cube centred on the origin."""
    centres = (np.arange(n) + 0.5) / n - 0.5
    a, b, c = np.meshgrid(centres, centres, centres, indexing="ij")
    return np.stack([a.ravel(), b.ravel(), c.ravel()], axis=1)


def deformed_offsets(F, offsets):
    """(p, k, 3): F_p applied to each offset k by elementwise products, summed over j as
    (j = 0 + j = 2) + j = 1: the order np.einsum("pij,kj->pki") took with the pinned
    numpy, so the answers did not move, but fixed here rather than left to einsum's SIMD
    loops, whose order may differ with the CPU or a numpy release."""
    o = offsets[None, :, None, :]
    f = F[:, None, :, :]
    return (f[..., 0] * o[..., 0] + f[..., 2] * o[..., 2]) + f[..., 1] * o[..., 1]


def children_of(particles, parents, n, id_base, id_stride):
    """Columns of the n^3 children of each particle in ``parents`` (int index array)."""
    k = n ** 3
    offsets = sub_cube_offsets(n)
    edge = cube_roots(np.ascontiguousarray(particles.vol0[parents], np.float64))
    F = particles.F[parents].reshape(-1, 3, 3)
    moved = deformed_offsets(F, offsets) * edge[:, None, None]
    children = {}
    for name in particles.COLUMNS:
        column = np.repeat(getattr(particles, name)[parents], k, axis=0)
        if name in DIVIDED:
            column /= k
        children[name] = column
    children["x"] = (particles.x[parents][:, None, :] + moved).reshape(-1, 3)
    # where each child was at the start: the parent's start plus its unstrained offset
    children["x0"] = (particles.x0[parents][:, None, :]
                      + offsets[None, :, :] * edge[:, None, None]).reshape(-1, 3)
    children["id"] = (id_base + particles.id[parents][:, None] * id_stride
                      + np.arange(k)[None, :]).reshape(-1)
    children["refine"] = children["refine"] * n
    return children


def split(particles, parents, factors, id_base, id_stride):
    """Replace each particle ``parents[i]`` by ``factors[i]^3`` children (factors >= 2):
    the first child takes the parent's row; returns the columns (name -> array, every
    column of the store) of the others, for the caller to append as it appends any
    particles it is handed (``ParticleBodies.add_particles``)."""
    parents = np.asarray(parents, np.int64)
    factors = np.asarray(factors, np.int64)
    rest = {name: [getattr(particles, name)[:0]] for name in particles.COLUMNS}
    for n in np.unique(factors):
        group = parents[factors == n]
        children = children_of(particles, group, int(n), id_base, id_stride)
        first = np.arange(len(group)) * int(n) ** 3
        for name, column in children.items():
            getattr(particles, name)[group] = column[first]
            rest[name].append(np.delete(column, first, axis=0))
    return {name: np.concatenate(parts) for name, parts in rest.items()}
