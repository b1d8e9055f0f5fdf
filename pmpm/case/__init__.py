"""The case layer: YAML case files to validated case dicts and typed records, and bodies
to particles.

Pure Python + numpy + PyYAML + meshio; of pmpm it imports only the plain-data material
catalog. Public API:

- :func:`load_case` (path, overrides) -> validated case dict; raises :class:`CaseError`
  listing every problem with its key path.
- :func:`load_config` (path, overrides) -> :class:`CaseConfig`, the validated case as
  frozen records (``config.time.cfl``, ``config.contact.pairs[0].friction``, ...);
  :meth:`CaseConfig.from_case` builds it from a validated case dict.
- :func:`validate_case` the same for a raw tree already in memory (e.g. a stored case).
- :func:`fill_body` (body, grid, case_dir) -> (positions (n, 3), volumes (n,)).

The keys, units and defaults are in the schema tables (``schema.py`` and the modules it
imports); ``docs/case-file.md`` is generated from them by ``python -m
pmpm.case.reference --write``.
"""
from .config import (BodyConfig, CaseConfig, ContactConfig, DecompositionConfig, GridConfig,
                     LoadConfig, OutputConfig, PairConfig, RegionConfig, TimeConfig,
                     TimeFunctionConfig, WindowConfig)
from .errors import CaseError
from .fill import fill_body
from .loader import load_case, load_config
from .schema import FACES, validate_case

__all__ = ["BodyConfig", "CaseConfig", "CaseError", "ContactConfig", "DecompositionConfig",
           "FACES", "GridConfig", "LoadConfig", "OutputConfig", "PairConfig", "RegionConfig",
           "TimeConfig", "TimeFunctionConfig", "WindowConfig", "fill_body", "load_case",
           "load_config", "validate_case"]
