"""Test-session hooks for the whole repository.

The notebooks run once per test session (nbval); each notebook whose every cell passed is written, with the
outputs of that run, to ``build/executed/`` (``STAIR_EXECUTED_DIR`` overrides), so that the book
(``python -m stair_lite.book``) is built from exactly the copies that were checked. The book's own test
(``tests/test_book.py``) runs after the notebooks.
"""
import os
from pathlib import Path

import nbformat

os.environ.setdefault("PYOPENGL_PLATFORM", "egl")
EXECUTED_DIR = Path(os.environ.get("STAIR_EXECUTED_DIR", Path(__file__).parent / "build" / "executed"))
_passed: dict = {}  # nbval's notebook node -> [its cells collected, its cells passed]


def pytest_collection_modifyitems(session, config, items):
    """The book's test last: it reads the notebooks executed in this session."""
    items.sort(key=lambda item: Path(str(item.fspath)).name == "test_book.py")
    for item in items:
        if hasattr(item, "test_outputs"):  # a notebook cell under nbval
            _passed.setdefault(item.parent, [0, 0])[0] += 1


def pytest_runtest_makereport(item, call):
    if call.when == "call" and hasattr(item, "test_outputs") and call.excinfo is None:
        item.cell.outputs = item.test_outputs or []
        _passed[item.parent][1] += 1


def pytest_sessionfinish(session):
    for node, (collected, passed) in _passed.items():
        executed = EXECUTED_DIR / Path(str(node.fspath)).name
        if passed == collected == sum(cell.cell_type == "code" for cell in node.nb.cells):  # every cell ran and passed
            EXECUTED_DIR.mkdir(parents=True, exist_ok=True)
            nbformat.write(node.nb, executed)
        else:
            executed.unlink(missing_ok=True)  # never a copy of an older run beside a failed or partial one
