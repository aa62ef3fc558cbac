"""Exact sensitivities of the 3D rod equilibrium (issue 32 item 1, 3D solver).

Checked as the planar ones (tests/test_fit.py): against fourth-order differences of full 3D solves (every perturbed
equilibrium solved from scratch along its loading path, on a fixed grid so that refinement does not pollute the
comparison), to 1e-7 relative (scaled by the largest component); in the plane, against the planar solver's
sensitivities; and the refusals.
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import magsoft_env as ms
from magsoft_env.fields import PointDipole, Transformed
from magsoft_env.theory.options import SolverOptions
from magsoft_env.theory.rod_sensitivity import (
    ROD_PARAMETERS,
    SOURCE_ROD_PARAMETERS,
    RodSensitivity,
    rod_sensitivities,
    source_rod_sensitivities,
    torsion_derivatives,
)
from magsoft_env.theory.rod_solver import critical_field
from magsoft_env.theory.sensitivity import PARAMETERS, sensitivities

BEAM = ms.Beam(25e-3, 5e-3, 1.13e-3)
OPTS = SolverOptions(nodes=32)
# scale of a parameter whose value may be zero (the difference step is 1e-3 of it)
_ZERO_SCALE = {"Bx": 1e-3, "By": 1e-3, "Bz": 1e-3, "gravity": 1.0, "clamp_angle": 1.0, "source_x": 25e-3,
               "source_y": 25e-3, "source_z": 25e-3, "source_roll": 1.0, "source_pitch": 1.0, "source_yaw": 1.0}


def _case(seed):
    """A random 3D case: field with B_y, a magnetization with a width component, gravity on or off, a clamp angle."""
    rng = np.random.default_rng(seed)
    m = rng.uniform(-1.0, 1.0, 3)
    m[1] = np.sign(m[1]) * max(abs(m[1]), 0.2)
    beam = ms.Beam(25e-3, rng.uniform(3e-3, 6e-3), rng.uniform(0.9e-3, 1.3e-3), magnetization=tuple(m),
                   volume_fraction=rng.uniform(0.1, 0.25))
    B = tuple(rng.uniform(-3e-3, 3e-3, 3))
    g = 9.81 if seed % 2 == 0 else 0.0
    return beam, B, g, float(rng.uniform(-0.3, 0.3))


def _perturb(beam, load, p, v):
    """(beam, load) with parameter ``p`` set to ``v``; load = (field or source, gravity, clamp angle)."""
    fld, g, th0 = load
    if p in ("E0", "particle_magnetization", "density", "poisson_ratio"):
        beam = dataclasses.replace(beam, material=dataclasses.replace(beam.material, **{p: v}))
    elif p in ("thickness", "width", "volume_fraction"):
        beam = dataclasses.replace(beam, **{p: v})
    elif p == "gravity":
        g = v
    elif p in ("Bx", "By", "Bz"):
        fld = tuple(v if i == "xyz".index(p[1]) else c for i, c in enumerate(fld))
    elif p == "clamp_angle":
        th0 = v
    elif p in ("source_roll", "source_pitch", "source_yaw"):  # a dipole turned about its centre: its moment turned
        axis = np.eye(3)[("source_roll", "source_pitch", "source_yaw").index(p)]
        moment = Rotation.from_rotvec(v * axis).apply(np.asarray(fld.moment))
        fld = PointDipole(position=fld.position, moment=tuple(moment))
    elif p.startswith("source_"):
        off = np.zeros(3)
        off["xyz".index(p[-1])] = v
        fld = Transformed(fld, position=off)
    return beam, (fld, g, th0)


def _value(beam, load, p):
    fld, g, th0 = load
    mat = beam.material
    return {"E0": mat.E0, "particle_magnetization": mat.particle_magnetization, "density": mat.density,
            "poisson_ratio": mat.poisson_ratio, "thickness": beam.thickness, "width": beam.width,
            "volume_fraction": beam.volume_fraction.value, "gravity": g, "clamp_angle": th0,
            "Bx": fld[0] if p == "Bx" else 0.0, "By": fld[1] if p == "By" else 0.0,
            "Bz": fld[2] if p == "Bz" else 0.0}.get(p, 0.0)


def _outputs(beam, load):
    fld, g, th0 = load
    r = ms.solve_equilibrium(beam, fld, gravity=g, clamp_angle=th0, model="3d", options=OPTS)
    assert r.success, r.message
    return {"tip": np.r_[r.tip_position, r.tip_twist], "frames": r.frames, "centreline": r.centreline,
            "twist": r.twist}


def _differences(beam, load, p):
    """Fourth-order differences of full solves in ``p``: central, or forward from a zero gravity (none below)."""
    v0 = _value(beam, load, p)
    h = 1e-3 * max(abs(v0), _ZERO_SCALE.get(p, 0.0))
    if p == "gravity" and v0 == 0.0:
        f = [_outputs(*_perturb(beam, load, p, v0 + m * h)) for m in range(5)]
        return {k: (-25 * f[0][k] + 48 * f[1][k] - 36 * f[2][k] + 16 * f[3][k] - 3 * f[4][k]) / (12 * h)
                for k in f[0]}
    f = [_outputs(*_perturb(beam, load, p, v0 + m * h)) for m in (-2, -1, 1, 2)]
    return {k: (f[0][k] - 8 * f[1][k] + 8 * f[2][k] - f[3][k]) / (12 * h) for k in f[0]}


def _close(a, b, rtol=1e-7):
    """|a - b| <= rtol * max |b| (the largest component as the scale); the relative error."""
    scale = np.abs(b).max()
    err = np.abs(a - b).max()
    return err <= rtol * scale, err / scale if scale else err


def _check_against_solves(S: RodSensitivity, beam, load, params):
    worst = {}
    for k, p in enumerate(params):
        fd = _differences(beam, load, p)
        checks = {"tip_position": (S.tip_position[:, k], fd["tip"][:3]),
                  "tip_twist": (S.tip_twist[k], fd["tip"][3]),
                  "frames": (S.frames[..., k], fd["frames"]),
                  "positions": (S.positions(S.s)[:, :, k], fd["centreline"]),
                  "twist": (S.twist[:, k], fd["twist"])}
        for what, (a, b) in checks.items():
            ok, rel = _close(a, b)
            assert ok, f"{p}: d {what} / d {p} off by {rel:.3g} relative"
            worst[p] = max(worst.get(p, 0.0), rel)
    print("worst relative error per parameter:", {p: f"{v:.1e}" for p, v in worst.items()})


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_rod_sensitivities_equal_differences_of_full_solves(seed):
    beam, B, g, th0 = _case(seed)
    r = ms.solve_equilibrium(beam, B, gravity=g, clamp_angle=th0, model="3d", options=OPTS)
    assert r.success and r.stable, r.message
    params = tuple(p for p in ROD_PARAMETERS if not (p == "density" and g == 0.0))  # no weight: no density
    S = rod_sensitivities(r, params)
    _check_against_solves(S, beam, (B, g, th0), params)
    # the tip's row of positions(s) is the tip's derivative; frames' derivatives are [rotation]x frames
    assert np.allclose(S.positions([beam.length])[0], S.tip_position, rtol=1e-12, atol=0)
    turned = np.cross(S.rotation[:, None, :, :], np.swapaxes(r.frames, 1, 2)[..., None], axis=2)
    assert np.allclose(np.swapaxes(turned, 1, 2), S.frames, rtol=0, atol=1e-12 * np.abs(S.frames).max())


def test_source_rod_sensitivities_equal_differences_of_full_solves():
    beam = ms.Beam(25e-3, 5e-3, 1.13e-3, magnetization=(1.0, 0.3, 0.2))
    src = PointDipole(position=(28e-3, 8e-3, -8e-3), moment=(1e-3, -2e-3, 4e-3))
    r = ms.solve_equilibrium(beam, src, gravity=9.81, clamp_angle=0.1, model="3d", options=OPTS)
    assert r.success and r.stable, r.message
    params = ("E0", "particle_magnetization", "density", "gravity", "clamp_angle", "width", "source_x", "source_y",
              "source_z", "source_roll", "source_pitch", "source_yaw")
    S = source_rod_sensitivities(r, params)
    _check_against_solves(S, beam, (src, 9.81, 0.1), params)


def test_current_sensitivities_equal_differences_of_full_solves_in_3d():
    """Navion's three currents, a strip magnetized across its width too: d/dI_i against fourth-order differences
    of full solves at the perturbed currents (their own loading paths)."""
    from magsoft_env.fields import CoilSystem, allocate
    from magsoft_env.theory.sensitivity import current_sensitivities

    beam = ms.Beam(25e-3, 5e-3, 1.13e-3, magnetization=(1.0, 0.3, 0.2))
    navion = CoilSystem.from_calibration("navion")
    I0 = allocate(navion, (12e-3, 0, 0), field=(1e-3, 2e-3, 3e-3)).currents
    r = ms.solve_equilibrium(beam, navion.at_currents(I0), gravity=9.81, model="3d", options=OPTS)
    assert r.success and r.stable, r.message
    S = current_sensitivities(r, navion, I0)
    assert S.params == tuple(f"I_{n}" for n in navion.coil_names) and set(S.units.values()) == {"A"}
    for k in range(navion.n_coils):
        h = 1e-3 * max(abs(I0[k]), 1.0)
        tips = []
        for m in (-2, -1, 1, 2):
            Ik = I0.copy()
            Ik[k] += m * h
            rk = ms.solve_equilibrium(beam, navion.at_currents(Ik), gravity=9.81, model="3d", options=OPTS)
            tips.append(np.r_[rk.tip_position, rk.tip_twist])
        fd = (tips[0] - 8 * tips[1] + 8 * tips[2] - tips[3]) / (12 * h)
        ok, rel = _close(np.r_[S.tip_position[:, k], S.tip_twist[k]], fd)
        assert ok, f"I_{k}: off by {rel:.3g}"
    with pytest.raises(ValueError, match="not solved in"):
        current_sensitivities(r, navion, I0 + 1.0)


def test_in_the_plane_the_3d_derivatives_are_the_planar_ones():
    B, g, th0 = (-4e-3, 6e-3), 9.81, 0.1
    r2 = ms.solve_equilibrium(BEAM, B, gravity=g, clamp_angle=th0, model="planar", options=SolverOptions(nodes=40))
    r3 = ms.solve_equilibrium(BEAM, (B[0], 0.0, B[1]), gravity=g, clamp_angle=th0, model="3d",
                              options=SolverOptions(nodes=40))
    S2 = sensitivities(r2, PARAMETERS)
    S3 = rod_sensitivities(r3, ROD_PARAMETERS)
    for p in PARAMETERS:
        a, b = S3[p], S2[p]
        assert _close(a["tip_position"], b["tip_position"])[0], p
        assert _close(a["tip_angle"], b["tip_angle"])[0], p
        assert abs(a["tip_position"][1]) <= 1e-12 * np.abs(b["tip_position"]).max(), p  # nothing out of the plane
    # the width cancels from the planar equation, and B_y moves the strip out of the plane only (by symmetry)
    ref = np.abs(S3["thickness"]["tip_position"]).max()
    assert np.abs(S3["width"]["tip_position"]).max() <= 1e-12 * ref
    by = S3["By"]["tip_position"]
    assert abs(by[1]) > 1e-3 and max(abs(by[0]), abs(by[2])) <= 1e-12 * abs(by[1])
    assert abs(S3["By"]["tip_twist"]) > 1.0 and abs(S3["By"]["tip_angle"]) <= 1e-12 * abs(S3["By"]["tip_twist"])


def test_torsion_constant_derivatives():
    for w, h in ((5e-3, 1.13e-3), (1e-3, 2e-3), (2e-3, 2e-3)):
        beam = ms.Beam(25e-3, w, h)
        J, dJw, dJh = torsion_derivatives(w, h)
        assert J == pytest.approx(beam.torsion_constant, rel=1e-15)
        for name, v, d in (("width", w, dJw), ("thickness", h, dJh)):
            st = 1e-4 * v
            f = [dataclasses.replace(beam, **{name: v + m * st}).torsion_constant for m in (-2, -1, 1, 2)]
            assert d == pytest.approx((f[0] - 8 * f[1] + 8 * f[2] - f[3]) / (12 * st), rel=1e-9), (w, h, name)
        assert w * dJw + h * dJh == pytest.approx(4 * J, rel=1e-13)  # J is homogeneous of degree 4


def test_cost_of_a_full_gradient():
    """One full gradient (all twelve parameters, the stability eigenvalue included) against one forward solve;
    printed (run with -s), not asserted: timings on a shared machine are noise."""
    beam, B, g, th0 = _case(0)
    t_solve, t_grad = [], []
    for _ in range(3):
        t = time.perf_counter()
        r = ms.solve_equilibrium(beam, B, gravity=g, clamp_angle=th0, model="3d", options=OPTS)
        t_solve.append(time.perf_counter() - t)
        t = time.perf_counter()
        rod_sensitivities(r, ROD_PARAMETERS)
        t_grad.append(time.perf_counter() - t)
    print(f"\n3D rod, {r.nodes} nodes: forward solve {1e3 * min(t_solve):.1f} ms, full gradient "
          f"({len(ROD_PARAMETERS)} parameters) {1e3 * min(t_grad):.1f} ms = {min(t_grad) / min(t_solve):.2f} solves")
    src = PointDipole(position=(28e-3, 8e-3, -8e-3), moment=(1e-3, -2e-3, 4e-3))
    t_solve, t_grad = [], []
    for _ in range(3):
        t = time.perf_counter()
        r = ms.solve_equilibrium(beam, src, gravity=g, clamp_angle=th0, model="3d", options=OPTS)
        t_solve.append(time.perf_counter() - t)
        t = time.perf_counter()
        source_rod_sensitivities(r, SOURCE_ROD_PARAMETERS)
        t_grad.append(time.perf_counter() - t)
    print(f"3D rod in a dipole's field: forward solve {1e3 * min(t_solve):.1f} ms, full gradient "
          f"({len(SOURCE_ROD_PARAMETERS)} parameters) {1e3 * min(t_grad):.1f} ms = "
          f"{min(t_grad) / min(t_solve):.2f} solves")


def test_rod_sensitivities_refuse_what_they_cannot_do():
    r = ms.solve_equilibrium(BEAM, (0.0, 1e-3, 5e-3), model="3d", options=OPTS)
    with pytest.raises(ValueError, match="Did you mean 'E0'"):
        rod_sensitivities(r, ["E"])
    with pytest.raises(ValueError, match="must not repeat"):
        rod_sensitivities(r, ["E0", "E0"])
    with pytest.raises(ValueError, match="source_x"):  # a source's offset: not for a uniform field
        rod_sensitivities(r, ["source_x"])
    with pytest.raises(ValueError, match="3D RodResult"):
        rod_sensitivities(ms.solve_equilibrium(BEAM, (0.0, 5e-3), model="planar"), ["E0"])
    src = PointDipole(position=(28e-3, 8e-3, -8e-3), moment=(1e-3, -2e-3, 4e-3))
    rs = ms.solve_equilibrium(BEAM, src, model="3d", options=OPTS)
    with pytest.raises(ValueError, match="source_rod_sensitivities"):
        rod_sensitivities(rs, ["E0"])
    with pytest.raises(ValueError, match="3D SourceRodResult"):
        source_rod_sensitivities(r, ["E0"])
    with pytest.raises(ValueError, match="cantilever"):
        rod_sensitivities(ms.solve_equilibrium(BEAM, (0.0, 1e-3, 5e-3), support="free", gravity=0.0, model="3d",
                                               options=OPTS), ["E0"])
    mix = dataclasses.replace(BEAM, material=ms.Material.rule_of_mixtures())
    with pytest.raises(ValueError, match="density is a function"):
        rod_sensitivities(ms.solve_equilibrium(mix, (0.0, 1e-3, 5e-3), model="3d", options=OPTS), ["density"])
    none = dataclasses.replace(BEAM, material=dataclasses.replace(BEAM.material, particle_magnetization=0.0))
    with pytest.raises(ValueError, match="particle_magnetization is 0"):
        rod_sensitivities(ms.solve_equilibrium(none, (0.0, 1e-3, 5e-3), model="3d", options=OPTS),
                          ["particle_magnetization"])
    # at the lateral-torsional bifurcation of a strip under a field across its width the derivative does not exist
    crit = critical_field(BEAM, (0.0, 2e-3, 0.0), degrees=(24, 32))
    at = ms.solve_equilibrium(BEAM, crit.field, gravity=0.0, model="3d", options=OPTS)
    assert at.success and abs(at.min_eigenvalue) < 1e-6
    with pytest.raises(ValueError, match="fold or bifurcation"):
        rod_sensitivities(at, ["E0"])
