"""Hyperparameter files of ``train/`` (YAML, one block per env id over a ``default:`` block) and
``--set key=value`` overrides."""

from __future__ import annotations

import copy
import difflib

ALGOS = ("ppo", "sac")


# ---------------------------------------------------------------------------- hyperparameters
def parse_override(text: str):
    """Value of a ``KEY=VALUE`` command-line override: YAML, with "1e-4"-style strings as floats
    (YAML 1.1 reads exponent notation without a dot as a string)."""
    import yaml

    return _yaml_numbers(yaml.safe_load(text))


def _yaml_numbers(v):
    """``v`` with YAML 1.1's exponent strings ("1e-4", read as strings without a dot) as floats,
    in nested dicts and lists too; other strings unchanged."""
    if isinstance(v, str):
        try:
            return float(v) if any(c.isdigit() for c in v) else v
        except ValueError:
            return v
    if isinstance(v, dict):
        return {k: _yaml_numbers(x) for k, x in v.items()}
    if isinstance(v, list):
        return [_yaml_numbers(x) for x in v]
    return v


def load_hyperparams(path, env_id: str, algo: str) -> dict:
    """Resolved settings for ``env_id`` and ``algo`` from a YAML file keyed by env id.

    The file has a ``default:`` block and one block per env id; each block may hold
    ``env_kwargs`` (constructor arguments), ``n_envs``, ``n_timesteps``, ``normalize``,
    ``eval_episodes`` and one sub-block per algorithm (``ppo:``, ``sac:``) of SB3 keyword
    arguments. The env block overrides the default block key by key (sub-blocks merged).

    Returns
    -------
    dict
        ``{"env_id", "algo", "env_kwargs", "n_envs", "n_timesteps", "normalize",
        "eval_episodes", "algo_kwargs"}``.
    """
    import yaml

    algo = str(algo).lower()
    if algo not in ALGOS:
        raise ValueError(f"algo must be one of {list(ALGOS)}, got {algo!r}.")
    with open(path) as fh:
        table = yaml.safe_load(fh) or {}
    if not isinstance(table, dict) or "default" not in table:
        raise ValueError(f"hyperparameter file {str(path)!r} must be a mapping with a 'default:' block.")
    known = [k for k in table if k != "default"]
    if env_id not in table:
        import gymnasium as gym


        if env_id not in gym.registry:
            hint = difflib.get_close_matches(env_id, known + list(gym.registry), n=1)
            extra = f" Did you mean {hint[0]!r}?" if hint else ""
            raise ValueError(f"env id {env_id!r} is not registered.{extra}")
    merged = copy.deepcopy(table["default"])
    for key, value in (table.get(env_id) or {}).items():
        if isinstance(value, dict) and isinstance(merged.get(key), dict):
            merged[key] = {**merged[key], **value}
        else:
            merged[key] = value
    algo_kwargs = _yaml_numbers(dict(merged.get(algo) or {}))
    return {
        "env_id": env_id,
        "algo": algo,
        "env_kwargs": _yaml_numbers(dict(merged.get("env_kwargs") or {})),
        "n_envs": int(merged.get("n_envs", 1)),
        "n_timesteps": int(float(algo_kwargs.pop("n_timesteps", merged.get("n_timesteps", 10000)))),
        "normalize": bool(merged.get("normalize", True)),
        "eval_episodes": int(merged.get("eval_episodes", 2)),
        "algo_kwargs": algo_kwargs,
    }


# ---------------------------------------------------------------------------- evaluation


__all__ = ["ALGOS", "load_hyperparams", "parse_override"]
