"""Command-line conventions of the scripts: a bad input is one line on stderr and exit code 2."""

from __future__ import annotations

import argparse
import contextlib
import os
import re
import stat
import sys
import tempfile
import warnings
from pathlib import Path
from types import TracebackType


class UsageError(ValueError):
    """A bad command-line argument; the message is one line."""


class Parser(argparse.ArgumentParser):
    """argparse that raises :class:`UsageError` instead of printing the usage and exiting."""

    def error(self, message: str) -> None:  # type: ignore[override]
        raise UsageError(f"{message} (see --help)")


class HelpFormatter(argparse.ArgumentDefaultsHelpFormatter, argparse.RawDescriptionHelpFormatter):
    """Shows defaults (not the absent ones: ``None``, an unset flag, an empty list), keeps the
    description's and epilog's line breaks."""

    def _get_help_string(self, action: argparse.Action) -> str | None:
        if action.default is None or action.default is False or action.default == []:
            return action.help
        return super()._get_help_string(action)


def describe(docstring: str) -> str:
    """A module docstring as ``--help`` text: all of it, without reStructuredText's double backticks."""
    return docstring.replace("``", "")


def positive_int(text: str) -> int:
    """An argparse type: a whole number >= 1."""
    return _int_at_least(text, 1)


def non_negative_int(text: str) -> int:
    """An argparse type: a whole number >= 0 (seeds)."""
    return _int_at_least(text, 0)


def _int_at_least(text: str, minimum: int) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a whole number >= {minimum}, got {text!r}") from None
    if value < minimum:
        raise argparse.ArgumentTypeError(f"must be >= {minimum}, got {value}")
    return value


def distinct(values: list, flag: str) -> list:
    """``values`` if none is given twice; a repeated one would run (and count) its work twice."""
    repeated = sorted({str(v) for v in values if values.count(v) > 1})
    if repeated:
        raise UsageError(f"argument {flag}: {', '.join(repeated)} given more than once (see --help)")
    return values


def given_flags(parser: argparse.ArgumentParser, argv: list[str] | None) -> set[str]:
    """The destinations of the options ``argv`` names (a flag given at its default value included, which
    comparing values with the defaults cannot tell apart), by parsing it again with no defaults."""
    defaults = [(action, action.default) for action in parser._actions]
    try:
        for action, _ in defaults:
            action.default = argparse.SUPPRESS
        return set(vars(parser.parse_args(argv)))
    finally:
        for action, default in defaults:
            action.default = default


def fail(message: object) -> int:
    """Print ``error: message`` as one line on stderr; the exit code of a refused input."""
    print(f"error: {' '.join(str(message).split())}", file=sys.stderr)
    return 2


#: Terminal colour codes, which gymnasium puts around its warnings' text.
_ANSI = re.compile(r"\x1b\[[0-9;]*m")


class OneLineWarnings:
    """Python warnings (gymnasium's about an out-of-date env id, a library's) as one ``warning: …``
    line each on stderr, each text once, instead of Python's two lines (file, line, then code).

    Held until :meth:`release`: a script releases them once its checks passed, so a refusal before
    then is its one error line alone. A context manager: on exit, warnings show as before.
    """

    def __init__(self) -> None:
        self._held: list[str] | None = []
        self._seen: set[str] = set()
        self._saved = warnings.catch_warnings()

    def __enter__(self) -> OneLineWarnings:
        self._saved.__enter__()
        warnings.showwarning = self._show
        return self

    def __exit__(self, kind: type[BaseException] | None, error: BaseException | None,
                 traceback: TracebackType | None) -> None:
        self._saved.__exit__(kind, error, traceback)

    def _show(self, message: Warning | str, category: type[Warning], filename: str, lineno: int,
              file: object = None, line: str | None = None) -> None:
        text = " ".join(_ANSI.sub("", str(message)).removeprefix("WARN: ").split())
        if text in self._seen:
            return
        self._seen.add(text)
        if self._held is None:
            print(f"warning: {text}", file=sys.stderr, flush=True)
        else:
            self._held.append(text)

    def release(self) -> None:
        """Print the warnings held so far; later ones print as they come."""
        for text in self._held or []:
            print(f"warning: {text}", file=sys.stderr, flush=True)
        self._held = None


def check_writable_dir(path: Path, flag: str) -> None:
    """Refuse now, not after the work: ``path``, or the nearest folder above it that exists, must
    be a folder a file can be created in (tried, and removed). Creates nothing that stays."""
    existing = path
    try:
        while not existing.exists():
            existing = existing.parent
    except OSError as err:
        raise UsageError(f"{flag} {path}: cannot inspect {existing} ({err.strerror})") from err
    if not existing.is_dir():
        raise UsageError(f"{flag} {path}: {existing} is not a directory")
    try:
        with tempfile.NamedTemporaryFile(dir=existing, prefix=".write-check-"):
            pass
    except OSError as err:
        raise UsageError(f"{flag} {path}: cannot write in {existing} ({err.strerror or err})") from err


def section_markers(name: str) -> tuple[str, str]:
    """The HTML comments that delimit a generated section ``name`` of a README."""
    return f"<!-- {name}:start -->", f"<!-- {name}:end -->"


def readme_around_section(readme: Path, name: str) -> tuple[str, str]:
    """The README's text before and after its generated section ``name`` (:class:`UsageError` if
    it cannot be read or lacks the markers): checked before the section is rendered."""
    start, end = section_markers(name)
    try:
        text = readme.read_text()
    except (OSError, UnicodeDecodeError) as err:
        raise UsageError(f"--readme {readme}: cannot read it ({getattr(err, 'strerror', None) or err})") from err
    if start not in text or end not in text.split(start, 1)[-1]:
        raise UsageError(f"--readme {readme}: no {start} … {end} markers to put the table between")
    head, rest = text.split(start, 1)
    return head, rest.split(end, 1)[1]


def write_whole(path: Path, content: str | bytes) -> None:
    """Write ``content`` (text, or bytes as they are) to ``path`` whole or not at all: into a file beside
    it, then renamed over it, so that Ctrl-C or a full disk leaves the old file as it was (a README's
    hand-written text, a kept export, a training run's checkpoint)."""
    temporary = tempfile.NamedTemporaryFile("wb" if isinstance(content, bytes) else "w",
                                            encoding=None if isinstance(content, bytes) else "utf-8",
                                            dir=path.parent, prefix=f".{path.name}.", suffix=".tmp", delete=False)
    try:
        with temporary:
            temporary.write(content)
        # The file keeps its permissions (a new one gets the umask's), not the temporary file's 0600.
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(temporary.name, stat.S_IMODE(os.stat(path).st_mode) if path.exists() else 0o666 & ~umask)
        os.replace(temporary.name, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(temporary.name)
        raise


def replace_readme_section(readme: Path, name: str, body: str) -> None:
    """Put ``body`` between the README's markers of section ``name`` (the file replaced whole)."""
    head, tail = readme_around_section(readme, name)
    start, end = section_markers(name)
    write_whole(readme, f"{head}{start}\n{body}\n{end}{tail}")
