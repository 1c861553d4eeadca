"""Probe: why the normal solver's update pass (``normal_update``) takes about twice the time its
bytes need on a GPU, by variants of it side by side in one run.

At n = 1024 on an H100 (float64, L2 flushed before each call) ``normal_update`` took 31 us
(``bench/reduction_launch.py --cold``) for about 42 MB of traffic (p, g, t and K t read, b read on
the contact, g written), 15 us at the copy bandwidth. The variants, each launched like the
solver's pass over the same solved Hertz state (tau = 0 on an iterate not converged: the whole
path runs, p and g stay), isolate one suspect each:

- ``as solved``: the solver's kernel (4 blocks per SM);
- ``no block sum``: the same loop, its five block sums kept from the compiler but not reduced
  (they are written only where they cannot be: a negative count);
- ``two cells``: the loop takes two cells per turn, every load of both before any store (the
  compiler may not move a load above a store to another array, which serialises the turns);
- ``stream``: the traffic alone: g <- g - tau K t with p, t and b read, one sum;
- ``prefetch``: b read with p, g, t and K t on every cell (no load that waits for the step), and
  the next cell's loads issued before this cell's stores (inside a solve it was slower: README).

With their register counts (``wp.get_cuda_kernel_properties``), which set how many blocks of 256
threads an SM holds at once (65536 registers per SM on an H100: 4 blocks at 64 registers or fewer).
``--registers`` then times the solver's three reducing kernels of the grid (``normal_update``,
``normal_gap``, ``normal_direction_sum``) as they are and compiled with ``cuda_max_registers``
caps, at 4 and 8 blocks per SM.

    python bench/update_variants.py --device cuda:0 --sizes 1024 2048 [--cold]
"""

from __future__ import annotations

import argparse
import math
import time
from typing import Any

import warp as wp

from iteration_parts import timed_ms  # bench/, beside this script
from warpcontact.physics.geometry import Grid, Sphere
from warpcontact.kernels import normal as nk
from warpcontact.kernels.overloads import float_overload, register_float_overloads
from warpcontact.kernels.reduce import block_add, block_add_vector, cell_index, cg_converged, cg_step_length
from warpcontact.numerics.launch import ReductionLaunch
from warpcontact.physics.materials import PAPER_PAIR
from warpcontact.numerics.model import ContactModel
from warpcontact.solvers import NormalSolver
from warpcontact.numerics.state import ContactState

R, DZ = 10e-6, 1.0e-10
A = math.sqrt(R * DZ)

wp.set_module_options({"enable_backward": False})


@wp.func
def update_cell(i: int, tau: Any, done: bool, output_scale: Any, width: int, pressure_cap: Any,
                direction: wp.array(dtype=Any), padded_output: wp.array2d(dtype=Any),
                interference: wp.array(dtype=Any), pressure: wp.array(dtype=Any), gap: wp.array(dtype=Any)):
    """The solver's per-cell work of ``normal_update`` (loads, step, stores, residual terms)."""
    zero = pressure_cap - pressure_cap
    p = pressure[i]
    g = gap[i]
    t = direction[i]
    r = output_scale * nk.padded_entry(padded_output, i, width)
    entered = zero
    changed = zero
    if not done:
        old = p
        p, g, entered, changed = nk.projected_step(p, g, t, r, tau, pressure_cap)
        if p != old:
            pressure[i] = p
        gap[i] = g
    b = zero
    if p > zero:
        b = interference[i]
    dg, dv, dr = nk.residual_terms(p, g, b, pressure_cap)
    return wp.vector(entered, changed, dg, dv, dr)


@wp.kernel
def update_no_block_sum(direction: wp.array(dtype=Any), padded_output: wp.array2d(dtype=Any), output_scale: Any,
                        width: int, interference: wp.array(dtype=Any), pressure_cap: Any,
                        settings: wp.array(dtype=Any), n: int, outer: int, inner: int, per: int,
                        pressure: wp.array(dtype=Any), gap: wp.array(dtype=Any), sums: wp.array(dtype=Any)):
    block, lane = wp.tid()
    thread = block * wp.block_dim() + lane
    tau = cg_step_length(sums)
    done = cg_converged(sums, settings[nk.P_TOL])
    zero = output_scale - output_scale
    acc = wp.vector(zero, zero, zero, zero, zero)
    for k in range(per):
        i = cell_index(thread, outer, inner, k)
        if i < n:
            acc += update_cell(i, tau, done, output_scale, width, pressure_cap, direction, padded_output,
                               interference, pressure, gap)
    if acc[0] < zero:  # never: keeps the sums alive without reducing them
        for c in range(5):
            sums[nk.S_IOL + c] = acc[c]


@wp.kernel
def update_two_cells(direction: wp.array(dtype=Any), padded_output: wp.array2d(dtype=Any), output_scale: Any,
                     width: int, interference: wp.array(dtype=Any), pressure_cap: Any,
                     settings: wp.array(dtype=Any), n: int, outer: int, inner: int, per: int,
                     pressure: wp.array(dtype=Any), gap: wp.array(dtype=Any), sums: wp.array(dtype=Any)):
    block, lane = wp.tid()
    thread = block * wp.block_dim() + lane
    tau = cg_step_length(sums)
    done = cg_converged(sums, settings[nk.P_TOL])
    zero = output_scale - output_scale
    acc = wp.vector(zero, zero, zero, zero, zero)
    for k in range(0, per, 2):
        i0 = cell_index(thread, outer, inner, k)
        i1 = cell_index(thread, outer, inner, k + 1)
        if i1 < n:
            # all loads of both cells first
            p0 = pressure[i0]
            g0 = gap[i0]
            t0 = direction[i0]
            r0 = output_scale * nk.padded_entry(padded_output, i0, width)
            b0 = zero
            if p0 > zero or g0 < zero:  # b is read where p may be > 0 after the step
                b0 = interference[i0]
            p1 = pressure[i1]
            g1 = gap[i1]
            t1 = direction[i1]
            r1 = output_scale * nk.padded_entry(padded_output, i1, width)
            b1 = zero
            if p1 > zero or g1 < zero:
                b1 = interference[i1]
            if not done:
                q0, h0, e0, c0 = nk.projected_step(p0, g0, t0, r0, tau, pressure_cap)
                q1, h1, e1, c1 = nk.projected_step(p1, g1, t1, r1, tau, pressure_cap)
                if q0 != p0:
                    pressure[i0] = q0
                if q1 != p1:
                    pressure[i1] = q1
                gap[i0] = h0
                gap[i1] = h1
                acc += wp.vector(e0 + e1, c0 + c1, zero, zero, zero)
                p0 = q0
                p1 = q1
                g0 = h0
                g1 = h1
            dg0, dv0, dr0 = nk.residual_terms(p0, g0, wp.where(p0 > zero, b0, zero), pressure_cap)
            dg1, dv1, dr1 = nk.residual_terms(p1, g1, wp.where(p1 > zero, b1, zero), pressure_cap)
            acc += wp.vector(zero, zero, dg0 + dg1, dv0 + dv1, dr0 + dr1)
        elif i0 < n:
            acc += update_cell(i0, tau, done, output_scale, width, pressure_cap, direction, padded_output,
                               interference, pressure, gap)
    block_add_vector(sums, nk.S_IOL, acc, lane)


@wp.kernel
def update_stream(direction: wp.array(dtype=Any), padded_output: wp.array2d(dtype=Any), output_scale: Any,
                  width: int, interference: wp.array(dtype=Any), pressure_cap: Any,
                  settings: wp.array(dtype=Any), n: int, outer: int, inner: int, per: int,
                  pressure: wp.array(dtype=Any), gap: wp.array(dtype=Any), sums: wp.array(dtype=Any)):
    block, lane = wp.tid()
    thread = block * wp.block_dim() + lane
    tau = cg_step_length(sums)
    zero = output_scale - output_scale
    s = zero
    for k in range(per):
        i = cell_index(thread, outer, inner, k)
        if i < n:
            p = pressure[i]
            t = direction[i]
            g = gap[i] - tau * output_scale * nk.padded_entry(padded_output, i, width)
            gap[i] = g
            if p > zero:
                s += g * g + t * interference[i]
    block_add(sums, nk.S_NEXT_VIOL, s)


@wp.func
def step_cell(p: Any, g: Any, t: Any, r: Any, b: Any, tau: Any, done: bool, pressure_cap: Any, i: int,
              pressure: wp.array(dtype=Any), gap: wp.array(dtype=Any)):
    """``update_cell`` from values already loaded (b read unconditionally): step, stores, terms."""
    zero = pressure_cap - pressure_cap
    entered = zero
    changed = zero
    q = p
    h = g
    if not done:
        q, h, entered, changed = nk.projected_step(p, g, t, r, tau, pressure_cap)
        if q != p:
            pressure[i] = q
        gap[i] = h
    dg, dv, dr = nk.residual_terms(q, h, wp.where(q > zero, b, zero), pressure_cap)
    return wp.vector(entered, changed, dg, dv, dr)


@wp.kernel
def update_prefetch(direction: wp.array(dtype=Any), padded_output: wp.array2d(dtype=Any), output_scale: Any,
                    width: int, interference: wp.array(dtype=Any), pressure_cap: Any,
                    settings: wp.array(dtype=Any), n: int, outer: int, inner: int, per: int,
                    pressure: wp.array(dtype=Any), gap: wp.array(dtype=Any), sums: wp.array(dtype=Any)):
    block, lane = wp.tid()
    thread = block * wp.block_dim() + lane
    tau = cg_step_length(sums)
    done = cg_converged(sums, settings[nk.P_TOL])
    zero = output_scale - output_scale
    acc = wp.vector(zero, zero, zero, zero, zero)
    i = cell_index(thread, outer, inner, 0)
    p = zero
    g = zero
    t = zero
    r = zero
    b = zero
    if i < n:
        p = pressure[i]
        g = gap[i]
        t = direction[i]
        r = output_scale * nk.padded_entry(padded_output, i, width)
        b = interference[i]
    for k in range(per):
        if i < n:
            # the next cell's loads before this cell's stores
            j = cell_index(thread, outer, inner, k + 1)
            pn = zero
            gn = zero
            tn = zero
            rn = zero
            bn = zero
            if k + 1 < per and j < n:
                pn = pressure[j]
                gn = gap[j]
                tn = direction[j]
                rn = output_scale * nk.padded_entry(padded_output, j, width)
                bn = interference[j]
            acc += step_cell(p, g, t, r, b, tau, done, pressure_cap, i, pressure, gap)
            i = j
            p = pn
            g = gn
            t = tn
            r = rn
            b = bn
    block_add_vector(sums, nk.S_IOL, acc, lane)


for _k in (update_no_block_sum, update_two_cells, update_stream, update_prefetch):
    register_float_overloads(_k)


_capped = {}


def capped(kernel, registers: int):
    """``kernel`` compiled with ``cuda_max_registers=registers`` (a module of its own)."""
    key = (kernel.key, registers)
    if key not in _capped:
        _capped[key] = register_float_overloads(wp.kernel(kernel.func, cuda_max_registers=registers, module="unique"))
    return _capped[key]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--device", default="cuda:0")
    ap.add_argument("--sizes", type=int, nargs="*", default=[1024, 2048])
    ap.add_argument("--cold", action="store_true", help="each call after an L2 flush, its time subtracted")
    ap.add_argument("--registers", type=int, nargs="*", default=[64, 32],
                    help="cuda_max_registers caps to compile the solver's reducing kernels with")
    ap.add_argument("--per-sm", type=int, nargs="*", default=[2, 4, 8], help="blocks per SM of the variants' launches")
    args = ap.parse_args()
    wp.config.quiet = True
    wp.init()
    device = wp.get_device(args.device)
    cold = ", cold (L2 flushed before each call)" if args.cold else ""
    print(f"# normal_update variants, ms per call{cold}; device {device} ({device.name}), float64, "
          f"{time.strftime('%Y-%m-%d')}")
    variants = {"as solved": nk.normal_update, "no block sum": update_no_block_sum, "two cells": update_two_cells,
                "stream": update_stream, "prefetch": update_prefetch}
    if device.is_cuda:
        regs = {}
        for name, k in variants.items():
            props = wp.get_cuda_kernel_properties(float_overload(k, wp.float64), device, block_dim=256)
            regs[name] = f"{props['register_count']} regs, {props['local_memory_size']} B local"
        print("# " + "; ".join(f"{name}: {r}" for name, r in regs.items()))
    for n in args.sizes:
        m = ContactModel(PAPER_PAIR, Sphere(R, "paraboloid"), Grid(n, 4 * A), device=device)
        s = NormalSolver(m)
        st = ContactState(m)
        s.solve(st, DZ)
        fft = m.operator.fft
        p, g, t, b = (a.flatten() for a in (st.pressure, st.gap, s.direction, s.interference))
        inputs = [t, fft.padded_output, fft.output_scale, n, b, s._cap, s.settings]
        # tau = 0 (g.t = 0, t.Kt = 1) on an iterate not converged (residual 1): the whole path runs
        s.sums.assign([0.0, 1.0, 1.0, 0.0, 1.0] + [0.0] * (nk.N_SUMS - 5))
        row = []
        for per_sm in args.per_sm:
            shape = ReductionLaunch.for_cells(m.n_cells, device, blocks_per_sm=per_sm)
            for name, k in variants.items():
                ms = timed_ms(device, lambda k=k: m.launches.launch_reduce(k, shape, m.n_cells, inputs, [p, g, s.sums]),
                              cold=args.cold)
                row.append(f"{name} {per_sm}/SM {1e3 * ms:.1f}")
        print(f"N = {n:5d} (us): " + "  ".join(row), flush=True)
        reducing = {
            "normal_update": (nk.normal_update, inputs, [p, g, s.sums]),
            "normal_gap": (nk.normal_gap, [st.disp_z.flatten(), b, p, s._cap], [g, s.sums]),
            "normal_direction_sum": (nk.normal_direction_sum, [g, p, s._cap, s.sums, s.scalars, fft.padded_output,
                                                           fft.output_scale, int(s.preconditioned), n],
                                     [t, fft.padded_input]),
        }
        for name, (kernel, k_in, k_out) in reducing.items():
            row = []
            for cap in [None, *args.registers]:
                k = kernel if cap is None else capped(kernel, cap)
                label = "as is" if cap is None else f"max {cap}"
                if device.is_cuda:
                    regs = wp.get_cuda_kernel_properties(float_overload(k, wp.float64), device, block_dim=256)
                    label += f" ({regs['register_count']} regs, {regs['local_memory_size']} B local)"
                for per_sm in (4, 8):
                    shape = ReductionLaunch.for_cells(m.n_cells, device, blocks_per_sm=per_sm)
                    ms = timed_ms(device, lambda k=k: m.launches.launch_reduce(k, shape, m.n_cells, k_in, k_out),
                                  cold=args.cold)
                    row.append(f"{label} {per_sm}/SM {1e3 * ms:.1f}")
                s.sums.assign([0.0, 1.0, 1.0, 0.0, 1.0] + [0.0] * (nk.N_SUMS - 5))
            print(f"N = {n:5d} {name} (us): " + "  ".join(row), flush=True)


if __name__ == "__main__":
    main()
