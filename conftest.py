"""Test-session hooks for the whole repository.

The notebooks run once per test session (nbval); each notebook whose every cell passed is written, with the
outputs of that run, to ``build/executed/`` (``STAIR_EXECUTED_DIR`` overrides), so that the book
(``python -m stair_lite.book``) is built from exactly the copies that were checked. The book's own test
(``tests/test_book.py``) runs after the notebooks. The session ends with each notebook's run time (the sum of its
cells'), against the course's budget of ``NOTEBOOK_BUDGET_S`` per notebook on a 2-core machine.
"""
import os
from pathlib import Path

import nbformat

os.environ.setdefault("PYOPENGL_PLATFORM", "egl")
EXECUTED_DIR = Path(os.environ.get("STAIR_EXECUTED_DIR", Path(__file__).parent / "build" / "executed"))
_passed: dict = {}  # nbval's notebook node -> [its cells collected, its cells passed]; written when all passed
_seconds: dict = {}  # notebook file name -> seconds its cells took in this session
NOTEBOOK_BUDGET_S = 240  # a notebook at learner defaults runs in at most 4 minutes (README, "Teaching")


def pytest_collection_modifyitems(session, config, items):
    """The book's test last: it reads the notebooks executed in this session."""
    items.sort(key=lambda item: Path(str(item.fspath)).name == "test_book.py")
    for item in items:
        if hasattr(item, "test_outputs"):  # a notebook cell under nbval
            _passed.setdefault(item.parent, [0, 0])[0] += 1


def pytest_runtest_makereport(item, call):
    if call.when == "call" and hasattr(item, "test_outputs"):
        name = Path(str(item.fspath)).name
        _seconds[name] = _seconds.get(name, 0.0) + call.duration
    if call.when == "call" and hasattr(item, "test_outputs") and call.excinfo is None:
        item.cell.outputs = item.test_outputs or []
        counts = _passed[item.parent]
        counts[1] += 1
        if counts[0] == counts[1] == sum(cell.cell_type == "code" for cell in item.parent.nb.cells):
            EXECUTED_DIR.mkdir(parents=True, exist_ok=True)  # every cell ran and passed: keep this run's copy
            nbformat.write(item.parent.nb, EXECUTED_DIR / Path(str(item.fspath)).name)


def pytest_collection_finish(session):
    """No copy of an older run beside the notebooks this session runs (a failed one would leave it there)."""
    for node in _passed:
        (EXECUTED_DIR / Path(str(node.fspath)).name).unlink(missing_ok=True)


def pytest_terminal_summary(terminalreporter):
    """Each notebook's run time in this session (the sum of its cells'), flagged when over the budget."""
    if not _seconds:
        return
    terminalreporter.section("notebook run times")
    for name, seconds in sorted(_seconds.items()):
        flag = f"  over the {NOTEBOOK_BUDGET_S} s budget" if seconds > NOTEBOOK_BUDGET_S else ""
        terminalreporter.write_line(f"{seconds:7.1f} s  {name}{flag}")
