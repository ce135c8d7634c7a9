"""Copy-paste between files, found by pylint's own rule (its ``duplicate-code`` check, R0801) in a tenth of the time.

``pylint --disable=all --enable=duplicate-code --min-similarity-lines=6`` reports a block of more than 6 lines
that two files share once comments, docstrings, imports and function signatures are stripped. pylint runs that
check with ``pylint.checkers.symilar.Symilar``; what makes it slow (13 s over this project's 170 files) is the
tree each file needs for its imports and signatures: ``astroid.parse`` infers every ``self.x = ...`` it sees,
importing numpy and pandas into astroid to do so. The lines it strips come from the tree's shape alone (the line
spans of import statements and of ``def`` headers), which the same astroid builder gives without inference or
transforms; ``copies`` hands Symilar that tree and otherwise runs pylint's code (1.3 s here).
``tests/test_layout.py`` checks that the report is pylint's on files with and without copies.

    >>> import tempfile, pathlib
    >>> from duplicates import copies
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> body = "".join(f"    total = total + {i} * x\\n" for i in range(7))
    >>> for name in ("a", "b"):
    ...     _ = (folder / f"{name}.py").write_text(f"def {name}(x):\\n    total = 0\\n{body}    return total\\n")
    >>> "9 similar lines in 2 files" in copies(sorted(folder.glob("*.py")))
    True
"""

from __future__ import annotations

from pathlib import Path

MIN_LINES = 6  # a shared block longer than this is a copy (pylint's --min-similarity-lines)


def copies(paths: list[Path], min_lines: int = MIN_LINES, fast: bool = True) -> str:
    """pylint's similarity report for ``paths`` ("" when no block of more than ``min_lines`` lines is shared).

    ``fast`` False: each file's tree from ``astroid.parse`` (what pylint builds; for the check that both agree).
    """
    from astroid.builder import AstroidBuilder
    from astroid.manager import AstroidManager
    from pylint.checkers.symilar import Symilar

    builder = AstroidBuilder(AstroidManager(), apply_transforms=False)
    similar = Symilar(min_lines=min_lines, ignore_comments=True, ignore_docstrings=True, ignore_imports=True,
                      ignore_signatures=True)
    for path in paths:
        text = Path(path).read_text(encoding="utf-8")
        tree = builder._data_build(text, "", str(path))[0] if fast else None  # the tree, neither inferred nor transformed
        with open(path, encoding="utf-8") as stream:
            similar.append_stream(str(path), stream, tree=tree)
    found = similar._compute_sims()
    return similar._get_similarity_report(found) if found else ""
