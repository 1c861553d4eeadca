"""The one place that turns user names of devices and float types into Warp objects."""

from __future__ import annotations

import re

import numpy as np
import warp as wp

from ..errors import InputError

_DTYPES = {"float64": wp.float64, "float32": wp.float32}


def init_warp(quiet: bool = True):
    """Initialise Warp once, quietly."""
    wp.config.quiet = quiet
    if quiet:
        wp.config.log_level = wp.LOG_WARNING
    wp.init()


def resolve_device(name) -> "wp.context.Device":
    """Warp device for "cpu", "cuda" or "cuda:N"; InputError naming ``solver.device`` otherwise."""
    init_warp()
    if not isinstance(name, str):
        name = str(name)
    if not re.fullmatch(r"cpu|cuda(:\d+)?", name):
        raise InputError("solver.device", f"unknown device {name!r}; use 'cpu', 'cuda' or 'cuda:N'")
    if name.startswith("cuda"):
        count = wp.get_cuda_device_count()
        ordinal = int(name.split(":")[1]) if ":" in name else 0
        if count == 0:
            raise InputError("solver.device", f"{name!r} was asked for, but no CUDA device is present here")
        if ordinal >= count:
            raise InputError("solver.device", f"{name!r} does not exist: {count} CUDA device(s) present")
    return wp.get_device(name)


def resolve_dtype(name):
    """Warp float type for "float32" or "float64"."""
    if name in (wp.float32, wp.float64):
        return name
    if name not in _DTYPES:
        raise InputError("solver.dtype", f"unknown dtype {name!r}; use 'float64' or 'float32'")
    return _DTYPES[name]


def dtype_name(dtype) -> str:
    return "float64" if dtype == wp.float64 else "float32"


def numpy_dtype(dtype):
    return np.float64 if dtype == wp.float64 else np.float32


def available_devices() -> list[str]:
    """"cpu" and every CUDA device present, as names."""
    init_warp()
    return ["cpu"] + [f"cuda:{i}" for i in range(wp.get_cuda_device_count())]
