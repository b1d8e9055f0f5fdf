"""The records the kernels receive whole: named tuples of arrays (and a few scalars) that
Numba passes as one argument at no cost, so that no kernel takes more than about a
dozen arguments and a new field is added in one place.

A record is built by the solver from its current arrays (columns are replaced when
particles migrate or are sorted, so records are rebuilt at every use; building one costs
about a microsecond). A kernel argument that may be ``None`` (e.g. the contact view when
there is no contact) is compiled away: ``if view is not None`` is pruned by Numba when the
argument's type is ``none``, so an absent feature costs nothing.
"""
from collections import namedtuple

from ..materials.state import MaterialState

#: The grid of one level as a particle kernel sees it: ``origin`` (3,), ``inv_h`` (the
#: level's 1 / cell size), the rank's local node block ``lo`` (3,), ``strides`` (3,),
#: the ``shape`` function's marker (``pmpm.kernels.shape.MARKERS``: a tuple whose length
#: is the shape code) and per body the particles' uGIMP
#: ``half_width`` (nb,) in cells.
GridGeometry = namedtuple("GridGeometry", "origin inv_h lo strides shape half_width")

#: A local node block as a node kernel sees it: ``shape``, ``lo``, ``strides`` (3,) of
#: the block, the level's ``n_cells`` (3,), the box-face ``boundary`` codes (6,),
#: ``faces`` (n_nodes,) uint16, each node's packed face codes (``pmpm.kernels.boundary``),
#: and the box faces' Coulomb ``friction`` coefficients (6,) (0 where none).
NodeBlock = namedtuple("NodeBlock", "shape lo strides n_cells boundary faces friction")

#: The kinematics of material points: ``x``, ``v`` (n, 3), ``mass`` (n,), ``body``
#: (n,) int32, and ``level`` (n,) int32, the grid level each point maps to.
PointState = namedtuple("PointState", "x v mass body level")

#: A layer-ordered scatter (``pmpm.kernels.layered``): the particles' canonical
#: ``order`` (n,), the slab ``axis``, the first row of each node plane ``starts``
#: (n_planes + 1,), the shape's ``halo``, the ``scratch`` window (rows, c) and the
#: ``kept`` first layers' sums (layers, rows, c).
LayerSums = namedtuple("LayerSums", "order axis starts halo scratch kept")

#: Per body: material ``codes`` (nb,), packed ``params`` (nb, N_SLOTS), ``rigid`` (nb,).
BodyMaterials = namedtuple("BodyMaterials", "codes params rigid")

#: External loads: ``gravity`` (3,), ``vectors`` (n_loads, 3) at this step's mid-time,
#: and per point the load ``index`` (n,) int32 (-1: none) and its ``scale`` (n,).
ExternalLoads = namedtuple("ExternalLoads", "gravity vectors index scale")

#: What a point kernel reads of the multi-velocity contact fields: ``slot_of`` (n_nodes,)
#: (-1: not a contact node) and the per-slot, per-body ``cvel`` (start velocity),
#: ``cforce`` (force) and ``cnew`` (end velocity and acceleration).
ContactView = namedtuple("ContactView", "slot_of cvel cforce cnew")

#: The contact fields of one level (pmpm.kernels.contact): per slot and body ``cnodal``
#: (mass, momentum, mass gradient, offset), ``cvel``, ``cnorm``, ``cforce``, ``cnew``,
#: and ``slot_nodes`` (the local node of each slot).
ContactSlots = namedtuple("ContactSlots", "cnodal slot_nodes cvel cnorm cforce cnew")

#: Per pair of bodies (nb, nb): ``master`` (whose normal; -1 the average), Coulomb
#: ``friction`` and the ``separation`` check in cells (inf: none).
PairRules = namedtuple("PairRules", "master friction separation")

#: The tied slaves of a window block: ``slaves`` (n,), ``masters`` (n, 8) (-1: none),
#: ``weights`` (n, 8), and ``count`` rows in use.
TieSet = namedtuple("TieSet", "slaves masters weights count")

__all__ = ["GridGeometry", "NodeBlock", "PointState", "BodyMaterials", "ExternalLoads",
           "ContactView", "ContactSlots", "PairRules", "TieSet", "LayerSums", "MaterialState"]
