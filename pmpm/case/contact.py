"""The ``contact:`` section: multi-velocity grid contact (seed 001 Secs. 2-4).

    contact:
      method: 2             # none (one shared velocity field: standard MPM), 1 or 2
      friction: 0.1         # Coulomb coefficient of every pair not listed below
      normal: average       # collinear normals: average (Eq. 10), stiffer, or a body name
      separation: 0.9       # optional: contact only where the bodies are at most 0.9
                            # cells apart at a node (absent or none: the paper's detection)
      pairs:                # optional: per pair of bodies
        - bodies: [ball, plate]
          friction: 0.0
          normal: ball      # the named body's own normal (Sec. 2.3 choices 1 and 2)
          separation: 0.9

With method 1 or 2 every body has its own velocity field at nodes that two or more
bodies reach, and every pair of bodies is in contact.
"""
from .errors import join, unknown_name
from .fields import (INVALID, OMIT, Field, at_least, boolean, greater, list_of, number,
                     read_mapping, text, valid)

METHODS = {"none": 0, "0": 0, "1": 1, "2": 2}
NORMAL_RULES = ("average", "stiffer")


def read_method(raw, path, problems):
    key = str(raw).strip().lower()
    if key not in METHODS:
        problems.add(path, f"must be none, 1 or 2 (seed 001 Secs. 3.1 and 3.2); got {raw!r}")
        return INVALID
    return METHODS[key]


def read_pair_bodies(raw, path, problems):
    if not (isinstance(raw, list) and len(raw) == 2 and all(isinstance(b, str) for b in raw)):
        problems.add(path, f"expected two body names, e.g. [ball, plate]; got {raw!r}")
        return INVALID
    if raw[0] == raw[1]:
        problems.add(path, f"a body cannot be in contact with itself ({raw[0]!r})")
        return INVALID
    return list(raw)


def read_separation(raw, path, problems):
    """Cells > 0, or none (null): no separation check, the paper's detection."""
    if raw is None or str(raw).strip().lower() == "none":
        return None
    return number(greater(0))(raw, path, problems)


FRICTION = Field(number(at_least(0)), 0.0)
SEPARATION = Field(read_separation, OMIT)
PAIR = {"bodies": Field(read_pair_bodies), "friction": Field(number(at_least(0)), OMIT),
        "normal": Field(text(), OMIT), "separation": SEPARATION}


def read_pair(raw, path, problems):
    return read_mapping(raw, path, PAIR, problems)


CONTACT = {"method": Field(read_method, 0), "friction": FRICTION,
           "skip_separating": Field(boolean(), False),
           "normal": Field(text(), "average"), "separation": SEPARATION,
           "pairs": Field(list_of(read_pair, 0, "pair"), [])}


def read_contact(raw, path, problems):
    return read_mapping(raw, path, CONTACT, problems)


def check_contact(contact, body_names, problems):
    """Pairs name known bodies, each pair once; normals name a rule or a body of the pair."""
    if contact is INVALID:
        return
    if valid(contact, "normal") and contact["normal"] not in NORMAL_RULES:
        problems.add("contact.normal", f"must be average or stiffer (a body's own normal is "
                     f"chosen per pair); got {contact['normal']!r}")
    pairs = contact.get("pairs")
    if not isinstance(pairs, list):
        return
    seen = {}
    for i, pair in enumerate(pairs):
        path = join("contact.pairs", i)
        if pair is INVALID or not valid(pair, "bodies"):
            continue
        known = True
        for j, name in enumerate(pair["bodies"]):
            if name not in body_names:
                problems.add(join(join(path, "bodies"), j), unknown_name("body", name, body_names))
                known = False
        key = frozenset(pair["bodies"])
        if key in seen:
            problems.add(join(path, "bodies"), f"pair listed twice (also contact.pairs[{seen[key]}])")
        seen.setdefault(key, i)
        normal = pair.get("normal")
        if known and normal is not None and normal is not INVALID \
                and normal not in NORMAL_RULES and normal not in pair["bodies"]:
            problems.add(join(path, "normal"),
                         f"must be average, stiffer or one of the pair's bodies "
                         f"{pair['bodies']}; got {normal!r}")
