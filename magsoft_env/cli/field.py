"""``magsoft field``: the field and gradient of a coil system at points, per ampere of each coil, and the largest
field each axis reaches there within the current limits.

Coil systems by name (``--source navion``, ``cardiomag``, the ideal ones: ``--list``) or from an MPEM calibration
file (``--source my_system.yaml --max-current-A 20``). Positions in mm, currents in A, fields in mT, gradients in
mT/m (the unit in each flag's and key's name).
"""

from __future__ import annotations

import math

import numpy as np

from ..units import MM, MT
from .output import dumps_json

#: Largest |coordinate| of ``--at-mm`` (mm).
MAX_AT_MM = 10_000.0
#: Most points one call takes.
MAX_POINTS = 1000


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "field",
        help="field and gradient of a coil system (Navion, CardioMag, an MPEM file) at points, per ampere of each coil",
        description="Evaluate a coil system's field (mT) and gradient (mT/m) at points (mm) for coil currents (A); "
        "print each coil's field per ampere there and the largest |B_x|, |B_y|, |B_z| reachable within the current "
        "limits (each axis on its own).",
    )
    p.add_argument("--source", default=None, metavar="NAME_OR_FILE",
                   help="a named coil system (see --list) or an MPEM calibration file (.yaml)")
    p.add_argument("--currents-A", type=float, nargs="+", default=None, metavar="I",
                   help="one current per coil (A; default all zero)")
    p.add_argument("--at-mm", type=float, nargs=3, action="append", default=None, metavar=("X", "Y", "Z"),
                   help="a point (mm); repeat the flag for more points (default the origin)")
    p.add_argument("--max-current-A", type=float, nargs="+", default=None, metavar="A",
                   help="current limit (A), one for all coils or one per coil (default: the system's; needed for a "
                        "file without Max_Current)")
    p.add_argument("--json", action="store_true", help="print one JSON object instead of text")
    p.add_argument("--list", action="store_true", help="list the named coil systems and exit")
    p.set_defaults(run=run)


def _points(at) -> np.ndarray:
    pts = np.array(at if at else [[0.0, 0.0, 0.0]], dtype=float)
    if len(pts) > MAX_POINTS:
        raise ValueError(f"--at-mm takes at most {MAX_POINTS} points, got {len(pts)}.")
    for row in pts:
        if not all(math.isfinite(v) and abs(v) <= MAX_AT_MM for v in row):
            raise ValueError(f"--at-mm must be finite coordinates within +-{MAX_AT_MM:g} mm, got {row.tolist()}.")
    return pts


def _limits_flag(values):
    if values is None:
        return None
    for v in values:
        if not (math.isfinite(v) and v > 0.0):
            raise ValueError(f"--max-current-A must be positive currents (A), got {values}.")
    return values[0] if len(values) == 1 else values


def run(args) -> int:
    from magsoft_env.fields import CALIBRATIONS, CoilSystem

    if args.list:
        for name, cal in CALIBRATIONS.items():
            coils = CoilSystem.from_calibration(name)
            print(f"{name:20s} {coils.n_coils} coils, +-{cal.max_current:g} A  {cal.description}")
        return 0
    if args.source is None:
        raise ValueError(f"--source is required: a named coil system ({', '.join(CALIBRATIONS)}) or an MPEM .yaml "
                         "file (see --list).")
    pts_mm = _points(args.at_mm)
    coils = CoilSystem.from_calibration(args.source, max_current=_limits_flag(args.max_current_A))
    n = coils.n_coils
    currents = np.zeros(n) if args.currents_A is None else np.array(args.currents_A, dtype=float)
    if currents.shape != (n,):
        raise ValueError(f"--currents-A needs one current per coil ({n}: {', '.join(coils.coil_names)}), got "
                         f"{currents.size}.")
    if not np.isfinite(currents).all():
        raise ValueError(f"--currents-A must be finite (A), got {currents.tolist()}.")
    coils.check_currents(currents)  # a current beyond its limit: the coil named, before any output
    B, G = coils.field_and_gradient(pts_mm * MM, currents)
    rows = []
    for i, x in enumerate(pts_mm * MM):
        Bk, _ = coils.unit_fields(x.reshape(1, 3))
        rows.append({
            "at_mm": pts_mm[i].tolist(),
            "B_mT": (B[i] / MT).tolist(),
            "B_norm_mT": float(np.linalg.norm(B[i]) / MT),
            "G_mT_per_m": (G[i] / MT).tolist(),
            "per_ampere_mT_per_A": (Bk[0].T / MT).tolist(),
            "max_field_mT": (coils.max_field(x) / MT).tolist(),
        })
    info = {"source": coils.name, "coils": list(coils.coil_names), "max_current_A": coils.max_current.tolist(),
            "currents_A": currents.tolist(), "offset": coils.offset is not None, "points": rows}
    if args.json:
        print(dumps_json(info))
        return 0
    _print_text(coils, currents, rows)
    return 0


def _row(values, fmt="{:9.4f}") -> str:
    return " ".join(fmt.format(v) for v in values)


def _print_text(coils, currents, rows) -> None:
    limits = ", ".join(f"{v:g}" for v in coils.max_current)
    print(f"{coils.name}: {coils.n_coils} coils ({', '.join(coils.coil_names)}), limits +-[{limits}] A"
          f"{', with its offset field' if coils.offset is not None else ''}")
    print(f"currents (A): {' '.join(f'{v:g}' for v in currents)}")
    for r in rows:
        x, y, z = r["at_mm"]
        print(f"\nat ({x:g}, {y:g}, {z:g}) mm")
        print(f"  B (mT)              {_row(r['B_mT'])}   |B| = {r['B_norm_mT']:.4f} mT")
        for a, g in zip("xyz", r["G_mT_per_m"], strict=True):
            print(f"  dB{a}/d(x,y,z) (mT/m) {_row(g)}")
        print(f"  {'coil':16s}{'Bx mT/A':>10s}{'By mT/A':>10s}{'Bz mT/A':>10s}{'limit A':>9s}")
        for name, b, lim in zip(coils.coil_names, r["per_ampere_mT_per_A"], coils.max_current, strict=True):
            print(f"  {name:16s}{b[0]:10.4f}{b[1]:10.4f}{b[2]:10.4f}{lim:9g}")
        mx = r["max_field_mT"]
        print(f"  largest |Bx|, |By|, |Bz| within the limits (each axis alone): {mx[0]:.3f}, {mx[1]:.3f}, "
              f"{mx[2]:.3f} mT")
