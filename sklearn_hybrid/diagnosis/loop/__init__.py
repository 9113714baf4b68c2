"""The closed loop: find what the science misses, add it where held-out data support it, refit.

``close.py`` holds :func:`close_the_loop`, the one call, which runs the stages of ``stages.py`` (each
with a typed input and output); ``stepwise.py`` the forward selection
(screen, refit, judge, drop, second look); ``placed.py`` what a candidate is (a term placed on a
component, or several judged as one); ``candidates.py`` the candidates and their rankings;
``joint.py`` the sets of terms that explain the residual only together; ``collapse.py`` the single
term that replaces stand-ins; ``arguments.py`` the checks of the loop's arguments, made before anything
is fitted; ``report.py`` the :class:`LoopResult` that reports and plots itself; ``watch.py`` the seam through
which a study of the loop itself (the identification benchmark's checks) sees the selected model and stresses
the second look, without replacing any of these functions.
The judge, the network-free refits and the evidence rule are shared with the exploratory wing and
live one floor up.
"""

from .candidates import Candidates
from .close import close_the_loop
from .report import LoopResult, format_table, plot_unexplained, prediction_metrics

__all__ = ["close_the_loop", "Candidates", "LoopResult", "format_table", "plot_unexplained", "prediction_metrics"]
