"""The studies' budgets and bounds that their command-line options show: one module that imports nothing.

    >>> from chatterbench.comparisons.studies.limits import MAX_RUNS, NO_WORKERS
    >>> MAX_RUNS, NO_WORKERS
    (600, ('wait', 'stop'))

``tune``, ``sweep`` and ``calibrate`` print these in their ``--help``; read from here, a help
loads no pandas, numba or engine (issue 33: every ``--help`` under 1 s). The studies import
them from here under the same names (``studies.tune.MAX_RUNS`` is this one).
"""

# tune (studies/tune.py)
MAX_RUNS = 600  # the search's budget: runs of up to UNIT_STEPS engine steps (a neighbourhood once begun is completed)
ROBUST_FRACTION = 1.0  # the share of a candidate's band and knob neighbours that must pass where it is robust

# a sweep on Dask (studies/sweep/runner.py)
NO_WORKER_WAIT = 60.0  # [s] a Dask cluster without a worker this long is said on stderr
NO_WORKERS = ("wait", "stop")  # then: wait for a worker, or stop the sweep

# the restitution curve's speeds (studies/restitution_curve.py)
DECADES_BELOW = 2.0  # the default speeds span this many decades below the scene's first impact speed ...
ABOVE = 2.0  # ... up to this many times it
DEFAULT_POINTS = 13  # about five speeds a decade over the default 2.3 decades, ends included
MAX_POINTS = 200  # speeds per engine at most: each is one engine run
