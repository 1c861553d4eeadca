"""warpcontact: sphere-on-flat contact with friction and adhesion on NVIDIA Warp (CPU and CUDA).

Boussinesq-Cerruti half-spaces of two dissimilar materials, DC-FFT convolution, projected
conjugate-gradient solvers (Polonsky & Keer 1999; Chen & Wang 2008), displacement-driven loading.
See MODEL.md-level details in docs/ and the README.
"""

from ._version import __version__  # noqa: F401  (kept in sync with pyproject.toml)

from typing import TYPE_CHECKING

if TYPE_CHECKING:  # for readers, type checkers and the documentation's static analysis
    from .api import fretting, gross_slip, path, pull_off, solve, solve_batch
    from .records.case import Case, case_from_dict, load_case
    from .errors import ConvergenceError, InputError, NonFiniteError
    from .physics.geometry import Grid, Sphere
    from .physics.roughness import rough_surface, surface_statistics
    from .physics.materials import COPPER, HARDENED_STEEL, PAPER_PAIR, Material, MaterialPair
    from .studies.stress_study import subsurface_stress

# The names below are imported when first used (PEP 562), so that `warpcontact --help` and the
# command line's argument parsing do not import Warp, SciPy and the solvers (a second or so).
_LAZY = {
    "ConvergenceError": "errors", "InputError": "errors", "NonFiniteError": "errors",
    "Grid": "physics.geometry", "Sphere": "physics.geometry",
    "rough_surface": "physics.roughness", "surface_statistics": "physics.roughness",
    "COPPER": "physics.materials", "HARDENED_STEEL": "physics.materials", "PAPER_PAIR": "physics.materials",
    "Material": "physics.materials",
    "MaterialPair": "physics.materials",
    "Case": "records.case", "case_from_dict": "records.case", "load_case": "records.case",
    "gross_slip": "api", "path": "api", "pull_off": "api", "solve": "api", "solve_batch": "api", "fretting": "api",
    "subsurface_stress": "studies.stress_study",
}


def quiet_warp():
    """Warp without its banner and per-module compile lines (Warp 1.19 reads log_level); called
    before Warp is initialised (device.init_warp, and on the first use of the names above)."""
    import warp as wp

    wp.config.quiet = True
    wp.config.log_level = wp.LOG_WARNING


def __getattr__(name):
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'warpcontact' has no attribute {name!r}")
    import importlib

    quiet_warp()
    value = getattr(importlib.import_module(f".{module}", __name__), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted([*globals(), *_LAZY])


__all__ = [
    "__version__",
    "Case",
    "case_from_dict",
    "load_case",
    "solve",
    "solve_batch",
    "path",
    "gross_slip",
    "pull_off",
    "fretting",
    "subsurface_stress",
    "rough_surface",
    "surface_statistics",
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
