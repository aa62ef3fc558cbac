"""One case, run: the kinds of job a batch holds, each a pure function of its case (a JSON-ready dict).

A case is data: ``{"kind": KIND, ...}`` with the keys of the matching ``magsoft`` command where one exists
(``robot``, ``field_mT``, ``seconds``, ``reverse``, ...). Its result depends on the case alone, never on the
engine, the worker or the order: every job runs with BLAS on one thread, and a job that draws random numbers
takes them from the case's ``seed``. Results are plain numbers (JSON-ready); wall times are kept out of them
(the batch records each case's wall time beside its result).

Kinds (:data:`KINDS`):

``equilibrium``
    ``solve_equilibrium`` of a robot's beam (``robot``: a built-in name or a file) or of ``beam`` (a robot file's
    beam block) under ``field_mT`` (``[B_x, B_z]``, or ``[B_x, B_y, B_z]`` for the 3D rod); options ``gravity``,
    ``support``, ``coupling``, ``extensible``, ``clamp_deg``, ``start``, ``model``. The result is the
    equilibrium's ``to_dict()``.
``path``
    ``solve_path`` from zero field to ``field_mT`` in ``steps`` states (default 14), same keys; the result holds
    ``states``, one ``to_dict()`` each.
``gait``
    ``run_gait`` of ``robot`` (with a drive) for ``seconds`` (default 4); ``reverse``, ``segments``,
    ``timestep_ms``, ``fidelity``, ``field_scale``, ``friction``. The result is ``GaitResult.to_dict()``.
``design``
    ``design_profile`` for a built-in ``target`` (ball, vase, ...) or ``target_xz_mm`` (points, clamp first);
    ``width_mm``, ``thickness_mm``, ``volume_fraction``, ``field_min_mT``, ``field_max_mT``, ``family``, ``size``,
    ``points``, ``starts``, ``max_nfev``, ``seed``, ``gravity``, ``free_direction``.
``crosscheck``
    The analytical solver against the MuJoCo rod along a robot's or a preset's (``preset``) loading path;
    ``segments`` (a list, default ``[20]``), ``field_mT``, ``steps``.
``rollout``
    Episodes of a Gymnasium ``env`` (a registered id, ``env_kwargs``) played by a saved ``policy`` (a model
    ``.zip``; ``algo``) or, without one, by the robot's open-loop gait; ``episodes``, ``seed``.
``sleep``
    Waits ``seconds`` and returns them; ``raise``: a message to fail with instead (for checking an engine and
    measuring its cost per task).

Every robot-based kind also takes ``scale``: factors on the robot's ``length``, ``width``, ``thickness``,
``E0`` (modulus), ``magnetization`` (particle magnetization) and ``density``, the way the sweeps and the
Monte-Carlo scatter vary a robot (:mod:`magsoft_env.parallel.sweeps`).
"""

from __future__ import annotations

import dataclasses
import math
import signal
import threading
import time
import traceback

from ..io import jsonable
from ..threads import single_threaded_blas
from ..units import MM, MT

#: The kinds of job a case may name.
KINDS = ("equilibrium", "path", "gait", "design", "crosscheck", "rollout", "sleep")
#: Keys of ``scale`` (factors on a robot's beam).
SCALE_KEYS = ("length", "width", "thickness", "E0", "magnetization", "density")
#: Keys every case may carry besides its kind's (bookkeeping, ignored by the job).
COMMON_KEYS = ("kind", "id", "seed", "tags", "sample")

_KEYS = {
    "equilibrium": ("robot", "beam", "field_mT", "gravity", "support", "coupling", "extensible", "clamp_deg",
                    "start", "model", "scale"),
    "gait": ("robot", "seconds", "reverse", "segments", "timestep_ms", "fidelity", "field_scale", "friction",
             "scale"),
    "design": ("target", "target_xz_mm", "width_mm", "thickness_mm", "volume_fraction", "field_min_mT",
               "field_max_mT", "family", "size", "points", "starts", "max_nfev", "gravity", "free_direction"),
    "crosscheck": ("robot", "preset", "field_mT", "steps", "segments", "scale"),
    "rollout": ("env", "env_kwargs", "policy", "algo", "episodes"),
    "sleep": ("seconds", "raise"),
}
_KEYS["path"] = (*_KEYS["equilibrium"], "steps")


class CaseTimeout(TimeoutError):
    """A case ran longer than its batch's per-case timeout."""


def check_case(case, *, where: str = "case") -> dict:
    """``case`` if it is a dict naming a known kind with known keys; ValueError naming ``where`` otherwise.

    The values themselves are checked when the job runs (a bad value is a failure row, not a stopped batch)."""
    if not isinstance(case, dict):
        raise ValueError(f"{where} must be a JSON object with a 'kind', got {type(case).__name__}.")
    kind = case.get("kind")
    if kind not in KINDS:
        raise ValueError(f"{where}: 'kind' must be one of {list(KINDS)}, got {kind!r}.")
    unknown = sorted(set(case) - set(_KEYS[kind]) - set(COMMON_KEYS))
    if unknown:
        raise ValueError(f"{where}: unknown key(s) {unknown} for kind {kind!r}; known: "
                         f"{sorted(_KEYS[kind] + COMMON_KEYS)}.")
    return case


def run_case(case: dict) -> dict:
    """The result of one case (JSON-ready, wall times left out); raises what the job raises."""
    check_case(case)
    with single_threaded_blas():
        out = _RUNNERS[case["kind"]](case)
    return _without_wall_time(jsonable(out))


def run_one(case_id: str, case: dict, *, timeout: float | None = None) -> dict:
    """One row of the results: ``{"id", "ok", "result"}`` or ``{"id", "ok": False, "error"}``, and ``wall_time_s``.

    Never raises for a bad case: the exception becomes the row's ``error`` (its type, message and traceback).
    ``timeout`` (s): in the main thread, the case is interrupted (``CaseTimeout``) when it runs longer."""
    t0 = time.perf_counter()
    try:
        with _alarm(timeout):
            result = run_case(case)
        row = {"id": case_id, "ok": True, "result": result}
    except Exception as exc:  # noqa: BLE001  a bad case is a failure row, never a stopped batch
        row = {"id": case_id, "ok": False, "error": error_dict(exc)}
    row["wall_time_s"] = time.perf_counter() - t0
    return row


def run_chunk(chunk, timeout: float | None = None) -> list[dict]:
    """:func:`run_one` of each ``(case_id, case)`` of ``chunk``, in order."""
    return [run_one(cid, case, timeout=timeout) for cid, case in chunk]


def error_dict(exc: BaseException) -> dict:
    """``{"type", "message", "traceback"}`` of an exception (the traceback's last lines)."""
    tb = "".join(traceback.format_exception(type(exc), exc, exc.__traceback__))
    return {"type": type(exc).__name__, "message": str(exc), "traceback": tb[-4000:]}


def timeout_error(timeout: float) -> dict:
    """The error of a case stopped by the per-case timeout (the same on every engine)."""
    return {"type": "CaseTimeout", "message": f"the case ran longer than the timeout of {timeout:g} s",
            "traceback": ""}


class _alarm:
    """Raise :class:`CaseTimeout` in the block after ``timeout`` s (main thread only; otherwise a no-op: the
    engine's own deadline applies)."""

    def __init__(self, timeout):
        self.timeout = timeout
        self.armed = (timeout is not None and timeout > 0 and hasattr(signal, "setitimer")
                      and threading.current_thread() is threading.main_thread())

    def __enter__(self):
        if self.armed:
            def fire(signum, frame):
                raise CaseTimeout(f"the case ran longer than the timeout of {self.timeout:g} s")

            self.previous = signal.signal(signal.SIGALRM, fire)
            signal.setitimer(signal.ITIMER_REAL, float(self.timeout))
        return self

    def __exit__(self, *exc):
        if self.armed:
            signal.setitimer(signal.ITIMER_REAL, 0.0)
            signal.signal(signal.SIGALRM, self.previous)
        return False


#: Keys of timings in results (they depend on the machine, not on the case): left out.
TIMING_KEYS = ("wall_time_s", "wall_time", "wall_s", "mujoco_s", "theory_s")


def _without_wall_time(result):
    if isinstance(result, dict):
        return {k: _without_wall_time(v) for k, v in result.items() if k not in TIMING_KEYS}
    if isinstance(result, list):
        return [_without_wall_time(v) for v in result]
    return result


# ------------------------------------------------------------------------------------------ helpers
def _robot(case: dict, *, needed: bool = True):
    """The case's robot (``robot``, else ``beam`` as a drive-less robot) with ``scale`` applied; None if neither."""
    from ..cases.beamfile import beam_from_dict
    from ..cases.robots import Robot, load_robot

    if case.get("robot") is not None and case.get("beam") is not None:
        raise ValueError("give 'robot' or 'beam', not both.")
    if case.get("robot") is not None:
        src = case["robot"]
        robot = Robot.from_dict(src, where="case robot") if isinstance(src, dict) else load_robot(src)
    elif case.get("beam") is not None:
        robot = Robot("beam", beam_from_dict(case["beam"], where="case beam"))
    elif needed:
        raise ValueError(f"a {case['kind']!r} case needs 'robot' (a built-in name or a robot file) or 'beam'.")
    else:
        return None
    return scaled(robot, case.get("scale"))


def scaled(robot, scale: dict | None):
    """``robot`` with its beam's sizes, modulus, magnetization or density multiplied by ``scale``'s factors."""
    if not scale:
        return robot
    if not isinstance(scale, dict):
        raise ValueError(f"'scale' must be an object of factors {list(SCALE_KEYS)}, got {scale!r}.")
    unknown = sorted(set(scale) - set(SCALE_KEYS))
    if unknown:
        raise ValueError(f"'scale' has unknown key(s) {unknown}; known: {list(SCALE_KEYS)}.")
    for k, v in scale.items():
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not (math.isfinite(v) and v > 0):
            raise ValueError(f"'scale' {k} must be a factor > 0, got {v!r}.")
    b, m = robot.beam, robot.beam.material
    mat = {}
    if "E0" in scale:
        mat["E0"] = m.E0 * scale["E0"]
    if "magnetization" in scale:
        mat["particle_magnetization"] = m.particle_magnetization * scale["magnetization"]
    if "density" in scale:
        if callable(m.density):
            raise ValueError("'scale' density needs a material with a constant density.")
        mat["density"] = m.density * scale["density"]
    beam = {k: getattr(b, k) * scale[k] for k in ("length", "width", "thickness") if k in scale}
    if mat:
        beam["material"] = dataclasses.replace(m, **mat)
    return robot.replace(beam=dataclasses.replace(b, **beam)) if beam else robot


def _field(case: dict, default=(0.0, 13.0)):
    vals = case.get("field_mT", list(default))
    if not isinstance(vals, (list, tuple)) or len(vals) not in (2, 3):
        raise ValueError(f"'field_mT' must be [B_x, B_z] or [B_x, B_y, B_z] in mT, got {vals!r}.")
    for v in vals:
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or abs(v) > 1000:
            raise ValueError(f"'field_mT' components must be numbers in [-1000, 1000] mT, got {vals!r}.")
    return tuple(float(v) * MT for v in vals)


def _solver_kwargs(case: dict) -> dict:
    out = {k: case[k] for k in ("gravity", "support", "coupling", "extensible", "model") if k in case}
    if "clamp_deg" in case:
        out["clamp_angle"] = math.radians(case["clamp_deg"])
    return out


# ------------------------------------------------------------------------------------------ the kinds
def _equilibrium(case):
    from ..theory import solve_equilibrium

    robot = _robot(case)
    kw = _solver_kwargs(case)
    if "start" in case:
        kw["start"] = case["start"]
    return solve_equilibrium(robot.beam, _field(case), **kw).to_dict()


def _path(case):
    import numpy as np

    from ..theory import solve_path

    robot = _robot(case)
    steps = case.get("steps", 14)
    if isinstance(steps, bool) or not isinstance(steps, int) or not 2 <= steps <= 10_000:
        raise ValueError(f"'steps' must be an integer in [2, 10000], got {steps!r}.")
    end = np.array(_field(case))
    fields = [tuple(end * t) for t in np.linspace(0.0, 1.0, steps)]
    return {"states": [r.to_dict() for r in solve_path(robot.beam, fields, **_solver_kwargs(case))]}


def _gait(case):
    from ..sim.gait import run_gait

    robot = _robot(case)
    if case.get("reverse"):
        robot = robot.reversed()
    k = case.get("field_scale", 1.0)
    if k != 1.0:
        w = robot.wave
        robot = robot.replace(drive=dataclasses.replace(w, amplitude_x=w.amplitude_x * k,
                                                        amplitude_z=w.amplitude_z * k))
    if case.get("friction") is not None:
        robot = robot.replace(friction=case["friction"])
    dt = case.get("timestep_ms")
    return run_gait(robot, case.get("seconds", 4.0), segments=case.get("segments"), fidelity=case.get("fidelity"),
                    timestep=None if dt is None else dt * 1e-3).to_dict()


def _design(case):
    import numpy as np

    from ..design import builtin_target, design_profile, validate_target
    from ..spec import Beam

    if (case.get("target") is None) == (case.get("target_xz_mm") is None):
        raise ValueError("a 'design' case needs 'target' (a built-in name) or 'target_xz_mm', one of them.")
    if case.get("target") is not None:
        target = builtin_target(case["target"])
    else:
        target = np.asarray(case["target_xz_mm"], dtype=float) * MM
    target = validate_target(target, name="target")
    beam = Beam(length=1.0, width=case.get("width_mm", 5.0) * MM, thickness=case.get("thickness_mm", 1.13) * MM,
                volume_fraction=case.get("volume_fraction", 0.2))
    res = design_profile(
        target, beam, field_bounds=(case.get("field_min_mT", 1.0) * MT, case.get("field_max_mT", 20.0) * MT),
        family=case.get("family", "spline"), size=case.get("size"), n_points=case.get("points", 50),
        n_starts=case.get("starts", 4), max_nfev=case.get("max_nfev", 60), seed=case.get("seed", 0),
        gravity=case.get("gravity", 9.81),
        field_direction="free" if case.get("free_direction") else "perpendicular")
    return res.to_dict()


def _crosscheck(case):
    from ..cases import PathSegment, Preset, load_preset
    from ..compare import crosscheck_preset
    from ..spec import Field

    if case.get("preset") is not None:
        if case.get("robot") is not None:
            raise ValueError("give 'preset' or 'robot', not both.")
        preset = load_preset(case["preset"])
    else:
        robot = _robot(case)
        field = Field(*_field(case))
        preset = Preset(name=robot.name, description=robot.description or robot.name, beam=robot.beam,
                        path=(PathSegment(Field(), field, case.get("steps", 14)),))
    segments = tuple(case.get("segments", [20]))
    rows, _, _ = crosscheck_preset(preset, segments)
    return {"rows": [r.to_dict() if hasattr(r, "to_dict") else dataclasses.asdict(r) for r in rows]}


def _rollout(case):
    import gymnasium as gym

    from ..rl.evaluation import open_loop_actor, run_episodes

    env_id = case.get("env")
    if not isinstance(env_id, str):
        raise ValueError(f"a 'rollout' case needs 'env', a registered id, got {env_id!r}.")
    kwargs = dict(case.get("env_kwargs") or {})
    if case.get("policy") is not None:
        from ..rl.evaluation import load_policy

        policy = load_policy(case["policy"], algo=case.get("algo"), env=env_id, env_kwargs=kwargs or None)
        kwargs = kwargs or dict(policy.env_kwargs or {})

        def act(obs, env):
            return policy(obs)

        name = "policy"
    else:
        act, name = open_loop_actor(), "open loop"
    env = gym.make(env_id, **kwargs)
    try:
        res = run_episodes(env, act, episodes=case.get("episodes", 1), seed=case.get("seed", 0), name=name)
    finally:
        env.close()
    return res.to_dict()


def _sleep(case):
    seconds = case.get("seconds", 0.0)
    if isinstance(seconds, bool) or not isinstance(seconds, (int, float)) or not 0 <= seconds <= 86400:
        raise ValueError(f"'seconds' must be a number in [0, 86400], got {seconds!r}.")
    if case.get("raise"):
        raise ValueError(str(case["raise"]))
    if seconds:
        time.sleep(seconds)
    return {"seconds": seconds}


_RUNNERS = {"equilibrium": _equilibrium, "path": _path, "gait": _gait, "design": _design, "crosscheck": _crosscheck,
            "rollout": _rollout, "sleep": _sleep}

__all__ = ["COMMON_KEYS", "KINDS", "SCALE_KEYS", "CaseTimeout", "check_case", "error_dict", "run_case", "run_chunk",
           "run_one", "scaled", "timeout_error"]
