"""Videos (MP4, GIF) of gaits, policies and scenes, written with imageio."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..gl import select_gl_backend

VIDEO_SUFFIXES = (".mp4", ".gif")


def _check_path(path) -> Path:
    path = Path(path)
    if path.suffix.lower() not in VIDEO_SUFFIXES:
        raise ValueError(f"video path must end in one of {list(VIDEO_SUFFIXES)}, got {str(path)!r}.")
    return path


def write_video(frames, path, *, fps: float = 25.0) -> Path:
    """Write frames (each ``(H, W, 3)`` uint8) to ``path`` (``.mp4`` via ffmpeg, or ``.gif``).

    Returns the path.
    """
    import imageio.v2 as imageio

    path = _check_path(path)
    if not fps > 0:
        raise ValueError(f"fps must be > 0 (frames per second), got {fps!r}.")
    frames = [np.asarray(f, dtype=np.uint8) for f in frames]
    if not frames:
        raise ValueError("frames must contain at least one frame, got none.")
    path.parent.mkdir(parents=True, exist_ok=True)
    if path.suffix.lower() == ".gif":
        imageio.mimsave(path, frames, duration=1000.0 / fps, loop=0)
    else:
        imageio.mimwrite(path, frames, fps=fps, macro_block_size=1, quality=7)
    return path


def render_gait(
    preset, seconds: float, path=None, *, fps: float = 25.0, width: int = 480, height: int = 270,
    timestep: float = 1e-4, segments: int = 20, scene: str = "floor",
) -> tuple[list[np.ndarray], dict]:
    """Frames of an open-loop gait (:class:`~magsoft_env.gaits.GaitPreset`), optionally written.

    Parameters
    ----------
    preset : GaitPreset
    seconds : float
        Simulated time (s).
    path : str or Path, optional
        ``.mp4`` or ``.gif`` to write.
    fps : float
        Frames per simulated second (the video plays in real time).
    timestep : float
        Simulation step (s).
    scene : str
        ``floor``, ``channel`` or ``obstacle``.

    Returns
    -------
    frames : list of ndarray
        ``round(seconds * fps) + 1`` frames (the first shows t = 0), each ``(height, width, 3)``.
    summary : dict
        ``displacement_mm``, ``speed_mm_s`` (centre of mass), ``frames``, ``fps``, ``path``,
        ``message`` (``"ok"`` or the instability that stopped the run early).
    """
    if path is not None:
        path = _check_path(path)
    select_gl_backend()
    from ..sim import SimulationError, Simulator, as_waveform
    from ..sim.gait import gait_rod_options
    from .frames import RodRenderer

    if not seconds > 0:
        raise ValueError(f"seconds must be > 0 (s), got {seconds!r}.")
    sim = Simulator(preset.beam, gait_rod_options(preset, scene=scene, segments=segments, timestep=timestep,
                                                 render=True))
    sim.set_waveform(as_waveform(preset.wave))
    renderer = RodRenderer(sim, width=width, height=height)
    n_frames = int(round(seconds * fps))
    per_frame = max(1, int(round(1.0 / (fps * sim.timestep))))
    x0 = sim.center_of_mass()[0]
    frames, message = [renderer.render(label=preset.name)], "ok"
    try:
        for _ in range(n_frames):
            sim.step(per_frame)
            frames.append(renderer.render(label=preset.name))
    except SimulationError as err:
        message = str(err)
    finally:
        renderer.close()
    dx = float(sim.center_of_mass()[0] - x0)
    summary = {"displacement_mm": dx * 1e3, "speed_mm_s": dx / max(sim.time, 1e-12) * 1e3, "frames": len(frames),
               "fps": fps, "path": None if path is None else str(path), "message": message}
    if path is not None:
        write_video(frames, path, fps=fps)
    return frames, summary


def render_policy(env_id: str, policy=None, seconds: float = 4.0, path=None, *, seed: int = 0,
                  env_kwargs: dict | None = None) -> tuple[list[np.ndarray], dict]:
    """Frames of an environment driven by ``policy`` (``obs -> action``; None: the robot's
    open-loop gait for crawl envs, the target's field for the shape env), one frame per step.

    Returns frames and a summary (``steps``, ``return``, ``x_displacement_mm``, ``path``).
    """
    if path is not None:
        path = _check_path(path)
    select_gl_backend()
    import gymnasium as gym  # the ids are registered by importing magsoft_env, which ran first

    env = gym.make(env_id, render_mode="rgb_array", **(env_kwargs or {}))
    base = env.unwrapped
    obs, info = env.reset(seed=seed)
    x0 = info.get("x_position", 0.0)
    frames, total, steps = [env.render()], 0.0, 0
    t_end = float(seconds)
    while base.sim.time < t_end - 1e-9:
        if policy is not None:
            action = policy(obs)
        elif hasattr(base, "robot"):  # crawlers: the robot's paper gait
            action = base.open_loop_action(base.sim.time)
        elif hasattr(base, "open_loop_action"):  # shape env: hold the target's field
            action = base.open_loop_action()
        else:
            action = np.zeros(base.action_space.shape, dtype=np.float32)
        obs, r, term, trunc, info = env.step(action)
        total += float(r)
        steps += 1
        frames.append(env.render())
        if term or trunc:
            break
    fps = base.metadata.get("render_fps", 25)
    env.close()
    summary = {"steps": steps, "return": total, "x_displacement_mm": (info.get("x_position", 0.0) - x0) * 1e3,
               "frames": len(frames), "fps": fps, "path": None if path is None else str(path)}
    if path is not None:
        write_video(frames, path, fps=fps)
    return frames, summary
