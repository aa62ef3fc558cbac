"""Your own robot, from design to trained controller: design, save, check, simulate, train, render.

    python docs/examples/pipeline.py --out pipeline_out            # 14.4 min on 2 shared x86_64 cores, PPO 830 s
    python docs/examples/pipeline.py --out /tmp/p --timesteps 256 --seconds 0.5 --starts 1 --nfev 10   # a smoke run

1. design a magnetization profile that bends a 5 x 1.13 mm strip into the built-in "ball" contour
   (``design_profile``), 2. save the designed beam as a robot file with a drive (``Robot.save``),
3. check the design in MuJoCo (``mujoco_check``), 4. run the robot's open-loop gait on the floor
(``run_gait``), 5. train PPO (Stable-Baselines3 defaults) on ``MagSoftCrawl-v1`` with this robot, and
6. render the trained policy to an MP4 with the side panel. Every step prints what it measured and the wall time
so far; progress (the design's starts, PPO every 10 % of its steps) goes to stderr (``--quiet``: none).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", type=Path, default=Path("pipeline_out"), help="output folder")
    p.add_argument("--timesteps", type=int, default=50_000, help="PPO timesteps (default 50000)")
    p.add_argument("--seconds", type=float, default=4.0, help="simulated seconds of the gait and the video")
    p.add_argument("--starts", type=int, default=4, help="design: local starts")
    p.add_argument("--nfev", type=int, default=60, help="design: evaluations per start")
    p.add_argument("--quiet", action="store_true", help="no progress on stderr (the step lines stay)")
    args = p.parse_args(argv)
    if args.timesteps < 1 or args.seconds <= 0:
        p.error("--timesteps must be >= 1 and --seconds > 0")
    args.out.mkdir(parents=True, exist_ok=True)

    import gymnasium as gym
    import numpy as np
    from stable_baselines3 import PPO

    import magsoft_env as ms
    from magsoft_env.design import builtin_target
    from magsoft_env.render.video import render_policy
    from magsoft_env.rl.callbacks import ProgressLines

    t0 = time.perf_counter()

    def took() -> str:
        return f" [{time.perf_counter() - t0:.0f} s]"

    def starting(what: str) -> None:
        if not args.quiet:
            print(f"{what} ...{took()}", file=sys.stderr, flush=True)

    # 1. design: the beam's length becomes the contour's length
    strip = ms.Beam(length=1.0, width=5e-3, thickness=1.13e-3, volume_fraction=0.2)
    starting(f"1. designing for the 'ball' contour ({args.starts} starts x {args.nfev} evaluations)")
    design = ms.design_profile(builtin_target("ball"), strip, field_bounds=(1e-3, 20e-3), n_starts=args.starts,
                               max_nfev=args.nfev, seed=0, progress=not args.quiet)
    print(f"1. design: RMS error {design.rms_error_percent:.3f} % of L under B = ({design.field.Bx * 1e3:.2f}, "
          f"{design.field.Bz * 1e3:.2f}) mT; {design.message}{took()}", flush=True)

    # 2. the designed beam as a robot with a crawling drive (a vertical sine, as the paper's gaits)
    robot = ms.Robot("ball-crawler", design.beam, description="designed for the 'ball' contour, driven as a crawler",
                     drive=ms.Waveparams(amplitude_x=0.0, amplitude_z=1.5e-3, frequency=2.0))
    path = robot.save(args.out / "robot.yml")
    saved = ms.load_robot(path)  # the spline profile is stored as its knot values: equal to round-off
    s = np.linspace(0.0, robot.beam.length, 1001)
    print(f"2. saved {path}; reloaded beta differs by {np.max(np.abs(saved.beam.beta(s) - robot.beam.beta(s))):.1e} "
          f"rad at most{took()}", flush=True)

    # 3. the design in MuJoCo: the rod under the design field against the analytical shape
    starting("3. checking the design in MuJoCo")
    check = ms.mujoco_check(design, segments=20)
    print(f"3. MuJoCo check: max distance to the analytical shape {check['max_to_analytical'] * 1e3:.3f} mm; "
          f"settled: {check['success']}{took()}", flush=True)

    # 4. the open-loop gait on the floor
    starting(f"4. running the open-loop gait for {args.seconds:g} simulated s")
    gait = ms.run_gait(str(path), seconds=args.seconds)
    print(f"4. open-loop gait: {gait.displacement * 1e3:+.3f} mm in {gait.seconds:.2f} s, "
          f"speed {gait.speed * 1e3:+.3f} mm/s ({gait.direction}); whole periods: {gait.whole_periods}{took()}",
          flush=True)

    # 5. PPO with Stable-Baselines3's defaults on the floor env with this robot
    env = gym.make("MagSoftCrawl-v1", robot=str(path))
    model = PPO("MlpPolicy", env, seed=0, verbose=0, n_steps=min(2048, max(64, args.timesteps)))
    model.learn(total_timesteps=args.timesteps, progress_bar=False,
                callback=None if args.quiet else ProgressLines(args.timesteps, label="5. PPO"))
    model.save(args.out / "ppo_ball_crawler.zip")
    print(f"5. trained PPO for {args.timesteps} steps -> {args.out / 'ppo_ball_crawler.zip'}{took()}", flush=True)

    # 6. the trained policy, rendered with the side panel (x(t), B(t))
    def policy(obs):
        return model.predict(obs, deterministic=True)[0]

    starting(f"6. rendering {args.seconds:g} s of the trained policy")
    _, video = render_policy("MagSoftCrawl-v1", policy, args.seconds, args.out / "ball_crawler.mp4",
                             env_kwargs={"robot": str(path)}, panel=True)
    print(f"6. video {video['path']}: {video['steps']} steps, policy moved the robot "
          f"{video['x_displacement_mm']:+.3f} mm{took()}", flush=True)
    summary = {"design_rms_percent_L": design.rms_error_percent, "mujoco_max_to_analytical_mm":
               check["max_to_analytical"] * 1e3, "gait": gait.to_dict(), "timesteps": args.timesteps,
               "policy_displacement_mm": video["x_displacement_mm"]}
    (args.out / "pipeline.json").write_text(json.dumps(summary, indent=2, default=float) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
