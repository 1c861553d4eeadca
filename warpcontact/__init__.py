"""warpcontact: sphere-on-flat contact with friction and adhesion on NVIDIA Warp (CPU and CUDA).

Boussinesq-Cerruti half-spaces of two dissimilar materials, DC-FFT convolution, projected
conjugate-gradient solvers (Polonsky & Keer 1999; Chen & Wang 2008), displacement-driven loading.
See MODEL.md-level details in docs/ and the README.
"""

__version__ = "0.1.0"

import warp as _wp  # noqa: E402

_wp.config.quiet = True
_wp.config.log_level = _wp.LOG_WARNING  # no banner or per-module compile lines (Warp 1.19 reads log_level)

from .errors import ConvergenceError, InputError, NonFiniteError  # noqa: E402
from .geometry import Grid, Sphere  # noqa: E402
from .materials import COPPER, HARDENED_STEEL, PAPER_PAIR, Material, MaterialPair  # noqa: E402
from .case import Case, case_from_dict, load_case  # noqa: E402
from .api import gross_slip, path, pull_off, solve  # noqa: E402

__all__ = [
    "__version__",
    "Case",
    "case_from_dict",
    "load_case",
    "solve",
    "path",
    "gross_slip",
    "pull_off",
    "InputError",
    "ConvergenceError",
    "NonFiniteError",
    "Grid",
    "Sphere",
    "Material",
    "MaterialPair",
    "COPPER",
    "HARDENED_STEEL",
    "PAPER_PAIR",
]
