"""The research tests keep the 3D tables' disk cache to their run, as the default run does
(tests/conftest.py, which pytest does not load here): they leave nothing in the user's cache."""

from __future__ import annotations

import atexit
import os
import shutil
import tempfile

from sail_env.physics.memo import CACHE_VARIABLE

os.environ[CACHE_VARIABLE] = tempfile.mkdtemp(prefix="lightsail-gym-tables-")
atexit.register(shutil.rmtree, os.environ[CACHE_VARIABLE], ignore_errors=True)
