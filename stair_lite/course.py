"""The course edition: a student release of the notebooks and the grading of submissions, with nbgrader.

An exercise in a source notebook is two cells with nbgrader's metadata: the learner's function (a solution cell,
its body between ``### BEGIN SOLUTION`` and ``### END SOLUTION``) and the checker call after it (a graded cell
worth ``points``; it passes when it runs without an error). nbgrader replaces every solution region with
``raise NotImplementedError()`` in the release, and when grading it restores the graded cells from the source, so
a submission cannot edit its own checks.

  python -m stair_lite.course student [--out student]
  python -m stair_lite.course grade SUBMISSIONS [--out grades.csv] [--timeout 600] [--notebook-timeout 3600]

SUBMISSIONS holds one folder per student with that student's notebooks (any subset of the course's). Each
submitted notebook is first read by the tripwire (``course_guard``: code that reaches for the grader is refused),
then graded in its own process and copy of the course folder (as root: in its own mount and process namespaces,
every folder but its own read-only, no capabilities), with a memory limit and time limits; one that cannot be graded gets its row with 0 points and the reason.
"""
from __future__ import annotations

import argparse
import contextlib
import csv
import functools
import os
import shutil
import signal
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

import nbformat
import nbformat.validator

from .course_guard import tampering

NOTEBOOK_DIR = Path(__file__).resolve().parent.parent / "notebooks"
ASSIGNMENT = "stair_lite"  # nbgrader's name for the course's one assignment: the six notebooks
CELL_TIMEOUT_S = 600  # as the notebook tests (nbval's cell timeout)
RUN_PAST = "raises-exception"  # the cell tag with which Run All goes on past an error (Jupyter, nbclient)
_GRADING: set[int] = set()  # the process groups of the notebooks being graded now


def _notebooks(notebooks) -> list[Path]:
    """The given notebooks, or all of the course's."""
    return sorted(NOTEBOOK_DIR.glob("*.ipynb")) if notebooks is None else [Path(n) for n in notebooks]


def _api(root: Path, cell_timeout_s: int = CELL_TIMEOUT_S):
    """nbgrader's API on a course folder ``root`` with its own gradebook."""
    from nbgrader.apps import NbGraderAPI
    from traitlets.config import Config

    # nbgrader runs the ``alembic`` command of its environment: make it findable without an activated environment
    os.environ["PATH"] = os.pathsep.join([str(Path(sys.executable).parent), os.environ.get("PATH", "")])
    config = Config()
    config.CourseDirectory.root = str(root)
    config.CourseDirectory.db_url = f"sqlite:///{root / 'gradebook.db'}"
    config.ExecutePreprocessor.timeout = cell_timeout_s
    config.Execute.timeout = cell_timeout_s
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
    """One student's points on one notebook; ``reason`` says why a notebook was not graded by its checks."""

    student: str
    notebook: str
    score: float
    max_score: float
    failed: tuple[str, ...]  # the graded cells that did not pass
    reason: str = ""


@dataclass(frozen=True)
class Limits:
    """What one submitted notebook may take: each cell, the whole notebook (its own process), memory."""

    cell_timeout_s: int = CELL_TIMEOUT_S
    notebook_timeout_s: int = 3600
    memory_gb: float = 16.0

    def __post_init__(self):
        for name, low in (("cell_timeout_s", 1), ("notebook_timeout_s", 1), ("memory_gb", 1)):
            if not getattr(self, name) >= low:
                raise ValueError(f"{name} must be at least {low}, got {getattr(self, name)}")


def _checks(notebook: Path) -> dict[str, float]:
    """The graded cells of a source notebook: grade id -> points."""
    cells = nbformat.read(notebook, as_version=4).cells
    return {c.metadata["nbgrader"]["grade_id"]: c.metadata["nbgrader"]["points"] for c in cells
            if c.metadata.get("nbgrader", {}).get("grade")}


# Run as root inside new mount and process namespaces: every mount but /proc, /sys and /dev read-only except the
# submission's own folder, then every capability dropped (so nothing can remount), then the grading command.
CONFINE = r"""work="$1"; shift
mount --bind "$work" "$work" || exit 97
awk '{print $2}' /proc/self/mounts | while read -r m; do
  case "$m" in /proc|/proc/*|/sys|/sys/*|/dev|/dev/*|"$work") ;; *) mount -o remount,bind,ro "$m" 2>/dev/null ;; esac
done
if touch "$work/../.writable" 2>/dev/null; then echo "confinement failed: $work/.. is writable" >&2; exit 97; fi
exec setpriv --bounding-set -all --inh-caps -all --no-new-privs "$@"
"""


@functools.cache
def confinement() -> list[str]:
    """The command prefix that confines a submission's grading (``CONFINE`` under ``unshare``), or [] where this
    machine does not allow it (not root, or no namespaces): then it runs in its own process and folder, with the
    limits, but with the grader's rights."""
    if os.geteuid() != 0 or not (shutil.which("unshare") and shutil.which("setpriv")):
        return []
    prefix = ["unshare", "--mount", "--propagation", "private", "--pid", "--fork", "--mount-proc"]
    with tempfile.TemporaryDirectory(prefix="stair_confine_") as folder:
        probe = subprocess.run([*prefix, "sh", "-c", CONFINE, "confine", folder, "true"], capture_output=True)
    return [*prefix, "sh", "-c", CONFINE, "confine"] if probe.returncode == 0 else []


def _limit_memory(limits: Limits):
    """What the grading process of one submission does before it starts: its own session (so that it and its kernel
    can be stopped together) and the memory limit."""
    import resource

    def limit():
        os.setsid()
        size = int(limits.memory_gb * 2**30)
        resource.setrlimit(resource.RLIMIT_AS, (size, size))
    return limit


def _failure_reason(returncode: int, log: str, limits: Limits) -> str:
    """Why nbgrader could not grade a notebook, in one line."""
    if "CellTimeoutError" in log or "Timeout waiting for execute reply" in log or "timed out" in log:
        return f"a cell ran past the cell limit of {limits.cell_timeout_s} s"
    if "DeadKernelError" in log or "Kernel died" in log:
        return "the notebook's kernel died (a crash, an exit, or the memory limit)"
    if "MemoryError" in log:
        return f"the notebook ran past the memory limit of {limits.memory_gb:g} GB"
    last = [line for line in log.strip().splitlines() if line.strip()][-1:] or [f"exit status {returncode}"]
    return f"nbgrader could not grade it: {last[0].strip()[:200]}"


def _grade_isolated(course: Path, work: Path, student: str, submitted: Path, limits: Limits, keep: Path | None,
                    workers: int = 1):
    """Autograde one submitted notebook in its own copy of the course folder, in its own confined process
    (``confinement``) with the limits: returns ((points, max points, failed checks), "") or (None, reason)."""
    from nbgrader.api import Gradebook, MissingEntry

    shutil.copytree(course, work)
    target = work / "submitted" / student / ASSIGNMENT
    target.mkdir(parents=True)
    shutil.copy(submitted, target / submitted.name)
    for folder in ("home", "tmp"):
        (work / folder).mkdir()
    from .widgets import STATIC_ONLY

    # the kernel shows widgets as their static figures: nbgrader's runner can stall a whole cell timeout on a live one
    threads = str(max(1, (os.cpu_count() or 1) // workers))  # notebooks graded side by side share the cores
    env = {**os.environ, STATIC_ONLY: "1", "OMP_NUM_THREADS": threads, "HOME": str(work / "home"), "TMPDIR": str(work / "tmp"), "MPLCONFIGDIR": str(work / "home"),
           "JUPYTER_RUNTIME_DIR": str(work / "home"), "IPYTHONDIR": str(work / "home")}
    code = f"from stair_lite.course import _autograde_here; _autograde_here({str(work)!r}, {student!r}, {limits.cell_timeout_s})"
    child = subprocess.Popen([*confinement(), str(work), sys.executable, "-c", code] if confinement() else
                             [sys.executable, "-c", code], cwd=work, env=env, stdout=subprocess.PIPE,
                             stderr=subprocess.STDOUT, text=True, preexec_fn=_limit_memory(limits))
    _GRADING.add(child.pid)
    try:
        log, _ = child.communicate(timeout=limits.notebook_timeout_s)
    except subprocess.TimeoutExpired:
        log = f"the notebook ran past the notebook limit of {limits.notebook_timeout_s} s"
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(child.pid, signal.SIGKILL)  # the child, its kernel and whatever they started
        child.wait()
        _GRADING.discard(child.pid)
    if keep is not None and (work / "autograded" / student).is_dir():
        shutil.copytree(work / "autograded" / student, keep / student, dirs_exist_ok=True)
    if child.returncode != 0:
        reason = log if log.startswith("the notebook ran past") else _failure_reason(child.returncode, log, limits)
        return None, reason
    with Gradebook(f"sqlite:///{work / 'gradebook.db'}") as gb:
        try:
            sub = gb.find_submission_notebook(submitted.stem, ASSIGNMENT, student)
        except MissingEntry:
            return None, "nbgrader recorded no grade for it"
        failed = tuple(sorted(g.name for g in sub.grades if g.max_score > 0 and g.score < g.max_score))
        outcome = (sub.score, sub.max_score, failed)
    executed = nbformat.read(work / "autograded" / student / ASSIGNMENT / submitted.name, as_version=4)
    stops = {o.get("ename") for c in executed.cells for o in c.get("outputs", []) if o.get("output_type") == "error"}
    if "CellTimeoutError" in stops:
        return outcome, f"a cell ran past the cell limit of {limits.cell_timeout_s} s (stopped; the cells after it ran)"
    if "DeadKernelError" in stops:
        return outcome, "the notebook's kernel died (a crash, an exit, or the memory limit)"
    return outcome, ""


def _autograde_here(root: str, student: str, cell_timeout_s: int) -> None:
    """In the confined grading process: let nbgrader execute the student's notebook with the graded cells restored."""
    result = _api(Path(root), cell_timeout_s).autograde(ASSIGNMENT, student, force=True, create=True)
    if not result["success"]:
        print(f"{result['log']}\n{result.get('error', '')}")
        sys.exit(1)


def grade(submissions: str | Path, notebooks: list[Path] | None = None, keep: str | Path | None = None,
          limits: Limits = Limits(), workers: int = 1) -> list[Grade]:
    """Autograde every student folder in ``submissions`` against the source notebooks (executed by nbgrader with
    the graded cells restored from the source), each notebook in its own confined process (``_grade_isolated``)
    after the tripwire (``course_guard``) has read it, ``workers`` notebooks at a time. A notebook that cannot be
    graded gets its row with 0 points and the reason; the others are graded. ``keep``: a folder for the executed
    submissions. One grading per process at a time: nbgrader changes the working directory while it generates the
    course (two gradings in threads of one process break each other; run them as processes)."""
    from concurrent.futures import ThreadPoolExecutor

    if workers < 1:
        raise ValueError(f"workers must be at least 1, got {workers}")
    notebooks = _notebooks(notebooks)
    submissions = Path(submissions)
    if not submissions.is_dir():
        raise ValueError(f"no submissions folder {submissions}: expected {submissions}/<student>/<notebook>.ipynb")
    students = sorted(p for p in submissions.iterdir() if p.is_dir())
    if not students:
        raise ValueError(f"{submissions} holds no student folders: expected {submissions}/<student>/<notebook>.ipynb")
    sources = {nb.name: nb for nb in notebooks}
    keep = None if keep is None else Path(keep)
    with tempfile.TemporaryDirectory(prefix="stair_course_") as tmp:
        course = Path(tmp) / "course"
        _generate(course, notebooks)
        jobs = [(folder.name, file) for folder in students for file in sorted(folder.glob("*.ipynb")) or [None]]
        # each job is a process of its own: threads only wait for them
        pool = ThreadPoolExecutor(workers)
        try:
            return list(pool.map(lambda job: _grade_one(course, Path(tmp) / "work" / str(job[0]), *job[1], sources,
                                                        limits, keep, workers), enumerate(jobs)))
        except BaseException:  # Ctrl-C or SIGTERM: stop the notebooks being graded, so that their threads end
            for group in list(_GRADING):
                with contextlib.suppress(ProcessLookupError):
                    os.killpg(group, signal.SIGKILL)
            raise
        finally:
            pool.shutdown(wait=True, cancel_futures=True)


def _grade_one(course, work, student, file, sources, limits, keep, workers) -> Grade:
    """One student's notebook: refused with its reason, or graded in isolation (``file`` None: the student's folder
    holds no notebook)."""
    if file is None:
        return Grade(student, "", 0, 0, (), "no notebooks in the student's folder")
    source = sources.get(file.name)
    if source is None:
        expected = ", ".join(sorted(sources))
        return Grade(student, file.name, 0, 0, (), f"not a notebook of the course (expected one of {expected})")
    checks = _checks(source)
    ungraded = lambda reason: Grade(student, file.name, 0, sum(checks.values()), tuple(sorted(checks)), reason)  # noqa: E731
    try:
        submitted = nbformat.read(file, as_version=4)
        nbformat.validate(submitted)
    except Exception as err:  # a text file, a truncated notebook, another format: whatever nbformat says
        return ungraded(f"not a readable notebook: {str(err).splitlines()[0][:200]}")
    code = lambda nb: [c.source for c in nb.cells if c.cell_type == "code"]  # noqa: E731
    found = tampering(code(submitted), code(nbformat.read(source, as_version=4)))
    if found:
        return ungraded("refused, code that reaches for the grader: " + "; ".join(found[:3]))
    outcome, reason = _grade_isolated(course, work, student, file, limits, keep, workers)
    if outcome is None:
        return ungraded(reason)
    return Grade(student, file.name, *outcome, reason)


def write_table(grades: list[Grade], path: str | Path) -> None:
    """The points as CSV: one row per student and notebook."""
    with open(path, "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(["student", "notebook", "score", "max_score", "failed_checks", "reason"])
        for g in grades:
            writer.writerow([g.student, g.notebook, g.score, g.max_score, " ".join(g.failed), g.reason])


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="python -m stair_lite.course", description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("student", help="write the student edition of the notebooks")
    p.add_argument("--out", default="student")
    p = sub.add_parser("grade", help="autograde a folder of submissions (one folder per student)")
    p.add_argument("submissions")
    p.add_argument("--out", default="grades.csv")
    p.add_argument("--timeout", type=int, default=CELL_TIMEOUT_S, help="seconds a cell may run (default %(default)s)")
    p.add_argument("--notebook-timeout", type=int, default=Limits.notebook_timeout_s,
                   help="seconds a whole notebook may run (default %(default)s)")
    p.add_argument("--memory-gb", type=float, default=Limits.memory_gb,
                   help="address space of a notebook's process and kernel (default %(default)s)")
    p.add_argument("--workers", type=int, default=1, help="notebooks graded at a time, each in its own process "
                   "(default %(default)s)")
    p.add_argument("--keep", default=None, help="a folder for the executed submissions, "
                   "KEEP/<student>/stair_lite/<notebook>.ipynb, with their outputs (default: not kept)")
    args = parser.parse_args(argv)
    # a terminated grading unwinds like Ctrl-C: the running notebook is stopped and the temporary folders go
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))
    if args.command == "student":
        for path in student_release(args.out):
            print(f"wrote {path}")
        return
    try:
        limits = Limits(args.timeout, args.notebook_timeout, args.memory_gb)
        grades = grade(args.submissions, keep=args.keep, limits=limits, workers=args.workers)
    except ValueError as err:
        parser.exit(2, f"error: {err}\n")
    write_table(grades, args.out)
    width = max(len(g.student) for g in grades)
    for g in grades:
        failed = f"  failed: {', '.join(g.failed)}" if g.failed else ""
        why = f"  ({g.reason})" if g.reason else ""
        print(f"{g.student:<{width}}  {g.notebook:<32} {g.score:g} / {g.max_score:g}{failed}{why}")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
