"""Does the package reproduce the paper? Its Table 1 (``table1.py``), its six tasks at CPU size
(``bench_tasks.py``), the pendulum's theta by method, Figure 2a's sensitivity, the appendix's varying theta, and
two studies of why a task's theta stalls or is biased; the tasks themselves are in ``tasks.py``."""
