"""How fast? The training loop against plain PyTorch, free runs, large fits, the memory check, the README's Quick
start, and the time from data to a trustworthy theta (``bench_time_to_theta.py``, ``bench_time_to_answer.py``,
``bench_long_record.py``), with the systems written for the last two studies."""
