"""How every chart draws the engines and the reference: one colour each, one for sliding.

    >>> from chatterbench.comparisons.outputs.style import ENGINE_COLORS
    >>> ENGINE_COLORS["reference"]
    'black'

Verdict colours are the vocabulary's (``pipeline/vocabulary.py``), not repeated here.
"""

ENGINE_COLORS = {"reference": "black", "mujoco": "#1f77b4", "pybullet": "#d62728"}
STICK_COLOR = "#2ca02c"  # the reference's sliding: shading, plate entry, Zeno point
