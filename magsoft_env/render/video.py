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


def _check_size(width, height) -> tuple[int, int]:
    for name, v in (("width", width), ("height", height)):
        if int(v) != v or not 16 <= v <= 8192:
            raise ValueError(f"{name} must be an integer in [16, 8192] pixels, got {v!r}.")
    return int(width), int(height)


def render_gait(
    preset, seconds: float, path=None, *, fps: float = 25.0, width: int = 960, height: int = 540,
    timestep: float | None = None, segments: int | None = None, scene: str = "floor", panel: bool = False,
    overlay=None, zoom: bool | None = None, rod: str = "planar", view: str | None = None, progress: bool = False,
    rod_options: dict | None = None, source=None,
) -> tuple[list[np.ndarray], dict]:
    """Frames of an open-loop gait (a :class:`~magsoft_env.cases.robots.Robot` with a drive), optionally written.

    Each frame shows the robot in its rod's view (:func:`~magsoft_env.render.views.make_renderer`): the planar
    chain's side view by default (:class:`~magsoft_env.render.frames.RodRenderer`: the robot on the floor, grid and
    scale bar, the field dial (full scale: the drive's peak |B| rounded up to 1-2-5 mT), the centre-of-mass path
    and the start line, ``Δx`` since the start and (floor scene) a zoom inset of the rod's end over a 0.1 mm
    ruler); the 3D strip's perspective, or any rod in perspective or from above
    (:class:`~magsoft_env.render.strip.StripRenderer`).

    Parameters
    ----------
    preset : Robot
        ``name``, ``beam`` and ``wave`` are used (``gait_preset(...)``).
    seconds : float
        Simulated time (s).
    path : str or Path, optional
        ``.mp4`` or ``.gif`` to write.
    fps : float
        Frames per simulated second (the video plays in real time).
    width, height : int
        Frame size (pixels) of the view; ``panel`` adds its width to the right.
    timestep : float or None
        Simulation step (s); None: the robot's own (as :func:`~magsoft_env.sim.gait.run_gait`).
    segments : int or None
        Rod segments; None: the robot's own.
    scene : str
        ``floor``, ``channel`` or ``obstacle`` (the scenes the rod builds).
    panel : bool
        Add a :class:`~magsoft_env.render.frames.TimePanel` (Δx(t), B(t) over ``[0, seconds]``).
    overlay : callable, optional
        ``overlay(sim) -> (x, z)`` arrays (m), drawn dashed on each frame of the side view (e.g. an analytical
        shape).
    zoom : bool or None
        The side view's zoom inset of the rod's end with its 0.1 mm ruler, so that a 1-2 mm crawl shows; None: on
        for the ``floor`` scene.
    rod : str
        The rod (``RodOptions.rod``): ``"planar"`` (the hinge chain, default) or ``"cable"`` (the 3D strip on the
        floor, :func:`~magsoft_env.sim.gait.gait_rod_options`; a three-axis drive, e.g. with ``amplitude_y``, is
        played as given).
    view : {None, "side", "perspective", "top"}
        The camera (None: the rod's own: side for the planar chain, perspective for the strip).
    progress : bool
        A progress bar (tqdm, on stderr) over the simulated time.
    rod_options : dict or None
        More :class:`~magsoft_env.sim.RodOptions` keywords (:func:`~magsoft_env.sim.gait.gait_rod_options`).
    source : field source or None
        A field source besides the drive (as :func:`~magsoft_env.sim.gait.run_gait`'s ``source``: a magnet, a coil
        system at its currents, a :class:`~magsoft_env.fields.MovingSource`). The frames then draw its magnets,
        dipoles and loop centres that lie in the view (spheres) and the field at the robot's centre of mass (an
        arrow labelled in mT; docs/rendering.md, "Field sources").

    Returns
    -------
    frames : list of ndarray
        ``round(seconds * fps) + 1`` frames (the first shows t = 0), each ``(height, width, 3)``
        (wider with ``panel``).
    summary : dict
        ``displacement_mm``, ``speed_mm_s`` (centre of mass), ``displacement_y_mm`` (along +y), ``heading_deg``
        (tip minus base in the floor plane, from +x toward +y, at the end), ``frames``, ``fps``, ``width``,
        ``height`` (of the frames written), ``path``, ``message`` (``"ok"`` or the instability that stopped the run
        early), ``rod``, ``view``.
    """
    if path is not None:
        path = _check_path(path)
    if not seconds > 0:
        raise ValueError(f"seconds must be > 0 (s), got {seconds!r}.")
    if not (fps > 0 and np.isfinite(fps)):
        raise ValueError(f"fps must be > 0 (frames per second), got {fps!r}.")
    width, height = _check_size(width, height)
    if overlay is not None and not callable(overlay):
        raise ValueError(f"overlay must be a function sim -> (x, z) or None, got {type(overlay).__name__}.")
    select_gl_backend()
    from ..sim import SimulationError, Simulator, as_waveform
    from ..sim.gait import gait_rod_options
    from .frames import dial_scale
    from .views import make_renderer

    if source is None:
        from ..sim.sources import robot_source

        source = robot_source(preset)  # the robot file's field_source block, if it has one
    sim = Simulator(preset.beam, gait_rod_options(preset, scene=scene, segments=segments, timestep=timestep,
                                                 render=True, rod=rod, **(rod_options or {})), source=source)
    wave = as_waveform(preset.wave)
    sim.set_waveform(wave)
    peak = float(np.max(np.linalg.norm(wave.sample(np.linspace(0.0, seconds, 1001)), axis=1)))
    renderer = make_renderer(sim, view=view, width=width, height=height, field_scale=dial_scale(peak),
                             panel=panel, panel_seconds=seconds, zoom=zoom)
    view = getattr(renderer, "view", None) or "side"
    if overlay is not None and view != "side":
        renderer.close()
        raise ValueError("overlay draws an (x, z) curve in the side view; give view='side' (a rod in the x-z plane).")
    n_frames = int(round(seconds * fps))
    per_frame = max(1, int(round(1.0 / (fps * sim.timestep))))
    com0 = sim.pose().com

    def frame():
        return renderer.render(label=preset.name, overlay=None if overlay is None else overlay(sim))

    frames, message = [frame()], "ok"
    bar = _progress(progress, n_frames, f"{preset.name} ({rod}, {view})")
    try:
        for _ in range(n_frames):
            sim.step(per_frame)
            frames.append(frame())
            if bar is not None:
                bar.update(1)
    except SimulationError as err:
        message = str(err)
    finally:
        renderer.close()
        if bar is not None:
            bar.close()
    pose = sim.pose()
    dx = float(pose.com[0] - com0[0])
    summary = {"displacement_mm": dx * 1e3, "speed_mm_s": dx / max(sim.time, 1e-12) * 1e3,
               "displacement_y_mm": float(pose.com[1] - com0[1]) * 1e3,
               "heading_deg": float(np.degrees(pose.heading)), "frames": len(frames),
               "fps": fps, "width": int(frames[0].shape[1]), "height": int(frames[0].shape[0]),
               "path": None if path is None else str(path), "message": message, "rod": rod, "view": view}
    if path is not None:
        write_video(frames, path, fps=fps)
    return frames, summary


def _progress(on: bool, total: int, desc: str):
    """A tqdm bar of ``total`` frames on stderr, or None."""
    if not on:
        return None
    from tqdm.auto import tqdm

    return tqdm(total=total, desc=desc, unit="frame", mininterval=0.5, leave=False)


def render_policy(env_id: str, policy=None, seconds: float = 4.0, path=None, *, seed: int = 0,
                  env_kwargs: dict | None = None, width: int = 960, height: int = 540,
                  panel: bool = False, progress: bool = False) -> tuple[list[np.ndarray], dict]:
    """Frames of an environment driven by ``policy`` (``obs -> action``; None: the robot's
    open-loop gait for crawl envs, the target's field for the shape env, the hand-designed controller for the
    steering env), one frame per step.

    The environment is made with ``render_mode="rgb_array"``, ``env_kwargs`` and the frame size
    ``width`` x ``height`` (these two win over ``env_kwargs``). ``panel`` adds a
    :class:`~magsoft_env.render.frames.TimePanel` to the right: the centre of mass's Δx (floor
    envs; (Δx, Δy) for a 3D rod) or the tip's distance to the target (shape env) and the field, over
    ``[0, seconds]``. ``progress``: a progress bar (tqdm, on stderr) over the simulated time.

    Returns frames and a summary (``steps``, ``return``, ``x_displacement_mm``, ``frames``, ``fps``,
    ``width``, ``height``, ``path``).
    """
    if path is not None:
        path = _check_path(path)
    if not seconds > 0:
        raise ValueError(f"seconds must be > 0 (s), got {seconds!r}.")
    width, height = _check_size(width, height)
    select_gl_backend()
    import gymnasium as gym  # the ids are registered by importing magsoft_env, which ran first

    env = gym.make(env_id, render_mode="rgb_array", **{**(env_kwargs or {}), "width": width, "height": height})
    base = env.unwrapped
    obs, info = env.reset(seed=seed)
    x0 = info.get("x_position", 0.0)
    t_end = float(seconds)
    side = None
    axes = list(base.sim.backend.field_axes)  # the field components the rod takes, and as many panel lines
    n = len(axes)
    if panel:
        from .frames import TimePanel

        floor = bool(base.sim.options.has_contact)
        side = TimePanel(height=height, seconds=t_end, components=n,
                         x_label=None if floor else "tip to target (mm)")
        com0 = base.sim.pose().com

    def frame(info):
        img = env.render()
        if side is None:
            return img
        sim = base.sim
        # the centre of mass's (Δx) or (Δx, Δy) on the floor; the shape env: the tip's distance to the target
        x = sim.pose().com[:n - 1] - com0[:n - 1] if floor else info.get("position_error", 0.0)
        return np.concatenate([img, side.update(sim.time, x, sim.field_vector[axes])], axis=1)

    frames, total, steps = [frame(info)], 0.0, 0
    bar = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=round(t_end, 6), desc=env_id, unit="s", mininterval=0.5, leave=False,
                   bar_format="{desc}: {percentage:3.0f}% of " + f"{t_end:g} s" + " simulated [{elapsed}<{remaining}]")
    while base.sim.time < t_end - 1e-9:
        if policy is not None:
            action = policy(obs)
        elif hasattr(base, "baseline_action"):  # steering: the hand-designed controller (turn to the goal, go)
            action = base.baseline_action(obs)
        elif hasattr(base, "robot"):  # crawlers: the robot's paper gait
            action = base.open_loop_action(base.sim.time)
        elif hasattr(base, "open_loop_action"):  # shape env: hold the target's field
            action = base.open_loop_action()
        else:
            action = np.zeros(base.action_space.shape, dtype=np.float32)
        t_before = base.sim.time
        obs, r, term, trunc, info = env.step(action)
        total += float(r)
        steps += 1
        frames.append(frame(info))
        if bar is not None:
            bar.update(round(min(base.sim.time, t_end) - min(t_before, t_end), 6))
        if term or trunc:
            break
    if bar is not None:
        bar.close()
    fps = base.metadata.get("render_fps", 25)
    env.close()
    if side is not None:
        side.close()
    summary = {"steps": steps, "return": total, "x_displacement_mm": (info.get("x_position", 0.0) - x0) * 1e3,
               "frames": len(frames), "fps": fps, "width": int(frames[0].shape[1]),
               "height": int(frames[0].shape[0]), "path": None if path is None else str(path),
               "success": bool(info.get("is_success", False))}
    if path is not None:
        write_video(frames, path, fps=fps)
    return frames, summary
