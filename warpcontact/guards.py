"""Checks that a solved state can be trusted: the contact must fit in the domain and be resolved."""

from __future__ import annotations

import math
import warnings

import numpy as np

from .errors import InputError

#: contact radius under which a state is called too coarse [cells]
MIN_CONTACT_RADIUS_CELLS = 8


class CoarseGridWarning(UserWarning):
    """The contact spans too few cells for the discretisation error to be small."""


def check_contact_fits(state):
    """InputError (key ``grid.size``) if contact cells touch the edge of the domain: the domain is
    too small for the load, and the DC-FFT solution would miss the contact beyond it."""
    p = state.pressure.numpy()
    edge = np.concatenate([p[0], p[-1], p[:, 0], p[:, -1]])
    if np.any(edge > 0):
        g = state.model.grid
        dx, dy, dz = state.approach
        raise InputError(
            "grid.size",
            f"the contact reaches the edge of the {g.size:.4g} m domain at delta = ({dx:.4g}, {dy:.4g}, {dz:.4g}) m; "
            f"use at least {1.5 * g.size:.4g} m (and more cells to keep the resolution)",
        )


def warn_if_coarse(state):
    """CoarseGridWarning if the contact radius is under MIN_CONTACT_RADIUS_CELLS cells."""
    g = state.model.grid
    cells = int(np.count_nonzero(state.pressure.numpy() > 0))
    if cells == 0:
        return
    radius_cells = math.sqrt(cells / math.pi)
    if radius_cells < MIN_CONTACT_RADIUS_CELLS:
        need = math.ceil(g.n * MIN_CONTACT_RADIUS_CELLS / radius_cells)
        warnings.warn(
            f"the contact radius spans only {radius_cells:.1f} cells (under {MIN_CONTACT_RADIUS_CELLS}): "
            f"results carry a large discretisation error; use grid.n >= {need} for this domain",
            CoarseGridWarning,
            stacklevel=3,
        )
