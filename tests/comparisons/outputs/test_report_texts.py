"""The report's texts say what the judge does: its tolerances' scales, and its errors with their signs."""

import html
import re

import pytest

from chatterbench.comparisons.outputs.report import build_report
from chatterbench.comparisons.outputs.report_page import report_html, report_markdown
from chatterbench.comparisons.pipeline import tolerances as tolerances_module
from chatterbench.comparisons.pipeline.summary import summarize
from chatterbench.comparisons.pipeline.tolerances import TOLERANCE_KEYS, Tolerances


@pytest.fixture(scope="module")
def report():
    # feigin-pair to its first exit (3.14 s): PyBullet exits 0.14 ms early (dt 1e-4, measured), a
    # negative error whose sign the summary must keep; stick=0.1 shows the text follows the judge's values
    return build_report(["feigin-pair"], engines=("pybullet",), scene_overrides=["duration=3.5"],
                        tol=Tolerances(stick=0.1), progress=None)


def _provenance_tolerances(md: str) -> str:
    return re.search(r"^- tolerances: (.*)$", md, re.M).group(1)


def test_provenance_states_the_judges_tolerances_and_their_per_episode_scales(report):
    md, page = report_markdown(report), report_html(report)
    text = _provenance_tolerances(md)
    assert "time scale T" not in md and "time scale T" not in page  # before: "fractions of the scene's time scale T"
    assert text == tolerances_module.explain(report.comparisons[0].tolerances)  # one source: the judge's Tolerances
    assert html.escape(text) in page
    assert "stick = 0.1: |sticking start - Zeno point| <= 10% of the episode's chatter duration" in text
    assert "exit = 0.02: |exit error| <= 2% of the episode's sliding duration" in text


def test_the_scales_the_provenance_names_are_the_ones_the_judge_divides_by(report):
    # the text: chatter duration = Zeno point - first impact, sliding duration = exit - Zeno point (per episode)
    text = _provenance_tolerances(report_markdown(report))
    assert "own chatter duration = Zeno point - first impact" in text and "sliding duration = exit - Zeno point" in text
    t = report.comparisons[0].table
    row = t[t["wall"] != ""].iloc[0]
    chatter = row["ref_t_stick"] - row["ref_t_first_impact"]
    sliding = row["ref_t_exit"] - row["ref_t_stick"]
    # the _rel errors the judge compares with the tolerances, recomputed from the named scales (1e-9: rounding)
    assert row["stick_error_rel"] == pytest.approx(row["stick_error_zeno"] / chatter, rel=1e-9)
    assert row["exit_error_rel"] == pytest.approx(row["exit_error"] / sliding, rel=1e-9)


def test_every_tolerance_says_what_it_bounds():
    text = tolerances_module.explain(Tolerances())
    for key in TOLERANCE_KEYS:
        assert re.search(rf"(^|; ){key} = {getattr(Tolerances(), key):g}: ", text), key


def test_summary_shows_the_worst_error_with_its_sign(report):
    c = report.comparisons[0]
    exit_error = c.table.loc[c.table["wall"] != "", "exit_error"].dropna()
    assert len(exit_error) == 1 and exit_error.iloc[0] < 0  # PyBullet exits early
    md = report_markdown(report)
    row = re.search(r"^\| feigin-pair \| pybullet \| .*$", md, re.M).group(0).split("|")
    header = re.search(r"^\| scene \| .*$", md, re.M).group(0).split("|")
    shown = float(row[[h.strip() for h in header].index("worst exit error [ms]")])
    assert shown == pytest.approx(exit_error.iloc[0] * 1e3, rel=1e-2) and shown < 0  # before: 0.143, unsigned
    # the gate's metric stays the magnitude, and is the summary's number without its sign
    gate = summarize(c, "pybullet", {})
    assert gate["exit_error_max"] == pytest.approx(abs(exit_error.iloc[0]))
    assert report.summary["exit_error_worst"].iloc[0] == -gate["exit_error_max"]
