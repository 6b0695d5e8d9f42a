"""One-off measurements behind the docs' claims (research/README.md maps each claim to its script and
kept result). Not installed with the package and not imported by the library, the benchmarks a user
runs (benchmarks/) or the default test run; run from the repository root: ``python -m research.<name>``."""
