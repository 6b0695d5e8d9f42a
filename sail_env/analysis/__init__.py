"""Analysis off the runtime path: scripts and tables that derive, check or reproduce numbers the
tasks use, never imported by the envs, the core or the agents.

| module | what it computes | command |
|---|---|---|
| :mod:`~sail_env.analysis.paper` | the seed paper's figures and numbers, reproduced and corrected | ``python -m sail_env.analysis.paper --out paper/`` |
| :mod:`~sail_env.analysis.jitter` | the ground pointing jitter each sail tolerates; the realistic 3D tasks' levels (docs/physics.md §12) | ``python -m sail_env.analysis.jitter --out jitter.png`` |
| :mod:`~sail_env.analysis.planar` | the beam jitter a planar sail tolerates; its envelope kept for repeated queries (docs/physics.md §3) | (the paper, tests) |
| :mod:`~sail_env.analysis.damping` | the v/c damping's e-folds over a whole flight (docs/physics.md §13) | (tests) |
| :mod:`~sail_env.analysis.tables3d` | the 3D model's tables: planar comparison, quadrature convergence, stability (docs/physics.md §9–§10) | ``python -m sail_env.analysis.tables3d`` |
"""
