"""The cost of one state's summary: reduced on the device against the host numpy path it replaced.

``results.state_summary`` reduces the forces, the areas, the maximum pressure and the stick
centroid on the model's device in one pass (``kernels/summary.py``) and brings a 12-entry array
to the host. Before, it copied every field to the host as SI float64 arrays (``to_numpy_si``),
summed them with numpy and built the (n, n) coordinate mesh for the centroid; that path is kept
here (:func:`host_summary`) to time it in the same run. Both run on one synthetic state (a
Cattaneo-Mindlin-like traction field: a stick disk inside a slip annulus, and an adhesive ring
outside the contact with a Dugdale law), on the device and float type given.

Columns: ``host numpy`` the old path, ``of which copies`` its field copies to the host
(``to_numpy_si`` and the status), ``device`` the new path, median of ``--repeat`` calls after a
first (compiling) one, in ms; ``force error``: the largest difference of the six force sums from
the host path's, over the sum of the magnitudes |x| dA that bounds a float64 sum's rounding. With
``--dtype float32`` also the same kernel accumulating in float32 (an overload registered here
only): its time and its force error, which is why the package accumulates in float64.

    python bench/summary_cost.py --device cpu [--sizes 256 512 1024] [--dtype float64]
    python bench/summary_cost.py --device cuda:0 [--sizes 1024 4096 8192]
"""

from __future__ import annotations

import argparse
import math
import statistics
import time

import numpy as np
import warp as wp

from warpcontact import quiet_warp
from warpcontact.physics.adhesion import Dugdale
from warpcontact.physics.geometry import Grid, Sphere
from warpcontact.kernels import summary as sk
from warpcontact.kernels.tangential import SLIP, STICK
from warpcontact.numerics.launch import FirstRow, Rows, Sums
from warpcontact.physics.materials import PAPER_PAIR
from warpcontact.numerics.model import ContactModel
from warpcontact.records.results import adhesive_mask, state_summary
from warpcontact.numerics.state import ContactState

R = 10e-6
FORCES = (("force", "x"), ("force", "y"), ("force", "z"), ("force_elastic", "x"), ("force_elastic", "y"),
          ("force_elastic", "z"))


def host_summary(state, adhesion=None) -> dict:
    """The summary as ``results.state_summary`` made it before the device reduction: every field
    copied to the host in SI units, numpy sums, the (n, n) mesh for the stick centroid (the
    numbers that ``state_summary`` also returns, less the convergence record)."""
    m = state.model
    f = state.to_numpy_si()
    dA = m.grid.cell_area
    contact = f["pressure"] > 0
    adhesive = adhesive_mask(f, adhesion)
    stick = state.status.numpy() == STICK
    X, Y = m.grid.mesh()
    area = float(contact.sum() * dA)
    return {
        "force": {
            "x": float((f["shear_x"] + f["adhesive_shear_x"]).sum() * dA),
            "y": float((f["shear_y"] + f["adhesive_shear_y"]).sum() * dA),
            "z": float((f["pressure"] + f["adhesive_pressure"]).sum() * dA),
        },
        "force_elastic": {
            "x": float(f["shear_x"].sum() * dA),
            "y": float(f["shear_y"].sum() * dA),
            "z": float(f["pressure"].sum() * dA),
        },
        "adhesive_area": float(adhesive.sum() * dA),
        "contact_area": area,
        "contact_radius": math.sqrt(area / math.pi),
        "max_pressure": float(f["pressure"].max()),
        "stick_area": float(stick.sum() * dA),
        "stick_centroid": {"x": float(X[stick].mean()), "y": float(Y[stick].mean())} if stick.any() else None,
    }


def magnitudes(state) -> dict:
    """sum |x| dA [N] of each force sum's terms (the scale of its rounding)."""
    f = state.to_numpy_si()
    dA = state.model.grid.cell_area
    out = {}
    for c, q in (("x", "shear_x"), ("y", "shear_y"), ("z", "pressure")):
        adh = "adhesive_" + q
        out[("force", c)] = float((np.abs(f[q]) + np.abs(f[adh])).sum() * dA)
        out[("force_elastic", c)] = float(np.abs(f[q]).sum() * dA)
    return out


def synthetic_state(n: int, device: str, dtype: str):
    """A state of an n x n grid without solving: Hertz-like pressure over a disk of radius 0.3 of
    the domain, Cattaneo-Mindlin shear with a stick disk of radius 0.2 inside a slip annulus (and a
    small y shear, odd in y), an adhesive ring (Dugdale, tension and shear) for 0.1 of the domain
    beyond the contact; 1 % random noise on the tractions (seeded)."""
    size = 1e-6
    model = ContactModel(PAPER_PAIR, Sphere(R), Grid(n, size), device=device, dtype=dtype)
    law = Dugdale(2e7, 2e-9)
    rng = np.random.default_rng(1)
    x = (np.arange(n) - 0.5 * (n - 1)) / n  # cell centres / size
    X, Y = np.meshgrid(x, x, indexing="xy")
    r = np.hypot(X + 0.01, Y)  # off centre by 1 % of the domain: a centroid away from 0
    a, c, ring = 0.3, 0.2, 0.1
    p = 0.01 * np.sqrt(np.clip(1 - (r / a) ** 2, 0, None))
    qx = 0.3 * 0.01 / a * (np.sqrt(np.clip(a * a - r * r, 0, None)) - np.sqrt(np.clip(c * c - r * r, 0, None)))
    noise = lambda: 1 + 0.01 * rng.standard_normal((n, n))  # noqa: E731
    gap_m = np.clip(r - a, 0, None) / ring * law.h_0  # at h_0 a ring's width beyond the contact
    outside = (p <= 0) & (gap_m <= law.range)
    state = ContactState(model)
    values = {
        "pressure": p * noise(),
        "shear_x": qx * noise(),
        "shear_y": 1e-3 * qx * Y / a * noise(),
        "gap": gap_m / model.length_scale,
        "adhesive_pressure": np.where(outside, -law.sigma_0 / model.traction_scale, 0.0) * noise(),
        "adhesive_shear_x": np.where(outside, 1e-4, 0.0) * noise(),
        "adhesive_shear_y": np.where(outside, 1e-4 * Y, 0.0) * noise(),
    }
    for name, v in values.items():
        getattr(state, name).assign(np.asarray(v, dtype=model.np_dtype))
    status = np.where(r < c, int(STICK), np.where(r < a, int(SLIP), 0)).astype(np.int32)
    state.status.assign(status)
    return model, state, law


def float32_buffers(model):
    """The float32 sums and their starting values (0, -inf for the maximum) on the model's device."""
    start = np.zeros(sk.N_SUMMARY, dtype=np.float32)
    start[sk.S_MAX_PRESSURE] = -np.inf
    return (wp.zeros(sk.N_SUMMARY, dtype=wp.float32, device=model.device),
            wp.array(start, dtype=wp.float32, device=model.device))


def float32_sums(state, law, buffers):
    """The summary kernel with float32 sums (``buffers``: :func:`float32_buffers`): the overload
    the package does not register, for the comparison of the accumulations; launched as
    ``results.summary_sums`` launches the float64 one."""
    m = state.model
    sums, start = buffers
    if m.dtype != wp.float32:
        raise ValueError("float32_sums: a float32 state")
    wp.copy(sums, start)
    fields = [Rows(getattr(state, name).flatten()) for name in (
        "pressure", "adhesive_pressure", "shear_x", "adhesive_shear_x", "shear_y", "adhesive_shear_y", "gap", "status")]
    rows, columns = m.grid.shape
    m.launch_reduce(sk.summary_sums, [*fields, columns, rows, FirstRow(), wp.float64(m.length_scale),
                                      wp.float64(law.range), 1], [Sums(sums, maxima=(int(sk.S_MAX_PRESSURE),))])
    s = sums.numpy().astype(np.float64)
    E, dA = m.traction_scale, m.grid.cell_area
    return {("force", "z"): s[sk.S_FORCE_Z] * E * dA, ("force", "x"): s[sk.S_FORCE_X] * E * dA,
            ("force", "y"): s[sk.S_FORCE_Y] * E * dA, ("force_elastic", "z"): s[sk.S_ELASTIC_Z] * E * dA,
            ("force_elastic", "x"): s[sk.S_ELASTIC_X] * E * dA, ("force_elastic", "y"): s[sk.S_ELASTIC_Y] * E * dA}


def median_ms(fn, repeat: int) -> float:
    fn()  # compiles, allocates the buffers
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return 1e3 * statistics.median(times)


def force_error(got: dict, ref: dict, scale: dict) -> float:
    return max(abs(got[k] - ref[k[0]][k[1]]) / scale[k] for k in FORCES)


def check_same(dev: dict, host: dict):
    """The counts, the maximum pressure and the centroid must agree (the exact parts)."""
    for key in ("contact_area", "stick_area", "adhesive_area", "max_pressure"):
        if dev[key] != host[key]:
            raise SystemExit(f"{key}: device {dev[key]!r} != host {host[key]!r}")
    for c in "xy":
        d, h = dev["stick_centroid"][c], host["stick_centroid"][c]
        if abs(d - h) > 1e-9 * 1e-6:  # far above the rounding, far below a cell (1e-6 m / n)
            raise SystemExit(f"stick_centroid.{c}: device {d!r} != host {h!r}")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--sizes", type=int, nargs="+", default=None,
                    help="cells per side (default: 256 512 1024 on the CPU, 1024 4096 8192 on CUDA)")
    ap.add_argument("--dtype", default="float64", choices=["float64", "float32"])
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    quiet_warp()
    wp.init()
    sizes = args.sizes or ([256, 512, 1024] if args.device == "cpu" else [1024, 4096, 8192])
    device = wp.get_device(args.device)
    if args.dtype == "float32":  # before the module's first build: it compiles once
        wp.overload(sk.summary_sums, {
            **{name: wp.array(dtype=wp.float32) for name in (
                "pressure", "adhesive_pressure", "shear_x", "adhesive_shear_x", "shear_y", "adhesive_shear_y", "gap")},
            "sums": wp.array(dtype=wp.float32),
        })
    print(f"device {device.alias} ({device.name}), {args.dtype} fields, median of {args.repeat} calls\n")
    head = "| n | host numpy [ms] | of which copies [ms] | device [ms] | speed-up | force error |"
    rule = "|---|---|---|---|---|---|"
    if args.dtype == "float32":
        head += " float32 sums [ms] | float32 sums' force error |"
        rule += "---|---|"
    print(head)
    print(rule)
    for n in sizes:
        model, state, law = synthetic_state(n, args.device, args.dtype)
        host = host_summary(state, law)
        dev = state_summary(state, law)
        check_same(dev, host)
        scale = magnitudes(state)
        err = force_error({k: dev[k[0]][k[1]] for k in FORCES}, host, scale)
        t_host = median_ms(lambda: host_summary(state, law), args.repeat)
        t_copy = median_ms(lambda: (state.to_numpy_si(), state.status.numpy()), args.repeat)
        t_dev = median_ms(lambda: state_summary(state, law), args.repeat)
        row = f"| {n} | {t_host:.1f} | {t_copy:.1f} | {t_dev:.2f} | {t_host / t_dev:.0f}x | {err:.1e} |"
        if args.dtype == "float32":
            buffers = float32_buffers(model)
            err32 = force_error(float32_sums(state, law, buffers), host, scale)
            t32 = median_ms(lambda: float32_sums(state, law, buffers), args.repeat)
            row += f" {t32:.2f} | {err32:.1e} |"
        print(row, flush=True)


if __name__ == "__main__":
    main()
