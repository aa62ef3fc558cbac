"""The crawl task on arrays: crawl limits, the first broken one, reward, observation and ``info`` of ``n`` robots.

Every function here is numpy over a leading batch axis of ``n`` robots; nothing steps or reads MuJoCo. The single
crawl envs (:class:`~magsoft_env.envs.crawl.MagSoftCrawlEnv`, the channel and obstacle envs, which add success)
call them with ``n = 1`` at every step, and through them the C-thread batch
(:class:`~magsoft_env.envs.vector.MagSoftCrawlVecEnv`); the MuJoCo Warp batch
(:class:`~magsoft_env.envs.warp_vector.MagSoftCrawlWarpVecEnv`) calls them with ``n = num_envs``. What the
simulator measures (centre of mass, centreline, piece angles and rates, orientation, deepest contact, time) comes
in as arrays.

- :func:`crawl_limits`: the crawl limits' figures of centreline points (clearance, highest point, cos of the
  largest piece angle from the body's heading), :func:`limit_summary` their reductions over a step (what the Warp
  batch reduces on its device, ``sim/warp_batch.py``), :func:`first_violation` the first broken limit and
  :func:`violation_texts` its ``info["crawl_violation"]``.
- :func:`crawl_reward`: the reward and its terms.
- :func:`clock_tail`, :func:`observation`: the observation, clipped to :func:`observation_high`.
- :class:`CrawlRecords`: an episode's running records (its reset and step bookkeeping);
  :func:`crawl_info` the ``info`` values; :func:`vector_info`, :func:`stack_infos` Gymnasium's vector form
  (``info[key]`` an array over the robots, ``info["_" + key]`` its mask); :func:`single_info` one robot's.
- :func:`wave_rows`, :func:`period_substeps`: waveform-mode actions as periods.

Examples
--------
>>> import numpy as np
>>> task = CrawlTask(crawl_mode="height", max_clearance=1e-5, max_link_rotation=2.0, max_height=7.6e-3,
...                  forward_reward_weight=1000.0, target_direction=1, field_cost_weight=0.1, crawl_penalty=10.0,
...                  field_limit=2e-3, clock_frequency=2.0)
>>> lim = np.array([[[0.0, 0.0], [5e-3, 8e-3], [1.0, 1.0]]])   # one robot, two states: the second too high
>>> column, figures = first_violation(lim, task)
>>> int(column[0]), violation_texts(figures, np.array([0.25]), task, column >= 0)[0]
(1, 'height 8.00 mm > 7.60 mm at t = 0.2500 s')
>>> reward, terms = crawl_reward(np.array([1e-3]), np.array([0.5]), column >= 0, np.array([2.0]), task)
>>> float(reward[0]), float(terms["forward"][0]), float(terms["crawl"][0])
(-12.05, 0.0, -12.0)
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ..sim.readouts import FLIP_ANGLE

#: Clearance (m) of the rod's lowest point above the floor beyond which the whole beam is off the floor
#: (airborne): the gap of the capsule colliders, so that a resting beam reads minus its contact depth. A numerical
#: tolerance, not a hop height: the open-loop paper gaits in the crawl env (paper-5a, 5b, 5c at their own numerics,
#: 5 s each) reach at most 0.0005 mm at any substep, 20x below it; 0.01 mm is 0.9 % of the paper beams'
#: 1.13 mm thickness.
AIRBORNE_TOLERANCE = 1e-5
#: Observation bounds (observations are clipped to them): angular speed (rad/s), centre-of-mass speed (m/s).
OBS_MAX_ANGULAR_VELOCITY = 1e3
OBS_MAX_VELOCITY = 10.0
CRAWL_MODES = ("rotation", "height", "none")
#: How a free robot moved over an episode (``info["locomotion"]``, :func:`locomotion_modes`).
LOCOMOTION_MODES = ("crawl", "hop", "roll", "tumble", "tumble with flight")
#: Roll (rad) of a piece about its own axis beyond which the body rolled (its width axis past vertical).
ROLL_ANGLE = 0.5 * math.pi
#: ``info`` entries of a step whose observation is not finite (it truncates, as an unstable simulation).
NONFINITE_OBSERVATION = {"truncation_reason": "non-finite observation", "instability": "observation"}


@dataclass(frozen=True, kw_only=True)
class CrawlTask:
    """The crawl task's parameters (SI), the crawl env's constructor arguments of the same names (its spec sheet,
    :class:`~magsoft_env.envs.crawl.MagSoftCrawlEnv`): ``crawl_mode`` (``"rotation"``, ``"height"``, ``"none"``),
    ``max_clearance`` (m, None: no floor limit), ``max_link_rotation`` (rad), ``max_height`` (m),
    ``forward_reward_weight`` (s/m), ``target_direction`` (+-1), ``field_cost_weight``, ``crawl_penalty``,
    ``field_limit`` (T), ``clock_frequency`` (Hz)."""

    crawl_mode: str
    max_clearance: float | None
    max_link_rotation: float
    max_height: float
    forward_reward_weight: float
    target_direction: int
    field_cost_weight: float
    crawl_penalty: float
    field_limit: float
    clock_frequency: float

    def __post_init__(self):
        if self.crawl_mode not in CRAWL_MODES:
            raise ValueError(f"crawl_mode must be one of {CRAWL_MODES}, got {self.crawl_mode!r}.")

    @property
    def cos_rotation(self) -> float:
        """cos of ``max_link_rotation``: a piece whose cosine from the heading is below it breaks the rotation
        limit."""
        return math.cos(self.max_link_rotation)


# ---------------------------------------------------------------------- crawl limits
def crawl_limits(points, heading, *, half_thickness: float, inv_piece_length, floor_contact=None) -> np.ndarray:
    """The crawl limits' figures of centreline points: rows clearance of the lowest point above the floor minus
    ``half_thickness`` (m), highest point (m) and cos of the largest piece angle from the body's ``heading`` on the
    floor toward +z.

    Parameters
    ----------
    points : (n, N + 2, k, 3) array_like
        ``k`` states of the centreline of each of ``n`` robots (m), base end first.
    heading : (n,) array_like
        Each robot's heading on the floor (rad from +x toward +y; 0 for the planar chain).
    half_thickness : float
        Half the beam's thickness (m): the colliders' radius.
    inv_piece_length : (N + 1,) array_like
        1 / the pieces' lengths (1/m): the pieces are rigid (or held at length), so the cosine of a piece's angle
        is its extent along the heading over its length.
    floor_contact : (n, k) array_like or None
        The deepest floor contact of each state (m, < 0 touching, 0 none: the rod's contact history). A state that
        touches the floor reads a clearance of at most 0: the centreline's lowest point minus ``half_thickness``
        is the clearance of a round section (the chain's capsules; never above 0 while they touch), but over-reads
        a strip turned about its axis (up to (w - h) / 2 standing on edge), which is on the floor all the same.

    Returns
    -------
    (n, 3, k) ndarray
    """
    p = np.asarray(points, dtype=float)
    if p.ndim != 4 or p.shape[-1] != 3 or p.shape[1] < 2:
        raise ValueError(f"points must have shape (n, N + 2, k, 3), got {p.shape}.")
    inv = np.asarray(inv_piece_length, dtype=float)
    if inv.shape != (p.shape[1] - 1,):
        raise ValueError(f"inv_piece_length must have shape ({p.shape[1] - 1},) (one per piece), got {inv.shape}.")
    n, _, k, _ = p.shape
    z = p[..., 2]
    out = np.empty((n, 3, k))
    np.subtract(z.min(axis=1), half_thickness, out=out[:, 0])
    if floor_contact is not None:
        touching = np.asarray(floor_contact, dtype=float).reshape(n, k) < 0.0
        out[:, 0] = np.where(touching & (out[:, 0] > 0.0), 0.0, out[:, 0])
    z.max(axis=1, out=out[:, 1])
    h = np.asarray(heading, dtype=float).reshape(n, 1, 1)
    d = p[:, 1:] - p[:, :-1]
    along = d[..., 0] * np.cos(h) + d[..., 1] * np.sin(h)
    (along * inv[:, None]).min(axis=1, out=out[:, 2])
    return out


def limit_summary(lim: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A step's crawl-limit records from :func:`crawl_limits` columns ``(n, 3, k + 1)`` (the ``k`` substeps' start
    states, then the end state): the highest clearance (m), the lowest cos and the substeps that started airborne
    (clearance above :data:`AIRBORNE_TOLERANCE`), each ``(n,)``."""
    return lim[:, 0].max(axis=1), lim[:, 2].min(axis=1), np.count_nonzero(lim[:, 0, :-1] > AIRBORNE_TOLERANCE, axis=1)


def broken_limits(lim: np.ndarray, task: CrawlTask) -> np.ndarray:
    """Where the columns of :func:`crawl_limits` ``(n, 3, k)`` break a crawl limit of ``task``: ``(n, k)`` bool."""
    broken = np.zeros((lim.shape[0], lim.shape[2]), dtype=bool)
    if task.crawl_mode == "none":
        return broken
    if task.max_clearance is not None:
        broken |= lim[:, 0] > task.max_clearance
    if task.crawl_mode == "rotation":
        broken |= lim[:, 2] < task.cos_rotation
    else:
        broken |= lim[:, 1] > task.max_height
    return broken


def first_violation(lim: np.ndarray, task: CrawlTask) -> tuple[np.ndarray, np.ndarray]:
    """The first column of :func:`crawl_limits` ``(n, 3, k)`` that breaks a crawl limit of each robot (-1: none)
    and that column's figures (clearance, highest point, cos; ``(n, 3)``)."""
    broken = broken_limits(lim, task)
    column = np.where(broken.any(axis=1), broken.argmax(axis=1), -1)
    figures = lim[np.arange(lim.shape[0]), :, np.maximum(column, 0)]
    return column, figures


def violation_texts(figures: np.ndarray, when: np.ndarray, task: CrawlTask, mask: np.ndarray) -> np.ndarray:
    """``info["crawl_violation"]`` of the robots of ``mask``: which limit the state of ``figures`` ``(n, 3)``
    (:func:`first_violation`'s) broke at time ``when`` ``(n,)`` (s), and by how much; None elsewhere."""
    out = np.full(len(mask), None, dtype=object)
    for i in np.flatnonzero(mask).tolist():
        clear, top, cos = figures[i]
        at = f"at t = {when[i]:.4f} s"
        if task.max_clearance is not None and clear > task.max_clearance:
            got, lim = _apart(clear * 1e3, task.max_clearance * 1e3, 3)
            out[i] = (f"airborne {at}: the lowest point is {got} mm above the floor > {lim} mm (the whole beam off the "
                      "floor: a hop, not a crawl)")
        elif task.crawl_mode == "rotation":
            rot = math.acos(max(-1.0, min(1.0, cos)))
            got, lim = _apart(math.degrees(rot), math.degrees(task.max_link_rotation), 1)
            out[i] = f"link rotation {got} deg > {lim} deg {at}"
        else:
            got, lim = _apart(top * 1e3, task.max_height * 1e3, 2)
            out[i] = f"height {got} mm > {lim} mm {at}"
    return out


def _apart(value: float, limit: float, decimals: int) -> tuple[str, str]:
    """``value`` and ``limit`` written with ``decimals`` decimals, or with as many more (up to 12) as make them read
    apart (a value just past its limit does not read "0.010 mm > 0.010 mm")."""
    for d in range(decimals, 13):
        a, b = f"{value:.{d}f}", f"{limit:.{d}f}"
        if a != b:
            return a, b
    return a, b


# ---------------------------------------------------------------------- reward
def crawl_reward(forward_velocity, power, violated, episode_forward, task: CrawlTask,
                 success=0.0) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """The reward of ``n`` robots' step and its terms ``forward``, ``field``, ``crawl``, ``success`` (each ``(n,)``).

    ``forward = forward_reward_weight * target_direction * forward_velocity`` (the centre of mass's mean velocity
    along x over the step, m/s), 0 on a step that breaks a crawl limit (``violated``); ``field = -field_cost_weight
    * power`` (the step's mean field power over ``field_limit^2``); ``crawl = -(crawl_penalty + max(0,
    episode_forward))`` where ``violated`` (``episode_forward``: the forward reward earned before this step), else
    0: breaking a limit forfeits the episode's progress; ``success``: a subclass's bonus."""
    violated = np.asarray(violated, dtype=bool)
    forward = np.where(violated, 0.0, task.forward_reward_weight * task.target_direction * np.asarray(forward_velocity))
    field = -task.field_cost_weight * np.asarray(power, dtype=float)
    crawl = np.where(violated, -(task.crawl_penalty + np.maximum(episode_forward, 0.0)), 0.0)
    success = np.broadcast_to(np.asarray(success, dtype=float), forward.shape).copy()
    reward = forward + field + crawl + success
    return reward, {"forward": forward, "field": field, "crawl": crawl, "success": success}


# ---------------------------------------------------------------------- observation
def observation_high(pieces: int) -> np.ndarray:
    """The observation's bounds (float32, ``(2 pieces + 6,)``): pi for the piece angles, 1000 rad/s for their
    rates, 10 m/s for the centre-of-mass velocity, 1 for the field / clock (or last action) tail."""
    return np.concatenate([np.full(pieces, np.pi), np.full(pieces, OBS_MAX_ANGULAR_VELOCITY),
                           np.full(2, OBS_MAX_VELOCITY), np.ones(4)]).astype(np.float32)


def clock_tail(field, time, task: CrawlTask) -> np.ndarray:
    """The field mode's observation tail ``(n, 4)``: the field (B_x, B_z) ``(n, 2)`` over ``field_limit``, then sin
    and cos of the clock phase ``2 pi clock_frequency time`` (``time``: ``(n,)``, s)."""
    w = 2.0 * math.pi * task.clock_frequency * np.asarray(time, dtype=float)
    return np.column_stack([np.asarray(field) / task.field_limit, np.sin(w), np.cos(w)])


def observation(angles, angular_velocities, com_velocity, tail, high) -> np.ndarray:
    """The observation ``(n, 2 N + 8)`` float32: piece angles ``(n, N + 1)`` (rad), their rates (rad/s), the
    centre-of-mass velocity ``(n, 2)`` (m/s) and the ``tail`` ``(n, 4)``, clipped to ``[-high, high]``
    (:func:`observation_high`)."""
    obs = np.concatenate([angles, angular_velocities, com_velocity, tail], axis=1).astype(np.float32)
    return np.clip(obs, -high, high)


# ---------------------------------------------------------------------- waveform mode
def wave_rows(actions, *, field_limit: float, frequency_range) -> np.ndarray:
    """Waveform-mode actions ``(n, 4)`` in [-1, 1] (clipped) as rows ``(A_x, A_z, f, phase)`` (T, T, Hz, rad) of
    ``B_x = A_x sin(2 pi f t + phase)``, ``B_z = A_z sin(2 pi f t)``, the frequency mapped linearly onto
    ``frequency_range`` (Hz)."""
    a = np.clip(np.asarray(actions, dtype=float), -1.0, 1.0)
    f_lo, f_hi = frequency_range
    freq = f_lo + 0.5 * (a[:, 3] + 1.0) * (f_hi - f_lo)
    return np.column_stack([a[:, 0] * field_limit, a[:, 1] * field_limit, freq, a[:, 2] * math.pi])


def period_substeps(frequency, sim_dt: float) -> np.ndarray:
    """Substeps of one period at ``frequency`` ``(n,)`` (Hz): ``round(1 / (f sim_dt))``, at least 1."""
    return np.maximum(1, np.round(1.0 / (np.asarray(frequency, dtype=float) * sim_dt))).astype(np.int64)


# ---------------------------------------------------------------------- records and info
@dataclass
class CrawlRecords:
    """The running records of ``n`` robots' episodes (arrays over the leading axis, SI): centre of mass (x, z) and
    its mean velocity over the last step, the field now (B_x, B_z), the last waveform action, the forward reward
    earned, whether the body flipped, the highest clearance and lowest cos of the crawl limits at any substep,
    the substeps that started airborne and the substeps booked."""

    com: np.ndarray
    com_velocity: np.ndarray
    field: np.ndarray
    last_action: np.ndarray
    episode_forward: np.ndarray
    flipped: np.ndarray
    highest_clearance: np.ndarray
    lowest_cos: np.ndarray
    airborne: np.ndarray
    substeps: np.ndarray
    max_roll: np.ndarray | None = None

    def __post_init__(self):
        if self.max_roll is None:
            self.max_roll = np.zeros(len(self.airborne))

    @classmethod
    def zeros(cls, n: int) -> CrawlRecords:
        """Records of ``n`` robots before their first episode."""
        return cls(com=np.zeros((n, 2)), com_velocity=np.zeros((n, 2)), field=np.zeros((n, 2)),
                   last_action=np.zeros((n, 4)), episode_forward=np.zeros(n), flipped=np.zeros(n, dtype=bool),
                   highest_clearance=np.zeros(n), lowest_cos=np.ones(n), airborne=np.zeros(n, dtype=np.int64),
                   substeps=np.zeros(n, dtype=np.int64), max_roll=np.zeros(n))

    def restart(self, mask, *, com, start_limits) -> None:
        """The reset's bookkeeping of the robots of ``mask``: an episode starts at rest under zero field from the
        state whose centre of mass is ``com`` ``(n, 2)`` and whose :func:`crawl_limits` are ``start_limits``
        ``(n, 3)`` (rows of the other robots are not read)."""
        m = np.asarray(mask, dtype=bool)
        self.com[m] = np.asarray(com)[m]
        self.com_velocity[m] = 0.0
        self.field[m] = 0.0
        self.last_action[m] = 0.0
        self.episode_forward[m] = 0.0
        self.flipped[m] = False
        self.highest_clearance[m] = start_limits[m, 0]
        self.lowest_cos[m] = start_limits[m, 2]
        self.airborne[m] = 0
        self.substeps[m] = 0
        self.max_roll[m] = 0.0

    def book(self, mask, *, com, duration, highest_clearance, lowest_cos, airborne, substeps, roll=None) -> None:
        """A step's bookkeeping of the robots of ``mask``: the centre of mass now ``(n, 2)`` after ``duration``
        ``(n,)`` (s), the step's :func:`limit_summary` over ``substeps`` ``(n,)``, and the body's roll at its end
        ``(n,)`` (rad, the largest of its pieces; None: a rod in the x-z plane, 0)."""
        if roll is not None:
            m = np.asarray(mask, dtype=bool)
            self.max_roll[m] = np.maximum(self.max_roll, np.asarray(roll, dtype=float))[m]
        m = np.asarray(mask, dtype=bool)
        vel = (np.asarray(com) - self.com) / np.asarray(duration, dtype=float)[:, None]
        self.com_velocity[m] = vel[m]
        self.com[m] = np.asarray(com)[m]
        self.highest_clearance[m] = np.maximum(self.highest_clearance, highest_clearance)[m]
        self.lowest_cos[m] = np.minimum(self.lowest_cos, lowest_cos)[m]
        self.airborne[m] += np.asarray(airborne)[m]
        self.substeps[m] += np.asarray(substeps)[m]


def book_substeps(records: CrawlRecords, samples, end, *, com, duration, roll) -> tuple[np.ndarray, int]:
    """One robot's step booked from its crawl limits: ``samples`` (the blocks' :func:`crawl_limits`, ``(1, 3, k_i)``
    each, the substeps' start states) and ``end`` (the end state's, ``(1, 3, 1)``); the centre of mass now ``(1,
    2)``, the step's ``duration`` ``(1,)`` (s) and the body's ``roll`` ``(1,)`` (rad). Returns the step's limits
    ``(1, 3, k + 1)`` and ``k``."""
    lim = np.concatenate([*samples, end], axis=2)
    clear, cos, airborne = limit_summary(lim)
    k = lim.shape[2] - 1
    records.book([True], com=com, duration=duration, highest_clearance=clear, lowest_cos=cos, airborne=airborne,
                 substeps=[k], roll=roll)
    return lim, k


def crawl_info(records: CrawlRecords, *, orientation, reward, terms: Mapping, time, max_penetration,
               is_success) -> dict[str, np.ndarray]:
    """The ``info`` values of ``n`` robots, each an array over them: ``orientation`` (rad) and ``flipped`` (the
    records take this orientation in: past :data:`~magsoft_env.sim.readouts.FLIP_ANGLE` once in the episode),
    the ``reward`` and its ``terms`` (:func:`crawl_reward`), the centre of mass's position and x velocity, the
    field, ``time`` (s), ``is_success``, ``max_penetration`` (m), and the crawl limits' records:
    ``highest_clearance`` (m), ``airborne_fraction`` and ``largest_piece_angle`` (rad), ``max_roll`` (rad) and the
    episode's ``locomotion`` so far (:func:`locomotion_modes`)."""
    r = records
    turn = np.asarray(orientation, dtype=float)
    r.flipped |= np.abs(turn) > FLIP_ANGLE
    frac = np.divide(r.airborne, r.substeps, out=np.zeros(len(r.airborne)), where=r.substeps > 0)
    return {
        "orientation": turn, "flipped": r.flipped.copy(),
        "reward_forward": terms["forward"], "reward_field": terms["field"], "reward_crawl": terms["crawl"],
        "reward_success": terms["success"], "reward": np.asarray(reward, dtype=float),
        "x_position": r.com[:, 0].copy(), "z_position": r.com[:, 1].copy(),
        "x_velocity": r.com_velocity[:, 0].copy(), "field": r.field.copy(), "time": np.asarray(time, dtype=float),
        "is_success": np.asarray(is_success, dtype=bool),
        "max_penetration": np.asarray(max_penetration, dtype=float), "highest_clearance": r.highest_clearance.copy(),
        "airborne_fraction": frac, "largest_piece_angle": np.arccos(np.clip(r.lowest_cos, -1.0, 1.0)),
        "max_roll": r.max_roll.copy(), "locomotion": locomotion_modes(r.flipped, r.airborne, r.max_roll),
    }


def locomotion_modes(flipped, airborne, max_roll) -> np.ndarray:
    """How each of ``n`` robots moved over its episode so far (:data:`LOCOMOTION_MODES`): ``"tumble"`` once the body
    has been past vertical end over end (``flipped``), ``"tumble with flight"`` when it was also airborne at a
    substep (``airborne`` > 0 substeps with the whole beam above the floor), ``"hop"`` airborne without a flip,
    ``"roll"`` a piece's width axis past vertical (``max_roll`` above :data:`ROLL_ANGLE`) on the floor, else
    ``"crawl"``: part of the beam on the floor at every substep, right way up. ``(n,)`` object array of str."""
    flipped = np.asarray(flipped, dtype=bool)
    flight = np.asarray(airborne) > 0
    rolled = np.asarray(max_roll, dtype=float) > ROLL_ANGLE
    out = np.full(flipped.shape, "crawl", dtype=object)
    out[rolled] = "roll"
    out[flight] = "hop"
    out[flipped] = "tumble"
    out[flipped & flight] = "tumble with flight"
    return out


def zero_terms(n: int) -> dict[str, np.ndarray]:
    """Reward terms of ``n`` robots that earned nothing (a reset, a failed step)."""
    return {key: np.zeros(n) for key in ("forward", "field", "crawl", "success")}


def single_info(values: Mapping) -> dict:
    """One robot's ``info`` from :func:`crawl_info` values of ``n = 1``: numbers as Python scalars, arrays as
    arrays."""
    out = {}
    for key, v in values.items():
        v = np.asarray(v)
        if v.dtype == object:  # text (locomotion): as it is
            out[key] = v[0]
        else:
            out[key] = v[0].item() if v.ndim == 1 else v[0].copy()
    return out


def vector_info(values: Mapping, mask=None) -> dict:
    """Gymnasium's vector ``info`` of arrays over the robots: each key its array, ``"_" + key`` its mask (``mask``,
    default all)."""
    out = {}
    for key, v in values.items():
        out[key] = v
        out["_" + key] = np.ones(len(v), dtype=bool) if mask is None else np.array(mask, dtype=bool)
    return out


def stack_infos(infos: Mapping[int, Mapping], n: int) -> dict:
    """Gymnasium's vector ``info`` of ``n`` robots from the per-robot dicts ``infos`` (robot index -> its info):
    each key an array (the dtype of its first value's type, as ``gymnasium.vector.VectorEnv._add_info``: numbers,
    arrays, else objects with None) and ``"_" + key`` the mask of the robots that have it."""
    out: dict = {}
    for i, info in infos.items():
        for key, value in info.items():
            array = out.get(key)
            if array is None:
                if type(value) in (int, float, bool) or isinstance(value, np.number):
                    array = np.zeros(n, dtype=type(value))
                elif isinstance(value, np.ndarray):
                    array = np.zeros((n, *value.shape), dtype=value.dtype)
                else:
                    array = np.full(n, None, dtype=object)
                out[key] = array
                out["_" + key] = np.zeros(n, dtype=bool)
            array[i] = value
            out["_" + key][i] = True
    return out


__all__ = ["book_substeps", "AIRBORNE_TOLERANCE", "CRAWL_MODES", "LOCOMOTION_MODES", "ROLL_ANGLE", "locomotion_modes",
           "NONFINITE_OBSERVATION", "OBS_MAX_ANGULAR_VELOCITY", "OBS_MAX_VELOCITY",
           "CrawlRecords", "CrawlTask", "broken_limits", "clock_tail", "crawl_info", "crawl_limits", "crawl_reward",
           "first_violation", "limit_summary", "observation", "observation_high", "period_substeps", "single_info",
           "stack_infos", "vector_info", "violation_texts", "wave_rows", "zero_terms"]
