"""The verdicts: every name the judge can give, in one place, with its severity, meaning, colour and abbreviation.

    >>> from chatterbench.comparisons.pipeline.vocabulary import combine, UNDETERMINED, VERDICTS
    >>> combine(["match", "late", "rebound"])
    'late'
    >>> VERDICTS["unresolved"].group, UNDETERMINED
    ('timing', ('unresolved', 'unmeasured'))

Every consumer (compare's summary, sweep rows, the report, the gate, stability maps, the
tuning guide and the docs) takes names, order, colours and meanings from here,
and combines the verdicts of several episodes into one with ``combine``: the most severe
verdict present wins (``SEVERITY``, worst first); ``none`` is what nothing judged gives.

Groups: ``agree`` (the engine does what the reference does), ``timing`` (the right
episodes, at the wrong times), ``impacts`` (the right timing, the wrong impact law),
``physics`` (episodes missing, extra or never ending), ``broken`` (the run left the
physics: through a wall, energy out of bounds), ``failure`` (the run itself failed:
raised, hung, died or blew up). Two verdicts are *undetermined* (``UNDETERMINED``): the
samples cannot pin an error to its tolerance (``unresolved`` for a time, ``unmeasured`` for
restitution), so the run neither passes nor fails that check; a finer step decides. A failure never agrees: a run whose status is not ``ok``
always carries its failure verdict (``FAILURES``), even where the reference has nothing to judge.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable


@dataclass(frozen=True)
class Verdict:
    """One verdict: its name, what it means, and how it is drawn."""

    name: str
    group: str  # agree | timing | impacts | physics | broken | failure
    meaning: str  # one line, for legends and tables
    colour: str  # hex RGB, for tables and maps
    abbrev: str  # a few characters, for map cells
    determined: bool = True  # False: the samples cannot pin an error to its tolerance (neither passed nor failed)


# Worst first: the order ``combine`` uses. Failures of the run first (nothing it says can be
# trusted), then a run that left the physics, then wrong episodes, wrong timing, wrong impacts.
_ALL = (
    Verdict("crashed", "failure", "the engine process died (segfault, abort)", "#000000", "X"),
    Verdict("timeout", "failure", "the engine ran past its time limit", "#424242", "t/o"),
    Verdict("error", "failure", "the engine raised an error", "#8e0000", "err"),
    Verdict("diverged", "failure", "the state went non-finite or the energy grew past its bound", "#e53935", "div"),
    Verdict("penetrated", "broken", "went through a wall, past the scene's penetration allowance", "#ef9a9a", "pen"),
    Verdict("endless", "physics", "chatters through the reference's sliding and never sticks", "#4a148c", "end"),
    Verdict("missed", "physics", "never sticks where the reference slides", "#b39ddb", "mis"),
    Verdict("spurious", "physics", "sticks where the reference does not", "#7e57c2", "spu"),
    Verdict("buzz", "physics", "sticks, but the contact keeps opening after the stick: open longer than the "
            "persistence tolerance allows (the reason gives onsets per second, the open share, the largest gap and "
            "the force's swing)", "#ad1457", "bz"),
    Verdict("late", "timing", "sticks, exits or first impacts too late", "#ff9800", "L"),
    Verdict("early", "timing", "sticks, exits or first impacts too early", "#ffd54f", "E"),
    Verdict("rebound", "impacts", "timing within tolerance, but a resolved impact does not follow R, or the resolved "
            "impacts differ in number from the reference's (the reason says which)", "#4fc3f7", "R"),
    Verdict("unresolved", "timing", "the sampling places a sticking start, exit or first impact only to more than its "
            "tolerance, and the error is within that bound: neither passed nor failed", "#d7ccc8", "~", False),
    Verdict("unmeasured", "impacts", "timing within tolerance, but the step cannot measure any resolved impact to the "
            "restitution tolerance", "#b0bec5", "?", False),
    Verdict("match", "agree", "stick, exit and resolved impacts within tolerance", "#2ca02c", "ok"),
    Verdict("none", "agree", "no sliding in the reference nor in the engine: they agree", "#e0e0e0", "none"),
)

VERDICTS: dict[str, Verdict] = {v.name: v for v in _ALL}
SEVERITY: tuple[str, ...] = tuple(v.name for v in _ALL)  # worst first
NAMES: tuple[str, ...] = tuple(reversed(SEVERITY))  # best first, for legends
FAILURES: tuple[str, ...] = tuple(v.name for v in _ALL if v.group == "failure")  # run statuses that are verdicts
PASSING: tuple[str, ...] = tuple(v.name for v in _ALL if v.group in ("agree", "timing", "impacts") and v.name != "none")
COLOURS: dict[str, str] = {v.name: v.colour for v in _ALL}
ABBREVIATIONS: dict[str, str] = {v.name: v.abbrev for v in _ALL}
MEANINGS: dict[str, str] = {v.name: v.meaning for v in _ALL}
UNDETERMINED: tuple[str, ...] = tuple(v.name for v in _ALL if not v.determined)  # a finer step may pass or fail them

# The words the verdicts, the tables and the docs use, one spelling per thing (docs/verdicts.md, docs/explanation/judge.md).
GLOSSARY: tuple[tuple[str, str], ...] = (
    ("impact", "body 2 reaches a wall and rebounds by Newton's law y'+ = -R y'- (Feigin (1.3)); the event ``impact``"),
    ("strike", "an impact's incoming state (time, wall, y'-), before the law acts: what Feigin's plate and the plate "
               "map classify (a strike slides or leaves)"),
    ("visit", "body 2's time at one wall: from the first impact after an exit, after an impact on the other wall or "
              "from the start of the run, until it leaves that wall"),
    ("episode", "a visit that ends in a stick, in the reference or in the engine: one row of the episode table, "
                "one verdict"),
    ("chatter", "a visit's impacts, shrinking from its first impact to the Zeno point"),
    ("Zeno point", "where the chatter's impacts accumulate, infinitely many in finite time: t + 2 v+ / ((1 - R) |y''|)"
                   " for an impact at t with rebound speed v+ under a constant y''"),
    ("plate entry", "the visit's first strike inside Feigin's sliding plate Pi_2 ((2.1)-(2.2)): sliding is certain "
                    "from there, and Feigin's model sticks at once (event ``plate_entry``)"),
    ("stick", "the event that starts sliding (``stick``, at ``t_stick``): at the Zeno point, at the plate entry in "
              "Feigin's model, at the impact itself when R = 0 (``stick_rule`` says which); \"sticks\" and "
              "\"sticking\" are its verb"),
    ("sliding", "motion in kinematic constraint (Feigin (1.4)): body 2 rides on the wall, y = 0, from the stick to "
                "the exit (the code's ``stuck``: ``reference/stuck.py``)"),
    ("exit", "the end of sliding: the free relative acceleration (3.1) turns away from the wall and the bodies part "
             "(event ``exit``, at ``t_exit``)"),
    ("persistence", "a stuck contact that stays closed: the share of an episode's rest window (from the sticking "
                    "tolerance past the stick to the exit tolerance before the exit) its contact is open, bounded by the "
                    "``persistence`` tolerance (else ``buzz``), with its contact onsets per second, largest gap and the "
                    "force's swing against the load (``persistence.py``)"),
    ("band-robust", "a setting that passes at every checked dt of its band, [0.8, 1.25] x dt (16 or more, both ends "
                    "included), at every checked impact phase (4 or more places of the first impact within a step) and "
                    "at its knob neighbours (``tune``)"),
    ("colour", "the spelling of this code's names and texts (``COLOURS``, ``engine_colour``); ``color`` only "
               "where matplotlib spells it (its keyword, and the values handed to it)"),
)


def rank(verdict: str) -> int:
    """Severity rank, 0 = worst; an unknown name ranks after every known one."""
    return SEVERITY.index(verdict) if verdict in VERDICTS else len(SEVERITY)


def combine(verdicts: Iterable[str]) -> str:
    """One verdict for several episodes: the most severe present; ``none`` when there are none."""
    present = [str(v) for v in verdicts]
    if not present:
        return "none"
    return min(present, key=rank)


def check_verdict(name: str) -> str:
    """Return ``name`` if it is a verdict, else raise ValueError naming the allowed ones."""
    if name not in VERDICTS:
        raise ValueError(f"unknown verdict {name!r}; allowed: {', '.join(NAMES)}")
    return name


def markdown_table() -> str:
    """The vocabulary as a Markdown table (docs/explanation/judge.md, docs/verdicts.md), best first."""
    lines = ["| verdict | group | meaning |", "| --- | --- | --- |"]
    lines += [f"| `{VERDICTS[n].name}` | {VERDICTS[n].group} | {VERDICTS[n].meaning} |" for n in NAMES]
    return "\n".join(lines)


def text_colour(verdict: str) -> str:
    """Black or white, whichever reads on the verdict's colour (tables, map cells)."""
    colour = COLOURS.get(verdict, "#ffffff")
    r, g, b = (int(colour[i:i + 2], 16) for i in (1, 3, 5))
    return "#000000" if 0.299 * r + 0.587 * g + 0.114 * b > 140 else "#ffffff"


def glossary_markdown() -> str:
    """The glossary as a Markdown list (docs/explanation/judge.md, docs/verdicts.md)."""
    return "\n".join(f"- **{word}**: {meaning.replace('``', '`')}." for word, meaning in GLOSSARY)


def document() -> str:
    """docs/verdicts.md: the verdicts, how they combine, and the table (``python -m`` this module writes it)."""
    order = " > ".join(f"`{n}`" for n in SEVERITY)
    return "\n".join([
        "# Verdicts",
        "",
        "Generated from `comparisons/pipeline/vocabulary.py` (`python -m chatterbench.comparisons.pipeline.vocabulary"
        " > docs/verdicts.md`); the docs, the report's legend, the gate and the stability maps use the same names,"
        " meanings and colours.",
        "",
        "Each episode (a visit to a wall that ends in sticking, in the reference or in the engine) gets one verdict;"
        " several combine into one by severity, the worst present naming the run:",
        "",
        order + ".",
        "",
        "A run whose status is not `ok` always carries its failure verdict, also where the reference has nothing to"
        " judge (`none` is what agreement on nothing gives, never what a failed run gets).",
        "",
        markdown_table(),
        "",
        "## Words",
        "",
        glossary_markdown(),
        "",
    ])


if __name__ == "__main__":  # pragma: no cover - the docs generator
    print(document(), end="")
