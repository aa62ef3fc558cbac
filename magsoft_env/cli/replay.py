"""``magsoft replay``: play a shipped trained agent (``assets/agents``) on fixed seeds and print what it does, or
render it (docs/bench.md)."""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from .output import dumps_json, out_file


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "replay",
        help="play a shipped trained agent (--env ID --agent NAME): speed, return, airborne fraction, locomotion",
        description=(
            "Play a trained agent shipped with the package (magsoft_env.rl.load_agent; `magsoft replay --list` "
            "names them) deterministically for --episodes episodes, episode k on seed --seed + k, in its env id with "
            "the env arguments it was trained with, and print one row per episode: the centre of mass's speed along "
            "+x (mm/s), the return, the steps, the airborne fraction (the fraction of substeps with the whole robot "
            "off the floor), the highest clearance (mm), the locomotion mode (info['locomotion']), and whether a "
            "crawl limit ended it; then the means. --video out.mp4 renders the first episode as `magsoft video "
            "--env` does."),
    )
    p.add_argument("--env", help="environment id of the agent, e.g. MagSoftCrawl-v1")
    p.add_argument("--agent", help="the agent's name, e.g. ppo_seed0")
    p.add_argument("--list", action="store_true", help="list the shipped agents and exit")
    p.add_argument("--episodes", type=int, default=3, help="episodes (default 3)")
    p.add_argument("--seed", type=int, default=1000, help="seed of the first episode (default 1000, the bench's)")
    p.add_argument("--steps", type=int, default=None, help="at most this many control steps per episode (default: "
                                                           "the env's episode)")
    p.add_argument("--video", type=Path, default=None, help="render the first episode to this .mp4 or .gif")
    p.add_argument("--json", action="store_true", help="print the numbers as JSON")
    p.set_defaults(run=run)
    return p


def _episode(env, policy, seed: int, steps: int | None) -> dict:
    obs, info = env.reset(seed=seed)
    x0, t0, total, k = info.get("x_position", math.nan), info["time"], 0.0, 0
    term = trunc = False
    while steps is None or k < steps:
        obs, r, term, trunc, info = env.step(policy(obs))
        total += float(r)
        k += 1
        if term or trunc:
            break
    dt = info["time"] - t0
    return {"seed": seed, "steps": k, "seconds": dt,
            "speed_mm_s": 1e3 * (info.get("x_position", math.nan) - x0) / dt if dt > 0 else 0.0,
            "return": total, "airborne_fraction": float(info.get("airborne_fraction", math.nan)),
            "highest_clearance_mm": 1e3 * float(info.get("highest_clearance", math.nan)),
            "locomotion": str(info.get("locomotion", "")), "is_success": bool(info.get("is_success", False)),
            "ended_by": info.get("crawl_violation") or info.get("truncation_reason")
            or ("success" if info.get("is_success") else ("time limit" if trunc else ""))}


def run(args) -> int:
    import warnings

    with warnings.catch_warnings():  # MagSoftCrawl-v1 is kept on purpose beside v2: no "out of date" notice
        warnings.filterwarnings("ignore", message=".*is out of date", category=DeprecationWarning)
        return _replay(args)


def _replay(args) -> int:
    from magsoft_env.rl.agents import agent_dir, agent_info, shipped_agents

    if args.list:
        agents = shipped_agents()
        for env_id, names in agents.items():
            for name in names:
                info = agent_info(env_id, name)
                print(f"{env_id} {name}: {info.get('algo')} seed {info.get('seed')}, {info.get('model')} model at "
                      f"{info.get('model_timesteps')} steps, env kwargs {info.get('env_kwargs') or {}}")
        if not agents:
            print("no agents are shipped")
        return 0
    if args.env is None or args.agent is None:
        raise ValueError("give --env ID and --agent NAME (--list names the shipped agents).")
    if args.episodes < 1:
        raise ValueError(f"--episodes must be >= 1, got {args.episodes}.")
    if args.steps is not None and args.steps < 1:
        raise ValueError(f"--steps must be >= 1, got {args.steps}.")
    agent_dir(args.env, args.agent)  # unknown env id or name: ValueError listing the shipped agents
    if args.video is not None:
        from magsoft_env.render.video import VIDEO_SUFFIXES

        args.video = out_file(args.video, suffixes=tuple(VIDEO_SUFFIXES))

    from magsoft_env.rl.agents import load_agent, quiet_make

    info = agent_info(args.env, args.agent)
    policy = load_agent(args.env, args.agent)
    env_kwargs = dict(policy.env_kwargs or {})
    env = quiet_make(args.env, **env_kwargs)
    rows = [_episode(env, policy, args.seed + k, args.steps) for k in range(args.episodes)]
    env.close()
    mean = {key: sum(r[key] for r in rows) / len(rows)
            for key in ("speed_mm_s", "return", "steps", "airborne_fraction")}
    out = {"env_id": args.env, "agent": args.agent, "algo": info.get("algo"), "seed": info.get("seed"),
           "model_timesteps": info.get("model_timesteps"), "env_kwargs": env_kwargs, "episodes": rows, "mean": mean}
    if args.video is not None:
        from magsoft_env.render.video import render_policy

        ctrl_dt = getattr(env.unwrapped, "ctrl_dt", 0.02)
        seconds = rows[0]["steps"] * ctrl_dt
        _, summary = render_policy(args.env, policy, seconds, args.video, seed=args.seed, env_kwargs=env_kwargs,
                                   progress=sys.stderr.isatty())
        out["video"] = {k: summary.get(k) for k in ("path", "frames", "fps", "width", "height")}
    if args.json:
        print(dumps_json(out))
        return 0
    print(f"{args.env} / {args.agent} ({info.get('algo')}, training seed {info.get('seed')}, "
          f"{info.get('model_timesteps')} steps; env kwargs {env_kwargs or 'none'})")
    print("| seed | steps | speed (mm/s) | return | airborne fraction | highest clearance (mm) | locomotion | "
          "ended by |")
    print("|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['seed']} | {r['steps']} | {r['speed_mm_s']:+.3f} | {r['return']:+.1f} | "
              f"{r['airborne_fraction']:.4f} | {r['highest_clearance_mm']:.4f} | {r['locomotion']} | "
              f"{r['ended_by'] or '-'} |")
    print(f"| mean | {mean['steps']:.0f} | {mean['speed_mm_s']:+.3f} | {mean['return']:+.1f} | "
          f"{mean['airborne_fraction']:.4f} | | | |")
    if args.video is not None:
        print(f"wrote {out['video']['path']}")
    return 0
