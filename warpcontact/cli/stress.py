"""``warpcontact stress CASE.toml --out DIR [--state K] [--depths Z ...]``: the stress below the
surface in both bodies at one state of a case's load path, and where each body first yields.

Solves the case's path, evaluates the stress of state K in the sphere and the flat
(``warpcontact.numerics.stress``) and writes DIR/stress.json, DIR/stress.npz, DIR/stress_section.png and
DIR/stress_profiles.png. Wire it into ``cli/__init__.py`` with::

    from .stress import add_parser, cmd_stress
    add_parser(sub)                  # in _parser(), on the subparsers object
    {..., "stress": cmd_stress}      # in main()'s table of commands
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

from ..records.case import FFT_BACKENDS

EXAMPLE_STRESS = """example:
  warpcontact stress examples/hertz.toml --out out/hertz_stress
  warpcontact stress examples/figure2b.toml --out out/f2b_stress --layers 48 --max-depth 6e-8
  warpcontact stress examples/hertz.toml --out out/hz --depths 5e-9 1e-8 1.5e-8 2e-8

writes OUT/stress.json (per body, "sphere" and "flat": von_mises_max and tresca_max with value [Pa]
and x, y, z [m], z the depth into that body; yield_strength, yielded, margin = yield strength /
von Mises max; first_yield on the path up to the state; a rigid body: rigid = true, yielded = null
and the reason, no stress field), OUT/stress.npz (depths, x, y; per body
the x-z section through the centre along the sliding direction and the axis profile of every
stress component and derived field, and with --volume every depth's fields), OUT/stress_section.png
(von Mises in the section, the sphere above the interface and the flat below) and
OUT/stress_profiles.png (stresses on the axis against depth)."""


def add_parser(sub):
    """Register the ``stress`` sub-command on an argparse subparsers object; returns its parser."""
    p = sub.add_parser(
        "stress",
        help="stress below the surface in the sphere and the flat, von Mises maxima and first yield",
        description="Solve the load path of CASE, then evaluate the full stress tensor in both bodies (each an "
        "elastic half-space with its own E, nu; a rigid body has no stress field) below the solved surface tractions (pressure, shear, adhesive "
        "parts) at a set of depths: von Mises, maximum shear, principal and hydrostatic stresses, their maxima, "
        "and the state at which each body first reaches its yield_strength.",
        epilog=EXAMPLE_STRESS,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("case", help="case file (TOML)")
    p.add_argument("--out", required=True, help="output folder (created if needed)")
    p.add_argument("--state", type=int, default=-1,
                   help="state of the path, from 0; negative counts from the end (default -1, the last)")
    p.add_argument("--depths", type=float, nargs="+", metavar="Z",
                   help="depths below each body's surface [m] (default: --layers depths down to --max-depth)")
    p.add_argument("--layers", type=int, default=32, help="number of equally spaced depths (default 32)")
    p.add_argument("--max-depth", type=float, help="deepest depth [m] (default: 2 contact radii of the state)")
    p.add_argument("--volume", action="store_true",
                   help="also write every depth's fields to stress.npz (12 fields x depths x n x n per body)")
    p.add_argument("--no-first-yield", action="store_true",
                   help="skip the stress of the states before --state (first yield is then not reported)")
    p.add_argument("--device", help="override [solver] device: cpu, cuda, cuda:N")
    p.add_argument("--dtype", choices=("float64", "float32"), help="override [solver] dtype")
    p.add_argument("--fft", choices=FFT_BACKENDS, help="override [solver] fft")
    p.add_argument("--dpi", type=int, default=150, help="resolution of the PNG files (default 150)")
    p.add_argument("--quiet", action="store_true", help="no summary line")
    return p


def stress_json(result, case) -> dict:
    """stress.json's content (``StressResult.summary`` per body, with the run's record)."""
    from .. import __version__

    out = {
        "state_index": result.state_index,
        "delta": result.delta,
        "converged": result.converged,
        **result.summary(),
        "depths": [float(z) for z in result.depths],
        "section_axis": result.section_axis,
        "section_coordinate": float((result.y if result.section_axis == "x" else result.x)[result.section_index]),
        "frame": "each body's own: x, y of the grid, z the depth into the body (upwards in the sphere); "
                 "the sphere carries the pressure and minus the shear on the flat",
        "device": result.device,
        "dtype": result.dtype,
        "fft": result.fft,
        "elapsed_s": result.elapsed_s,
        "software": {"warpcontact": __version__},
        "case": case.to_dict(),
    }
    return out


def _rigid_panel(ax, name: str) -> None:
    """A rigid body's panel: no stress field to show, said in its place."""
    ax.text(0.5, 0.5, f"{name}: rigid, no stress field", ha="center", va="center", transform=ax.transAxes)
    ax.set_axis_off()


def _shown(result, axes) -> list:
    """The panels of ``axes`` (sphere's, flat's) that show a body's stress: the elastic bodies'."""
    return [ax for ax, name in zip(axes, ("sphere", "flat")) if name in result.bodies]


def _length_unit(values):
    from ..plots import si_scale

    return si_scale(values, "m")


def section_figure(result):
    """Von Mises in the section through the centre along the sliding direction: the sphere above
    the interface (depth upwards), the flat below; the yield strength as a contour, each body's
    maximum marked."""
    from ..plots.base import _figure

    axis = result.section_axis
    coord = result.x if axis == "x" else result.y
    depths = result.depths
    scale, unit = _length_unit(list(depths) + [float(np.max(np.abs(coord)))])
    vmax = max(float(np.max(b.section["von_mises"])) for b in result.bodies.values()) / 1e6
    fig = _figure((7.0, 6.4))
    axes = fig.subplots(2, 1, sharex=True)
    summary = result.summary()
    for ax, name, sign in ((axes[0], "sphere", 1.0), (axes[1], "flat", -1.0)):
        if name in result.rigid:
            _rigid_panel(ax, name)
            continue
        b = result.bodies[name]
        data = b.section["von_mises"] / 1e6
        levels = np.linspace(0.0, vmax, 21) if vmax > 0 else 21
        cs = ax.contourf(coord / scale, sign * depths / scale, data, levels=levels, cmap="viridis")
        sy = b.yield_strength
        if math.isfinite(sy) and float(np.max(data)) >= sy / 1e6:
            ax.contour(coord / scale, sign * depths / scale, data, levels=[sy / 1e6], colors="r", linewidths=1.2)
        m = summary[name]["von_mises_max"]
        other_name = "y" if axis == "x" else "x"
        off = m[other_name] - (result.y if axis == "x" else result.x)[result.section_index]
        where = ""
        if abs(off) <= (result.x[1] - result.x[0]):  # in this section: marked
            ax.plot([m[axis] / scale], [sign * m["z"] / scale], "wx", ms=8, mew=2)
        else:
            where = f", off this section at {other_name} = {m[other_name] / scale:.3g} {unit}"
        yl = f", yield strength {sy / 1e6:.4g} MPa (red where reached)" if math.isfinite(sy) else ""
        ax.set_title(f"{name} (nu = {b.nu:g}{yl})\nvon Mises max {m['value'] / 1e6:.4g} MPa at depth "
                     f"{m['z'] / scale:.4g} {unit}{where}", fontsize="medium")
        ax.set_ylabel(f"{'height above' if sign > 0 else 'depth below'} the interface [{unit}]")
        ax.set_aspect("equal", adjustable="box")
    other = "y" if axis == "x" else "x"
    _shown(result, axes)[-1].set_xlabel(f"{axis} [{unit}] (section at {other} = "
                       f"{(result.y if axis == 'x' else result.x)[result.section_index] / scale:.3g} {unit})")
    fig.colorbar(cs, ax=list(axes), label="von Mises stress [MPa]", shrink=0.8)
    return fig


def profiles_figure(result):
    """Stresses on the axis (the cell nearest the centre) against depth, one panel per body."""
    from ..plots.base import _figure

    depths = result.depths
    scale, unit = _length_unit(depths)
    fig = _figure((9.0, 4.4))
    axes = fig.subplots(1, 2, sharey=True)
    for ax, name in zip(axes, ("sphere", "flat")):
        if name in result.rigid:
            _rigid_panel(ax, name)
            continue
        b = result.bodies[name]
        for f, style in (("sigma_xx", "-"), ("sigma_yy", "--"), ("sigma_zz", "-."), ("von_mises", "-"),
                         ("tresca", ":")):
            ax.plot(b.axis[f] / 1e6, depths / scale, style, lw=1.8 if f == "von_mises" else 1.2, label=f)
        if math.isfinite(b.yield_strength) and b.yield_strength <= 2 * float(np.max(np.abs(b.axis["sigma_zz"]))):
            ax.axvline(b.yield_strength / 1e6, color="r", lw=0.8, ls=":", label="yield strength")
        ax.axvline(0.0, color="0.7", lw=0.6)
        ax.set_title(f"{name} (nu = {b.nu:g}) on the axis", fontsize="medium")
        ax.set_xlabel("stress [MPa] (tension positive)")
        ax.grid(True, color="0.9", linewidth=0.5)
    _shown(result, axes)[0].set_ylabel(f"depth into the body [{unit}]")
    axes[0].invert_yaxis()
    _shown(result, axes)[-1].legend(fontsize="small", loc="best")
    return fig


def cmd_stress(args) -> int:
    from ..records.case import load_case
    from ..plots import save
    from ..records.results import atomic_write_json, atomic_write_npz
    from ..numerics.stress import check_depths
    from ..studies.stress_study import subsurface_stress

    case = load_case(args.case).with_overrides(device=args.device, dtype=args.dtype, fft=args.fft)
    depths = check_depths(args.depths) if args.depths else None
    if args.max_depth is not None:
        check_depths([args.max_depth])
    out = Path(args.out)
    result = subsurface_stress(case, state=args.state, depths=depths, layers=args.layers, max_depth=args.max_depth,
                               volume=args.volume, with_first_yield=not args.no_first_yield)
    summary = stress_json(result, case)
    atomic_write_npz(out / "stress.npz", result.arrays())
    save(section_figure(result), out / "stress_section.png", dpi=args.dpi)
    save(profiles_figure(result), out / "stress_profiles.png", dpi=args.dpi)
    summary["complete"] = True
    atomic_write_json(out / "stress.json", summary)
    if not args.quiet:
        for name in ("sphere", "flat"):
            s = summary[name]
            if s.get("rigid"):
                print(f"{name}: rigid, no stress field", file=sys.stderr)
                continue
            m = s["von_mises_max"]
            y = (f", {'yielded' if s['yielded'] else 'elastic'} (margin {s['margin']:.3g})"
                 if s["yield_strength"] is not None else "")
            print(f"{name}: von Mises max {m['value']:.4e} Pa at depth {m['z']:.4e} m{y}", file=sys.stderr)
        print(f"[{result.device}, {result.dtype}, {len(result.depths)} depths, {result.elapsed_s:.2f} s] -> {out}",
              file=sys.stderr)
    if not result.converged:
        print(f"not converged: state {result.state_index} did not converge; stresses written to {out} with "
              "converged = false", file=sys.stderr)
        return 3
    return 0
