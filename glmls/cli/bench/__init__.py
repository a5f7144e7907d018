"""``glmls bench``: glmls against the tools a user would pick instead (:mod:`.runner`), on the
same inputs and cases (:mod:`.cases`)."""

from .runner import EXAMPLES, HELP, configure, main, run

__all__ = ["EXAMPLES", "HELP", "configure", "main", "run"]
