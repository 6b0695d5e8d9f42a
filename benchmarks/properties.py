"""The property of tests/test_properties.py on many more random draws, with a summary.

    python -m benchmarks.properties --examples 2000

Every draw must end as a clean episode or a ValueError at construction; the summary counts how
draws ended, and why constructions were refused (the first words of each message).
"""

from __future__ import annotations

import argparse
import time
from collections import Counter

from hypothesis import HealthCheck, given, settings

from sail_env.envs import LightSailEnv
from tests.test_properties import cases, check_episode


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--examples", type=int, default=2000, help="random draws (default: %(default)s)")
    args = parser.parse_args()
    outcomes, reasons = Counter(), Counter()

    @settings(max_examples=args.examples, deadline=None, derandomize=False, database=None,
              suppress_health_check=list(HealthCheck))
    @given(case=cases())
    def run(case: dict) -> None:
        outcome = check_episode(case)
        outcomes[outcome] += 1
        if outcome == "refused":
            try:
                LightSailEnv(**{k: v for k, v in case.items() if k != "action_seed"})
            except ValueError as error:
                words = [w for w in str(error).split()[:8] if not any(c.isdigit() for c in w)]
                reasons[" ".join(words)] += 1

    start = time.perf_counter()
    run()
    total = sum(outcomes.values())
    print(f"{total} draws in {time.perf_counter() - start:.0f} s, no failure of the property")
    for outcome, count in outcomes.most_common():
        print(f"  {outcome:9s} {count:6d} ({100 * count / total:.1f} %)")
    for reason, count in reasons.most_common():
        print(f"    refused: {reason} ... x{count}")


if __name__ == "__main__":
    main()
