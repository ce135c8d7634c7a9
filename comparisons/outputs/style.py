"""How every chart and page looks: one colour per engine and the reference, one for sliding, one style sheet.

    >>> from chatterbench.comparisons.outputs.style import REFERENCE_COLOUR, engine_colour
    >>> REFERENCE_COLOUR, engine_colour("mujoco"), engine_colour("pybullet")
    ('black', '#1f77b4', '#d62728')

An engine's colour is its place in the engine table (``engines.registry.ENGINE_NAMES``: the
built-in engines first, then the plugins), taken from ``PALETTE``; so every engine, a plugin's
too, has its own colour, the same in every chart. A name the table does not hold (a
simulator's trajectory file) takes one by a hash of the name, the same on every run.
Verdict colours are the vocabulary's (``pipeline/vocabulary.py``), not repeated here.
``PAGE_CSS`` is the inline style sheet of the HTML pages (``report_page.py``, the tuning
guide), so they look alike.
"""

import zlib

from chatterbench.engines.registry import ENGINE_NAMES

REFERENCE_COLOUR = "black"  # the reference (Feigin's model, exact)
# engines' colours in table order; none is the reference's, the sliding's or the exits' below
PALETTE = ("#1f77b4", "#d62728", "#ff7f0e", "#17becf", "#8c564b", "#e377c2", "#bcbd22", "#7f7f7f", "#393b79",
           "#637939", "#843c39", "#7b4173")
STICK_COLOUR = "#2ca02c"  # the reference's sliding: shading, plate entry, Zeno point
EXIT_COLOUR = "#9467bd"  # exits from sliding: the reference's exit marker


def engine_colour(name: str) -> str:
    """Engine ``name``'s colour in every chart (module docstring); ``"reference"``: ``REFERENCE_COLOUR``."""
    if name == "reference":
        return REFERENCE_COLOUR
    if name in ENGINE_NAMES:
        return PALETTE[ENGINE_NAMES.index(name) % len(PALETTE)]
    return PALETTE[zlib.crc32(name.encode("utf-8", "surrogatepass")) % len(PALETTE)]

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
