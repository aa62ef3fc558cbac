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
    three = model == "3d"
    data = as_measurements(measurements, result.beam.length, model=model)
    th0 = result.values.get("clamp_angle", clamp_angle)
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(9.5, 4.0), gridspec_kw={"width_ratios": [1.3, 1]})
    mis = []
    for m in data:
        r = solve_equilibrium(result.beam, m.field, gravity=gravity, clamp_angle=th0, model=model)
        label = (f"({', '.join(f'{b * 1e3:g}' for b in m.field)}) mT" if isinstance(m.field, tuple)
                 else type(m.field).__name__)
        if three:
            _, c, _ = r.sample(101)
            x, z = c[:, 0], c[:, 2]
            fit_pts = r.at(m.s)[0]
        else:
            _, x, z, _ = r.sample(101)
            fx, fz, _ = r.at(m.s)
            fit_pts = np.column_stack([fx, fz])
        line, = ax.plot(x * 1e3, z * 1e3, lw=1.2, label=label)
        ax.plot(m.points[:, 0] * 1e3, m.points[:, -1] * 1e3, "o", ms=4, mfc="none", color=line.get_color())
        mis.append(fit_pts - m.points)
    ax.set_aspect("equal")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("z (mm)")
    ax.set_title("fitted shapes (lines), measured points (circles)" + (", side view" if three else ""), fontsize=9)
    if len(data) <= 12:
        ax.legend(fontsize=7, loc="best")
    d = np.vstack(mis) * 1e3
    idx = np.arange(d.shape[0])
    names = ("x", "y", "z") if three else ("x", "z")
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


__all__ = ["plot_fit"]
