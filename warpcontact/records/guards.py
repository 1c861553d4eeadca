"""Checks that a solved state can be trusted: the contact must fit in the domain and be resolved,
and the pressure should stay under the bodies' yield strengths.

The resolution rule is one, in :func:`resolution_needs`, used by every command that solves
(through :class:`RunChecks`, which warns at most once per run and names the grid that would do):
cells across the contact radius, across the slip annulus at gross slip and across the adhesive
zone.
"""

from __future__ import annotations

import math
import warnings

from ..physics.geometry import profile_note

# the domain-edge check runs inside the solver's step (after its first turn and at its end), so it
# lives with the state (numerics, below the solvers); its names here are the ones users know
from ..numerics.state import EDGE_SHARE_AT_FIRST_TURN, check_contact_fits  # noqa: F401

#: contact radius under which a state is called too coarse [cells]
MIN_CONTACT_RADIUS_CELLS = 8
#: The results of a gross-slip search, taken from its final bracket: not reported when a state of
#: the path did not converge (the bracket may then be anywhere).
GROSS_SLIP_RESULTS = ("delta_x_max", "delta_x_gross", "mu", "mu_elastic", "force", "force_elastic")
#: The results of an approach-retract curve: not reported when a state of the curve did not converge.
PULL_OFF_RESULTS = ("pull_off_force", "pull_off_delta_z", "pull_off_fit", "pull_off_scatter")


#: adhesive tension on the domain's edge, over the largest anywhere, above which a state warns [-]
ADHESION_EDGE_FRACTION = 0.01
#: gap, in delta_n, where the SMC law's normal traction x e^(1 - x) (x = h / delta_n, peak 1 at
#: x = 1) has fallen to ADHESION_EDGE_FRACTION of its peak: x e^(1 - x) = 0.01 at x = 7.638
SMC_TAIL_IN_DELTA_N = 7.64
#: margin on the suggested domain side [-]
DOMAIN_MARGIN = 1.1


class CoarseGridWarning(UserWarning):
    """The contact spans too few cells for the discretisation error to be small."""


#: a pull-off whose refined states lie farther than this fraction of it from a smooth curve warns
#: (``approach_retract.pull_off_fit``): the grid's jaggedness is then a visible part of the answer
JAGGED_FRACTION = 0.01


def warn_if_jagged_pull_off(result: dict, n: int) -> bool:
    """Warn (:class:`CoarseGridWarning`) where the states around the pull-off scatter by more
    than ``JAGGED_FRACTION`` of it; True where it warned."""
    import warnings

    force, scatter = result.get("pull_off_force"), result.get("pull_off_scatter")
    if force is None or scatter is None or not math.isfinite(scatter) or not scatter > JAGGED_FRACTION * abs(force):
        return False
    warnings.warn(f"the retraction's force is jagged on the {n}-cell grid: states near the pull-off lie up to "
                  f"{100 * scatter / abs(force):.1f} % of it off a smooth curve (the contact edge leaves one ring "
                  f"of cells at a time); the pull-off carries that uncertainty (pull_off_fit: the smooth curve's "
                  f"{result['pull_off_fit']:.4e} N); refine grid.n", CoarseGridWarning, stacklevel=3)
    return True


class YieldWarning(UserWarning):
    """The contact pressure passes a body's yield strength: a real contact yields there."""


class CheckFailedWarning(UserWarning):
    """A check made after the solve (the yield check) failed; the solve's results stand."""


def check_failure(check: dict | None) -> str | None:
    """The reason a yield check failed (``numerics.yielding.state_yield_check``), or None where it
    ran or was skipped."""
    if isinstance(check, dict) and check.get("failed"):
        return str(check.get("reason"))
    return None


class AdhesionAtEdgeWarning(UserWarning):
    """The adhesive law still pulls hard on the domain's edge: the domain cuts off the law's tail."""


#: cells across the slip annulus at gross slip (the contact radius less the stick radius at
#: delta_x_max) under which the friction coefficient is called too coarse
MIN_SLIP_ANNULUS_CELLS = 8
#: cells across the adhesive zone (the ring of A_adh around the contact, or the disc of A_adh
#: without contact) under which the adhesive force is called too coarse
MIN_ADHESIVE_ZONE_CELLS = 3
#: grids suggested are multiples of this many cells
GRID_STEP = 16


def hertz_gap(r: float, a: float, radius: float) -> float:
    """Gap [m] at radius r >= a [m] outside a Hertz contact of radius a [m] on a sphere of
    ``radius`` [m] (Johnson 1985, eq. 3.42b): r^2 / 2R - a^2 / R plus the surface displacement
    (a^2 / pi R) ((2 - rho^2) asin(1 / rho) + sqrt(rho^2 - 1)), rho = r / a."""
    rho = r / a
    u = a * a / (math.pi * radius) * ((2.0 - rho * rho) * math.asin(min(1.0, 1.0 / rho)) + math.sqrt(rho * rho - 1.0))
    return r * r / (2.0 * radius) - a * a / radius + u


def adhesive_zone_estimate(a: float, radius: float, law_range: float) -> float:
    """Width [m] of the ring outside a contact of radius a [m] where the Hertz gap stays under the
    law's range [m]: the adhesive zone of the DMT side (a JKR-side zone is narrower)."""
    lo, hi = a, a + math.sqrt(2.0 * radius * law_range) + a
    while hertz_gap(hi, a, radius) < law_range:
        hi *= 2.0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if hertz_gap(mid, a, radius) < law_range else (lo, mid)
    return lo - a


def resolution_needs(n: int, size: float, contact_radius: float | None = None, slip_annulus: float | None = None,
                     adhesive_zone: float | None = None) -> list:
    """The one resolution rule: which widths [m] span too few cells of an n-cell grid of side
    ``size`` [m]. Returns (what, width [m], cells across it, cells needed, smallest grid.n that
    gives them) for each width under its minimum (MIN_CONTACT_RADIUS_CELLS,
    MIN_SLIP_ANNULUS_CELLS, MIN_ADHESIVE_ZONE_CELLS); [] when every width is resolved. A width of
    None or <= 0 is not judged."""
    dx = size / n
    out = []
    for what, width, minimum in (("the contact radius", contact_radius, MIN_CONTACT_RADIUS_CELLS),
                                 ("the slip annulus at gross slip", slip_annulus, MIN_SLIP_ANNULUS_CELLS),
                                 ("the adhesive zone", adhesive_zone, MIN_ADHESIVE_ZONE_CELLS)):
        if width is None or not width > 0.0:
            continue
        cells = width / dx
        if cells < minimum * (1.0 - 1e-9):  # 24 cells over 3 a: 8 cells, not 7.999999
            need = GRID_STEP * math.ceil(n * minimum / cells / GRID_STEP)
            out.append((what, width, cells, minimum, need))
    return out


def resolution_advice(n: int, size: float, where: str, **widths) -> str | None:
    """One sentence naming every width that is under-resolved (see :func:`resolution_needs`) and
    the grid that resolves them all, or None when the grid is fine. ``where``: the state judged,
    e.g. "at delta_z = 1e-10 m"."""
    needs = resolution_needs(n, size, **widths)
    if not needs:
        return None
    parts = [f"{what} ({width:.3g} m) spans {cells:.1f} cells (under {minimum})"
             for what, width, cells, minimum, _ in needs]
    need = max(nd[-1] for nd in needs)
    return (f"{' and '.join(parts)} {where} on the {n}-cell grid: results carry a large discretisation error; "
            f"use grid.n >= {need} (cells of {size / need:.3g} m) for grid.size = {size:.4g} m")


class RunChecks:
    """The checks of a run that need solved states, each warned about at most once per run.

    - resolution (:func:`resolution_advice`), judged on the states that carry the run's results:
      the deepest normal approach of the path (``observe(..., decisive=True)``) and, for a
      gross-slip search, the slip annulus at delta_x_max (:meth:`gross_slip`);
    - yield: the contact pressure passes a body's yield strength (judged on every state).

    Args:
        case: the run's :class:`~warpcontact.records.case.Case`.
    """

    def __init__(self, case):
        self.case = case
        self.resolution_warned = False
        self.yield_warned = False

    def _adhesive_zone(self, s: dict, contact_radius: float):
        ad = self.case.adhesion
        if ad is None:
            return None
        if s.get("adhesive_area", 0.0) > 0.0:
            return math.sqrt((s["adhesive_area"] + s["contact_area"]) / math.pi) - contact_radius
        if contact_radius > 0.0:  # no adhesive cell: the zone is narrower than a cell; estimate it
            law_range = ad.length
            if law_range and self.case.sphere.hertzian:  # (the estimate is the Hertz gap's)
                return adhesive_zone_estimate(contact_radius, self.case.sphere.radius, law_range)
        return None

    def _where(self, s: dict) -> str:
        d = s["delta"]
        return f"at delta_z = {d['z']:.4g} m" + (f", delta_x = {d['x']:.4g} m" if d["x"] else "")

    def observe(self, s: dict, decisive: bool = False) -> None:
        """After each solved state (its summary ``s``): the yield check; with ``decisive`` (the
        deepest normal approach) the resolution of the contact radius and the adhesive zone."""
        self._check_yield(s)
        if decisive and not self.resolution_warned:
            a = s.get("contact_radius", 0.0)
            self._warn(resolution_advice(self.case.grid.n, self.case.grid.size, self._where(s), contact_radius=a,
                                         adhesive_zone=self._adhesive_zone(s, a)))

    def gross_slip(self, r: dict) -> None:
        """After a gross-slip search (its result ``r``): the slip annulus at delta_x_max (the
        contact radius less the stick radius there)."""
        if self.resolution_warned or r.get("contact_area") is None:
            return
        a = math.sqrt(r["contact_area"] / math.pi)
        annulus = a - math.sqrt((r.get("stick_area") or 0.0) / math.pi)
        where = f"at delta_x_max = {r['delta_x_max']:.4g} m" if r.get("delta_x_max") else "at gross slip"
        self._warn(resolution_advice(self.case.grid.n, self.case.grid.size, where, slip_annulus=annulus))

    def decisive(self, s: dict) -> bool:
        """True for a state at the path's deepest normal approach (the contact is largest there)."""
        dz_max = self.case.load.delta_z_max
        return s["delta"]["z"] >= dz_max - 1e-9 * abs(dz_max)

    def _warn(self, text):
        if text:
            self.resolution_warned = True
            warnings.warn(text, CoarseGridWarning, stacklevel=4)

    def yielded(self, check: dict | None, where) -> None:
        """After the stress check of a run's final state (``yielding.yield_check``; ``where``: the
        state's summary, or words naming it): the yield warning (:func:`yield_below_text`), unless
        this run warned of yield already (the contact pressure above a yield strength): one warning
        of yield per run."""
        failure = check_failure(check)
        if failure is not None:
            warnings.warn(f"{failure} {self._where(where) if isinstance(where, dict) else where}; the solve's results "
                          "stand, yielded = null", CheckFailedWarning, stacklevel=3)
            return
        if self.yield_warned:
            return
        text = yield_below_text(check, self._where(where) if isinstance(where, dict) else where)
        if text:
            self.yield_warned = True
            warnings.warn(text, YieldWarning, stacklevel=3)

    def _check_yield(self, s: dict) -> None:
        if self.yield_warned:
            return
        p = s.get("max_pressure", 0.0)
        pair, fr = self.case.pair, self.case.friction
        over = [m for m in (pair.sphere, pair.flat) if p > m.yield_strength]
        if not over:
            return
        self.yield_warned = True
        names = " and ".join(f"{m.name}.yield_strength = {m.yield_strength:.4g} Pa" for m in over)
        why = ""
        if fr is not None and fr.law == "tabor" and pair.softer in over:
            why = ("; the Tabor law's von Mises limit k_vm sqrt(S_Y^2 - p^2) of the softer body is zero where p >= "
                   "S_Y, so that zone carries no shear and lowers mu")
        warnings.warn(f"the contact pressure reaches {p:.4g} Pa {self._where(s)}, above {names}: a real contact "
                      f"yields there (this model stays elastic){why}", YieldWarning, stacklevel=3)


def yield_below_text(check: dict | None, where: str) -> str | None:
    """One line naming each body whose largest von Mises stress (``yielding.yield_check``) reaches its
    yield strength at the state ``where`` names, or None when none does (or the check did not run)."""
    if not check or not check.get("yielded"):
        return None
    parts = [f"the {name}'s von Mises stress reaches {b['von_mises_max']:.4g} Pa at depth {b['z']:.3g} m, "
             f"above {name}.yield_strength = {b['yield_strength']:.4g} Pa (margin {b['margin']:.3g})"
             for name in ("sphere", "flat") if isinstance(b := check.get(name), dict) and b.get("yielded")]
    return f"{' and '.join(parts)} {where}: the body yields there (this model stays elastic)"


def adhesion_tail(adhesion) -> float:
    """Gap [m] beyond which the law's normal traction is under ADHESION_EDGE_FRACTION of its peak:
    SMC_TAIL_IN_DELTA_N delta_n for SMC (pure opening); the range for a law that is zero beyond
    it (Dugdale: h_0 (1 + smoothing))."""
    from ..physics.adhesion import SMC

    return SMC_TAIL_IN_DELTA_N * adhesion.delta_n if isinstance(adhesion, SMC) else adhesion.range


def suggested_adhesive_size(radius: float, delta_z: float, adhesion) -> float:
    """Smallest domain side [m] that holds the law's tail at normal approach ``delta_z`` [m] of a
    sphere of ``radius`` [m]: the rigid paraboloid's gap r^2 / 2R - delta_z reaches the tail's
    gap at r_edge = sqrt(2 R (delta_z + tail)); side = 2 r_edge DOMAIN_MARGIN. (The bodies'
    deformation opens the gap outside the contact, so the rigid gap errs on the large side.)
    Other shapes: :func:`suggested_shape_size`."""
    return 2.0 * DOMAIN_MARGIN * math.sqrt(2.0 * radius * max(0.0, delta_z + adhesion_tail(adhesion)))


def grid_holding(n: int, size: float, need: float):
    """The grid of ``n`` cells over ``size`` [m], grown to a side of at least ``need`` [m] with the
    cell side kept: the cell count rises to a fast FFT length (``scipy.fft.next_fast_len``) and
    the side with it. ``need`` <= ``size`` leaves the grid as it is.
    Returns a :class:`~warpcontact.physics.geometry.Grid`."""
    from ..physics.geometry import Grid

    if need > size:
        from scipy.fft import next_fast_len

        grown = next_fast_len(math.ceil(n * need / size))
        size *= grown / n
        n = grown
    return Grid(n, size)


def suggested_shape_size(shape, delta_z: float, adhesion) -> float | None:
    """:func:`suggested_adhesive_size` for any shape (a :class:`~warpcontact.physics.geometry.Sphere`):
    r_edge = ``shape.gap_radius(delta_z + tail)``, where the rigid profile's gap reaches the tail's
    (a sphere's: sqrt(2 R (delta_z + tail))); None for a height map."""
    r_edge = shape.gap_radius(delta_z + adhesion_tail(adhesion))
    return None if r_edge is None else 2.0 * DOMAIN_MARGIN * r_edge


def warn_if_adhesion_at_edge(state, adhesion, delta_z: float | None = None) -> bool:
    """AdhesionAtEdgeWarning if the adhesive tension on the domain's edge cells exceeds
    ADHESION_EDGE_FRACTION of the largest adhesive tension anywhere. The domain then cuts off the
    law's tail, and the adhesive force it would add beyond the edge is missing from the total
    force (the pull-off force, the friction coefficient). The message names ``grid.size`` and
    suggests a side from :func:`suggested_adhesive_size` at ``delta_z`` [m] (default: the state's;
    give the deepest approach of the path). Returns whether it warned (a path warns once). A body
    given as a height map (``profile = "height_map"``) is its map, with nothing beyond the domain:
    its adhesion at the edge is the map's own, and no tail is cut."""
    if adhesion is None or state.model.sphere.fills_domain:
        return False
    from warpcontact.kernels.summary import S_MAX_TENSION

    from .results import summary_sums
    from ..numerics.state import domain_edge

    # p_adh / E* <= 0: tension positive; the peak reduced and the edge gathered on the device
    peak = float(summary_sums(state, adhesion)[S_MAX_TENSION])
    if not peak > 0.0:
        return False
    edge = float((-domain_edge(state.adhesive_pressure)).max())
    if not edge > ADHESION_EDGE_FRACTION * peak:
        return False
    m = state.model
    dz = state.approach[2] if delta_z is None else delta_z
    need = suggested_shape_size(m.sphere, dz, adhesion)
    if need is None or not need > m.grid.size:  # the deformed gap closes faster than the rigid estimate: grow by half
        need = 1.5 * m.grid.size
    warnings.warn(
        f"the adhesive tension on the edge of the {m.grid.size:.4g} m domain is {100 * edge / peak:.0f} % of its "
        f"peak at delta_z = {state.approach[2]:.4g} m: the domain cuts off the adhesive law's tail, which changes "
        f"the total adhesive force; use grid.size >= {need:.4g} m{profile_note(need, m.sphere)} "
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
