"""The rendered book (``stair_lite.book``), checked in a real headless browser (Debian's chromium).

It is built from the notebooks that this test session executed (``conftest.py`` writes them and runs this test
last), so ``make test`` runs every notebook once. Alone, without those copies, it is skipped unless
STAIR_BOOK_REQUIRED=1 (as ``make test`` sets), when their absence is a failure.
"""
import functools
import http.server
import json
import os
import re
import shutil
import subprocess
import threading
from pathlib import Path

import pytest

from stair_lite import book

EXECUTED = Path(os.environ.get("STAIR_EXECUTED_DIR", book.ROOT / "build" / "executed"))
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")

# Loads a page in an iframe of the same origin and reports its title and each figure in the chapter's body:
# loaded (a decoded image with a size) and blank (every pixel the same colour on a canvas).
CHECK_PAGE = """<!doctype html><html><body><pre id="result">pending</pre><script>
const page = PAGE;
async function inspect(page) {
  const frame = document.createElement("iframe");
  frame.style.width = "1200px"; frame.style.height = "800px";
  document.body.appendChild(frame);
  await new Promise(done => { frame.onload = done; frame.src = page; });
  const doc = frame.contentDocument;
  const images = [...doc.querySelectorAll("main img, article img")];
  // onload means every image has loaded; decode() may stay pending while MathJax keeps headless chromium's virtual
  // clock busy, so it is given 5 virtual seconds (drawImage decodes a loaded image anyway)
  const pause = new Promise(done => setTimeout(done, 5000));
  await Promise.all(images.map(img => Promise.race([img.decode().catch(() => null), pause])));
  const figures = images.map(img => {
    const loaded = img.complete && img.naturalWidth > 0;
    let blank = true;
    if (loaded) {
      const canvas = document.createElement("canvas");
      canvas.width = img.naturalWidth; canvas.height = img.naturalHeight;
      const context = canvas.getContext("2d");
      context.drawImage(img, 0, 0);
      const data = context.getImageData(0, 0, canvas.width, canvas.height).data;
      for (let i = 4; i < data.length; i += 4) {
        if (data[i] !== data[0] || data[i + 1] !== data[1] || data[i + 2] !== data[2]) { blank = false; break; }
      }
    }
    return {src: img.getAttribute("src"), loaded, blank};
  });
  return {page, title: doc.title, figures};
}
inspect(page).then(report => { document.getElementById("result").textContent = JSON.stringify(report); }).catch(error => { document.getElementById("result").textContent = "error: " + error; });
</script></body></html>"""


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    missing = [p.name for p in book.chapters() if not (EXECUTED / p.name).exists()]
    if missing:
        reason = f"no executed copies of {missing} in {EXECUTED}: run the notebooks in the same session"
        if os.environ.get("STAIR_BOOK_REQUIRED") == "1":
            pytest.fail(reason)
        pytest.skip(reason)
    return book.build(EXECUTED, tmp_path_factory.mktemp("book")).parent


class QuietHandler(http.server.SimpleHTTPRequestHandler):
    def log_message(self, *args):
        pass


def browser_report(html_dir: Path, page: str) -> dict:
    """Open ``page`` of the site in headless chromium over HTTP and return the check page's report on it."""
    check = f"_check_{page}"
    (html_dir / check).write_text(CHECK_PAGE.replace("PAGE", json.dumps(page)))
    handler = functools.partial(QuietHandler, directory=str(html_dir))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    try:
        dom = subprocess.run(
            [CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
             "--virtual-time-budget=60000", "--dump-dom", f"http://127.0.0.1:{server.server_port}/{check}"],
            capture_output=True, text=True, timeout=300, check=True).stdout
    finally:
        server.shutdown()
    result = re.search(r'<pre id="result">(.*?)</pre>', dom, re.S).group(1)
    assert result != "pending", f"the check of {page} did not finish in the browser"
    assert not result.startswith("error"), f"{page}: {result}"
    return json.loads(result.replace("&quot;", '"').replace("&amp;", "&"))


@pytest.mark.skipif(CHROMIUM is None, reason="chromium is not installed (make test installs it)")
def test_every_chapter_loads_in_a_browser_with_its_figures(site):
    assert "stair_lite" in browser_report(site, "index.html")["title"]
    for chapter in book.chapters():
        page = browser_report(site, chapter.with_suffix(".html").name)
        assert chapter.stem[3:].split("_")[0] in page["title"].lower(), page["title"]
        assert page["figures"], f"{page['page']} shows no figure"
        broken = [f["src"] for f in page["figures"] if not f["loaded"]]
        blank = [f["src"] for f in page["figures"] if f["loaded"] and f["blank"]]
        assert not broken and not blank, f"{page['page']}: broken {broken}, blank {blank}"


def test_chapters_link_to_each_other_and_to_the_source(site):
    chapter = (site / "04_entropy_utility.html").read_text()
    assert 'href="02_voxel_occupancy_field.html"' in chapter  # "notebook 02" in the text
    assert re.search(r'href="source/utility.html"><code', chapter)  # `utility.py` in the text
    source = (site / "source" / "utility.html").read_text()
    assert "def score_views" in re.sub(r"<[^>]+>", "", source)


def test_the_course_plan_is_a_page_of_the_book(site):
    plan = re.sub(r"<[^>]+>", "", (site / "COURSE.html").read_text())
    assert all(f"Week {k}" in plan for k in (1, 2, 3, 4)) and "capstone" in plan.lower()
    assert 'href="COURSE.html"' in (site / "index.html").read_text()


def test_mentions_are_linked_once():
    chapters = {"02": "02_voxel_occupancy_field.ipynb"}
    text = "See `stair_lite/field.py`, `utility.py`, `nothing.py` and notebook 02 ([notebook 02](x.ipynb))."
    linked = book.link_mentions(text, chapters)
    assert "[`stair_lite/field.py`](source/field.md)" in linked and "[`utility.py`](source/utility.md)" in linked
    assert "`nothing.py` and" in linked  # not a module: left alone
    assert linked.count("](02_voxel_occupancy_field.ipynb)") == 1 and "[notebook 02](x.ipynb)" in linked


def rendered_dom(html_dir: Path, page: str) -> str:
    """The DOM of ``page`` after headless chromium ran its scripts (MathJax among them), served over HTTP."""
    handler = functools.partial(QuietHandler, directory=str(html_dir))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    try:
        return subprocess.run(
            [CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
             "--virtual-time-budget=60000", "--dump-dom", f"http://127.0.0.1:{server.server_port}/{page}"],
            capture_output=True, text=True, timeout=300, check=True).stdout
    finally:
        server.shutdown()


@pytest.mark.skipif(CHROMIUM is None, reason="chromium is not installed (make test installs it)")
def test_every_chapters_equations_render_without_a_network(site):
    """MathJax is part of the site (no CDN): in a browser with no network, as here, every equation is typeset and
    none is left as raw LaTeX."""
    typeset = {}
    for page in [chapter.with_suffix(".html").name for chapter in book.chapters()] + ["COURSE.html"]:
        dom = rendered_dom(site, page)
        text = re.sub(r"<(script|style)\b.*?</\1>", "", dom, flags=re.S)
        text = re.sub(r"<mjx-container\b.*?</mjx-container>", "", text, flags=re.S)  # typeset math keeps its source
        raw = [m for m in ("\\(", "\\[") if m in text]
        assert not raw, f"{page}: equations shown as raw LaTeX ({raw})"
        typeset[page] = dom.count("<mjx-container")
    assert typeset["04_entropy_utility.html"] > 50, typeset  # the utility's chapter is full of equations
    assert typeset["COURSE.html"] > 5, typeset  # the course plan's misconceptions and answers hold equations
    assert sum(n > 0 for n in typeset.values()) >= 6, typeset
