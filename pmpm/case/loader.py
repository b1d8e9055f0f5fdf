"""``load_case``: a case file, plus ``--set`` overrides, to a validated case dict;
``load_config``: the same as frozen records."""
import os

from .config import CaseConfig
from .errors import Problems
from .schema import validate_case
from .yamlio import read_yaml_file


def load_case(path, overrides=(), check_geometry=True):
    """Read, override, substitute, validate and complete the case file at ``path``.

    Parameters
    ----------
    path : str or path-like
        The YAML case file. Mesh file names in it are relative to its folder.
    overrides : iterable of str
        ``"KEY=VALUE"`` strings from ``--set`` (``params.cell=0.38``,
        ``bodies[0].velocity=[0,0,-190]``); VALUE is parsed as YAML.
    check_geometry : bool
        Fill every body to check that it is not empty and lies inside the grid box
        (and that mesh files can be read). Without it only mesh files' existence is checked.

    Returns
    -------
    dict
        The validated case with every default filled: plain dicts, lists, floats, ints,
        strings and bools (no numpy), the same when validated again.

    Raises
    ------
    CaseError
        With ``problems``, one ``"key.path: message"`` line per problem, all of them.
    """
    raw, duplicate_keys = read_yaml_file(path)
    problems = Problems()
    for line in duplicate_keys:
        problems.add("", line)
    case_dir = os.path.dirname(os.path.abspath(path))
    title = os.path.splitext(os.path.basename(path))[0]
    return validate_case(raw, case_dir, title, overrides, check_geometry, problems)


def load_config(path, overrides=(), check_geometry=True):
    """``CaseConfig`` of the case file at ``path`` (the arguments and errors of
    ``load_case``)."""
    return CaseConfig.from_case(load_case(path, overrides, check_geometry))
