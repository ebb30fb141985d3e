"""Opt-in compiled core: with ``WISWARM_MYPYC=1`` the sans-I/O core (``wiswarm_zenoh/core``,
but its package file and ``policies``, whose array-or-float generics mypyc refuses) is
compiled by mypyc, about twice as fast on the leader's poll path; without it (the
default) the package is pure Python. Everything else is in ``pyproject.toml``.

    WISWARM_MYPYC=1 python setup.py build_ext --inplace   # ``make compiled``
"""

import os
from pathlib import Path

from setuptools import setup

NOT_COMPILED = {"__init__.py", "config.py", "policies.py"}

ext_modules = []
if os.environ.get("WISWARM_MYPYC") == "1":
    from mypyc.build import mypycify

    core = sorted(str(path) for path in Path("wiswarm_zenoh/core").glob("*.py")
                  if path.name not in NOT_COMPILED)
    ext_modules = mypycify(["--config-file", "pyproject.toml", *core],
                           group_name="wiswarm_zenoh.core.native")

setup(ext_modules=ext_modules)
