"""Exact sensitivities of the planar equilibrium and the fit built on them (issue: fit the model to your robot).

Sensitivities are checked against fourth-order central differences of full solves (an independent route: every
perturbed equilibrium is solved from scratch along its loading path); the fit against synthetic data from a
known beam.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import magsoft_env as ms
from magsoft_env.theory.options import SolverOptions
from magsoft_env.theory.sensitivity import PARAMETERS, sensitivities

BEAM = ms.Beam(25e-3, 5e-3, 1.13e-3)
OPTS = SolverOptions(nodes=40)


def _tip(beam, B, g, th0, p=None, v=None):
    mat = beam.material
    if p in ("E0", "particle_magnetization", "density"):
        beam = dataclasses.replace(beam, material=dataclasses.replace(mat, **{p: v}))
    elif p in ("thickness", "volume_fraction"):
        beam = dataclasses.replace(beam, **{p: v})
    elif p == "gravity":
        g = v
    elif p == "Bx":
        B = (v, B[1])
    elif p == "Bz":
        B = (B[0], v)
    elif p == "clamp_angle":
        th0 = v
    return ms.solve_equilibrium(beam, B, gravity=g, clamp_angle=th0, model="planar", options=OPTS).tip_position


def _value(beam, B, g, th0, p):
    return {"E0": beam.material.E0, "particle_magnetization": beam.material.particle_magnetization,
            "density": beam.material.density, "gravity": g, "Bx": B[0], "Bz": B[1], "clamp_angle": th0,
            "thickness": beam.thickness, "volume_fraction": beam.volume_fraction.value}[p]


@pytest.mark.parametrize("profile", ["uniform", "jig"])
def test_sensitivities_equal_differences_of_full_solves(profile):
    beam = BEAM if profile == "uniform" else ms.Beam(25e-3, 5e-3, 1.13e-3, magnetization=ms.Function(lambda s: 40 * s))
    B, g, th0 = (-4e-3, 6e-3), 9.81, 0.1
    r = ms.solve_equilibrium(beam, B, gravity=g, clamp_angle=th0, model="planar", options=OPTS)
    S = sensitivities(r, PARAMETERS)
    for k, p in enumerate(PARAMETERS):
        v0 = _value(beam, B, g, th0, p)
        h = 1e-3 * max(abs(v0), 1e-3)
        f = [_tip(beam, B, g, th0, p, v0 + m * h) for m in (-2, -1, 1, 2)]
        fd = (f[0] - 8 * f[1] + 8 * f[2] - f[3]) / (12 * h)
        assert np.abs(S.tip_position[:, k] - fd).max() <= 1e-7 * np.abs(fd).max(), p
    # positions along the beam: the tip's row equals the tip's derivative
    assert np.allclose(S.positions([beam.length])[0], S.tip_position, rtol=1e-12, atol=0)


def test_sensitivities_refuse_what_they_cannot_do():
    r = ms.solve_equilibrium(BEAM, (0, 5e-3))
    with pytest.raises(ValueError, match="Did you mean 'E0'"):
        sensitivities(r, ["E"])
    with pytest.raises(ValueError, match="planar EquilibriumResult"):
        sensitivities(ms.solve_equilibrium(BEAM, (0, 1e-3, 5e-3)), ["E0"])
    with pytest.raises(ValueError, match="inextensible"):
        sensitivities(ms.solve_equilibrium(BEAM, (0, 5e-3), extensible=True), ["E0"])


def _data(truth, fields, noise, seed, g=9.81):
    rng = np.random.default_rng(seed)
    return [(B, ms.solve_equilibrium(truth, B, gravity=g).tip_position[[0, 2]] + rng.normal(scale=noise, size=2))
            for B in fields]


FIELDS = [(0.0, 0.0), (0.0, 2e-3), (0.0, -2e-3), (2e-3, 1e-3), (-1.5e-3, 2.5e-3), (1e-3, -3e-3)]


def test_fit_recovers_E0_and_magnetization_with_calibrated_intervals():
    truth = dataclasses.replace(BEAM, material=dataclasses.replace(BEAM.material, E0=0.075e6,
                                                                   particle_magnetization=520e3))
    covered = 0
    for seed in range(3):
        res = ms.fit(BEAM, _data(truth, FIELDS, 0.05e-3, seed), params=("E0", "particle_magnetization"))
        assert res.success, res.message
        for p, true in (("E0", 0.075e6), ("particle_magnetization", 520e3)):
            assert abs(res.values[p] / true - 1) < 0.02
            lo, hi = res.interval95[p]
            covered += lo <= true <= hi
        assert res.beam.material.E0 == res.values["E0"]
        assert 0.02e-3 < res.residual_sigma < 0.1e-3  # the noise level, estimated from the residual
    assert covered >= 5


def test_fit_without_noise_is_exact_and_takes_points_along_the_beam():
    truth = dataclasses.replace(BEAM, thickness=1.2e-3)
    s = np.array([0.3, 0.6, 1.0]) * BEAM.length
    data = []
    for B in FIELDS[:3]:
        r = ms.solve_equilibrium(truth, B)
        x, z, _ = r.at(s)
        data.append((B, s, np.column_stack([x, z])))
    res = ms.fit(BEAM, data, params=["thickness"], restarts=0)
    assert abs(res.values["thickness"] - 1.2e-3) < 1e-9 * 1.2e-3
    assert res.rms < 1e-9


def test_fit_refuses_bad_input_and_unidentifiable_sets():
    data = _data(BEAM, FIELDS, 0.0, 0)
    with pytest.raises(ValueError, match="Did you mean 'E0'"):
        ms.fit(BEAM, data, params=("E_0",))
    with pytest.raises(ValueError, match="not identifiable together"):
        ms.fit(BEAM, _data(BEAM, FIELDS[1:], 0.0, 0, g=0.0), params=("E0", "particle_magnetization"), gravity=0.0)
    with pytest.raises(ValueError, match="not identifiable"):
        ms.fit(BEAM, _data(BEAM, FIELDS[1:], 0.0, 0, g=0.0), params=("density",), gravity=0.0)
    with pytest.raises(ValueError, match=r"measurements\[1\]"):
        ms.fit(BEAM, [data[0], ((0, 1e-3), (1.0, 2.0, 3.0, 4.0))])
    with pytest.raises(ValueError, match="in metres"):
        ms.fit(BEAM, [((0, 1e-3), (20.0, 5.0))])


def test_fit_a_magnets_position_offset_with_the_modulus():
    """Measurements under a magnet at commanded positions that are all off by one unknown offset: the fit finds
    the offset and E0 within their uncertainties (the exact sensitivities in a source, checked below)."""
    from magsoft_env.fields import PointDipole, Transformed

    truth = dataclasses.replace(BEAM, material=dataclasses.replace(BEAM.material, E0=0.07e6))
    off = np.array([0.8e-3, 0.0, -0.5e-3])
    data = [((0, 0), ms.solve_equilibrium(truth, (0, 0)).tip_position)]
    for x in (15e-3, 25e-3, 35e-3):
        for z in (-40e-3, 12e-3):
            src = PointDipole(position=(x, 0, z), moment=(0, 0, 3e-3))
            data.append((src, ms.solve_equilibrium(truth, Transformed(src, position=off), model="planar").tip_position))
    res = ms.fit(BEAM, data, params=("E0", "source_x", "source_z"), restarts=0)
    assert res.success, res.message
    assert abs(res.values["E0"] / 0.07e6 - 1) < 1e-6
    assert abs(res.values["source_x"] - off[0]) < 1e-7 and abs(res.values["source_z"] - off[2]) < 1e-7


def test_source_sensitivities_equal_differences_of_full_solves():
    from magsoft_env.fields import PointDipole
    from magsoft_env.theory.sensitivity import SOURCE_PARAMETERS, source_sensitivities

    def solve(beam=BEAM, pos=(30e-3, 0, -10e-3), g=9.81, th0=0.1, pitch=0.0):
        # a dipole turned about its centre by pitch (right-handed about y): its moment (0, 0, 1) -> (sin, 0, cos)
        src = PointDipole(position=pos, moment=(5e-3 * np.sin(pitch), 0, 5e-3 * np.cos(pitch)))
        return ms.solve_equilibrium(beam, src, gravity=g, clamp_angle=th0, options=OPTS, model="planar")

    r = solve()
    S = source_sensitivities(r, SOURCE_PARAMETERS)
    mat = BEAM.material
    for k, p in enumerate(SOURCE_PARAMETERS):
        v0 = {"E0": mat.E0, "particle_magnetization": mat.particle_magnetization, "density": mat.density,
              "gravity": 9.81, "clamp_angle": 0.1, "thickness": BEAM.thickness, "source_x": 30e-3,
              "source_z": -10e-3, "source_pitch": 0.0}[p]
        h = 1e-3 * (abs(v0) or 1.0)

        def tip(v, p=p):
            if p in ("E0", "particle_magnetization", "density"):
                return solve(beam=dataclasses.replace(BEAM, material=dataclasses.replace(mat, **{p: v})))
            if p == "thickness":
                return solve(beam=dataclasses.replace(BEAM, thickness=v))
            if p == "gravity":
                return solve(g=v)
            if p == "clamp_angle":
                return solve(th0=v)
            if p == "source_pitch":
                return solve(pitch=v)
            return solve(pos=(v, 0, -10e-3) if p == "source_x" else (30e-3, 0, v))

        f = [tip(v0 + m * h).tip_position for m in (-2, -1, 1, 2)]
        fd = (f[0] - 8 * f[1] + 8 * f[2] - f[3]) / (12 * h)
        assert np.abs(S.tip_position[:, k] - fd).max() <= 1e-7 * np.abs(fd).max(), p


def test_current_sensitivities_equal_differences_of_full_solves():
    """Navion's currents on the planar strip: d tip / d I_i against fourth-order differences of full solves."""
    from magsoft_env.fields import CoilSystem, allocate
    from magsoft_env.theory.sensitivity import current_sensitivities

    navion = CoilSystem.from_calibration("navion")
    I0 = allocate(navion, (12e-3, 0, 0), field=(-1e-3, 0.0, 3e-3)).currents
    r = ms.solve_equilibrium(BEAM, navion.at_currents(I0), gravity=9.81, options=OPTS, model="planar")
    S = current_sensitivities(r, navion, I0)
    for k in range(navion.n_coils):
        h = 1e-3 * max(abs(I0[k]), 1.0)
        f = []
        for m in (-2, -1, 1, 2):
            Ik = I0.copy()
            Ik[k] += m * h
            f.append(ms.solve_equilibrium(BEAM, navion.at_currents(Ik), gravity=9.81, options=OPTS,
                                          model="planar").tip_position)
        fd = (f[0] - 8 * f[1] + 8 * f[2] - f[3]) / (12 * h)
        assert np.abs(S.tip_position[:, k] - fd).max() <= 1e-7 * np.abs(fd).max(), k
    with pytest.raises(ValueError, match="CoilSystem"):
        current_sensitivities(r, "navion", I0)


def test_fit_a_magnets_turn_and_offset_in_the_plane():
    """Dipoles turned about y by one unknown angle and moved by one offset (the truth: the moments turned, the
    positions moved, written out): the planar fit finds source_pitch, the offset and E0."""
    from magsoft_env.fields import PointDipole

    truth = dataclasses.replace(BEAM, material=dataclasses.replace(BEAM.material, E0=0.07e6))
    a, off = 0.07, np.array([0.6e-3, 0.0, -0.4e-3])
    data = [((0, 0), ms.solve_equilibrium(truth, (0, 0)).tip_position)]
    for x in (15e-3, 25e-3, 35e-3):
        for z, m in ((-40e-3, (0.0, 0.0, 3e-3)), (12e-3, (2e-3, 0.0, 2e-3))):
            turned = (m[0] * np.cos(a) + m[2] * np.sin(a), 0.0, -m[0] * np.sin(a) + m[2] * np.cos(a))
            moved = PointDipole(position=(x + off[0], 0.0, z + off[2]), moment=turned)
            data.append((PointDipole(position=(x, 0.0, z), moment=m),
                         ms.solve_equilibrium(truth, moved, model="planar").tip_position))
    res = ms.fit(BEAM, data, params=("E0", "source_x", "source_z", "source_pitch"), restarts=0)
    assert res.success and res.model == "planar", res.message
    assert abs(res.values["E0"] / 0.07e6 - 1) < 1e-6
    assert abs(res.values["source_pitch"] - a) < 1e-7
    assert abs(res.values["source_x"] - off[0]) < 1e-8 and abs(res.values["source_z"] - off[2]) < 1e-8
