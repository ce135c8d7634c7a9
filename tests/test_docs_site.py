"""The documentation site: `mkdocs build --strict` passes, and its generated reference pages say what the code does.

The reference pages' tables are written at build time by ``docs/hooks/generated.py`` from the code
(the argparse parser, the scene's dataclasses, the code that writes recommended.json, the gate
reader); these tests read the built pages as a reader's browser gets them, and break the hook's
inputs on purpose to see it refuse (a page that would go stale stops the build).
"""

from __future__ import annotations

import argparse
import dataclasses
import doctest
import html
import importlib
import re
import sys
from pathlib import Path

import pytest

mkdocs = pytest.importorskip("mkdocs", reason="the docs site needs mkdocs-material: pip install \".[test]\"")

ROOT = Path(__file__).resolve().parents[1]
HOOKS = ROOT / "docs" / "hooks"


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    """The site, built once with ``mkdocs build --strict`` (any warning fails it: a broken link, a missing page)."""
    from mkdocs.commands.build import build
    from mkdocs.config import load_config

    out = tmp_path_factory.mktemp("site")
    config = load_config(str(ROOT / "mkdocs.yml"), site_dir=str(out), strict=True)
    build(config)  # raises mkdocs.exceptions.Abort on the first warning counted in strict mode
    return out


@pytest.fixture
def hooks(monkeypatch):
    """The hook's modules, imported as mkdocs imports them (from their folder)."""
    monkeypatch.syspath_prepend(str(HOOKS))
    return {name: importlib.import_module(name) for name in ("gen_markup", "gen_cli", "gen_scene", "gen_recommended",
                                                               "gen_gate", "generated")}


def _text(page: Path | str) -> str:
    """A built page's article (or a piece of HTML) as text: tags dropped, character references read, whitespace
    squeezed; the navigation left out."""
    source = page.read_text(encoding="utf-8") if isinstance(page, Path) else page
    article = source.split("<article", 1)[-1].split("</article>", 1)[0]
    return " ".join(html.unescape(re.sub(r"<[^>]+>", " ", article)).split())


def _sections(page: Path) -> dict[str, str]:
    """A built page's text by its second-level headings' ids."""
    parts = re.split(r'<h2 id="([^"]+)"', page.read_text(encoding="utf-8"))
    return {parts[i]: _text(parts[i + 1]) for i in range(1, len(parts), 2)}


def test_the_site_builds_strict_with_every_page_of_the_nav(site):
    for page in ("index.html", "tutorial/index.html", "how-to/plugin/index.html", "reference/cli/index.html",
                 "reference/scene/index.html", "reference/recommended-json/index.html",
                 "reference/gate-file/index.html",
                 "verdicts/index.html", "bad-inputs/index.html", "explanation/judge/index.html",
                 "explanation/architecture/index.html"):
        assert (site / page).is_file(), page
    assert not (site / "hooks").exists()  # the hook's code is not published


def test_the_commands_page_has_every_option_of_every_command(site):
    from chatterbench.comparisons.cli.commands import COMMANDS
    from chatterbench.comparisons.cli.main import build_parser

    sections = _sections(site / "reference" / "cli" / "index.html")
    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    missing = [f"{name} {option}" for name in COMMANDS for action in sub.choices[name]._actions
               if not isinstance(action, argparse._HelpAction)  # every command's --help, said once above the tables
               for option in action.option_strings if option not in sections.get(f"chatterbench-{name}", "")]
    assert not missing, missing
    # a default shown is the parser's (tune's --max-runs), and a help text is --help's
    tune = sections["chatterbench-tune"]
    default = next(a.default for a in sub.choices["tune"]._actions if "--max-runs" in a.option_strings)
    assert re.search(rf"--max-runs [A-Z_]+ {default} the search's budget", tune), tune[:3000]
    assert COMMANDS["tune"] in tune


def test_the_scene_page_has_every_key_a_scene_file_takes(site):
    from chatterbench.reference import scene

    text = _text(site / "reference" / "scene" / "index.html")
    keys = [*scene._TOP_KEYS, *(f"{t}.{k}" for t, ks in scene._SECTION_KEYS.items() for k in ks),
            *(f.name for f in dataclasses.fields(scene.Force))]
    assert [k for k in keys if k not in text] == []
    assert "restitution float required [1] Newton's R at every impact, 0 <= R < 1" in text
    assert "duration float 1.0 [s] simulated time from initial.t" in text  # the reader's default, from the reader


def test_the_recommended_json_page_lists_exactly_what_tune_writes(site, hooks):
    text = _text(site / "reference" / "recommended-json" / "index.html")
    keys = hooks["gen_recommended"].written_keys()
    assert {"answer", "frontier", "tightest", "best_reachable", "same_model"} <= set(keys)
    assert all(k in text for k in keys) and all(k in text for k in hooks["gen_recommended"].point_keys())


def test_a_key_written_with_no_line_stops_the_build(hooks, monkeypatch):
    # known answer the other way: the page cannot silently drop a key the code writes, nor keep one it no longer does
    gen = hooks["gen_recommended"]
    monkeypatch.delitem(gen.TOP, "tightest")
    with pytest.raises(gen.DocsError, match=r"no line .*\['tightest'\]"):
        gen.recommended_markdown()
    monkeypatch.setitem(gen.TOP, "tightest", "back")
    monkeypatch.setitem(gen.POINT, "gone", "a key no longer written")
    with pytest.raises(gen.DocsError, match=r"no longer written: \['gone'\]"):
        gen.recommended_markdown()


def test_the_gate_page_has_every_key_operator_and_metric(site):
    from chatterbench.comparisons.ci import gate

    text = _text(site / "reference" / "gate-file" / "index.html")
    names = [*gate.TOP_KEYS, *gate.CHECK_KEYS, *gate.METRICS, *gate.NUMBER_OPS, *gate.TEXT_OPS]
    assert [n for n in names if n not in text] == []


def test_a_metric_the_gate_docstring_does_not_name_stops_the_build(hooks, monkeypatch):
    gen = hooks["gen_gate"]
    monkeypatch.setattr(gen.gate, "METRICS", (*gen.gate.METRICS, "wobble_max"))
    with pytest.raises(gen.DocsError, match="wobble_max"):
        gen.gate_markdown()


def test_the_verdicts_page_is_the_vocabulary(site):
    from chatterbench.comparisons.pipeline.vocabulary import GLOSSARY, VERDICTS

    text = _text(site / "verdicts" / "index.html")
    for name, verdict in VERDICTS.items():
        assert f"{name} {verdict.group} {' '.join(verdict.meaning.split())}" in text, name
    assert all(word in text for word, _ in GLOSSARY)


def test_text_from_the_code_never_becomes_markup(hooks):
    import markdown

    gen = hooks["gen_markup"]
    hostile = "a | b <script>alert(1)</script> *x* _y_ `z` [l](http://e) \\ # ~~s~~ &amp;"
    row = gen.table(["key", "what"], [[gen.code(hostile), gen.cell(hostile)]])
    page = markdown.markdown(row, extensions=["tables"])
    assert "<script>" not in page and "<em>" not in page and "<a " not in page and "<del>" not in page
    assert page.count("<td>") == 2  # the pipe did not open a column
    cells = re.findall(r"<td>(.*?)</td>", page)
    assert [html.unescape(re.sub(r"</?code>", "", c)) for c in cells] == [hostile, hostile]


def test_an_unknown_part_names_the_page(hooks):
    with pytest.raises(KeyError, match=r"tutorial.md: no generated part 'clii'"):
        hooks["generated"].fill("<!-- generated: clii -->\n", "tutorial.md")


@pytest.mark.parametrize("name", ["gen_markup", "gen_cli", "gen_scene", "gen_recommended", "gen_gate"])
def test_the_hooks_examples_run(hooks, name):
    result = doctest.testmod(hooks[name], globs={}, optionflags=doctest.ELLIPSIS)
    assert result.failed == 0 and result.attempted > 0, result


def test_the_test_extra_installs_the_site_builder():
    text = (ROOT / "pyproject.toml").read_text(encoding="utf-8")
    extra = text.split("test = [", 1)[1].split("]", 1)[0]
    assert '"mkdocs-material' in extra and '"mkdocs>=' in extra
    assert sys.modules.get("material") or importlib.util.find_spec("material"), "mkdocs-material is not installed"
