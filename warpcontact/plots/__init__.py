"""Figures of solved states, after the paper's Figures 1 and 2; a pull-off's force-approach curve
(:func:`pull_off_curve`), a fretting run's loops and energies (:func:`fretting_loop`,
:func:`fretting_energy`), a contact's area, patches and mean gap against the load
(:func:`contact_load`) and a sweep's results against its swept values (:func:`sweep_figure`).

Each function returns a :class:`matplotlib.figure.Figure` drawn with the Agg canvas of its own:
nothing touches pyplot or the global backend. The figures of a solved state are in
``plots.states``, the curves of a pull-off and a fretting run in ``plots.curves``, a sweep's
figures in ``plots.sweeps``, and what they share (the colours, an axis's SI prefix, the PNG
written whole) in ``plots.base``.
"""

from .base import ADHESIVE_COLOR, CONTACT_COLOR, STICK_COLOR, save, si_scale
from .curves import contact_load, fretting_energy, fretting_loop, pull_off_curve
from .states import area_formatter, area_map, field_maps, has_adhesion, profile
from .sweeps import fretting_map, sweep_figure

__all__ = ["area_map", "area_formatter", "contact_load", "field_maps", "fretting_energy", "fretting_loop", "fretting_map", "profile",
           "pull_off_curve", "save", "si_scale", "has_adhesion", "sweep_figure", "CONTACT_COLOR", "STICK_COLOR",
           "ADHESIVE_COLOR"]
