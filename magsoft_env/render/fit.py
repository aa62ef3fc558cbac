"""A figure of a fit (:func:`magsoft_env.fit`): measured and fitted shapes, and the misfit of each point."""

from __future__ import annotations

import numpy as np


def plot_fit(result, measurements, *, gravity: float = 9.81, clamp_angle: float = 0.0, path=None):
    """Left: the fitted beam's shapes under each measured field with the measured points (a side view, x-z, for a
    3D fit); right: the misfit of each point (mm), x and z (and y in 3D). Returns the matplotlib Figure; saves it
    when ``path`` is given."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    from ..theory import solve_equilibrium
    from ..theory.fit import as_measurements

    model = getattr(result, "model", "planar")
    data = as_measurements(measurements, result.beam.length, model=model)
    th0 = result.values.get("clamp_angle", clamp_angle)
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(9.5, 4.0), gridspec_kw={"width_ratios": [1.3, 1]})
    mis = []
    for m in data:
        r = solve_equilibrium(result.beam, m.field, gravity=gravity, clamp_angle=th0, model=model)
        label = (f"({', '.join(f'{b * 1e3:g}' for b in m.field)}) mT" if isinstance(m.field, tuple)
                 else type(m.field).__name__)
        x, z = _side_view(r)
        fit_pts = _points(r, m.s)
        line, = ax.plot(x * 1e3, z * 1e3, lw=1.2, label=label)
        ax.plot(m.points[:, 0] * 1e3, m.points[:, -1] * 1e3, "o", ms=4, mfc="none", color=line.get_color())
        mis.append(fit_pts - m.points)
    ax.set_aspect("equal")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("z (mm)")
    ax.set_title("fitted shapes (lines), measured points (circles)" + (", side view" if model == "3d" else ""),
                 fontsize=9)
    if len(data) <= 12:
        ax.legend(fontsize=7, loc="best")
    d = np.vstack(mis) * 1e3
    idx = np.arange(d.shape[0])
    names = ("x", "y", "z")[:: 1 if d.shape[1] == 3 else 2]
    wid = 0.8 / len(names)
    for j, name in enumerate(names):
        bx.bar(idx + (j - (len(names) - 1) / 2) * wid, d[:, j], width=wid, label=name)
    bx.axhline(0.0, color="k", lw=0.6)
    bx.set_xlabel("measured point")
    bx.set_ylabel("fitted - measured (mm)")
    vals = "\n".join(f"{p} = {result.values[p]:.5g} +- {result.sigma[p]:.2g}" for p in result.params)
    bx.set_title(f"rms {result.rms * 1e3:.3f} mm\n{vals}", fontsize=8)
    bx.legend(fontsize=7)
    fig.tight_layout()
    if path is not None:
        fig.savefig(path, dpi=110)
    return fig


def plot_plan(plan, beam, *, gravity: float = 9.81, clamp_angle: float = 0.0, path=None):
    """A figure of a measurement plan (:func:`magsoft_env.plan_measurements`): left, the shape the guess takes
    under each planned field (numbered as in the plan's table, the field's direction as an arrow at the tip);
    right, the fields in the B_x-B_z plane and the predicted 1-sigma of each parameter. Returns the matplotlib
    Figure; saves it when ``path`` is given."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    from ..theory import solve_equilibrium

    fig, (ax, bx) = plt.subplots(1, 2, figsize=(9.5, 4.2), gridspec_kw={"width_ratios": [1.4, 1]})
    L = beam.length * 1e3
    dims = len(plan.fields[0])  # 3 in 3D: the side view (x-z) of the shapes, the fields' x-z parts
    for k, f in enumerate(plan.fields, 1):
        r = solve_equilibrium(beam, f, gravity=gravity, clamp_angle=clamp_angle, model="3d" if dims == 3 else "planar")
        x, z = _side_view(r)
        f = (f[0], f[-1])
        line, = ax.plot(x * 1e3, z * 1e3, lw=1.3)
        col = line.get_color()
        ax.annotate(str(k), (x[-1] * 1e3, z[-1] * 1e3), xytext=(3, 3), textcoords="offset points", fontsize=8,
                    color=col)
        b = np.hypot(*f)
        if b > 0:
            u = np.asarray(f) / b * 0.15 * L
            ax.annotate("", (x[-1] * 1e3 + u[0], z[-1] * 1e3 + u[1]), (x[-1] * 1e3, z[-1] * 1e3),
                        arrowprops={"arrowstyle": "->", "color": col, "lw": 1.0})
        bx.plot([0, f[0] * 1e3], [0, f[1] * 1e3], color=col, lw=1.0)
        bx.plot([f[0] * 1e3], [f[1] * 1e3], "o", color=col, ms=4)
        bx.annotate(str(k), (f[0] * 1e3, f[1] * 1e3), xytext=(3, 3), textcoords="offset points", fontsize=8,
                    color=col)
    ax.plot([0], [0], "ks", ms=5)
    ax.set_aspect("equal")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("z (mm)")
    side = ", side view" if dims == 3 else ""
    ax.set_title(f"the guess under each planned field{side} (gravity {gravity:g} m/s^2)", fontsize=9)
    lim = 1.1 * max(max(abs(v) for f in plan.fields for v in f) * 1e3, 1e-3)
    bx.set_xlim(-lim, lim)
    bx.set_ylim(-lim, lim)
    bx.set_aspect("equal")
    bx.axhline(0.0, color="0.7", lw=0.6)
    bx.axvline(0.0, color="0.7", lw=0.6)
    bx.set_xlabel("B_x (mT)")
    bx.set_ylabel("B_z (mT)")
    sig = "\n".join((f"{p}: {plan.relative_sigma[p]:.3%}" if p != "clamp_angle" else f"{p}: {plan.sigma[p]:.2e} rad")
                    for p in plan.params)
    bx.set_title("the planned fields" + (" (B_x, B_z; B_y in the table)" if dims == 3 else ""), fontsize=9)
    bx.text(0.03, 0.03, f"predicted 1-sigma\n{sig}", transform=bx.transAxes, fontsize=8, va="bottom",
            bbox={"boxstyle": "round", "fc": "white", "ec": "0.7"})
    fig.tight_layout()
    if path is not None:
        fig.savefig(path, dpi=110)
    return fig


def _side_view(result, n: int = 101):
    """x and z (m) of an analytical shape at ``n`` points: a planar one's, or a 3D one's side view."""
    out = result.sample(n)
    if len(out) == 3:  # (s, centreline (n, 3), frames): the 3D rod
        return out[1][:, 0], out[1][:, 2]
    return out[1], out[2]  # (s, x, z, theta)


def _points(result, s) -> np.ndarray:
    """The shape's points at reference arc lengths ``s``: (n, 2) x, z in the plane, (n, 3) in 3D."""
    out = result.at(s)
    if len(out) == 2:  # (centreline (n, 3), frames): the 3D rod
        return out[0]
    return np.column_stack([out[0], out[1]])


__all__ = ["plot_fit", "plot_plan"]
