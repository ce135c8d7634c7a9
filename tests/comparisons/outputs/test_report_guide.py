"""``report --tune DIR`` embeds a guide section as inert content: in a browser nothing in it runs, loads or hides the page.

Before (issue 34): ``t/guide_section.html`` was embedded verbatim, so a ``<script>`` in it ran
in the report, a remote ``<img>`` was fetched (the report promises no network), and an
unclosed ``<!--`` hid the rest of ``index.html``. Here a real report, opened by headless
Chromium with a local server standing in for the network. Issue 45: a ``position:fixed`` div
covering the page (and a class and id of the page's own) is kept as text in the flow, never placed.
"""

from __future__ import annotations

import http.server
import re
import shutil
import subprocess
import threading
from pathlib import Path

import pytest

from helpers import cli

CHROMIUM = next((p for p in ("/usr/bin/chromium", shutil.which("chromium") or "", shutil.which("chromium-browser") or "")
                 if p and Path(p).exists()), None)


class _Counting(http.server.BaseHTTPRequestHandler):
    hits: list[str] = []

    def do_GET(self):  # noqa: N802 - the handler's name
        type(self).hits.append(self.path)
        self.send_response(204)
        self.end_headers()

    def log_message(self, *args):  # quiet
        pass


@pytest.fixture
def server():
    httpd = http.server.HTTPServer(("127.0.0.1", 0), _Counting)
    _Counting.hits = []
    thread = threading.Thread(target=httpd.serve_forever, daemon=True)
    thread.start()
    yield httpd.server_address[1]
    httpd.shutdown()


def _hostile(port: int) -> str:
    return ('<h2 id="tuning-pybullet-bouncing-ball">Tuning pybullet for bouncing-ball</h2>\n'
            f"<p>the answer</p><script>document.title = 'ran'; fetch('http://127.0.0.1:{port}/script')</script>\n"
            f'<img src="http://127.0.0.1:{port}/beacon.png" alt="beacon">'
            f'<img src="data:image/png;base64,AAAA" onerror="document.title = \'ran too\'">'
            f'<p style="background: url(http://127.0.0.1:{port}/style.png)">styled</p>\n'
            # issue 45: a div over the whole page, white, on top, holding a fake verdict
            '<div style="position:fixed;inset:0;z-index:2147483647;background:white" class="summary" id="summary">'
            "<h1>chatterbench report</h1><p>every engine: match</p></div>\n<p>then <!-- never closed")


@pytest.mark.skipif(CHROMIUM is None, reason="no Chromium installed (apt-get install chromium) to open the report")
def test_a_hostile_guide_section_is_inert_in_a_browser(tmp_path, server, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "t").mkdir()
    (tmp_path / "t" / "guide_section.html").write_text(_hostile(server))
    done = cli(["report", "bouncing-ball", "--engines", "pybullet", "--set", "duration=1.6", "--tune", "t", "--out", "r"])
    assert done.code == 0, done.err
    assert "left out of the report: 1 script, 1 image not embedded in the file, 1 onerror attribute, 1 <h1> element, " \
           "1 comment" in done.err
    page = tmp_path / "r" / "index.html"
    dom = subprocess.run([CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
                          "--disable-background-networking", f"--user-data-dir={tmp_path / 'profile'}",
                          "--virtual-time-budget=3000", "--dump-dom", page.as_uri()],
                         capture_output=True, text=True, timeout=90).stdout
    assert re.search(r"<title>chatterbench report</title>", dom)  # no script of the section ran
    dom = re.sub(r"<!--.*?-->", "", dom, flags=re.S)  # what a comment holds is not on the page
    assert "Tuning pybullet for bouncing-ball" in dom and "the answer" in dom and "styled" in dom  # its text is there
    assert "What produced this report" in dom  # and so is the rest of the page, after it
    assert _Counting.hits == []  # nothing was fetched
    end = dom.index('<h2 id="atlas"') if '<h2 id="atlas"' in dom else dom.index('<h2 id="provenance"')
    section = dom[dom.index("Tuning pybullet for bouncing-ball"):end]  # the guide section, up to what the report adds
    assert "every engine: match" in section  # the overlay's text stays, as text in the flow of the page
    assert "style=" not in section and "class=" not in section and "id=" not in section  # nothing places it on top

