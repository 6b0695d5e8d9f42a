"""Paired evaluation of agents on a lightsail-gym task: report.json, episodes.csv, report.md, plots.

    python evaluate.py --agent passive --agent lqr --agent runs/LightSail-v0-ppo-0/best_model.zip
    python evaluate.py --env LightSailRealistic-v0 --agent lqg --agent PATH.zip --episodes 200

``--agent`` is ``passive``, ``lqr``, ``lqg``, ``lqg-mm`` (3D tasks: a bank of LQGs on a grid of models,
acting with the one that predicts best, agents/adaptive.py), ``lqg-mm-offset`` (the same bank estimating
a constant beam offset, as the uncertain task's pointing bias), a ceiling ``lqr-oracle`` or ``lqg-oracle`` (bounds that
read the simulator's true state and parameter draw, agents/oracle.py; no station could field them)
or the path of a model saved by ``train.py`` (loaded with the VecNormalize statistics beside it, acting deterministically; its run's
``run.json`` says whether it needs them and which env it was trained on).
Episode ``i`` is ``env.reset(seed=seed + i)`` for every agent, so all agents face the
same start states, cut-off times and noise draws: the comparison is paired. Each agent's success
is reported twice: sampled (the episode's own coast to cut-off, the task as registered) and
expected (``--expected-paths K`` further coasts from each window's end, the same episodes' numbers:
the probability of success given the window's end, without the coast's coin flip, so the same
episodes tell agents apart with a narrower interval). From the second agent on, the report gives
each one's paired difference from the first, both ways.

A bad argument, an unusable model, an unwritable ``--out`` or one that holds a report already
(``--overwrite`` replaces it) is one line on stderr and exit code 2, before any episode runs and
with nothing written. The report is written whole or not at all: made in a hidden folder beside
``--out`` and renamed into place, so Ctrl-C, a full disk or another evaluation into the same
``--out`` leaves the earlier report as it was, never a mix. Model ``.zip`` and statistics ``.pkl``
files are unpickled, which runs code: load only files you trust.
"""

from __future__ import annotations

import argparse
import contextlib
import csv
import errno
import json
import math
import os
import secrets
import shutil
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from typing import Any

import gymnasium as gym
import matplotlib
import numpy as np
import scipy.stats
from tqdm import tqdm

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import sail_env  # noqa: F401, E402  (registers the env ids)
from agents import Agent, LQGAgent, LQRAgent, PassiveAgent  # noqa: E402
from agents.adaptive import MultipleModelLQGAgent, OffsetFreeMultipleModelLQGAgent  # noqa: E402
from agents.oracle import OracleLQGAgent, OracleLQRAgent, attach  # noqa: E402
from agents.residual import RESIDUAL_BASES, ResidualAgent  # noqa: E402
from agents.mlp_policy import MlpPolicyAgent  # noqa: E402
from agents.cli import (HelpFormatter, OneLineWarnings, Parser, UsageError, check_writable_dir, describe,  # noqa: E402
                        fail)
from agents.sb3 import ModelLoadError, SB3Agent, one_thread_per_process, versions  # noqa: E402
from sail_env.core.spec import MAX_PATHS, EpisodeSpec  # noqa: E402
from sail_env.physics.pointing import POINTING_TOLERANCE_RAD  # noqa: E402
from sail_env.tasks import TASKS  # noqa: E402

BASELINES: dict[str, Callable[[EpisodeSpec], Agent]] = {"passive": PassiveAgent, "lqr": LQRAgent, "lqg": LQGAgent,
                                                        # Bounds that read the simulator's truth (agents/oracle.py).
                                                        "lqr-oracle": OracleLQRAgent, "lqg-oracle": OracleLQGAgent,
                                                        # Multiple-model adaptive LQG for the 3D tasks (agents/adaptive.py),
                                                        # and the same bank estimating a beam offset.
                                                        "lqg-mm": MultipleModelLQGAgent,
                                                        "lqg-mm-offset": OffsetFreeMultipleModelLQGAgent}
#: Apart from the seeds train.py trains and selects models on.
DEFAULT_SEED = 100_000
#: What the trajectory plot shows, per lateral axis: the offset, the tilt that moves it and the beam
#: inputs on it (docs/physics.md §9: the planar (X, θ) is the 3D model's (x, θy); θx moves y).
TRAJECTORY_AXES = {False: (("x", "theta", "beam_offset", "beam_tilt"),),
                   True: (("x", "theta_y", "beam_offset_x", "beam_tilt_x"),
                          ("y", "theta_x", "beam_offset_y", "beam_tilt_y"))}
#: Episodes stepped as one batch: the progress bar moves once a batch; memory stays bounded.
BATCH_EPISODES = 50
#: Without a terminal (a log), a line at most this often while an agent plays [s]: not minutes of silence.
LOG_EVERY_S = 30.0
#: Further coasts per episode behind the expected success (``--expected-paths``): on
#: LightSailUncertain-v2 they add ~30 % to an evaluation's time (64: ~170 %).
EXPECTED_PATHS = 16


def make_agent(spec: str, env: gym.Env, raw_observations_ok: bool = False) -> Agent:
    """A baseline by name, or a trained model by path (:class:`ModelLoadError` if unusable).

    A model whose run was trained on another env id is used, with a one-line warning on stderr.
    """
    if spec in BASELINES:
        return BASELINES[spec](env.unwrapped.episode_spec)
    if not Path(spec).is_file():
        raise ModelLoadError(not_an_agent(spec))
    if Path(spec).suffix == ".npz":  # a JAX learner's actor (train_jax.py), played in NumPy
        return load_policy(spec, env)
    agent = SB3Agent.load(spec, env.observation_space.shape, raw_observations_ok)
    if agent.trained_env is not None and agent.trained_env != env.spec.id:
        print(f"warning: {spec} was trained on {agent.trained_env} (its run.json), "
              f"evaluated here on {env.spec.id}", file=sys.stderr)
    if agent.residual is not None:  # the policy corrects a classical controller, which runs beside it
        base, scale = agent.residual
        return ResidualAgent(agent, RESIDUAL_BASES[base](env.unwrapped.episode_spec), scale)
    return agent


def load_policy(spec: str, env: gym.Env) -> MlpPolicyAgent:
    """A ``policy.npz`` of ``train_jax.py`` as an agent named as SB3's models are, ``algo:run/stem`` (so a
    run's ``policy`` and ``best_policy`` are two agents; ``ModelLoadError`` if unreadable or for observations
    of another size)."""
    path = Path(spec).resolve()  # runs/latest/policy.npz is named by the run the link points at now
    try:
        agent = MlpPolicyAgent(spec)
        agent.name = f"{agent.meta.get('algo', 'jax_ppo')}:{path.parent.name}/{path.stem}"
    except (OSError, ValueError, KeyError) as err:
        raise ModelLoadError(f"{spec}: not a policy file of train_jax.py ({err})") from err
    if agent.obs_size != env.observation_space.shape[-1]:
        raise ModelLoadError(f"{spec}: its policy takes observations of size {agent.obs_size} "
                             f"({agent.meta.get('env_id')}), {env.spec.id}'s are {env.observation_space.shape[-1]}")
    if agent.meta.get("env_id") not in (None, env.spec.id):
        print(f"warning: {spec} was trained on {agent.meta['env_id']}, evaluated here on {env.spec.id}", file=sys.stderr)
    return agent


def not_an_agent(spec: str) -> str:
    """Why ``spec`` is no agent and, when it names a path in a folder, what that folder holds: a
    short run saves no ``best_model.zip``, and the README's next command names one."""
    message = f"{spec}: neither a baseline ({', '.join(BASELINES)}) nor a model file"
    path = Path(spec)
    folder = path if path.is_dir() else path.parent
    if not (os.sep in spec or path.suffix == ".zip") or not folder.is_dir():
        return message
    models = sorted(p.name for pattern in ("*.zip", "*.npz") for p in folder.glob(pattern))
    checkpoints = list((folder / "checkpoints").glob("*.zip"))
    if models:
        return f"{message}; {folder} holds {', '.join(models)}: pass one of those"
    if checkpoints:
        return f"{message}; {folder} holds no model, only {len(checkpoints)} checkpoints in {folder / 'checkpoints'}"
    return f"{message}; {folder} holds no model (.zip, or a JAX run's .npz)"


def run_episode(env: gym.Env, agent: Agent, seed: int, trajectory: bool = False) -> dict[str, Any]:
    """One seeded episode: start state, outcome, return, and the trajectory if asked for (rows: t [s],
    then per lateral axis of :data:`TRAJECTORY_AXES` its offset [m], tilt [rad], beam offset [m] and
    beam tilt [rad]: planar X, θ, d, ψ; 3D those of x, then of y)."""
    plant = env.unwrapped.episode_spec.plant
    action_scale = env.unwrapped.episode_spec.action_scale
    columns = [name for axis in TRAJECTORY_AXES["theta_x" in plant.state_names] for name in axis]
    attach(agent, env)
    obs, info = env.reset(seed=seed)
    agent.reset()
    start = info["state"]
    steps: list[list[float]] = []
    total, done = 0.0, False
    while not done:
        action = np.asarray(agent.act(obs), dtype=np.float32)
        obs, reward, terminated, truncated, info = env.step(action)
        total += reward
        done = terminated or truncated
        if trajectory:
            values = {**info["state"], **dict(zip(plant.input_names, np.clip(action, -1, 1) * action_scale))}
            steps.append([info["t"], *(values[name] for name in columns)])
    episode = {"seed": seed, **{f"{k}0": v for k, v in start.items()}, "cutoff_s": info["cutoff_s"],
               "terminal_pointing_rad": info["terminal_pointing_rad"],
               "success": bool(info["is_success"]), "diverged": bool(info["diverged"]), "return": total}
    if trajectory:
        episode["trajectory"] = np.array(steps)
    return episode


def start_columns(episode: dict[str, Any]) -> list[str]:
    """The start-state entries of an episode's record (``x0``, ``vx0``, …: state names + 0)."""
    return [key for key in episode if key.endswith("0") and key != "seed"]


def start_tilt(episode: dict[str, Any]) -> float:
    """The tilt's magnitude at the start of control [rad] (planar ``|θ|``, 3D ``√(θx² + θy²)``)."""
    if "theta0" in episode:
        return abs(episode["theta0"])
    return math.hypot(episode["theta_x0"], episode["theta_y0"])


def wilson_interval(successes: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """Wilson score interval for a binomial proportion."""
    if n == 0:
        return 0.0, 1.0
    p = successes / n
    centre = (p + z**2 / (2 * n)) / (1 + z**2 / n)
    half = z * math.sqrt(p * (1 - p) / n + z**2 / (4 * n**2)) / (1 + z**2 / n)
    return max(0.0, centre - half), min(1.0, centre + half)


def finite_or_none(value: float) -> float | None:
    """JSON has no inf or NaN: diverged episodes point nowhere (null)."""
    return float(value) if math.isfinite(value) else None


#: Resamples of the paired bootstrap (:func:`paired_difference`).
BOOTSTRAP = 10_000


def paired_difference(success: np.ndarray, reference: np.ndarray, rng_seed: int = 0) -> dict[str, Any]:
    """Success of an agent minus a reference's over the same episodes: the difference, its 95 % paired
    bootstrap interval (episodes resampled together, :data:`BOOTSTRAP` times, a fixed seed) and, for
    one run's booleans, McNemar's exact two-sided p-value on the discordant pairs (``wins``: the agent
    succeeds where the reference fails; ``losses``: the reverse). ``success`` is (episodes,) or, for
    several seeds of a learner, (seeds, episodes), whose mean over the seeds is compared: booleans, or
    each episode's probability of success (the expected success)."""
    success, reference = np.asarray(success), np.asarray(reference)
    binary = success.dtype == bool and reference.dtype == bool
    runs = success.reshape(-1, success.shape[-1]) if success.ndim else success
    if success.ndim not in (1, 2) or reference.ndim != 1 or runs.shape[1] != len(reference) or not len(reference):
        raise ValueError(f"success must be (episodes,) or (seeds, episodes) over the reference's "
                         f"(episodes,) episodes, got {success.shape} and {reference.shape}")
    diff = runs.mean(axis=0) - reference.astype(float)
    rng = np.random.default_rng(rng_seed)
    resampled = diff[rng.integers(0, len(diff), (BOOTSTRAP, len(diff)))].mean(axis=1)
    out = {"difference": float(diff.mean()), "ci95": [float(np.quantile(resampled, 0.025)),
                                                      float(np.quantile(resampled, 0.975))]}
    if success.ndim == 1 and binary:
        wins, losses = int(np.sum(success & ~reference)), int(np.sum(~success & reference))
        p = 1.0 if wins + losses == 0 else float(scipy.stats.binomtest(wins, wins + losses, 0.5).pvalue)
        out.update(wins=wins, losses=losses, mcnemar_p=p)
    return out


def summarise(episodes: list[dict[str, Any]]) -> dict[str, Any]:
    """Success rate with its Wilson 95 % interval, the expected success (if the episodes have it) with
    its normal 95 % interval, pointing quantiles, mean return."""
    n, wins = len(episodes), sum(e["success"] for e in episodes)
    pointing = np.array([e["terminal_pointing_rad"] for e in episodes])
    summary = {"episodes": n, "success_rate": wins / n, "success_ci95": list(wilson_interval(wins, n))}
    if "expected_success" in episodes[0]:
        expected = np.array([e["expected_success"] for e in episodes])
        half = 1.96 * expected.std(ddof=1) / math.sqrt(n) if n > 1 else math.inf
        summary.update(expected_success=float(expected.mean()),
                       expected_success_ci95=[max(0.0, expected.mean() - half), min(1.0, expected.mean() + half)])
    return {**summary, "terminal_pointing_rad": {"median": finite_or_none(np.median(pointing)),
                                                 "p90": finite_or_none(np.quantile(pointing, 0.9, method="lower")),
                                                 "max": finite_or_none(pointing.max())},
            "diverged": sum(e["diverged"] for e in episodes),
            "mean_return": float(np.mean([e["return"] for e in episodes]))}


def paired_differences(results: dict[str, list[dict[str, Any]]]) -> dict[str, dict[str, Any]]:
    """Each agent after the first against the first over the same episodes (:func:`paired_difference`):
    ``success`` (sampled) and, where the episodes have it, ``expected_success``."""
    (first, reference), *others = results.items()
    out = {}
    for name, episodes in others:
        out[name] = {key: paired_difference(np.array([e[key] for e in episodes]), np.array([e[key] for e in reference]))
                     for key in ("success", "expected_success") if key in reference[0]}
    return {"reference": first, "agents": out} if out else {}


# ---------------------------------------------------------------------- plots
MARKERS = "osD^vPX*"
LINESTYLES = ("-", "--", ":", "-.")
#: Curves closer than this fraction of a panel's range are said to coincide.
COINCIDE = 0.01


def agent_styles(names: Iterable[str]) -> dict[str, dict[str, Any]]:
    """One look per agent, the same in every plot. Earlier agents are drawn wider, with larger
    hollow markers, under later ones: curves that coincide stay visible as a bundle."""
    names = list(names)
    last = max(len(names) - 1, 1)
    return {name: {"color": f"C{i}", "marker": MARKERS[i % len(MARKERS)], "ls": LINESTYLES[i % len(LINESTYLES)],
                   "lw": 1.0 + 2.0 * (last - i) / last, "ms": 4.0 + 3.0 * (last - i) / last,
                   "mfc": "none", "mew": 1.2, "zorder": 2 + i, "label": name}
            for i, name in enumerate(names)}


def coinciding(curves: dict[str, np.ndarray]) -> list[list[str]]:
    """Groups of two or more agents whose curves differ by less than :data:`COINCIDE` of the range."""
    values = [np.asarray(c, dtype=float) for c in curves.values()]
    if len({v.shape for v in values}) != 1:
        return []
    finite = np.concatenate([v[np.isfinite(v)] for v in values])
    span = np.ptp(finite) if finite.size else 0.0
    groups: list[tuple[np.ndarray, list[str]]] = []
    for name, value in zip(curves, values):
        for first, members in groups:
            with np.errstate(invalid="ignore"):  # inf − inf (both diverged) is NaN: it does not part them
                gap = np.nanmax(np.abs(value - first), initial=0.0)
            if gap <= COINCIDE * span:
                members.append(name)
                break
        else:
            groups.append((value, [name]))
    return [members for _, members in groups if len(members) > 1]


def note_coinciding(ax: plt.Axes, curves: dict[str, np.ndarray]) -> None:
    """Say above the panel which curves lie on top of each other."""
    notes = [" = ".join(group) for group in coinciding(curves)]
    if notes:
        ax.set_title(f"coincide (< {COINCIDE:.0%} of range): " + "; ".join(notes), loc="right", fontsize=7,
                     color="0.3")


def save_with_legend_above(fig: plt.Figure, ax: plt.Axes, path: Path, env_id: str) -> None:
    """The legend in a band above the panels, where it covers no curve, the env's id in the bottom
    corner (a plot names what it shows); save and close."""
    fig.text(0.005, 0.005, env_id, fontsize=7, color="0.4", ha="left", va="bottom")
    handles, labels = ax.get_legend_handles_labels()
    fig.legend(handles, labels, loc="upper center", ncol=min(len(labels), 3), fontsize=8, frameon=False)
    rows = -(-len(labels) // 3)
    fig.tight_layout(rect=(0, 0, 1, 1 - 0.3 * rows / fig.get_figheight()))
    fig.savefig(path, dpi=120)
    plt.close(fig)


def plot_pointing(results: dict[str, list[dict[str, Any]]], path: Path, env_id: str) -> None:
    """Empirical CDF of terminal pointing per agent, log axis, 10 nrad line (diverged: never reached);
    agents whose curves lie on top of each other (in log10) are named above the panel."""
    fig, ax = plt.subplots(figsize=(6.4, 4))
    curves = {}
    for name, style in agent_styles(results).items():
        values = np.sort([e["terminal_pointing_rad"] for e in results[name]])
        ax.step(values, np.arange(1, len(values) + 1) / len(values), where="post",
                **{k: v for k, v in style.items() if k not in ("marker", "ms", "mfc", "mew")})
        with np.errstate(divide="ignore"):
            curves[name] = np.log10(values)
    note_coinciding(ax, curves)
    ax.axvline(POINTING_TOLERANCE_RAD, color="k", ls="--", lw=1, label="10 nrad")
    ax.set(xscale="log", xlabel="terminal pointing [rad]", ylabel="fraction of episodes ≤ x", ylim=(0, 1.02))
    save_with_legend_above(fig, ax, path, env_id)


#: Markers per curve of a trajectory plot (they tell the agents apart; the line is the data).
TRAJECTORY_MARKERS = 10


def marker_steps(steps: int, curve: int) -> list[int]:
    """Where curve number ``curve`` of ``steps`` points puts its markers: at random steps (seeded by
    the curve's number), because markers at any regular spacing sample the 0.09 s oscillation into
    a false slow wave (aliasing); each curve draws its own, so they do not hide each other."""
    rng = np.random.default_rng(curve)
    return sorted(rng.choice(steps, size=min(TRAJECTORY_MARKERS, steps), replace=False).tolist())


#: The trajectory plot's panels, a column per lateral axis of :data:`TRAJECTORY_AXES`, and the
#: columns' titles (none for the planar model's one).
TRAJECTORY_LABELS = {False: (("X [mm]", "θ [mrad]", "beam offset d [mm]", "beam tilt ψ [mrad]"),),
                     True: (("x [mm]", "θy [mrad]", "beam offset on x [mm]", "beam tilt on x [mrad]"),
                            ("y [mm]", "θx [mrad]", "beam offset on y [mm]", "beam tilt on y [mrad]"))}
TRAJECTORY_TITLES = {False: ("",), True: ("the 3D sail's x axis", "its y axis")}


def plot_trajectories(trajectories: dict[str, np.ndarray], path: Path, env_id: str, three_d: bool) -> None:
    """Offset, tilt and the beam inputs over the control window (rows of :func:`run_episode`), every
    agent from the same start; in 3D a column for each lateral axis, x then y.

    The beam offset and tilt are in the units of X and θ: they act through ``X − d`` and ``θ − ψ``.
    """
    columns = TRAJECTORY_LABELS[three_d]
    fig, axes = plt.subplots(4, len(columns), figsize=(6.4 * len(columns), 7.8), sharex=True, squeeze=False)
    styles = agent_styles(trajectories)
    for c, (labels, title) in enumerate(zip(columns, TRAJECTORY_TITLES[three_d])):
        axes[0, c].set_title(title, loc="left", fontsize=9)
        for k, (ax, label) in enumerate(zip(axes[:, c], labels)):
            curves = {name: steps[:, 1 + 4 * c + k] * 1e3 for name, steps in trajectories.items()}
            for i, (name, curve) in enumerate(curves.items()):
                ax.plot(trajectories[name][:, 0], curve, markevery=marker_steps(len(curve), i), **styles[name])
            ax.set_ylabel(label, fontsize=8)
            note_coinciding(ax, curves)
        axes[-1, c].set_xlabel("flight time [s]")
    save_with_legend_above(fig, axes[0, 0], path, env_id)


def plot_success_vs_tilt(results: dict[str, list[dict[str, Any]]], path: Path, env_id: str, three_d: bool,
                         bins: int = 8) -> None:
    """Success rate in bins of the tilt's size at the start of control (planar ``|θ|``, 3D the total
    tilt ``√(θx² + θy²)``; at least 10 episodes a bin)."""
    tilts = np.array([start_tilt(e) for e in next(iter(results.values()))]) * 1e3
    bins = max(1, min(bins, len(tilts) // 10))
    edges = np.quantile(tilts, np.linspace(0, 1, bins + 1))
    which = np.clip(np.searchsorted(edges, tilts, side="right") - 1, 0, bins - 1)
    centres = [tilts[which == b].mean() for b in range(bins)]
    fig, ax = plt.subplots(figsize=(6.4, 4))
    rates = {}
    for name, style in agent_styles(results).items():
        success = np.array([e["success"] for e in results[name]], dtype=float)
        rates[name] = np.array([success[which == b].mean() for b in range(bins)])
        ax.plot(centres, rates[name], **style)
    note_coinciding(ax, rates)
    tilt = "total tilt √(θx² + θy²)" if three_d else "|θ|"
    ax.set(xlabel=f"{tilt} at start of control [mrad] (bins of equal count)", ylabel="success rate",
           ylim=(-0.02, 1.05))
    save_with_legend_above(fig, ax, path, env_id)


# ---------------------------------------------------------------------- report
#: The files of a report. A folder that holds only these is a report's (``--overwrite`` replaces it).
REPORT_FILES = ("report.json", "episodes.csv", "pointing.png", "trajectories.png", "success_vs_tilt.png",
                "report.md")


def unused_report_dir(base: Path) -> Path:
    """The default ``--out``: ``base``, or the first of ``base_2``, ``base_3``, … that holds nothing
    (as train.py numbers its run folders), so that running the same command again keeps the
    earlier report. (An explicit ``--out`` that holds one is refused instead.)"""
    for k in range(1, 10_000):
        path = base if k == 1 else base.with_name(f"{base.name}_{k}")
        if not path.exists() or (path.is_dir() and not any(path.iterdir())):
            return path
    raise UsageError(f"{base}: no free report folder up to _9999; choose --out")


def check_out(out: Path, overwrite: bool) -> None:
    """Refuse now, not after the episodes (:class:`UsageError`): an ``out`` that holds a report
    (unless ``overwrite``) or files of another kind, or where the report cannot be made (it is made
    in a folder beside ``out``)."""
    check_writable_dir(out, "--out")
    if not out.is_dir():  # made when the report is written (check_writable_dir refused a file)
        return
    others = sorted(p.name for p in out.iterdir() if p.name not in REPORT_FILES)
    if others:
        raise UsageError(f"--out {out} holds files that are not a report's ({', '.join(others[:3])}"
                         f"{', …' if len(others) > 3 else ''}): choose a new or empty folder")
    if any(out.iterdir()) and not overwrite:
        raise UsageError(f"--out {out} holds a report already: --overwrite replaces it, or choose another --out")
    check_writable_dir(out.resolve().parent, "--out")


@contextlib.contextmanager
def interrupts_deferred() -> Iterator[None]:
    """Ctrl-C during the block is raised at its end: a swap of two folders is not cut in two.
    (Outside the main thread, where no signal is delivered, nothing to do.)"""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    received: list[int] = []
    previous = signal.signal(signal.SIGINT, lambda signum, frame: received.append(signum)) or signal.SIG_DFL
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
    if received and callable(previous):
        previous(signal.SIGINT, None)


def publish(staging: Path, out: Path, overwrite: bool) -> None:
    """Rename the finished report folder ``staging`` to ``out``: one step, so ``out`` holds one report
    whole, never a mix. The rename replaces no folder that holds anything: a report another evaluation
    published meanwhile refuses this one (:class:`UsageError`) unless ``overwrite``, when that report is
    moved aside first and removed once this one is in place (put back if the rename fails)."""
    replaced: list[Path] = []
    with interrupts_deferred():
        try:
            while True:
                try:
                    staging.rename(out)
                    break
                except OSError as err:
                    if err.errno not in (errno.ENOTEMPTY, errno.EEXIST):
                        raise
                    if not overwrite:
                        raise UsageError(f"--out {out}: another evaluation wrote its report there while this one "
                                         "ran; it is kept (--overwrite replaces it)") from err
                aside = out.parent / f".{out.name}.replaced-{os.getpid()}-{secrets.token_hex(4)}"
                with contextlib.suppress(FileNotFoundError):  # another evaluation moved it aside first
                    out.rename(aside)
                    replaced.append(aside)
        except BaseException:
            if replaced and not out.exists():
                replaced.pop().rename(out)
            raise
        finally:
            for folder in replaced:
                shutil.rmtree(folder, ignore_errors=True)


def write_report(out: Path, env_id: str, config: dict[str, Any], results: dict[str, list[dict[str, Any]]],
                 trajectories: dict[str, np.ndarray], overwrite: bool = False) -> dict[str, Any]:
    """The report (:data:`REPORT_FILES`) in ``out``, whole or not at all: written in a hidden folder
    beside it, then published (:func:`publish`); after an error or Ctrl-C that folder is removed and
    ``out`` is as it was."""
    out = out.resolve()  # a link to a folder: the folder; "." has a name
    made = [folder for folder in out.parents if not folder.exists()]  # innermost first
    out.parent.mkdir(parents=True, exist_ok=True)
    staging = out.parent / f".{out.name}.writing-{os.getpid()}-{secrets.token_hex(4)}"
    try:
        staging.mkdir()
        report = write_report_files(staging, env_id, config, results, trajectories)
        publish(staging, out, overwrite)
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        for folder in made:  # the folders made for it, unless another evaluation uses them now
            with contextlib.suppress(OSError):
                folder.rmdir()
        raise
    return report


def write_report_files(out: Path, env_id: str, config: dict[str, Any], results: dict[str, list[dict[str, Any]]],
                       trajectories: dict[str, np.ndarray]) -> dict[str, Any]:
    """report.json, episodes.csv, the plots and report.md in the folder ``out``, which exists."""
    summary = {name: summarise(episodes) for name, episodes in results.items()}
    report = {"agents": summary, "paired": paired_differences(results), "env": env_id, "config": config,
              "versions": versions()}
    (out / "report.json").write_text(json.dumps(report, indent=2, allow_nan=False), encoding="utf-8")

    first = next(iter(results.values()))[0]
    columns = ["agent", "episode", "seed", *start_columns(first), "cutoff_s", "terminal_pointing_rad", "success",
               *(["expected_success"] if "expected_success" in first else []), "diverged", "return"]
    with (out / "episodes.csv").open("w", newline="", encoding="utf-8") as file:
        writer = csv.DictWriter(file, columns, extrasaction="ignore")
        writer.writeheader()
        for name, episodes in results.items():
            for i, episode in enumerate(episodes):
                writer.writerow({"agent": name, "episode": i, **episode})

    three_d = "theta_x0" in next(iter(results.values()))[0]
    plot_pointing(results, out / "pointing.png", env_id)
    plot_trajectories(trajectories, out / "trajectories.png", env_id, three_d)
    plot_success_vs_tilt(results, out / "success_vs_tilt.png", env_id, three_d)
    (out / "report.md").write_text(markdown(env_id, config, summary, report["paired"]), encoding="utf-8")
    return report


def fmt(value: float | None) -> str:
    return "diverged" if value is None else f"{value:.2e}"


def fmt_rad(value: float | None) -> str:
    """A pointing with its unit; a diverged one has none ("diverged", not "diverged rad")."""
    return "diverged" if value is None else f"{value:.2e} rad"


def difference_line(key: str, d: dict[str, Any]) -> str:
    """One paired difference in points with its interval (and McNemar's p for the sampled success)."""
    lo, hi = d["ci95"]
    p = f", McNemar p = {d['mcnemar_p']:.2g}" if "mcnemar_p" in d else ""
    return f"{key.replace('_', ' ')} {100 * d['difference']:+.1f} pts ({100 * lo:+.1f} … {100 * hi:+.1f}{p})"


def markdown(env_id: str, config: dict[str, Any], summary: dict[str, dict[str, Any]],
             paired: dict[str, Any]) -> str:
    """The results table, the paired differences from the first agent and the plots."""
    expected = "expected_success" in next(iter(summary.values()))
    lines = [f"# {env_id}: {config['episodes']} paired episodes (seeds {config['seed']}…"
             f"{config['seed'] + config['episodes'] - 1})", "",
             "| agent | success (≤ 10 nrad) | 95 % CI |" + (" expected success | 95 % CI |" if expected else "") +
             " median pointing [rad] | p90 | max | diverged | mean return |",
             "|---|---:|---:|" + ("---:|---:|" if expected else "") + "---:|---:|---:|---:|---:|"]
    for name, s in summary.items():
        p, (lo, hi) = s["terminal_pointing_rad"], s["success_ci95"]
        cells = f" {s['expected_success']:.1%} | {s['expected_success_ci95'][0]:.1%}–{s['expected_success_ci95'][1]:.1%} |" \
            if expected else ""
        lines.append(f"| {name} | {s['success_rate']:.1%} | {lo:.1%}–{hi:.1%} |{cells} {fmt(p['median'])} | "
                     f"{fmt(p['p90'])} | {fmt(p['max'])} | {s['diverged']} | {s['mean_return']:.2f} |")
    if paired:
        lines += ["", f"Paired differences from {paired['reference']} (95 % paired bootstrap intervals):", ""]
        lines += [f"- {name}: " + "; ".join(difference_line(key, d[key]) for key in d)
                  for name, d in paired["agents"].items()]
    lines += ["", "![terminal pointing](pointing.png)", "",
              "![trajectories from the start of episode 0](trajectories.png)", "",
              "![success rate against initial tilt](success_vs_tilt.png)", ""]
    return "\n".join(lines)


def run_batch(env_id: str, agent: Agent, episodes: int, seed: int,
              env_kwargs: dict[str, Any] | None = None, rewards: bool = False) -> list[dict[str, Any]]:
    """Episodes ``seed + i`` all at once on the vector env (the same episodes as :func:`run_episode`'s);
    ``env_kwargs`` change the task's keywords (``expected_paths``: each episode's ``expected_success``
    too); ``rewards``: each episode's rewards step by step too (``"rewards"``, the last one the terminal
    step's)."""
    envs = gym.make_vec(env_id, num_envs=episodes, vectorization_mode="vector_entry_point", **(env_kwargs or {}))
    attach(agent, envs)
    obs, _ = envs.reset(seed=seed)
    agent.reset()
    start = envs.unwrapped.state.x.copy()
    running = np.ones(episodes, dtype=bool)
    returns, scores = np.zeros(episodes), {}
    steps: list[list[float]] = [[] for _ in range(episodes)]
    while running.any():
        obs, reward, terminated, _, info = envs.step(np.asarray(agent.act(obs), dtype=np.float32))
        returns += np.where(running, reward, 0.0)
        if rewards:
            for i in np.flatnonzero(running):
                steps[i].append(float(reward[i]))
        ended = terminated & running
        if ended.any():
            final = info["final_info"]
            for key in ("cutoff_s", "terminal_pointing_rad", "is_success", "diverged", "expected_success"):
                if key in final:
                    scores.setdefault(key, np.zeros(episodes))[ended] = final[key][ended]
        running &= ~terminated
    envs.close()
    names = envs.unwrapped.episode_spec.plant.state_names
    return [{"seed": seed + i, **{f"{k}0": float(start[i, j]) for j, k in enumerate(names)},
             "cutoff_s": float(scores["cutoff_s"][i]), "terminal_pointing_rad": float(scores["terminal_pointing_rad"][i]),
             "success": bool(scores["is_success"][i]), "diverged": bool(scores["diverged"][i]),
             "return": float(returns[i]), **({"rewards": steps[i]} if rewards else {}),
             **({"expected_success": float(scores["expected_success"][i])} if "expected_success" in scores else {})}
            for i in range(episodes)]


def run_agent(env_id: str, agent: Agent, episodes: int, seed: int, progress: bool = True,
              env_kwargs: dict[str, Any] | None = None) -> list[dict[str, Any]]:
    """:func:`run_batch` in batches of :data:`BATCH_EPISODES` (the same episodes). ``progress``: a
    progress bar on a terminal; otherwise (a log) a line on stderr every :data:`LOG_EVERY_S` and one
    when done."""
    on_terminal = progress and sys.stderr.isatty()
    log = progress and not on_terminal
    start = last_line = time.perf_counter()
    results: list[dict[str, Any]] = []
    with tqdm(total=episodes, desc=agent.name, unit="episode", file=sys.stderr, disable=not on_terminal) as bar:
        for first in range(0, episodes, BATCH_EPISODES):
            batch = min(BATCH_EPISODES, episodes - first)
            results += run_batch(env_id, agent, batch, seed + first, env_kwargs)
            bar.update(batch)
            now = time.perf_counter()
            if log and len(results) < episodes and now - last_line >= LOG_EVERY_S:
                print(f"{agent.name}: {len(results)}/{episodes} episodes, {now - start:.0f} s", file=sys.stderr,
                      flush=True)
                last_line = now
    if log:
        print(f"{agent.name}: {episodes} episodes in {time.perf_counter() - start:.1f} s", file=sys.stderr, flush=True)
    return results


def evaluate(env_id: str, specs: list[str], episodes: int, seed: int, raw_observations_ok: bool = False,
             progress: bool = True, expected_paths: int = 0) -> tuple[dict, dict]:
    """Every agent on episodes ``seed … seed + episodes − 1``: :func:`load_agents`, then :func:`play`."""
    return play(*load_agents(env_id, specs, raw_observations_ok), episodes, seed, progress, expected_paths)


def load_agents(env_id: str, specs: list[str], raw_observations_ok: bool = False) -> tuple[gym.Env, list[Agent]]:
    """A single env of the task and every agent (:func:`make_agent`), all loaded before any episode
    runs; their names must be distinct (:class:`ValueError`)."""
    env = gym.make(env_id)
    agents = [make_agent(spec, env, raw_observations_ok) for spec in specs]
    names = [agent.name for agent in agents]
    if len(set(names)) != len(names):
        raise ValueError(f"agent names must be distinct, got {names}")
    return env, agents


def play(env: gym.Env, agents: list[Agent], episodes: int, seed: int, progress: bool = True,
         expected_paths: int = 0) -> tuple[dict, dict]:
    """Every agent on episodes ``seed … seed + episodes − 1`` of ``env``'s task; per-episode results
    (with ``expected_paths``, each episode's expected success too), and the trajectory of episode
    ``seed`` played on ``env`` (closed after)."""
    results, trajectories = {}, {}
    paths = {"expected_paths": expected_paths} if expected_paths else None
    for agent in agents:
        try:
            results[agent.name] = run_agent(env.spec.id, agent, episodes, seed, progress, paths)
        except ValueError as err:  # an agent's non-finite action: name whose
            raise ValueError(f"{agent.name}: {err}") from err
        trajectories[agent.name] = run_episode(env, agent, seed, trajectory=True)["trajectory"]
    env.close()
    return results, trajectories


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    """The arguments, checked: :class:`UsageError` (one line) for any that is bad."""
    parser = Parser(prog="evaluate.py", description=describe(__doc__), formatter_class=HelpFormatter)
    parser.add_argument("--env", default="LightSail-v0", help=f"task id: {', '.join(TASKS)}")
    parser.add_argument("--agent", action="append", required=True,
                        help=f"one of {', '.join(BASELINES)}, a model .zip or a JAX run's policy.npz; repeat to compare")
    parser.add_argument("--episodes", type=int, default=200, help="paired episodes per agent")
    parser.add_argument("--seed", type=int, default=DEFAULT_SEED, help="episode i uses reset(seed=seed + i)")
    parser.add_argument("--expected-paths", type=int, default=EXPECTED_PATHS, metavar="K",
                        help="further coasts from each window's end behind the expected success (0: not reported)")
    parser.add_argument("--out", type=Path, help="report directory (default: reports/<env>, or the first free "
                                                 "reports/<env>_2, _3, …)")
    parser.add_argument("--overwrite", action="store_true", help="replace the report --out holds (refused otherwise)")
    parser.add_argument("--raw-observations", action="store_true",
                        help="accept models with neither a run.json nor VecNormalize statistics beside them as "
                             "trained on raw observations (refused otherwise)")
    parser.add_argument("--no-progress-bar", action="store_true",
                        help="no bar on a terminal, no line per agent otherwise")
    args = parser.parse_args(argv)
    if args.env not in TASKS:
        parser.error(f"--env must be one of {', '.join(TASKS)}, got {args.env!r}")
    if args.episodes < 1:
        parser.error(f"--episodes must be >= 1, got {args.episodes}")
    if args.seed < 0:
        parser.error(f"--seed must be >= 0, got {args.seed}")
    if not 0 <= args.expected_paths <= MAX_PATHS:
        parser.error(f"--expected-paths must be in [0, {MAX_PATHS}], got {args.expected_paths}")
    args.out = args.out or unused_report_dir(Path("reports") / args.env)
    check_out(args.out, args.overwrite)
    return args


def main(argv: list[str] | None = None) -> int:
    """evaluate.py: 0; 2 after one line on stderr, nothing written; 130 after Ctrl-C, nothing written."""
    try:
        with OneLineWarnings() as warnings_shown:
            return evaluate_and_report(argv, warnings_shown)
    except KeyboardInterrupt:
        fail("interrupted: no report written, --out is as it was")
        return 130


def evaluate_and_report(argv: list[str] | None, warnings_shown: OneLineWarnings) -> int:
    """:func:`main`'s work; Python warnings show once the checks have passed, a line each."""
    try:
        args = parse_args(argv)
        one_thread_per_process()
        env, agents = load_agents(args.env, args.agent, args.raw_observations)
        warnings_shown.release()
        results, trajectories = play(env, agents, args.episodes, args.seed, not args.no_progress_bar,
                                     args.expected_paths)
    except (UsageError, ModelLoadError, ValueError) as err:
        return fail(err)
    # A model is recorded by the file it is, not the link it was reached by (runs/latest moves on).
    specs = [spec if spec in BASELINES else str(Path(spec).resolve()) for spec in args.agent]
    config = {"episodes": args.episodes, "seed": args.seed, "agents": specs, "expected_paths": args.expected_paths,
              "env_kwargs": {k: repr(v) for k, v in gym.spec(args.env).kwargs.items()}}
    try:
        report = write_report(args.out, args.env, config, results, trajectories, args.overwrite)
    except UsageError as err:  # another evaluation published a report there meanwhile
        return fail(err)
    except OSError as err:  # writable when checked, but not now (disk full, removed)
        return fail(f"--out {args.out}: {err} (no report written, --out is as it was)")
    for name, s in report["agents"].items():
        lo, hi = s["success_ci95"]
        expected = "" if "expected_success" not in s else (
            f", expected {s['expected_success']:.1%} [{s['expected_success_ci95'][0]:.1%}, "
            f"{s['expected_success_ci95'][1]:.1%}]")
        print(f"{name:>32}: success {s['success_rate']:.1%} [{lo:.1%}, {hi:.1%}]{expected}, "
              f"median pointing {fmt_rad(s['terminal_pointing_rad']['median'])}, mean return {s['mean_return']:.2f}")
    for name, d in report.get("paired", {}).get("agents", {}).items():
        print(f"{name:>32}: {'; '.join(difference_line(key, d[key]) for key in d)} vs {report['paired']['reference']}")
    print(f"report: {args.out / 'report.md'}")
    return 0
