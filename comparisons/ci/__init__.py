"""Accuracy gates in a user's CI: gate files (``gate``), running them (``checks``), the one pass/fail
decision (``decision``: limits, ``baseline``, failed runs) that JUnit XML (``junit``) and the job
outputs (``job_outputs``) render, and the ``chatter_gate`` pytest fixture (``pytest_plugin``).

    >>> from chatterbench.comparisons.ci.gate import load_gate
    >>> [c.name for c in load_gate("gates/default.toml").checks][:2]
    ['bouncing-ball/pybullet', 'feigin-pair/pybullet']
"""
