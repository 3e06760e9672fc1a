"""The course edition: a student release of the notebooks and the grading of submissions, with nbgrader.

An exercise in a source notebook is two cells with nbgrader's metadata: the learner's function (a solution cell,
its body between ``### BEGIN SOLUTION`` and ``### END SOLUTION``) and the checker call after it (a graded cell
worth ``points``; it passes when it runs without an error). nbgrader replaces every solution region with
``raise NotImplementedError()`` in the release, and when grading it restores the graded cells from the source, so
a submission cannot edit its own checks.

  python -m stair_lite.course student [--out student]
  python -m stair_lite.course grade SUBMISSIONS [--out grades.csv]

SUBMISSIONS holds one folder per student with that student's notebooks (any subset of the six).
"""
from __future__ import annotations

import argparse
import contextlib
import csv
import os
import shutil
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

import nbformat
import nbformat.validator

NOTEBOOK_DIR = Path(__file__).resolve().parent.parent / "notebooks"
ASSIGNMENT = "stair_lite"  # nbgrader's name for the course's one assignment: the six notebooks
CELL_TIMEOUT_S = 600  # as the notebook tests (nbval's cell timeout)
RUN_PAST = "raises-exception"  # the cell tag with which Run All goes on past an error (Jupyter, nbclient)


def _notebooks(notebooks) -> list[Path]:
    """The given notebooks, or all of the course's."""
    return sorted(NOTEBOOK_DIR.glob("*.ipynb")) if notebooks is None else [Path(n) for n in notebooks]


def _api(root: Path):
    """nbgrader's API on a course folder ``root`` with its own gradebook."""
    from nbgrader.apps import NbGraderAPI
    from traitlets.config import Config

    # nbgrader runs the ``alembic`` command of its environment: make it findable without an activated environment
    os.environ["PATH"] = os.pathsep.join([str(Path(sys.executable).parent), os.environ.get("PATH", "")])
    config = Config()
    config.CourseDirectory.root = str(root)
    config.CourseDirectory.db_url = f"sqlite:///{root / 'gradebook.db'}"
    config.ExecutePreprocessor.timeout = CELL_TIMEOUT_S
    config.Execute.timeout = CELL_TIMEOUT_S
    return NbGraderAPI(config=config)


def _generate(root: Path, notebooks: list[Path]):
    """Copy the source notebooks into a course folder and let nbgrader make the release (and its gradebook)."""
    source = root / "source" / ASSIGNMENT
    source.mkdir(parents=True)
    for nb in notebooks:
        shutil.copy(nb, source / nb.name)
    api = _api(root)
    result = api.generate_assignment(ASSIGNMENT, force=True)
    if not result["success"]:
        raise RuntimeError(f"nbgrader could not generate the student release:\n{result['log']}\n{result.get('error', '')}")
    return api


def _prepare_for_students(path: Path) -> None:
    """A released notebook as a student opens it: exercise cells expanded, graded cells tagged so that Run All
    goes on past a check that fails (the cells after it fall back on the reference)."""
    _, nb = nbformat.validator.normalize(nbformat.read(path, as_version=4))  # nbgrader's output lacks cell ids
    nb = nbformat.from_dict(nb)
    for cell in nb.cells:
        grading = cell.metadata.get("nbgrader", {})
        if grading.get("solution"):
            cell.metadata.get("jupyter", {}).pop("source_hidden", None)
        if grading.get("grade"):
            cell.metadata["tags"] = sorted(set(cell.metadata.get("tags", [])) | {RUN_PAST})
    nbformat.write(nb, path)


@contextlib.contextmanager
def _static_widgets():
    """While grading, the kernels show widgets as their static figures (``widgets.STATIC_ONLY``): nbgrader's
    notebook runner can stall for a whole cell timeout after a cell that displays a live widget."""
    from .widgets import STATIC_ONLY

    before = os.environ.get(STATIC_ONLY)
    os.environ[STATIC_ONLY] = "1"  # the kernels nbgrader starts inherit this process's environment
    try:
        yield
    finally:
        if before is None:
            os.environ.pop(STATIC_ONLY)
        else:
            os.environ[STATIC_ONLY] = before


def student_release(out: str | Path, notebooks: list[Path] | None = None) -> list[Path]:
    """Write the student edition of the notebooks into ``out``: no solution code, no outputs. Returns the files."""
    notebooks = _notebooks(notebooks)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="stair_course_") as tmp:
        _generate(Path(tmp), notebooks)
        written = []
        for nb in notebooks:
            target = out / nb.name
            shutil.copy(Path(tmp) / "release" / ASSIGNMENT / nb.name, target)
            _prepare_for_students(target)
            written.append(target)
    return written


@dataclass(frozen=True)
class Grade:
    """One student's points on one notebook."""

    student: str
    notebook: str
    score: float
    max_score: float
    failed: tuple[str, ...]  # the graded cells that did not pass


def grade(submissions: str | Path, notebooks: list[Path] | None = None, keep: str | Path | None = None) -> list[Grade]:
    """Autograde every student folder in ``submissions`` against the source notebooks (executed by nbgrader with
    the graded cells restored from the source). ``keep``: a folder for the executed submissions."""
    from nbgrader.api import MissingEntry

    notebooks = _notebooks(notebooks)
    submissions = Path(submissions)
    students = sorted(p for p in submissions.iterdir() if p.is_dir()) if submissions.is_dir() else []
    if not students:
        raise ValueError(f"{submissions} holds no student folders: expected {submissions}/<student>/<notebook>.ipynb")
    known = {nb.name for nb in notebooks}
    grades = []
    with tempfile.TemporaryDirectory(prefix="stair_course_") as tmp:
        root = Path(tmp)
        api = _generate(root, notebooks)
        for folder in students:
            files = sorted(folder.glob("*.ipynb"))
            strangers = [f.name for f in files if f.name not in known]
            if strangers or not files:
                raise ValueError(f"{folder} holds {strangers or 'no notebooks'}; a submission holds notebooks named "
                                 f"as the course's: {sorted(known)}")
            target = root / "submitted" / folder.name / ASSIGNMENT
            target.mkdir(parents=True)
            for f in files:
                shutil.copy(f, target / f.name)
            with _static_widgets():
                result = api.autograde(ASSIGNMENT, folder.name, force=True, create=True)
            if not result["success"]:
                raise RuntimeError(f"nbgrader could not grade {folder}:\n{result['log']}\n{result.get('error', '')}")
        with api.gradebook as gb:
            for folder in students:
                submitted = {f.name for f in folder.glob("*.ipynb")}
                for nb in notebooks:
                    if nb.name not in submitted:
                        continue
                    try:
                        sub = gb.find_submission_notebook(nb.stem, ASSIGNMENT, folder.name)
                    except MissingEntry:
                        raise RuntimeError(f"nbgrader recorded no grade for {folder.name}/{nb.name}") from None
                    failed = tuple(sorted(g.name for g in sub.grades if g.max_score > 0 and g.score < g.max_score))
                    grades.append(Grade(folder.name, nb.name, sub.score, sub.max_score, failed))
        if keep is not None:
            shutil.copytree(root / "autograded", Path(keep), dirs_exist_ok=True)
    return grades


def write_table(grades: list[Grade], path: str | Path) -> None:
    """The points as CSV: one row per student and notebook."""
    with open(path, "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(["student", "notebook", "score", "max_score", "failed_checks"])
        for g in grades:
            writer.writerow([g.student, g.notebook, g.score, g.max_score, " ".join(g.failed)])


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="python -m stair_lite.course", description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("student", help="write the student edition of the notebooks")
    p.add_argument("--out", default="student")
    p = sub.add_parser("grade", help="autograde a folder of submissions (one folder per student)")
    p.add_argument("submissions")
    p.add_argument("--out", default="grades.csv")
    args = parser.parse_args(argv)
    if args.command == "student":
        for path in student_release(args.out):
            print(f"wrote {path}")
        return
    grades = grade(args.submissions)
    write_table(grades, args.out)
    width = max(len(g.student) for g in grades)
    for g in grades:
        failed = f"  failed: {', '.join(g.failed)}" if g.failed else ""
        print(f"{g.student:<{width}}  {g.notebook:<32} {g.score:g} / {g.max_score:g}{failed}")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
