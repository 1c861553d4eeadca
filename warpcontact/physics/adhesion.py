"""Adhesion laws (MODEL.md section 6).

The adhesive normal problem is one energy minimisation (``warpcontact.solvers.adhesive``): a law
gives its potential, tension and stiffness as a function of the gap in ``kernels/adhesive.py``
(``law_values``, one branch per law), selected by ``normal_law(model)``. To add a law: its branch
there and a small class here with ``normal_law``, ``tangential_opening`` (zero unless the law
couples the opening to the slip), ``range``, ``work_of_adhesion``, ``peak_tension``,
``has_shear`` and ``describe``; a law with an adhesive shear (SMC) also has ``tractions``
(kernels/adhesion.py).
"""

from __future__ import annotations

import math
from dataclasses import dataclass


from warpcontact.kernels import adhesion as ak
from warpcontact.kernels import adhesive as nk

from ..errors import InputError

#: a cell out of contact with a gap under TOUCHING x the law's length is touching: it sits on the
#: model's jump between the law (h = 0+) and the contact side (no adhesive traction), and may
#: carry any traction between the two. Within 1e-2 delta_n the SMC tractions differ from their
#: h = 0 values by under 1e-2 sigma_max; cells there otherwise flip in and out of contact from one
#: turn to the next (measured: the fixed point cycled forever on such cells).
TOUCHING = 1e-2


#: cell_softening above which pull-off warns of lattice trapping (measured, Dugdale, n = 192:
#: lambda = 2 at 4.4: +8 %, approach and retraction 0.1 pi R w apart). Below it the grid still
#: adds a sawtooth to the retraction: refined pull-offs at lambda = 2, n = 192, one centred ramp:
#: +1.6 % at 0.74, +0.4 % at 0.44-0.49, +0.1-0.3 % at 0.37 and below (validation/md_convergence.py)
TRAPPING_SOFTENING = 2.0


def maugis_parameter(law, radius: float, e_star: float) -> float:
    """lambda = sigma_peak (9 R / (2 pi w E*^2))^(1/3) [-]: Maugis's transition parameter with the
    law's peak tension in the place of Dugdale's sigma_0 and its work of adhesion w, for a sphere
    of radius ``radius`` [m] on the pair's E* [Pa]. DMT below about 0.1, JKR above about 5
    (Johnson & Greenwood 1997's adhesion map); about 1.16 Tabor's parameter for the smooth laws.
    Table 2's SMC law: 0.056."""
    w = law.work_of_adhesion
    return law.peak_tension * (9.0 * radius / (2.0 * math.pi * w * e_star**2)) ** (1.0 / 3.0)


def cell_softening(law, model) -> float:
    """How much faster the law's tension can fall with the gap than one cell's elastic stiffness
    E* / (c0 dx) lets the cell follow (c0: a cell's self-compliance in units of dx / E*):
    steepest_softening c0 dx / E* [-]. Above 1 a cell alone has two stable gaps at one load, so
    the discrete contact edge snaps cell by cell and sticks between snaps (lattice trapping:
    approach and retraction part where the continuum has one curve, and the pull-off is too
    tensile). It falls as the grid is refined (dx) or the law made smoother."""
    c0 = model.operator.self_coefficient("zz")
    return law.steepest_softening * c0 * model.grid.dx / model.traction_scale


def trapping_warning(law, model) -> str | None:
    """A warning where ``cell_softening`` passes ``TRAPPING_SOFTENING``, naming the grid that
    brings it to 1 (the same domain) and, for Dugdale, the smoothing that would."""
    kappa = cell_softening(law, model)
    if not kappa > TRAPPING_SOFTENING:
        return None
    if not math.isfinite(kappa):
        return ("adhesion: the sharp Dugdale law (smoothing 0) softens infinitely fast: on a grid the contact "
                "edge sticks between cells (lattice trapping); give adhesion.smoothing >= 0.05")
    n = model.grid.n
    hint = f"n >= {math.ceil(n * kappa)} over the same domain"
    if isinstance(law, Dugdale):
        hint += f", or adhesion.smoothing >= {min(0.95, law.smoothing * kappa):.2g}"
    return (f"adhesion: the law's tension falls {kappa:.1f} times faster than one cell's elastic stiffness "
            f"(cell_softening): cells snap one by one and the contact edge sticks between them (lattice "
            f"trapping: approach and retraction apart, pull-off too tensile; Dugdale lambda = 2 at 4.4: +8 %); "
            f"for 1: {hint}")


def _no_opening(model, state, out):
    """The tangential opening of a law without one: zero."""
    out.zero_()


def _positive(key, v):
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
        raise InputError(key, f"must be a positive finite number, got {v!r}")


@dataclass(frozen=True)
class SMC:
    """McGarry et al. (2014) "separation magnitude coupling" traction-separation law.

    With x_n = h/delta_n, x_t = |s|/delta_t, m = sqrt(x_n^2 + x_t^2):
    p_adh = -sigma_max x_n exp(1 - m), |q_adh| = tau_max x_t exp(1 - m) (resisting the slip).
    McGarry, J. P. et al. (2014), "Potential-based and non-potential-based cohesive zone
    formulations under mixed-mode separation and over-closure", Eng. Fract. Mech. 124, 163-179.

    Attributes:
        sigma_max: peak normal traction [Pa] (reached at h = delta_n, s = 0).
        tau_max: peak shear traction [Pa].
        delta_n: normal characteristic length [m].
        delta_t: tangential characteristic length [m].
        contact_shear: the shear inside the contact (cells with p_c > 0): "bounded" (the
            default), the contact shear alone, bounded by the shear limit as a whole; or
            "added", the law's shear at h = 0 and the cell's slip added to the bounded contact
            shear, as the paper's text reads ("on the first part [A_c] the elastic and adhesive
            tractions apply ... The two components are then added").
    """

    sigma_max: float
    tau_max: float
    delta_n: float
    delta_t: float
    contact_shear: str = "bounded"

    #: the law has an adhesive shear (``tractions`` gives it from the gap and the slip)
    has_shear = True

    def __post_init__(self):
        for k in ("sigma_max", "tau_max", "delta_n", "delta_t"):
            _positive(f"adhesion.{k}", getattr(self, k))
        if self.contact_shear not in CONTACT_SHEAR:
            raise InputError("adhesion.contact_shear", f"unknown choice {self.contact_shear!r}; choose one of "
                                                       f"{', '.join(CONTACT_SHEAR)}")

    @property
    def work_of_adhesion(self) -> float:
        """w = e sigma_max delta_n [J/m^2], the work of pure opening."""
        return math.e * self.sigma_max * self.delta_n

    @property
    def range(self) -> float:
        """Gap [m] up to which a cell counts as adhesive contact (the rising branch: delta_n)."""
        return self.delta_n

    @property
    def peak_tension(self) -> float:
        """Largest normal tension [Pa] (pure opening)."""
        return self.sigma_max

    @property
    def steepest_softening(self) -> float:
        """Largest fall of the normal tension with the gap, -dt/dh [Pa/m] (pure opening, at
        h = 2 delta_n): sigma_max / (e delta_n)."""
        return self.sigma_max / (math.e * self.delta_n)

    def normal_law(self, model):
        """(law id, scaled parameters, scaled length) for the adhesive normal solve."""
        L = model.length_scale
        return int(nk.LAW_SMC), (self.sigma_max / model.traction_scale, self.delta_n / L, 0.0), self.delta_n / L

    def tangential_opening(self, model, state, out):
        """out <- |s| / delta_t of each cell: the normal law at the cell's current slip."""
        model.launch(nk.smc_opening, model.n_cells,
                     [state.slip_x.flatten(), state.slip_y.flatten(), model.scalar(self.delta_t / model.length_scale)],
                     [out.flatten()])

    def tractions(self, model, state, law_pressure, law_shear_x, law_shear_y):
        """The law's tractions (scaled) of the state's gap and slip, on cells out of contact
        (touching cells: see ``TOUCHING``)."""
        s = model.traction_scale
        L = model.length_scale
        model.launch(
            ak.smc_tractions,
            dim=model.n_cells,
            inputs=[
                state.gap.flatten(), state.slip_x.flatten(), state.slip_y.flatten(), state.pressure.flatten(),
                state.adhesive_pressure.flatten(), state.adhesive_shear_x.flatten(), state.adhesive_shear_y.flatten(),
                model.scalar(self.sigma_max / s), model.scalar(self.tau_max / s), model.scalar(self.delta_n / L),
                model.scalar(self.delta_t / L), model.scalar(TOUCHING * self.delta_n / L),
                int(self.contact_shear == "added"),
            ],
            outputs=[law_pressure.flatten(), law_shear_x.flatten(), law_shear_y.flatten()],
        )

    def describe(self) -> dict:
        out = {"law": "smc", "sigma_max": self.sigma_max, "tau_max": self.tau_max, "delta_n": self.delta_n,
               "delta_t": self.delta_t, "work_of_adhesion": self.work_of_adhesion}
        if self.contact_shear != "bounded":
            out["contact_shear"] = self.contact_shear
        return out


#: the SMC law's shear inside the contact (``SMC.contact_shear``)
CONTACT_SHEAR = ("bounded", "added")


#: where the Dugdale law's ramps go (``Dugdale.ramps``; the case file's choices, case.DUGDALE_RAMPS)
RAMPS = ("centred", "both")


def max_smoothing(ramps: str) -> float:
    """The Dugdale smoothing's upper bound (exclusive) [-]: the centred ramp spans
    h_0 (1 -/+ smoothing / 2) and must start above contact (2); the ramps at both ends must not
    overlap (1)."""
    return 2.0 if ramps == "centred" else 1.0


@dataclass(frozen=True)
class Dugdale:
    """Dugdale-Maugis law: tension sigma_0 where 0 < h <= h_0 (Maugis 1992), w = sigma_0 h_0.

    On a grid the law's jumps make cells at the edges of the cohesive zone flip from one
    fixed-point turn to the next, and trap the zone's edge between cells; ``smoothing`` > 0
    replaces them by linear ramps of width smoothing x h_0, which keep w = sigma_0 h_0 exact.
    smoothing = 0 is the sharp law. ``ramps`` places them:

    - "both": a ramp rising from h = 0 and one falling past h_0. The law's centroid moves
      out by smoothing h_0 / 2 and the contact edge carries no tension: the pull-off moves towards
      DMT by O(smoothing) (measured in the continuum, axisymmetric rings, lambda = 2: +1.0 % at
      smoothing 0.1, +1.8 % at 0.3 from Maugis-Dugdale; validation/md_convergence.py).
    - "centred" (default): one ramp, falling from h_0 - smoothing h_0 / 2 to h_0 + smoothing h_0 / 2 (a
      cell's average of the sharp law where the gap varies by that much across it); the tension
      sigma_0 acts from contact on, as Maugis's (the contact cells carry tensions down to
      -sigma_0, the energy minimiser's bound). w is kept and the centroid moves by only
      smoothing^2 h_0 / 24, so the pull-off changes at second order (continuum, lambda = 2:
      +0.014 % at smoothing 0.3, +0.09 % at 0.6, +0.25 % at 1).

    Attributes:
        sigma_0: adhesive tension [Pa].
        h_0: range [m].
        smoothing: ramp width over h_0 [-] (default 0.05; below 2 centred, below 1 at both ends).
        ramps: "centred" (default) or "both".
    """

    sigma_0: float
    h_0: float
    smoothing: float = 0.05
    ramps: str = "centred"

    has_shear = False
    #: the tension ends at a finite gap (range): surfaces beyond it do not interact at all, so the
    #: adhesive zone's forming and breaking are events of the approach-retract path
    finite_range = True

    def __post_init__(self):
        _positive("adhesion.sigma_0", self.sigma_0)
        _positive("adhesion.h_0", self.h_0)
        if self.ramps not in RAMPS:
            raise InputError("adhesion.ramps", f"must be one of {', '.join(map(repr, RAMPS))}, got {self.ramps!r}")
        limit = max_smoothing(self.ramps)
        if not (isinstance(self.smoothing, (int, float)) and 0.0 <= self.smoothing < limit):
            raise InputError("adhesion.smoothing", f"must lie in [0, {limit:g}) with ramps = {self.ramps!r}, "
                                                   f"got {self.smoothing!r}")

    @property
    def centred(self) -> bool:
        return self.ramps == "centred"

    @property
    def work_of_adhesion(self) -> float:
        return self.sigma_0 * self.h_0

    @property
    def range(self) -> float:
        """The largest gap with a tension [m]: h_0 (1 + smoothing), or h_0 (1 + smoothing / 2) centred."""
        return self.h_0 * (1.0 + (0.5 if self.centred else 1.0) * self.smoothing)

    @property
    def peak_tension(self) -> float:
        return self.sigma_0

    @property
    def steepest_softening(self) -> float:
        """-dt/dh on the falling ramp [Pa/m]: sigma_0 / (smoothing h_0); infinite for the sharp law."""
        return self.sigma_0 / (self.smoothing * self.h_0) if self.smoothing > 0 else math.inf

    def normal_law(self, model):
        L = model.length_scale
        law_id = nk.LAW_DUGDALE_CENTRED if self.centred else nk.LAW_DUGDALE
        return (int(law_id), (self.sigma_0 / model.traction_scale, self.h_0 / L, self.smoothing * self.h_0 / L),
                self.h_0 / L)

    def tangential_opening(self, model, state, out):
        _no_opening(model, state, out)

    def tractions(self, model, state, law_pressure, law_shear_x, law_shear_y):
        """The law's tension (scaled) of the state's gap on cells out of contact; no shear."""
        L = model.length_scale
        model.launch(
            ak.dugdale_tractions,
            dim=model.n_cells,
            inputs=[
                state.gap.flatten(), state.pressure.flatten(), state.adhesive_pressure.flatten(),
                model.scalar(self.sigma_0 / model.traction_scale), model.scalar(self.h_0 / L),
                model.scalar(self.smoothing * self.h_0 / L), model.scalar(TOUCHING * self.h_0 / L),
                int(self.centred),
            ],
            outputs=[law_pressure.flatten()],
        )
        law_shear_x.zero_()
        law_shear_y.zero_()

    def describe(self) -> dict:
        return {"law": "dugdale", "sigma_0": self.sigma_0, "h_0": self.h_0, "smoothing": self.smoothing,
                "ramps": self.ramps, "work_of_adhesion": self.work_of_adhesion}


@dataclass(frozen=True)
class _WorkAndLength:
    """What the normal-only laws of a work of adhesion w [J/m^2] and one length L [m] share
    (Exponential, LennardJones93): their checks, the length as their range, the kernel's
    parameters (w and the length in model units), no tangential opening, their description, and
    the scales of their tension: w / L for the largest tension, w / L^2 for the steepest
    softening. Each names its length's field (``LENGTH``), its name in a case file (``NAME``), its
    branch of kernels/adhesive.py (``KERNEL``) and its largest tension and steepest softening in
    those scales (``PEAK``, ``SOFTENING``, dimensionless).

    Attributes:
        work_of_adhesion: w [J/m^2].
    """

    work_of_adhesion: float

    has_shear = False
    LENGTH = NAME = ""
    KERNEL = -1
    PEAK = SOFTENING = math.nan

    def __post_init__(self):
        _positive("adhesion.work_of_adhesion", self.work_of_adhesion)
        _positive(f"adhesion.{self.LENGTH}", getattr(self, self.LENGTH))

    @property
    def range(self) -> float:
        """Gap [m] up to which a cell counts as adhesive contact: the law's length."""
        return getattr(self, self.LENGTH)

    @property
    def peak_tension(self) -> float:
        """The largest tension [Pa]: PEAK w / L."""
        return self.PEAK * self.work_of_adhesion / self.range

    @property
    def steepest_softening(self) -> float:
        """The largest -dt/dh [Pa/m]: SOFTENING w / L^2."""
        return self.SOFTENING * self.work_of_adhesion / self.range**2

    def normal_law(self, model):
        L = model.length_scale
        w = self.work_of_adhesion / (model.traction_scale * L)
        return int(self.KERNEL), (w, self.range / L, 0.0), self.range / L

    def tangential_opening(self, model, state, out):
        _no_opening(model, state, out)

    def describe(self) -> dict:
        return {"law": self.NAME, "work_of_adhesion": self.work_of_adhesion, self.LENGTH: self.range}


@dataclass(frozen=True)
class Exponential(_WorkAndLength):
    """Exponential law: tension t(h) = (w / rho) exp(-h / rho), potential -w exp(-h / rho); the
    largest tension w / rho acts at contact (h = 0), where it softens fastest, -dt/dh = w / rho^2.
    The law of Tamaas's exponential adhesion functional and of the Adhesion package's exponential
    potential.

    Attributes:
        rho: decay length [m].
    """

    rho: float

    LENGTH, NAME, KERNEL = "rho", "exponential", nk.LAW_EXPONENTIAL
    PEAK = SOFTENING = 1.0


@dataclass(frozen=True)
class LennardJones93(_WorkAndLength):
    """Lennard-Jones 9-3 law measured from its equilibrium distance z0 (z = h + z0; the repulsive
    side is the hard wall at h = 0): t = (8 w / 3 z0) ((z0/z)^3 - (z0/z)^9), potential
    -(4 w / 3) ((z0/z)^2 - (z0/z)^8 / 4), so that the work of separation is w and the largest
    tension 16 w / (9 sqrt(3) z0) acts at z = 3^(1/6) z0 (Greenwood, Proc. R. Soc. A 453 (1997)
    1277; the Adhesion package's Lj93 potential). The largest -dt/dh, (8 w / 3 z0^2) max_r
    (3 r^4 - 9 r^10) with r = z0 / z, is reached at r^6 = 2/15: 1.8 (2/15)^(2/3) (8 / 3) w / z0^2.

    Attributes:
        z0: equilibrium distance [m].
    """

    z0: float

    LENGTH, NAME, KERNEL = "z0", "lj93", nk.LAW_LJ93
    PEAK = 16.0 / (9.0 * math.sqrt(3.0))
    SOFTENING = 1.8 * (2.0 / 15.0) ** (2.0 / 3.0) * 8.0 / 3.0
