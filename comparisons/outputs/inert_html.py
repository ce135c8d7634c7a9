"""A tuning guide's HTML section made inert for the report: the tags ``tune`` writes, checked, and nothing else.

    >>> from chatterbench.comparisons.outputs.inert_html import inert_section
    >>> section = inert_section('<h2 id="t">Tuning</h2><script>alert(1)</script><img src="https://x.test/a.png"><!-- x')
    >>> section.html
    '<h2>Tuning</h2>'
    >>> section.removed
    ('1 script', '1 image not embedded in the file', '1 comment')

``report --tune DIR`` puts ``DIR/guide_section.html`` into its page, which promises no script
and no network. The file is parsed (``html.parser``) and written again from what it holds:
the elements a guide is made of (``ALLOWED``: text, headings, tables, lists, code, figures)
with their allowed attributes, text escaped again; an image only when its picture is in the
file (``data:image/png|jpeg|gif;base64``), so nothing is loaded from elsewhere; every other
element, attribute, comment and declaration left out, the content of ``script``, ``style``
and the like with it. No ``style``, ``class`` or ``id`` is kept (issue 45: a ``position:fixed``
div, or a class or id the report's style sheet places, could cover the page with a fake one):
the report's own style sheet sets the section's look. These three, which ``tune`` writes
itself, are dropped without a word; what ``tune`` does not write is counted. Tags left open are closed where the section ends, so nothing in it
(an unclosed ``<!--``, ``<table>``, ``<textarea>``) can hide or swallow the rest of the page.
``removed`` counts what was left out, for the one line the command prints about it.
"""

from __future__ import annotations

import html
import re
from collections import Counter
from html.parser import HTMLParser
from typing import NamedTuple

# element -> the attributes it keeps; what `chatterbench tune` writes into guide_section.html (outputs/guide.py),
# less its presentation (SILENT): nothing from the file places, hides or covers anything on the page
_COMMON = ("title",)
SILENT = {"id", "class", "style"}  # written by tune, dropped without a note
ALLOWED = {
    **dict.fromkeys(("h2", "h3", "h4", "p", "figure", "figcaption", "pre", "code", "strong", "em", "b", "i", "span",
                     "div", "ul", "ol", "li", "table", "thead", "tbody", "tr", "details", "summary", "br"), _COMMON),
    "th": (*_COMMON, "colspan", "rowspan"), "td": (*_COMMON, "colspan", "rowspan"),
    "img": (*_COMMON, "alt", "src", "width", "height"),
}
VOID = {"br", "img"}
DROPPED_WITH_CONTENT = {"script", "style", "iframe", "object", "embed", "template", "noscript", "svg", "math", "textarea",
                        "title", "head", "xmp", "noembed", "noframes"}
_IMAGE = re.compile(r"data:image/(?:png|jpeg|gif);base64,[A-Za-z0-9+/=\s]*")


class InertSection(NamedTuple):
    """The section as the report embeds it, and what was left out (``("1 script", "2 comments")``)."""

    html: str
    removed: tuple[str, ...]


class _Rewriter(HTMLParser):
    def __init__(self) -> None:
        super().__init__(convert_charrefs=True)
        self.out: list[str] = []
        self.open: list[str] = []  # the allowed elements open now
        self.skipping: list[str] = []  # dropped elements whose content goes with them
        self.removed: Counter[str] = Counter()

    def handle_starttag(self, tag: str, attrs) -> None:
        if self.skipping:
            if tag in DROPPED_WITH_CONTENT and tag not in VOID:
                self.skipping.append(tag)
            return
        if tag in DROPPED_WITH_CONTENT:
            self.removed[tag] += 1
            self.skipping.append(tag)
            return
        if tag not in ALLOWED:
            self.removed[f"<{tag}> element"] += 1
            return
        kept = []
        for name, value in attrs:
            value = "" if value is None else value
            if name in SILENT:
                continue
            if name not in ALLOWED[tag]:
                self.removed[f"{name} attribute"] += 1
            elif name == "src" and not _IMAGE.fullmatch(value):
                self.removed["image not embedded in the file"] += 1
                return  # the whole image: it would load from elsewhere
            else:
                kept.append(f' {name}="{html.escape(value, quote=True)}"')
        self.out.append(f"<{tag}{''.join(kept)}>")
        if tag not in VOID:
            self.open.append(tag)

    def handle_startendtag(self, tag: str, attrs) -> None:
        self.handle_starttag(tag, attrs)
        if tag in self.open and tag not in VOID and self.open[-1] == tag:
            self.handle_endtag(tag)

    def handle_endtag(self, tag: str) -> None:
        if self.skipping:
            if tag == self.skipping[-1]:
                self.skipping.pop()
            return
        if tag in self.open:  # close it, and whatever was left open inside it
            while self.open:
                inner = self.open.pop()
                self.out.append(f"</{inner}>")
                if inner == tag:
                    break

    def handle_data(self, data: str) -> None:
        if not self.skipping:
            self.out.append(html.escape(data, quote=False))

    def handle_comment(self, data: str) -> None:
        self.removed["comment"] += 1

    def handle_decl(self, decl: str) -> None:
        self.removed["declaration"] += 1

    def handle_pi(self, data: str) -> None:
        self.removed["processing instruction"] += 1

    def unknown_decl(self, data: str) -> None:
        self.removed["declaration"] += 1


def _said(what: str, n: int) -> str:
    plural = what if n == 1 else (what.replace("image", "images", 1) if what.startswith("image") else
                                  what.replace("attribute", "attributes") if what.endswith("attribute") else
                                  what.replace("element", "elements") if what.endswith("element") else what + "s")
    return f"{n} {plural}"


def inert_section(text: str) -> InertSection:
    """``text`` (a guide section's HTML) as inert HTML and what was left out (module docstring)."""
    rewriter = _Rewriter()
    rewriter.feed(text)
    tail = rewriter.rawdata  # an unfinished construct at the end (an unclosed "<!--", "<a"): left out, not waited for
    rewriter.rawdata = ""
    rewriter.close()
    if tail.strip():
        rewriter.removed["comment" if tail.lstrip().startswith("<!--") else "unfinished tag"] += 1
    closing = "".join(f"</{tag}>" for tag in reversed(rewriter.open))
    removed = tuple(_said(what, n) for what, n in rewriter.removed.items())
    return InertSection("".join(rewriter.out) + closing, removed)
