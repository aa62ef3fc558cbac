"""Vector-env throughput: the batched floor env against the single env, Gymnasium and SB3 vector envs, the C bound.

    python -m magsoft_env.bench.vec_bench [--env-id MagSoftCrawl-v1] [--seconds 3] [--sizes 1 2 8 32]
                                          [--only single,batched,sync,async,subproc,bound]

Every row steps its robots with random actions, uniform in [-1, 1]^2 (the default +-2 mT field
limit), episodes ending and restarting as in training (autoreset), and gives aggregate env steps per
second. For each number of envs the measurement is fixed work, interleaved: every row starts from
the same seeds and draws the same actions, so the baseline and the Gymnasium-semantics vector envs run
the very same trajectories (the batched env bit for bit, tested); in each of ``--rounds`` rounds every
row takes the same number of calls (the baseline's round lasting about ``--seconds / --rounds``), in
alternating order, so that the slow and fast spells of a shared machine (a 2-core cloud VM's speed on a fixed
workload swings by up to 1.5x within a second) fall on all of them alike. The table gives the rate over
all rounds and its ratio to the baseline's (the same work), with the lowest and highest ratio over five
runs of consecutive rounds:

* ``single``: the baseline, the single env: ``n`` ``gym.make`` envs stepped one after another in this
  process (seeded and autoreset as the vector envs' robots), so its rate is one env's.
* ``batched``: :class:`~magsoft_env.envs.vector.MagSoftCrawlVecEnv` (``gym.make_vec``, its default
  threads: ``min(n, CPUs)``).
* ``sync`` / ``async``: Gymnasium's ``SyncVectorEnv`` / ``AsyncVectorEnv`` (one process per env) of
  ``gym.make`` envs.
* ``subproc``: SB3's ``SubprocVecEnv`` (one process per env, ``fork``).
* ``threaded``: :class:`~magsoft_env.rl.vec.ThreadedVecEnv`, SB3's ``DummyVecEnv`` on threads (``make_vec_env``
  with ``Monitor``; what rl-zoo3 runs use by default). SB3 resets an env at once, not at the next step,
  so its trajectories part from the baseline's at the first episode end (the same kind of work).
* ``machine``: two rows, the C step alone (``mj_step(m, d, k)`` of a control step, from fixed mid-crawl
  states of the baseline's robots, no Python) on one and on two threads in the same rounds: the
  machine's own two-thread scaling at that moment, printed under the table with the batched env's
  ratio as a share of it (the vCPUs of a 2-core x86 cloud VM swing between 60 and 99 us per substep each).
* ``bound``: the C step alone. The single env's own trajectory (random actions, ``--bound-steps``
  control steps) is replayed from its recorded states with its fields held, by
  ``mujoco.rollout.Rollout`` (no Python between substeps, no checks, no observations; bit for bit
  the env's trajectory) on 1 and 2 threads, in turn with the single env stepping the same actions:
  microseconds per robot substep and the env steps per second that alone allows.

Timings are wall clock on a shared machine: compare numbers from one run only, and read ``uptime``.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import time

import numpy as np

MODES = ("single", "batched", "sync", "async", "subproc", "threaded", "machine", "bound")


def _actions(rng, shape) -> np.ndarray:
    return rng.uniform(-1.0, 1.0, shape).astype(np.float32)


def _timed(step, seconds: float) -> float:
    """Env steps/s of ``step()`` (which returns how many env steps it took) over ``seconds`` of wall time."""
    step()
    t0 = time.perf_counter()
    done = 0
    while True:
        done += step()
        dt = time.perf_counter() - t0
        if dt >= seconds:
            return done / dt


class _Single:
    """The single env: ``n`` ``gym.make`` envs, seeded ``seed + i`` as the vector envs seed their robots,
    stepped one after another in this process with the vector envs' action stream, each reset at the step
    after its episode ended (their NEXT_STEP autoreset): the batched env's trajectories, one robot at a time."""

    def __init__(self, env_id: str, n: int = 1, seed: int = 1, **kwargs):
        import gymnasium as gym

        self.envs = [gym.make(env_id, **kwargs) for _ in range(n)]
        for i, env in enumerate(self.envs):
            env.reset(seed=seed + i)
        self.done = [False] * n
        self.n = n
        self.rng = np.random.default_rng(seed)

    def step(self) -> int:
        actions = _actions(self.rng, (self.n, *self.envs[0].action_space.shape))
        for i, env in enumerate(self.envs):
            if self.done[i]:
                env.reset()
                self.done[i] = False
                continue
            _, _, term, trunc, _ = env.step(actions[i])
            self.done[i] = term or trunc
        return self.n

    def close(self) -> None:
        for env in self.envs:
            env.close()


class _Vector:
    """``n`` envs in vector env ``mode`` (batched, sync, async, subproc, threaded), autoresetting."""

    def __init__(self, mode: str, env_id: str, n: int, seed: int = 1, **kwargs):
        import gymnasium as gym

        mode, _, threads = mode.partition(":")  # "batched:4": the batched env on 4 threads
        if threads:
            kwargs = {**kwargs, "num_threads": int(threads)}

        self.n = n
        self.rng = np.random.default_rng(seed)
        if mode == "subproc":
            from stable_baselines3.common.vec_env import SubprocVecEnv

            def make_one():
                import magsoft_env  # noqa: F401  (registers the ids)

                return gym.make(env_id, **kwargs)

            self.venv = SubprocVecEnv([make_one] * n, start_method="fork")
            self.venv.seed(seed)
            self.venv.reset()
        elif mode == "threaded":
            from stable_baselines3.common.env_util import make_vec_env

            from ..rl.vec import ThreadedVecEnv

            self.venv = make_vec_env(env_id, n_envs=n, seed=seed, vec_env_cls=ThreadedVecEnv, env_kwargs=kwargs)
            self.venv.reset()
        else:
            vmode = {"batched": "vector_entry_point", "sync": "sync", "async": "async"}[mode]
            self.venv = gym.make_vec(env_id, num_envs=n, vectorization_mode=vmode, **kwargs)
            self.venv.reset(seed=seed)

    def step(self) -> int:
        space = getattr(self.venv, "single_action_space", None) or self.venv.action_space  # Gymnasium / SB3
        self.venv.step(_actions(self.rng, (self.n, *space.shape)))
        return self.n

    def close(self) -> None:
        self.venv.close()


class _CAlone:
    """The machine's own scaling, measured alongside: the C step alone (``mj_step(m, d, k)`` for a control
    step's ``k`` substeps, GIL released, no Python between substeps, no checks) of ``n`` robots, each from
    a fixed mid-episode state of the baseline's robots (so every call is the same work), on 1 or 2 threads
    taking robots from one queue. Its 2-thread / 1-thread ratio is what threads can give on the machine
    at that moment: the vCPUs' speeds swing independently (60-99 us for the same substep, measured)."""

    def __init__(self, single: _Single, threads: int):
        import copy

        import mujoco

        from ..envs.vector import ThreadTeam

        self.n = single.n
        base = single.envs[0].unwrapped
        self.model, self.substeps = base.sim.model, base.n_substeps
        self.spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
        self.datas = [copy.copy(env.unwrapped.sim.data) for env in single.envs]
        self.states = []
        for d in self.datas:
            state = np.empty(mujoco.mj_stateSize(self.model, self.spec))
            mujoco.mj_getState(self.model, d, state, self.spec)
            self.states.append((state, d.qacc_warmstart.copy()))
        self.team = ThreadTeam(threads, name="magsoft-bench")  # the batched env's threads and end-of-call poll

    def _robot(self, i: int) -> None:
        import mujoco

        d = self.datas[i]
        state, warm = self.states[i]
        mujoco.mj_setState(self.model, d, state, self.spec)
        d.qacc_warmstart[:] = warm
        mujoco.mj_step(self.model, d, self.substeps)

    def step(self) -> int:
        self.team.each(range(self.n), self._robot)
        return self.n

    def close(self) -> None:
        self.team.close()


def throughput(env_id: str, n: int, modes, *, seconds: float = 3.0, rounds: int = 45, groups: int = 5,
               **kwargs) -> dict:
    """Aggregate env steps/s of ``n`` envs in each vector env of ``modes`` and of the single env.

    Fixed work, finely interleaved: every stepper starts from the same seeds and draws the same actions,
    so the single env (``n`` envs stepped in turn) and the Gymnasium-semantics vector envs run the same
    trajectories; in each of ``rounds`` rounds each stepper takes the same ``K`` calls (``K`` sized so
    that the single env's round lasts about ``seconds / rounds``), in alternating order, so that the
    machine's slow and fast spells (a cloud VM's speed swings by up to 1.5x within a second, measured) fall
    on all of them alike. Returns ``{mode: (rate, ratio, lowest, highest)}``: the rate over all rounds,
    its ratio to the single env's (the same work: the ratio of their total times), and the lowest and
    highest ratio over ``groups`` runs of consecutive rounds; ``"single"``: its rate and ratios of 1."""
    steppers = {"single": _Single(env_id, n, **kwargs)}
    try:
        for mode in modes:
            if mode == "machine":  # after a few steps, so that the robots are mid-crawl
                for _ in range(20):
                    steppers["single"].step()
                steppers["machine:1"] = _CAlone(steppers["single"], 1)
                steppers["machine:2"] = _CAlone(steppers["single"], 2)
            else:
                steppers[mode] = _Vector(mode, env_id, n, **kwargs)
        for st in steppers.values():  # warm-up
            st.step()
        t0 = time.perf_counter()
        steppers["single"].step()
        calls = max(1, round(seconds / rounds / (time.perf_counter() - t0)))
        times: dict = {k: np.zeros(rounds) for k in steppers}
        steps: dict = {k: np.zeros(rounds) for k in steppers}
        names = list(steppers)
        for r in range(rounds):
            for k in (names if r % 2 == 0 else names[::-1]):
                st = steppers[k]
                t0 = time.perf_counter()
                steps[k][r] = sum(st.step() for _ in range(calls))
                times[k][r] = time.perf_counter() - t0
    finally:
        for st in steppers.values():
            st.close()
    parts = np.array_split(np.arange(rounds), min(groups, rounds))
    out = {}
    for k in steppers:
        rate = steps[k].sum() / times[k].sum()
        base = steps["single"].sum() / times["single"].sum()
        by_part = [(steps[k][p].sum() / times[k][p].sum()) / (steps["single"][p].sum() / times["single"][p].sum())
                   for p in parts]
        out[k] = (float(rate), float(rate / base), float(min(by_part)), float(max(by_part)))
    return out


def c_bound(env_id: str, steps: int, *, seed: int = 0, rounds: int = 3, **kwargs) -> dict:
    """The C step alone on the single env's own trajectory. Records the state (and solver warm start)
    before each of ``steps`` random-action control steps, then, ``rounds`` times in turn: the single env
    stepping the same actions from the same seed (the same trajectory, every check and readout), and
    every control step replayed from its state with its field held by ``mujoco.rollout`` (native
    controls, no checks, no Python between substeps) on 1 and on 2 threads. Medians over the rounds."""
    import gymnasium as gym
    import mujoco
    from mujoco import rollout

    from ..sim.model import NATIVE_CONTROL_SPEC, native_controls

    env = gym.make(env_id, **kwargs)
    base = env.unwrapped
    if base.action_mode != "field" or base.slew_rate is not None:
        env.close()
        raise ValueError(f"the C bound replays held fields: field-mode envs without slew_rate only, got "
                         f"action_mode={base.action_mode!r}, slew_rate={base.slew_rate!r}")
    m, d = base.sim.model, base.sim.data
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    nstate = mujoco.mj_stateSize(m, spec)
    states, warm = np.empty((steps, nstate)), np.empty((steps, m.nv))
    rng = np.random.default_rng(seed)
    actions = _actions(rng, (steps, *env.action_space.shape))
    fields = np.array([base.field_of_action(a) for a in actions])

    def run_env(record: bool) -> None:
        env.reset(seed=seed)
        for k, a in enumerate(actions):
            if record:
                mujoco.mj_getState(m, d, states[k], spec)
                warm[k] = d.qacc_warmstart
            _, _, term, trunc, _ = env.step(a)
            if term or trunc:
                env.reset()

    run_env(True)
    sub = base.n_substeps
    control = native_controls(base.sim.rod, fields)[:, None, :]  # held over the control step
    state = np.empty((steps, sub, nstate))
    sens = np.empty((steps, sub, m.nsensordata))
    pools = {1: (rollout.Rollout(nthread=0), mujoco.MjData(m)), 2: (rollout.Rollout(nthread=2),
                                                                   [mujoco.MjData(m) for _ in range(2)])}
    times: dict = {"env": [], 1: [], 2: []}
    try:
        for _ in range(rounds):
            t0 = time.perf_counter()
            run_env(False)
            times["env"].append(time.perf_counter() - t0)
            for nthread, (r, datas) in pools.items():
                t0 = time.perf_counter()
                r.rollout(m, datas, states, control, control_spec=NATIVE_CONTROL_SPEC, nstep=sub,
                          initial_warmstart=warm, state=state, sensordata=sens)
                times[nthread].append(time.perf_counter() - t0)
    finally:
        for r, _ in pools.values():
            r.close()
        env.close()
    med = {k: float(np.median(v)) for k, v in times.items()}
    return {"substeps": sub, "segments": base.segments, "sim_dt": base.sim_dt, "steps": steps, "rounds": rounds,
            "env_steps_per_s": steps / med["env"],
            "us_per_substep_1": med[1] / (steps * sub) * 1e6, "env_steps_per_s_1": steps / med[1],
            "us_per_substep_2": 2 * med[2] / (steps * sub) * 1e6, "env_steps_per_s_2": steps / med[2]}


def _closing(stepper):
    return contextlib.closing(stepper)


def _load() -> str:
    try:
        return " ".join(f"{x:.2f}" for x in os.getloadavg())
    except OSError:
        return "n/a"


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--env-id", default="MagSoftCrawl-v1")
    p.add_argument("--seconds", type=float, default=3.0,
                   help="wall time of the single env per table column, in --rounds rounds (s, default 3)")
    p.add_argument("--rounds", type=int, default=45, help="interleaved rounds per table column (default 45)")
    p.add_argument("--sizes", type=int, nargs="+", default=[1, 2, 8, 32], help="numbers of envs")
    p.add_argument("--only", default=",".join(MODES), help=f"comma-separated subset of {','.join(MODES)}")
    p.add_argument("--bound-steps", type=int, default=200, help="control steps replayed for the C bound")
    p.add_argument("--batched-threads", default="",
                   help="comma list of thread counts: extra rows of the batched env on that many threads (its default "
                        "is min(num_envs, CPUs); more threads than CPUs let one robot's C step run while another "
                        "thread waits for the GIL)")
    args = p.parse_args(argv)
    only = [m.strip() for m in args.only.split(",") if m.strip()]
    bad = sorted(set(only) - set(MODES))
    if bad:
        raise SystemExit(f"--only: unknown mode(s) {bad}; choose from {', '.join(MODES)}")
    if not args.seconds > 0 or min(args.sizes) < 1 or args.bound_steps < 1 or args.rounds < 1:
        raise SystemExit("--seconds must be > 0, --sizes, --rounds and --bound-steps >= 1")
    import magsoft_env  # noqa: F401  (registers the ids)
    from magsoft_env.envs.vector import usable_cpus

    env_id = args.env_id
    print(f"# {env_id}, random actions, {args.seconds:g} s per cell; {usable_cpus()} CPUs, load average "
          f"{_load()} (1, 5, 15 min)")
    rows = [m for m in ("batched", "sync", "async", "subproc", "threaded", "machine") if m in only]
    try:
        extra_threads = [int(t) for t in args.batched_threads.split(",") if t.strip()]
    except ValueError:
        raise SystemExit(f"--batched-threads must be a comma list of integers, got {args.batched_threads!r}") from None
    if any(t < 1 for t in extra_threads):
        raise SystemExit(f"--batched-threads must be >= 1, got {args.batched_threads!r}")
    rows[1:1] = [f"batched:{t}" for t in extra_threads]
    base = None
    if rows:
        print("\nAggregate env steps/s over all rounds (in brackets: the ratio to the single env on the same "
              "trajectories, interleaved, and its lowest and highest over five runs of consecutive rounds)\n")
        print(f"| vector env | {' | '.join(f'{n} env' + ('s' if n > 1 else '') for n in args.sizes)} |")
        print(f"|---|{'---|' * len(args.sizes)}")
        table = {n: throughput(env_id, n, rows, seconds=args.seconds, rounds=args.rounds) for n in args.sizes}
        cells = [f"{table[n]['single'][0]:.0f}" for n in args.sizes]
        print(f"| single env, robots in turn (baseline) | {' | '.join(cells)} |")
        for mode in [r for r in rows if r != "machine"] + (["machine:1", "machine:2"] if "machine" in rows else []):
            cells = [f"{rate:.0f} ({ratio:.2f}x, {lo:.2f}-{hi:.2f})"
                     for rate, ratio, lo, hi in (table[n][mode] for n in args.sizes)]
            names = {"machine:1": "C step alone, 1 thread", "machine:2": "C step alone, 2 threads"}
            label = names.get(mode, mode)
            label = f"batched, {mode.partition(':')[2]} threads" if mode.startswith("batched:") else label
            print(f"| {label} | {' | '.join(cells)} |")
        if "machine" in rows:
            scale = {n: table[n]["machine:2"][0] / table[n]["machine:1"][0] for n in args.sizes if n > 1}
            print("\nThe machine's own 2-thread scaling in the same rounds (C step alone, 2 threads / 1 thread): "
                  + (", ".join(f"x{scale[n]:.2f} at {n} envs" for n in scale) or "needs 2 envs or more"))
            if "batched" in rows:
                print("The batched env's ratio as a share of it: "
                      + (", ".join(f"{table[n]['batched'][1] / scale[n]:.0%} at {n} envs" for n in scale) or "-"))
        base = float(np.median([table[n]["single"][0] for n in args.sizes]))
        print(f"\nload average after the table: {_load()}")
    elif "single" in only:
        with _closing(_Single(env_id)) as st:
            base = _timed(st.step, args.seconds)
        print(f"\nsingle env loop: {base:8.1f} env steps/s")
    if "bound" in only:
        try:
            b = c_bound(env_id, args.bound_steps)
        except ValueError as err:
            print(f"\nC bound: not measured ({err}).")
            return 0
        s1, s2 = b["env_steps_per_s_1"], b["env_steps_per_s_2"]
        se = b["env_steps_per_s"]
        print(f"\nC bound: the single env's trajectory ({b['steps']} control steps x {b['substeps']} substeps, "
              f"{b['segments']} segments) replayed by mujoco.rollout, fields held, no checks; medians of "
              f"{b['rounds']} rounds, in turn with the single env on the same trajectory:")
        print(f"  single env, same trajectory: {se:.0f} env steps/s")
        print(f"  C alone, 1 thread : {b['us_per_substep_1']:.1f} us per robot substep -> {s1:.0f} env steps/s "
              f"(the single env runs at {se / s1:.2f} of it: the rest is Python, checks, observation, reward)")
        print(f"  C alone, 2 threads: {b['us_per_substep_2']:.1f} us CPU per robot substep -> {s2:.0f} env steps/s "
              f"(x{s2 / s1:.2f} one thread; x{s2 / se:.2f} the single env: no batch on 2 cores passes this)")
        need = 2.0 / (1000.0 * b["substeps"]) * 1e6
        print(f"  1000 env steps/s on 2 cores needs <= {need:.0f} us per robot substep at perfect scaling "
              f"({b['substeps']} substeps per env step)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
