"""How every chart and page looks: one colour per engine and the reference, one for sliding, one style sheet.

    >>> from chatterbench.comparisons.outputs.style import ENGINE_COLOURS
    >>> ENGINE_COLOURS["reference"]
    'black'

Verdict colours are the vocabulary's (``pipeline/vocabulary.py``), not repeated here.
``PAGE_CSS`` is the inline style sheet of the HTML pages (``report_page.py``, the tuning
guide), so they look alike.
"""

ENGINE_COLOURS = {"reference": "black", "mujoco": "#1f77b4", "pybullet": "#d62728", "drake": "#ff7f0e",
                 "mujoco_warp": "#17becf"}
STICK_COLOUR = "#2ca02c"  # the reference's sliding: shading, plate entry, Zeno point
EXIT_COLOUR = "#9467bd"  # exits from sliding: the reference's exit marker

# the style sheet of every HTML page the suite writes (the report, the tuning guide): one look, inline, no network
PAGE_CSS = """
body { font-family: system-ui, -apple-system, "Segoe UI", sans-serif; margin: 2em auto; max-width: 1300px;
       padding: 0 1em; color: #222; line-height: 1.4; }
h1 { margin-bottom: 0.2em; } h2 { margin-top: 2em; border-bottom: 1px solid #ccc; }
table { border-collapse: collapse; margin: 0.8em 0; font-size: 0.9em; }
th, td { border: 1px solid #ccc; padding: 0.25em 0.6em; text-align: right; }
th { background: #f3f3f3; } td.text, th.text { text-align: left; }
td.verdict { font-weight: 600; text-align: center; }
figure { margin: 1em 0; } figure img { max-width: 100%; height: auto; border: 1px solid #eee; }
figcaption { font-size: 0.85em; color: #555; }
.note { color: #555; font-size: 0.9em; } code { background: #f6f6f6; padding: 0 0.2em; }
table.prov th { width: 13em; }
"""
