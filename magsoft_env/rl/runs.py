"""Training runs on disk: rl-zoo3 log folders (``<folder>/<algo>/<env>_<n>/``) inside this project's run
folders (``runs/<run-id>/``), the env id, algorithm and env arguments each was trained with."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path


@dataclass(frozen=True)
class RunRecord:
    """One rl-zoo3 training run as found on disk (frozen).

    Attributes
    ----------
    log_dir : Path
        rl-zoo3's save path, ``<log folder>/<algo>/<env>_<n>``: the models, ``evaluations.npz``,
        ``*.monitor.csv``.
    env_id : str
        The environment it was trained in (``args.yml``).
    algo : str
        rl-zoo3's algorithm name (``"ppo"``, ``"sac"``, ...).
    env_kwargs : dict
        The environment's constructor arguments in training: ``config.yml``'s ``env_kwargs``, replaced by
        the command line's ``--env-kwargs`` when given (as rl-zoo3 does).
    hyperparams : dict
        The block rl-zoo3 read (``config.yml``), ``env_kwargs`` included.
    args : dict
        rl-zoo3's command-line arguments (``args.yml``).
    """

    log_dir: Path
    env_id: str
    algo: str
    env_kwargs: dict = field(default_factory=dict)
    hyperparams: dict = field(default_factory=dict)
    args: dict = field(default_factory=dict)

    @property
    def params_dir(self) -> Path:
        """``<log_dir>/<env>``: ``config.yml``, ``args.yml``, ``vecnormalize.pkl``, ``command.txt``."""
        return self.log_dir / _env_folder(self.env_id)

    @property
    def final_model(self) -> Path:
        """The model saved at the end of training."""
        return self.log_dir / f"{_env_folder(self.env_id)}.zip"

    @property
    def best_model(self) -> Path:
        """The model with the best evaluation return (rl-zoo3's evaluation callback)."""
        return self.log_dir / "best_model.zip"

    @property
    def vecnormalize(self) -> Path | None:
        """Observation normalization statistics, if the run normalized."""
        p = self.params_dir / "vecnormalize.pkl"
        return p if p.exists() else None

    def model(self, *, best: bool = False) -> Path:
        """The final model (or, with ``best``, the best evaluated one); ValueError if it is not there."""
        p = self.best_model if best else self.final_model
        if not p.exists():
            what = "no best_model.zip (was it trained with --eval-freq > 0?)" if best else f"no {p.name}"
            raise ValueError(f"run {str(self.log_dir)!r} has {what}.")
        return p


def _env_folder(env_id: str) -> str:
    """rl-zoo3's folder name for an env id (``huggingface_sb3.EnvironmentName``: ``/`` becomes ``-``)."""
    return env_id.replace("/", "-")


def read_zoo_yaml(path) -> dict:
    """A ``config.yml`` or ``args.yml`` written by rl-zoo3 (``yaml.dump`` of an ``OrderedDict``), read
    without executing arbitrary tags: the ``OrderedDict`` becomes a dict, any other Python tag is refused."""
    import yaml

    class Loader(yaml.SafeLoader):
        pass

    def ordered(loader, node):
        pairs = loader.construct_sequence(node.value[0], deep=True) if node.value else []
        return {k: v for k, v in pairs}

    Loader.add_constructor("tag:yaml.org,2002:python/object/apply:collections.OrderedDict", ordered)
    try:
        data = yaml.load(Path(path).read_text(), Loader=Loader)  # noqa: S506 (a SafeLoader subclass)
    except yaml.YAMLError as err:
        raise ValueError(f"could not read {str(path)!r}: {err}") from err
    return dict(data or {})


def _is_log_dir(p: Path) -> bool:
    return any((c / "args.yml").is_file() for c in p.iterdir() if c.is_dir()) if p.is_dir() else False


def find_run(path) -> RunRecord:
    """The run at ``path``: a model ``.zip`` inside an rl-zoo3 log folder, the log folder itself, or a folder
    holding exactly one log folder at any depth up to three (e.g. ``runs/<run-id>`` written by
    ``train/train.py``, or an rl-zoo ``-f`` folder).

    Raises ValueError when there is no run, or several (they are listed).
    """
    p = Path(path)
    if not p.exists():
        raise ValueError(f"run path must be an existing run folder or model .zip, got {str(p)!r}.")
    if p.is_file():  # a model: its own folder is the log folder, or there is no run
        if not _is_log_dir(p.parent):
            raise ValueError(f"{str(p)!r} is not in an rl-zoo3 log folder (no <env>/args.yml beside it).")
        p = p.parent
    if _is_log_dir(p):
        log_dirs = [p]
    else:
        log_dirs = sorted({a.parent.parent for depth in ("*/*", "*/*/*", "*/*/*/*")
                           for a in p.glob(f"{depth}/args.yml")})
    if not log_dirs:
        raise ValueError(f"{str(p)!r} holds no rl-zoo3 run (no <env>/args.yml below it).")
    if len(log_dirs) > 1:
        raise ValueError(f"{str(p)!r} holds {len(log_dirs)} runs; name one: "
                         + ", ".join(str(d) for d in log_dirs[:10]))
    log_dir = log_dirs[0]
    args_files = [c / "args.yml" for c in sorted(log_dir.iterdir()) if (c / "args.yml").is_file()]
    args = read_zoo_yaml(args_files[0])
    env_id = str(args.get("env", args_files[0].parent.name))
    config = args_files[0].parent / "config.yml"
    hyper = read_zoo_yaml(config) if config.is_file() else {}
    env_kwargs = dict(hyper.get("env_kwargs") or {})
    if args.get("env_kwargs") is not None:  # rl-zoo3: the command line's --env-kwargs replace the file's
        env_kwargs = dict(args["env_kwargs"])
    return RunRecord(log_dir=log_dir, env_id=env_id, algo=str(args.get("algo", "ppo")), env_kwargs=env_kwargs,
                     hyperparams=hyper, args=args)


__all__ = ["RunRecord", "find_run", "read_zoo_yaml"]
