"""lightsail-gym: keep a laser-propelled light sail on its beam.

Importing the package registers the task suite (planar and 3D) with Gymnasium::

    import gymnasium as gym
    import sail_env  # noqa: F401  (or gym.make("sail_env:LightSail-v0"))
    env = gym.make("LightSail-v0")
    envs = gym.make_vec("LightSail-v0", num_envs=1024, vectorization_mode="vector_entry_point")

and the JAX backend's tasks as ``jax/<id>`` (Gymnasium's functional API; the entry points import JAX
only when such an env is made)::

    env = gym.make("jax/LightSail-v0")
"""

from gymnasium.envs.registration import register, registry

from sail_env.tasks import ENTRY_POINTS, JAX_TASKS, PLANAR_TASKS, RIGID3D_TASKS

__version__ = "0.5.0"

for _family, _tasks in (("planar", PLANAR_TASKS), ("rigid3d", RIGID3D_TASKS)):
    for _task_id, _kwargs in _tasks.items():
        if _task_id not in registry:
            register(id=_task_id, entry_point=ENTRY_POINTS[_family][0], vector_entry_point=ENTRY_POINTS[_family][1],
                     kwargs=_kwargs)

for _task_id in JAX_TASKS:
    if f"jax/{_task_id}" not in registry:
        register(id=f"jax/{_task_id}", entry_point=ENTRY_POINTS["jax"][0], vector_entry_point=ENTRY_POINTS["jax"][1],
                 kwargs={"env_id": _task_id}, disable_env_checker=True)  # JAX arrays out, as phys2d's
