"""Reinforcement learning on the environments through rl-zoo3: its hyperparameter files read and checked,
training runs that are never overwritten, evaluation against the open-loop paper gaits, learning curves,
policies checked against the env they are played in (the library behind ``train/``), and
:class:`~magsoft_env.rl.vec.SB3VecAdapter`, the batched floor envs as an SB3 ``VecEnv``, and
:class:`~magsoft_env.rl.vec.ThreadedVecEnv`, SB3's ``DummyVecEnv`` on threads (rl-zoo3 runs with ``vec="threads"``).
Stable-Baselines3, rl-zoo3 and torch are imported only when used (``SB3VecAdapter``: on first access)."""

from .agents import agent_dir, agent_info, agent_model_path, load_agent, shipped_agents
from .evaluation import (
    EvalResult,
    Policy,
    check_policy_env,
    evaluate_open_loop,
    load_policy,
    locomotion_mode,
    open_loop_actor,
    policy_run_info,
    run_episodes,
)
from .hyperparams import (
    ALGOS,
    ZOO_KEYS,
    algo_arguments,
    algo_class,
    check_algo_kwargs,
    check_env_id,
    check_env_kwargs,
    check_hyperparams,
    env_arguments,
    load_hyperparams,
    parse_override,
    split_hyperparams,
)
from .runs import RunRecord, find_run, read_zoo_yaml
from .training import (
    GYM_PACKAGE,
    evaluate_run,
    fail_stale_trials,
    learning_curve,
    open_study,
    optuna_storage,
    run_zoo,
    summarize_run,
    train,
    tune,
    zoo_argv,
)

#: names of .vec, which imports stable_baselines3: loaded on first access
_VEC_NAMES = ("SB3VecAdapter", "ThreadedVecEnv", "make_sb3_vec_env", "unbatch_infos")


def __getattr__(name: str):
    if name in _VEC_NAMES:
        from . import vec

        return getattr(vec, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = ["agent_dir", "agent_info", "agent_model_path", "load_agent", "shipped_agents",
           "ALGOS", "GYM_PACKAGE", "ZOO_KEYS", "EvalResult", "Policy", "RunRecord", "SB3VecAdapter", "ThreadedVecEnv",
           "algo_arguments",
           "algo_class", "check_algo_kwargs", "check_env_id", "check_env_kwargs", "check_hyperparams",
           "check_policy_env", "env_arguments", "evaluate_open_loop", "evaluate_run", "find_run", "learning_curve",
           "locomotion_mode",
           "load_hyperparams", "load_policy", "make_sb3_vec_env", "open_loop_actor", "parse_override",
           "policy_run_info", "read_zoo_yaml", "run_episodes", "run_zoo", "split_hyperparams", "summarize_run",
           "train", "unbatch_infos", "zoo_argv", "fail_stale_trials", "open_study", "optuna_storage", "tune"]
