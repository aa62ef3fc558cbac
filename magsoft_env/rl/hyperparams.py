"""Hyperparameter files in rl-baselines3-zoo's format (one block per env id), read the way rl-zoo3 reads
them, and the checks that turn a misspelt algorithm or environment argument into a ValueError naming the
closest valid one."""

from __future__ import annotations

import copy
import difflib
import inspect

#: Algorithms whose hyperparameter files ``train/`` ships (rl-zoo3 trains more).
ALGOS = ("ppo", "sac")

#: Keys of an rl-zoo block that rl-zoo itself consumes; every other key goes to the algorithm's constructor.
ZOO_KEYS = ("n_timesteps", "policy", "n_envs", "normalize", "env_kwargs", "frame_stack", "env_wrapper",
            "vec_env_wrapper", "callback", "monitor_kwargs", "noise_type", "noise_std")

#: Constructor arguments rl-zoo3 passes itself (``env``, ``seed``, ...): not allowed in a block.
_ZOO_PASSES = ("self", "env", "seed", "verbose", "device", "tensorboard_log", "_init_setup_model")


# ---------------------------------------------------------------------------- values
def parse_override(text: str):
    """Value of a ``KEY=VALUE`` command-line override: YAML, with "1e-4"-style strings as floats
    (YAML 1.1 reads exponent notation without a dot as a string)."""
    import yaml

    return _yaml_numbers(yaml.safe_load(text))


def _yaml_numbers(v):
    """``v`` with YAML 1.1's exponent strings ("1e-4", read as strings without a dot) as floats,
    in nested dicts and lists too; other strings unchanged."""
    if isinstance(v, str):
        return float(v) if _is_number_string(v) else v
    if isinstance(v, dict):
        return {k: _yaml_numbers(x) for k, x in v.items()}
    if isinstance(v, list):
        return [_yaml_numbers(x) for x in v]
    return v


def _is_number_string(v: str) -> bool:
    try:
        float(v)
    except ValueError:
        return False
    return any(c.isdigit() for c in v)


def _refuse_number_strings(value, where: str) -> None:
    """A string that reads as a number ("2e-3") in a hyperparameter file: rl-zoo3 would pass it on as a string."""
    if isinstance(value, dict):
        for k, v in value.items():
            _refuse_number_strings(v, f"{where}.{k}")
    elif isinstance(value, list):
        for k, v in enumerate(value):
            _refuse_number_strings(v, f"{where}[{k}]")
    elif isinstance(value, str) and _is_number_string(value):
        raise ValueError(f"{where} = {value!r} is a string in YAML 1.1 (which rl-zoo3 reads): write it with a dot "
                         f"and a signed exponent, e.g. {float(value)!r}.")


def _suggest(name: str, allowed) -> str:
    hint = difflib.get_close_matches(name, sorted(allowed), n=1)
    return f" Did you mean {hint[0]!r}?" if hint else ""


# ---------------------------------------------------------------------------- algorithm and env arguments
def algo_class(algo: str):
    """The Stable-Baselines3 (or sb3-contrib) class rl-zoo3 trains as ``algo`` (e.g. ``"ppo"``)."""
    algo = str(algo).lower()
    try:
        from rl_zoo3.utils import ALGOS as ZOO_ALGOS
    except ImportError:  # rl-zoo3 not installed: the two this project ships files for
        import stable_baselines3 as sb3

        ZOO_ALGOS = {"ppo": sb3.PPO, "sac": sb3.SAC}
    if algo not in ZOO_ALGOS:
        raise ValueError(f"algo must be one of {sorted(ZOO_ALGOS)}, got {algo!r}.{_suggest(algo, ZOO_ALGOS)}")
    return ZOO_ALGOS[algo]


def _init_arguments(cls) -> set:
    """Named ``__init__`` arguments of ``cls`` and its bases (``**kwargs`` forwarded up the chain)."""
    names = set()
    for klass in cls.__mro__:
        init = klass.__dict__.get("__init__")
        if init is not None:
            names |= {n for n, p in inspect.signature(init).parameters.items()
                      if p.kind not in (p.VAR_KEYWORD, p.VAR_POSITIONAL)}
    return names


def algo_arguments(algo: str) -> set:
    """Keys an rl-zoo block may hold for ``algo``: rl-zoo's own (:data:`ZOO_KEYS`) and the algorithm's
    constructor arguments (those rl-zoo passes itself excluded)."""
    return (_init_arguments(algo_class(algo)) - set(_ZOO_PASSES)) | set(ZOO_KEYS)


def check_algo_kwargs(algo: str, block: dict, *, where: str = "hyperparameter") -> None:
    """Raise ValueError for a key of ``block`` that neither rl-zoo3 nor ``algo``'s constructor takes, or a
    ``policy_kwargs`` key the policy does not take, naming the closest valid one."""
    allowed = algo_arguments(algo)
    cls = algo_class(algo)
    for key in block:
        if key not in allowed:
            raise ValueError(f"unknown {cls.__name__} {where} {key!r}.{_suggest(key, allowed)} "
                             f"Allowed: {', '.join(sorted(allowed))}.")
    policy, kwargs = block.get("policy", "MlpPolicy"), block.get("policy_kwargs")
    if isinstance(kwargs, dict) and isinstance(policy, str) and policy in getattr(cls, "policy_aliases", {}):
        allowed = _init_arguments(cls.policy_aliases[policy]) - {"self", "observation_space", "action_space",
                                                                 "lr_schedule"}
        for key in kwargs:
            if key not in allowed:
                raise ValueError(f"unknown {policy} policy_kwargs key {key!r}.{_suggest(key, allowed)} "
                                 f"Allowed: {', '.join(sorted(allowed))}.")


def env_arguments(env_id: str) -> set:
    """Constructor arguments of the environment registered as ``env_id``."""
    import gymnasium as gym
    from gymnasium.envs.registration import load_env_creator

    check_env_id(env_id)
    creator = load_env_creator(gym.spec(env_id).entry_point)
    if inspect.isclass(creator):
        inner = getattr(creator, "source_class", None)  # an env that passes its other arguments to another
        return (_init_arguments(creator) | (_init_arguments(inner) if inner else set())) - {"self"}
    return {n for n, p in inspect.signature(creator).parameters.items()
            if p.kind not in (p.VAR_KEYWORD, p.VAR_POSITIONAL)}


def check_env_kwargs(env_id: str, env_kwargs: dict | None, *, build: bool = False) -> None:
    """Raise ValueError for an argument the ``env_id`` constructor does not take, naming the closest one;
    with ``build``, also make the env once (its own checks then refuse bad values) and close it."""
    import gymnasium as gym

    kwargs = dict(env_kwargs or {})
    allowed = env_arguments(env_id)
    for key in kwargs:
        if key not in allowed:
            raise ValueError(f"{env_id} has no argument {key!r}.{_suggest(key, allowed)} "
                             f"Allowed: {', '.join(sorted(allowed))}.")
    if build:
        gym.make(env_id, **kwargs).close()


def check_env_id(env_id: str) -> None:
    """Raise ValueError for an id Gymnasium does not know, naming the closest registered one."""
    import gymnasium as gym

    from ..envs import register_all

    register_all()  # the ids, when the package facade was not imported
    if env_id not in gym.registry:
        raise ValueError(f"env id {env_id!r} is not registered.{_suggest(env_id, gym.registry)}")


def check_hyperparams(block: dict, env_id: str, algo: str) -> None:
    """Check one rl-zoo block for ``env_id`` and ``algo``: keys (closest name suggested), ``n_timesteps`` and
    ``n_envs`` >= 1, no numbers written as YAML 1.1 strings, ``env_kwargs`` the env's arguments."""
    if not isinstance(block, dict):
        raise ValueError(f"the hyperparameters of {env_id} must be a mapping, got {type(block).__name__}.")
    if "n_timesteps" not in block:
        raise ValueError(f"the hyperparameters of {env_id} need n_timesteps (rl-zoo3 requires it).")
    _refuse_number_strings(block, env_id)
    check_algo_kwargs(algo, block)
    for key in ("n_timesteps", "n_envs"):
        value = block.get(key, 1)
        if isinstance(value, bool) or not isinstance(value, int | float) or int(value) != value or value < 1:
            raise ValueError(f"{key} must be a whole number >= 1, got {value!r}.")
    env_kwargs = block.get("env_kwargs") or {}
    if not isinstance(env_kwargs, dict):
        raise ValueError(f"env_kwargs must be a mapping, got {env_kwargs!r}.")
    check_env_kwargs(env_id, env_kwargs)


# ---------------------------------------------------------------------------- files
def load_hyperparams(path, env_id: str, algo: str = "ppo") -> dict:
    """The hyperparameters rl-zoo3 would use for ``env_id`` from ``path``, checked.

    Reads the file as ``rl_zoo3.exp_manager.ExperimentManager.read_hyperparameters`` does: a YAML
    mapping keyed by env id (YAML merge keys ``<<:`` resolved), the block of ``env_id``, else the
    ``default`` block. rl-zoo3 takes one file per algorithm (``-conf``); ``algo`` is the one the file
    is for, used for the checks (:func:`check_hyperparams`).

    Returns
    -------
    dict
        A copy of the block in rl-zoo's format: ``n_timesteps``, ``policy``, ``n_envs``, ``normalize``,
        ``env_kwargs`` and the algorithm's keyword arguments, at one level. Use :func:`split_hyperparams`
        for the algorithm's arguments alone.
    """
    import yaml

    with open(path) as fh:
        table = yaml.safe_load(fh) or {}
    if not isinstance(table, dict):
        raise ValueError(f"hyperparameter file {str(path)!r} must be a mapping keyed by env id.")
    check_env_id(env_id)
    if env_id in table:
        block = table[env_id]
    elif "default" in table:
        block = table["default"]
    else:
        raise ValueError(f"hyperparameter file {str(path)!r} has no block for {env_id!r} and no 'default' "
                         f"block.{_suggest(env_id, table)}")
    block = copy.deepcopy(block)
    check_hyperparams(block, env_id, algo)
    return block


def split_hyperparams(block: dict) -> tuple[dict, dict]:
    """``(zoo_settings, algo_kwargs)``: the keys rl-zoo3 consumes (:data:`ZOO_KEYS`, ``policy`` included)
    and the rest, which go to the algorithm's constructor."""
    zoo = {k: v for k, v in block.items() if k in ZOO_KEYS}
    return zoo, {k: v for k, v in block.items() if k not in ZOO_KEYS}


__all__ = ["ALGOS", "ZOO_KEYS", "algo_arguments", "algo_class", "check_algo_kwargs", "check_env_id",
           "check_env_kwargs", "check_hyperparams", "env_arguments", "load_hyperparams", "parse_override",
           "split_hyperparams"]
