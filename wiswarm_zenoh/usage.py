"""User-facing errors: one line on stderr, exit code 2. At the bottom of the layers, so
that any module may refuse bad configuration the way the command line does."""

from __future__ import annotations

import argparse
from typing import NoReturn


class UsageError(Exception):
    """A problem with flags or configuration that the user must fix (exit code 2)."""


class OneLineParser(argparse.ArgumentParser):
    """An argument parser whose errors are a single line on stderr, exit code 2."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: error: {message}\n")
