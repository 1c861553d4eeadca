"""Plausibility of a case's SI inputs, judged before anything is solved.

A value no solid or contact can have is refused with :class:`~warpcontact.errors.InputError`
naming the key, the range that would be consistent and, where a unit slip explains the value,
the unit the user probably meant ("sphere.E = 310 Pa ... did you mean 3.1e11 Pa (310 GPa)?").
A merely unusual value gets a :class:`PlausibilityWarning`.

Soft matter is real (cells and hydrogels have E from about 100 Pa to 100 kPa), so a modulus is
not judged by a fixed range alone but by its consistency with the other inputs:

- a strength (yield strength, hardness) above the body's own modulus E: the body would yield at a
  strain above 1, where no linear-elastic solid lives (real solids yield at S_Y / E of about
  1e-4 to 0.05; the theoretical strength is about E / 10);
- an adhesive peak stress above the pair's E*: the cohesive zone would open the surfaces by
  strains above 1 (above E* / 10, the theoretical strength, it is only warned about);
- a work of adhesion above MAX_WORK_OF_ADHESION: twice the surface energy of the most cohesive
  solids is a few J/m^2;
- a Hertz contact radius sqrt(R delta_z) far wider than the domain: the case's own domain says
  which scale the user had in mind, and the radius or the approach is off by a unit.

Fixed bounds are kept for what no solid has at all: a modulus above MAX_MODULUS (diamond is
1.2e12 Pa) or below MIN_MODULUS.
"""

from __future__ import annotations

import math
import warnings

from ..errors import InputError
from ..physics.materials import MaterialPair

#: Stiffest solid known (diamond, about 1.2e12 Pa), with a margin [Pa].
MAX_MODULUS = 2e12
#: Below the softest gels (about 10 Pa) [Pa].
MIN_MODULUS = 1.0
#: Largest work of adhesion any pair of solids has (twice the surface energy of the most cohesive
#: metals and ceramics, 2-5 J/m^2), with a margin [J/m^2].
MAX_WORK_OF_ADHESION = 10.0
#: A typical work of adhesion [J/m^2] (van der Waals and capillary contacts: 0.01-1): the target
#: when a unit slip of an adhesive length is guessed.
TYPICAL_WORK_OF_ADHESION = 0.05
#: Theoretical strength of a solid over its modulus [-]: an adhesive stress above it is warned about.
THEORETICAL_STRENGTH = 0.1
#: A strength (yield strength, hardness) under this fraction of its body's E is refused: solids
#: yield at S_Y / E of 1e-4 to 0.05 [-]; the unit guess aims at TYPICAL_STRENGTH_OVER_E.
MIN_STRENGTH_OVER_E = 1e-5
TYPICAL_STRENGTH_OVER_E = 3e-3
#: An adhesive force scale 2 pi R w under this fraction of the contact's Hertz force is warned
#: about [-]: the law hardly acts (a stress in MPa written as Pa gives a millionth of it).
WEAK_ADHESION = 1e-6
#: A contact radius sqrt(R delta_z) over the domain's half-width above which the case is refused
#: with a unit hint (between 1 and this, Case's own check asks for a wider domain) [-].
FAR_WIDER = 3.0
#: Smallest approach a unit guess may propose [m] (a tenth of a picometre) and the largest approach
#: over the radius it may leave [-].
MIN_GUESS_APPROACH = 1e-13
MAX_GUESS_APPROACH_OVER_R = 0.05
#: Smallest sphere radius a unit guess may propose [m] (an atom).
MIN_GUESS_RADIUS = 1e-10
#: Smallest range of an adhesive law a unit guess may propose [m] (a tenth of an atom).
MIN_GUESS_LENGTH = 1e-11

#: SI prefixes: factor -> name.
PREFIXES = {1e12: "T", 1e9: "G", 1e6: "M", 1e3: "k", 1e-3: "m", 1e-6: "u", 1e-9: "n", 1e-12: "p"}
UP = (1e3, 1e6, 1e9, 1e12)
DOWN = (1e-3, 1e-6, 1e-9, 1e-12)

#: The adhesion laws' keys: peak normal stress, peak shear stress (or None), length.
ADHESION_STRESS_KEYS = {"smc": ("sigma_max", "tau_max", "delta_n"), "dugdale": ("sigma_0", None, "h_0")}
#: The laws given by their work of adhesion and length: the length's key (the peak tension follows).
ADHESION_LENGTH_KEYS = {"exponential": "rho", "lj93": "z0"}


class PlausibilityWarning(UserWarning):
    """An input that is possible but unusual enough that it may be a unit slip."""


def _num(x: float) -> str:
    """A short rendering: 3.1e11, 0.3, 1e-10."""
    text = f"{x:.4g}"
    if "e" in text:
        mant, exp = text.split("e")
        text = f"{mant}e{int(exp)}"
    return text


def _meant(value: float, factor: float, unit: str) -> str:
    """``3.1e11 Pa (310 GPa)``: the value read in the unit ``PREFIXES[factor] + unit``, in SI."""
    return f"{_num(value * factor)} {unit} ({_num(value)} {PREFIXES[factor]}{unit})"


def _closest(value: float, factors, target: float, ok=lambda v: True):
    """The factor of ``factors`` that brings ``value`` nearest ``target`` (in log) among those for
    which ``ok(value * factor)``; None when none does."""
    best = None
    for f in factors:
        v = value * f
        if not ok(v):
            continue
        d = abs(math.log10(v / target))
        if best is None or d < best[0]:
            best = (d, f)
    return None if best is None else best[1]


def _modulus_guess(name: str, E: float, other_E: float, floor: float = 0.0):
    """A factor that turns body ``name``'s modulus ``E`` into a stiff solid's like the other body's
    (``other_E``, when that one is plausible), above ``floor``; None when no unit slip explains it."""
    target = other_E if MIN_MODULUS * 1e6 <= other_E <= MAX_MODULUS else 1e11
    return _closest(E, UP, target, lambda v: floor < v <= MAX_MODULUS and abs(math.log10(v / target)) < 1.5)


def check_moduli(bodies: dict) -> None:
    """Each body's modulus within what solids have, and above its own strengths.

    ``bodies``: name ("sphere", "flat") -> (E [Pa], nu, yield_strength [Pa], hardness [Pa]); a
    rigid body (E = inf) has no modulus or strength to judge, and is passed over.
    """
    names = list(bodies)
    for name in names:
        E = bodies[name][0]
        if E == math.inf:
            continue
        other_E = bodies[names[1 - names.index(name)]][0] if len(names) == 2 else 1e11
        if E > MAX_MODULUS:
            target = other_E if other_E <= MAX_MODULUS else 1e11
            f = _closest(E, DOWN, target, lambda v: MIN_MODULUS <= v <= MAX_MODULUS)
            hint = f"; did you mean {_num(E * f)} Pa?" if f else ""
            raise InputError(f"{name}.E", f"= {_num(E)} Pa is stiffer than any solid (diamond: 1.2e12 Pa); "
                                          f"expected {_num(MIN_MODULUS)} to {_num(MAX_MODULUS)} Pa (for a rigid "
                                          f"{name}, the limit E -> inf, set {name}.rigid = true instead of E){hint}")
        if E < MIN_MODULUS:
            f = _modulus_guess(name, E, other_E)
            hint = f"; did you mean {_meant(E, f, 'Pa')}?" if f else ""
            raise InputError(f"{name}.E", f"= {_num(E)} Pa is softer than any solid (the softest gels: about 10 Pa); "
                                          f"expected {_num(MIN_MODULUS)} to {_num(MAX_MODULUS)} Pa{hint}")
    for name in names:
        E, _, yield_strength, hardness = bodies[name]
        if E == math.inf:
            continue
        other_E = bodies[names[1 - names.index(name)]][0] if len(names) == 2 else 1e11
        for key, strength in (("yield_strength", yield_strength), ("hardness", hardness)):
            if math.isfinite(strength) and 0.0 < strength < MIN_STRENGTH_OVER_E * E:
                g = _closest(strength, UP, TYPICAL_STRENGTH_OVER_E * E,
                             lambda v: MIN_STRENGTH_OVER_E * E <= v <= THEORETICAL_STRENGTH * E)
                hint = f"; did you mean {_meant(strength, g, 'Pa')}?" if g else ""
                raise InputError(f"{name}.{key}", f"= {_num(strength)} Pa is {_num(strength / E)} of {name}.E = "
                                                  f"{_num(E)} Pa: the body would yield at a strain of "
                                                  f"{_num(strength / E)}, and solids yield at S_Y / E of 1e-4 to 0.05; "
                                                  f"expected at least {_num(MIN_STRENGTH_OVER_E * E)} Pa{hint}")
            if not (math.isfinite(strength) and strength > E):
                continue
            why = (f"= {_num(strength)} Pa is above {name}.E = {_num(E)} Pa: the body would yield at a strain above "
                   f"1, and solids yield at S_Y / E of 1e-4 to 0.05 (the theoretical strength is about E / 10)")
            f = _modulus_guess(name, E, other_E, floor=strength / THEORETICAL_STRENGTH)
            if f is not None:  # the modulus is the odd one: a stiff solid written in GPa (or MPa)
                raise InputError(f"{name}.E", f"= {_num(E)} Pa is below {name}.{key} = {_num(strength)} Pa: the body "
                                              f"would yield at a strain above 1; E of a solid with that strength lies "
                                              f"between {_num(strength / THEORETICAL_STRENGTH)} and "
                                              f"{_num(MAX_MODULUS)} Pa; did you mean {_meant(E, f, 'Pa')}?")
            g = _closest(strength, DOWN, 3e-3 * E, lambda v: 1e-5 * E <= v <= THEORETICAL_STRENGTH * E)
            hint = (f"; did you mean {_num(strength * g)} Pa?" if g
                    else f"; expected below {_num(E * THEORETICAL_STRENGTH)} Pa")
            raise InputError(f"{name}.{key}", why + hint)


def check_adhesion(adhesion, E_star: float, bodies: dict) -> None:
    """The adhesive law's stresses against the pair's E*, and its work of adhesion.

    ``adhesion``: the case's AdhesionSpec (``law``, its keys, ``work_of_adhesion``); ``bodies`` as
    in :func:`check_moduli`, to tell a modulus written in the wrong unit from a stress.
    """
    if adhesion.law in ADHESION_LENGTH_KEYS:
        _check_work_and_length(adhesion, E_star)
        return
    keys = ADHESION_STRESS_KEYS.get(adhesion.law)
    if keys is None:  # a law this module does not know: nothing to judge
        return
    normal_key, shear_key, length_key = keys
    names = list(bodies)
    unusual = []  # warned about once nothing is refused
    for key in (normal_key, shear_key):
        if key is None:
            continue
        stress = getattr(adhesion, key)
        if stress > E_star:
            for name in names:  # a modulus in GPa written as Pa makes every stress look too large
                E = bodies[name][0]
                other_E = bodies[names[1 - names.index(name)]][0] if len(names) == 2 else 1e11
                # against a rigid body there is no other modulus to tell a unit slip by
                f = _modulus_guess(name, E, other_E) if max(E, other_E) < math.inf else None
                if f is not None and E < other_E:
                    raise InputError(
                        f"{name}.E", f"= {_num(E)} Pa makes E* = {_num(E_star)} Pa, far below adhesion.{key} = "
                                     f"{_num(stress)} Pa: the adhesive stress may not exceed E* (it would open the "
                                     f"surfaces by strains above 1); did you mean {_meant(E, f, 'Pa')}? (for a soft "
                                     f"body, adhesion.{key} at most {_num(THEORETICAL_STRENGTH * E_star)} Pa)")
            g = _closest(stress, DOWN, 1e-3 * E_star, lambda v: v <= THEORETICAL_STRENGTH * E_star)
            hint = f"; did you mean {_num(stress * g)} Pa?" if g else ""
            raise InputError(f"adhesion.{key}", f"= {_num(stress)} Pa is above E* = {_num(E_star)} Pa: the cohesive "
                                                f"zone would open the surfaces by strains above 1, outside linear "
                                                f"elasticity; expected at most {_num(THEORETICAL_STRENGTH * E_star)} "
                                                f"Pa (E* / 10, the theoretical strength){hint}")
        if stress > THEORETICAL_STRENGTH * E_star:
            unusual.append(f"adhesion.{key} = {_num(stress)} Pa is above E* / 10 = "
                          f"{_num(THEORETICAL_STRENGTH * E_star)} Pa, the theoretical strength of the solids: the "
                          f"cohesive zone opens the surfaces by strains near 1, at the edge of linear elasticity")
    w = adhesion.work_of_adhesion
    if w > MAX_WORK_OF_ADHESION:
        length = getattr(adhesion, length_key)
        stress = getattr(adhesion, normal_key)
        formula = "e sigma_max delta_n" if adhesion.law == "smc" else "sigma_0 h_0"
        what = (f"gives a work of adhesion w = {formula} = {_num(w)} J/m^2 (adhesion.{normal_key} = {_num(stress)} Pa, "
                f"adhesion.{length_key} = {_num(length)} m), above any pair of solids (at most about "
                f"{_num(MAX_WORK_OF_ADHESION)} J/m^2; van der Waals and capillary contacts have 0.01 to 1 J/m^2)")
        if stress > THEORETICAL_STRENGTH * E_star:  # the stress is the odd one (above the solids' strength)
            g = _closest(stress, DOWN, TYPICAL_WORK_OF_ADHESION / (w / stress),
                         lambda v: MIN_MODULUS <= v <= THEORETICAL_STRENGTH * E_star)
            hint = f"; did you mean {_num(stress * g)} Pa?" if g else ""
            raise InputError(f"adhesion.{normal_key}", f"= {_num(stress)} Pa {what}{hint}")
        g = _closest(length, DOWN, TYPICAL_WORK_OF_ADHESION / (w / length),
                     lambda v: v >= MIN_GUESS_LENGTH and v * (w / length) <= MAX_WORK_OF_ADHESION)
        hint = f"; did you mean {_meant(length, g, 'm')}?" if g else ""
        raise InputError(f"adhesion.{length_key}", f"= {_num(length)} m {what}{hint}")
    for text in unusual:
        warnings.warn(text, PlausibilityWarning, stacklevel=4)


def check_adhesion_force(adhesion, E_star: float, radius: float, delta_z_max: float) -> None:
    """Warn where the adhesive law hardly acts: its force scale 2 pi R w under WEAK_ADHESION of the
    Hertz force at the deepest approach (a stress in MPa written as Pa makes w a millionth of what
    was meant), naming the unit slip that gives a work of adhesion of 0.01-1 J/m^2 where one does.
    Judged against the contact, not by w alone: cells adhere with w of 1e-7 J/m^2 at forces that
    matter to them."""
    w = adhesion.work_of_adhesion
    if not (delta_z_max > 0.0 and 0.0 < w):
        return
    hertz = 4.0 / 3.0 * E_star * math.sqrt(radius) * delta_z_max**1.5
    force = 2.0 * math.pi * radius * w
    if not force < WEAK_ADHESION * hertz:
        return
    text = (f"the adhesive force scale 2 pi R w = {_num(force)} N is {_num(force / hertz)} of the Hertz force "
            f"{_num(hertz)} N at delta_z = {_num(delta_z_max)} m: the law hardly acts")
    typical = lambda v: 1e-2 <= v <= 1.0  # noqa: E731 - works of adhesion of van der Waals and capillary contacts
    if adhesion.law in ADHESION_LENGTH_KEYS:
        text = f"adhesion.w = {_num(w)} J/m^2: {text}"
        g = _closest(w, (1e3, 1e6), TYPICAL_WORK_OF_ADHESION, typical)
        if g is not None:
            text += f"; did you mean {_num(w * g)} J/m^2?"
    elif adhesion.law in ADHESION_STRESS_KEYS:
        normal_key, shear_key, length_key = ADHESION_STRESS_KEYS[adhesion.law]
        formula = "e sigma_max delta_n" if adhesion.law == "smc" else "sigma_0 h_0"
        stress, length = getattr(adhesion, normal_key), getattr(adhesion, length_key)
        text = (f"adhesion: w = {formula} = {_num(w)} J/m^2 (adhesion.{normal_key} = {_num(stress)} Pa, "
                f"adhesion.{length_key} = {_num(length)} m); {text}")
        g = _closest(stress, UP, TYPICAL_WORK_OF_ADHESION / (w / stress),
                     lambda v: v <= THEORETICAL_STRENGTH * E_star and typical(w * v / stress))
        h = _closest(length, UP, TYPICAL_WORK_OF_ADHESION / (w / length), lambda v: typical(w * v / length))
        if g is not None:
            shear = f", and adhesion.{shear_key} in {PREFIXES[g]}Pa too" if shear_key is not None else ""
            text += f"; did you mean adhesion.{normal_key} = {_meant(stress, g, 'Pa')}{shear}?"
        elif h is not None:
            text += f"; did you mean adhesion.{length_key} = {_meant(length, h, 'm')}?"
    warnings.warn(text, PlausibilityWarning, stacklevel=4)


def _check_work_and_length(adhesion, E_star: float) -> None:
    """A law given by w and a length (exponential, lj93): w within what solids have, and the
    peak tension it implies (w over the length) below E*."""
    key = ADHESION_LENGTH_KEYS[adhesion.law]
    w, length, peak = adhesion.w, getattr(adhesion, key), adhesion.peak_tension
    if w > MAX_WORK_OF_ADHESION:
        g = _closest(w, DOWN, TYPICAL_WORK_OF_ADHESION, lambda v: v <= MAX_WORK_OF_ADHESION)
        hint = f"; did you mean {_num(w * g)} J/m^2?" if g else ""
        raise InputError("adhesion.w", f"= {_num(w)} J/m^2 is above any pair of solids (at most about "
                                       f"{_num(MAX_WORK_OF_ADHESION)} J/m^2; van der Waals and capillary contacts "
                                       f"have 0.01 to 1 J/m^2){hint}")
    if peak > E_star:
        g = _closest(length, UP, w / (THEORETICAL_STRENGTH * E_star), lambda v: w / v <= THEORETICAL_STRENGTH * E_star)
        hint = f"; did you mean {_meant(length, g, 'm')}?" if g else ""
        raise InputError(f"adhesion.{key}", f"= {_num(length)} m with w = {_num(w)} J/m^2 gives a peak tension of "
                                            f"{_num(peak)} Pa, above E* = {_num(E_star)} Pa: the attraction would "
                                            f"open the surfaces by strains above 1, outside linear elasticity{hint}")
    if peak > THEORETICAL_STRENGTH * E_star:
        warnings.warn(f"adhesion.{key} = {_num(length)} m with w = {_num(w)} J/m^2 gives a peak tension of "
                      f"{_num(peak)} Pa, above E* / 10 = {_num(THEORETICAL_STRENGTH * E_star)} Pa, the theoretical "
                      f"strength of the solids", PlausibilityWarning, stacklevel=4)


def check_contact_scale(radius: float, profile: str, size: float, delta_z_max: float, delta_z_key: str) -> None:
    """Refuse a Hertz contact radius a = sqrt(R delta_z) far wider than the domain, naming the
    input a unit slip explains (the radius or the approach read in um or nm fits the domain).

    Between a domain that holds the contact and FAR_WIDER, the case's own domain check (which
    suggests a wider ``grid.size``) speaks instead.
    """
    if not delta_z_max > 0.0:
        return
    a = math.sqrt(radius * delta_z_max)
    half = 0.5 * size
    if not a > FAR_WIDER * half:
        return

    def fits(R, dz):
        if R < MIN_GUESS_RADIUS or dz < MIN_GUESS_APPROACH or dz > MAX_GUESS_APPROACH_OVER_R * R:
            return False
        if profile == "sphere" and size >= math.sqrt(2.0) * R:
            return False
        return 2.0 * math.sqrt(R * dz) < size

    guesses = []  # (change in decades, key, value, factor)
    for f in DOWN:
        if fits(radius, delta_z_max * f):
            guesses.append((abs(math.log10(f)), delta_z_key, delta_z_max, f))
        if fits(radius * f, delta_z_max):
            guesses.append((abs(math.log10(f)), "sphere.radius", radius, f))
    what = (f"the Hertz contact radius sqrt(R delta_z) = {_num(a)} m (sphere.radius = {_num(radius)} m, "
            f"delta_z = {_num(delta_z_max)} m) is {_num(a / half)} times the domain's half-width "
            f"{_num(half)} m (grid.size = {_num(size)} m)")
    if guesses:
        _, key, value, f = min(guesses)
        raise InputError(key, f"= {_num(value)} m: {what}; did you mean {_meant(value, f, 'm')}?")
    raise InputError("grid.size", f"{what}; check the units of sphere.radius, {delta_z_key} and grid.size "
                                  f"(all in m)")


def check_shift(load, size: float) -> None:
    """Refuse a tangential shift larger than the domain's half-width, with the unit that makes it
    a shift of the contact's scale. The model is one of small displacements: the contact stays
    where the sphere's profile puts it on the grid, and a shift beyond the domain (the sphere off
    the grid) is a unit slip, not a path this model describes."""
    half = 0.5 * size
    if load.explicit:
        key = "load.path"
        shift = max(max(abs(dx), abs(dy)) for dx, dy, _ in load.states)
    else:
        keys = ("delta_x_amplitude", "delta_y_amplitude") if load.cyclic else ("delta_x", "delta_y")
        key, shift = max(((f"load.{k}", abs(getattr(load, k) or 0.0)) for k in keys), key=lambda item: item[1])
    if not shift > half:
        return
    g = _closest(shift, DOWN, 1e-2 * half, lambda v: v <= 0.5 * half)
    hint = f"; did you mean {_meant(shift, g, 'm')}?" if g else ""
    raise InputError(key, f"shifts the sphere by {_num(shift)} m, beyond the domain's half-width {_num(half)} m "
                          f"(grid.size = {_num(size)} m): the sphere would leave the grid (tangential shifts are "
                          f"in m, like every length){hint}")


#: a height map's relief left out by a grid coarser than its pixels, as a share of its rms
#: height, above which ``check_map_sampling`` warns
MAP_RELIEF_LEFT_OUT = 0.01


def check_map_sampling(surface, grid) -> None:
    """Warn where the grid's cells are coarser than a height map's pixels and leave out more than
    ``MAP_RELIEF_LEFT_OUT`` of its rms height (``HeightMap.unresolved_relief``): the map is read
    at the cell centres, so its relief between them (wavelengths under two cells) is not in the
    gap, nor the small contacts it would make (a rough contact's area and patches depend on the
    shortest wavelength resolved). ``surface``: a ``HeightMap``."""
    left_out = surface.unresolved_relief(grid)
    rms = float(surface.heights.std())
    if left_out <= MAP_RELIEF_LEFT_OUT * rms:
        return
    n_needed = int(math.ceil(grid.size / surface.pixel_size))
    warnings.warn(f"grid.n = {grid.n} gives cells of {_num(grid.dx)} m, coarser than the {surface.key} height map's "
                  f"pixels of {_num(surface.pixel_size)} m: {_num(left_out)} m rms of its relief "
                  f"({100 * left_out / rms:.0f} % of its rms height) lies under two cells and is left out of the "
                  f"gap; grid.n = {n_needed} reads every pixel", PlausibilityWarning, stacklevel=4)


def check_case(sphere, flat, grid, load, adhesion=None) -> None:
    """Every plausibility check of a case's parts, in the order a user reads them: the bodies, the
    contact's scale against the domain (a sphere's or paraboloid's: Hertz's scales), the adhesive
    law. ``sphere``: SphereSpec; ``flat``:
    Material; ``grid``: Grid; ``load``: LoadSpec; ``adhesion``: AdhesionSpec or None. A rigid
    body enters as E = inf (``check_moduli`` passes it over)."""
    bodies = {name: (m.E, m.nu, m.yield_strength, m.hardness) for name, m in (("sphere", sphere.material),
                                                                              ("flat", flat))}
    check_moduli(bodies)
    key = "load.path" if load.explicit else "load.delta_z"
    hertzian = sphere.profile in ("sphere", "paraboloid")  # Hertz's scales judge these profiles alone
    if hertzian:
        check_contact_scale(sphere.radius, sphere.profile, grid.size, load.delta_z_max, key)
    check_shift(load, grid.size)
    if adhesion is not None:
        E_star = MaterialPair(sphere.material, flat).E_star
        check_adhesion(adhesion, E_star, bodies)
        if hertzian:
            check_adhesion_force(adhesion, E_star, sphere.radius, load.delta_z_max)


__all__ = ["PlausibilityWarning", "check_adhesion", "check_adhesion_force", "check_case", "check_contact_scale",
           "check_map_sampling", "check_moduli", "check_shift"]
