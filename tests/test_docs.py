"""The docs that name verdicts and tolerances come from the code that defines them."""

from pathlib import Path

from chatterbench.comparisons.pipeline.tolerances import Tolerances
from chatterbench.comparisons.pipeline.vocabulary import NAMES, document, markdown_table

ROOT = Path(__file__).resolve().parents[1]


def test_readme_verdict_list_is_the_vocabulary():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    block = text.split("<!-- verdicts:begin -->\n", 1)[1].split("\n<!-- verdicts:end -->", 1)[0]
    assert block == markdown_table()


def test_verdict_doc_is_current():
    # regenerate: python -m chatterbench.comparisons.pipeline.vocabulary > docs/verdicts.md
    assert (ROOT / "docs" / "verdicts.md").read_text(encoding="utf-8") == document()


def test_readme_tolerance_table_has_every_default():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    for key, value in Tolerances().as_dict().items():
        assert f"| `{key}` | {value:g} |" in text, key


def test_gate_doc_points_at_the_vocabulary():
    from chatterbench.comparisons.ci import gate

    assert "docs/verdicts.md" in gate.__doc__
    assert gate.TEXT_METRICS["verdict"] == NAMES
