"""Train PPO on the JAX backend, many seeds in one jitted run, in chunks that are checkpointed:

    python train_jax.py --env LightSail-v0 --seeds 16
    python train_jax.py --env LightSail3DRealistic-v1 --seeds 4 -n 20000000 --recurrent 64 --checkpoint-every 50
    python train_jax.py --resume runs/LightSail3DRealistic-v1-jax_ppo-0     # continue it after an interruption

Each chunk of --checkpoint-every updates (rollouts, GAE, minibatch epochs) is one compiled function
(agents.jax_ppo), vmap-ed over the seeds. Each seed gets a run folder as train.py's,
runs/<env>-jax_ppo-<seed> (_2, _3, … if taken; runs/latest then names the first seed's), made when
the run starts and holding:

    run.json         the settings, the device, the wall time with compilation, the success rate of each
                     rollout's ended episodes so far, the learning curve ("curve": after every chunk, env
                     steps and the deterministic policy's success on the same 256 fresh episodes of the JAX
                     env; "beyond_box": on those episodes, the share of the actions it asked for beyond
                     [-1, 1], which the env clips; "exploration_std": the Gaussian's standard deviation
                     the chunk's rollouts drew their actions with, averaged over the actions, and at
                     the episodes' last steps), "status": "running"; at the end "finished" and the
                     deterministic policy's success on 1,000 other fresh episodes
    policy.npz       the deterministic actor after the last chunk (at the end: the trained one), which
                     evaluate.py --agent runs/latest/policy.npz plays on the Gym env (with its memory, if it
                     has one: --history, --recurrent, --episode-mean; and --tanh-mean's squashing; not
                     with --privileged-actor, whose actor sees what no env shows)
    best_policy.npz  the actor after the chunk whose curve point is the highest so far (the first of equals;
                     run.json "best": its env steps and success): the model a learner is reported with, as
                     train.py's best_model.zip, selected on the curve's episodes, apart from any evaluation's
    checkpoint.npz   in the first seed's folder, for all seeds: the whole training state after the last
                     chunk (networks, optimiser, environments, memories, keys), what --resume reads

On the realistic 3D and uncertain tasks, --coast fast trains ~30 times faster on a CPU: each draw's coast
pieces are built once (a minute or two at the start), and the episodes are the task's in law, not draw for draw
(sail_env.jax.fast_coast); --terminal-reward expected scores each episode by its mean over 16 coasts from
the window's end (--expected-paths), which leaves every policy's expected return as it is. evaluate.py plays
the task as registered.

Each file is replaced whole (written beside, renamed over): after every chunk the policies, the checkpoint,
then each run.json. --resume DIR (any seed's folder of the run) continues the run from its checkpoint with its own
settings to the networks an uninterrupted run ends with (bit for bit on a CPU); beside it only
--checkpoint-every may be given (without it the run keeps its chunks). A finished run is not resumed, and no new run writes into
an old folder. A refused argument is one line on stderr and exit 2, with nothing written.
"""

from __future__ import annotations

import argparse
import dataclasses
import functools
import json
import sys
import time
from pathlib import Path
from typing import Any

import jax
import numpy as np

import sail_env.jax
from agents import cli
from agents.jax_ppo import PPOConfig, RunState, actor_arrays, make_chunks, play_deterministic
from agents.mlp_policy import POLICY_FILE, read_npz, save_policy, write_npz
from agents.training import new_run_dir, point_latest
from sail_env.jax.env import COASTS, TERMINAL_REWARDS, EnvParams, SailEnv
from sail_env.tasks import JAX_TASKS

ALGO = "jax_ppo"
RUN_FILE = "run.json"
BEST_POLICY_FILE = "best_policy.npz"
CHECKPOINT_FILE = "checkpoint.npz"
#: The fresh episodes of the JAX env that score each seed's deterministic policy at the end.
EVAL_EPISODES = 1000
#: The learning curve: after every chunk, the deterministic policy's success on these fresh episodes of the
#: JAX env (the same ones each time; other episodes than the final evaluation's).
CURVE_EPISODES = 256
#: The keys of the two evaluations' episodes.
EVAL_KEY, CURVE_KEY = 10**6, 2 * 10**6
#: Updates per chunk unless ``--checkpoint-every`` says otherwise (a resumed run: its own).
CHECKPOINT_EVERY = 100
#: Flags that ``--resume`` applies; every other one is the run's own.
RESUME_APPLIES = ("resume", "checkpoint_every")
#: The coasts ``--terminal-reward expected`` averages over unless ``--expected-paths`` says: its variance falls as
#: 1/K (``tests/jax/test_fast_coast.py``), and 16 paths cost about the fast coast's episode again.
EXPECTED_PATHS = 16


def layer_sizes(text: str) -> tuple[int, ...]:
    """An argparse type: hidden layer sizes, ``128,128``."""
    try:
        sizes = tuple(int(size) for size in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be layer sizes separated by commas, e.g. 128,128; "
                                         f"got {text!r}") from None
    if min(sizes) < 1:
        raise argparse.ArgumentTypeError(f"layer sizes must be >= 1, got {text!r}")
    return sizes


def build_parser() -> cli.Parser:
    """train_jax.py's command line; each flag of PPO is its :class:`PPOConfig` field (``dest``)."""
    defaults = {f.name: f.default for f in dataclasses.fields(PPOConfig)}
    parser = cli.Parser(prog="train_jax.py", description=cli.describe(__doc__), formatter_class=cli.HelpFormatter)
    parser.add_argument("--env", default="LightSail-v0", help="a task of the JAX backend (sail_env.tasks.JAX_TASKS)")
    parser.add_argument("--seeds", type=cli.positive_int, default=1, help="how many seeds, trained together")
    parser.add_argument("--first-seed", type=cli.non_negative_int, default=0, help="the first seed's number")
    parser.add_argument("-n", "--timesteps", dest="total_timesteps", type=cli.positive_int, metavar="STEPS",
                        default=defaults["total_timesteps"], help="env steps per seed")
    parser.add_argument("--num-envs", type=cli.positive_int, default=defaults["num_envs"],
                        help="environments per seed, stepped together")
    parser.add_argument("--num-steps", type=cli.positive_int, default=defaults["num_steps"],
                        help="steps per environment per rollout")
    parser.add_argument("--num-minibatches", type=cli.positive_int, default=defaults["num_minibatches"],
                        help="per epoch (with --recurrent: sets of whole environments)")
    parser.add_argument("--update-epochs", type=cli.positive_int, default=defaults["update_epochs"],
                        help="passes over each rollout")
    parser.add_argument("--learning-rate", type=float, default=defaults["learning_rate"],
                        help="Adam's step size, annealed linearly unless --no-anneal-lr")
    parser.add_argument("--anneal-lr", action=argparse.BooleanOptionalAction, default=defaults["anneal_lr"],
                        help="anneal the learning rate linearly over the run to --final-learning-rate "
                             "(--no-anneal-lr: keep it)")
    parser.add_argument("--final-learning-rate", type=float, default=defaults["final_learning_rate"],
                        help="where the annealing ends, in [0, --learning-rate]")
    parser.add_argument("--gamma", type=float, default=defaults["gamma"], help="discount")
    parser.add_argument("--gae-lambda", type=float, default=defaults["gae_lambda"],
                        help="GAE's λ: 1 gives the returns' own advantages, lower leans on the critic")
    parser.add_argument("--ent-coef", type=float, default=defaults["ent_coef"], help="weight of the entropy bonus")
    parser.add_argument("--log-std-init", type=float, default=defaults["log_std_init"],
                        help="the Gaussian policy's log standard deviation at the start")
    parser.add_argument("--hidden", type=layer_sizes, default=defaults["hidden"], metavar="SIZES",
                        help="tanh layer sizes of actor and critic, e.g. 128,128")
    parser.add_argument("--history", type=cli.positive_int, default=defaults["history"],
                        help="the networks see the last H observations (1: the current one)")
    parser.add_argument("--recurrent", type=cli.non_negative_int, default=defaults["recurrent"],
                        help="units of a GRU in actor and critic (0: none)")
    parser.add_argument("--episode-mean", action="store_true",
                        help="the networks also see the mean of the episode's observations so far")
    parser.add_argument("--clipped-likelihood", action="store_true",
                        help="PPO's likelihood of the clipped action the env plays (Fujita & Maeda 2018)")
    parser.add_argument("--tanh-mean", action="store_true",
                        help="the actor's mean is the tanh of its last layer, inside the box")
    parser.add_argument("--privileged-critic", action="store_true",
                        help="in training, the critic also sees the episode's parameter draw (the asymmetric "
                             "actor-critic); the actor sees what any controller sees")
    parser.add_argument("--privileged-actor", action="store_true",
                        help="the actor sees the draw too: a diagnostic, whose policy no env can play")
    parser.add_argument("--state-dependent-std", action="store_true",
                        help="the actor also outputs its Gaussian's log std, about the learnt one, per state")
    parser.add_argument("--checkpoint-every", type=cli.positive_int, metavar="UPDATES",
                        help=f"updates per compiled chunk, after each of which the run is checkpointed (default "
                             f"{CHECKPOINT_EVERY}; a resumed run keeps its own unless given)")
    parser.add_argument("--coast", choices=COASTS, default="default",
                        help="fast: each draw's coast pieces built once, the same episodes in law (the realistic 3D "
                             "and uncertain tasks; sail_env.jax.fast_coast); the curve and the final episodes too")
    parser.add_argument("--terminal-reward", choices=TERMINAL_REWARDS, default="sampled",
                        help="expected: the terminal reward's mean over --expected-paths coasts from the window's end "
                             "(the same expected return, less variance)")
    parser.add_argument("--expected-paths", type=cli.positive_int, metavar="K",
                        help=f"coasts the expected terminal reward averages (default {EXPECTED_PATHS})")
    parser.add_argument("--draws", type=cli.positive_int, metavar="K",
                        help="the bank of parameter draws the env plays (default: the task's, 512 with --coast fast)")
    parser.add_argument("--runs-dir", type=Path, default=Path("runs"), help="where the run folders are made")
    parser.add_argument("--resume", type=Path, metavar="RUN_DIR",
                        help="continue the run in RUN_DIR (any seed's folder) from its checkpoint")
    return parser


@functools.cache
def task(env_id: str, options: tuple[tuple[str, Any], ...] = ()) -> tuple[SailEnv, EnvParams]:
    """The JAX env and params of a task with ``options`` (``sail_env.jax.make``'s keywords as pairs: the
    coast and the terminal reward), one pair per process: the compiled functions below are keyed by both,
    so a second run in the same process reuses them. Built eagerly even when first asked for while one of
    them is traced (its arrays are then constants, not that trace's)."""
    with jax.ensure_compile_time_eval():
        return sail_env.jax.make(env_id, **dict(options))


def env_options(coast: str, expected_paths: int | None, terminal_reward: str,
                draws: int | None = None) -> tuple[tuple[str, Any], ...]:
    """The env options of the flags (:func:`task`'s), the defaults left out (a run of the task as registered
    has none); ``--terminal-reward expected`` averages over :data:`EXPECTED_PATHS` paths unless told."""
    if expected_paths is None:
        expected_paths = EXPECTED_PATHS if terminal_reward == "expected" else 0
    chosen = (("coast", coast), ("expected_paths", expected_paths), ("terminal_reward", terminal_reward),
              ("draws", draws))
    defaults = {"coast": "default", "expected_paths": 0, "terminal_reward": "sampled", "draws": None}
    return tuple((name, value) for name, value in chosen if value != defaults[name])


# The env's params enter these compiled functions as an argument (``params``: the task's own unless given), not as
# constants of the program: the fast coast's maps (~2 GB) as constants made XLA hold several copies (14 GB).
@functools.partial(jax.jit, static_argnames=("env_id", "config", "options"))
def init_states(keys: jax.Array, env_id: str, config: PPOConfig, options: tuple = (),
                params: EnvParams | None = None) -> RunState:
    """The seeds' runs before their first update (one key each)."""
    env, default = task(env_id, options)
    return jax.vmap(make_chunks(env, default if params is None else params, config).init)(keys)


@functools.partial(jax.jit, static_argnames=("env_id", "config", "updates", "options"))
def run_chunk(state: RunState, env_id: str, config: PPOConfig, updates: int, options: tuple = (),
              params: EnvParams | None = None) -> tuple[RunState, dict]:
    """``updates`` more updates of every seed's run, and their metrics (seeds, updates)."""
    env, default = task(env_id, options)
    chunks = make_chunks(env, default if params is None else params, config)
    return jax.vmap(lambda one: chunks.run(one, updates))(state)


@functools.partial(jax.jit, static_argnames=("env_id", "config", "episodes", "options"))
def deterministic_play(actor: dict, env_id: str, config: PPOConfig, episodes: int, seed: int, options: tuple = (),
                       params: EnvParams | None = None) -> tuple[jax.Array, jax.Array]:
    """Each seed's deterministic success on the same ``episodes`` fresh episodes of the JAX env (key
    ``seed``), and the share of its actions beyond the box (:func:`agents.jax_ppo.play_deterministic`)."""
    env, default = task(env_id, options)
    params = default if params is None else params
    return jax.vmap(lambda one: play_deterministic(env, params, config, one, jax.random.key(seed), episodes))(actor)


def save_policies(runs_dir: Path, progress: dict[str, Any], state: RunState, config: PPOConfig,
                  file: str = POLICY_FILE, rows: list[int] | None = None) -> None:
    """Each seed's deterministic actor as it is now (``file``, replaced whole), or only those of ``rows``."""
    for row, (seed, name) in enumerate(zip(progress["seeds"], progress["runs"])):
        if rows is not None and row not in rows:
            continue
        network = jax.tree.map(lambda a: np.asarray(a)[row], state.network)
        save_policy(runs_dir / name / file, actor_arrays(network),
                    {"env_id": progress["env_id"], "algo": ALGO, "seed": seed,
                     "timesteps": progress["updates"] * config.batch_size, "history": config.history,
                     "recurrent": config.recurrent, "episode_mean": config.episode_mean,
                     "tanh_mean": config.tanh_mean, "privileged_actor": config.privileged_actor})


def seed_keys(seeds: list[int]) -> jax.Array:
    return jax.vmap(jax.random.key)(np.array(seeds))


def save_checkpoint(path: Path, state: RunState, progress: dict[str, Any]) -> None:
    """The state (leading axis: the seeds; its leaves in ``jax.tree`` order, keys as their data) and the
    run's ``progress`` (JSON), written whole."""
    leaves = [jax.random.key_data(leaf) if jax.dtypes.issubdtype(leaf.dtype, jax.dtypes.prng_key) else leaf
              for leaf in jax.tree.leaves(state)]
    write_npz(path, {"progress": np.array(json.dumps(progress)),
                     **{f"leaf{i}": np.asarray(leaf) for i, leaf in enumerate(leaves)}})


def load_checkpoint(path: Path) -> tuple[RunState, dict[str, Any]]:
    """A checkpoint's state and progress, the state's structure that of a fresh run of its settings
    (``ValueError`` if the file does not fit it: another version of the code)."""
    data = read_npz(path)
    progress = json.loads(str(data["progress"]))
    arrays = [data[f"leaf{i}"] for i in range(len(data) - 1)]
    config = config_of(progress["config"])
    template = jax.eval_shape(functools.partial(init_states, env_id=progress["env_id"], config=config,
                                                options=options_of(progress)), seed_keys(progress["seeds"]))
    like, structure = jax.tree.flatten(template)
    if len(arrays) != len(like):
        raise ValueError(f"{path}: {len(arrays)} arrays, a run of its settings has {len(like)}")
    leaves = []
    for array, shape in zip(arrays, like):
        leaf = jax.random.wrap_key_data(array) if jax.dtypes.issubdtype(shape.dtype, jax.dtypes.prng_key) else array
        if leaf.shape != shape.shape or leaf.dtype != shape.dtype:
            raise ValueError(f"{path}: an array of {leaf.dtype}{list(leaf.shape)} where a run of its settings has "
                             f"{shape.dtype}{list(shape.shape)}")
        leaves.append(jax.numpy.asarray(leaf))
    return jax.tree.unflatten(structure, leaves), progress


def options_of(progress: dict[str, Any]) -> tuple[tuple[str, Any], ...]:
    """A run's env options (:func:`env_options`; none for runs begun before they were kept)."""
    return tuple((name, value) for name, value in progress.get("env_options", {}).items())


def write_runs(runs_dir: Path, progress: dict[str, Any], status: str, final: np.ndarray | None = None) -> None:
    """Each seed's run.json: the run's ``progress`` with that seed's own entries."""
    per_seed = ("success_per_update", "curve", "beyond_box", "exploration_std", "best")
    shared = {key: value for key, value in progress.items() if key != "seeds" and key not in per_seed}
    for row, (seed, name) in enumerate(zip(progress["seeds"], progress["runs"])):
        record = {"seed": seed, "seeds_trained_together": len(progress["seeds"]), "status": status, **shared,
                  **{key: progress[key][row] for key in per_seed if key in progress}}
        if final is not None:
            record[f"final_success_jax_{EVAL_EPISODES}"] = float(final[row])
        cli.write_whole(runs_dir / name / RUN_FILE, json.dumps(record, indent=1))


def config_of(settings: dict[str, Any]) -> PPOConfig:
    """The PPO settings among ``settings`` (parsed flags, or a run's stored ``config``)."""
    values = {f.name: settings[f.name] for f in dataclasses.fields(PPOConfig) if f.name in settings}
    return PPOConfig(**{**values, "hidden": tuple(values.get("hidden", PPOConfig.hidden))})


def resume_point(run_dir: Path) -> Path:
    """The checkpoint that continues the run in ``run_dir`` (:class:`cli.UsageError` if there is none)."""
    try:
        record = json.loads((run_dir / RUN_FILE).read_text())
    except (OSError, ValueError) as err:
        raise cli.UsageError(f"--resume {run_dir}: not a run folder of train_jax.py ({err})") from err
    if record.get("algo") != ALGO:
        raise cli.UsageError(f"--resume {run_dir}: not a run folder of train_jax.py (algo {record.get('algo')!r})")
    if record.get("status") != "running":  # runs from before checkpoints were written at their end only
        raise cli.UsageError(f"--resume {run_dir}: the run has finished; a new run starts without --resume")
    checkpoint = run_dir.parent / record["runs"][0] / CHECKPOINT_FILE
    if not checkpoint.is_file():
        raise cli.UsageError(f"--resume {run_dir}: its checkpoint {checkpoint} is missing")
    return checkpoint


def flag_of(parser: cli.Parser, dest: str) -> str:
    """The command-line flag that sets ``dest`` (``--timesteps`` for ``total_timesteps``)."""
    return next(action.option_strings[-1] for action in parser._actions if action.dest == dest)


def start_run(args: argparse.Namespace, config: PPOConfig, options: tuple, command: str,
              device: str) -> tuple[RunState, dict[str, Any]]:
    """A new run's folders, initial state and progress."""
    seeds = list(range(args.first_seed, args.first_seed + args.seeds))
    runs = [new_run_dir(args.env, ALGO, seed, args.runs_dir).name for seed in seeds]
    point_latest(args.runs_dir / runs[0])
    print(f"{ALGO} on {args.env}: {config.num_updates * config.batch_size:,} steps x {len(seeds)} seeds "
          f"({config.num_envs} envs) on {device}", flush=True)
    progress = {"env_id": args.env, "env_options": dict(options), "algo": ALGO, "seeds": seeds, "runs": runs,
                "config": dataclasses.asdict(config),
                "device": device, "jax": jax.__version__, "wall_s_with_compile": 0.0, "updates": 0,
                "steps_per_update": config.batch_size, "success_per_update": [[] for _ in seeds],
                "command": command, "resumed": []}
    return init_states(seed_keys(seeds), args.env, config, options, task(args.env, options)[1]), progress


def chunk_summary(success: np.ndarray) -> str:
    """The success of the episodes that ended in a chunk's rollouts, averaged over its updates and seeds."""
    seen = success[np.isfinite(success)]
    return f"rollouts' success {seen.mean():.1%}" if seen.size else "no episode ended yet"


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    command = " ".join(["python", "train_jax.py", *(sys.argv[1:] if argv is None else argv)])
    try:
        args = parser.parse_args(argv)
        if args.resume is not None:
            given = sorted(cli.given_flags(parser, argv) - set(RESUME_APPLIES))
            if given:
                raise cli.UsageError("--resume continues the run with its own settings: "
                                     f"drop {flag_of(parser, given[0])}")
            checkpoint = resume_point(args.resume)
            try:
                state, progress = load_checkpoint(checkpoint)
            except (OSError, ValueError, KeyError) as err:
                raise cli.UsageError(f"--resume {args.resume}: cannot read {checkpoint} ({err})") from err
            config, runs_dir, options = config_of(progress["config"]), checkpoint.parent.parent, options_of(progress)
        else:
            if args.env not in JAX_TASKS:
                raise cli.UsageError(f"--env {args.env}: the JAX backend has {', '.join(JAX_TASKS)}")
            config, runs_dir = config_of(vars(args)), args.runs_dir
            options = env_options(args.coast, args.expected_paths, args.terminal_reward, args.draws)
            if args.expected_paths is not None and args.terminal_reward != "expected":
                raise cli.UsageError("--expected-paths: the paths are for --terminal-reward expected")
            _, params = task(args.env, options)  # a bad option is refused here, by name (the fast coast is built)
            if (config.privileged_critic or config.privileged_actor) and len(params.factors) == 1:
                flag = "--privileged-critic" if config.privileged_critic else "--privileged-actor"
                raise cli.UsageError(f"{flag}: {args.env} draws no parameters per episode (no spread): "
                                     "there is nothing for it to see")
            cli.check_writable_dir(runs_dir, "--runs-dir")
    except (cli.UsageError, ValueError) as err:
        return cli.fail(err)

    start = time.perf_counter()
    device = str(jax.devices()[0].device_kind)
    if args.resume is None:
        state, progress = start_run(args, config, options, command, device)
    else:
        print(f"{ALGO} on {progress['env_id']}: resuming {progress['runs'][0]} at update {progress['updates']} "
              f"of {config.num_updates} on {device}", flush=True)
        progress["resumed"].append({"command": command, "device": device, "at_update": progress["updates"]})
    # A resumed run keeps its chunks unless told otherwise (runs begun before they were kept: the default).
    progress["checkpoint_every"] = args.checkpoint_every or progress.get("checkpoint_every", CHECKPOINT_EVERY)
    env_id, checkpoint = progress["env_id"], runs_dir / progress["runs"][0] / CHECKPOINT_FILE
    params = task(env_id, options)[1]
    wall_before, updates_before = progress["wall_s_with_compile"], progress["updates"]

    def save(state: RunState) -> None:
        progress["wall_s_with_compile"] = wall_before + time.perf_counter() - start
        save_checkpoint(checkpoint, state, progress)
        write_runs(runs_dir, progress, "running")

    if progress["updates"] == 0:
        save(state)  # an interruption during the first chunk resumes from here
    try:
        while progress["updates"] < config.num_updates:
            updates = min(progress["checkpoint_every"], config.num_updates - progress["updates"])
            chunk_start = time.perf_counter()
            state, metrics = run_chunk(state, env_id, config, updates, options, params)
            success = np.asarray(metrics["success"])  # waits for the chunk
            trained_s = time.perf_counter() - chunk_start
            for row, curve in enumerate(success):
                progress["success_per_update"][row] += [None if np.isnan(v) else float(v) for v in curve]
            progress["updates"] += updates
            curve, beyond = map(np.asarray, deterministic_play(state.network["actor"], env_id, config,
                                                               CURVE_EPISODES, CURVE_KEY, options, params))
            best, improved = progress.setdefault("best", [None for _ in progress["seeds"]]), []
            for row, rate in enumerate(curve):  # runs begun before a record was kept start it at their resume
                point = [progress["updates"] * config.batch_size, float(rate)]
                progress.setdefault("curve", [[] for _ in progress["seeds"]])[row].append(point)
                progress.setdefault("beyond_box", [[] for _ in progress["seeds"]])[row].append(
                    [point[0], float(beyond[row])])
                at_end = np.asarray(metrics["std_at_end"][row])
                progress.setdefault("exploration_std", [[] for _ in progress["seeds"]])[row].append(
                    [point[0], float(np.mean(metrics["std"][row])),
                     float(np.nanmean(at_end)) if np.isfinite(at_end).any() else None])
                if best[row] is None or point[1] > best[row][1]:
                    best[row] = point
                    improved.append(row)
            scored_s = time.perf_counter() - chunk_start - trained_s
            save_policies(runs_dir, progress, state, config)
            save_policies(runs_dir, progress, state, config, BEST_POLICY_FILE, improved)
            save(state)
            speed = len(progress["seeds"]) * updates * config.batch_size / trained_s  # the first chunk's: with compiling
            print(f"update {progress['updates']} of {config.num_updates}: {chunk_summary(success)}; deterministic "
                  f"{', '.join(f'{rate:.1%}' for rate in curve)} on {CURVE_EPISODES} episodes (actions beyond "
                  f"the box {', '.join(f'{share:.0%}' for share in beyond)}; {speed:,.0f} "
                  f"env-steps/s training, {scored_s:.0f} s scoring)", flush=True)
    except KeyboardInterrupt:
        print(f"interrupted: {progress['updates']} of {config.num_updates} updates checkpointed; continue with "
              f"python train_jax.py --resume {runs_dir / progress['runs'][0]}", file=sys.stderr)
        return 130

    final = np.asarray(deterministic_play(state.network["actor"], env_id, config, EVAL_EPISODES, EVAL_KEY, options,
                                          params)[0])
    for row, (seed, name) in enumerate(zip(progress["seeds"], progress["runs"])):
        best = progress.get("best", [None] * len(progress["seeds"]))[row]  # none: resumed after its last chunk
        print(f"seed {seed}: {float(final[row]):.1%} success on {EVAL_EPISODES:,} JAX episodes -> "
              f"{runs_dir / name / POLICY_FILE}" + (f"; the best on the curve, {best[1]:.1%} at {best[0]:,} steps -> "
                                                    f"{runs_dir / name / BEST_POLICY_FILE}" if best else ""))
    progress["wall_s_with_compile"] = wall_before + time.perf_counter() - start
    write_runs(runs_dir, progress, "finished", final)
    session = time.perf_counter() - start
    steps = len(progress["seeds"]) * (config.num_updates - updates_before) * config.batch_size
    print(f"finished: {len(progress['seeds'])} seeds in {session:.1f} s with compilation this session "
          f"({steps / session:,.0f} env-steps/s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
