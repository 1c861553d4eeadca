"""Checks that a solved state can be trusted: the contact must fit in the domain and be resolved."""

from __future__ import annotations

import math
import warnings

import numpy as np

from .errors import InputError

#: contact radius under which a state is called too coarse [cells]
MIN_CONTACT_RADIUS_CELLS = 8
#: The results of a gross-slip search, taken from its final bracket: not reported when a state of
#: the path did not converge (the bracket may then be anywhere).
GROSS_SLIP_RESULTS = ("delta_x_max", "delta_x_gross", "mu", "mu_elastic", "force", "force_elastic")
#: The results of an approach-retract curve: not reported when a state of the curve did not converge.
PULL_OFF_RESULTS = ("pull_off_force", "pull_off_delta_z")


#: adhesive tension on the domain's edge, over the largest anywhere, above which a state warns [-]
ADHESION_EDGE_FRACTION = 0.01
#: gap, in delta_n, where the SMC law's normal traction x e^(1 - x) (x = h / delta_n, peak 1 at
#: x = 1) has fallen to ADHESION_EDGE_FRACTION of its peak: x e^(1 - x) = 0.01 at x = 7.638
SMC_TAIL_IN_DELTA_N = 7.64
#: margin on the suggested domain side [-]
DOMAIN_MARGIN = 1.1


class CoarseGridWarning(UserWarning):
    """The contact spans too few cells for the discretisation error to be small."""


class AdhesionAtEdgeWarning(UserWarning):
    """The adhesive law still pulls hard on the domain's edge: the domain cuts off the law's tail."""


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


def adhesion_tail(adhesion) -> float:
    """Gap [m] beyond which the law's normal traction is under ADHESION_EDGE_FRACTION of its peak:
    SMC_TAIL_IN_DELTA_N delta_n for SMC (pure opening); the range for a law that is zero beyond
    it (Dugdale: h_0 (1 + smoothing))."""
    from .adhesion import SMC

    return SMC_TAIL_IN_DELTA_N * adhesion.delta_n if isinstance(adhesion, SMC) else adhesion.range


def suggested_adhesive_size(radius: float, delta_z: float, adhesion) -> float:
    """Smallest domain side [m] that holds the law's tail at normal approach ``delta_z`` [m] of a
    sphere of ``radius`` [m]: the rigid paraboloid's gap r^2 / 2R - delta_z reaches the tail's
    gap at r_edge = sqrt(2 R (delta_z + tail)); side = 2 r_edge DOMAIN_MARGIN. (The bodies'
    deformation opens the gap outside the contact, so the rigid gap errs on the large side.)"""
    return 2.0 * DOMAIN_MARGIN * math.sqrt(2.0 * radius * max(0.0, delta_z + adhesion_tail(adhesion)))


def warn_if_adhesion_at_edge(state, adhesion, delta_z: float | None = None) -> bool:
    """AdhesionAtEdgeWarning if the adhesive tension on the domain's edge cells exceeds
    ADHESION_EDGE_FRACTION of the largest adhesive tension anywhere. The domain then cuts off the
    law's tail, and the adhesive force it would add beyond the edge is missing from the total
    force (the pull-off force, the friction coefficient). The message names ``grid.size`` and
    suggests a side from :func:`suggested_adhesive_size` at ``delta_z`` [m] (default: the state's;
    give the deepest approach of the path). Returns whether it warned (a path warns once)."""
    if adhesion is None:
        return False
    tension = -state.adhesive_pressure.numpy()  # p_adh / E* <= 0: tension positive
    peak = float(tension.max())
    if not peak > 0.0:
        return False
    edge = float(np.concatenate([tension[0], tension[-1], tension[:, 0], tension[:, -1]]).max())
    if not edge > ADHESION_EDGE_FRACTION * peak:
        return False
    m = state.model
    dz = state.approach[2] if delta_z is None else delta_z
    need = suggested_adhesive_size(m.sphere.radius, dz, adhesion)
    if not need > m.grid.size:  # the deformed gap closes faster than the rigid estimate: grow by half
        need = 1.5 * m.grid.size
    warnings.warn(
        f"the adhesive tension on the edge of the {m.grid.size:.4g} m domain is {100 * edge / peak:.0f} % of its "
        f"peak at delta_z = {state.approach[2]:.4g} m: the domain cuts off the adhesive law's tail, which changes "
        f"the total adhesive force; use grid.size >= {need:.4g} m "
        f"(and grid.n to match, to keep the resolution)",
        AdhesionAtEdgeWarning,
        stacklevel=3,
    )
    return True


def withhold_if_unconverged(result: dict, keys) -> dict:
    """``result`` with ``keys`` set to None and a ``note`` naming them when ``result["converged"]``
    is false: values built on an unconverged state are not reported as numbers. Returns a new
    dict (the same one when converged); the states listed in it keep their own ``converged``."""
    if result["converged"]:
        return result
    names = " and ".join(filter(None, (", ".join(keys[:-1]), keys[-1])))
    return {**result, **{k: None for k in keys},
            "note": f"a state on the path did not converge: {names} {'are' if len(keys) > 1 else 'is'} not reported"}
