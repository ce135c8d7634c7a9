"""Studies made of many comparisons: sweeps (``sweep/``), tuning (``tune/``), the sliding-plate map
(``plate_map``), isolation of each run in a child process (``isolate``) and the benchmarks (``bench``; tune's:
``bench_tune``).
"""
