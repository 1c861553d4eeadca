"""The ``[load]`` table of a case file: the path of rigid-body approaches (MODEL.md section 3), given
as the default path (a normal leg, then a tangential one), the cyclic path of fretting, or an
explicit list of states."""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np

from ..errors import InputError
from .values import _check_keys, _got, _integer, _is_bool, _number, _positive, _set

LOAD_KEYS = ("delta_z", "delta_x", "delta_y", "steps", "normal_steps", "tangential_steps", "delta_x_amplitude",
             "delta_y_amplitude", "cycles", "path")
#: Most load steps per leg of the default path (a guard against typos such as 1e9 steps).
MAX_STEPS = 100_000
#: Most whole cycles of a cyclic path (load.cycles); the path's states are bounded too (2 MAX_STEPS).
MAX_CYCLES = 10_000

State = tuple[float, float, float]

#: The [load] keys of the default path (an explicit ``path`` replaces them all).
DEFAULT_PATH_KEYS = ("delta_z", "delta_x", "delta_y", "steps", "normal_steps", "tangential_steps",
                     "delta_x_amplitude", "delta_y_amplitude", "cycles")
#: The [load] keys of a cyclic path (fretting): the amplitudes and the number of whole cycles.
CYCLIC_KEYS = ("delta_x_amplitude", "delta_y_amplitude", "cycles")


@dataclass(frozen=True)
class LoadSpec:
    """The ``[load]`` table: the path of rigid-body approaches (MODEL.md section 3).

    Either the default path (``delta_z`` required; ``delta_x``, ``delta_y``, ``steps``), the
    cyclic path of fretting (``delta_z`` and ``delta_x_amplitude`` or ``delta_y_amplitude``,
    ``cycles``) or an explicit path (``states``, the file's ``path`` key), never two of them.

    Attributes:
        delta_z: final normal approach [m] of the default or cyclic path; None with an explicit path.
        delta_x: final tangential approach along x [m] of the default path.
        delta_y: final tangential approach along y [m] of the default path.
        steps: equal steps per leg of the default path (normal leg, then tangential leg).
        normal_steps: equal steps of the normal leg where they differ from ``steps`` (None: ``steps``).
        tangential_steps: equal steps of the tangential leg where they differ from ``steps`` (None:
            ``steps``); on a cyclic path, the steps of each quarter cycle.
        delta_x_amplitude: displacement amplitude along x [m], > 0, of a cyclic path (fretting): after
            the normal leg, delta_x goes 0 -> +amplitude (the first quarter), then ``cycles`` times
            +amplitude -> -amplitude -> +amplitude; None: no cyclic path.
        delta_y_amplitude: displacement amplitude along y [m], > 0, of a cyclic path, in phase with
            ``delta_x_amplitude``; None: none along y.
        cycles: whole cycles of a cyclic path after its first quarter, 1 to 10000 (default 1).
        states: the explicit path, (delta_x, delta_y, delta_z) triples [m] in order; None for the
            default path.
    """

    delta_z: float | None = None
    delta_x: float = 0.0
    delta_y: float = 0.0
    steps: int = 1
    tangential_steps: int | None = None
    states: tuple[State, ...] | None = None
    normal_steps: int | None = None
    delta_x_amplitude: float | None = None
    delta_y_amplitude: float | None = None
    cycles: int = 1

    def __post_init__(self):
        if self.states is not None:
            if self.delta_z is not None:
                raise InputError("load.delta_z", "must not be given together with load.path (the path lists every state)")
            for name, default in (("delta_x", 0.0), ("delta_y", 0.0), ("steps", 1), ("normal_steps", None),
                                  ("tangential_steps", None), ("delta_x_amplitude", None),
                                  ("delta_y_amplitude", None), ("cycles", 1)):
                if getattr(self, name) != default:
                    raise InputError(f"load.{name}", "must not be given together with load.path (the path lists every state)")
            _set(self, "states", _path_states(self.states))
            return
        if self.delta_z is None:
            raise InputError("load.delta_z", "is required (or give load.path)")
        _set(self, "delta_z", _number("load.delta_z", self.delta_z, unit="m"))
        _set(self, "delta_x", _number("load.delta_x", self.delta_x, unit="m"))
        _set(self, "delta_y", _number("load.delta_y", self.delta_y, unit="m"))
        _set(self, "steps", _integer("load.steps", self.steps, 1, MAX_STEPS))
        for name in ("normal_steps", "tangential_steps"):
            if getattr(self, name) is not None:
                _set(self, name, _integer(f"load.{name}", getattr(self, name), 1, MAX_STEPS))
        for name in ("delta_x_amplitude", "delta_y_amplitude"):
            if getattr(self, name) is not None:
                _set(self, name, _positive(f"load.{name}", getattr(self, name), "m"))
        _set(self, "cycles", _integer("load.cycles", self.cycles, 1, MAX_CYCLES))
        if not self.cyclic:
            if self.cycles != 1:
                raise _cycles_without_amplitude()
            return
        for name in ("delta_x", "delta_y"):
            if getattr(self, name) != 0.0:
                amplitude = f"load.{name}_amplitude"
                raise InputError(f"load.{name}", f"must be left out of a cyclic path (its tangential approach runs "
                                                 f"between -{amplitude} and +{amplitude}); give one or the other")
        quarters = 1 + 4 * self.cycles
        total = self.normal_leg_steps + quarters * self.tangential_leg_steps
        if total > 2 * MAX_STEPS:
            raise InputError("load.cycles", f"{self.cycles} cycle(s) of 4 x {self.tangential_leg_steps} steps after "
                                            f"the first quarter and {self.normal_leg_steps} normal steps give {total} "
                                            f"states; a path holds at most {2 * MAX_STEPS}: take fewer cycles or fewer "
                                            "load.tangential_steps")

    @property
    def explicit(self) -> bool:
        """True when the path was given state by state (the ``path`` key)."""
        return self.states is not None

    @property
    def cyclic(self) -> bool:
        """True for a cyclic (fretting) path: an amplitude was given."""
        return self.delta_x_amplitude is not None or self.delta_y_amplitude is not None

    @property
    def normal_leg_steps(self) -> int | None:
        """The normal leg's equal steps: ``normal_steps``, else ``steps`` (an explicit path: None)."""
        if self.states is not None:
            return None
        return self.steps if self.normal_steps is None else self.normal_steps

    @property
    def tangential_leg_steps(self) -> int | None:
        """The tangential leg's equal steps (a cyclic path: per quarter cycle): ``tangential_steps``,
        else ``steps`` (an explicit path: None)."""
        if self.states is not None:
            return None
        return self.steps if self.tangential_steps is None else self.tangential_steps

    def cycle_bounds(self) -> list[tuple[int, int]]:
        """The whole cycles of a cyclic path as (first, last) indices into :meth:`path`: each cycle
        runs from the state at +amplitude (the last of the first quarter, or of the cycle before)
        through -amplitude back to +amplitude, 4 ``tangential_leg_steps`` steps. Empty for a path
        that is not cyclic."""
        if not self.cyclic:
            return []
        n, q = self.normal_leg_steps, self.tangential_leg_steps
        first = n + q - 1
        return [(first + 4 * q * c, first + 4 * q * (c + 1)) for c in range(self.cycles)]

    def path(self) -> list[State]:
        """The (delta_x, delta_y, delta_z) states [m] of the path, in the order they are solved.

        Default path: delta_z in ``normal_steps`` (default ``steps``) equal steps with delta_x =
        delta_y = 0, then delta_x and delta_y together in ``tangential_steps`` (default ``steps``)
        equal steps at the final delta_z (that leg is left out when delta_x = delta_y = 0). A cyclic
        path has the same normal leg, then the tangential approach s (delta_x_amplitude,
        delta_y_amplitude) with s going 0 -> 1 in ``tangential_steps`` steps (the first quarter)
        and ``cycles`` times 1 -> -1 -> 1 in 4 ``tangential_steps`` steps. The unloaded state
        (0, 0, 0) is not part of the path.
        """
        if self.states is not None:
            return list(self.states)
        n = self.normal_leg_steps
        states = [(0.0, 0.0, self.delta_z * k / n) for k in range(1, n + 1)]
        states[-1] = (0.0, 0.0, self.delta_z)
        q = self.tangential_leg_steps
        if self.cyclic:
            ax, ay = self.delta_x_amplitude or 0.0, self.delta_y_amplitude or 0.0
            # s at each step: 1 - k / q on the way down, k / q - 1 back up (exact at 0 and +-1)
            s = [k / q for k in range(1, q + 1)]
            for _ in range(self.cycles):
                s += [1.0 - k / q for k in range(1, 2 * q + 1)] + [k / q - 1.0 for k in range(1, 2 * q + 1)]
            return states + [(ax * f + 0.0, ay * f + 0.0, self.delta_z) for f in s]  # + 0.0: no -0.0
        if self.delta_x != 0.0 or self.delta_y != 0.0:
            states += [(self.delta_x * k / q, self.delta_y * k / q, self.delta_z) for k in range(1, q + 1)]
            states[-1] = (self.delta_x, self.delta_y, self.delta_z)
        return states

    @property
    def delta_z_max(self) -> float:
        """The largest normal approach on the path [m]."""
        return max(s[2] for s in self.path())

    def to_dict(self) -> dict:
        if self.states is not None:
            return {"path": [list(s) for s in self.states]}
        out = {"delta_z": self.delta_z}
        if self.cyclic:
            out.update({k: getattr(self, k) for k in CYCLIC_KEYS if getattr(self, k) is not None})
        else:
            out.update(delta_x=self.delta_x, delta_y=self.delta_y)
        out["steps"] = self.steps
        for name in ("normal_steps", "tangential_steps"):
            if getattr(self, name) is not None:
                out[name] = getattr(self, name)
        return out


def _cycles_without_amplitude() -> InputError:
    return InputError("load.cycles", "belongs to a cyclic path: give load.delta_x_amplitude or load.delta_y_amplitude "
                                     "(m) with it")


def _path_states(v) -> tuple[State, ...]:
    key = "load.path"
    shape = "an array of [delta_x, delta_y, delta_z] arrays in m"
    if isinstance(v, (str, bytes, Mapping)) or not isinstance(v, (Sequence, np.ndarray)):
        raise InputError(key, f"must be {shape}, {_got(v)}")
    if len(v) == 0:
        raise InputError(key, f"must hold at least one state ({shape}), got an empty array")
    if len(v) > 2 * MAX_STEPS:
        raise InputError(key, f"must hold at most {2 * MAX_STEPS} states, got {len(v)}")
    states = []
    for i, s in enumerate(v):
        if isinstance(s, (str, bytes, Mapping)) or not isinstance(s, (Sequence, np.ndarray)) or len(s) != 3:
            raise InputError(key, f"entry {i} must be [delta_x, delta_y, delta_z] (3 numbers in m), {_got(s)}")
        state = []
        for j, (name, x) in enumerate(zip(("delta_x", "delta_y", "delta_z"), s)):
            if _is_bool(x) or not isinstance(x, numbers.Real):
                raise InputError(key, f"entry {i} ({name}) must be a number in m, {_got(x)}")
            try:
                x = float(x)
            except OverflowError:
                x = math.inf
            if not math.isfinite(x):
                raise InputError(key, f"entry {i} ({name}) must be finite, got {x!r}")
            state.append(x)
        states.append(tuple(state))
    return tuple(states)


def _load_from(ld: Mapping) -> LoadSpec:
    _check_keys("load", ld, LOAD_KEYS)
    if "path" in ld:
        for k in DEFAULT_PATH_KEYS:
            if k in ld:
                raise InputError(f"load.{k}", "must not be given together with load.path (the path lists every state)")
        return LoadSpec(states=_path_states(ld["path"]))
    if "delta_z" not in ld:
        raise InputError("load.delta_z", "is required (or give load.path)")
    if "cycles" in ld and not any(k in ld for k in ("delta_x_amplitude", "delta_y_amplitude")):
        raise _cycles_without_amplitude()
    return LoadSpec(**{k: ld[k] for k in DEFAULT_PATH_KEYS if k in ld})
