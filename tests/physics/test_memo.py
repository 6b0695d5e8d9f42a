"""Tables a process builds once (sail_env/physics/memo.py): the same task's plants share them, read-only,
and another sail gets its own."""

import dataclasses
import time

import gymnasium as gym
import numpy as np
import pytest

import sail_env  # noqa: F401
from sail_env.physics import memo
from sail_env.physics.memo import built_once
from sail_env.physics.rigid3d.body import RigidSail
from sail_env.physics.rigid3d.config import RigidSailConfig
from sail_env.physics.rigid3d.flight import DrawFlights, draw_flights

#: The factory under draw_flights' two caches (what a new process would call).
draw_flights_factory = draw_flights.__wrapped__.__wrapped__


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


def test_arrays_inside_lists_and_nested_objects_become_read_only(monkeypatch):
    monkeypatch.setenv(memo.CACHE_VARIABLE, "off")
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


# ---------------------------------------------------------------------- on disk
BUILT: list[int] = []


def counted_table(size: int) -> np.ndarray:
    """A cheap table that records each build."""
    BUILT.append(size)
    return np.arange(size) / 7.0


@pytest.fixture
def tables_dir(tmp_path, monkeypatch):
    monkeypatch.setenv(memo.CACHE_VARIABLE, str(tmp_path / "tables"))
    memo.code_version.cache_clear()
    BUILT.clear()
    yield tmp_path / "tables"
    memo.code_version.cache_clear()


def test_a_table_is_built_once_written_and_loaded_by_a_later_process_to_the_bit(tables_dir):
    first = built_once(counted_table)(5)
    later = built_once(counted_table)(5)  # a new process: a new in-memory cache, the same directory
    assert BUILT == [5] and later is not first and np.array_equal(later, first)
    assert later.tobytes() == (np.arange(5) / 7.0).tobytes() and not later.flags.writeable
    assert len(list(tables_dir.glob("counted_table-*.pkl"))) == 1 and not list(tables_dir.glob("*.tmp"))
    built_once(counted_table)(6)
    assert BUILT == [5, 6]


def test_a_new_machine_set_up_or_unreadable_file_builds_afresh(tables_dir, monkeypatch):
    built_once(counted_table)(5)
    monkeypatch.setenv("OPENBLAS_CORETYPE", "Haswell")  # other kernels round differently
    memo.code_version.cache_clear()
    built_once(counted_table)(5)
    assert BUILT == [5, 5] and len(list(tables_dir.glob("*.pkl"))) == 2
    for path in tables_dir.glob("*.pkl"):
        path.write_bytes(b"truncated")
    assert np.array_equal(built_once(counted_table)(5), np.arange(5) / 7.0) and BUILT == [5, 5, 5]


def test_the_disk_keeps_the_most_recently_used_tables_of_a_kind(tables_dir, monkeypatch):
    monkeypatch.setattr(memo, "TABLES_KEPT", 2)
    once = built_once(counted_table)
    for step in (lambda: once(1), lambda: once(2), lambda: built_once(counted_table)(1), lambda: once(3)):
        step()  # the third reads 1 from disk: 1 is then the most recently used
        time.sleep(0.03)  # apart in the file system's clock (a few ms a tick)
    built_once(counted_table)(1), built_once(counted_table)(3)
    assert BUILT == [1, 2, 3] and len(list(tables_dir.glob("counted_table-*.pkl"))) == 2
    built_once(counted_table)(2)  # its file was the oldest: removed, built again
    assert BUILT == [1, 2, 3, 2]


@pytest.mark.parametrize("setting", ["off", "a file"])
def test_tables_stay_in_memory_when_off_or_the_directory_cannot_be_written(tmp_path, monkeypatch, setting):
    blocker = tmp_path / "plain-file"
    blocker.write_text("")
    monkeypatch.setenv(memo.CACHE_VARIABLE, "off" if setting == "off" else str(blocker / "tables"))
    BUILT.clear()
    assert np.array_equal(built_once(counted_table)(4), np.arange(4) / 7.0)
    built_once(counted_table)(4)
    assert BUILT == [4, 4] and sorted(p.name for p in tmp_path.iterdir()) == ["plain-file"]


def test_the_flights_loaded_from_disk_are_the_built_ones_to_the_bit(tables_dir):
    args = (RigidSailConfig(curvature_radius_m=4.0, beam_profile="gaussian", beam_radius_m=1.6), 1200.0, True,
            5e8, 1.2)
    fresh = DrawFlights(RigidSail(args[0]), *args[1:])
    written, loaded = built_once(draw_flights_factory)(*args), built_once(draw_flights_factory)(*args)
    assert written is not loaded
    for name, value in vars(fresh.table).items():
        assert np.array_equal(np.asarray(getattr(loaded.table, name)), np.asarray(value)), name
    times = np.linspace(0.0, 1200.0, 7)
    for read in ("speed", "power_factor", "distance"):
        assert getattr(loaded, read)(np.full(7, 1.1), times).tobytes() == \
            getattr(fresh, read)(np.full(7, 1.1), times).tobytes()


def test_the_directory_is_the_variable_s_else_the_xdg_cache_s_else_the_home_s(monkeypatch, tmp_path):
    monkeypatch.delenv(memo.CACHE_VARIABLE)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert memo.cache_dir() == tmp_path / "lightsail-gym"
    monkeypatch.delenv("XDG_CACHE_HOME")
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    assert memo.cache_dir() == tmp_path / "home" / ".cache" / "lightsail-gym"
    monkeypatch.setenv(memo.CACHE_VARIABLE, " Off ")
    assert memo.cache_dir() is None
