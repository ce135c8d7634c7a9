"""The atlas in the report: read from an atlas folder (``report --atlas DIR``) or the dataset kept in the package.

    >>> from chatterbench.comparisons.outputs.atlas_section import packaged_atlas
    >>> section = packaged_atlas()
    >>> section.source.startswith("the atlas kept with chatterbench"), len(section.cases) > 0
    (True, True)

An atlas folder is what ``chatterbench atlas --out DIR`` writes (``studies.atlas``); the report
reads its ``atlas.json`` (provenance) and each ``cases/SCENE/ENGINE/case.json``, following no
link (a link is refused by name), each file bounded. The dataset kept in the package
(``comparisons/atlas_data``) is such a folder without the candidates and figures. The section
says where the atlas comes from (command, machine, date, versions, wall time) and, plainly,
where the engine versions installed here differ from the atlas's: its answers were measured on
those versions.
"""

from __future__ import annotations

import html
import json
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from chatterbench.reference.errors import InputError

from .atlas_files import (POINT_HEADERS, TABLE_HEADERS, point_cells, points_markdown, atlas_frame, atlas_table_markdown, overview_figure, provenance_sentence,
                          scene_figure, table_cells)

DATA = Path(__file__).resolve().parent.parent / "atlas_data"  # the dataset kept in the package
MAX_SPEC_BYTES = 2**20  # [bytes] of an atlas.json: the atlas writes about 1 KiB


@dataclass(frozen=True)
class AtlasSection:
    """An atlas as the report shows it: where from, its provenance, its cases and what differs here."""

    source: str  # in words: the folder given, or the dataset kept with chatterbench
    provenance: dict[str, Any]
    cases: tuple[dict[str, Any], ...]
    version_notes: tuple[str, ...]  # one per engine whose installed version differs from the atlas's


def read_atlas(folder: str | Path, source: str | None = None) -> AtlasSection:
    """The atlas under ``folder`` (module docstring); an ``InputError`` naming the file when it is not one."""
    from chatterbench.comparisons.studies.atlas import SPEC_FILE, AtlasError, done_cases

    folder = Path(folder)
    spec = folder / SPEC_FILE
    for path in (folder, spec, folder / "cases"):
        if path.is_symlink():
            raise AtlasError(f"--atlas {folder}: {path.name} is a link; the report reads no link (copy the atlas)")
    if not spec.is_file():
        raise AtlasError(f"--atlas {folder}: no {SPEC_FILE} there (write an atlas with `chatterbench atlas --out "
                         f"{folder}`)")
    if spec.stat().st_size > MAX_SPEC_BYTES:
        raise AtlasError(f"--atlas {folder}: {SPEC_FILE} is {spec.stat().st_size:,} bytes, more than an atlas writes")
    fd = os.open(spec, os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0))
    with os.fdopen(fd, "rb") as f:
        raw = f.read(MAX_SPEC_BYTES + 1)
    try:
        provenance = json.loads(raw.decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise AtlasError(f"--atlas {folder}: {SPEC_FILE} is not an atlas's ({exc})") from None
    if not isinstance(provenance, dict):
        raise AtlasError(f"--atlas {folder}: {SPEC_FILE} is not an atlas's (not a JSON object)")
    cases = tuple(done_cases(folder).values())
    for case in cases:
        _check_case(case, folder)
    provenance = {**provenance, "wall_s": sum(c.get("wall_s") or 0 for c in cases if _positive(c.get("wall_s")))}
    codes = sorted({str(c["code"]) for c in cases if c.get("code")})
    if len(codes) > 1 or (codes and codes[0] != provenance.get("code")):  # a resumed atlas: say which code ran
        provenance["code"] = f"cases made by {', '.join(codes)}" + (
            f" (and {provenance['code']})" if provenance.get("code") and provenance["code"] not in codes
            and any(not c.get("code") for c in cases) else "")
    machines: dict[str, int] = {}  # a case without its machine (written before cases named theirs): the atlas's
    for case in cases:
        where = str(case.get("machine") or provenance.get("machine", "?"))
        machines[where] = machines.get(where, 0) + 1
    if len(machines) > 1:  # a resumed atlas: say where each share of its cases ran (their wall times differ there)
        most_first = sorted(machines.items(), key=lambda kv: (-kv[1], kv[0]))
        provenance["machine"] = "; ".join(f"{m} ({n} case{'s' * (n != 1)})" for m, n in most_first)
    return AtlasSection(source=source or str(folder), provenance=provenance, cases=cases,
                        version_notes=tuple(version_notes(provenance, {c["engine"] for c in cases})))


def _check_case(case: dict[str, Any], folder: Path) -> None:
    """A case the tables can show: its frontier entries with numeric tolerances, dt and cost."""
    from chatterbench.comparisons.studies.atlas import AtlasError

    where = f"--atlas {folder}: cases/{case.get('scene')}/{case.get('engine')}/case.json"
    for k in ("scene", "engine", "status"):
        if not isinstance(case.get(k), str):
            raise AtlasError(f"{where}: `{k}` must be text")
    rec = case.get("recommended")
    if rec is None:
        return
    if not isinstance(rec, dict) or not isinstance(rec.get("frontier", []), list):
        raise AtlasError(f"{where}: `recommended` must be tune's recommended.json")
    for e in rec.get("frontier", []):
        ok = (isinstance(e, dict) and isinstance(e.get("tolerances"), dict)
              and all(_positive(e["tolerances"].get(k)) for k in ("stick", "restitution"))
              and _positive(e.get("dt")) and _positive(e.get("cost_steps_per_s")))
        if not ok:
            raise AtlasError(f"{where}: a frontier entry needs positive numbers `dt`, `cost_steps_per_s` and "
                             "`tolerances.stick`, `tolerances.restitution`")


def _positive(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and 0 < v < float("inf")


def packaged_atlas() -> AtlasSection | None:
    """The dataset kept in the package (None when the package has none)."""
    if not (DATA / "atlas.json").is_file():
        return None
    return read_atlas(DATA, source="the atlas kept with chatterbench (comparisons/atlas_data)")


def version_notes(provenance: dict[str, Any], engines) -> list[str]:
    """Per engine of the atlas whose version here differs from the atlas's: one sentence."""
    from chatterbench.engines.registry import engine_version, unavailable_reason

    made = provenance.get("versions") or {}
    notes = []
    for engine in sorted(engines):
        if engine not in made:
            continue
        if unavailable_reason(engine):
            notes.append(f"{engine} is not installed here (the atlas measured {engine} {made[engine]})")
            continue
        here = engine_version(engine)
        if str(here) != str(made[engine]):
            notes.append(f"{engine} {here} is installed here, the atlas measured {engine} {made[engine]}: its answers "
                         "may differ on this version (rerun `chatterbench atlas` to measure it)")
    return notes


def atlas_html(section: AtlasSection, img) -> str:
    """The section as HTML: heading, provenance, version notes, overview chart, each scene's chart, the table.
    ``img(fig, id, caption)``: a matplotlib figure as the report embeds it."""
    atlas = atlas_frame(section.cases)
    asked = (section.provenance.get("search") or {}).get("tolerances")
    parts = ['<h2 id="atlas">Atlas: every engine\'s band-robust frontier on every scene</h2>',
             f'<p class="note">From {html.escape(section.source)}. {html.escape(provenance_sentence(section.provenance))}.'
             " Band-robust: passes at every dt of [0.8, 1.25] x dt, at 4 impact phases and at the knobs' neighbours; "
             "persistence: the contact's open share after each stick, and its onsets per second.</p>"]
    parts += [f'<p class="note version-note">Versions differ: {html.escape(n)}.</p>' for n in section.version_notes]
    if len(atlas):
        parts.append(img(overview_figure(atlas), "atlas-overview", "The atlas at a glance: per scene and engine, the "
                         "tightest tolerances reached band-robustly (colour: the sticking tolerance) and the cost of the "
                         "robust setting at the asked tolerances"))
        for scene in dict.fromkeys(atlas["scene"]):
            parts.append(img(scene_figure(section.cases, scene, asked), f"atlas-frontier-{scene}",
                             f"{scene}: each engine's cheapest band-robust setting against the tolerance it reaches, "
                             "timing (left) and restitution (right), from the atlas"))
    parts.append(_table(TABLE_HEADERS, table_cells(atlas), text=(0, 1, 2, 5)))
    parts.append(_table(POINT_HEADERS, point_cells(section.cases), text=(0, 1, 2)))
    return "\n".join(parts)


def _table(headers, rows, text=()) -> str:
    """An HTML table of plain cells, escaped; the columns in ``text`` left-aligned (the page's ``text`` class)."""
    cls = lambda k: ' class="text"' if k in text else ' class="num"'  # noqa: E731
    return ("<table><thead><tr>" + "".join(f"<th{cls(k)}>{html.escape(h)}</th>" for k, h in enumerate(headers))
            + "</tr></thead><tbody>" + "".join("<tr>" + "".join(f"<td{cls(k)}>{html.escape(c)}</td>"
                                                                for k, c in enumerate(row)) + "</tr>" for row in rows)
            + "</tbody></table>")


def atlas_md(section: AtlasSection) -> str:
    """The section as Markdown: the atlas's table under a heading, with where it comes from and the version notes."""
    from ..pipeline.inert_text import md_escape

    notes = "".join(f"Versions differ: {md_escape(n)}.\n\n" for n in section.version_notes)
    return (f"## Atlas: every engine's band-robust frontier on every scene\n\nFrom {md_escape(section.source)}. "
            f"{md_escape(provenance_sentence(section.provenance))}.\n\n{notes}"
            f"{atlas_table_markdown(atlas_frame(section.cases))}\n\n{points_markdown(section.cases)}\n")


def check_atlas(folder: str) -> AtlasSection:
    """``--atlas DIR`` read for the report; its problems as ``InputError`` naming the option."""
    try:
        return read_atlas(folder)
    except InputError:
        raise
    except OSError as exc:
        raise InputError(f"--atlas {folder}: cannot read it ({exc.strerror or exc})") from None
