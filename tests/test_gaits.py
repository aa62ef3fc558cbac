"""Paper gaits (Fig. 5): presets, run_gait, the magsoft gait command."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from magsoft_env.cases.gaits import gait_preset, list_gaits
from magsoft_env.cli import main
from magsoft_env.sim import as_waveform
from magsoft_env.sim.gait import direction_of, run_gait
from magsoft_env.spec.drive import Waveparams


def test_presets_follow_the_paper_descriptions():
    assert list_gaits() == ("paper-5a", "paper-5b", "paper-5c")
    a = gait_preset("paper-5a").beam
    L = a.length
    # 10 % left half, 20 % right half; multiple symmetric polylines: a "W" jig, four equal pieces
    # falling and rising 15 deg in turn, mirror-symmetric about the middle
    np.testing.assert_allclose(a.phi([0.1 * L, 0.9 * L]), [0.1, 0.2])
    centres = (np.arange(4) + 0.5) * L / 4
    np.testing.assert_allclose(np.degrees(a.beta(centres)), [15.0, -15.0, 15.0, -15.0], atol=1e-9)
    np.testing.assert_allclose(a.beta(centres), -a.beta(L - centres), atol=1e-12)
    b = gait_preset("paper-5b").beam
    betas = b.beta(np.array([1, 3, 5]) * b.length / 6)
    assert len(set(np.round(betas, 9))) == 3 and abs(betas[-1]) == max(abs(betas))  # largest slope on the right
    c = gait_preset("paper-5c")
    s = np.linspace(0, c.beam.length, 9)
    np.testing.assert_allclose(c.beam.beta(s), -c.beam.beta(s[::-1]), atol=1e-6)  # cosine jig: odd about the middle
    assert c.wave.amplitude_x != 0 and c.wave.amplitude_z != 0 and c.wave.phase != 0


def test_reverse_inverts_bx_only():
    w, r = gait_preset("paper-5c").wave, gait_preset("paper-5c", reverse=True).wave
    assert r.amplitude_x == -w.amplitude_x
    assert (r.amplitude_z, r.frequency, r.phase) == (w.amplitude_z, w.frequency, w.phase)


def test_unknown_preset_suggests_the_closest():
    with pytest.raises(ValueError, match="Did you mean 'paper-5c'"):
        gait_preset("paper-5C")


def test_waveparams_sample_matches_phase_shifted_waveform():
    w = Waveparams(1e-3, 2e-3, 2.0, math.pi / 4)
    t = np.linspace(0.0, 1.0, 11)
    np.testing.assert_allclose(w.sample(t), as_waveform(w).sample(t), atol=1e-15)


def test_waveparams_square_matches_switched_square_waveform_and_checks_input():
    w = Waveparams(2e-3, 1.5e-3, 2.0, math.pi / 2, shape="square", coil_time=0.01)
    t = np.linspace(0.0, 1.0, 101)
    np.testing.assert_allclose(w.sample(t), as_waveform(w).sample(t), atol=1e-15)
    assert w.describe() == "square (coil 10 ms) B_x +2 +90 deg, B_z 1.5 mT, 2 Hz"
    with pytest.raises(ValueError, match="shape must be one of"):
        Waveparams(0.0, 1e-3, 2.0, shape="triangle")
    with pytest.raises(ValueError, match="coil_time applies to shape='square' only"):
        Waveparams(0.0, 1e-3, 2.0, coil_time=0.01)
    with pytest.raises(ValueError, match="coil_time must be >= 0"):
        Waveparams(0.0, 1e-3, 2.0, shape="square", coil_time=-1.0)


def test_direction_of():
    assert [direction_of(v) for v in (1e-3, -1e-3, 1e-7)] == ["right", "left", "none"]


def test_run_gait_validates_input():
    p = gait_preset("paper-5a")
    with pytest.raises(ValueError, match="seconds must be > 0"):
        run_gait(p, 0.0)
    with pytest.raises(ValueError, match="robot must be a built-in name"):
        run_gait(42, 1.0)
    with pytest.raises(ValueError, match="Did you mean 'paper-5a'"):
        run_gait("papr-5a", 1.0)
    no_drive = p.replace(drive=None)
    with pytest.raises(ValueError, match="has no drive"):
        run_gait(no_drive, 1.0)


def test_run_gait_records_a_consistent_result():
    r = run_gait(gait_preset("paper-5b"), 0.6, segments=8, timestep=5e-4)
    assert r.success
    assert r.seconds == pytest.approx(0.6)
    assert r.displacement == pytest.approx(r.com_x[-1] - r.com_x[0])
    assert r.warmup == pytest.approx(0.3, abs=0.011)  # one period (0.5 s) is capped at half the run
    assert np.isfinite(r.speed) and r.max_height > 0


def test_5c_reverses_with_bx():
    # the paper's dual-direction crawler: inverting B_x reverses the motion (coarse step: fast)
    fwd = run_gait(gait_preset("paper-5c"), 2.0, timestep=5e-4)
    rev = run_gait(gait_preset("paper-5c", reverse=True), 2.0, timestep=5e-4)
    assert fwd.success and rev.success
    assert np.sign(fwd.speed) == -np.sign(rev.speed)
    assert min(abs(fwd.speed), abs(rev.speed)) > 0.1e-3  # m/s: both crawl
    # mirror symmetry (beta odd about the middle): inverting B_x is the mirror image half a period later
    assert fwd.speed == pytest.approx(-rev.speed, rel=0.05)


# The directions docs/envs.md ("Paper gaits") reports, at a coarser step than the table's 0.1 ms
# (the table shows the same signs at 0.2, 0.1 and 0.05 ms), at the segments they were established with
# (20 for 5a, 40 for 5b, not the robots' own 80) and over shorter runs, to stay fast.


def test_5a_under_oscillating_bz_moves_right_with_its_right_half_lifting_more():
    # the preset ("W" jig, B_z 2 mT, 2 Hz): against the paper's left, a reported disagreement; the
    # right half (phi = 20 %) deflects more, as the paper describes
    r = run_gait(gait_preset("paper-5a"), 2.0, segments=20, timestep=2e-4)
    assert r.success
    assert r.speed > 0.15e-3  # m/s
    assert r.max_lift_right > 3.0 * r.max_lift_left


def test_5a_single_v_under_oscillating_bz_at_4hz_moves_left():
    # the former preset's single-V robot at the same amplitude and 4 Hz crawls left: its direction
    # depends on the frequency (docs/envs.md, "Paper gaits")
    import dataclasses

    from magsoft_env.cases.gaits import beam_5a

    p = gait_preset("paper-5a")
    p = dataclasses.replace(p, beam=beam_5a(vees=1), drive=dataclasses.replace(p.wave, frequency=4.0))
    r = run_gait(p, 2.0, segments=20, timestep=2e-4)
    assert r.success and r.speed < -0.1e-3  # m/s


def test_5a_under_oscillating_bx_does_not_crawl():
    # B_x acts only on the small transverse magnetization (sin 15 deg): below the tumbling threshold
    # the beam barely deforms and does not move
    import dataclasses

    p = dataclasses.replace(gait_preset("paper-5a"), drive=Waveparams(5e-3, 0.0, 2.0))
    r = run_gait(p, 1.5, segments=20, timestep=2e-4)
    assert r.success
    assert abs(r.speed) < 0.05e-3 and max(r.max_lift_left, r.max_lift_right) < 1.5e-3


def test_5b_moves_left():
    r = run_gait(gait_preset("paper-5b"), 2.0, segments=40, timestep=2e-4)
    assert r.success and r.speed < -0.2e-3  # m/s, the paper's direction


def test_square_drive_turns_5a_left_and_5b_right():
    # docs/envs.md, "The drive waveform": switched at the sine's zero crossings (1.5 mT, 2 Hz), 5a
    # goes left (the paper's direction, -0.54 mm/s at 0.1 ms) and 5b goes right (against the paper's
    # left, +0.99 mm/s): no one drive gives both paper directions
    import dataclasses

    speeds = {}
    for name in ("paper-5a", "paper-5b"):
        p = gait_preset(name)
        wave = dataclasses.replace(p.wave, amplitude_z=0.75 * p.wave.amplitude_z, shape="square")
        r = run_gait(dataclasses.replace(p, drive=wave), 2.0, segments={"paper-5a": 20, "paper-5b": 40}[name],
                     timestep=2e-4)
        assert r.success
        speeds[name] = r.speed
    assert speeds["paper-5a"] < -0.3e-3 and speeds["paper-5b"] > 0.5e-3  # m/s


def test_5b_turned_over_goes_right_at_friction_half_and_left_when_tacky():
    # docs/envs.md, "Tacky friction": 5b face down (its right end flips more, as the paper describes)
    # crawls right at the presets' friction 0.5 and left at 2 (+1.17 / -0.21 mm/s at 0.1 ms)
    import dataclasses

    from magsoft_env.cases.gaits import beam_5b

    p = dataclasses.replace(gait_preset("paper-5b"), beam=beam_5b(face_down=True))
    low = run_gait(p, 2.0, segments=40, timestep=2e-4)
    tacky = run_gait(dataclasses.replace(p, friction=2.0), 2.0, segments=40, timestep=2e-4)
    assert low.success and tacky.success
    assert low.speed > 0.1e-3 and tacky.speed < -0.1e-3  # m/s
    assert low.max_lift_right > low.max_lift_left


def test_symmetric_robot_under_pure_bz_does_not_drift():
    # the cosine-jig beam under an oscillating B_z alone is its own mirror image: no net motion
    # (this caught a +0.55 mm/s drift of sphere colliders, hence capsules in the presets)
    import dataclasses

    p = dataclasses.replace(gait_preset("paper-5c"), drive=Waveparams(0.0, 1.5e-3, 2.0))
    r = run_gait(p, 1.5, timestep=5e-4)
    assert abs(r.speed) < 0.05e-3  # m/s


def test_gait_cli_json(capsys):
    rc = main(["gait", "--preset", "paper-5c", "--reverse", "--seconds", "0.6", "--timestep-ms", "0.5",
               "--segments", "8", "--json"])
    assert rc == 0
    out = json.loads(capsys.readouterr().out)
    assert {"displacement_mm", "speed_mm_s", "direction", "paper_direction"} <= set(out)
    assert out["field_mT"]["amplitude_x"] == -2.0  # reversed: B_x inverted from the preset's +2 mT
    assert out["direction"] in ("left", "right", "none")


def test_gait_cli_text_and_bad_input(capsys):
    assert main(["gait", "--preset", "paper-5a", "--seconds", "0.2", "--timestep-ms", "0.5", "--segments", "6"]) == 0
    text = capsys.readouterr().out
    assert "mm/s" in text and "paper: left, -0.85 mm/s" in text
    assert main(["gait", "--preset", "paper-5a", "--seconds", "-1"]) == 2
    assert "--seconds must be > 0" in capsys.readouterr().err
    assert main(["gait", "--preset", "paper-5a", "--coil-ms", "10"]) == 2
    assert "--coil-ms applies to --waveform square only" in capsys.readouterr().err
    assert main(["gait", "--preset", "paper-5a", "--field-scale", "0"]) == 2
    assert "--field-scale must lie in (0, 10]" in capsys.readouterr().err


def test_gait_cli_replaces_the_drive(capsys):
    rc = main(["gait", "--preset", "paper-5a", "--waveform", "square", "--coil-ms", "10", "--field-scale", "0.75",
               "--friction", "1.5", "--seconds", "0.3", "--timestep-ms", "0.5", "--segments", "6", "--json"])
    assert rc == 0
    out = json.loads(capsys.readouterr().out)
    f = out["field_mT"]
    assert (f["shape"], f["coil_ms"], f["amplitude_z"]) == ("square", 10.0, pytest.approx(1.5))
    assert out["friction"] == 1.5
    assert main(["gait", "--preset", "paper-5a", "--friction", "-1"]) == 2
    assert "--friction must lie in [0, 10]" in capsys.readouterr().err
    assert main(["gait", "--preset", "paper-5c", "--face-down"]) == 2
    assert "--face-down applies to --preset paper-5a and paper-5b" in capsys.readouterr().err
    assert main(["gait", "--preset", "paper-5b", "--face-down", "--seconds", "0.2", "--timestep-ms", "0.5",
                 "--segments", "6", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["face_down"] is True


def test_gaits_pin_their_rod_options():
    # the gaits must not move when the sim's defaults change: contact, solver and base are explicit
    from magsoft_env.cases.gaits import GAIT_ROD_OPTIONS
    from magsoft_env.sim.gait import gait_rod_options
    from magsoft_env.sim.model import material_contact_timeconst

    p = gait_preset("paper-5a")
    o = gait_rod_options(p)
    assert o.contact_timeconst == material_contact_timeconst(p.beam) == pytest.approx(1.42e-4, rel=0.01)
    assert (o.contact_geom, o.timestep, o.segments) == ("capsule", 1e-4, 80)  # 5a's own numerics
    assert all(getattr(o, k) == v for k, v in GAIT_ROD_OPTIONS.items())
    # 5b settles only once the step resolves its contact events (docs/convergence.md)
    o = gait_rod_options(gait_preset("paper-5b"))
    assert (o.segments, o.timestep) == (80, 2.5e-5)
    o = gait_rod_options(gait_preset("paper-5b"), fidelity="fast")
    assert (o.segments, o.timestep) == (20, 2e-4)
    with pytest.raises(ValueError, match="not both"):
        gait_rod_options(gait_preset("paper-5b"), fidelity="fast", segments=40)
    with pytest.raises(ValueError, match="fidelity must be one of"):
        gait_rod_options(gait_preset("paper-5b"), fidelity="medium")


def test_beam_5a_jig_angle_and_face():
    from magsoft_env.cases.gaits import beam_5a

    L = 25e-3
    up, down = beam_5a(), beam_5a(math.radians(30.0), face_down=True)
    np.testing.assert_allclose(np.degrees(up.beta([0.25 * L, 0.75 * L])), [15.0, -15.0], atol=1e-9)
    np.testing.assert_allclose(np.degrees(down.beta([0.25 * L, 0.75 * L])), [-30.0, 30.0], atol=1e-9)
    three = beam_5a(vees=3, face_down=True)  # six pieces, starting rising (face down)
    centres = (np.arange(6) + 0.5) * L / 6
    np.testing.assert_allclose(np.degrees(three.beta(centres)), [-15.0, 15.0] * 3, atol=1e-9)
    assert three.length == pytest.approx(L)
    with pytest.raises(ValueError, match="vees must be a positive integer"):
        beam_5a(vees=0)


def test_beam_5b_faces():
    from magsoft_env.cases.gaits import beam_5b

    L = 25e-3
    centres = (np.arange(3) + 0.5) * L / 3
    np.testing.assert_allclose(np.degrees(beam_5b().beta(centres)), [5.0, 10.0, 20.0], atol=1e-9)
    np.testing.assert_allclose(np.degrees(beam_5b(face_down=True).beta(centres)), [-5.0, -10.0, -20.0], atol=1e-9)
    assert gait_preset("paper-5b").beam == beam_5b()


def test_fidelity_levels_set_the_numerics():
    from magsoft_env.cases.gaits import FIDELITY

    assert FIDELITY["fast"] == (20, 2e-4) and FIDELITY["converged"][1] < FIDELITY["fine"][1]
    r = run_gait(gait_preset("paper-5c"), 0.05, fidelity="fast")
    assert r.success and len(r.time) > 1
    with pytest.raises(ValueError, match="fidelity must be one of"):
        run_gait(gait_preset("paper-5c"), 0.05, fidelity="exact")
    with pytest.raises(ValueError, match="not both"):
        run_gait(gait_preset("paper-5c"), 0.05, fidelity="fast", segments=10)


def test_run_gait_shows_progress_on_request(capsys):
    quiet = run_gait(gait_preset("paper-5c"), 0.2, segments=6, timestep=5e-4)
    assert capsys.readouterr().err == ""
    shown = run_gait(gait_preset("paper-5c"), 0.2, segments=6, timestep=5e-4, progress=True)
    assert "of 0.2 s simulated" in capsys.readouterr().err
    assert shown.displacement == quiet.displacement  # the bar changes nothing
