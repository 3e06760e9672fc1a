"""The course edition: exercises as nbgrader cells, a student release without solutions, grading by points."""
import csv
import json
import re
import shutil
import subprocess
import sys
import warnings
from pathlib import Path

import nbformat
import pytest

from stair_lite import course
from stair_lite.exercises import mine_or_reference
from stair_lite.exercises.sensor import check_view_angle

NOTEBOOKS = sorted(course.NOTEBOOK_DIR.glob("*.ipynb"))
REGION = re.compile(r"### BEGIN SOLUTION\n(.*?)### END SOLUTION", re.S)


def grading(cell) -> dict:
    return cell.metadata.get("nbgrader", {})


def test_every_exercise_is_a_solution_cell_followed_by_a_graded_check():
    ids, exercises = [], 0
    for path in NOTEBOOKS:
        nb = nbformat.read(path, as_version=4)
        assert not re.search(r"def \w+_solution\(", "".join(c.source for c in nb.cells)), path.name
        for i, cell in enumerate(nb.cells):
            g = grading(cell)
            ids += [g["grade_id"]] if g else []
            if g.get("solution"):
                exercises += len(REGION.findall(cell.source))
                assert REGION.search(cell.source), f"{path.name}: {g['grade_id']} has no solution region"
                check = nb.cells[i + 1]
                assert grading(check).get("grade") and grading(check)["points"] > 0, f"{path.name} {g['grade_id']}"
                assert "check_" in check.source
    assert exercises >= 24 and len(ids) == len(set(ids))  # 24 solution regions to write, one grade id per cell


def test_the_course_has_at_least_26_points_and_the_table_of_course_md_says_how_many():
    points = {}
    for path in NOTEBOOKS:
        cells = nbformat.read(path, as_version=4).cells
        points[path.name[:2]] = sum(grading(c).get("points", 0) for c in cells if grading(c).get("grade"))
    assert sum(points.values()) >= 26
    text = (course.NOTEBOOK_DIR.parent / "COURSE.md").read_text()
    assert f"There are {sum(points.values())} points in all" in text
    for number, n in points.items():
        row = next(line for line in text.splitlines() if line.startswith(f"| {number} |"))
        assert row.rstrip().endswith(f"| {n} |"), row


def test_the_student_release_holds_no_solution_code(tmp_path):
    released = course.student_release(tmp_path / "student")
    assert [p.name for p in released] == [p.name for p in NOTEBOOKS]
    for source, release in zip(NOTEBOOKS, released):
        text = release.read_text()
        nb = nbformat.read(release, as_version=4)
        cells = nbformat.read(source, as_version=4).cells
        elsewhere = "".join(REGION.sub("", c.source) for c in cells)  # what the notebook shows outside solutions
        for cell in cells:
            for region in REGION.findall(cell.source):
                for line in region.splitlines():
                    if len(line.strip()) > 12 and line.strip() not in elsewhere:  # a line only a solution has
                        assert json.dumps(line.strip())[1:-1] not in text, f"{release.name} shows: {line.strip()}"
        solutions = [c for c in nb.cells if grading(c).get("solution")]
        assert solutions and all("raise NotImplementedError()" in c.source for c in solutions)
        assert all(not c.metadata.get("jupyter", {}).get("source_hidden") for c in solutions)
        assert all(course.RUN_PAST in c.metadata.get("tags", []) for c in nb.cells if grading(c).get("grade"))
        assert all(not c.get("outputs") for c in nb.cells if c.cell_type == "code")


def test_every_check_passes_the_reference_silently(capfd):
    """nbgrader gives a graded cell no points when it writes to stderr (a warning, say), not only when it raises:
    each graded cell, run with the learner's functions bound to the checkers' references, must stay silent there."""
    for path in NOTEBOOKS:
        namespace = {}  # a notebook's checks import their checkers once
        for cell in nbformat.read(path, as_version=4).cells:
            if not grading(cell).get("grade"):
                continue
            exec("\n".join(line for line in cell.source.splitlines() if line.startswith(("from ", "import ", " "))), namespace)
            for checker, function in re.findall(r"^(check_\w+)\((\w+)\)$", cell.source, re.M):
                namespace[function] = namespace[checker].reference
            capfd.readouterr()
            with warnings.catch_warnings():
                warnings.simplefilter("error")
                exec(cell.source, namespace)
            assert capfd.readouterr().err == "", grading(cell)["grade_id"]


def test_a_right_answer_that_warns_gets_a_printed_note_and_keeps_its_points(capfd):
    """A warning on stderr would cost the learner the check's points under nbgrader; the checkers show it on stdout."""
    from stair_lite.exercises.field import check_training_step

    def training_step(model, optimizer, render, loss_fn, batch):
        loss = loss_fn(render(model, batch), batch)
        optimizer.zero_grad()
        loss.backward()
        optimizer.step()
        return float(loss)  # right, but torch warns: a tensor that requires grad converted to a number

    check_training_step(training_step)
    out, err = capfd.readouterr()
    assert err == "" and out.count("note: training_step warned: Converting a tensor with requires_grad=True") == 1


def test_a_failing_answer_falls_back_on_the_reference(capsys):
    def view_angle(a, b):
        return abs(a[0] - b[0]) + abs(a[1] - b[1])  # the flat-plane mistake

    used = mine_or_reference(view_angle, check_view_angle)
    assert used is check_view_angle.reference
    assert "view_angle does not pass its check yet" in capsys.readouterr().out
    assert mine_or_reference(check_view_angle.reference, check_view_angle) is check_view_angle.reference


def test_grading_gives_full_points_to_the_solutions_and_fewer_to_a_wrong_answer(tmp_path):
    """Notebook 01 (the quickest) graded three ways: the source (every answer right), one wrong answer, and the
    untouched student release, which must still run to the end."""
    source = NOTEBOOKS[0]
    submissions = tmp_path / "submissions"
    for student in ("solutions", "one_wrong", "untouched"):
        (submissions / student).mkdir(parents=True)
    shutil.copy(source, submissions / "solutions" / source.name)
    nb = nbformat.read(source, as_version=4)
    cell = next(c for c in nb.cells if grading(c).get("grade_id") == "01_scale_intrinsics")
    assert "scaled[:2] *= factor" in cell.source
    cell.source = cell.source.replace("scaled[:2] *= factor", "scaled[:2, :2] *= factor")  # the principal point left behind
    nbformat.write(nb, submissions / "one_wrong" / source.name)
    course.student_release(tmp_path / "release", [source])
    shutil.copy(tmp_path / "release" / source.name, submissions / "untouched" / source.name)

    grades = {g.student: g for g in course.grade(submissions, [source], keep=tmp_path / "executed", workers=2)}
    assert grades["solutions"].score == grades["solutions"].max_score == 5 and not grades["solutions"].failed
    assert grades["one_wrong"].score == 4 and grades["one_wrong"].failed == ("01_scale_intrinsics_check",)
    assert grades["untouched"].score == 0 and len(grades["untouched"].failed) == 5
    executed = nbformat.read(tmp_path / "executed" / "untouched" / course.ASSIGNMENT / source.name, as_version=4)
    errors = [c for c in executed.cells if any(o.get("output_type") == "error" for o in c.get("outputs", []))]
    assert errors and all(grading(c).get("grade") for c in errors)  # only the checks fail; the rest ran
    last_code = [c for c in executed.cells if c.cell_type == "code"][-1]
    assert "closest test view" in "".join(o.get("text", "") for o in last_code.outputs)  # it ran, on the reference
    table = tmp_path / "grades.csv"
    course.write_table(list(grades.values()), table)
    assert table.read_text().splitlines()[0] == "student,notebook,score,max_score,failed_checks,reason"


# Per notebook after the first: one answer deliberately wrong (grade id -> the solution's line and its mistake) and,
# in the notebooks with three exercises, one left as the release's stub; every other answer is the solution.
MISTAKES = {
    "02_voxel_occupancy_field.ipynb": ("02_transmittance_and_weights", "T = np.cumprod(passing, axis=1)",
                                       "T = np.cumprod(1.0 - occ, axis=1)"),            # inclusive transmittance
    "03_semantic_rendering.ipynb": ("03_render_semantics", "s[BACKGROUND] += 1.0 - weights.sum()",
                                    "pass"),                                              # no background share
    "04_entropy_utility.ipynb": ("04_utility", "epsilon * h_ray.sum(axis=(1, 2))",
                                 "epsilon * (h_ray * ~mask).sum(axis=(1, 2))"),           # exploration off-target only
    "05_planning_loop.ipynb": ("05_first_step_above", 'return r["step"]', "return records.index(r)"),  # an index
    "06_baseline_comparison.ipynb": ("06_paired_p_value", "return float(2 * stats.t.sf(", "return float(1 * stats.t.sf("),
    "07_when_labels_lie.ipynb": ("07_class_entropy", "np.log(np.where(", "np.log2(np.where("),  # bits, not nats
    "08_what_a_view_teaches.ipynb": ("08_noise_ceiling", "oracle = np.delete(gains, s, axis=0).mean(axis=0)",
                                     "oracle = gains.mean(axis=0)"),                    # the oracle sees its own stream
}
UNANSWERED = {"02_voxel_occupancy_field.ipynb": "02_composite", "03_semantic_rendering.ipynb": "03_replay_probabilities",
              "04_entropy_utility.ipynb": "04_ray_entropy"}


def answered(source: str) -> str:
    """A solution cell as a learner who wrote the solution submits it: without nbgrader's region markers."""
    return "\n".join(line for line in source.splitlines() if line.strip() not in ("### BEGIN SOLUTION", "### END SOLUTION"))


def prepare_the_release_with_one_wrong_answer_per_notebook(root: Path) -> dict:
    """Notebooks 02-08 as a learner submits them (``root/submissions/learner``): the student release with its answers
    filled in, one of them wrong per notebook and (where there are three) one left unanswered. Returns the failed
    checks expected per notebook and every check's points."""
    notebooks = [p for p in NOTEBOOKS if p.name in MISTAKES]
    assert len(notebooks) == len(NOTEBOOKS) - 1  # notebook 01 is graded three ways above
    released = {p.name: p for p in course.student_release(root / "release", notebooks)}
    student = root / "submissions" / "learner"
    student.mkdir(parents=True)
    expected_failed, points = {}, {}
    for source in notebooks:
        wrong_id, right, mistake = MISTAKES[source.name]
        solutions = {grading(c)["grade_id"]: c.source for c in nbformat.read(source, as_version=4).cells
                     if grading(c).get("solution")}
        nb = nbformat.read(released[source.name], as_version=4)
        for cell in nb.cells:
            g = grading(cell)
            points[(source.name, g.get("grade_id"))] = g.get("points", 0)
            if g.get("solution") and g["grade_id"] != UNANSWERED.get(source.name):
                cell.source = answered(solutions[g["grade_id"]])
                if g["grade_id"] == wrong_id:
                    assert right in cell.source, (source.name, right)
                    cell.source = cell.source.replace(right, mistake)
        nbformat.write(nb, student / source.name)
        expected_failed[source.name] = tuple(sorted(f"{i}_check" for i in (wrong_id, UNANSWERED.get(source.name)) if i))
    return {"expected_failed": expected_failed, "points": points}


@pytest.mark.release
def test_the_release_with_one_wrong_answer_per_notebook_runs_to_the_end_and_loses_those_points(tmp_path):
    """Graded as an instructor grades (``python -m stair_lite.course grade``, keeping the executed notebooks), each
    notebook of the release above runs top to bottom: only the checks of its wrong and unanswered answers fail,
    every later cell runs on the reference, and the points drop by theirs."""
    expected = prepare_the_release_with_one_wrong_answer_per_notebook(tmp_path)
    expected_failed, points = expected["expected_failed"], expected["points"]
    graded = subprocess.run([sys.executable, "-m", "stair_lite.course", "grade", str(tmp_path / "submissions"),
                             "--workers", "2", "--out", str(tmp_path / "grades.csv"), "--keep", str(tmp_path / "executed")],
                            capture_output=True, text=True)
    assert graded.returncode == 0, graded.stdout[-3000:] + graded.stderr[-3000:]
    with open(tmp_path / "grades.csv", newline="") as table:
        rows = {row["notebook"]: row for row in csv.DictReader(table)}
    assert sorted(rows) == sorted(expected_failed)
    for name, row in rows.items():
        failed = tuple(row["failed_checks"].split())
        assert failed == expected_failed[name] and not row["reason"], (name, row)
        lost = sum(points[(name, c)] for c in failed)
        assert float(row["score"]) == float(row["max_score"]) - lost < float(row["max_score"]), (name, row)
        executed = nbformat.read(tmp_path / "executed" / "learner" / course.ASSIGNMENT / name, as_version=4)
        errors = [grading(c).get("grade_id") for c in executed.cells
                  if any(o.get("output_type") == "error" for o in c.get("outputs", []))]
        assert sorted(errors) == list(failed), name  # only the failing checks raised; the rest ran
        assert all(c.execution_count for c in executed.cells if c.cell_type == "code"), name  # every cell ran
        printed = "".join(o.get("text", "") for c in executed.cells for o in c.get("outputs", []))
        assert printed.count("does not pass its check yet") >= len(failed), name  # fell back on the reference
