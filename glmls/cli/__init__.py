"""The ``glmls`` command line (:mod:`.main`); each command is a module of this package."""

from .main import main

__all__ = ["main"]
