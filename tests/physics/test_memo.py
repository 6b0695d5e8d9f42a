"""Tables a process builds once (sail_env/physics/memo.py): the same task's plants share them, read-only,
and another sail gets its own."""

import dataclasses

import gymnasium as gym
import numpy as np
import pytest

import sail_env  # noqa: F401
from sail_env.physics.memo import built_once


def plant(env_id: str, **kwargs):
    return gym.make(env_id, **kwargs).unwrapped.episode_spec.plant


def test_two_makes_of_a_task_share_its_tables_and_cannot_write_them():
    first, second = plant("LightSailUncertain-v1"), plant("LightSailUncertain-v1")
    assert first is not second
    assert first.scales is second.scales and first.flights is second.flights and first.table is second.table
    for array in (first.scales.log_scales, first.flights.table.momentum, first.table.radii, first.table._parts[0][0]):
        with pytest.raises(ValueError, match="read-only"):
            array[0] = 0.0


def test_another_sail_gets_its_own_tables():
    nominal = plant("LightSail3DRealistic-v1")
    darker = plant("LightSail3DRealistic-v1", absorptivity=0.15)
    assert darker.flights is not nominal.flights and darker.scales is not nominal.scales
    assert not np.array_equal(darker.flights.table.momentum, nominal.flights.table.momentum)


def test_arrays_inside_lists_and_nested_objects_become_read_only():
    @dataclasses.dataclass
    class Rows:
        values: np.ndarray

    Rows.__module__ = "sail_env.test"  # a package object: its attributes are followed

    @built_once
    def table(size: int) -> tuple:
        return np.zeros(size), [np.ones(size)], Rows(np.arange(size, dtype=float))

    flat, (listed,), rows = table(3)
    assert table(3)[0] is flat
    for array in (flat, listed, rows.values):
        assert not array.flags.writeable
