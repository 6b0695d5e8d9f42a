"""Tables a process builds once (sail_env/physics/memo.py): the same task's plants share them, read-only,
and another sail gets its own."""

import dataclasses
import inspect
import multiprocessing
import os
import subprocess
import sys
import warnings
from pathlib import Path
from types import SimpleNamespace

import gymnasium as gym
import numpy as np
import pytest

import sail_env  # noqa: F401
from sail_env.physics import blas, memo
from sail_env.physics.memo import built_once
from sail_env.physics.rigid3d import flight, scales, uncertainty
from sail_env.physics.rigid3d.body import RigidSail
from sail_env.physics.rigid3d.config import RigidSailConfig
from sail_env.physics.rigid3d.flight import DrawFlights
from sail_env.physics.rigid3d.scales import ScaleTable
from sail_env.physics.rigid3d.uncertainty import CurvatureTable


def plant(env_id: str, **kwargs):
    return gym.make(env_id, **kwargs).unwrapped.episode_spec.plant


def test_two_makes_of_a_task_share_its_tables_and_cannot_write_them():
    first, second = plant("LightSailUncertain-v1"), plant("LightSailUncertain-v1")
    assert first is not second
    assert first.scales is second.scales and first.flights is second.flights and first.table is second.table
    for array in (first.scales.log_scales, first.flights.table.momentum, first.table.radii, first.table._parts[0][0],
                  first.table._splines[0][0].c):
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
BUILT: list[object] = []


def counted_table(size: int) -> np.ndarray:
    """A cheap table that records each build."""
    BUILT.append(size)
    return np.arange(size) / 7.0


#: The task's sail (v1: a deep dish in a Gaussian of waist 0.8 a, 10 % absorbed).
SAIL = RigidSailConfig(curvature_radius_m=4.0, absorptivity=0.1, reflectivity=0.9, beam_profile="gaussian",
                       beam_radius_m=1.6)


def counted_flights(*args: object) -> DrawFlights:
    BUILT.append("flights")
    return DrawFlights(RigidSail(args[0]), *args[1:])


def counted_scales(*args: object) -> ScaleTable:
    BUILT.append("scales")
    return ScaleTable(RigidSail(args[0]), *args[1:])


def counted_curvature(*args: object) -> CurvatureTable:
    BUILT.append("curvature")
    return CurvatureTable(*args)


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
    assert len(list(tables_dir.glob(f"counted_table-*{memo.SUFFIX}"))) == 1 and not list(tables_dir.glob("*.tmp"))
    built_once(counted_table)(6)
    assert BUILT == [5, 6]


def test_a_new_machine_set_up_a_file_of_another_key_or_an_unreadable_one_builds_afresh(tables_dir, monkeypatch):
    built_once(counted_table)(5)
    (first,) = tables_dir.glob(f"*{memo.SUFFIX}")
    # Other OpenBLAS blocking (or kernels) round differently: another key, another file.
    monkeypatch.setenv("OPENBLAS_L2_SIZE", str(int(os.environ.get("OPENBLAS_L2_SIZE") or 0) + 4096))
    memo.code_version.cache_clear()
    built_once(counted_table)(5)
    (second,) = set(tables_dir.glob(f"*{memo.SUFFIX}")) - {first}
    assert BUILT == [5, 5]
    second.write_bytes(first.read_bytes())  # a whole file under another name: its stored key tells
    with pytest.warns(RuntimeWarning, match="another table"):
        built_once(counted_table)(5)
    second.write_bytes(b"truncated")
    with pytest.warns(RuntimeWarning, match="not a table file"):
        built_once(counted_table)(5)
    assert BUILT == [5, 5, 5, 5]
    assert np.array_equal(built_once(counted_table)(5), np.arange(5) / 7.0) and BUILT == [5, 5, 5, 5]


def flip_a_bit_in_the_array(content: bytes) -> bytes:
    """The file with one bit flipped inside the table's float array (as a disk or a copy might)."""
    at = content.index((np.arange(50) / 7.0).tobytes()) + 8 * 20 + 3
    return content[:at] + bytes([content[at] ^ 0x10]) + content[at + 1:]


@pytest.mark.parametrize("damage, reason", [
    (flip_a_bit_in_the_array, "does not match its SHA-256"),
    (lambda content: content[: len(content) * 2 // 3], "does not match its SHA-256"),  # a writer killed mid-copy
    (lambda content: content.replace(b"table 1\n", b"table 2\n", 1), "not a table file of this format and version"),
    (lambda content: b"\x80\x05" + content, "not a table file"),  # a pickle, say
])
def test_a_damaged_truncated_or_foreign_file_is_never_used_but_built_again_with_one_warning(tables_dir, damage,
                                                                                             reason):
    built_once(counted_table)(50)
    (path,) = tables_dir.glob(f"*{memo.SUFFIX}")
    path.write_bytes(damage(path.read_bytes()))
    with pytest.warns(RuntimeWarning) as warned:
        rebuilt = built_once(counted_table)(50)
    assert len(warned) == 1 and reason in str(warned[0].message) and str(path) in str(warned[0].message)
    assert BUILT == [50, 50] and rebuilt.tobytes() == (np.arange(50) / 7.0).tobytes()
    # Replaced (atomically: no temporary file left): the next process loads it, without a warning.
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert built_once(counted_table)(50).tobytes() == rebuilt.tobytes()
    assert BUILT == [50, 50] and list(tables_dir.iterdir()) == [path]


@pytest.mark.parametrize("structure, arrays", [
    ({"partial": [{"function": "shutil:rmtree"}, {"tuple": ["."]}, {"dict": []}]}, []),
    ({"object": ["subprocess:Popen", None]}, []),
    ({"object": ["builtins:eval", None]}, []),
    ({"array": 0}, [np.array([print], dtype=object)]),  # an array of objects (a pickle inside)
])
def test_a_file_runs_no_code_it_names(tables_dir, tmp_path, monkeypatch, structure, arrays):
    """The format holds no code: a file can name only classes and functions of this package and SciPy that
    are already imported, and loading calls none of its functions."""
    monkeypatch.chdir(tmp_path)  # where a forged rmtree(".") would have removed the tables
    built_once(counted_table)(5)
    (path,) = tables_dir.glob(f"*{memo.SUFFIX}")
    key = memo._read(path)[0]
    with monkeypatch.context() as patch, path.open("wb") as file:  # forged, its digest right
        patch.setattr(memo, "_to_arrays", lambda table: (structure, arrays))
        memo._write(file, key, None)
    with pytest.warns(RuntimeWarning, match="not used"):
        assert built_once(counted_table)(5).tobytes() == (np.arange(5) / 7.0).tobytes()
    assert BUILT == [5, 5] and list(tmp_path.iterdir()) == [tables_dir]


RACE: list = []  # the barrier the racing writers meet at (set before they fork)


def raced_table(size: int) -> np.ndarray:
    """A table whose builders wait for each other: both have found no file, both write."""
    BUILT.append(size)
    RACE[0].wait(timeout=120)
    return np.arange(size) / 7.0


def test_two_processes_writing_the_same_table_leave_one_whole_file(tables_dir, monkeypatch):
    context = multiprocessing.get_context("fork")
    monkeypatch.setattr(sys.modules[__name__], "RACE", [context.Barrier(2)])
    writers = [context.Process(target=built_once(raced_table), args=(40,)) for _ in range(2)]
    for writer in writers:
        writer.start()
    for writer in writers:
        writer.join(timeout=180)
    assert [writer.exitcode for writer in writers] == [0, 0]
    (path,) = tables_dir.iterdir()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert built_once(raced_table)(40).tobytes() == (np.arange(40) / 7.0).tobytes()
    assert BUILT == []  # this process loaded what the others wrote


def unnamed_parts(size: int) -> dict:
    BUILT.append(size)
    return {"rows": np.arange(size), "pick": lambda row: row}


def test_a_table_the_format_cannot_hold_is_kept_in_memory_only(tables_dir):
    built_once(unnamed_parts)(3)
    assert built_once(unnamed_parts)(3)["pick"](2) == 2
    assert BUILT == [3, 3] and not list(tables_dir.iterdir())


def test_a_file_that_cannot_be_touched_is_still_read_and_stale_temporary_files_go(tables_dir, monkeypatch):
    built_once(counted_table)(5)
    abandoned, fresh = tables_dir / "killed-writer.tmp", tables_dir / "writing-now.tmp"
    abandoned.write_bytes(b"half"), fresh.write_bytes(b"half")
    os.utime(abandoned, (1e9, 1e9))

    def refused(*args):
        raise PermissionError("another user's file")

    with monkeypatch.context() as patch:
        patch.setattr(memo.os, "utime", refused)
        built_once(counted_table)(5)
    assert BUILT == [5]
    built_once(counted_table)(6)  # a write prunes
    assert not abandoned.exists() and fresh.exists()


def test_the_sources_are_read_as_the_package_is_imported(tables_dir, monkeypatch):
    """A process whose files are edited while it runs keeps filing tables under the code it runs."""
    before = memo.code_version()
    monkeypatch.setattr(memo, "_source_digest", lambda: "edited on disk since")
    memo.code_version.cache_clear()
    assert memo.code_version() == before
    monkeypatch.setattr(memo, "_SOURCES", "another code")
    memo.code_version.cache_clear()
    assert memo.code_version() != before


def test_the_disk_keeps_the_most_recently_used_tables_of_a_kind(tables_dir, monkeypatch):
    monkeypatch.setattr(memo, "TABLES_KEPT", 2)
    once = built_once(counted_table)
    once(1), once(2)
    earlier_format = tables_dir / "counted_table-0123456789abcdef0123456789abcdef.pkl"
    earlier_format.write_bytes(b"a pickle, never read again")
    os.utime(earlier_format, (1e8, 1e8))
    for age, size in ((2, 1), (1, 2)):  # 1 older than 2, both long ago (whatever the clock's resolution)
        (path,) = [p for p in tables_dir.glob(f"*{memo.SUFFIX}") if np.array_equal(memo._read(p)[1],
                                                                                    np.arange(size) / 7.0)]
        os.utime(path, (1e9 - age, 1e9 - age))
    built_once(counted_table)(1)  # read from disk: now the most recently used
    once(3)
    assert BUILT == [1, 2, 3] and len(list(tables_dir.glob("counted_table-*"))) == 2
    built_once(counted_table)(1), built_once(counted_table)(3)
    assert BUILT == [1, 2, 3]
    built_once(counted_table)(2)  # its file was the oldest: removed, built again
    assert BUILT == [1, 2, 3, 2]


@pytest.mark.parametrize("setting", ["off", "0", "a file"])
def test_tables_stay_in_memory_when_off_or_the_directory_cannot_be_written(tmp_path, monkeypatch, setting):
    blocker = tmp_path / "plain-file"
    blocker.write_text("")
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv(memo.CACHE_VARIABLE, str(blocker / "tables") if setting == "a file" else setting)
    BUILT.clear()
    assert np.array_equal(built_once(counted_table)(4), np.arange(4) / 7.0)
    built_once(counted_table)(4)
    assert BUILT == [4, 4] and sorted(p.name for p in tmp_path.iterdir()) == ["plain-file"]


def test_the_3d_tables_loaded_from_disk_are_the_built_ones_to_the_bit(tables_dir):
    flights_args = (SAIL, 1200.0, True, 5e8, 1.2)
    fresh = DrawFlights(RigidSail(SAIL), *flights_args[1:])
    written, loaded = built_once(counted_flights)(*flights_args), built_once(counted_flights)(*flights_args)
    assert BUILT == ["flights"] and written is not loaded and len(list(tables_dir.glob(f"*{memo.SUFFIX}"))) == 1
    for name, value in vars(fresh.table).items():
        assert np.array_equal(np.asarray(getattr(loaded.table, name)), np.asarray(value)), name
    ratios, times = np.full(7, 1.1), np.linspace(0.0, 1200.0, 7)
    for read in ("speed", "power_factor", "distance", "beam_scale"):
        assert getattr(loaded, read)(ratios, times).tobytes() == getattr(fresh, read)(ratios, times).tobytes()

    scales = ScaleTable(RigidSail(SAIL), 1.5)
    built_once(counted_scales)(SAIL, 1.5)
    loaded_scales = built_once(counted_scales)(SAIL, 1.5)
    spots = np.linspace(1.0, 1.5, 9)
    for got, want in zip((*loaded_scales.at(spots), loaded_scales.push_at(spots)),
                         (*scales.at(spots), scales.push_at(spots))):
        assert got.tobytes() == want.tobytes()

    curvature = CurvatureTable(SAIL, 1.0, 0.2)
    built_once(counted_curvature)(SAIL, 1.0, 0.2)
    loaded_curvature = built_once(counted_curvature)(SAIL, 1.0, 0.2)
    radii, absorptivities = np.linspace(3.3, 4.7, 5), np.linspace(0.06, 0.14, 5)
    for got, want in zip(loaded_curvature.at(radii, absorptivities), curvature.at(radii, absorptivities)):
        assert got.tobytes() == want.tobytes()
    assert BUILT == ["flights", "scales", "curvature"]


#: A new process loads the three 3D tables another wrote (building is made to fail), without a warning.
LOAD_IN_A_NEW_PROCESS = """
import warnings
warnings.simplefilter("error")
from sail_env.physics.rigid3d import flight, scales, uncertainty
from sail_env.physics.rigid3d.config import RigidSailConfig

def refused(*args, **kwargs):
    raise AssertionError("built, not loaded")

flight.DrawFlights.__init__ = scales.ScaleTable.__init__ = uncertainty.CurvatureTable.__init__ = refused
flight.draw_flights(*{flights!r}), scales.scale_table(*{scales!r}), uncertainty.curvature_table(*{curvature!r})
"""


def test_a_new_process_loads_the_3d_tables_before_it_imported_their_classes_modules(tables_dir):
    """SciPy's splines of the curvature table are of a module a new process imports only when it loads them."""
    arguments = {"flights": (SAIL, 1200.0, True, 5e8, 1.2), "scales": (SAIL, 1.5, True),
                 "curvature": (SAIL, 1.0, 0.2)}
    factories = (flight.draw_flights, scales.scale_table, uncertainty.curvature_table)
    for factory, args in zip(factories, arguments.values()):
        memo._stored(inspect.unwrap(factory), args)
    assert len(list(tables_dir.iterdir())) == 3
    run = subprocess.run([sys.executable, "-c", LOAD_IN_A_NEW_PROCESS.format(**arguments)], capture_output=True,
                         text=True, timeout=300, env={**os.environ, "PYTHONPATH": str(Path(memo.__file__).parents[2])})
    assert run.returncode == 0, run.stderr[-2000:]


def test_the_directory_is_the_variable_s_else_the_xdg_cache_s_else_the_home_s(monkeypatch, tmp_path):
    monkeypatch.delenv(memo.CACHE_VARIABLE)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert memo.cache_dir() == tmp_path / "lightsail-gym"
    monkeypatch.delenv("XDG_CACHE_HOME")
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    assert memo.cache_dir() == tmp_path / "home" / ".cache" / "lightsail-gym"
    for off in (" Off ", "0", "false"):
        monkeypatch.setenv(memo.CACHE_VARIABLE, off)
        assert memo.cache_dir() is None


def test_the_key_does_not_depend_on_the_order_threadpoolctl_lists_the_blas_libraries(tables_dir, monkeypatch):
    """threadpoolctl lists NumPy's and SciPy's OpenBLAS in either order between identical processes: each
    order must give the same key, or half the processes miss the other half's tables."""
    numpy_s, scipy_s = (SimpleNamespace(internal_api="openblas", version=version, architecture=kernel)
                        for version, kernel in (("0.3.27", "Haswell"), ("0.3.21", "SkylakeX")))
    keys = set()
    for listed in ((numpy_s, scipy_s), (scipy_s, numpy_s)):
        monkeypatch.setattr(blas, "blas_libraries", lambda listed=listed: listed)
        memo.code_version.cache_clear()
        keys.add(memo.code_version())
    assert len(keys) == 1
