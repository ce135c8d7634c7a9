"""The docs that name verdicts, words and tolerances come from the code that defines them; the tour names every module.

The README is the first screen (under 200 lines: what it answers, the two set-up commands, examples, links to the
site); the site's pages under docs/ hold the rest (the judge's rules, the tour, ...).
"""

import ast
import pkgutil
import re
from pathlib import Path

import chatterbench.comparisons
import chatterbench.engines
import chatterbench.reference
from chatterbench.comparisons.pipeline.tolerances import Tolerances
from chatterbench.comparisons.pipeline.vocabulary import GLOSSARY, NAMES, document, glossary_markdown, markdown_table

ROOT = Path(__file__).resolve().parents[1]
JUDGE = ROOT / "docs" / "explanation" / "judge.md"  # how the judge decides: tolerances, verdicts, words
TOUR = ROOT / "docs" / "explanation" / "architecture.md"  # the tour of the code


def test_the_judge_pages_verdict_list_is_the_vocabulary():
    text = JUDGE.read_text(encoding="utf-8")
    block = text.split("<!-- verdicts:begin -->\n", 1)[1].split("\n<!-- verdicts:end -->", 1)[0]
    assert block == markdown_table()


def test_the_judge_pages_glossary_is_the_vocabularys():
    text = JUDGE.read_text(encoding="utf-8")
    block = text.split("<!-- words:begin -->\n", 1)[1].split("\n<!-- words:end -->", 1)[0]
    assert block == glossary_markdown()
    # every word of the list is defined, once
    words = [w for w, _ in GLOSSARY]
    assert len(set(words)) == len(words)
    assert {"episode", "visit", "impact", "strike", "stick", "sliding", "exit", "plate entry", "Zeno point"} <= set(words)


def test_verdict_doc_is_current():
    # regenerate: python -m chatterbench.comparisons.pipeline.vocabulary > docs/verdicts.md
    assert (ROOT / "docs" / "verdicts.md").read_text(encoding="utf-8") == document()


def test_the_judge_pages_tolerance_table_has_every_default():
    text = JUDGE.read_text(encoding="utf-8")
    for key, value in Tolerances().as_dict().items():
        assert f"| `{key}` | {value:g} |" in text, key


def test_gate_doc_points_at_the_vocabulary():
    from chatterbench.comparisons.ci import gate

    assert "docs/verdicts.md" in gate.__doc__
    assert gate.TEXT_METRICS["verdict"] == NAMES


def _tour() -> dict[str, str]:
    """The tour page's map as {folder: its text}: a folder starts a line (indented by 2: inside the folder above)."""
    block = TOUR.read_text(encoding="utf-8").split("```text\n", 1)[1].split("```\n", 1)[0]
    sections, outer, current = {}, "", None
    for line in block.splitlines():
        indent = len(line) - len(line.lstrip())
        word, _, rest = line.strip().partition(" ")
        if indent <= 2 and word.endswith("/"):
            current = outer + word if indent else word
            outer = outer if indent else word
            sections[current] = rest
        elif current:
            sections[current] += " " + line.strip()
    return sections


def test_the_tour_names_every_module():
    sections = _tour()
    missing = []
    for pkg in (chatterbench.reference, chatterbench.engines, chatterbench.comparisons):
        top = pkg.__name__.split(".", 1)[1]
        for info in pkgutil.walk_packages(pkg.__path__, prefix=pkg.__name__ + "."):
            parts = info.name.split(".")[1:]
            if parts[-1] == "__main__":
                continue
            if info.ispkg:  # a package is a folder of the tour, or named in its parent's
                folder = "/".join(parts) + "/"
                parent = sections.get("/".join(parts[:-1]) + "/", "")
                if folder not in sections and not re.search(rf"(?<![\w/]){parts[-1]}/", parent):
                    missing.append(info.name)
                continue
            text = sections.get("/".join(parts[:-1]) + "/", "")
            if not re.search(rf"(?<![\w/]){parts[-1]}(?![\w/])", text):
                missing.append(info.name)
        assert top + "/" in sections or any(k.startswith(top + "/") for k in sections)
    assert not missing, f"modules the tour ({TOUR.name}) does not name (one line each under their folder): {missing}"


def test_one_spelling_of_colour_in_the_codes_own_names():
    # the glossary's "colour": module-level names, functions, classes and fields say colour; "color" is matplotlib's
    found = []
    for path in [*ROOT.joinpath("reference").rglob("*.py"), *ROOT.joinpath("engines").rglob("*.py"),
                 *ROOT.joinpath("comparisons").rglob("*.py")]:
        tree = ast.parse(path.read_text(encoding="utf-8"))
        scopes = [tree, *(n for n in ast.walk(tree) if isinstance(n, ast.ClassDef))]
        names = [n.name for n in ast.walk(tree) if isinstance(n, (ast.FunctionDef, ast.ClassDef))]
        for scope in scopes:
            for node in scope.body:
                targets = node.targets if isinstance(node, ast.Assign) else [getattr(node, "target", None)]
                names += [t.id for t in targets if isinstance(t, ast.Name)]
        found += [f"{path.relative_to(ROOT)}: {n}" for n in names if "color" in n.lower()]
    assert not found, found


def test_ci_runs_the_readmes_test_command_with_every_optional_extra():
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    command = next(line for line in readme.splitlines() if "pytest" in line and line.startswith("python3 -m pip"))
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8").strip().splitlines()[-1]
    assert ci == command.replace("pip install ", "pip install -q ", 1), (ci, command)
    from chatterbench.engines.registry import BUILT_IN

    extras = re.search(r'"\.\[([^\]]*)\]"', command).group(1).split(",")
    assert {e.extra for e in BUILT_IN if e.extra} <= set(extras), extras  # every optional engine's tests run in CI


def _set_up_block(text: str) -> str:
    return text.split("```bash\n", 1)[1].split("```", 1)[0]


def test_the_install_page_gives_the_readmes_two_commands_as_they_are():
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    page = (ROOT / "docs" / "how-to" / "install.md").read_text(encoding="utf-8")
    assert _set_up_block(page) == _set_up_block(readme)
    assert "chatterbench report" in _set_up_block(readme) and "pytest" in _set_up_block(readme)


def test_the_readme_is_a_first_screen_that_links_every_page_of_the_site():
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert len(readme.splitlines()) < 200
    # the two commands come before any physics: the set-up block opens within the first 30 lines
    assert readme.splitlines().index("```bash") < 30
    links = set(re.findall(r"\]\((docs/[^)#]+\.md)(?:#[^)]*)?\)", readme))
    nav = (ROOT / "mkdocs.yml").read_text(encoding="utf-8").split("\nnav:\n", 1)[1]
    pages = {f"docs/{p}" for p in re.findall(r":\s*([\w/.-]+\.md)\s*$", nav, re.M)}
    assert len(pages) > 20  # every page of the nav was read
    assert [p for p in links if not (ROOT / p).is_file()] == []
    assert sorted(pages - links) == [], "pages of the site the README does not link"
    figures = re.findall(r"!\[[^\]]*\]\(([^)]+)\)", readme)
    assert figures and all((ROOT / f).is_file() for f in figures)


_NAMED_PATH = re.compile(r"(?<![\w./-])((?:chatterbench/)?(?:tests|comparisons|engines|reference|examples|gates|docs|\.ci)/"
                         r"[\w./-]*\w)")


def test_every_file_the_docs_and_gate_files_name_is_there():
    # issue 33: gates/default.toml said "Format: chatterbench/comparisons/gate.py" (it is comparisons/ci/gate.py), the
    # README named tests/comparisons/test_judge.py (it is under pipeline/); a path is read as a user types it
    missing = []
    for doc in [ROOT / "README.md", *ROOT.joinpath("gates").glob("*.toml"), *ROOT.joinpath("docs").rglob("*.md")]:
        # a link's target is relative to its page (docs/reference/cli.md links reference/scene.md as scene.md):
        # mkdocs build --strict checks those (tests/test_docs_site.py), the README's links are checked above
        text = re.sub(r"\]\([^)]*\)", "]()", doc.read_text(encoding="utf-8"))
        for match in _NAMED_PATH.finditer(text):
            path = ROOT / match[1].removeprefix("chatterbench/")  # the package's path inside the repository
            module = path.with_name(path.name.split(".")[0] + ".py")  # engines/registry.BUILT_IN: a name in a module
            if not path.exists() and not module.exists():
                missing.append(f"{doc.relative_to(ROOT)}: {match[1]}")
    assert not missing, missing
