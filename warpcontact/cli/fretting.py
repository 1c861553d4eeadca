"""``warpcontact fretting CASE.toml --out DIR``: a cyclic path solved as ``solve`` solves it
(:func:`warpcontact.cli.solve.solve_and_write`: the same result.json, fields.npz, interrupts and
partial writes), with each whole cycle's energy, regime and loop (:mod:`warpcontact.studies.fretting`)
in result.json, and OUT/loop.png and OUT/energy.png."""

from __future__ import annotations

EXAMPLE = """example:
  warpcontact fretting examples/fretting_steel.toml --out out/fretting

writes OUT/result.json: every state as solve writes it, and "cycles", one entry per whole cycle:
energy [J] (the loop integral of F_x d(delta_x) + F_y d(delta_y)) with energy_error [J] (trapezoid
against Simpson), force_amplitude Q* [N], displacement_amplitude delta* [m], energy_ratio
A = W / (4 delta* Q*), regime ("partial slip" or "gross slip"), min_stick_area [m^2]; normal_force [N];
closed_form (Mindlin-Deresiewicz, for Coulomb friction, an uncoupled pair and no adhesion).
OUT/loop.png (F_x against delta_x, every cycle) and OUT/energy.png (energy per cycle);
OUT/fields.npz: the last state's fields (--fields all for every state's)."""


HELP = "cyclic tangential loading: each cycle's loop, dissipated energy and regime"
DESCRIPTION = ("Solve the cyclic path of CASE (after the normal leg, delta_x goes 0 -> +amplitude, then [load] cycles "
               "times +amplitude -> -amplitude -> +amplitude, each quarter in tangential_steps steps; "
               "docs/fretting.md) and report each whole cycle's loop: the energy it dissipates, the force amplitude, Fouvry's energy "
               "ratio and the regime, against Mindlin and Deresiewicz's closed form where it applies.")
FIELDS_HELP = ("whose fields OUT/fields.npz holds: the last state's (last, the default: a cyclic path has hundreds of "
               "states, and the loops are in result.json), every state's (all) or none")


def cmd_fretting(args) -> int:
    from ..plots import fretting_energy, fretting_loop
    from ..records.case import load_case
    from ..studies.fretting import check_fretting_case, fretting_keys
    from .solve import solve_and_write

    case = load_case(args.case).with_overrides(device=args.device, dtype=args.dtype, fft=args.fft)
    check_fretting_case(case)
    return solve_and_write(case, args, "fretting", extra=lambda states: fretting_keys(case, states),
                           figures=(("loop.png", fretting_loop), ("energy.png", fretting_energy)), report=report)


def report(record: dict) -> list[str]:
    """The lines printed at the end of a fretting run: each cycle's energy, force amplitude, ratio A
    and regime, and the closed form's (or why it does not apply)."""
    lines = []
    for c in record["cycles"]:
        if c["energy"] is None:
            lines.append(f"cycle {c['cycle']}: {c['note']}")
            continue
        lines.append(f"cycle {c['cycle']}: W = {c['energy']:.4e} J (+- {c['energy_error']:.1e}), Q* = "
                     f"{c['force_amplitude']:.4e} N, A = {c['energy_ratio']:.4f}, {c['regime']}")
    ref = record["closed_form"]
    if ref is not None:
        lines.append(f"Mindlin-Deresiewicz: W = {ref['energy']:.4e} J, Q* = {ref['force_amplitude']:.4e} N, "
                     f"A = {ref['energy_ratio']:.4f}, {ref['regime']} (F_z = {ref['normal_force']:.4e} N)")
    else:
        lines.append(f"no closed form: {record['closed_form_note']}")
    return lines


__all__ = ["cmd_fretting", "report"]
