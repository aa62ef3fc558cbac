"""MagSoftCoilsWaveform-v0 and MagSoftMagnetWaveform-v0: the coil and magnet steering tasks with a rotating field as
the action (its vertical plane, magnitude and frequency each 0.1 s), made at the strip by the actuator."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np

from ..validate import positive
from . import as_action
from .coils import MagSoftCoilsEnv, SourceSteerEnv
from .magnet import MagSoftMagnetEnv
from .steer import DEFAULT_FREQUENCY_RANGE, _range

#: Default control interval of the waveform ids (s): as ``MagSoftSteerWaveform-v0``'s.
DEFAULT_WAVE_DT = 0.1
#: Default interval at which the actuator is commanded within a step (s): the source envs' own control step.
DEFAULT_ACTUATOR_DT = 0.02


class SourceWaveformEnv(gym.Env):
    """
    ## Description

    The steering task of a field-source env (:class:`~magsoft_env.envs.coils.MagSoftCoilsEnv`,
    :class:`~magsoft_env.envs.magnet.MagSoftMagnetEnv`: the paper's Fig. 5c strip on a floor, brought to a goal) with
    ``MagSoftSteerWaveform-v0``'s action: each step chooses a field of magnitude ``A`` turning at ``f`` in the
    vertical plane through the horizontal direction ``u``, ``B = A (-cos(phi) u + sin(phi) z)``, which tumbles the
    strip along ``+u``; the phase runs on from step to step. The actuator makes that field at the strip: every
    ``actuator_dt`` (20 ms) within the step, the source env is stepped with the action that makes the wanted field
    (at the middle of that interval) at the strip's centre of mass (``field_action``: the least-norm currents of the
    coils, or the magnet above the strip with its axis and height set for the field). So the physics is the source
    env's in full (the coils' drive, the magnet's bounded speed and turn rate, the field's gradient and its
    variation over the strip); the action is the waveform a coil controller or a magnet-holding arm would be told.

    This is the level at which learning worked for the uniform field: SAC learned ``MagSoftSteerWaveform-v0``
    (18-19 of 20 goals) but not the per-step field of ``MagSoftSteer-v0`` (docs/training.md, "Steering").

    ## Action Space

    ``Box(-1, 1, (4,), float32)``, as ``MagSoftSteerWaveform-v0``'s:

    | Num | Action | Min | Max | Type (Unit) |
    |-----|--------|-----|-----|-------------|
    | 0, 1 | direction u (x, y), normalized; both 0: no field | -1 | 1 | dimensionless |
    | 2 | A, mapped linearly onto [0, field_scale] | -1 | 1 | field (T) |
    | 3 | f, mapped linearly onto ``frequency_range`` | -1 | 1 | frequency (Hz) |

    ## Observation Space

    The source env's (its ``observation_space``), with the clock slot (sin, cos) holding the waveform's phase
    ``phi`` instead.

    ## Rewards

    The sum of the source env's rewards over the step's actuator steps (progress, the actuator's cost, crawl
    penalty, success); ``info``'s terms (``reward_progress``, ...) are their sums over the step too.

    ## Starting State

    The source env's.

    ## Episode End

    The source env's (goal reached, lost, crawl limits, the magnet touched, an unstable or unphysical simulation),
    checked after every actuator step: the step ends with the first. Truncation: 50 steps = 5 s (the registered
    ids).

    ``info`` is the source env's at the step's end, with ``wave_direction`` (u, (2,)), ``wave_magnitude`` (T),
    ``wave_frequency`` (Hz) and ``actuator_steps`` (how many ran).

    ## Arguments

    | Parameter | Default | Description |
    |-----------|---------|-------------|
    | ``ctrl_dt`` | 0.1 | control interval (s), a whole multiple of ``actuator_dt`` |
    | ``actuator_dt`` | 0.02 | how often the actuator is commanded within a step (s): the source env's ``ctrl_dt`` |
    | ``frequency_range`` | (0.25, 2) | the waveform's frequencies (Hz) |
    | others | | the source env's (``robot``, ``coils``, ``sim_dt``, ``field_scale``, ``render_mode``, ...) |

    ## Version History

    - v0: initial version.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 10}
    #: the source env class (a :class:`~magsoft_env.envs.coils.SourceSteerEnv` with ``field_action``)
    source_class: type[SourceSteerEnv] = SourceSteerEnv

    def __init__(self, robot="paper-5c", *, ctrl_dt: float = DEFAULT_WAVE_DT,
                 actuator_dt: float = DEFAULT_ACTUATOR_DT,
                 frequency_range: tuple[float, float] = DEFAULT_FREQUENCY_RANGE, render_mode: str | None = None,
                 **kwargs):
        step = positive("ctrl_dt", ctrl_dt, unit="s")
        sub = positive("actuator_dt", actuator_dt, unit="s")
        ratio = step / sub
        if round(ratio) < 1 or abs(ratio - round(ratio)) > 1e-9 * max(1.0, ratio):
            raise ValueError(f"ctrl_dt must be a whole multiple (>= 1) of actuator_dt = {sub:g} s, got ctrl_dt = "
                             f"{ctrl_dt!r} s ({ratio:g} x).")
        freq = _range("frequency_range", frequency_range, unit="Hz")
        self.source_env = self.source_class(robot, ctrl_dt=sub, render_mode=render_mode, **kwargs)
        env = self.source_env
        env.frequency_range = freq  # the range its wave_of_action / action_of_wave read
        self.ctrl_dt, self.actuator_dt, self.frequency_range = step, sub, freq
        self.repeat = int(round(ratio))
        self.render_mode = render_mode
        self.action_space = gym.spaces.Box(-1.0, 1.0, (4,), np.float32)
        self.observation_space = env.observation_space
        self.metadata = {**self.metadata, "render_fps": max(1, int(round(1.0 / step)))}
        self._clock = env.steer_obs_size - 2  # the clock slot (sin, cos) of the source env's observation
        self._phase = 0.0
        self._last_obs = np.zeros(self.observation_space.shape, np.float32)

    @property
    def sim(self):
        """The source env's :class:`~magsoft_env.sim.Simulator`."""
        return self.source_env.sim

    @property
    def robot(self) -> str:
        """The robot's name."""
        return self.source_env.robot

    # ------------------------------------------------------------------ waves
    def wave_of_action(self, action) -> tuple[np.ndarray, float, float]:
        """``(u, A, f)`` of an action: the unit direction (zeros: no field), magnitude (T) and frequency (Hz)."""
        return self.source_env.wave_of_action(action)

    def action_of_wave(self, direction, magnitude: float, frequency: float) -> np.ndarray:
        """The action for a field of ``magnitude`` (T) turning at ``frequency`` (Hz) that tumbles the strip along
        ``direction`` (x, y)."""
        return self.source_env.action_of_wave(direction, magnitude, frequency)

    @staticmethod
    def wave_field(u, magnitude: float, phase: float) -> np.ndarray:
        """The wave's field (T, (3,)) at ``phase``: ``A (-cos(phi) u + sin(phi) z)``."""
        return magnitude * np.array([-math.cos(phase) * u[0], -math.cos(phase) * u[1], math.sin(phase)])

    def baseline_action(self, obs=None) -> np.ndarray:
        """The hand controller: the full magnitude (``field_scale``) at the source env's ``clock_frequency`` (1 Hz),
        toward the goal (``MagSoftSteerWaveform-v0``'s)."""
        o = self._last_obs if obs is None else np.asarray(obs)
        env = self.source_env
        return self.action_of_wave(o[:2], env.field_scale, env.clock_frequency)

    # ------------------------------------------------------------------ gymnasium API
    def _observe(self, obs) -> np.ndarray:
        o = np.array(obs, dtype=np.float32, copy=True)
        o[self._clock:self._clock + 2] = (math.sin(self._phase), math.cos(self._phase))
        return o

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        obs, info = self.source_env.reset(seed=seed, options=options)
        self._phase = 0.0
        self._last_obs = self._observe(obs)
        return self._last_obs, info

    def step(self, action):
        action = as_action(self.action_space, action)
        u, amp, f = self.wave_of_action(action)
        env = self.source_env
        turn = 2.0 * math.pi * f * self.actuator_dt
        total, ran, terms = 0.0, 0, {}
        obs, terminated, truncated, info = self._last_obs, False, False, {}
        while ran < self.repeat:
            ran += 1
            field = self.wave_field(u, amp, self._phase + 0.5 * turn)  # the interval's middle
            obs, reward, terminated, truncated, info = env.step(env.field_action(field))
            self._phase = math.remainder(self._phase + turn, 2.0 * math.pi)
            total += float(reward)
            for key, value in info.items():
                if key.startswith("reward_"):
                    terms[key] = terms.get(key, 0.0) + float(value)
            if terminated or truncated:
                break
        info = dict(info, **terms, reward=total, wave_direction=u.copy(), wave_magnitude=float(amp),
                    wave_frequency=float(f), actuator_steps=ran)
        self._last_obs = self._observe(obs)
        return self._last_obs, total, bool(terminated), bool(truncated), info

    def render(self):
        return self.source_env.render()

    def close(self):
        self.source_env.close()


class MagSoftCoilsWaveformEnv(SourceWaveformEnv):
    __doc__ = SourceWaveformEnv.__doc__.replace(
        "## Description", "## Description\n\n    ``MagSoftCoilsWaveform-v0``: the coils of "
        ":class:`~magsoft_env.envs.coils.MagSoftCoilsEnv` (Navion by default) make the wave.\n", 1)
    source_class = MagSoftCoilsEnv


class MagSoftMagnetWaveformEnv(SourceWaveformEnv):
    __doc__ = SourceWaveformEnv.__doc__.replace(
        "## Description", "## Description\n\n    ``MagSoftMagnetWaveform-v0``: the permanent magnet of "
        ":class:`~magsoft_env.envs.magnet.MagSoftMagnetEnv` (``tilt=True``) makes the wave.\n", 1)
    source_class = MagSoftMagnetEnv

    def __init__(self, robot="paper-5c", **kwargs):
        if kwargs.get("tilt", True) is False:
            raise ValueError("MagSoftMagnetWaveform-v0 needs tilt=True: with the magnet's position alone the field's "
                             "direction at the strip cannot be chosen.")
        super().__init__(robot, **kwargs)


__all__ = ["MagSoftCoilsWaveformEnv", "MagSoftMagnetWaveformEnv", "SourceWaveformEnv"]
