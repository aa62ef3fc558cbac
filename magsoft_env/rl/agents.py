"""The trained agents shipped with the package (``assets/agents/``): list them, read what they were trained with,
load one as a deterministic :class:`~magsoft_env.rl.evaluation.Policy`.

Layout: ``assets/agents/<env-id>/<algo>_seed<k>/`` is an rl-zoo3 experiment folder (what rl-zoo3 writes as
``<log folder>/<algo>/<env-id>_<n>/``), cut to what playing needs:

- ``<env-id>.zip``: the SB3 model (the final one of the run, unless ``agent.yml`` says ``model: best``);
- ``<env-id>/config.yml``, ``<env-id>/args.yml``: the hyperparameters and command line rl-zoo3 recorded;
- ``<env-id>/vecnormalize.pkl``: the observation normalization statistics (the PPO block normalizes);
- ``evaluations.npz``: rl-zoo3's evaluation returns during training (the learning curve);
- ``agent.yml``: what the benchmark and ``magsoft replay`` read: env id and version, env arguments, algorithm,
  seed, resolved hyperparameters, training steps, wall time, the machine, and the agent's evaluation.

``rl_zoo3.enjoy`` plays one after copying the folder to ``<f>/<algo>/<env-id>_1`` (``-f <f> --exp-id 1``).
"""

from __future__ import annotations

from pathlib import Path

#: The agents' folder under the package's assets.
AGENTS_FOLDER = "agents"
#: The metadata file of each agent.
AGENT_FILE = "agent.yml"


def agents_root() -> Path:
    """``assets/agents`` (``magsoft_env/_assets/agents`` in a wheel)."""
    from ..assets import assets_dir

    return assets_dir() / AGENTS_FOLDER


def shipped_agents() -> dict[str, list[str]]:
    """The shipped agents: env id -> agent names (sorted), from the folders that hold an ``agent.yml``."""
    root = agents_root()
    out: dict[str, list[str]] = {}
    if not root.is_dir():
        return out
    for env_dir in sorted(p for p in root.iterdir() if p.is_dir()):
        names = sorted(a.name for a in env_dir.iterdir() if (a / AGENT_FILE).is_file())
        if names:
            out[env_dir.name] = names
    return out


def _listing(agents: dict[str, list[str]]) -> str:
    return "; ".join(f"{env}: {', '.join(names)}" for env, names in agents.items()) or "none"


def agent_dir(env_id: str, name: str) -> Path:
    """The folder of the shipped agent ``name`` of ``env_id``; a ValueError that lists the shipped agents (and the
    closest name) for an unknown env id or name."""
    import difflib

    agents = shipped_agents()
    if env_id not in agents:
        hint = difflib.get_close_matches(str(env_id), list(agents), n=1, cutoff=0.5)
        extra = f" Did you mean {hint[0]!r}?" if hint else ""
        raise ValueError(f"no agent is shipped for env {env_id!r}.{extra} Shipped agents: {_listing(agents)}.")
    if name not in agents[env_id]:
        hint = difflib.get_close_matches(str(name), agents[env_id], n=1, cutoff=0.5)
        extra = f" Did you mean {hint[0]!r}?" if hint else ""
        raise ValueError(f"no agent {name!r} is shipped for {env_id}.{extra} Its agents: "
                         f"{', '.join(agents[env_id])}.")
    return agents_root() / env_id / name


def agent_info(env_id: str, name: str) -> dict:
    """The agent's ``agent.yml`` (env id, env kwargs, algo, seed, hyperparameters, training steps, wall time,
    machine, evaluation)."""
    import yaml

    return dict(yaml.safe_load((agent_dir(env_id, name) / AGENT_FILE).read_text()) or {})


def agent_model_path(env_id: str, name: str) -> Path:
    """The SB3 model ``.zip`` of the shipped agent."""
    d = agent_dir(env_id, name)
    return d / f"{env_id.replace('/', '-')}.zip"


def quiet_make(env_id: str, **kwargs):
    """``gym.make(env_id, **kwargs)`` without Gymnasium's "out of date" DeprecationWarning: ``MagSoftCrawl-v1`` is
    kept on purpose beside ``MagSoftCrawl-v2`` (v1's agents and trajectories stay as they were)."""
    import warnings

    import gymnasium as gym

    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=".*is out of date", category=DeprecationWarning)
        return gym.make(env_id, **kwargs)


def load_agent(env_id: str, name: str, *, env=None):
    """The shipped agent ``name`` of ``env_id`` (e.g. ``load_agent("MagSoftCrawl-v1", "ppo_seed0")``) as a
    deterministic :class:`~magsoft_env.rl.evaluation.Policy` (``policy(obs) -> action``, its observation
    normalization applied), checked against ``env`` (default: ``env_id`` made with the agent's recorded env
    arguments, ``policy.env_kwargs``). Needs stable-baselines3."""
    from .evaluation import load_policy

    info = agent_info(env_id, name)
    if env is None:
        env = quiet_make(env_id, **dict(info.get("env_kwargs") or {}))
        try:
            return load_policy(agent_model_path(env_id, name), algo=info.get("algo"), env=env)
        finally:
            env.close()
    return load_policy(agent_model_path(env_id, name), algo=info.get("algo"), env=env)


__all__ = ["AGENTS_FOLDER", "AGENT_FILE", "agent_dir", "agent_info", "agent_model_path", "agents_root",
           "load_agent", "quiet_make", "shipped_agents"]
