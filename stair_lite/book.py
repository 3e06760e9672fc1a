"""The rendered book: the executed notebooks as a static HTML site (Sphinx with MyST-NB and the book theme).

  python -m stair_lite.book [--executed build/executed] [--out build/book]

Chapters are the executed copies that the notebook tests wrote (``conftest.py``: every cell ran and passed in
that session); a notebook without one, or whose source changed after it, is executed here first (nbclient).
The book adds a page per ``stair_lite`` module with its source, links every mention of a module
(`` `stair_lite/field.py` ``) and of another chapter ("notebook 02") to it, and carries ``REFERENCES.md``,
``RESULTS.md``, and the course plan ``COURSE.md``. The site is ``OUT/html/index.html``: plain files, to be served
by any static host.
"""
from __future__ import annotations

import argparse
import functools
import re
import shutil
import subprocess
import sys
from pathlib import Path

import nbformat
from nbclient import NotebookClient

ROOT = Path(__file__).resolve().parent.parent
NOTEBOOK_DIR, PACKAGE_DIR = ROOT / "notebooks", ROOT / "stair_lite"
CELL_TIMEOUT_S = 600  # as the notebook tests
CONF = '''project = "stair_lite"
author = "stair_lite"
extensions = ["myst_nb", "sphinx-mathjax-offline"]  # MathJax is bundled into the site: equations render offline
html_theme = "sphinx_book_theme"
html_title = "stair_lite: semantic-targeted active reconstruction, step by step"
html_theme_options = {"show_toc_level": 2}
nb_execution_mode = "off"  # the chapters are executed copies: nothing runs while the book is built
myst_enable_extensions = ["dollarmath", "amsmath"]
myst_heading_anchors = 3
exclude_patterns = ["_build"]
suppress_warnings = ["myst.header", "mystnb.unknown_mime_type"]
'''


def chapters() -> list[Path]:
    return sorted(NOTEBOOK_DIR.glob("[0-9][0-9]_*.ipynb"))


@functools.cache
def modules() -> tuple[Path, ...]:
    """The package's modules (subpackages included), as paths relative to the package (read once)."""
    return tuple(sorted(p.relative_to(PACKAGE_DIR) for p in PACKAGE_DIR.rglob("*.py") if p.name != "__init__.py"))


def source_page(module: Path) -> str:
    """The book page of a module: its dotted name, then its source."""
    return "source/" + ".".join(module.with_suffix("").parts)


def executed_copy(notebook: Path, executed_dir: Path) -> nbformat.NotebookNode:
    """The notebook with outputs: the tests' executed copy when it is newer than the source, else run it now."""
    copy = executed_dir / notebook.name
    if copy.exists() and copy.stat().st_mtime >= notebook.stat().st_mtime:
        return nbformat.read(copy, as_version=4)
    print(f"[book] executing {notebook.name} (no executed copy from the tests)", flush=True)
    nb = nbformat.read(notebook, as_version=4)
    NotebookClient(nb, timeout=CELL_TIMEOUT_S, kernel_name="python3",
                   resources={"metadata": {"path": str(NOTEBOOK_DIR)}}).execute()
    executed_dir.mkdir(parents=True, exist_ok=True)
    nbformat.write(nb, copy)
    return nb


def link_mentions(text: str, chapter_files: dict[str, str]) -> str:
    """Markdown with every `stair_lite/x.py` (or `x.py` of a package module) linked to its source page and
    every "notebook NN" linked to that chapter; text already inside a link is left alone."""
    known = {str(m): source_page(m) for m in modules()}

    def module_link(match):
        page = known.get(match.group(2))
        return f"[{match.group(0)}]({page}.md)" if page else match.group(0)

    text = re.sub(r"(?<!\[)`(stair_lite/)?([a-z_]+(?:/[a-z_]+)?\.py)`", module_link, text)
    return re.sub(r"(?<!\[)\b(notebooks? )(0[1-9])\b",
                  lambda m: f"[{m.group(1)}{m.group(2)}]({chapter_files[m.group(2)]})" if m.group(2) in chapter_files
                  else m.group(0), text)


def stage(src: Path, executed_dir: Path) -> None:
    """Write the book's sources: conf.py, the index, the chapters, the module pages and the three documents."""
    if src.exists():
        shutil.rmtree(src)
    (src / "source").mkdir(parents=True)
    (src / "conf.py").write_text(CONF)
    chapter_files = {p.name[:2]: p.name for p in chapters()}
    for notebook in chapters():
        nb = executed_copy(notebook, executed_dir)
        for cell in nb.cells:
            if cell.cell_type == "markdown":
                cell.source = link_mentions(cell.source, chapter_files)
        nbformat.write(nb, src / notebook.name)
    for module in modules():
        code = (PACKAGE_DIR / module).read_text()
        (src / (source_page(module) + ".md")).write_text(
            f"# `stair_lite/{module}`\n\n```python\n{code}\n```\n")
    for document in ("COURSE.md", "REFERENCES.md", "RESULTS.md"):
        shutil.copy(ROOT / document, src / document)
    intro = (ROOT / "README.md").read_text().split("\n## ")[0].split("\n", 1)[1]  # the README's opening paragraphs
    source_entries = "\n".join(source_page(m) for m in modules())
    chapter_entries = "\n".join(p.name for p in chapters())
    (src / "index.md").write_text(
        f"# stair_lite\n{intro}\n\nEach chapter is a notebook of the repository, shown as it ran in the tests; "
        "run it yourself with `make lab`.\n\n"
        f"```{{toctree}}\n:caption: Chapters\n:maxdepth: 1\n\n{chapter_entries}\n```\n\n"
        "```{toctree}\n:caption: Results and references\n:maxdepth: 1\n\nRESULTS.md\nREFERENCES.md\n```\n\n"
        "```{toctree}\n:caption: Teaching with it\n:maxdepth: 1\n\nCOURSE.md\n```\n\n"
        f"```{{toctree}}\n:caption: Source of the package\n:maxdepth: 1\n\n{source_entries}\n```\n")


def build(executed_dir: Path, out: Path) -> Path:
    """Stage and build the book; returns the site's index.html."""
    stage(out / "src", executed_dir)
    html = out / "html"
    subprocess.run([sys.executable, "-m", "sphinx", "-b", "html", "-q", "-j", "1", str(out / "src"), str(html)],
                   check=True)
    return html / "index.html"


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--executed", type=Path, default=ROOT / "build" / "executed",
                        help="the executed notebooks (written by the notebook tests)")
    parser.add_argument("--out", type=Path, default=ROOT / "build" / "book")
    args = parser.parse_args(argv)
    print(f"[book] {build(args.executed, args.out)}")


if __name__ == "__main__":
    main()
