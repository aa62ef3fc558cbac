"""Target curves for inverse design: validation, arc-length resampling, CSV files, built-in object contours.

A target is a planar curve (x, z) in metres that the beam's centreline should follow, starting at
the clamped end. Built-in targets are half-contours of the paper's four objects (Fig. 6): a gripper
finger clamped under the object's bottom centre, running outward along the bottom (+x) and up its
side (+z). They are built from arcs and straight pieces joined with continuous tangents, so the
clamp tangent is +x and the curve is smooth enough for a beam to follow.
"""

from __future__ import annotations

import csv
import math
import os
from pathlib import Path

import numpy as np

from ..units import MM
from ..validate import finite_number, integer, pair, positive

MIN_POINTS = 4  # fewest distinct points a target may have
MAX_POINTS = 100_000  # most points a target may have (or be resampled to): the distance is O(points x 241)

# Built-in objects: turtle pieces (radius of curvature in mm, or None for a straight piece; turn
# angle in degrees, or length in mm for a straight piece). Positive turns curl toward +z.
BUILTIN_PIECES: dict[str, dict] = {
    "ball": {
        "description": "ball of diameter 20 mm; the finger wraps 135 degrees of it from the bottom",
        "pieces": [(10.0, 135.0)],
    },
    "vase": {
        "description": "small vase: flat bottom, bulging belly, narrow neck and the start of a flaring lip",
        "pieces": [(None, 5.0), (4.0, 60.0), (10.0, 60.0), (6.0, -60.0)],
    },
    "calabash": {
        "description": "calabash (bottle gourd): lower bulb of diameter 14 mm, waist, start of the upper bulb",
        "pieces": [(7.0, 150.0), (3.0, -90.0), (4.0, 60.0)],
    },
    "dumbbell": {
        "description": "round dumbbell standing on one end: weight of diameter 12 mm, fillet, then the handle",
        "pieces": [(6.0, 150.0), (2.5, -60.0), (None, 5.0)],
    },
}
BUILTIN_TARGETS = tuple(BUILTIN_PIECES)


def turtle_curve(pieces, *, step: float = 0.05) -> np.ndarray:
    """Curve (x, z) in mm from straight and circular pieces, starting at the origin along +x.

    ``pieces`` is a sequence of ``(radius_mm, turn_deg)`` for arcs (negative turns curl toward -z)
    and ``(None, length_mm)`` for straight pieces. Returns an ``(n, 2)`` array sampled about every
    ``step`` mm.
    """
    step = positive("turtle_curve step", step, unit="mm")
    if isinstance(pieces, (str, bytes)) or not isinstance(pieces, (list, tuple)) or not pieces:
        raise ValueError(f"turtle_curve pieces must be a non-empty list of (radius_mm, amount), got {pieces!r}.")
    checked, total = [], 0.0
    for i, piece in enumerate(pieces):
        radius, amount = pair(f"turtle_curve pieces[{i}]", piece, "(radius_mm or None, amount)")
        if radius is None:
            amount = positive(f"turtle_curve pieces[{i}] length", amount, unit="mm")
            total += amount
        else:
            radius = positive(f"turtle_curve pieces[{i}] radius", radius, unit="mm")
            amount = finite_number(f"turtle_curve pieces[{i}] turn", amount, unit="deg")
            total += abs(math.radians(amount)) * radius
        checked.append((radius, amount))
    if total / step > MAX_POINTS:
        raise ValueError(
            f"turtle_curve step {step:g} mm gives {total / step:.0f} points over {total:g} mm: at most {MAX_POINTS}; "
            "use a larger step."
        )
    pts = [np.zeros(2)]
    heading = 0.0
    for radius, amount in checked:
        p0 = pts[-1]
        if radius is None:
            n = max(2, int(math.ceil(amount / step)))
            t = np.linspace(0.0, amount, n + 1)[1:]
            seg = p0 + np.outer(t, [math.cos(heading), math.sin(heading)])
        else:
            turn = math.radians(amount)
            n = max(2, int(math.ceil(abs(turn) * radius / step)))
            sign = 1.0 if turn > 0 else -1.0
            centre = p0 + sign * radius * np.array([-math.sin(heading), math.cos(heading)])
            phi = heading + np.linspace(0.0, turn, n + 1)[1:]
            seg = centre + sign * radius * np.column_stack([np.sin(phi), -np.cos(phi)])
            heading += turn
        pts.extend(seg)
    return np.asarray(pts)


def write_builtin_contours(folder, *, step_mm: float = 0.25) -> list[Path]:
    """Regenerate ``assets/contours/<name>.csv`` (columns ``x_mm, z_mm``) from :data:`BUILTIN_PIECES`."""
    folder = Path(_path_arg("folder", folder))
    step_mm = positive("step_mm", step_mm, unit="mm")
    folder.mkdir(parents=True, exist_ok=True)
    out = []
    for name, spec in BUILTIN_PIECES.items():
        xz = turtle_curve(spec["pieces"], step=step_mm)
        length = curve_length(xz)
        path = folder / f"{name}.csv"
        with path.open("w", encoding="utf-8", newline="") as fh:
            imax = int(np.argmax(xz[:, 0]))
            fh.write(f"# {name}: {spec['description']}.\n")
            fh.write(
                f"# Half-contour from the bottom centre, clamp tangent +x, z up. Curve length {length:.2f} mm; "
                f"height {xz[:, 1].max():.2f} mm; widest radius {xz[imax, 0]:.2f} mm; narrowest radius above it "
                f"{xz[imax:, 0].min():.2f} mm.\n"
            )
            fh.write("# Generated by magsoft_env.design.targets.write_builtin_contours.\n")
            w = csv.writer(fh, lineterminator="\n")
            w.writerow(["x_mm", "z_mm"])
            for x, z in xz:
                w.writerow([f"{x:.5f}", f"{z:.5f}"])
        out.append(path)
    return out


# ---------------------------------------------------------------------------------------------
def curve_length(xz) -> float:
    """Length of the polyline through the rows of ``xz`` (same unit as ``xz``)."""
    xz = _xz_array("xz", xz, min_len=1)
    return float(np.sum(np.hypot(*np.diff(xz, axis=0).T)))


def _segments_cross(p, q) -> tuple[int, int] | None:
    """First pair (i, j), j > i + 1, of polyline segments that intersect or touch, else None."""
    a, b = p[:-1], p[1:]
    n = len(a)
    if n < 3:
        return None
    d = b - a
    scale = float(np.max(np.abs(p))) or 1.0
    eps = 1e-12 * scale * scale
    for i in range(n - 2):
        j = np.arange(i + 2, n)
        if i == 0 and q:  # closed curves: first and last segments share a point legitimately
            j = j[j != n - 1]
        if j.size == 0:
            continue

        def cross(u, v):
            return u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]

        r = d[i]
        s = d[j]
        qp = a[j] - a[i]
        den = cross(r, s)
        t_num = cross(qp, s)
        u_num = cross(qp, r)
        par = np.abs(den) <= eps
        with np.errstate(divide="ignore", invalid="ignore"):
            t = t_num / den
            u = u_num / den
        hit = (~par) & (t >= 0) & (t <= 1) & (u >= 0) & (u <= 1)
        # collinear overlap
        col = par & (np.abs(t_num) <= eps)
        if np.any(col):
            rr = float(r @ r)
            t0 = (qp @ r) / rr
            t1 = ((a[j] + s - a[i]) @ r) / rr
            lo, hi = np.minimum(t0, t1), np.maximum(t0, t1)
            hit |= col & (hi >= 0) & (lo <= 1)
        if np.any(hit):
            return i, int(j[np.argmax(hit)])
    return None


def validate_target(target_xz, *, name: str = "target_xz") -> np.ndarray:
    """Check a target curve and return it as a float ``(n, 2)`` array (same unit as given).

    Raises ValueError for a wrong shape, non-finite values, fewer than :data:`MIN_POINTS`
    distinct points (consecutive repeats are dropped), or a self-intersecting curve.
    """
    try:
        xz = np.asarray(target_xz, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be an (N, 2) array of numbers (x, z), got {type(target_xz).__name__}.") from None
    if xz.ndim != 2 or xz.shape[1] != 2:
        raise ValueError(f"{name} must have shape (N, 2) with columns x, z; got shape {xz.shape}.")
    bad = ~np.isfinite(xz).all(axis=1)
    if np.any(bad):
        raise ValueError(
            f"{name} must contain only finite numbers; got non-finite values in rows "
            f"{np.flatnonzero(bad)[:5].tolist()}."
        )
    if len(xz) == 0:
        raise ValueError(f"{name} needs at least {MIN_POINTS} distinct points, got 0.")
    if len(xz) > MAX_POINTS:
        raise ValueError(f"{name} must have at most {MAX_POINTS} points, got {len(xz)}.")
    keep = np.concatenate([[True], np.any(np.diff(xz, axis=0) != 0.0, axis=1)])
    xz = xz[keep]
    if len(xz) < MIN_POINTS:
        raise ValueError(f"{name} needs at least {MIN_POINTS} distinct points, got {len(xz)}.")
    hit = _segments_cross(xz, False)
    if hit is not None:
        i, j = hit
        raise ValueError(
            f"{name} must not intersect itself: expected a simple open curve, got segment {i} "
            f"({xz[i].tolist()} -> {xz[i + 1].tolist()}) crossing segment {j} "
            f"({xz[j].tolist()} -> {xz[j + 1].tolist()})."
        )
    return xz


def resample(xz, n: int) -> np.ndarray:
    """``n`` points (an integer in [2, MAX_POINTS]) evenly spaced in arc length along the polyline ``xz``
    (an (m, 2) array, m >= 2; endpoints kept)."""
    n = integer("n", n, 2, MAX_POINTS)
    xz = _xz_array("xz", xz)
    s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(xz, axis=0).T))])
    t = np.linspace(0.0, s[-1], n)
    return np.column_stack([np.interp(t, s, xz[:, 0]), np.interp(t, s, xz[:, 1])])


def tangent_angle(xz, n: int = 201) -> tuple[np.ndarray, np.ndarray]:
    """Unwrapped tangent angle (rad) of the curve against normalized arc length u in [0, 1].

    Smoothed by central differences on an arc-length resampling with ``n`` points.
    """
    p = resample(xz, n)
    d = np.gradient(p, axis=0)
    ang = np.unwrap(np.arctan2(d[:, 1], d[:, 0]))
    return np.linspace(0.0, 1.0, n), ang


def read_curve_csv(path) -> np.ndarray:
    """Read a curve from CSV with a header naming the unit: ``x_mm, z_mm`` or ``x_m, z_m``.

    Lines starting with ``#`` are comments. Returns an ``(n, 2)`` array in metres (not validated).
    """
    path = Path(_path_arg("target CSV path", path))
    if not path.is_file():
        raise ValueError(f"target CSV {str(path)!r} does not exist or is not a file.")
    try:
        with path.open(encoding="utf-8") as fh:
            rows = [r for r in csv.reader(line for line in fh if line.strip() and not line.lstrip().startswith("#"))]
    except UnicodeDecodeError as exc:
        raise ValueError(f"target CSV {str(path)!r} is not UTF-8 text: {exc}.") from None
    except (OSError, csv.Error) as exc:
        raise ValueError(f"target CSV {str(path)!r} cannot be read: {exc}.") from None
    if not rows:
        raise ValueError(f"target CSV {str(path)!r} is empty: expected a header x_mm,z_mm and rows of numbers.")
    header = [h.strip().lower() for h in rows[0]]
    units = {("x_mm", "z_mm"): MM, ("x_m", "z_m"): 1.0}
    scale = None
    for (hx, hz), sc in units.items():
        if hx in header and hz in header:
            ix, iz, scale = header.index(hx), header.index(hz), sc
            break
    if scale is None:
        raise ValueError(
            f"target CSV {str(path)!r} needs a header with columns x_mm,z_mm (or x_m,z_m), got {rows[0]}."
        )
    if len(rows) - 1 > MAX_POINTS:
        raise ValueError(f"target CSV {str(path)!r} has {len(rows) - 1} rows: at most {MAX_POINTS}.")
    try:
        data = np.array([[float(r[ix]), float(r[iz])] for r in rows[1:]], dtype=float)
    except (ValueError, IndexError) as exc:
        raise ValueError(f"target CSV {str(path)!r} has a row that is not two numbers: {exc}.") from None
    bad = ~np.isfinite(data).all(axis=1) if data.size else np.zeros(0, bool)
    if np.any(bad):
        raise ValueError(
            f"target CSV {str(path)!r} must contain only finite numbers; got nan or inf in data rows "
            f"{np.flatnonzero(bad)[:5].tolist()}."
        )
    return data.reshape(-1, 2) * scale


def _path_arg(name: str, value):
    if not isinstance(value, (str, os.PathLike)) or (isinstance(value, str) and not value):
        raise ValueError(f"{name} must be a file path (str or Path), got {value!r}.")
    return value


def _xz_array(name: str, xz, *, min_len: int = 2) -> np.ndarray:
    from ..validate import finite_array

    a = finite_array(name, xz, ndim=2, min_len=min_len)
    if a.shape[1] != 2:
        raise ValueError(f"{name} must have shape (N, 2) with columns x, z; got shape {a.shape}.")
    return a


def builtin_target(name: str) -> np.ndarray:
    """Contour of a built-in object (``ball``, ``vase``, ``calabash``, ``dumbbell``) in metres, ``(n, 2)``."""
    from ..assets import asset_path
    from ..validate import choice

    if not isinstance(name, str):
        raise ValueError(f"target must be one of {list(BUILTIN_TARGETS)}, got {name!r}.")
    choice("target", name, BUILTIN_TARGETS)
    return read_curve_csv(asset_path("contours", f"{name}.csv"))


def prepare_target(target_xz, n_points: int, *, name: str = "target_xz") -> np.ndarray:
    """Validate, translate so that it starts at the origin, and resample to ``n_points`` by arc length."""
    n_points = integer("n_points", n_points, MIN_POINTS, MAX_POINTS)
    xz = validate_target(target_xz, name=name)
    xz = xz - xz[0]
    return resample(xz, n_points)
