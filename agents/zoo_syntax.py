"""The Python expressions RL Baselines3 Zoo hyperparameter files write in strings, read without ``eval``.

Zoo files hold values such as ``policy_kwargs: "dict(net_arch=[64, 64], activation_fn=nn.Tanh)"``.
``eval`` of such a string runs whatever a (downloaded, shared) file contains, and an empty
``__builtins__`` does not stop it (``().__class__.__bases__[0].__subclasses__()`` reaches
every class in the interpreter). :func:`parse` walks the syntax tree instead and builds
values from a closed list of forms; nothing in the string is ever executed.
"""

from __future__ import annotations

import ast
from typing import Any

from torch import nn

#: The activation functions a file may name, as ``nn.<Name>`` in an expression or ``<name>``
#: (any case) as a plain YAML value.
ACTIVATIONS: dict[str, type[nn.Module]] = {
    cls.__name__: cls for cls in (nn.Tanh, nn.ReLU, nn.ELU, nn.LeakyReLU, nn.GELU, nn.SiLU, nn.Sigmoid, nn.Softplus)
}
ACCEPTED = ("literals (numbers, strings, True, False, None, [...], (...), {...}), dict(key=value, ...) "
            f"and the activations {', '.join(f'nn.{name}' for name in ACTIVATIONS)}")


def parse(text: str, key: str) -> Any:
    """The value written in ``text``; ``ValueError`` naming ``key`` for anything outside the accepted forms."""
    try:
        return _value(ast.parse(text.strip(), mode="eval").body, text, key)
    except SyntaxError as err:
        raise ValueError(f"{key}: cannot parse {_shown(text)} ({err.msg}); accepted: {ACCEPTED}") from None
    except (RecursionError, MemoryError):
        raise ValueError(f"{key}: {_shown(text)} is nested too deeply; accepted: {ACCEPTED}") from None


def activation(name: Any, key: str = "activation_fn") -> type[nn.Module]:
    """An accepted activation class, from itself or its name (``tanh``, ``ReLU``, ``nn.ELU``)."""
    if isinstance(name, type) and name in ACTIVATIONS.values():
        return name
    by_lower = {n.lower(): cls for n, cls in ACTIVATIONS.items()}
    if isinstance(name, str) and name.lower().removeprefix("nn.") in by_lower:
        return by_lower[name.lower().removeprefix("nn.")]
    raise ValueError(f"{key} must be one of {sorted(by_lower)} (or nn.<Name>), got {name!r}")


def _value(node: ast.expr, text: str, key: str) -> Any:
    match node:
        case ast.Constant(value=value) if value is None or isinstance(value, (bool, int, float, str)):
            return value
        case ast.UnaryOp(op=ast.USub() | ast.UAdd() as op, operand=ast.Constant(value=value)) \
                if isinstance(value, (int, float)) and not isinstance(value, bool):
            return -value if isinstance(op, ast.USub) else value
        case ast.List(elts=items):
            return [_value(item, text, key) for item in items]
        case ast.Tuple(elts=items):
            return tuple(_value(item, text, key) for item in items)
        case ast.Dict(keys=keys, values=values) if None not in keys:  # None: a ``**mapping`` entry
            names = [_value(k, text, key) for k in keys]
            if all(isinstance(name, (str, int, float)) for name in names):  # hashable, printable
                return {name: _value(v, text, key) for name, v in zip(names, values)}
        case ast.Call(func=ast.Name(id="dict"), args=[], keywords=keywords) \
                if all(keyword.arg is not None for keyword in keywords):
            return {keyword.arg: _value(keyword.value, text, key) for keyword in keywords}
        case ast.Attribute(value=ast.Name(id="nn"), attr=name) if name in ACTIVATIONS:
            return ACTIVATIONS[name]
    part = ast.get_source_segment(text.strip(), node) or ast.dump(node)
    where = "" if part == text.strip() else f" in {_shown(text)}"
    raise ValueError(f"{key}: {_shown(part)}{where} is not accepted; accepted: {ACCEPTED}")


def _shown(text: str, limit: int = 80) -> str:
    """``text`` quoted for a one-line message, shortened if long."""
    return repr(text if len(text) <= limit else text[:limit - 3] + "...")
