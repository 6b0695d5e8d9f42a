#!/usr/bin/env bash
# The JAX backend's GPU goals in one run of under 5 minutes, for a machine with JAX's CUDA build
# (issues: LightSail-v0 >= 0.5x gymnax CartPole-v1 at N = 10^6 in float64; LightSailRealistic-v0
# >= 10^9 env-steps/s; LightSail3D-v0 >= 10^8; LightSail3DRealistic-v1 and LightSailUncertain-v2 >= 2x10^6 at N >= 10^4; PPO >= 99 %
# within 60 s, 16 seeds in one vmap run; a short PPO on LightSail3DRealistic-v1). Prepare here, then run it
# there with the wheels carried:
#
#   pip download --no-deps -d wheels gymnasium gymnax farama-notifications   # what the CUDA image lacks
#   bash benchmarks/gpu_check.sh                                             # on the GPU machine
#
# Prints the device, the speed table (N = 10^4 ... 10^6, the backend's four tasks, and the Numba vector
# env at N = 1,024 on the host) and the PPO run's figures; writes
# speed_jax_gpu.json and the PPO's runs and report under ${OUT:-/tmp/gpu_check}.
set -euo pipefail
cd "$(dirname "$0")/.."
out="${OUT:-/tmp/gpu_check}"
mkdir -p "$out"
if [ -d wheels ]; then
    python3 -m pip install -q --no-deps --no-index --target "$out/site" wheels/*.whl
    export PYTHONPATH="$out/site:$PWD"
else
    export PYTHONPATH="$PWD"
fi
# No GPU, no check: the speed figures below are an accelerator's, and on a CPU the first would run into its
# timeout after minutes with no word (exit 3, one line, before anything is measured).
python3 -c "import jax, sys; print('JAX', jax.__version__, jax.devices())
sys.exit(0 if jax.default_backend() == 'gpu' else
         'gpu_check.sh: no GPU (JAX sees ' + str(jax.devices()) + '): run it where JAX has its CUDA build')" || exit 3
timeout 180 python3 -m benchmarks.speed_jax --sizes 10000 100000 1000000 --rounds 2 --out "$out/speed_jax_gpu.json"
timeout 120 python3 -m benchmarks.speed_jax --along-sizes 16384 --rounds 1 --out "$out/speed_jax_along_gpu.json"
timeout 90 python3 train_jax.py --env LightSail-v0 --seeds 16 --runs-dir "$out/runs"
agents=()
for seed in $(seq 0 15); do agents+=(--agent "$out/runs/LightSail-v0-jax_ppo-$seed/policy.npz"); done
timeout 60 python3 evaluate.py --agent lqr "${agents[@]}" --episodes 200 --out "$out/report" --no-progress-bar
timeout 90 python3 train_jax.py --env LightSail3DRealistic-v1 --seeds 4 -n 2000000 --num-envs 4096 --runs-dir "$out/runs3d"
