"""Hyperparameter strings are read, never executed: the shipped files as before, escapes refused."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml
from stable_baselines3.common.utils import LinearSchedule
from torch import nn

from agents import zoo_syntax
from agents.sb3 import HYPERPARAMS_DIR, algo_kwargs, normalize_kwargs, policy_kwargs

SHIPPED = [(path.name, env_id, entry) for path in sorted(HYPERPARAMS_DIR.glob("*.yml"))
           for env_id, entry in yaml.safe_load(path.read_text()).items()]


def _former_eval(text: str) -> object:
    """The former reading (``eval`` with empty builtins), as the reference on the trusted shipped files only."""
    return eval(text, {"__builtins__": {}}, {"dict": dict, "nn": nn})  # noqa: S307


@pytest.mark.parametrize("name, env_id, entry", SHIPPED, ids=[f"{n}:{e}" for n, e, _ in SHIPPED])
def test_shipped_files_read_as_the_former_eval_did(name: str, env_id: str, entry: dict) -> None:
    for key in ("policy_kwargs", "normalize"):
        if isinstance(entry.get(key), str):
            assert zoo_syntax.parse(entry[key], key) == _former_eval(entry[key])
    assert policy_kwargs(entry.get("policy_kwargs")) == (_former_eval(entry["policy_kwargs"])
                                                         if isinstance(entry.get("policy_kwargs"), str) else {})


def test_the_documented_forms() -> None:
    text = "dict(net_arch=dict(pi=[64, 64], vf=[32]), activation_fn=nn.ReLU, log_std_init=-1.5, ortho_init=False, " \
           "squash=None, name='x', shape=(1, +2), table={'a': 1, 2: -3e-4})"
    assert zoo_syntax.parse(text, "policy_kwargs") == {
        "net_arch": {"pi": [64, 64], "vf": [32]}, "activation_fn": nn.ReLU, "log_std_init": -1.5, "ortho_init": False,
        "squash": None, "name": "x", "shape": (1, 2), "table": {"a": 1, 2: -3e-4}}
    assert policy_kwargs({"activation_fn": "tanh"})["activation_fn"] is nn.Tanh
    assert policy_kwargs({"activation_fn": "nn.GELU"})["activation_fn"] is nn.GELU
    assert policy_kwargs("dict(activation_fn=nn.LeakyReLU)")["activation_fn"] is nn.LeakyReLU
    assert normalize_kwargs("dict(norm_obs=True, norm_reward=False, clip_obs=5.0)") == {
        "norm_obs": True, "norm_reward": False, "clip_obs": 5.0}
    assert normalize_kwargs(True) == {} and normalize_kwargs(False) is None and normalize_kwargs("False") is None


def test_linear_schedule_decays_from_its_value_to_zero() -> None:
    schedule = algo_kwargs({"learning_rate": "lin_3e-4", "clip_range": 0.2}, 2)["learning_rate"]
    assert isinstance(schedule, LinearSchedule)
    assert schedule(1.0) == pytest.approx(3e-4) and schedule(0.5) == pytest.approx(1.5e-4) and schedule(0.0) == 0.0


ESCAPES = [
    "().__class__.__bases__[0].__subclasses__()",
    "__import__('os').system('touch {marker}')",
    "__import__('pathlib').Path('{marker}').touch()",
    "dict(a=__import__('pathlib').Path('{marker}').touch())",
    "[c for c in ().__class__.__base__.__subclasses__()]",
    "open('{marker}', 'w')",
    "nn.Module",
    "nn.Tanh()",
    "nn.Tanh.__init__",
    "nn.modules.activation.Tanh",
    "getattr(nn, 'Tanh')",
    "dict(**{{'a': 1}})",
    "{{**{{}}}}",
    "lambda: 0",
    "9 ** 9 ** 9 ** 9",  # would never finish if it were evaluated
    "'a' * 10 ** 12",  # would exhaust memory
    "f'{{1}}'",
    "b'bytes'",
    "1j",
    "...",
    "-True",
    "{{[1]: 2}}",
    "dict(1)",
    "(x := 1)",
]


@pytest.mark.parametrize("payload", ESCAPES)
def test_anything_else_is_refused_without_running(payload: str, tmp_path: Path) -> None:
    marker = tmp_path / "ran"
    text = payload.format(marker=marker)
    with pytest.raises(ValueError, match=r"^policy_kwargs: .* accepted: literals") as error:
        policy_kwargs(text)
    assert "\n" not in str(error.value)
    with pytest.raises(ValueError, match=r"^normalize: "):
        normalize_kwargs(text)
    assert not marker.exists()


@pytest.mark.parametrize("text", ["dict(a=1", "[" * 10_000, "-" * 100_000 + "1"])
def test_unparsable_or_deep_text_is_one_line_error(text: str) -> None:
    with pytest.raises(ValueError, match=r"^policy_kwargs: ") as error:
        zoo_syntax.parse(text, "policy_kwargs")
    assert "\n" not in str(error.value) and len(str(error.value)) < 500


@pytest.mark.parametrize("value, message", [
    ({"learning_rate": "lin_x"}, "learning_rate must be a finite number"),
    ({"learning_rate": "lin_nan"}, "got 'lin_nan'"),
    ({"learning_rate": "3e-4"}, "write 3.0e-4"),  # YAML 1.1 reads 3e-4 as text
    ({"clip_range": True}, "clip_range must be a finite number"),
    ({"policy_kwargs": "[64, 64]"}, "policy_kwargs must be a mapping"),
    ({"policy_kwargs": {"activation_fn": "sigmoidx"}}, "policy_kwargs.activation_fn must be one of"),
    ({"policy_kwargs": "dict(activation_fn='os.system')"}, "policy_kwargs.activation_fn must be one of"),
])
def test_bad_algorithm_values_name_the_key(value: dict, message: str) -> None:
    with pytest.raises(ValueError, match=message.replace(".", r"\.")):
        algo_kwargs(value, 2)


@pytest.mark.parametrize("value", ["dict(gamma=0.9)", {"norm_obs": True, "typo": 1}, None, 1, "[True]"])
def test_bad_normalize_values_are_refused(value: object) -> None:
    with pytest.raises(ValueError, match="^normalize must be true, false or a mapping of"):
        normalize_kwargs(value)
