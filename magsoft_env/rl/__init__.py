"""Reinforcement learning on the environments: hyperparameter files, training runs, evaluation
against the open-loop paper gaits, policy loading (the library behind ``train/``).
Stable-Baselines3 and torch are imported only when used."""

from .evaluation import EvalResult, evaluate_open_loop, load_policy, open_loop_actor, run_episodes
from .hyperparams import ALGOS, load_hyperparams, parse_override
from .training import evaluate_run, train

__all__ = ["ALGOS", "EvalResult", "evaluate_open_loop", "evaluate_run", "load_hyperparams", "load_policy",
           "open_loop_actor", "parse_override", "run_episodes", "train"]
