"""What light delay and absorption do to active control of the 3D sail (docs/tasks.md, "The 3D tasks").

    python -m research.delay_absorption_3d [--episodes 200]   # from the repo root

Passive, LQR and LQG on LightSail3D-v0 and three variants of it, on the same seeded episodes
(evaluate.py's episode runner); prints a markdown table of success rates.
"""

from __future__ import annotations

import argparse

from research.realistic_ablation import success_rate

ENV_ID = "LightSail3D-v0"
DELAY = {"light_delay": True, "control_start_s": 10.0}
VARIANTS = {"default": {}, "`absorptivity=0.1`": {"absorptivity": 0.1},
            "`light_delay=True, control_start_s=10`": DELAY, "both": {"absorptivity": 0.1, **DELAY}}
AGENTS = ("passive", "lqr", "lqg")


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=200)
    args = parser.parse_args(argv)
    print(f"{ENV_ID}, {args.episodes} episodes per cell\n")
    print("| variant | passive | LQR | LQG |")
    print("|---|---:|---:|---:|")
    for name, kwargs in VARIANTS.items():
        rates = [success_rate(agent, args.episodes, ENV_ID, **kwargs) for agent in AGENTS]
        print(f"| {name} | " + " | ".join(f"{rate:.1%}" for rate in rates) + " |", flush=True)


if __name__ == "__main__":
    main()
