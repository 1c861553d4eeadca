"""``warpcontact figure CASE.toml|DIR|NPZ --out OUTDIR [--state K]``: the paper-style figures of a state.

Given a case file it first solves it as ``warpcontact solve CASE --out OUTDIR`` does (result.json
and fields.npz in OUTDIR); given a solve's folder or NPZ it reads ``fields.npz`` (numpy alone, no
pickles). Then it writes
OUTDIR/area_map.png (A_c blue, A_st orange, A_adh yellow, as in the paper's Figures 1 and 2),
OUTDIR/fields.png (pressure, shear magnitude, gap and the area map) and OUTDIR/profile.png
(pressure and shear along x through the centre). Wire it into ``cli/__init__.py`` with::

    from .figure import add_parser, cmd_figure
    add_parser(sub)                  # in _parser(), on the subparsers object
    {..., "figure": cmd_figure}      # in main()'s table of commands
"""

from __future__ import annotations

import argparse
import sys
import zipfile
from pathlib import Path

import numpy as np

from ..records.case import FFT_BACKENDS
from ..errors import InputError

EXAMPLE_FIGURE = """example:
  warpcontact figure examples/figure1b.toml --out out/fig1b      # solve the case, then draw its last state
  warpcontact solve examples/table2_k080_dz5e-5.toml --out out/k080
  warpcontact figure out/k080 --out out/k080/fig               # the last state of the path
  warpcontact figure out/k080/fields.npz --out out/k080/fig --state 2

writes OUTDIR/area_map.png (elastic contact A_c blue, stick A_st orange, adhesive contact A_adh
yellow; axes in nm, areas in nm^2 in the legend), OUTDIR/fields.png (pressure and shear magnitude
[MPa], gap [nm], area map) and OUTDIR/profile.png (pressure, shear_x and the shear limit when the
file has it, MPa against x in nm, through the centre row). --state counts from 0; negative values
count from the end (-1, the default, is the last state).

  warpcontact gross-slip CASE.toml --out out/gs && warpcontact figure out/gs --out out/gs/fig
  warpcontact pull-off CASE.toml --out out/po && warpcontact figure out/po --out out/po/fig

draw the state at gross slip (the case solved again along the search's history, up to
delta_x_max) and the force-approach curve (OUTDIR/pull_off.png)."""

#: Arrays a file must hold for the figures (masks are rebuilt from pressure/status when missing).
REQUIRED = ("pressure", "shear_x", "shear_y", "gap", "x", "y")


def add_parser(sub):
    """Register the ``figure`` sub-command on an argparse subparsers object; returns its parser."""
    p = sub.add_parser(
        "figure",
        help="draw the contact, stick and adhesive areas and the fields of a solved state (PNG)",
        description="Draw the paper-style area map (A_c blue, A_st orange, A_adh yellow), the field maps and "
        "the centre-line profiles of one state of a solved path, from the fields.npz that 'warpcontact solve' "
        "writes.",
        epilog=EXAMPLE_FIGURE,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("fields", metavar="CASE_OR_DIR_OR_NPZ",
                   help="a case file (.toml: solved first, into --out), a solve's output folder (holding "
                   "fields.npz), an NPZ file, or the output folder of gross-slip (the state at gross slip, solved "
                   "again along the search's history) or pull-off (the force-approach curve)")
    p.add_argument("--out", required=True, help="output folder for the PNG files (created if needed)")
    p.add_argument("--device", help="with a case file: override [solver] device: cpu, cuda, cuda:N")
    p.add_argument("--dtype", choices=("float64", "float32"), help="with a case file: override [solver] dtype")
    p.add_argument("--fft", choices=FFT_BACKENDS, help="with a case file: override [solver] fft")
    p.add_argument("--state", type=int, default=-1,
                   help="state of the path to draw, from 0; negative counts from the end (default -1, the last)")
    p.add_argument("--dpi", type=int, default=150, help="resolution of the PNG files (default 150)")
    p.add_argument("--quiet", action="store_true", help="do not list the files written")
    p.set_defaults(func=cmd_figure)
    return p


def _npz_path(arg: str) -> Path:
    p = Path(arg)
    if p.is_dir():
        if not (p / "fields.npz").exists() and not (p / "result.json").exists():
            raise InputError(str(arg), "holds neither result.json nor fields.npz: nothing to draw (give the output "
                                       "folder of solve, gross-slip or pull-off, a fields.npz or a case file)")
        p = p / "fields.npz"
    if not p.exists():
        raise InputError(str(arg), f"no such file: {p} (give a solve's output folder or its fields.npz)")
    if not p.is_file():
        raise InputError(str(arg), f"{p} is not a file")
    return p


def load_fields(arg) -> dict:
    """The arrays of a fields NPZ as a dict of numpy arrays; InputError when missing or unreadable."""
    path = _npz_path(str(arg))
    try:
        f = np.load(path, allow_pickle=False)
        if not isinstance(f, np.lib.npyio.NpzFile):
            raise InputError(str(arg), f"{path} holds a single array, not the NPZ of fields that 'solve' writes")
        with f:
            fields = {k: f[k] for k in f.files}
    except InputError:
        raise
    except (OSError, ValueError, EOFError, zipfile.BadZipFile, KeyError) as e:
        raise InputError(str(arg), f"cannot read {path} as an NPZ of fields: {e}") from None
    missing = [k for k in REQUIRED if k not in fields]
    if missing:
        raise InputError(str(arg), f"{path} lacks the array(s) {', '.join(missing)}: not a fields.npz from 'solve'")
    shape = fields["pressure"].shape
    if len(shape) != 3 or shape[0] < 1 or shape[1:] != (fields["y"].size, fields["x"].size) or min(shape[1:]) < 2:
        raise InputError(str(arg), f"{path}: pressure has shape {shape}, expected (n_states, len(y), len(x)) "
                                   f"with x, y of at least 2 cells")
    for k in ("shear_x", "shear_y", "gap", "contact_mask", "stick_mask", "status", "adhesive_mask",
              "adhesive_pressure", "shear_limit"):
        if k in fields and fields[k].shape != shape:
            raise InputError(str(arg), f"{path}: {k} has shape {fields[k].shape}, pressure {shape}")
    return fields


def _path_index(fields: dict, k: int) -> int:
    """The index in the path (result.json's states) of entry ``k`` of the NPZ: its ``state_index``
    where the file has one (``solve --fields last`` keeps one state), else ``k``."""
    index = fields.get("state_index")
    return int(index[k]) if index is not None and index.shape == (fields["pressure"].shape[0],) else k


def _not_converged(npz: Path, k: int) -> bool:
    """True when the result.json beside the NPZ marks state k of the path as not converged (no
    file: False)."""
    import json

    try:
        states = json.loads((npz.parent / "result.json").read_text()).get("states", [])
        return k < len(states) and states[k].get("converged") is False
    except (OSError, ValueError, AttributeError, TypeError):
        return False


def partial_note(npz: Path) -> str:
    """A warning's text when the result.json beside the NPZ says its run did not finish (stopped by
    a signal, killed, or an output not written), else "" (no file, or a complete run)."""
    import json

    try:
        res = json.loads((npz.parent / "result.json").read_text())
    except (OSError, ValueError):
        return ""
    if not isinstance(res, dict) or res.get("complete", True) is not False:
        return ""  # complete, or written before result files said
    done, planned = res.get("n_states"), res.get("n_states_planned")
    of = f"{done} of {planned} states" if done is not None and planned is not None else "a part of the path"
    if res.get("interrupted"):
        why = f"its run was stopped ({res.get('stop_signal') or 'interrupted'}) after {of}"
    elif res.get("write_error"):
        why = f"an output of its run was not written ({res['write_error']})"
    else:
        why = f"its run had not finished when it was last written ({of}; still running, or killed)"
    return f"{npz.parent / 'result.json'} is not complete: {why}"


def case_caption(npz: Path) -> str:
    """One line naming the friction law and the adhesion law of the case in the result.json beside
    the NPZ ("" when there is none): what the paper puts in its figure captions."""
    import json

    try:
        case = json.loads((npz.parent / "result.json").read_text())["case"]
    except (OSError, ValueError, KeyError, TypeError):
        return ""
    return laws_caption(case)


def laws_caption(case) -> str:
    """One line naming the friction law and the adhesion law of ``case`` (a result.json's "case"),
    "" when it is not a case's dict."""
    if not isinstance(case, dict):
        return ""
    parts = []
    friction = case.get("friction") or {}
    if friction.get("law") == "tabor":
        parts.append(f"Tabor + von Mises, $k_\\tau$ = {friction['k_tau']:g}")
    elif friction.get("law") == "coulomb":
        parts.append(f"Coulomb, $\\mu$ = {friction['mu']:g}")
    else:
        parts.append("frictionless")
    adhesion = case.get("adhesion")
    if not adhesion:
        parts.append("no adhesion")
    elif adhesion.get("law") == "smc":
        parts.append(f"SMC adhesion: $\\sigma_{{max}}$ = {adhesion['sigma_max']:.3g} Pa, "
                     f"$\\delta_n$ = {adhesion['delta_n']:.3g} m")
    elif adhesion.get("law") == "exponential":
        parts.append(f"exponential adhesion: w = {adhesion['w']:.3g} J/m$^2$, $\\rho$ = {adhesion['rho']:.3g} m")
    elif adhesion.get("law") == "lj93":
        parts.append(f"LJ 9-3 adhesion: w = {adhesion['w']:.3g} J/m$^2$, $z_0$ = {adhesion['z0']:.3g} m")
    else:
        parts.append(f"Dugdale adhesion: $\\sigma_0$ = {adhesion['sigma_0']:.3g} Pa, $h_0$ = {adhesion['h_0']:.3g} m")
    return ";  ".join(parts)


def _result_of(arg) -> dict | None:
    """The result.json of a command's output folder (or the file itself), or None."""
    import json

    p = Path(arg)
    p = p / "result.json" if p.is_dir() else p
    if p.name != "result.json" or not p.is_file():
        return None
    try:
        res = json.loads(p.read_text())
    except (OSError, ValueError):
        return None
    return res if isinstance(res, dict) else None


def gross_slip_fields(result: dict) -> dict:
    """The fields (as ``fields.npz`` holds them, one state) of the state at gross slip of a
    gross-slip result: the case is solved again along the chain the search kept (the normal
    states, then every state with stick cells, each from the one before: the search's history),
    up to the last state with stick cells, delta_x_max. Deterministic: the same forces as the
    result's to the last digit on the same device."""
    from ..records.case import case_from_dict
    from ..records.results import state_fields, state_summary
    from ..studies.runner import build

    states = result.get("states") or []
    chain = [s for s in states if s.get("kind") == "normal" or s.get("stick_cells", 0) > 0]
    if not chain or result.get("delta_x_max") is None:
        raise InputError("figure", "the gross-slip result holds no converged state at gross slip to draw")
    case = case_from_dict(result["case"])
    model, solver, state = build(case)
    for s in chain:
        solver.step(state, (s["delta"]["x"], s["delta"]["y"], s["delta"]["z"]))
    f = state_fields(state, solver.adhesion, solver.friction)
    out = {k: v[None] for k, v in f.items()}
    out["x"], out["y"] = model.grid.x, model.grid.y
    out["delta"] = np.array([state.approach], dtype=np.float64)
    out["state_index"] = np.array([states.index(chain[-1])], dtype=np.int64)
    out["_summary"] = state_summary(state, solver.adhesion)
    return out


def _annotate(fig, caption: str, unconverged: bool):
    """The laws' caption under the figure and, for a state that did not converge, a red mark."""
    if caption:
        fig.text(0.5, 0.0, caption, color="dimgray", fontsize="small", ha="center", va="top")
    if unconverged:
        fig.text(0.01, 0.995, "NOT CONVERGED", color="red", fontweight="bold", ha="left", va="top")
    return fig


def gross_slip_name(res: dict) -> str:
    """What the state of a gross-slip result's figures is, for their titles (its rigid
    displacements follow there): the state at gross slip, delta_x = delta_x_max, and mu."""
    mu = f"$\\mu$ = {res['mu']:.4f}" if res.get("mu") is not None else "$\\mu$ undefined ($F_z \\leq 0$)"
    return f"gross slip ($\\delta_x = \\delta_{{x,max}}$), {mu}"


def _no_fields(arg, folder: Path, res: dict) -> InputError:
    """Why an output folder with a result.json and no fields.npz has no state to draw, and what to do."""
    if res.get("fields_kept") == "none":
        why = ("nothing to draw: its solve kept no fields (--fields none); solve the case again with "
               "--fields last (the last state) or --fields all (every state) to draw it")
    elif res.get("write_error"):
        why = f"nothing to draw: its fields.npz was not written ({res['write_error']})"
    elif res.get("complete") is False:
        why = f"nothing to draw: no fields.npz yet ({partial_note(folder / 'fields.npz')})"
    elif res.get("fields_file"):
        why = f"nothing to draw: result.json names {res['fields_file']}, which is not in {folder} (moved or deleted)"
    else:
        why = "holds a result.json but no fields.npz: not the output of solve, gross-slip or pull-off"
    return InputError(str(arg), why)


def _figure_of_result(args, res: dict) -> int | None:
    """``figure`` on a gross-slip or pull-off output: the state at gross slip (three figures) or
    the force-approach curve (pull_off.png). None for a solve's output (its fields.npz is drawn)."""
    from .. import plots

    out = Path(args.out)
    dpi = getattr(args, "dpi", 150)
    quiet = getattr(args, "quiet", False)
    if "curve" in res and "pull_off_force" in res:
        path = out / "pull_off.png"
        plots.save(plots.pull_off_curve(res), path, dpi=dpi)
        if not quiet:
            print(f"figure: the force-approach curve -> {path}", file=sys.stderr)
        return 0
    if "delta_x_max" in res and "states" in res:
        fields = gross_slip_fields(res)
        fields.pop("_summary")
        state_name = gross_slip_name(res)
        caption = laws_caption(res.get("case"))
        unconverged = res.get("converged") is False
        written = []
        for name, draw in (("area_map.png", plots.area_map), ("fields.png", plots.field_maps),
                           ("profile.png", plots.profile)):
            fig = _annotate(draw(fields, 0, name=state_name), caption, unconverged)
            plots.save(fig, out / name, dpi=dpi)
            written.append(out / name)
        if not quiet:
            print("figure: the state at gross slip -> " + ", ".join(str(p) for p in written), file=sys.stderr)
        return 0
    return None


def cmd_figure(args) -> int:
    from .. import plots

    res = None if str(args.fields).lower().endswith(".toml") else _result_of(args.fields)
    if res is not None:  # an output folder, or its result.json
        folder = Path(args.fields) if Path(args.fields).is_dir() else Path(args.fields).parent
        if not (folder / "fields.npz").exists():
            status = _figure_of_result(args, res)
            if status is not None:
                return status
            raise _no_fields(args.fields, folder, res)
        args.fields = str(folder)
    if str(args.fields).lower().endswith(".toml"):  # a case: solve it into --out first, as 'solve' does
        from .solve import cmd_solve

        solve_args = argparse.Namespace(case=args.fields, out=args.out, device=getattr(args, "device", None),
                                        dtype=getattr(args, "dtype", None), fft=getattr(args, "fft", None),
                                        quiet=getattr(args, "quiet", False))
        status = cmd_solve(solve_args)
        if status not in (0, 3):  # stopped (130, 143, 129): the solve's states are kept, nothing drawn
            return status
        args.fields = args.out
        fig_status = status
    else:
        fig_status = 0
    written = []
    try:  # a stop from here on: the solve's outputs and the figures drawn so far are whole
        fields = load_fields(args.fields)
        n = fields["pressure"].shape[0]
        k = args.state
        if not -n <= k < n:
            raise InputError("--state", f"{k} is out of range: the file holds {n} state(s), 0 ... {n - 1} "
                                        f"(or -{n} ... -1 from the end)")
        dpi = getattr(args, "dpi", 150)
        if dpi is None or not 10 <= dpi <= 1200:
            raise InputError("--dpi", f"must be between 10 and 1200, got {dpi!r}")
        out = Path(args.out)
        if out.exists() and not out.is_dir():
            raise InputError("--out", f"{out} exists and is not a folder")
        npz = _npz_path(str(args.fields))
        note = partial_note(npz)
        if note:
            print(f"warpcontact: warning: {note}; the figures show a state that finished", file=sys.stderr)
        path_k = _path_index(fields, k % n)
        unconverged = _not_converged(npz, path_k)
        if unconverged:
            print(f"warpcontact: warning: state {path_k} did not converge in its solve (result.json); "
                  "the figures are marked NOT CONVERGED", file=sys.stderr)
        caption = case_caption(npz)
        for name, draw in (("area_map.png", plots.area_map), ("fields.png", plots.field_maps),
                           ("profile.png", plots.profile)):
            fig = _annotate(draw(fields, k), caption, unconverged)
            plots.save(fig, out / name, dpi=dpi)  # whole or not at all
            written.append(out / name)
    except KeyboardInterrupt as e:  # Ctrl-C, SIGTERM, SIGHUP
        from .. import interrupts

        print(f"{interrupts.describe(e)}: stopped while drawing; {len(written)} of 3 figure(s) written to "
              f"{args.out}", file=sys.stderr)
        return interrupts.exit_status(e)
    if not getattr(args, "quiet", False):
        print(f"figure: state {k % n} (of 0-{n - 1}) -> " + ", ".join(str(p) for p in written), file=sys.stderr)
    return fig_status
