"""A failing check points at its line of the gate file, and a gate speaks the report's column names (issue 33, item 3).

Before: ``::error title=chatter gate NAME::...`` carried no ``file=``/``line=``, so nothing
pointed at the failing check in the gate file; and ``report`` printed ``stick_error_worst``
where a gate refused it ("did you mean 'stick_error_max'?").
"""

from __future__ import annotations

import re

import pytest

from helpers import RESTS, ball_check, ball_gate, cli

GATE = ball_gate(  # two checks of the ball on PyBullet (0.2 s of engine time each)
    ball_check("passes", ["verdict == match"]),
    ball_check("fails", ["verdict == match", "stick_error_max <= 1e-6"], comment="# the one that fails",
               extra="tolerances = { stick = 0.06 }"),
    description="lines", defaults=f"settings = {RESTS}   # the ball rests (its default 0 keeps bouncing: buzz)\n")


def _line_of(text: str, needle: str) -> int:
    """The file's own line (from 1) holding ``needle``, as an editor numbers it."""
    return next(n for n, line in enumerate(text.splitlines(), 1) if needle in line)


@pytest.fixture
def github(monkeypatch):
    monkeypatch.setenv("GITHUB_ACTIONS", "true")
    monkeypatch.delenv("GITHUB_STEP_SUMMARY", raising=False)


def test_the_annotation_names_the_gate_file_and_the_failing_limits_line(tmp_path, monkeypatch, github):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "gates").mkdir()
    (tmp_path / "gates" / "mine.toml").write_text(GATE)
    done = cli(["gate", "gates/mine.toml"])
    assert done.code == 1, done.err
    errors = [line for line in done.out.splitlines() if line.startswith("::error ")]
    assert len(errors) == 1, errors  # the passing check has none
    where = re.match(r"::error file=([^,]+),line=(\d+),title=chatter gate fails::", errors[0])
    assert where, errors[0]
    assert where[1] == "gates/mine.toml"  # as given, relative to where the job runs (the repository's root)
    assert int(where[2]) == _line_of(GATE, '"stick_error_max <= 1e-6"')


def test_a_check_missing_from_the_baseline_points_at_its_header(tmp_path, monkeypatch, github):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "gate.toml").write_text(GATE.replace('"stick_error_max <= 1e-6"', '"stick_error_max <= 1"'))
    assert cli(["gate", "gate.toml", "--save-baseline", "base.json"]).code == 0
    (tmp_path / "gate.toml").write_text(GATE.replace('"stick_error_max <= 1e-6"', '"stick_error_max <= 1"')
                                        .replace('name = "fails"', 'name = "renamed"'))
    done = cli(["gate", "gate.toml", "--baseline", "base.json"])
    assert done.code == 1
    errors = [line for line in done.out.splitlines() if line.startswith("::error ")]
    assert len(errors) == 1 and "title=chatter gate renamed::" in errors[0], errors
    assert f"file=gate.toml,line={_line_of(GATE, '[[check]]   # the one that fails')}," in errors[0]


@pytest.mark.slow
def test_a_gate_takes_the_columns_the_report_prints(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    shown = cli(["report", "bouncing-ball", "--engines", "pybullet", "--set", "duration=1.6", "--out", "r"])
    assert shown.code == 0, shown.err
    table = shown.out.splitlines()
    header = next(i for i, line in enumerate(table) if "stick_error_worst" in line)
    columns, cells = table[header].split(), table[header + 1].split()
    worst = float(cells[columns.index("stick_error_worst")])  # PyBullet sticks 2.3 ms late: positive
    assert 1e-3 < worst < 3e-3
    base = ('[[check]]\nscene = "bouncing-ball"\nengine = "pybullet"\ndt = 1e-4\nscene_overrides = { duration = 1.6 }\n'
            "limits = [%s]\n")
    for limits, code in ((f'"stick_error_worst >= {worst * 0.99!r}", "stick_error_worst <= {worst * 1.01!r}"', 0),
                         (f'"stick_error_worst <= {worst * 0.9!r}"', 1),  # later than that: caught
                         ('"stick_error_worst <= 0"', 1),  # "never late" fails; "never early" holds
                         ('"stick_error_worst >= 0"', 0)):
        (tmp_path / "g.toml").write_text(base % limits)
        done = cli(["gate", "g.toml"])
        assert done.code == code, (limits, done.out, done.err)
        if code:
            assert "stick_error_worst = " in done.out


def test_a_bare_keyword_on_a_signed_column_is_refused():
    from chatterbench.comparisons.ci.gate import GateError, limits_from_keywords

    with pytest.raises(GateError, match=r"stick_error_worst is signed .* stick_error_worst=\('>=', -0.01\)"):
        limits_from_keywords(stick_error_worst=0.01)
    assert str(limits_from_keywords(stick_error_worst=(">=", -0.01))[0]) == "stick_error_worst >= -0.01"


def test_the_gate_pages_file_format_reads_as_written(tmp_path):
    # the docs document the format (before: only a docstring did); the how-to's example is a valid gate file, lines
    # and all (the reference page, docs/reference/gate-file.md, is written from gate.py's docstring at build time)
    from pathlib import Path

    from chatterbench.comparisons.ci.gate import load_gate

    page = (Path(__file__).resolve().parents[3] / "docs" / "how-to" / "gate.md").read_text(encoding="utf-8")
    example = page.split("```toml\n", 1)[1].split("```", 1)[0]
    (tmp_path / "example.toml").write_text(example)
    gate = load_gate(tmp_path / "example.toml")
    check = gate.checks[0]
    assert (check.name, check.engine, check.dt, dict(check.settings)) == ("feigin-pair/mujoco", "mujoco", 1e-4, {"w0_dt": 0.03})
    assert [str(lim) for lim in check.limits] == ["verdict == match", "exit_error_max <= 0.002", "n_match >= 13"]
    assert check.line == _line_of(example, "[[check]]")
    assert check.limit_lines == tuple(_line_of(example, f'"{t}"') for t in ("verdict == match", "exit_error_max <= 2e-3",
                                                                             "n_match >= 13"))


def test_a_line_separator_inside_a_name_does_not_move_the_lines():
    from chatterbench.comparisons.ci.gate_lines import check_lines

    # issue 45: U+2028 and U+0085 are allowed in a TOML string; str.splitlines broke the line there, so every limit
    # after it was pointed at one line too far
    text = '[[check]]\nname = "a\u2028b\x85c"\nlimits = [\n  "verdict == match",\n]\n'
    assert check_lines(text, [["verdict == match"]]) == [(1, (4,))]
