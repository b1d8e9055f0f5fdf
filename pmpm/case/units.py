"""The case's unit system (``units:``) and the checks that catch a value given in
another one: a density of 2700 (kg/m^3) in a mm-ms-g case ran to the end with a kinetic
energy of 3e10 mJ and no word.

pmpm takes any consistent system; the two it knows are mm-ms-g (the default, as the
docs' examples: stress MPa, velocity mm/ms = m/s, energy mJ) and m-s-kg (SI). In either,
every material's density and elastic moduli must lie in the range real materials span
(from gases and foams to osmium and diamond), and its bulk sound speed sqrt(K/rho), in
m/s in both systems, between that of a soft foam and twice diamond's; an equation of
state's c0 must lie within a factor of two of sqrt(K/rho) where the material gives K
(or E and nu). ``units: other`` (a consistent system of your own) skips the checks."""
import math

from .errors import join
from .fields import valid
from ..materials import catalog

SYSTEMS = ("mm-ms-g", "m-s-kg", "other")
#: (density, modulus) ranges per system, and the unit names for the messages
RANGES = {"mm-ms-g": ((1e-7, 0.03), (1e-4, 2e6)),
          "m-s-kg": ((0.1, 3e4), (1e2, 2e12))}
UNIT_NAMES = {"mm-ms-g": ("g/mm^3", "MPa"), "m-s-kg": ("kg/m^3", "Pa")}
#: m/s: the bulk sound speed of any condensed material, model fluid or test material
SOUND_SPEED = (1.0, 4e4)
#: c0 against sqrt(K/rho): a factor beyond this is a unit slip (km/s for m/s)
C0_FACTOR = 2.0


def check_units(case, problems):
    """Add a problem naming the key of each density, modulus or sound speed that does
    not belong to ``case["units"]``."""
    system = case.get("units")
    materials = case.get("materials")
    if system not in RANGES or not isinstance(materials, dict):
        return
    for name, material in materials.items():
        if isinstance(material, dict):
            check_material_units(material, join("materials", name), system, problems)


def check_material_units(material, path, system, problems):
    (rho_lo, rho_hi), (mod_lo, mod_hi) = RANGES[system]
    rho_unit, mod_unit = UNIT_NAMES[system]
    other = "m-s-kg" if system == "mm-ms-g" else "mm-ms-g"
    hint = f"; if the case is in {other} units, say so with units: {other}"
    if valid(material, "density") and not rho_lo <= material["density"] <= rho_hi:
        problems.add(join(path, "density"),
                     f"{material['density']:g} is not a density in {rho_unit} ({system}: "
                     f"real materials lie in {rho_lo:g} to {rho_hi:g}){hint}")
        return
    for key in ("E", "K", "G"):
        if valid(material, key) and not mod_lo <= material[key] <= mod_hi:
            problems.add(join(path, key),
                         f"{material[key]:g} is not a modulus in {mod_unit} ({system}: real "
                         f"materials lie in {mod_lo:g} to {mod_hi:g}){hint}")
            return
    bulk = bulk_modulus(material)
    if bulk is None or not valid(material, "density"):
        return
    speed = math.sqrt(bulk / material["density"])
    if not SOUND_SPEED[0] <= speed <= SOUND_SPEED[1]:
        problems.add(path, f"the bulk sound speed sqrt(K/density) = {speed:.3g} m/s is outside "
                     f"{SOUND_SPEED[0]:g} to {SOUND_SPEED[1]:g} m/s: the density and the "
                     f"moduli are in different units ({system}: {rho_unit} and {mod_unit})")
        return
    eos = material.get("eos")
    if isinstance(eos, dict) and valid(eos, "c0") and \
            not speed / C0_FACTOR <= eos["c0"] <= speed * C0_FACTOR:
        problems.add(join(join(path, "eos"), "c0"),
                     f"{eos['c0']:g} is far from the bulk sound speed sqrt(K/density) = "
                     f"{speed:.4g} m/s of the material's moduli (more than a factor "
                     f"{C0_FACTOR:g} apart): c0 is a speed in mm/ms = m/s in {system}")


def bulk_modulus(material):
    """K from the two elastic constants the material gives, or None."""
    given = {k: material[k] for k in catalog.ELASTIC_CONSTANTS if valid(material, k)}
    if len(given) != 2:
        return None
    try:
        K = catalog.elastic_from_any_two(given)[2]
    except ZeroDivisionError:
        return None
    return K if K > 0 else None
