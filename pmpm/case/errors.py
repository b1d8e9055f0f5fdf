"""The case layer's error type and the problem list every validation step appends to."""
import difflib


class CaseError(Exception):
    """A case file that cannot be run.

    ``problems`` lists every problem found, each as ``"key.path: message"``
    (for example ``"bodies[1].material: unknown material 'stel'; known: copper, steel"``).
    Likely causes: a typo in a key or a name, a missing required key, a value out of its
    physical range, a ``--set`` override naming a key that does not exist, a mesh file that
    cannot be read, or a body that does not fit inside the grid box.
    """

    def __init__(self, problems):
        self.problems = list(problems)
        super().__init__(str(self))

    def __str__(self):
        return "\n".join(self.problems)


class Problems:
    """Collects ``"path: message"`` lines so that all problems are reported at once."""

    def __init__(self):
        self.lines = []

    def add(self, path, message):
        self.lines.append(f"{path}: {message}" if path else message)

    def __len__(self):
        return len(self.lines)

    def raise_if_any(self):
        if self.lines:
            raise CaseError(self.lines)


def join(path, key):
    """The key path of ``key`` under ``path``: ``join("bodies", 1) == "bodies[1]"``."""
    if isinstance(key, int):
        return f"{path}[{key}]"
    return f"{path}.{key}" if path else str(key)


def did_you_mean(word, choices):
    """`` (did you mean 'x'?)`` when a choice is close to ``word`` (or equal but for
    case: ``FEM`` for ``fem``), else ``""``."""
    names = [str(c) for c in choices]
    close = [c for c in names if c.lower() == str(word).lower()]
    close = close or difflib.get_close_matches(str(word), names, n=1, cutoff=0.6)
    return f" (did you mean {close[0]!r}?)" if close else ""


def unknown_name(what, word, choices):
    """``unknown material 'stel'; known: copper, steel (did you mean 'steel'?)``."""
    known = ", ".join(sorted(str(c) for c in choices)) or "none"
    return f"unknown {what} {word!r}; known: {known}{did_you_mean(word, choices)}"


def describe(value):
    """A short description of a wrong value for an error message."""
    if value is None:
        return "nothing"
    text = repr(value)
    text = text if len(text) <= 40 else text[:37] + "..."
    return f"{type(value).__name__} {text}"
