"""The one place that turns user names of devices and float types into Warp objects."""

from __future__ import annotations

import os
import re
import sys
import tempfile

import numpy as np
import warp as wp

from ..errors import InputError

_DTYPES = {"float64": wp.float64, "float32": wp.float32}


# what Warp's native start-up prints on a machine without an NVIDIA driver: noise for a CPU run;
# a case that asks for CUDA there is refused by resolve_device with the key to change
NO_DRIVER_NOTICE = "Warp CUDA warning: Could not find or load the NVIDIA CUDA driver"

_initialised = False


def init_warp(quiet: bool = True):
    """Initialise Warp once, quietly: without its banner and, where no NVIDIA driver is installed,
    without its notice that GPU execution is not available (anything else it prints is kept)."""
    global _initialised
    wp.config.quiet = quiet
    if quiet:
        wp.config.log_level = wp.LOG_WARNING
    if _initialised or not quiet:
        wp.init()
    else:
        _init_without_driver_notice()
    _initialised = True


def _init_without_driver_notice():
    """``wp.init()`` with the native library's standard error caught in a file (it writes to file
    descriptor 2, below Python) and written back but for :data:`NO_DRIVER_NOTICE`."""
    sys.stderr.flush()
    with tempfile.TemporaryFile() as caught:
        saved = os.dup(2)
        os.dup2(caught.fileno(), 2)
        try:
            wp.init()
        finally:
            os.dup2(saved, 2)
            os.close(saved)
        caught.seek(0)
        text = caught.read().decode(errors="replace")
    kept = [line for line in text.splitlines(keepends=True) if not line.startswith(NO_DRIVER_NOTICE)]
    if kept:
        sys.stderr.write("".join(kept))
        sys.stderr.flush()


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
