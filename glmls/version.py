"""glmls's version (one place: the package, the command line and the wheel's metadata read it)."""

__version__ = "0.2.0"
