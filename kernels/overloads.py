"""Registers the float32 and float64 overloads of generic kernels, so each module compiles once.

A generic kernel takes ``wp.array(dtype=Any)`` fields and ``Any`` scalars of one float type;
``register_float_overloads`` substitutes float32 and float64 for every ``Any``;
``register_complex_overloads`` the 2-vectors of complex numbers for the arrays it names. Kernels
whose ``Any`` stands for something else register their overloads by hand.
"""

from typing import Any

import warp as wp


def _substitute(arg_type, scalar):
    if isinstance(arg_type, wp.array) and arg_type.dtype is Any:
        return wp.array(dtype=scalar, ndim=arg_type.ndim)
    if arg_type is Any:
        return scalar
    return arg_type


def register_float_overloads(kernel):
    """Register ``kernel`` for float32 and float64; returns the kernel (usable as a decorator)."""
    for scalar in (wp.float32, wp.float64):
        wp.overload(kernel, [_substitute(a.type, scalar) for a in kernel.adj.args])
    return kernel


def float_overload(kernel, scalar):
    """The overload of a generic kernel registered by :func:`register_float_overloads` for the
    float type ``scalar`` (for ``wp.get_cuda_kernel_properties``, which takes a concrete one)."""
    return wp.overload(kernel, [_substitute(a.type, scalar) for a in kernel.adj.args])


def mixed_float_overloads(kernel, float32_args):
    """Register ``kernel`` with the arguments named in ``float32_args`` in float32 and every other
    ``Any`` in float64: the float64 solver kernels that read or write the buffers of a float32
    transform (``SolverSettings.preconditioner_float32``); returns the kernel."""
    wp.overload(kernel, [_substitute(a.type, wp.float32 if a.label in float32_args else wp.float64)
                         for a in kernel.adj.args])
    return kernel


def register_complex_overloads(kernel, complex_args):
    """Register ``kernel`` for float32 and float64 where the ``Any`` arrays named in
    ``complex_args`` hold complex numbers as 2-vectors (``wp.vec2f``, ``wp.vec2d``) and every
    other ``Any`` is the float type; returns the kernel."""
    for scalar, vector in ((wp.float32, wp.vec2f), (wp.float64, wp.vec2d)):
        wp.overload(kernel, [_substitute(a.type, vector if a.label in complex_args else scalar)
                             for a in kernel.adj.args])
    return kernel
