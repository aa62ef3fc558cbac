"""Free vibration of the clamped 3D strip: its first frequency in each mode, measured in MuJoCo."""

from __future__ import annotations

import math

import mujoco
import numpy as np

from ..spec import Beam
from .cable_build import build_cable, frequencies, settling_damping
from .cable_frames import tip_twist, vertices

#: Free-vibration modes :func:`free_vibration` measures.
MODES = ("weak", "strong", "torsion")


def free_vibration(beam: Beam, mode: str, *, segments: int = 20, timestep: float = 1e-4,
                   integrator: str = "discrete", periods: float = 4.0, amplitude: float = 1e-3,
                   grading: float = 1.0) -> tuple[float, np.ndarray, np.ndarray]:
    """First clamped-free frequency (Hz) of the strip in ``mode`` (``weak``: bending about the width axis, tip z;
    ``strong``: about the thickness axis, tip y; ``torsion``: tip twist), measured from free vibration.

    The strip (no gravity, no damping) is settled under a static tip load (a force along z or y, or a couple about
    x) that deflects the tip by ``amplitude`` (fraction of L; rad for torsion), released, and run ``periods``
    periods of the beam formula (:func:`frequencies`); the frequency is the mean rate of the upward zero
    crossings of the tip signal (linearly interpolated), whose spacing the higher modes of the nearly first-mode
    shape barely move. Returns ``(frequency, time, signal)``.
    """
    from ..validate import positive
    from .health import check_steps
    from .model import RodOptions

    if mode not in MODES:
        raise ValueError(f"mode must be one of {MODES}, got {mode!r}.")
    # a NaN or zero amplitude has no zero crossings to time, and a NaN period count no end
    amplitude = positive("amplitude", amplitude, unit="fraction of L, or rad for torsion")
    if amplitude > 0.2:
        raise ValueError(f"amplitude must lie in (0, 0.2] (a small deflection: fraction of L, or rad for torsion), "
                         f"got {amplitude!r}.")
    periods = positive("periods", periods)
    if periods > 1000.0:
        raise ValueError(f"periods must lie in (0, 1000], got {periods!r}.")
    opts = RodOptions(rod="cable", segments=segments, timestep=timestep, integrator=integrator, gravity=0.0,
                      retardation_time=0.0, grading=grading)
    cm = build_cable(beam, opts)
    m = cm.model
    data = mujoco.MjData(m)
    ref = frequencies(beam)[mode]
    L = beam.length
    tip = cm.vertex_body[-1]
    tw = int(cm.twist_dof[-1])
    ei_w, ei_s, gj = (float(v) for v in beam.stiffnesses(np.array([0.5 * L]))[0])

    def load(on: bool) -> None:
        data.xfrc_applied[:] = 0.0
        data.qfrc_applied[:] = 0.0
        if not on:
            return
        if mode == "weak":
            data.xfrc_applied[tip, 2] = 3.0 * ei_w * amplitude / L**2
        elif mode == "strong":
            data.xfrc_applied[tip, 1] = 3.0 * ei_s * amplitude / L**2
        else:
            data.qfrc_applied[tw] = gj * amplitude / L

    def signal() -> float:
        if mode == "torsion":
            return tip_twist(cm, data)
        x = vertices(cm, data)[-1]
        return float(x[2] if mode == "weak" else x[1])

    w1 = 2.0 * math.pi * frequencies(beam)["weak"]
    settle_steps = int(20.0 / (w1 * timestep)) + 1
    check_steps(f"settling and {periods:g} periods at timestep {timestep:g} s",
                settle_steps + periods / (ref * timestep), "Use fewer periods or a larger timestep.")
    m.dof_damping[:] = settling_damping(cm)
    load(True)
    for _ in range(settle_steps):  # e^-20 of the initial transient
        mujoco.mj_step(m, data)
    m.dof_damping[:] = 0.0
    load(False)
    n = int(periods / (ref * timestep)) + 1
    sig = np.empty(n)
    for k in range(n):
        mujoco.mj_step(m, data)
        sig[k] = signal()
    time = timestep * np.arange(1, n + 1)
    y = sig - 0.5 * (sig.max() + sig.min())
    up = np.flatnonzero((y[:-1] < 0.0) & (y[1:] >= 0.0))
    if len(up) < 2:
        return math.nan, time, sig
    tc = time[up] - y[up] * timestep / (y[up + 1] - y[up])
    return float((len(tc) - 1) / (tc[-1] - tc[0])), time, sig


__all__ = ["MODES", "free_vibration"]
