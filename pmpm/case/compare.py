"""What ``--restart`` may change: the differences between the validated case a
checkpoint was written with and the case given now, as dotted key paths.

A restart continues a state already computed from the case it was started with, so only
keys that cannot alter that state may change (:data:`RESTART_MAY_CHANGE`): the end time,
the output settings, how the work is shared among ranks, the title, and the run's limits.
``params`` are not compared themselves: their effect is in the keys that use them.
"""
import json

MISSING = object()   # a key or list item on one side only

#: Key paths (and the prefixes of whole sections, ending in ".") a restart may change.
RESTART_MAY_CHANGE = ("time.end", "time.max_steps", "grid.lost_mass_fraction", "output.",
                      "decomposition.", "title", "units", "params.")


def may_change_text():
    """The keys a restart may change, as the error message lists them."""
    return ", ".join(key + "*" if key.endswith(".") else key
                     for key in RESTART_MAY_CHANGE if key != "params.")


def may_change_on_restart(path):
    """True when the dotted key ``path`` may differ between a checkpoint and a restart."""
    return any(path == key or (key.endswith(".") and path.startswith(key))
               for key in RESTART_MAY_CHANGE)


def show(value):
    """A value as the case file would spell it, short: numbers with 12 significant digits."""
    if value is None:
        return "none"
    if isinstance(value, bool):
        return json.dumps(value)
    if isinstance(value, float):
        return f"{value:.12g}"
    if isinstance(value, (int, str)):
        return str(value)
    if isinstance(value, list) and all(not isinstance(v, (list, dict)) for v in value):
        return "[" + ", ".join(show(v) for v in value) + "]"
    return "{...}" if isinstance(value, dict) else "[...]"


def _scalars_only(value):
    return isinstance(value, list) and all(not isinstance(v, (list, dict)) for v in value)


def differences(old, new, path=""):
    """(dotted path, old value, new value) for every leaf that differs; a key or list item
    present on one side only gives :data:`MISSING` on the other. A list of plain values (a vector,
    a list of times) is one leaf."""
    if isinstance(old, dict) and isinstance(new, dict):
        found = []
        for key in list(old) + [k for k in new if k not in old]:
            sub = f"{path}.{key}" if path else str(key)
            if key not in new or key not in old:
                found.append((sub, old.get(key, MISSING), new.get(key, MISSING)))
            else:
                found += differences(old[key], new[key], sub)
        return found
    if (isinstance(old, list) and isinstance(new, list)
            and not (_scalars_only(old) and _scalars_only(new))):
        found = []
        for i in range(max(len(old), len(new))):
            sub = f"{path}[{i}]"
            if i >= len(old) or i >= len(new):
                found.append((sub, old[i] if i < len(old) else MISSING,
                              new[i] if i < len(new) else MISSING))
            else:
                found += differences(old[i], new[i], sub)
        return found
    if type(old) is not type(new) and isinstance(old, (int, float)) \
            and isinstance(new, (int, float)) and not isinstance(old, bool) \
            and not isinstance(new, bool):
        return [] if old == new else [(path, old, new)]
    return [] if old == new and type(old) is type(new) else [(path, old, new)]


def restart_changes(old, new):
    """(refused, allowed): lists of (path, change) for the differences between the
    validated case of a checkpoint (``old``) and that of the restart (``new``), the
    change spelt ``old -> new``, ``added (new)`` or ``removed (was old)``."""
    refused, allowed = [], []
    for path, before, after in differences(old, new):
        if before is MISSING:
            change = f"added ({show(after)})"
        elif after is MISSING:
            change = f"removed (was {show(before)})"
        else:
            change = f"{show(before)} -> {show(after)}"
        (allowed if may_change_on_restart(path) else refused).append((path, change))
    return refused, allowed
