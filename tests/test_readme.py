"""The README's quick example runs and prints what the README says it prints; the paths and
``python -m`` modules that the README and the docs cite exist."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_quick_example_prints_what_the_readme_shows() -> None:
    section = (ROOT / "README.md").read_text().split("## Quick example", 1)[1]
    code, printed = re.findall(r"```(?:python)?\n(.*?)```", section, flags=re.S)[:2]
    run = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    assert run.stdout == printed


#: The README and the docs, the two folder READMEs among them.
DOCS = ("README.md", "docs/*.md", "benchmarks/README.md", "research/README.md")
#: A repository path in the text (a folder of the repository, then a file or folder name; ``[012]``
#: globs kept), not part of a longer path or of ``git show REV:path`` (an old commit's file).
CITED_PATH = re.compile(r"(?<![\w./:-])((?:sail_env|agents|benchmarks|research|tests|docs)/[\w./*-]*(?:\[\w-]+\])?[\w*]*)")
CITED_MODULE = re.compile(r"python3? -m ((?:sail_env|agents|benchmarks|research)(?:\.\w+)+)")
LINK = re.compile(r"\]\(([^)#\s]+)")


def cited_paths_missing(doc: Path) -> list[str]:
    """The paths, ``python -m`` modules and relative links of ``doc`` that name nothing in the tree."""
    text, missing = doc.read_text(), []
    for path in CITED_PATH.findall(text):
        path = path.rstrip(".")
        if not any(list(base.glob(path)) if any(c in path for c in "*[") else (base / path).exists()
                   for base in (ROOT, doc.parent)):  # from the root, or a link from the doc's folder
            missing.append(path)
    for module in CITED_MODULE.findall(text):
        base = ROOT / module.replace(".", "/")
        if not (base.with_suffix(".py").is_file() or (base / "__main__.py").is_file() or (base / "__init__.py").is_file()):
            missing.append(f"python -m {module}")
    for link in LINK.findall(text):
        if "://" not in link and not (doc.parent / link).exists():
            missing.append(f"({link})")
    return missing


def test_the_docs_cite_paths_that_exist() -> None:
    """A moved or removed script, result or module fails here until the docs follow it."""
    docs = [doc for pattern in DOCS for doc in sorted(ROOT.glob(pattern))]
    assert len(docs) >= 8
    assert {str(doc.relative_to(ROOT)): cited_paths_missing(doc) for doc in docs} == {str(doc.relative_to(ROOT)): [] for doc in docs}
