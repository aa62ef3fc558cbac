"""The paper gaits (Fig. 5) under varied fields, friction and numerics: the table in docs/envs.md.

    python -m magsoft_env.bench.gait_sweep [--quick] [--groups 5a-field,5b-numerics] [--seconds 6]
                                           [--json out.json]

Every row is one :func:`magsoft_env.sim.gait.run_gait` of a preset with some of its settings
replaced (field, friction, segments, timestep); the speed is the centre-of-mass speed along +x
after the first field period. Groups:

* ``presets``: the three presets as shipped (``--reverse`` for 5c), defaults of ``magsoft gait`` (each robot's
  own numerics). The other groups run the study numerics the docs tables were measured at
  (:data:`STUDY_SEGMENTS`, :data:`STUDY_TIMESTEP`) unless a row says otherwise.

The groups ``5a-field``, ``5a-robot``, ``5a-frequency``, ``5a-friction`` and ``5a-numerics``
run the single-V 5a robot (``beam_5a(vees=1)``), so that they reproduce the docs table measured
with it; ``presets`` runs the shipped
preset (the 2-V "W" jig).
* ``5a-field``: paper-5a under oscillating B_z, oscillating B_x, a field oscillating along a
  tilted axis (B_x and B_z in phase or in antiphase) and rotating fields (B_x 90 deg ahead of
  or behind B_z), 2 Hz.
* ``5a-robot``: what the paper leaves open about the robot itself: the other face down
  (beta -> -beta) and a 30 deg jig instead of 15 deg.
* ``5a-frequency``, ``5a-friction``: paper-5a's own field at 1 and 4 Hz; friction 0.3 and 1.0.
* ``5a-polylines``: the 5a robot magnetized by multiple symmetric polylines (zigzag jigs of 1-4
  V's, ``beam_5a(vees=n)``): both faces down, jig angle 10-30 deg, oscillating B_z 1.25-2.5 mT at
  1-4 Hz, oscillating B_x 2.5 and 5 mT, and 20 / 40 segments at 0.1 / 0.05 ms (42 rows, about
  6 minutes on one core).
* ``waveform``: every gait under its own field as a sine (the presets), an ideal square and a
  square through a 10 / 40 ms coil, at 0.75x and 1x the preset amplitudes; and 5b turned over
  (its right end flipping more, as the paper describes) under the sine and the square (36 rows).
* ``friction``: tacky silicone, friction 1.5-3, every robot under its sine and (1.5, 2) under
  the 0.75x square (25 rows).
* ``5a-numerics``, ``5b-numerics``, ``5c-numerics``: timestep 0.2 / 0.1 / 0.05 ms and 20 / 40
  segments, to show whether the speeds converge.

``--quick`` runs only ``presets`` for 2 s each (a smoke check of the directions, about a
minute); the docs table is the full run (default 6 s, about 15 minutes on one core).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import sys

from magsoft_env.cases.gaits import PAPER_5A_VEES, beam_5a, beam_5b, gait_preset
from magsoft_env.sim.gait import run_gait
from magsoft_env.spec.drive import Waveparams
from magsoft_env.units import MT

#: The numerics the study tables of docs/envs.md were measured at (not each robot's own numerics): 20
#: segments (40 for paper-5b) at 0.1 ms. Every group but ``presets`` runs them unless its row says otherwise, so
#: that the tables reproduce; ``presets`` runs each robot at its own numerics, as ``magsoft gait`` does.
STUDY_SEGMENTS = {"paper-5a": 20, "paper-5b": 40, "paper-5c": 20}
STUDY_TIMESTEP = 1e-4


@dataclasses.dataclass(frozen=True)
class Case:
    """One row: a preset with optional replacements (``None``: the preset's own)."""

    group: str
    preset: str
    reverse: bool = False
    wave: Waveparams | None = None
    friction: float | None = None
    segments: int | None = None  # None: STUDY_SEGMENTS (group "presets": the robot's own)
    timestep: float | None = STUDY_TIMESTEP  # None: the robot's own
    label: str = ""
    jig_angle_deg: float | None = None  # paper-5a only: V-jig angle (preset 15 deg)
    face_down: bool = False  # paper-5a and paper-5b: the other face on the floor
    vees: int | None = None  # paper-5a only: V's in the symmetric zigzag jig (None: PAPER_5A_VEES)


def _w(bx_mT: float, bz_mT: float, f: float = 2.0, phase_deg: float = 0.0) -> Waveparams:
    return Waveparams(bx_mT * MT, bz_mT * MT, f, math.radians(phase_deg))


def cases(groups=None) -> list[Case]:
    """The sweep's rows, optionally only the named groups."""
    own = {"timestep": None}  # the robots' own numerics (segments None too)
    out = [Case("presets", "paper-5a", **own), Case("presets", "paper-5b", **own), Case("presets", "paper-5c", **own),
           Case("presets", "paper-5c", reverse=True, **own)]
    for bz in (1.0, 1.25, 1.5, 2.0, 2.5):
        out.append(Case("5a-field", "paper-5a", wave=_w(0.0, bz), label="oscillating B_z"))
    for bx in (2.0, 5.0, 6.0, 7.0):
        out.append(Case("5a-field", "paper-5a", wave=_w(bx, 0.0), label="oscillating B_x"))
    for ph, what in ((0.0, "tilted axis, in phase"), (180.0, "tilted axis, antiphase"),
                     (90.0, "rotating, B_x 90 deg ahead"), (-90.0, "rotating, B_x 90 deg behind")):
        out.append(Case("5a-field", "paper-5a", wave=_w(1.5, 1.5, 2.0, ph), label=what))
    for bz in (1.5, 2.0):
        out.append(Case("5a-robot", "paper-5a", wave=_w(0.0, bz), face_down=True, label="face down"))
    out.append(Case("5a-robot", "paper-5a", wave=_w(6.0, 0.0), face_down=True, label="face down"))
    for bx in (2.0, 3.0):
        out.append(Case("5a-robot", "paper-5a", wave=_w(bx, 0.0), jig_angle_deg=30.0, label="30 deg jig"))
    out.append(Case("5a-robot", "paper-5a", wave=_w(0.0, 1.5), jig_angle_deg=30.0, label="30 deg jig"))
    wa = gait_preset("paper-5a").wave
    for f, seg, dt in ((1.0, 20, 1e-4), (3.0, 20, 1e-4), (4.0, 20, 1e-4), (4.0, 40, 5e-5)):
        out.append(Case("5a-frequency", "paper-5a", wave=dataclasses.replace(wa, frequency=f), segments=seg,
                        timestep=dt))
    for mu in (0.3, 1.0):
        out.append(Case("5a-friction", "paper-5a", friction=mu))
    out += polyline_cases()
    out += waveform_cases()
    out += friction_cases()
    for name, rev in (("paper-5a", False), ("paper-5b", False), ("paper-5c", False), ("paper-5c", True)):
        group = name[-2:] + "-numerics"
        for seg, dt in ((20, 2e-4), (20, 1e-4), (20, 5e-5), (40, 1e-4), (40, 5e-5)):
            out.append(Case(group, name, reverse=rev, segments=seg, timestep=dt))
    # the single-V robot for the groups measured with it
    own = ("presets", "5a-polylines", "waveform", "friction")  # groups that set their own robot
    out = [dataclasses.replace(c, vees=1) if c.preset == "paper-5a" and c.group not in own else c for c in out]
    if groups:
        known = {c.group for c in out}
        bad = set(groups) - known
        if bad:
            raise ValueError(f"unknown groups {sorted(bad)}; known: {sorted(known)}")
        out = [c for c in out if c.group in groups]
    return out


def _poly(vees: int, face_down: bool = False, angle: float = 15.0) -> str:
    jig = {1: "V", 2: "W"}.get(vees, f"{vees} V's")
    return f"{jig} jig {angle:g} deg" + (", face down" if face_down else "")


def polyline_cases() -> list[Case]:
    """Group ``5a-polylines``: the 5a robot magnetized by multiple symmetric polylines (zigzags of
    1-4 V's), both faces down, jig angle 10-30 deg, oscillating B_z 1.25-2.5 mT at 1-3 Hz (and 4 Hz), a few
    oscillating B_x rows, and 20 / 40 segments at 0.1 / 0.05 ms for the convergence of the
    multiple-V robots. Fixed before any row was run; no row was chosen by its direction."""
    g, out = "5a-polylines", []
    for n in (1, 2, 3, 4):  # the core: V's x face x amplitude, 15 deg, 2 Hz
        for down in (False, True):
            for bz in (1.5, 2.0):
                out.append(Case(g, "paper-5a", wave=_w(0.0, bz), vees=n, face_down=down, label=_poly(n, down)))
    for n in (2, 3):
        for bz in (1.25, 2.5):  # the ends of the crawl window
            out.append(Case(g, "paper-5a", wave=_w(0.0, bz), vees=n, label=_poly(n)))
        for f in (1.0, 3.0, 4.0):  # frequency (4 Hz: where the single V goes left)
            out.append(Case(g, "paper-5a", wave=_w(0.0, 2.0, f), vees=n, label=_poly(n)))
        for ang in (10.0, 30.0):  # jig angle
            out.append(Case(g, "paper-5a", wave=_w(0.0, 2.0), vees=n, jig_angle_deg=ang, label=_poly(n, angle=ang)))
    for n in (2, 3, 4):  # oscillating B_x: acts on the transverse (zigzag) part of the magnetization
        for bx in (2.5, 5.0):
            out.append(Case(g, "paper-5a", wave=_w(bx, 0.0), vees=n, label=_poly(n)))
    for n in (2, 3):  # convergence of the multiple-V robots (the 20-segment, 0.1 ms rows are above)
        for seg, dt in ((20, 5e-5), (40, 1e-4), (40, 5e-5)):
            out.append(Case(g, "paper-5a", wave=_w(0.0, 2.0), vees=n, segments=seg, timestep=dt, label=_poly(n)))
    return out


def waveform_cases() -> list[Case]:
    """Group ``waveform``: the drive's shape. Each gait (5a with its W jig and with the single V,
    5b, 5c) under its own field as a sine (the presets), as an ideal square (switched at the sine's
    zero crossings) and as a square through a coil of time constant 10 and 40 ms, at 0.75x and 1x
    the preset amplitudes. Chosen after an exploratory study of 5a (186 runs: densities by phi,
    unipolar fields, squares, coil lags, ramps; docs/envs.md) showed that the square drive turns 5a
    left; these rows test the same drives on every gait."""
    out = []
    for preset, vees, label in (("paper-5a", 2, "W jig"), ("paper-5a", 1, "V jig"), ("paper-5b", None, ""),
                                ("paper-5c", None, "")):
        w = gait_preset(preset).wave
        for scale in (0.75, 1.0):
            for shape, coil in (("sine", 0.0), ("square", 0.0), ("square", 10e-3), ("square", 40e-3)):
                wave = dataclasses.replace(w, amplitude_x=w.amplitude_x * scale, amplitude_z=w.amplitude_z * scale,
                                           shape=shape, coil_time=coil)
                out.append(Case("waveform", preset, wave=wave, vees=vees, label=label))
    w = gait_preset("paper-5b").wave
    for scale in (0.75, 1.0):  # 5b turned over: its right end flips more, as the paper describes
        for shape in ("sine", "square"):
            wave = dataclasses.replace(w, amplitude_z=w.amplitude_z * scale, shape=shape)
            out.append(Case("waveform", "paper-5b", wave=wave, face_down=True, label="face down"))
    return out


def friction_cases() -> list[Case]:
    """Group ``friction``: tacky silicone. Ecoflex on a smooth substrate has friction coefficients
    of about 1 or more; the presets use 0.5 (the ``5a-friction`` rows go to 1.0). Each robot (5a W
    and V, 5b both faces, 5c) under its preset sine at 1.5, 2 and 3, and under the square at 0.75x
    the preset amplitude (the drive that turns 5a left) at 1.5 and 2."""
    robots = (("paper-5a", dict(vees=2, label="W jig")), ("paper-5a", dict(vees=1, label="V jig")),
              ("paper-5b", {}), ("paper-5b", dict(face_down=True, label="face down")), ("paper-5c", {}))
    out = []
    for preset, kw in robots:
        w = gait_preset(preset).wave
        for mu in (1.5, 2.0, 3.0):
            out.append(Case("friction", preset, friction=mu, **kw))
        square = dataclasses.replace(w, amplitude_x=0.75 * w.amplitude_x, amplitude_z=0.75 * w.amplitude_z,
                                     shape="square")
        for mu in (1.5, 2.0):
            out.append(Case("friction", preset, wave=square, friction=mu, **kw))
    return out


def run_case(case: Case, seconds: float) -> dict:
    """Run one row; returns a JSON-ready dict (mm, mm/s, mT, ms)."""
    p = gait_preset(case.preset, reverse=case.reverse)
    if case.wave is not None:
        p = dataclasses.replace(p, drive=case.wave)
    if case.friction is not None:
        p = dataclasses.replace(p, friction=case.friction)
    if case.preset == "paper-5b" and case.face_down:
        p = dataclasses.replace(p, beam=beam_5b(face_down=True))
    elif case.jig_angle_deg is not None or case.face_down or case.vees is not None:
        angle = math.radians(15.0 if case.jig_angle_deg is None else case.jig_angle_deg)
        p = dataclasses.replace(p, beam=beam_5a(angle, face_down=case.face_down,
                                                   vees=PAPER_5A_VEES if case.vees is None else case.vees))
    segments = case.segments
    if segments is None and case.timestep is not None:
        segments = STUDY_SEGMENTS.get(case.preset)
    r = run_gait(p, seconds, segments=segments, timestep=case.timestep)
    w = p.wave
    d = r.to_dict()
    d.update(preset=case.preset, group=case.group, label=case.label, reverse=case.reverse,
             segments=r.segments, timestep_ms=r.timestep * 1e3, friction=p.friction, bx_mT=w.amplitude_x / MT,
             bz_mT=w.amplitude_z / MT, frequency_Hz=w.frequency, phase_deg=math.degrees(w.phase),
             shape=w.shape, coil_ms=w.coil_time * 1e3,
             paper_direction=p.paper_direction,
             paper_speed_mm_s=None if p.paper_speed is None else p.paper_speed * 1e3)
    return d


def _field(d: dict) -> str:
    parts = []
    if d.get("shape", "sine") != "sine":
        coil = f" (coil {d['coil_ms']:g} ms)" if d.get("coil_ms") else ""
        parts.append(f"{d['shape']}{coil}")
    if d["bx_mT"]:
        ph = f" {d['phase_deg']:+.0f} deg" if d["phase_deg"] and d["bz_mT"] else ""
        parts.append(f"B_x {d['bx_mT']:+g}{ph}")
    if d["bz_mT"]:
        parts.append(f"B_z {d['bz_mT']:g}")
    return ", ".join(parts) + f" mT, {d['frequency_Hz']:g} Hz"


HEADER = ("| group | gait | field | friction | N | dt (ms) | speed (mm/s) | direction | lift left / right (mm) "
          "| max height (mm) | paper |\n|---|---|---|---|---|---|---|---|---|---|---|")


def row(d: dict) -> str:
    paper = d["paper_direction"] + ("" if d["paper_speed_mm_s"] is None else f", {d['paper_speed_mm_s']:+.2f}")
    direction = d["direction"] if d["success"] else "unstable"
    label = f" ({d['label']})" if d["label"] else ""
    return (f"| {d['group']} | {d['preset']}{' --reverse' if d['reverse'] else ''}{label} | {_field(d)} | "
            f"{d['friction']:g} | {d['segments']} | {d['timestep_ms']:g} | {d['speed_mm_s']:+.2f} | {direction} | "
            f"{d['max_lift_left_mm']:.1f} / {d['max_lift_right_mm']:.1f} | {d['max_height_mm']:.1f} | {paper} |")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="only the presets, 2 s each (smoke check)")
    ap.add_argument("--groups", default="", help="comma-separated groups (default: all)")
    ap.add_argument("--seconds", type=float, default=None, help="simulated time per row in s (default 6; quick 2)")
    ap.add_argument("--json", default=None, help="also write the rows to this JSON file")
    args = ap.parse_args(argv)
    groups = [g for g in args.groups.split(",") if g] or (["presets"] if args.quick else None)
    seconds = args.seconds if args.seconds is not None else (2.0 if args.quick else 6.0)
    rows = []
    print(f"{seconds:g} s per row; speed after the first field period\n")
    print(HEADER)
    for case in cases(groups):
        d = run_case(case, seconds)
        rows.append(d)
        print(row(d), flush=True)
    print(f"\n{len(rows)} rows, {sum(d['wall_time_s'] for d in rows):.0f} s of computing")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=1)
    return 0 if all(d["success"] for d in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
