"""Grading that a submission cannot subvert: the tripwire that reads submitted code, and the isolation that grades
each notebook in its own confined process (a tiny course notebook, so that each case takes seconds)."""
import glob
import os

import nbformat
import pytest

from stair_lite import course
from stair_lite.course_guard import findings, tampering

SOLUTION = ("def view_angle(view_a, view_b):\n"
            "    def direction(view):\n"
            "        el, az = view\n"
            "        return np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])\n"
            "    return float(np.arccos(np.clip(direction(view_a) @ direction(view_b), -1.0, 1.0)))\n")
WRONG = "def view_angle(view_a, view_b):\n    return abs(view_a[0] - view_b[0]) + abs(view_a[1] - view_b[1])\n"


@pytest.mark.parametrize("code, what", [
    ("import stair_lite.exercises.sensor as s\ns.check_view_angle = lambda f: True", "changes s.check_view_angle"),
    ("stair_lite.exercises.sensor.check_view_angle = print", "changes stair_lite.exercises.sensor.check_view_angle"),
    ("np.allclose = lambda *a, **k: True", "changes np.allclose"),
    ("def view_angle(a, b):\n    m = np\n    m.isclose = lambda *a, **k: True\n    return 0.0", "changes m.isclose"),
    ("def view_angle(a, b):\n    return check_view_angle.reference(a, b)", "reads the attribute reference"),
    ("import os\nos._exit(1)", "imports os"),
    ("f = view_angle.__globals__", "reads the attribute __globals__"),
    ("setattr(np, 'allclose', print)", "uses setattr"),
    ("with open('/etc/passwd') as f:\n    pass", "uses open"),
    ("!rm -rf /", "runs the shell"),
    ("from stair_lite.exercises.sensor import _close", "imports the private name _close"),
])
def test_the_tripwire_names_code_that_reaches_for_the_grader(code, what):
    assert any(what in finding for _, finding in findings(code)), findings(code)


def test_the_tripwire_passes_every_solution_and_ordinary_code():
    ordinary = "buf.use_counts[3] = 0\nout = np.zeros(3)\nout[:2] = 1.0\nclass A:\n    def __init__(self):\n        self.k = 2\n"
    assert findings(ordinary) == []
    for path in sorted(glob.glob(str(course.NOTEBOOK_DIR / "*.ipynb"))):
        for cell in nbformat.read(path, as_version=4).cells:
            if cell.metadata.get("nbgrader", {}).get("solution"):
                assert findings(cell.source) == [], (path, cell.metadata["nbgrader"]["grade_id"])
    # the source notebook's own cells are not read: only what a submission changed or added
    assert tampering(["%matplotlib inline", "np.allclose = 1"], ["%matplotlib inline"]) == \
        ["cell 1 line 1: changes np.allclose (allclose is a name the checkers rely on)"]


def tiny_course(folder):
    """A one-exercise course notebook (notebook 01's view angle) and a helper that writes submissions of it."""
    def cell(source, **grading):
        c = nbformat.v4.new_code_cell(source)
        if grading:
            c.metadata["nbgrader"] = {"schema_version": 3, "task": False, "locked": not grading.get("solution", False),
                                      "grade": False, "solution": False, **grading}
        return c

    body = SOLUTION.replace("    def direction", "    ### BEGIN SOLUTION\n    def direction") + "    ### END SOLUTION"
    nb = nbformat.v4.new_notebook(cells=[
        cell("import numpy as np\nfrom stair_lite.exercises.sensor import check_view_angle"),
        cell(body, grade_id="t_view_angle", solution=True),
        cell("check_view_angle(view_angle)", grade_id="t_view_angle_check", grade=True, points=1),
    ])
    source = folder / "01_tiny.ipynb"
    nbformat.write(nb, source)

    def submit(student, answer, extra=None):
        sub = nbformat.read(source, as_version=4)
        sub.cells[1].source = answer
        if extra is not None:
            sub.cells.insert(2, nbformat.v4.new_code_cell(extra))
        (folder / "submissions" / student).mkdir(parents=True)
        nbformat.write(sub, folder / "submissions" / student / source.name)
    return source, submit


def test_grading_survives_cheats_escapes_hangs_and_broken_files(tmp_path, monkeypatch):
    """One class: a right answer; one that replaces the checker; one that writes outside its folder by a route the
    tripwire does not read (numpy's save); one that never ends; a text file named as the notebook; a notebook the
    course does not have. Each gets its row and reason; the right one its point; nothing is written outside; no
    temporary folder is left."""
    source, submit = tiny_course(tmp_path)
    outside = tmp_path / "outside"
    outside.mkdir()
    os.chmod(outside, 0o755)  # the grader's folder: readable, writable only by its owner
    submit("good", SOLUTION)
    submit("patcher", WRONG, "import stair_lite.exercises.sensor as s\ns.check_view_angle = lambda f: True")
    submit("writer", SOLUTION.replace("    return float(", f"    np.save({str(outside / 'x.npy')!r}, np.zeros(1))\n"
                                                        "    return float("))
    submit("sleeper", "def view_angle(view_a, view_b):\n    while True:\n        pass\n")
    (tmp_path / "submissions" / "broken").mkdir()
    (tmp_path / "submissions" / "broken" / source.name).write_text("not a notebook")
    nbformat.write(nbformat.read(source, as_version=4), tmp_path / "submissions" / "broken" / "08_mine.ipynb")
    temporary = tmp_path / "tmp"
    temporary.mkdir()
    monkeypatch.setenv("TMPDIR", str(temporary))
    monkeypatch.setattr("tempfile.tempdir", None)

    grades = course.grade(tmp_path / "submissions", [source], limits=course.Limits(cell_timeout_s=20), workers=2)
    rows = {(g.student, g.notebook): g for g in grades}
    assert rows[("good", source.name)].score == 1 == rows[("good", source.name)].max_score
    assert rows[("good", source.name)].reason == ""
    patcher = rows[("patcher", source.name)]
    assert patcher.score == 0 and "reaches for the grader" in patcher.reason and "check_view_angle" in patcher.reason
    sleeper = rows[("sleeper", source.name)]
    assert sleeper.score == 0 and "cell limit of 20 s" in sleeper.reason
    assert rows[("broken", source.name)].score == 0 and "not a readable notebook" in rows[("broken", source.name)].reason
    assert "not a notebook of the course" in rows[("broken", "08_mine.ipynb")].reason
    if course.confinement():  # graded in a read-only world: the write was refused, so the check never passed
        assert rows[("writer", source.name)].score == 0
    assert not (outside / "x.npy").exists()
    assert list(temporary.iterdir()) == []  # no course folder left behind
    course.write_table(grades, tmp_path / "grades.csv")
    assert (tmp_path / "grades.csv").read_text().splitlines()[0].endswith(",failed_checks,reason")


def test_grade_names_a_missing_or_empty_folder(tmp_path, capsys):
    for folder in (tmp_path / "missing", tmp_path):
        with pytest.raises(SystemExit) as stop:
            course.main(["grade", str(folder)])
        assert stop.value.code == 2 and str(folder) in capsys.readouterr().err
    with pytest.raises(SystemExit):
        course.main(["grade", str(tmp_path), "--timeout", "0"])
    assert "cell_timeout_s must be at least 1, got 0" in capsys.readouterr().err


def test_the_confined_process_gets_the_memory_limit():
    import resource
    import subprocess
    import sys

    limits = course.Limits(memory_gb=2)
    code = "import resource; print(resource.getrlimit(resource.RLIMIT_AS)[0])"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         preexec_fn=course._limit_memory(limits), check=True).stdout
    assert int(out) == 2 * 2**30 != resource.getrlimit(resource.RLIMIT_AS)[0]


@pytest.mark.skipif(os.geteuid() != 0, reason="the confinement needs root (it then drops every capability)")
def test_the_confinement_leaves_only_the_submissions_folder_writable(tmp_path):
    import subprocess
    import sys

    assert course.confinement(), "this machine allows mount namespaces as root: grading must confine"
    work = tmp_path / "work"
    work.mkdir()
    code = ("import pathlib\n"
            f"pathlib.Path({str(work / 'inside')!r}).write_text('x')\n"
            f"pathlib.Path({str(tmp_path / 'outside')!r}).write_text('x')")
    run = subprocess.run([*course.confinement(), str(work), sys.executable, "-c", code], capture_output=True, text=True)
    assert "Read-only file system" in run.stderr and (work / "inside").exists() and not (tmp_path / "outside").exists()


@pytest.mark.parametrize("stop", ["SIGINT", "SIGTERM"])
def test_an_interrupted_grading_leaves_no_folder_and_no_process(tmp_path, stop):
    import signal
    import subprocess
    import sys
    import time

    source, submit = tiny_course(tmp_path)
    submit("sleeper", "def view_angle(view_a, view_b):\n    while True:\n        pass\n")
    temporary = tmp_path / "tmp"
    temporary.mkdir()
    code = ("import sys; from pathlib import Path; from stair_lite import course; "
            f"course.NOTEBOOK_DIR = Path({str(tmp_path)!r}); course.main(sys.argv[1:])")
    child = subprocess.Popen([sys.executable, "-c", code, "grade", str(tmp_path / "submissions"), "--out",
                              str(tmp_path / "grades.csv")], env={**os.environ, "TMPDIR": str(temporary)},
                             preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL) and None,
                             stdout=subprocess.PIPE, stderr=subprocess.STDOUT, start_new_session=True)
    deadline = time.time() + 120
    while not list(temporary.glob("*/work/*/autograded")) and time.time() < deadline:  # the kernel is running
        time.sleep(0.5)
    assert time.time() < deadline, "grading never reached the submission"
    time.sleep(2)
    child.send_signal(getattr(signal, stop))
    child.wait(timeout=60)
    assert child.returncode != 0 and list(temporary.iterdir()) == []
    assert subprocess.run(["pgrep", "-f", str(tmp_path)], capture_output=True).stdout == b""  # no kernel left
