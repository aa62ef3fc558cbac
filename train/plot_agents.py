"""Learning curves of the shipped agents of one env id, with the spread across their seeds.

    python train/plot_agents.py MagSoftCrawl-v1 --out docs/img/bench_crawl_ppo.png [--agents ppo_seed0,ppo_seed1]

Left: rl-zoo3's deterministic evaluation return (``evaluations.npz``, mean over its episodes) of each seed against
the training steps, their mean and min-max band. Right: the training episodes' returns (``monitor.csv``, the
stochastic policy), each seed's mean in whole bins of 5,000 steps, the mean across seeds and the min-max band.
"""

from __future__ import annotations

import argparse
import sys

import numpy as np


def _monitor(path):
    import csv

    rows = list(csv.reader(path.read_text().splitlines()[1:]))  # the first line is a JSON comment
    head, data = rows[0], rows[1:]
    r, length = head.index("r"), head.index("l")
    ret = np.array([float(x[r]) for x in data])
    steps = np.cumsum([int(x[length]) for x in data])
    return steps, ret


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("env_id")
    ap.add_argument("--out", required=True)
    ap.add_argument("--agents", help="comma-separated agent names (default: every shipped agent of the id)")
    ap.add_argument("--bin", type=int, default=5000, help="training-episode bin (steps)")
    args = ap.parse_args(argv)

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from magsoft_env.rl.agents import agent_dir, agent_info, shipped_agents

    names = args.agents.split(",") if args.agents else shipped_agents().get(args.env_id, [])
    if not names:
        print(f"plot_agents.py: error: no agents for {args.env_id}", file=sys.stderr)
        return 2
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(7.2, 2.8), dpi=90)
    evals, bins = [], []
    for name in names:
        d = agent_dir(args.env_id, name)
        seed = agent_info(args.env_id, name).get("seed")
        ev = np.load(d / "evaluations.npz")
        t, r = ev["timesteps"], ev["results"].mean(axis=1)
        evals.append((t, r))
        ax1.plot(t / 1e3, r, lw=0.8, alpha=0.6, label=f"seed {seed}")
        steps, ret = _monitor(d / "monitor.csv")
        edges = np.arange(0, steps[-1] + args.bin, args.bin)
        idx = np.digitize(steps, edges)
        full = [i for i in sorted(set(idx)) if edges[i - 1] + args.bin <= steps[-1]]  # whole bins only
        centres = [(edges[i - 1] + args.bin / 2) for i in full]
        means = [ret[idx == i].mean() for i in full]
        bins.append((np.array(centres), np.array(means)))
        ax2.plot(np.array(centres) / 1e3, means, lw=0.8, alpha=0.6)
    n = min(len(t) for t, _ in evals)
    t = evals[0][0][:n]
    stack = np.array([r[:n] for _, r in evals])
    ax1.fill_between(t / 1e3, stack.min(0), stack.max(0), color="C7", alpha=0.25, lw=0)
    ax1.plot(t / 1e3, stack.mean(0), color="k", lw=1.6, label=f"mean of {len(names)}")
    m = min(len(c) for c, _ in bins)
    c = bins[0][0][:m]
    stack = np.array([b[:m] for _, b in bins])
    ax2.fill_between(c / 1e3, stack.min(0), stack.max(0), color="C7", alpha=0.25, lw=0)
    ax2.plot(c / 1e3, stack.mean(0), color="k", lw=1.6)
    ax1.set(xlabel="training steps (thousands)", ylabel="evaluation return", title="deterministic evaluations")
    ax2.set(xlabel="training steps (thousands)", ylabel="episode return", title="training episodes")
    ax1.legend(fontsize=7, frameon=False)
    for ax in (ax1, ax2):
        ax.grid(alpha=0.3)
        ax.tick_params(labelsize=8)
    fig.suptitle(f"PPO on {args.env_id}: {len(names)} seeds, min-max band", fontsize=9)
    fig.tight_layout()
    fig.savefig(args.out)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
