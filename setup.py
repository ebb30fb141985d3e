"""Opt-in compiled core: with ``WISWARM_MYPYC=1`` the sans-I/O core (``wiswarm_zenoh/core``,
but its package file and ``policies``, whose array-or-float generics mypyc refuses) and
the transport modules every poll runs through (``POLL_PATH``) are compiled by mypyc:
the core two to three times as fast alone, but the leader's polls/s no faster since the
reply is judged after the next poll went (``docs/measurements.md``); without it (the
default) the package is pure Python. Everything else is in ``pyproject.toml``.

    WISWARM_MYPYC=1 python setup.py build_ext --inplace   # ``make compiled``
"""

import os
from pathlib import Path

from setuptools import setup

NOT_COMPILED = {"__init__.py", "config.py", "policies.py"}
POLL_PATH = ("leader_node", "steady_gets", "outlets", "links")  # in wiswarm_zenoh/transport

ext_modules = []
if os.environ.get("WISWARM_MYPYC") == "1":
    from mypyc.build import mypycify

    core = sorted(str(path) for path in Path("wiswarm_zenoh/core").glob("*.py")
                  if path.name not in NOT_COMPILED)
    transport = [f"wiswarm_zenoh/transport/{name}.py" for name in POLL_PATH]
    ext_modules = mypycify(["--config-file", "pyproject.toml", *core, *transport],
                           group_name="wiswarm_zenoh.core.native")

setup(ext_modules=ext_modules)
