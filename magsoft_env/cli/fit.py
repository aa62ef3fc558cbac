"""``magsoft fit``: fit a robot's parameters (E0, magnetization, ...) to measured shapes in a CSV file.

The CSV has one header row with units in the column names and one row per tracked point:

- the field: ``Bx_mT`` and ``Bz_mT`` (or ``_T``), and optionally ``By_mT`` (across the width); rows with the same
  field form one measurement;
- the position: ``tip_x_mm`` and ``tip_z_mm`` (the tip), or ``s_mm``, ``x_mm`` and ``z_mm`` (a point at reference
  arc length s from the clamp), and optionally ``tip_y_mm`` / ``y_mm``; ``_m`` instead of ``_mm`` for metres.
  Positions are relative to the clamp, x along the undeformed beam, y across its width, z up.

A field with ``B_y`` or a point with y != 0 takes the 3D rod (``--model auto``, the default); otherwise the fit is
planar (and an all-zero y column changes nothing). ``--model 3d`` or ``planar`` chooses.

Prints the fitted values with their 1-sigma uncertainties and correlations, writes the fitted robot file with
``--out`` and a figure of the fit (measured and fitted positions, misfits) with ``--plot``.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np

from .output import dumps_json

_FIELD_UNITS = {"mT": 1e-3, "T": 1.0}
_LENGTH_UNITS = {"mm": 1e-3, "m": 1.0}
#: Most rows a CSV may have.
MAX_ROWS = 100_000


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "fit",
        help="fit E0, the magnetization (and more) to measured shapes in a CSV file",
        description="Fit a robot's parameters to tracked positions under known fields (a cantilever, clamp at the "
                    "origin; planar, or the 3D rod with B_y or y data): Levenberg-Marquardt on exact sensitivities, "
                    "with 1-sigma uncertainties.",
    )
    p.add_argument("data", help="CSV file: Bx_mT, Bz_mT (By_mT) and tip_x_mm, tip_z_mm (tip_y_mm), or s_mm, x_mm, "
                                "z_mm (y_mm) columns")
    p.add_argument("--robot", default="paper-5c", help="robot name or YAML file with the starting values")
    p.add_argument("--params", default="E0,particle_magnetization",
                   help="comma-separated parameters to fit: E0, particle_magnetization, density, thickness, "
                        "volume_fraction, clamp_angle; in 3D also width, poisson_ratio (default "
                        "E0,particle_magnetization)")
    p.add_argument("--model", choices=("auto", "planar", "3d"), default="auto",
                   help="auto (default): the 3D rod when a field has B_y or a point y != 0, planar otherwise")
    p.add_argument("--restarts", type=int, default=4,
                   help="further starts of the fit, 1.4x above and below each parameter (0-20, default 4)")
    p.add_argument("--gravity", type=float, default=9.81, help="gravity during the measurements (m/s^2, default 9.81)")
    p.add_argument("--sigma-mm", type=float, default=None,
                   help="measurement noise (mm, 1 sigma) if known; otherwise estimated from the residual")
    p.add_argument("--out", default=None, help="write the fitted robot file (YAML) here")
    p.add_argument("--plot", default=None, help="write a figure of the fit (PNG) here")
    p.add_argument("--json", action="store_true", help="print one JSON object instead of text")
    p.set_defaults(run=run)


def _unit(name: str, suffixes: dict) -> tuple[str, float] | None:
    for suf, scale in sorted(suffixes.items(), key=lambda kv: -len(kv[0])):
        if name.endswith("_" + suf):
            return name[: -len(suf) - 1], scale
    return None


def read_measurements(path) -> list:
    """Measurements for :func:`magsoft_env.fit` from a CSV file (see the module docstring); ValueError naming the
    row and column on bad input."""
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"data file {str(path)!r} not found.")
    with path.open(newline="") as fh:
        rows = list(csv.reader(fh))
    rows = [r for r in rows if r and any(c.strip() for c in r) and not r[0].lstrip().startswith("#")]
    if len(rows) < 2:
        raise ValueError(f"{path.name}: needs a header row and at least one data row, got {len(rows)} row(s).")
    if len(rows) > MAX_ROWS + 1:
        raise ValueError(f"{path.name}: at most {MAX_ROWS} data rows, got {len(rows) - 1}.")
    header = [h.strip() for h in rows[0]]
    cols: dict[str, tuple[int, float]] = {}
    for j, h in enumerate(header):
        fu = _unit(h, _FIELD_UNITS)
        lu = _unit(h, _LENGTH_UNITS)
        if fu and fu[0] in ("Bx", "By", "Bz"):
            cols[fu[0]] = (j, fu[1])
        elif lu and lu[0] in ("tip_x", "tip_y", "tip_z", "s", "x", "y", "z"):
            cols[lu[0]] = (j, lu[1])
        else:
            raise ValueError(f"{path.name}: column {h!r} is not known: expected Bx_mT, Bz_mT, optionally By_mT (or "
                             "_T) and tip_x_mm, tip_z_mm, optionally tip_y_mm, or s_mm, x_mm, z_mm, optionally y_mm "
                             "(or _m); units go in the column names.")
    for need in ("Bx", "Bz"):
        if need not in cols:
            raise ValueError(f"{path.name}: missing column {need}_mT (or {need}_T).")
    tip = "tip_x" in cols or "tip_z" in cols or "tip_y" in cols
    pts = "x" in cols or "z" in cols or "s" in cols or "y" in cols
    if tip == pts:
        raise ValueError(f"{path.name}: give either tip_x_mm and tip_z_mm, or s_mm, x_mm and z_mm (not both, not "
                         "neither).")
    need = ("tip_x", "tip_z") if tip else ("s", "x", "z")
    for n in need:
        if n not in cols:
            raise ValueError(f"{path.name}: missing column {n}_mm (or {n}_m).")

    def num(i: int, key: str) -> float:
        j, scale = cols[key]
        row = rows[i]
        try:
            v = float(row[j])
        except (IndexError, ValueError):
            cell = row[j] if j < len(row) else ""
            raise ValueError(f"{path.name}: row {i + 1}, column {header[j]!r}: expected a number, got {cell!r}.") \
                from None
        if not math.isfinite(v):
            raise ValueError(f"{path.name}: row {i + 1}, column {header[j]!r}: not a finite number ({v}).")
        return v * scale

    # a field with B_y takes (B_x, B_y, B_z), else (B_x, B_z); points (x, y, z) with a y column, else (x, z)
    with_y = "tip_y" in cols if tip else "y" in cols
    groups: dict[tuple, list] = {}
    for i in range(1, len(rows)):
        By = num(i, "By") if "By" in cols else 0.0
        B = (num(i, "Bx"), By, num(i, "Bz")) if By != 0.0 else (num(i, "Bx"), num(i, "Bz"))
        if tip:
            xyz = (num(i, "tip_x"), num(i, "tip_y"), num(i, "tip_z")) if with_y else (num(i, "tip_x"), num(i, "tip_z"))
            groups.setdefault(B, []).append((0.0, *xyz))
        else:
            xyz = (num(i, "x"), num(i, "y"), num(i, "z")) if with_y else (num(i, "x"), num(i, "z"))
            groups.setdefault(B, []).append((num(i, "s"), *xyz))
    out = []
    for B, entries in groups.items():
        arr = np.array(entries)
        if tip:
            if len(arr) > 1:
                mT = ", ".join(f"{b * 1e3:g}" for b in B)
                raise ValueError(f"{path.name}: the field ({mT}) mT has {len(arr)} tip rows; give one tip per "
                                 "field.")
            out.append((B, arr[0, 1:]))
        else:
            out.append((B, arr[:, 0], arr[:, 1:]))
    return out


def run(args) -> int:
    import magsoft_env as ms
    from magsoft_env.cases.robots import resolve_robot

    if not (math.isfinite(args.gravity) and 0.0 <= args.gravity <= 100.0):
        raise ValueError(f"--gravity must lie in [0, 100] m/s^2, got {args.gravity!r}.")
    if args.sigma_mm is not None and not (math.isfinite(args.sigma_mm) and args.sigma_mm > 0):
        raise ValueError(f"--sigma-mm must be a positive length (mm), got {args.sigma_mm!r}.")
    for flag, value in (("--out", args.out), ("--plot", args.plot)):
        if value is not None and Path(value).parent and not Path(value).parent.exists():
            raise ValueError(f"{flag}: the folder of {value!r} does not exist.")
    robot = resolve_robot(args.robot, name="--robot")
    data = read_measurements(args.data)
    params = tuple(p.strip() for p in args.params.split(",") if p.strip())
    res = ms.fit(robot.beam, data, params=params, gravity=args.gravity,
                 sigma=None if args.sigma_mm is None else args.sigma_mm * 1e-3, model=args.model,
                 restarts=args.restarts)
    out = {"robot": robot.name, "data": str(args.data), "measurements": len(data), **res.to_dict()}
    if args.out:
        fitted = robot.replace(beam=res.beam)
        out["out"] = str(fitted.save(args.out))
    if args.plot:
        from magsoft_env.render.fit import plot_fit

        plot_fit(res, data, gravity=args.gravity, path=args.plot)
        out["plot"] = str(args.plot)
    if args.json:
        print(dumps_json(out))
        return 0 if res.success else 1
    print(f"fit of {', '.join(params)} to {len(data)} measurement(s) in {args.data} (robot {robot.name}, "
          f"gravity {args.gravity:g} m/s^2{', 3D rod' if res.model == '3d' else ''}): "
          f"{'converged' if res.success else 'NOT converged'}")
    for p in params:
        v, s = res.values[p], res.sigma[p]
        rel = f" ({s / abs(v):.2%})" if v else ""
        print(f"  {p:24s} {v:.6g} +- {s:.3g}{rel}   [{res.interval95[p][0]:.6g}, {res.interval95[p][1]:.6g}] 95 %")
    if len(params) > 1:
        print("  correlations: " + ", ".join(f"{params[i]}/{params[j]} {res.correlation[i, j]:+.3f}"
                                             for i in range(len(params)) for j in range(i + 1, len(params))))
    print(f"  rms misfit {res.rms * 1e3:.4f} mm; residual sigma {res.residual_sigma * 1e3:.4f} mm; "
          f"{res.iterations} evaluations")
    if not res.success or "Warning" in res.message:
        print(f"  {res.message}")
    if args.out:
        print(f"fitted robot written to {out['out']}")
    if args.plot:
        print(f"figure written to {args.plot}")
    return 0 if res.success else 1
