"""``warpcontact surface --out DIR --size L ...``: a synthetic self-affine rough surface as a height
map a case file reads (``[flat] height_map``), with its power spectrum; ``--stats FILE``: the
statistics of a given height map. The numerics are in :mod:`warpcontact.physics.roughness`.

Exit status: 0 done; 2 a mistake in the options or the map (one line naming the option); 74 an
output that could not be written.
"""

from __future__ import annotations

import argparse
import io
import sys
from pathlib import Path

from ..errors import InputError

HELP = "write a synthetic self-affine rough surface (a height map for case files), or --stats of a map"
DESCRIPTION = """\
Write a synthetic self-affine rough surface: Gaussian heights filtered in Fourier space to the power
spectrum C(q) ~ q^(-2-2H) between the long- and short-wavelength cutoffs (Jacobs, Junge & Pastewka
2017), scaled to the asked rms height or rms slope, periodic, the same for the same seed. OUT holds
surface.npy (heights in m, first axis along x), surface.json (pixel_size, height_unit, the inputs,
the statistics) and psd.png (the radially averaged power spectrum). With --stats FILE, print the
statistics of a height map instead (rms height, rms slope, rms curvature, min, max, the fitted
Hurst exponent); with --out as well, write them and the map's psd.png there."""
EXAMPLE = """example:
  warpcontact surface --out out/rough --n 256 --size 256e-9 --hurst 0.8 --rms-height 1e-9 \\
      --short-cutoff 4e-9 --seed 1
  warpcontact surface --stats out/rough/surface.npy --pixel-size 1e-9

then, in a case file (docs/surfaces.md):
  [flat]
  height_map = "out/rough/surface.npy"   # relative to the case file's folder
  pixel_size = 1e-9
  height_unit = "m\""""

#: the options that rough_surface's argument names stand for, in its InputErrors
_OPTION = {"n": "--n", "size": "--size", "hurst": "--hurst", "rms_height": "--rms-height",
           "rms_slope": "--rms-slope", "short_cutoff": "--short-cutoff", "long_cutoff": "--long-cutoff",
           "seed": "--seed", "height_map": "--stats", "pixel_size": "--pixel-size", "height_unit": "--height-unit"}


def add_parser(sub):
    """Register the ``surface`` sub-command on an argparse subparsers object; returns its parser."""
    p = sub.add_parser("surface", help=HELP, description=DESCRIPTION, epilog=EXAMPLE,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", help="output folder (created if needed); required unless --stats")
    p.add_argument("--n", type=int, default=256, help="pixels per side (default 256)")
    p.add_argument("--size", type=float, help="side of the square map [m]; the pixel is size / n")
    p.add_argument("--hurst", type=float, default=0.8, help="Hurst exponent H, 0 < H < 1 (default 0.8)")
    scale = p.add_mutually_exclusive_group()
    scale.add_argument("--rms-height", type=float, help="rms height [m]")
    scale.add_argument("--rms-slope", type=float, help="rms slope [-] (forward differences on the pixels)")
    p.add_argument("--short-cutoff", type=float, help="shortest wavelength [m] (default: 2 pixels)")
    p.add_argument("--long-cutoff", type=float, help="roll-off wavelength [m] (default: the map's side)")
    p.add_argument("--seed", type=int, default=0, help="seed of the random phases (default 0)")
    p.add_argument("--stats", metavar="FILE", help="print the statistics of this height map (.npy or text grid)")
    p.add_argument("--pixel-size", type=float, help="--stats: the map's pixel side [m]")
    p.add_argument("--height-unit", default="m", help="--stats: the unit of the map's values: m, mm, um, nm, pm")
    p.add_argument("--quiet", action="store_true", help="no summary line")
    return p


def _option_error(e: InputError) -> InputError:
    """An InputError of the numerics or the map reader, named after the command's option."""
    name = e.key.rsplit(".", 1)[-1]
    return InputError(_OPTION.get(name, e.key), e.problem)


def psd_figure(heights, pixel_size: float, stats: dict, inputs: dict | None = None):
    """The radially averaged power spectrum C(q) [m^4] against q [1/m], log-log, with the fitted
    power law over its band (and the asked exponent's slope through the same band)."""
    import numpy as np

    from ..physics.roughness import power_spectrum
    from matplotlib.figure import Figure

    q, c = power_spectrum(heights, pixel_size)
    kept = c > 1e-12 * c.max()  # beyond a short cutoff: round-off, not the surface
    q, c = q[kept], c[kept]
    fig = Figure(figsize=(5.6, 4.2))
    ax = fig.add_subplot()
    ax.loglog(q, c, "o-", ms=3, lw=0.8, label="radially averaged PSD")
    if stats.get("hurst") is not None:
        lo, hi = stats["fit_q_min"], stats["fit_q_max"]
        band = (q >= lo) & (q <= hi)
        if band.any():
            qq = np.array([lo, hi])
            slope = -2.0 - 2.0 * stats["hurst"]
            c0 = np.exp(np.mean(np.log(c[band]) - slope * np.log(q[band])))
            ax.loglog(qq, c0 * qq**slope, "k--", lw=1, label=f"fit: H = {stats['hurst']:.3f}")
    if inputs:
        ax.set_title(f"asked H = {inputs['hurst']:g}, seed {inputs['seed']}", fontsize="medium")
    ax.set_xlabel("wavevector q [1/m]")
    ax.set_ylabel("C(q) [m$^4$]")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize="small")
    return fig


def _write(out: Path, name: str, data: bytes) -> None:
    from ..records.results import atomic_write_bytes

    out.mkdir(parents=True, exist_ok=True)
    atomic_write_bytes(out / name, data)


def _png(fig) -> bytes:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    return buf.getvalue()


def _stats_lines(stats: dict) -> list[str]:
    hurst = "none (the map is not square, or its band holds too few points)" if stats.get("hurst") is None \
        else f"{stats['hurst']:.4f} (PSD fit between q = {stats['fit_q_min']:.4g} and {stats['fit_q_max']:.4g} 1/m)"
    return [f"shape          {stats['shape'][0]} x {stats['shape'][1]} pixels of {stats['pixel_size']:.4g} m",
            f"rms height     {stats['rms_height']:.6g} m",
            f"rms slope      {stats['rms_slope']:.6g}",
            f"rms curvature  {stats['rms_curvature']:.6g} 1/m",
            f"min, max       {stats['min']:.6g} m, {stats['max']:.6g} m (lowest shifted to 0, as case files read it)",
            f"Hurst exponent {hurst}"]


def cmd_surface(args) -> int:
    """Write a synthetic surface into ``args.out``, or print (and with --out write) the statistics
    of ``args.stats``. Returns 0; mistakes raise InputError naming the option."""
    import json

    import numpy as np

    from .._version import __version__
    from ..physics.roughness import rough_surface, surface_statistics

    if args.stats is not None:
        from ..records.bodies import read_height_map

        if args.pixel_size is None:
            raise InputError("--pixel-size", "is required with --stats (the map's pixel side, in m)")
        try:
            surface = read_height_map("stats", args.stats, args.pixel_size, args.height_unit)
        except InputError as e:
            raise _option_error(e) from None
        stats = surface_statistics(surface.heights, surface.pixel_size)
        print("\n".join(_stats_lines(stats)))
        if args.out is not None:
            out = Path(args.out)
            _write(out, "stats.json", json.dumps({"map": str(Path(args.stats).resolve()), **stats,
                                                  "software": {"warpcontact": __version__}}, indent=1).encode())
            _write(out, "psd.png", _png(psd_figure(surface.heights, surface.pixel_size, stats)))
        return 0
    if args.out is None:
        raise InputError("--out", "is required (the folder for surface.npy, surface.json and psd.png), or give --stats")
    if args.size is None:
        raise InputError("--size", "is required: the side of the square map in m")
    if args.rms_height is None and args.rms_slope is None:
        raise InputError("--rms-height", "give --rms-height [m] or --rms-slope [-]")
    inputs = {"n": args.n, "size": args.size, "hurst": args.hurst, "rms_height": args.rms_height,
              "rms_slope": args.rms_slope, "short_cutoff": args.short_cutoff, "long_cutoff": args.long_cutoff,
              "seed": args.seed}
    try:
        heights = rough_surface(**inputs)
    except InputError as e:
        raise _option_error(e) from None
    pixel = args.size / args.n
    stats = surface_statistics(heights, pixel)
    out = Path(args.out)
    buf = io.BytesIO()
    np.save(buf, heights)
    _write(out, "surface.npy", buf.getvalue())
    record = {"height_map": "surface.npy", "pixel_size": pixel, "height_unit": "m", "inputs": inputs,
              "statistics": stats, "software": {"warpcontact": __version__}}
    _write(out, "surface.json", json.dumps(record, indent=1).encode())
    _write(out, "psd.png", _png(psd_figure(heights, pixel, stats, inputs)))
    if not args.quiet:
        print(f"surface {args.n} x {args.n} pixels of {pixel:.4g} m: rms height {stats['rms_height']:.4g} m, rms slope "
              f"{stats['rms_slope']:.4g}, fitted H {stats['hurst'] if stats['hurst'] is None else round(stats['hurst'], 3)} -> {out} (height_map = "
              f"\"{out / 'surface.npy'}\", pixel_size = {pixel:.6g})", file=sys.stderr)
    return 0
