"""lightsail-gym: keep a laser-propelled light sail on its beam.

Importing the package registers the task suite (planar and 3D) with Gymnasium::

    import gymnasium as gym
    import sail_env  # noqa: F401  (or gym.make("sail_env:LightSail-v0"))
    env = gym.make("LightSail-v0")
    envs = gym.make_vec("LightSail-v0", num_envs=1024, vectorization_mode="vector_entry_point")
"""

from gymnasium.envs.registration import register, registry

from sail_env.tasks import ENTRY_POINTS, PLANAR_TASKS, RIGID3D_TASKS

__version__ = "0.4.0"

for _family, _tasks in (("planar", PLANAR_TASKS), ("rigid3d", RIGID3D_TASKS)):
    for _task_id, _kwargs in _tasks.items():
        if _task_id not in registry:
            register(id=_task_id, entry_point=ENTRY_POINTS[_family][0], vector_entry_point=ENTRY_POINTS[_family][1],
                     kwargs=_kwargs)
