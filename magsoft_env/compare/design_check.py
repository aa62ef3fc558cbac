"""Check a design in MuJoCo: the designed beam under the designed field, simulated, against the analytical shape."""

from __future__ import annotations

import numpy as np

from ..design.distance import point_to_polyline


def mujoco_check(result, *, segments: int = 20) -> dict:
    """Simulate ``result.beam`` under ``result.field`` with :func:`magsoft_env.mujoco_equilibrium`.

    Returns a dict (SI): ``success``, ``message``, ``segments``, ``sim_xz`` ((segments + 2, 2) m),
    ``max_to_analytical`` and ``rms_to_analytical`` (m, distances from the simulated chain's
    points to the analytical centreline) and ``rms_to_target`` (m, the eq. 18 error of the
    simulated shape). Imports mujoco only when called; raises ImportError with a hint if it is
    missing.
    """
    if not isinstance(segments, (int, np.integer)) or segments < 2:
        raise ValueError(f"segments must be an integer >= 2, got {segments!r}.")
    try:
        from ..sim import mujoco_equilibrium
    except ImportError as exc:  # pragma: no cover - depends on the installation
        raise ImportError(f"the MuJoCo check needs mujoco (pip install 'mujoco>=4.0'): {exc}") from exc
    st = result.settings
    if st.get("coupling", "rotated") != "rotated" or st.get("extensible", False):
        raise ValueError(
            "the MuJoCo rod models the rotated coupling of an inextensible beam: expected a design with "
            f"coupling='rotated', extensible=False, got coupling={st.get('coupling')!r}, "
            f"extensible={st.get('extensible')!r}."
        )
    sim = mujoco_equilibrium(result.beam, result.field, gravity=st["gravity_m_s2"], segments=int(segments),
                             clamp_angle=st["clamp_angle_rad"])
    xz = np.column_stack([sim.x, sim.z])
    d_an = point_to_polyline(xz, result.predicted_xz)
    d_tg = point_to_polyline(result.target_xz, xz)
    return {
        "success": bool(sim.success),
        "message": sim.message,
        "segments": int(segments),
        "sim_xz": xz,
        "max_to_analytical": float(d_an.max()),
        "rms_to_analytical": float(np.sqrt(np.mean(d_an**2))),
        "rms_to_target": float(np.sqrt(np.mean(d_tg**2))),
    }
