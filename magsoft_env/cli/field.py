"""``magsoft field``: the field and gradient of a coil system at points, per ampere of each coil, and the largest
field each axis reaches there within the current limits; with ``--want-mT``, the currents of least norm for a
wanted field (and gradient) at the first point.

Coil systems by name (``--source navion``, ``cardiomag``, the ideal ones: ``--list``) or from an MPEM calibration
file (``--source my_system.yaml --max-current-A 20``); any other source file (magnets, dipoles, loops, sums:
docs/fields.md, "Sources in files") gives its field and gradient at the points. ``--plot out.png`` draws the
source's field on a plane (:func:`magsoft_env.render.fields.plot_source`: ``--plane``, ``--extent-mm``,
``--offset-mm``, and ``--robot`` for a robot's rest centreline). Positions in mm, currents in A, fields in mT,
gradients in mT/m (the unit in each flag's and key's name).
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
#: Largest |component| of ``--want-mT`` (mT) and ``--want-gradient-mT-per-m`` (mT/m).
MAX_WANT_MT = 10_000.0
MAX_WANT_MT_PER_M = 1e7
#: Planes of ``--plane`` (those of :func:`magsoft_env.render.fields.plot_source`).
PLOT_PLANES = ("xz", "xy", "yz", "zx", "yx", "zy")
#: Suffixes of ``--plot``.
PLOT_SUFFIXES = (".png", ".pdf", ".svg")


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
    p.add_argument("--want-mT", type=float, nargs=3, default=None, metavar=("BX", "BY", "BZ"),
                   help="allocate: the currents of least norm (within the limits) for this field (mT) at the first "
                        "--at-mm point; the report then uses them (not with --currents-A)")
    p.add_argument("--want-gradient-mT-per-m", type=float, nargs="+", default=None, metavar="G",
                   help="with --want-mT, also this gradient (mT/m): 5 values (dBx/dx dBx/dy dBx/dz dBy/dy dBy/dz) or "
                        "9 (the symmetric, traceless matrix row by row)")
    p.add_argument("--json", action="store_true", help="print one JSON object instead of text")
    p.add_argument("--list", action="store_true", help="list the named coil systems and exit")
    fig = p.add_argument_group("figure")
    fig.add_argument("--plot", default=None, metavar="PATH",
                     help="also draw |B| (log scale, mT) and the field lines on a plane, with the source's magnets, "
                          "dipoles and loop centres, to this image (.png, .pdf, .svg)")
    fig.add_argument("--plane", choices=list(PLOT_PLANES), default="xz",
                     help="--plot: the plane, horizontal axis first (default xz)")
    fig.add_argument("--extent-mm", type=float, nargs="+", default=None, metavar="MM",
                     help="--plot: the half-width of a square about the origin (one number, default 40) or U_MIN U_MAX "
                          "V_MIN V_MAX along the plane's axes (mm)")
    fig.add_argument("--offset-mm", type=float, default=0.0, metavar="MM",
                     help="--plot: the plane's position along its normal axis (mm; default 0)")
    fig.add_argument("--points", type=int, default=160,
                     help="--plot: cells along the horizontal axis (default 160, in [4, 1000])")
    fig.add_argument("--robot", default=None, metavar="ROBOT",
                     help="--plot: draw this robot's rest centreline (a robot file or built-in name; straight along +x "
                          "from the origin, where magsoft solve clamps it and the floor scenes start it)")
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
        raise ValueError(f"--source is required: a named coil system ({', '.join(CALIBRATIONS)}), an MPEM .yaml "
                         "file (see --list) or a source file (docs/fields.md, 'Sources in files').")
    pts_mm = _points(args.at_mm)
    plot = _plot_args(args)  # the figure's flags and the robot, checked before any work
    if not _is_coil_system(args.source, CALIBRATIONS):
        return _run_source_file(args, pts_mm, plot)
    want_B, want_G = _wanted(args)
    coils = CoilSystem.from_calibration(args.source, max_current=_limits_flag(args.max_current_A))
    n = coils.n_coils
    allocation = None
    if want_B is not None:
        from magsoft_env.fields import allocate

        allocation = allocate(coils, pts_mm[0] * MM, field=want_B * MT,
                              gradient=None if want_G is None else want_G * MT)
        args.currents_A = allocation.currents.tolist()
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
    if allocation is not None:
        info["allocation"] = _allocation_info(coils, pts_mm[0], allocation)
    if plot is not None:
        info["plot"] = str(_draw(coils.at_currents(currents), plot, f"{coils.name} at {_amps(currents)}"))
    if args.json:
        print(dumps_json(info))
        return 0
    _print_text(coils, currents, rows)
    if allocation is not None:
        _print_allocation(coils, info["allocation"])
    if plot is not None:
        print(f"\nwrote {info['plot']}")
    return 0


def _amps(currents) -> str:
    return "[" + ", ".join(f"{v:g}" for v in currents) + "] A"


def _is_coil_system(spec: str, calibrations) -> bool:
    """Whether ``--source`` names a coil system: a calibration name, or a file that is an MPEM calibration (a YAML
    with ``Coil_List``) or is not a readable source file (then the coil system's reader says what is wrong)."""
    from pathlib import Path

    if spec in calibrations:
        return True
    path = Path(spec).expanduser()
    if path.suffix.lower() not in (".yml", ".yaml", ".json") or not path.is_file():
        return True
    import json

    import yaml

    try:
        text = path.read_text(encoding="utf-8")
        data = json.loads(text) if path.suffix.lower() == ".json" else yaml.safe_load(text)
    except (OSError, UnicodeDecodeError, ValueError, yaml.YAMLError):
        return False  # load_source gives the reason
    return isinstance(data, dict) and "Coil_List" in data


def _plot_args(args):
    """``--plot`` and its flags checked (ValueError naming the flag), with the robot's rest centreline: a dict, or
    None without ``--plot`` (then the figure's flags must not be given)."""
    if args.plot is None:
        given = [f for f, v in (("--extent-mm", args.extent_mm), ("--robot", args.robot)) if v is not None]
        if given:
            raise ValueError(f"{' and '.join(given)} {'is' if len(given) == 1 else 'are'} for the figure: give --plot "
                             "PATH too.")
        return None
    from .output import out_file

    path = out_file(args.plot, flag="--plot", suffixes=PLOT_SUFFIXES)
    ext = [40.0] if args.extent_mm is None else list(args.extent_mm)
    if len(ext) not in (1, 4):
        raise ValueError(f"--extent-mm takes one number (a half-width, mm) or four (U_MIN U_MAX V_MIN V_MAX), got "
                         f"{len(ext)}.")
    if not all(math.isfinite(v) and abs(v) <= MAX_AT_MM for v in ext):
        raise ValueError(f"--extent-mm must be finite and within +-{MAX_AT_MM:g} mm, got {ext}.")
    if len(ext) == 1 and not ext[0] > 0:
        raise ValueError(f"--extent-mm with one number is a half-width > 0 (mm), got {ext[0]:g}.")
    if len(ext) == 4 and not (ext[0] < ext[1] and ext[2] < ext[3]):
        raise ValueError(f"--extent-mm U_MIN U_MAX V_MIN V_MAX needs U_MIN < U_MAX and V_MIN < V_MAX, got {ext}.")
    if not (math.isfinite(args.offset_mm) and abs(args.offset_mm) <= MAX_AT_MM):
        raise ValueError(f"--offset-mm must be finite and within +-{MAX_AT_MM:g} mm, got {args.offset_mm}.")
    if not 4 <= args.points <= 1000:
        raise ValueError(f"--points must be an integer in [4, 1000], got {args.points}.")
    robot = None
    if args.robot is not None:
        from magsoft_env.cases.robots import resolve_robot

        r = resolve_robot(args.robot, name="--robot")
        L = r.beam.length
        robot = np.column_stack([np.linspace(0.0, L, 51), np.zeros(51), np.zeros(51)])
    return {"path": path, "extent": ext[0] if len(ext) == 1 else tuple(ext), "robot": robot, "plane": args.plane,
            "offset": args.offset_mm, "points": args.points}


def _draw(source, plot, title: str):
    from magsoft_env.render.fields import plot_source
    from magsoft_env.render.figures import save_figure

    plane = plot["plane"]
    normal = ({"x", "y", "z"} - set(plane)).pop()
    fig = plot_source(source, plane=plane, extent_mm=plot["extent"], offset_mm=plot["offset"], points=plot["points"],
                      robot=plot["robot"], title=f"{title}\n|B| in the {plane} plane, {normal} = {plot['offset']:g} mm")
    return save_figure(fig, plot["path"])


def _run_source_file(args, pts_mm, plot) -> int:
    """``magsoft field --source FILE`` for a source file that is not a coil system: B and G at the points."""
    from magsoft_env.fields import load_source

    for flag, v in (("--currents-A", args.currents_A), ("--max-current-A", args.max_current_A),
                    ("--want-mT", args.want_mT), ("--want-gradient-mT-per-m", args.want_gradient_mT_per_m)):
        if v is not None:
            raise ValueError(f"{flag} applies to a coil system (a name or an MPEM file); {args.source} is a source "
                             "file (its coil systems, if any, state their currents_A).")
    try:
        source = load_source(args.source)
    except ValueError as exc:
        raise ValueError(f"--source {args.source}: {exc}") from None
    B, G = source.field_and_gradient(pts_mm * MM)
    rows = [{"at_mm": pts_mm[i].tolist(), "B_mT": (B[i] / MT).tolist(), "B_norm_mT": float(np.linalg.norm(B[i]) / MT),
             "G_mT_per_m": (G[i] / MT).tolist()} for i in range(len(pts_mm))]
    from magsoft_env.fields import source_markers

    markers = [{"kind": kind, "at_mm": (p / MM).tolist()} for kind, pts in source_markers(source) for p in pts]
    info = {"source": args.source, "markers": markers, "points": rows}
    if plot is not None:
        info["plot"] = str(_draw(source, plot, args.source))
    if args.json:
        print(dumps_json(info))
        return 0
    print(f"{args.source}: {type(source).__name__}")
    for m in markers:
        x, y, z = m["at_mm"]
        print(f"  {m['kind']} at ({x:g}, {y:g}, {z:g}) mm")
    for r in rows:
        x, y, z = r["at_mm"]
        print(f"\nat ({x:g}, {y:g}, {z:g}) mm")
        print(f"  B (mT)              {_row(r['B_mT'])}   |B| = {r['B_norm_mT']:.4f} mT")
        for a, g in zip("xyz", r["G_mT_per_m"], strict=True):
            print(f"  dB{a}/d(x,y,z) (mT/m) {_row(g)}")
    if plot is not None:
        print(f"\nwrote {info['plot']}")
    return 0


def _wanted(args):
    """``--want-mT`` and ``--want-gradient-mT-per-m`` checked: (B (3,) mT or None, G (3, 3) mT/m or None)."""
    if args.want_mT is None:
        if args.want_gradient_mT_per_m is not None:
            raise ValueError("--want-gradient-mT-per-m needs --want-mT BX BY BZ (the field wanted with it, mT).")
        return None, None
    if args.currents_A is not None:
        raise ValueError("--want-mT and --currents-A exclude each other: --want-mT computes the currents.")
    B = np.array(args.want_mT, dtype=float)
    if not all(math.isfinite(v) and abs(v) <= MAX_WANT_MT for v in B):
        raise ValueError(f"--want-mT must be 3 finite components within +-{MAX_WANT_MT:g} mT, got {B.tolist()}.")
    if args.want_gradient_mT_per_m is None:
        return B, None
    g = np.array(args.want_gradient_mT_per_m, dtype=float)
    if g.size not in (5, 9):
        raise ValueError("--want-gradient-mT-per-m takes 5 values (dBx/dx dBx/dy dBx/dz dBy/dy dBy/dz) or 9 (the "
                         f"matrix row by row), mT/m, got {g.size}.")
    if not all(math.isfinite(v) and abs(v) <= MAX_WANT_MT_PER_M for v in g):
        raise ValueError(f"--want-gradient-mT-per-m must be finite values within +-{MAX_WANT_MT_PER_M:g} mT/m, got "
                         f"{g.tolist()}.")
    if g.size == 5:
        G = np.array([[g[0], g[1], g[2]], [g[1], g[3], g[4]], [g[2], g[4], -g[0] - g[3]]])
    else:
        G = g.reshape(3, 3)
        scale = max(float(np.abs(G).max()), 1e-300)
        if np.abs(G - G.T).max() > 1e-6 * scale or abs(np.trace(G)) > 1e-6 * scale:
            raise ValueError("--want-gradient-mT-per-m with 9 values must be a symmetric, traceless matrix (the "
                             f"gradient of a source-free field), got {G.tolist()} (trace {np.trace(G):g} mT/m).")
    return B, G


def _allocation_info(coils, at_mm, a) -> dict:
    out = {
        "at_mm": at_mm.tolist(),
        "want_B_mT": (a.wanted["field"] / MT).tolist(),
        "want_G_mT_per_m": (a.wanted["gradient"] / MT).tolist() if "gradient" in a.wanted else None,
        "currents_A": a.currents.tolist(),
        "B_mT": (a.field / MT).tolist(),
        "G_mT_per_m": (a.gradient / MT).tolist(),
        "error_B_mT": a.error["field"] / MT,
        "error_G_mT_per_m": a.error["gradient"] / MT if "gradient" in a.error else None,
        "relative_error": a.relative_error,
        "reachable": a.reachable,
        "saturated": [c for c, f in zip(coils.coil_names, a.saturated, strict=True) if f],
        "rank": a.rank,
        "n_wanted": a.n_wanted,
        "settable": list(a.settable),
        "scale_limit": a.scale_limit,
        "status": a.status,
        "message": a.message,
    }
    return out


def _print_allocation(coils, a) -> None:
    x, y, z = a["at_mm"]
    print(f"\nallocation at ({x:g}, {y:g}, {z:g}) mm: {'reachable' if a['reachable'] else 'NOT reachable'}")
    print(f"  wanted B (mT)       {_row(a['want_B_mT'])}")
    print(f"  achieved B (mT)     {_row(a['B_mT'])}   |error| = {a['error_B_mT']:.3g} mT")
    if a["want_G_mT_per_m"] is not None:
        for ax, gw, ga in zip("xyz", a["want_G_mT_per_m"], a["G_mT_per_m"], strict=True):
            print(f"  dB{ax}/d(x,y,z) (mT/m) wanted {_row(gw)}   achieved {_row(ga)}")
        print(f"  |gradient error| = {a['error_G_mT_per_m']:.3g} mT/m")
    print(f"  {'coil':16s}{'current A':>10s}{'limit A':>9s}")
    for name, I, lim in zip(coils.coil_names, a["currents_A"], coils.max_current, strict=True):
        mark = "  at its limit" if name in a["saturated"] else ""
        print(f"  {name:16s}{I:10.4f}{lim:9g}{mark}")
    scale = a["scale_limit"]
    print(f"  relative error {a['relative_error']:.3g}; rank {a['rank']} of {a['n_wanted']} wanted components; "
          f"sets here: {', '.join(a['settable']) or 'nothing fully'}")
    print(f"  the wanted quantities scale by up to {scale:.6g} within the limits")
    print(f"  {a['message']}")


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
