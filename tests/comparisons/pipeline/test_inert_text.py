"""The one encoder of text from an input shown in a CI log or Markdown (issue 45): no line, command, heading or tag."""

from __future__ import annotations

import pytest

from chatterbench.comparisons.pipeline.inert_text import log_text, md_code, md_escape

HOSTILE = ["3.2.7\n::warning title=INJ::x\n## INJ fake PASS", "a\rb", "::error::x", "  ::notice::x", "x ##[error]y",
           "###[x", "a\u2028b\u2029c\x85d", "\x1b[31mred", "| INJ | row |"]


@pytest.mark.parametrize("text", HOSTILE)
def test_no_input_starts_a_line_or_a_workflow_command(text):
    shown = log_text(text)
    assert len(shown.splitlines()) == 1  # Python's splitlines: every line break there is, Unicode's included
    assert not shown.lstrip().startswith("::") and "##[" not in shown
    assert log_text(shown) == shown  # twice is once


@pytest.mark.parametrize("text", ["bouncing-ball/pybullet", "scene: a, b", "gate.toml", "x::y", "# a name"])
def test_a_clean_name_is_shown_as_it_is(text):
    assert log_text(text) == text


@pytest.mark.parametrize("text", [*HOSTILE, "<img src=http://198.51.100.7/beacon.png>\n## INJ", "<script>x</script>"])
def test_markdown_holds_no_tag_heading_or_cell_from_an_input(text):
    shown = md_escape(text)
    assert len(shown.splitlines()) == 1
    assert "<" not in shown.replace("\\<", "") and "|" not in shown.replace("\\|", "")
    assert not shown.lstrip().startswith("#")


@pytest.mark.parametrize("text", ["a`b", "``x", "a\n## INJ`"])
def test_a_code_span_is_one_span_on_one_line(text):
    span = md_code(text)
    fence = span[:len(span) - len(span.lstrip("`"))]
    assert span.endswith(fence) and fence not in span[len(fence):-len(fence)] and "\n" not in span
