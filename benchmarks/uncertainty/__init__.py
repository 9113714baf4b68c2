"""Is theta identified, and do the intervals hold the truth? Coverage over repeated data sets of the profiles,
the bootstrap and the network-free model's intervals (``bench_uncertainty.py``), of the fit report's standard
errors, of the Laplace experiment and of the intervals with fitted initial states; the systems are in
``systems.py``."""
