"""lightsail-gym: keep a laser-propelled light sail on its beam.

Importing the package registers the planar task suite with Gymnasium::

    import gymnasium as gym
    import sail_env  # noqa: F401  (or gym.make("sail_env:LightSail-v0"))
    env = gym.make("LightSail-v0")
"""

from gymnasium.envs.registration import register, registry

from sail_env.tasks import TASKS

__version__ = "0.1.0"

for _task_id, _kwargs in TASKS.items():
    if _task_id not in registry:
        register(id=_task_id, entry_point="sail_env.envs.planar:LightSailEnv", kwargs=_kwargs)
