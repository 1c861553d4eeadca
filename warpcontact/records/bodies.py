"""The body tables of a case file: ``[sphere]`` (body 1: its shape and material) and ``[flat]``
(body 2: its material and an optional height map), and the reading of height-map files.

Profiles and their keys (docs/surfaces.md): "sphere" and "paraboloid" (``radius``), "flat_punch"
(``radius``, ``edge_radius``), "cone" (``half_angle``, ``tip_radius``) and "height_map"
(``height_map``, ``pixel_size``, ``height_unit``); the flat takes the three keys of a height map.
A height map is a file: a .npy array, or a text grid that ``numpy.loadtxt`` reads; its first axis
runs along x, its values are heights in ``height_unit`` (docs/surfaces.md). A relative path is
taken from the case file's folder (``case_from_dict``'s ``base``).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from typing import Mapping

import numpy as np

from ..errors import InputError
from ..physics.geometry import PROFILES, HeightMap, Sphere
from ..physics.materials import Material
from .values import _boolean, _choice, _got, _inf_out, _number, _positive, _require, _set, _strength

#: The keys of a height map, in ``[sphere]`` (profile "height_map") and ``[flat]``.
MAP_KEYS = ("height_map", "pixel_size", "height_unit")
#: Each profile's own keys (the other keys of the table are the material's).
PROFILE_KEYS = {"sphere": ("radius",), "paraboloid": ("radius",), "flat_punch": ("radius", "edge_radius"),
                "cone": ("half_angle", "tip_radius"), "height_map": MAP_KEYS}
#: Profile keys that may be left out (their default then holds).
PROFILE_OPTIONAL = ("edge_radius", "tip_radius", "height_unit")
SPHERE_KEYS = ("radius", "E", "nu", "yield_strength", "hardness", "profile", "edge_radius", "half_angle",
               "tip_radius", *MAP_KEYS, "rigid")
FLAT_KEYS = ("E", "nu", "yield_strength", "hardness", *MAP_KEYS, "rigid")
#: The keys of a body's material: an elastic body needs E and nu, a rigid one (rigid = true) takes none.
MATERIAL_KEYS = ("E", "nu", "yield_strength", "hardness")
#: Units a height map's values may be in, and their factor to m.
HEIGHT_UNITS = {"m": 1.0, "mm": 1e-3, "um": 1e-6, "nm": 1e-9, "pm": 1e-12}


def _unused_by_rigid(table: str, key: str) -> InputError:
    return InputError(f"{table}.{key}", f"is not used by a rigid body ({table}.rigid = true: no modulus, no Poisson "
                                        f"ratio, it never yields); leave it out, or set {table}.rigid = false for an "
                                        f"elastic {table}")


def _material(table: str, E, nu, yield_strength, hardness, rigid: bool = False) -> Material:
    """A validated :class:`Material` named after its table, so its own checks report ``table.key``:
    elastic from E and nu, or with ``rigid`` a rigid body (``Material.rigid``), which takes no E
    or nu (None) and no finite yield strength or hardness."""
    if rigid:
        for key, v in (("E", E), ("nu", nu), ("yield_strength", yield_strength), ("hardness", hardness)):
            if v is None or (key in ("yield_strength", "hardness") and _strength(f"{table}.{key}", v) == math.inf):
                continue
            raise _unused_by_rigid(table, key)
        return Material.rigid(table)
    for key, v in (("E", E), ("nu", nu)):
        if v is None:
            raise InputError(f"{table}.{key}", "is required")
    if E == math.inf:
        raise InputError(f"{table}.E", f"must be finite, got inf; for a rigid {table}, set {table}.rigid = true "
                                       "and leave E and nu out")
    E = _positive(f"{table}.E", E, "Pa")
    nu = _number(f"{table}.nu", nu)
    if not -1.0 < nu <= 0.5:
        raise InputError(f"{table}.nu", f"must lie in (-1, 0.5], got {nu!r}")
    return Material(
        E=E,
        nu=nu,
        yield_strength=_strength(f"{table}.yield_strength", yield_strength),
        hardness=_strength(f"{table}.hardness", hardness),
        name=table,
    )


def _material_dict(m: Material) -> dict:
    if m.is_rigid:
        return {"rigid": True}
    return {"E": m.E, "nu": m.nu, "yield_strength": _inf_out(m.yield_strength), "hardness": _inf_out(m.hardness),
            "rigid": False}


def _check_body(spec, table: str) -> None:
    """Validate and normalise the material fields (E, nu, yield_strength, hardness, rigid) of a
    body's table (``SphereSpec``, ``FlatSpec``) in place."""
    _set(spec, "rigid", _boolean(f"{table}.rigid", spec.rigid))
    m = _material(table, spec.E, spec.nu, spec.yield_strength, spec.hardness, spec.rigid)
    if not m.is_rigid:
        for name in MATERIAL_KEYS:
            _set(spec, name, getattr(m, name))


def _body_material(spec, table: str) -> Material:
    """The Material of a validated body table, named after it."""
    if spec.rigid:
        return Material.rigid(table)
    return Material(spec.E, spec.nu, spec.yield_strength, spec.hardness, name=table)


@dataclass(frozen=True)
class SphereSpec:
    """The ``[sphere]`` table: the asperity's shape and material (body 1).

    Attributes:
        radius: R [m] of profiles "sphere" and "paraboloid"; the punch's radius [m] of "flat_punch".
        E: Young's modulus [Pa]; required unless rigid.
        nu: Poisson ratio [-], in (-1, 0.5]; required unless rigid.
        yield_strength: S_Y [Pa]; inf for no limit.
        hardness: H [Pa]; inf for no limit.
        profile: "sphere" (exact cap), "paraboloid" (r^2 / 2R), "flat_punch", "cone" or "height_map".
        edge_radius: the flat punch's edge radius [m], from 0 (a sharp edge) to the punch's radius.
        half_angle: the cone's semi-angle [degrees], between its axis and its surface: 0 < half_angle < 90.
        tip_radius: the cone's tip radius [m], >= 0 (0: a sharp tip).
        height_map: a height map's file (.npy, or a text grid that numpy.loadtxt reads), its first axis
            along x, heights positive away from the other body; a relative path is taken from the case
            file's folder.
        pixel_size: the height map's pixel side [m].
        height_unit: the unit of the height map's values: "m", "mm", "um", "nm" or "pm".
        rigid: true for a rigid sphere (the limit E -> inf: a glass lens on rubber), which takes no
            E, nu, yield_strength or hardness; the flat must then be elastic.
        surface: the height map read from its file (profile "height_map"), else None.
    """

    radius: float | None = None
    E: float | None = None
    nu: float | None = None
    yield_strength: float = math.inf
    hardness: float = math.inf
    profile: str = "sphere"
    rigid: bool = False
    edge_radius: float = 0.0
    half_angle: float | None = None
    tip_radius: float = 0.0
    height_map: str | None = None
    pixel_size: float | None = None
    height_unit: str = "m"
    surface: HeightMap | None = field(default=None, compare=False, repr=False)

    def __post_init__(self):
        _set(self, "profile", _choice("sphere.profile", self.profile, PROFILES))
        if self.profile in ("sphere", "paraboloid", "flat_punch"):
            _set(self, "radius", _positive("sphere.radius", self.radius, "m"))
        for name in ("edge_radius", "tip_radius"):
            v = _number(f"sphere.{name}", getattr(self, name), unit="m")
            if v < 0.0:
                raise InputError(f"sphere.{name}", f"must be >= 0 m (0: sharp), got {v!r}")
            _set(self, name, v)
        if self.profile == "flat_punch" and self.edge_radius > self.radius:
            raise InputError("sphere.edge_radius", f"= {self.edge_radius:.4g} m exceeds the punch's radius "
                                                   f"{self.radius:.4g} m: the rounded edge lies within the punch")
        if self.profile == "cone":
            _set(self, "half_angle", _number("sphere.half_angle", self.half_angle))
        if self.profile == "height_map" and self.surface is None:
            _set(self, "surface", read_height_map("sphere", self.height_map, self.pixel_size, self.height_unit))
        _check_body(self, "sphere")
        self.geometry  # the profile's own checks (Sphere), naming their keys

    @property
    def material(self) -> Material:
        """The sphere's material (named "sphere")."""
        return _body_material(self, "sphere")

    @property
    def geometry(self) -> Sphere:
        """The shape (:class:`~warpcontact.physics.geometry.Sphere`), without the flat's map."""
        return Sphere(self.radius, self.profile, self.edge_radius, self.half_angle, self.tip_radius, self.surface)


@dataclass(frozen=True)
class FlatSpec:
    """The ``[flat]`` table: the flat's material (body 2) and its height map, if it has one.

    Attributes:
        E: Young's modulus [Pa]; required unless rigid.
        nu: Poisson ratio [-], in (-1, 0.5]; required unless rigid.
        yield_strength: S_Y [Pa]; inf for no limit.
        hardness: H [Pa]; inf for no limit.
        height_map: the flat's height map file (as ``[sphere] height_map``): its heights add to the gap.
        pixel_size: the height map's pixel side [m].
        height_unit: the unit of the height map's values: "m", "mm", "um", "nm" or "pm".
        rigid: true for a rigid flat (the limit E -> inf: an elastic sphere on a rigid flat), which
            takes no E, nu, yield_strength or hardness; the sphere must then be elastic.
        surface: the height map read from its file, else None.
    """

    E: float | None = None
    nu: float | None = None
    yield_strength: float = math.inf
    hardness: float = math.inf
    rigid: bool = False
    height_map: str | None = None
    pixel_size: float | None = None
    height_unit: str = "m"
    surface: HeightMap | None = field(default=None, compare=False, repr=False)

    def __post_init__(self):
        _check_body(self, "flat")
        if self.height_map is not None and self.surface is None:
            _set(self, "surface", read_height_map("flat", self.height_map, self.pixel_size, self.height_unit))

    @property
    def material(self) -> Material:
        """The flat's material (named "flat")."""
        return _body_material(self, "flat")


def read_height_map(table: str, path, pixel_size, unit) -> HeightMap:
    """The height map of ``path`` (.npy, or a text grid for ``numpy.loadtxt``) with ``pixel_size``
    [m], its values in ``unit`` (``HEIGHT_UNITS``), as a :class:`HeightMap` in m. Every mistake
    (a missing or unreadable file, a shape that is no grid, values that are not finite numbers, an
    unknown unit, a pixel size that is no positive length) is an InputError naming
    ``<table>.height_map``, ``.pixel_size`` or ``.height_unit``."""
    key = f"{table}.height_map"
    if not isinstance(path, (str, os.PathLike)) or not str(path).strip():
        raise InputError(key, f"must be the path of a height map file (.npy, or text numpy.loadtxt reads), {_got(path)}")
    if pixel_size is None:
        raise InputError(f"{table}.pixel_size", f"is required with {key} (the side of a pixel, in m)")
    pixel = _positive(f"{table}.pixel_size", pixel_size, "m")
    if not isinstance(unit, str) or unit not in HEIGHT_UNITS:
        raise InputError(f"{table}.height_unit", f"must be one of {', '.join(map(repr, HEIGHT_UNITS))}, {_got(unit)}")
    path = str(path)
    try:
        if path.lower().endswith(".npy"):
            heights = np.load(path, allow_pickle=False)
        else:
            heights = np.loadtxt(path, dtype=np.float64, ndmin=2)
    except FileNotFoundError:
        raise InputError(key, f"no such file: {path}") from None
    except IsADirectoryError:
        raise InputError(key, f"is a directory, not a height map file: {path}") from None
    except (OSError, ValueError, EOFError, UnicodeDecodeError) as e:
        reason = " ".join(str(e).split())[:200]
        raise InputError(key, f"cannot be read as a height map ({path}): {reason}") from None
    if not isinstance(heights, np.ndarray) or heights.dtype.kind not in "iuf":
        kind = heights.dtype if isinstance(heights, np.ndarray) else type(heights).__name__
        raise InputError(key, f"holds {kind} values, not real numbers ({path})")
    return HeightMap(heights.astype(np.float64) * HEIGHT_UNITS[unit], pixel, source=path, key=table, height_unit=unit)


def _path(v, base):
    """A file path of a case file, taken from the folder ``base`` (None: the current one) when relative."""
    if not isinstance(v, str):
        return v
    v = os.path.expanduser(v)
    return os.path.abspath(v if os.path.isabs(v) or base is None else os.path.join(os.fspath(base), v))


def sphere_from_table(s: Mapping, base=None) -> SphereSpec:
    """The ``[sphere]`` table's :class:`SphereSpec` (keys checked, relative paths from ``base``)."""
    rigid = _rigid("sphere", s)
    profile = s.get("profile")
    owned = {k: p for p, keys in reversed(PROFILE_KEYS.items()) for k in keys}
    if profile is None:
        other = next((k for k in s if k in owned and k not in PROFILE_KEYS["sphere"]), None)
        if other is not None:
            raise InputError("sphere.profile", f"is required with sphere.{other} (a key of profile "
                                               f"{owned[other]!r}); write profile = {owned[other]!r}")
        profile = "sphere"
    keys = PROFILE_KEYS[_choice("sphere.profile", profile, PROFILES)]
    _require("sphere", s, tuple(k for k in keys if k not in PROFILE_OPTIONAL), f" for profile {profile!r}")
    for k in s:
        if k in owned and k not in keys:
            raise InputError(f"sphere.{k}", f"is not used by profile {profile!r}, which takes {', '.join(keys)}")
    _require("sphere", s, () if rigid else ("E", "nu"))
    return SphereSpec(**{k: (_path(v, base) if k == "height_map" else v) for k, v in s.items()})


def flat_from_table(f: Mapping, base=None) -> FlatSpec:
    """The ``[flat]`` table's :class:`FlatSpec` (keys checked, a relative path from ``base``)."""
    rigid = _rigid("flat", f)
    _require("flat", f, () if rigid else ("E", "nu"))
    for k in ("pixel_size", "height_unit"):
        if k in f and "height_map" not in f:
            raise InputError("flat.height_map", f"is required with flat.{k} (the file of the flat's height map)")
    return FlatSpec(**{k: (_path(v, base) if k == "height_map" else v) for k, v in f.items()})


def _map_dict(m: HeightMap) -> dict:
    return {"height_map": m.source, "pixel_size": m.pixel_size, "height_unit": m.height_unit}


def sphere_dict(shape: Sphere, material: Material) -> dict:
    """The ``[sphere]`` table of a shape and material (``Case.to_dict``): the profile's keys only."""
    keys = {"radius": shape.radius, "edge_radius": shape.edge_radius, "half_angle": shape.half_angle,
            "tip_radius": shape.tip_radius}
    own = {k: keys[k] for k in PROFILE_KEYS[shape.profile] if k in keys}
    if shape.profile == "height_map":
        own = _map_dict(shape.height_map)
    return {**own, **_material_dict(material), "profile": shape.profile}


def flat_dict(shape: Sphere, material: Material) -> dict:
    """The ``[flat]`` table of a material and the shape's flat map (``Case.to_dict``)."""
    return {**_material_dict(material), **(_map_dict(shape.flat_map) if shape.flat_map is not None else {})}


def _rigid(table: str, d: Mapping) -> bool:
    """A body table's ``rigid`` key (false when absent); a rigid body's table holds none of MATERIAL_KEYS."""
    rigid = _boolean(f"{table}.rigid", d.get("rigid", False))
    for key in MATERIAL_KEYS if rigid else ():
        if key in d:
            raise _unused_by_rigid(table, key)
    return rigid


__all__ = ["FLAT_KEYS", "HEIGHT_UNITS", "MAP_KEYS", "MATERIAL_KEYS", "PROFILE_KEYS", "SPHERE_KEYS", "FlatSpec",
           "SphereSpec", "flat_dict", "flat_from_table", "read_height_map", "sphere_dict", "sphere_from_table"]
