"""Does the closed loop name the missing physics, and add nothing where nothing lacks? The identification
benchmark (``bench_identification.py``: its systems in ``systems.py``, its batches in ``batches.py``, its protocol
in ``protocol.py``, its checks and side studies in ``checks.py``), the anchors beside it (UDE + SINDy, SINDy
alone), the sparse regressions against pysindy, and ResidualDiagnosis on a complete science model."""
