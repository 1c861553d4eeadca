"""Checks of single values of a case file, each reporting the dotted key it was given: numbers,
lengths, strengths, integers, choices, tables, keys (unknown, missing), and the hint for a number
written with its unit ("10 um")."""

from __future__ import annotations

import difflib
import math
import numbers
import re
from typing import Mapping, Sequence

import numpy as np

from ..errors import InputError
from .plausibility import PREFIXES

# ---------------------------------------------------------------------------------------------
# Value checks. Each takes the dotted key it reports and returns the normalised value.


def _is_bool(v) -> bool:
    return isinstance(v, (bool, np.bool_))


def _type_name(v) -> str:
    """The TOML name of a value's type, for messages."""
    if _is_bool(v):
        return "boolean"
    if isinstance(v, str):
        return "string"
    if isinstance(v, numbers.Integral):
        return "integer"
    if isinstance(v, numbers.Real):
        return "float"
    if isinstance(v, Mapping):
        return "table"
    if isinstance(v, (list, tuple)):
        return "array"
    if v is None:
        return "nothing"
    return type(v).__name__


def _show(v) -> str:
    """A short one-line rendering of a value, for messages."""
    if _is_bool(v):
        return "true" if v else "false"
    if isinstance(v, numbers.Real) and not isinstance(v, numbers.Integral):
        return repr(float(v))
    text = repr(v)
    text = " ".join(text.split())
    return text if len(text) <= 60 else text[:57] + "..."


def _got(v) -> str:
    return f"got {_type_name(v)} {_show(v)}" if v is not None else "got nothing"


#: units a value may be written with by mistake ("10 um"): the factor to SI and the SI unit named
#: in the hint (case files take bare numbers in SI units)
_UNITS = {prefix + written: (factor, si)
          for written, si in {"m": "m", "Pa": "Pa", "J/m^2": "J/m^2", "J/m2": "J/m^2", "N/m": "J/m^2"}.items()
          for factor, prefix in {1.0: "", **PREFIXES}.items()}
_UNITS |= {"\u00b5m": (1e-6, "m"), "\u03bcm": (1e-6, "m"), "A": (1e-10, "m"), "\u00c5": (1e-10, "m")}
_WITH_UNIT = re.compile(r"\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*([^\s\d].*?)?\s*")


def _string_hint(v: str, unit: str = "") -> str:
    """What to write instead of a number given as a string: the number itself, in SI units where
    the string carries one of ``_UNITS`` ("10 um" -> 1e-05 m) of the key's ``unit`` (any, where
    not given); "" when the string is no number."""
    m = _WITH_UNIT.fullmatch(v)
    if not m:
        return ""
    value, written = float(m.group(1)), m.group(2)
    if written is None:
        return f"; write it without quotes: {value!r}"
    if written in _UNITS and _UNITS[written][1] == (unit or _UNITS[written][1]):
        factor, si = _UNITS[written]
        return f"; case files take SI numbers: write {value * factor:.6g} ({v.strip()} in {si})"
    return f"; case files take bare numbers in SI units ({unit})" if unit else ""


def _number(key: str, v, *, allow_inf: bool = False, unit: str = "") -> float:
    """A real number (int accepted, bool refused), finite unless ``allow_inf`` (+inf only);
    ``unit``: the key's SI unit, for the hint where the number came as a string with a unit."""
    if _is_bool(v) or not isinstance(v, numbers.Real):
        hint = _string_hint(v, unit) if isinstance(v, str) else ""
        raise InputError(key, f"must be a number, {_got(v)}{hint}")
    try:
        x = float(v)
    except OverflowError:
        raise InputError(key, f"must be a finite number, got an integer too large for a float ({_show(v)})") from None
    if math.isnan(x):
        raise InputError(key, "must be a number, got nan")
    if math.isinf(x) and not (allow_inf and x > 0):
        raise InputError(key, f"must be finite, got {x!r}")
    return x


def _positive(key: str, v, unit: str, *, allow_inf: bool = False) -> float:
    x = _number(key, v, allow_inf=allow_inf, unit=unit)
    if not x > 0.0:
        raise InputError(key, f"must be > 0{' ' + unit if unit else ''}, got {x!r}")
    return x


def _strength(key: str, v) -> float:
    """A yield strength or hardness [Pa]: positive, or +inf (TOML ``inf`` or the string "inf") for no limit."""
    if isinstance(v, str) and v.strip().lower() in ("inf", "+inf"):
        return math.inf
    if isinstance(v, str):
        raise InputError(key, f'must be a number in Pa or "inf" (no limit), {_got(v)}{_string_hint(v, "Pa")}')
    return _positive(key, v, "Pa", allow_inf=True)


def _integer(key: str, v, minimum: int, maximum: int | None = None) -> int:
    if _is_bool(v) or not isinstance(v, numbers.Integral):
        raise InputError(key, f"must be an integer, {_got(v)}")
    n = int(v)
    if n < minimum:
        raise InputError(key, f"must be at least {minimum}, got {n}")
    if maximum is not None and n > maximum:
        raise InputError(key, f"must be at most {maximum}, got {n}")
    return n


def _choice(key: str, v, choices: Sequence[str]) -> str:
    if not isinstance(v, str):
        raise InputError(key, f"must be a string, one of {_list(choices)}; {_got(v)}")
    if v not in choices:
        raise InputError(key, f"must be one of {_list(choices)}; got {v!r}")
    return v


def _list(names: Sequence[str]) -> str:
    return ", ".join(repr(n) for n in names)


def _table(key: str, v) -> Mapping:
    if not isinstance(v, Mapping):
        raise InputError(key, f"must be a table, {_got(v)}")
    return v


def _check_keys(table: str, d: Mapping, allowed: Sequence[str], why: str = "unknown key") -> None:
    """Refuse any key of ``d`` outside ``allowed``, naming it (and, for a typo, the nearest allowed key)."""
    for k in d:
        if k in allowed:
            continue
        name = k if isinstance(k, str) else repr(k)
        typo = why.startswith("unknown") and isinstance(k, str)
        same = [a for a in allowed if a.lower() == name.lower()] if typo else []  # e for E
        near = same or (difflib.get_close_matches(name, allowed, n=1) if typo else [])
        hint = f"did you mean {near[0]!r}? " if near else ""
        raise InputError(f"{table}.{name}" if table else name, f"{why}; {hint}expected one of {', '.join(allowed)}")


def _require(table: str, d: Mapping, keys: Sequence[str], extra: str = "") -> None:
    for k in keys:
        if k not in d:
            raise InputError(f"{table}.{k}", "is required" + extra)


def _inf_out(x: float):
    """JSON-safe form of a strength: the string "inf" for no limit."""
    return "inf" if math.isinf(x) else x


def _set(obj, name: str, value) -> None:
    object.__setattr__(obj, name, value)  # normalising a field of a frozen dataclass


def _boolean(key: str, v) -> bool:
    if not _is_bool(v):
        raise InputError(key, f"must be true or false, {_got(v)}")
    return bool(v)
