"""How the solvers solve: one frozen settings object, chosen when a solver is made.

Every solver of a step (the coupled [`ContactSolver`][warpcontact.solvers.contact.ContactSolver], its
normal, tangential and adhesive solvers, the windows and the coarse grids of the nested start)
takes the same [`SolverSettings`][warpcontact.solvers.settings.SolverSettings]. A choice is fixed for the solver's life: the captured CUDA
graphs of a solver are built from it, so nothing a graph depends on can change after. To solve with
other settings, make another solver (``dataclasses.replace(settings, ...)`` gives the settings).
"""

from __future__ import annotations

import difflib
import math
from dataclasses import dataclass, fields, replace
from typing import Literal, get_args

#: how the lagged turns set their inner tolerance (``SolverSettings.turn_tolerance``)
TurnTolerance = Literal["residual", "change", "exact"]
#: the turns of a step with adhesion and friction (``SolverSettings.turns``)
Turns = Literal["auto", "lagged", "minimised"]
#: a speed-up chosen by the grid and the device (``"auto"``) or forced on or off
Choice = Literal["auto", True, False]
#: where the preconditioners' circulants live (``SolverSettings.preconditioner_grid``)
PreconditionerGrid = Literal["periodic", "padded"]
#: ``preconditioner_float32 = "auto"`` (the default): the preconditioners' transforms in float32
#: from these cells per side of a solver's grid (a window's own) on, by device kind; None: never
#: (docs/performance.md, "The preconditioners in float32": on an H200 Figure 2c and 2d at n = 2048
#: and 4096 (windows of 1280-2560) 5-29 % faster, at n = 1024 (windows of 512-640) no faster; on 2
#: CPU cores Figure 2c at n = 1024 (windows of 512-640) 12 % faster, at 256 and 512 within the
#: runs' spread)
PRECONDITIONER_FLOAT32_AUTO = {"cpu": 512, "cuda": 2048}
#: ``response_float32 = "auto"`` (the default): the tangential solves' responses K t in float32
#: from these cells per side of a solver's grid or window on, by device kind; None: never
#: (docs/performance.md, "The tangential responses in float32": on an H200 Figure 2c and 2d at
#: n = 4096 (windows of 2560) 0.90-0.94 of the time, at 2048 (windows of 1024-1280) 0.89-0.96, at
#: 1024 (windows of 512-640) within the runs' spread; on 2 CPU cores Figure 2c at n = 512 (windows
#: of 256-320) 0.96)
RESPONSE_FLOAT32_AUTO = {"cpu": 512, "cuda": 1024}
#: ``nested_float32 = "auto"`` (the default): the nested start's coarse grids in float32 where the
#: fine grid has at least these cells per side, by device kind; None: never (docs/performance.md,
#: "The nested start's coarse grids in float32")
NESTED_FLOAT32_AUTO = {"cpu": 1024, "cuda": None}


@dataclass(frozen=True)
class SolverSettings:
    """The choices of the solvers (numbers without units are relative, [-]).

    Attributes:
        tol: relative residual of the conjugate-gradient solves; None: 1e-10 in float64, 1e-5 in
            float32.
        outer_tol: relative change of the tractions that ends a step's turns; None: 100 tol.
        max_iter: iteration limit of each conjugate-gradient solve.
        max_turns: limit on the turns of a step (1000: the adhesive fixed point at Tabor
            parameter 5.7 took 493 turns, the Table 2 cells fewer than 200).
        normal_preconditioner: precondition the normal solves with the circulant inverse of their
            operator (``NormalSolver``); False: Polonsky & Keer's iteration as published.
        tangential_preconditioner: precondition the tangential solves likewise on their stick
            cells (``TangentialSolver``); False: Chen & Wang's iteration with Jacobi scaling.
        one_convolution: the normal solve carries its gap between exact recomputations (one
            convolution an iteration); False: K p recomputed at every iteration.
        exact_every: iterations between exact recomputations of a carried gap (normal and
            tangential solves).
        deferral: a carried gap is made exact once the bound on what the projections changed
            since exceeds this share of the violation; 0: after every projection.
        fourier_step_sums: the normal solve sums g . t and (K t) . t in Fourier space, one pass
            over the grid less; None: on CUDA (where it pays), not on the CPU.
        iterations_per_launch: iterations of a solve's device loop between two looks of the host
            (interrupts); the results do not depend on it.
        turn_tolerance: the lagged turns' inner tolerance: "residual" (1/100 of the coupled
            residual of the last turn, never looser than the turn before), "change" (1/100 of the
            last turn's change) or "exact" (every turn at ``tol``).
        turns: the turns of a step with adhesion and friction: "lagged" (the adhesive tractions a
            fixed point of their own), "minimised" (each turn's normal solve the whole adhesive
            minimisation) or "auto" (by the law's Maugis parameter; lagged with a hardness cap).
        turn_mixing: Anderson mixing of the minimised turns' shear; False: the plain fixed point.
        relax: mixing factor of the adhesive fixed point (``AndersonMixing``'s beta), in (0, 1].
        nested: start each step with friction and no adhesion from its solution on the grid of
            half the cells per side, itself started so in turn (True: down to 64 cells); "auto":
            from ``NESTED_AUTO_N`` cells per side (by device), each coarse grid by its own size.
        nested_float32: in a float64 model, the nested start's coarse grids are solved in float32
            (their tolerance ``NESTED_COARSE_TOL``, 1e-6, within float32's reach): they only start
            the fine step, whose own solves and tolerance set the answer. "auto": from
            ``NESTED_FLOAT32_AUTO`` cells per side of the fine grid on. No effect in a float32
            model.
        window: solve the shear and the pressure on the smallest window of the grid that holds
            the contact (the pressure's answer judged on the whole grid); "auto": the shear from
            ``WINDOW_AUTO_N`` cells per side, the pressure from ``NORMAL_WINDOW_AUTO_N`` (by
            device).
        preconditioner_float32: in a float64 model, the normal and tangential solves'
            preconditioners (the circulant inverses of K_zz and K_tt) transform in float32: half
            their transforms' bytes, the iterations' sums and updates still float64; "auto":
            from 2048 cells per side of the solver's grid or window on CUDA, 512 on the CPU
            (``PRECONDITIONER_FLOAT32_AUTO``). No effect in a float32 model.
        response_float32: in a float64 model, the tangential solves' product of the operator
            with the conjugate direction (its response K t, which the step length and the carried
            gradient take) transforms in float32 on the padded grid; the gradient made exact
            (K q in float64) every ``exact_every`` iterations and where the loop settles, and the
            solve judged on it: the same tolerance met, in float64. "auto": from
            ``RESPONSE_FLOAT32_AUTO`` cells per side of the solver's grid or window on. No effect
            in a float32 model.
        preconditioner_grid: the grid of the preconditioners' circulants: "periodic" (T. Chan's
            optimal circulants of K_zz and K_tt on the solver's own grid or window, transforms of
            n^2 entries), or "padded" (the DC-FFT's circulant on the padded grid, 4 n^2: the
            operator's own spectra inverted). The FFT backend ``warp`` has no periodic transforms
            and runs "padded" either way.
        window_turns: with the pressure solved on windows (``window``), a step with friction and
            without adhesion solves its later turns' pressure on its first turn's window alone,
            with the shear's normal displacement made there, and judges it on the whole grid once,
            at the step's end (where the turns converged and the whole grid moves it, a contact
            grown past the window, the turns again, each judged); False: every turn's pressure
            judged on the whole grid.
        use_graphs: replay solves as captured CUDA graphs; None: where the device supports the
            conditional graph nodes they need (CUDA 12.4+).
    """

    tol: float | None = None
    outer_tol: float | None = None
    max_iter: int = 2000
    max_turns: int = 1000
    normal_preconditioner: bool = True
    tangential_preconditioner: bool = True
    one_convolution: bool = True
    exact_every: int = 50
    deferral: float = 0.1
    fourier_step_sums: bool | None = None
    iterations_per_launch: int = 64
    turn_tolerance: TurnTolerance = "residual"
    turns: Turns = "auto"
    turn_mixing: bool = True
    relax: float = 0.5
    nested: Choice = "auto"
    nested_float32: Choice = "auto"
    window: Choice = "auto"
    preconditioner_float32: Choice = "auto"
    preconditioner_grid: PreconditionerGrid = "periodic"
    response_float32: Choice = "auto"
    window_turns: bool = True
    use_graphs: bool | None = None

    def __post_init__(self):
        for name in ("tol", "outer_tol"):
            value = getattr(self, name)
            if value is not None and not (_real(value) and 0.0 < value < 1.0):
                raise ValueError(f"settings.{name}: must be a number in (0, 1) or None, got {value!r}")
        for name, least in (("max_iter", 0), ("max_turns", 1), ("exact_every", 1), ("iterations_per_launch", 1)):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < least:
                raise ValueError(f"settings.{name}: must be an integer of at least {least}, got {value!r}")
        if not (_real(self.deferral) and 0.0 <= self.deferral <= 1.0):
            raise ValueError(f"settings.deferral: must be a number in [0, 1], got {self.deferral!r}")
        if not (_real(self.relax) and 0.0 < self.relax <= 1.0):
            raise ValueError(f"settings.relax: must be a number in (0, 1], got {self.relax!r}")
        for name in ("normal_preconditioner", "tangential_preconditioner", "one_convolution", "turn_mixing",
                     "window_turns"):
            if not isinstance(getattr(self, name), bool):
                raise ValueError(f"settings.{name}: must be True or False, got {getattr(self, name)!r}")
        for name in ("fourier_step_sums", "use_graphs"):
            if not (getattr(self, name) is None or isinstance(getattr(self, name), bool)):
                raise ValueError(f"settings.{name}: must be True, False or None (by device), got {getattr(self, name)!r}")
        for name, kind in (("turn_tolerance", TurnTolerance), ("turns", Turns), ("nested", Choice),
                           ("nested_float32", Choice), ("window", Choice),
                           ("preconditioner_float32", Choice), ("preconditioner_grid", PreconditionerGrid),
                           ("response_float32", Choice)):
            value = getattr(self, name)
            choices = get_args(kind)
            if not any(value is c if isinstance(c, bool) else (isinstance(value, str) and value == c) for c in choices):
                raise ValueError(f"settings.{name}: must be one of {', '.join(map(repr, choices))}, got {value!r}")

    @classmethod
    def of(cls, settings: SolverSettings | None = None, **choices) -> SolverSettings:
        """``settings`` (default: the defaults) with ``choices`` replaced, by field name; a name
        that is no setting raises TypeError naming the closest one."""
        names = [f.name for f in fields(cls)]
        for name in choices:
            if name not in names:
                close = difflib.get_close_matches(name, names, n=1)
                hint = f" (did you mean {close[0]!r}?)" if close else ""
                raise TypeError(f"{name!r} is not a solver setting{hint}; the settings: {', '.join(names)}")
        base = cls() if settings is None else settings
        if not isinstance(base, cls):
            raise TypeError(f"settings must be a {cls.__name__}, got {type(base).__name__}")
        return replace(base, **choices) if choices else base


def float32_chosen(choice, auto_from: dict, n: int, cuda: bool, float64: bool) -> bool:
    """Whether a float32 choice (``preconditioner_float32``, ``response_float32``,
    ``nested_float32``: True, False or "auto") holds for a solver's grid of n cells per side: only
    beside float64 fields; "auto": from ``auto_from``'s cells per side by device kind on
    (``PRECONDITIONER_FLOAT32_AUTO``, ``RESPONSE_FLOAT32_AUTO``, ``NESTED_FLOAT32_AUTO``; None:
    never)."""
    if choice == "auto":
        start = auto_from["cuda" if cuda else "cpu"]
        choice = start is not None and n >= start
    return bool(choice) and float64


def _real(value) -> bool:
    return not isinstance(value, bool) and isinstance(value, (int, float)) and math.isfinite(value)
