"""The case layer: YAML case files to validated case dicts, and bodies to particles.

Pure Python + numpy + PyYAML + meshio; of pmpm it imports only the plain-data material
catalog. Public API:

- :func:`load_case` (path, overrides) -> validated case dict; raises :class:`CaseError`
  listing every problem with its key path.
- :func:`validate_case` the same for a raw tree already in memory (e.g. a stored case).
- :func:`fill_body` (body, grid, case_dir) -> (positions (n, 3), volumes (n,)).

The keys, units and defaults are documented in the README ("The case file").
"""
from .errors import CaseError
from .fill import fill_body
from .loader import load_case
from .schema import validate_case

__all__ = ["CaseError", "fill_body", "load_case", "validate_case"]
