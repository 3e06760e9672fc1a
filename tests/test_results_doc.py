"""RESULTS.md quotes the claim verdicts of the stored sweeps; they must be what the code computes now."""
from pathlib import Path

import pytest

from stair_lite.claims import markdown_report
from stair_lite.experiments import RESULTS_DIR, collect

RESULTS_MD = Path(__file__).resolve().parents[1] / "RESULTS.md"


def quoted(marker: str) -> str:
    """The generated block of RESULTS.md between ``<!-- marker: generated ...`` and ``<!-- marker: end -->``."""
    text = RESULTS_MD.read_text()
    return text[text.index(f"<!-- {marker}: generated"):text.index(f"<!-- {marker}: end -->")].split("\n", 1)[1].rstrip("\n")


def test_results_md_quotes_the_computed_verdicts():
    computed = markdown_report(collect(RESULTS_DIR / "comparison_lite"),
                               collect(RESULTS_DIR / "ablation_hidden_chair_lite")).rstrip("\n")
    assert quoted("claims") == computed, "RESULTS.md is stale: paste the output of `python -m stair_lite claims ...` between its markers"


def test_results_md_quotes_the_label_noise_verdicts():
    from stair_lite.noise_study import markdown_report as noise_report, study_rows

    computed = noise_report(study_rows(RESULTS_DIR, log=lambda message: None)).rstrip("\n")
    assert quoted("label noise") == computed, "RESULTS.md is stale: paste the output of `python -m stair_lite label-noise-claims`"


@pytest.mark.parametrize("marker, folder", [("league", "headroom_league_lite"), ("league former", "headroom_league_lite_former"),
                                            ("league paper", "headroom_league_paper")])
def test_results_md_quotes_the_computed_league(marker, folder):
    from stair_lite.headroom import Headroom, league_markdown

    computed = league_markdown([Headroom.load(p.with_suffix("")) for p in sorted((RESULTS_DIR / folder).glob("*.json"))])
    assert quoted(marker) == computed.rstrip("\n"), f"RESULTS.md is stale: paste the output of `python -m stair_lite league --results {folder}`"


def test_the_stored_league_is_of_the_adopted_map():
    """The league's tables are the re-run's: their seeded missions planned on the adopted map (preset lite), on which
    STAIR's utility is the marking of the unknown that ``stair_unknown`` names, so the two score every view alike, and
    the rule before the league (``stair_unmarked``) does not."""
    from stair_lite.headroom import Headroom

    tables = [Headroom.load(p.with_suffix("")) for p in sorted((RESULTS_DIR / "headroom_league_lite").glob("*.json"))]
    assert len(tables) == 12 and {t.preset for t in tables} == {"lite"} and {t.streams for t in tables} == {3}
    for t in tables:
        spread = [r for r in t.rows if r["kind"] == "spread"]
        assert [r["u_stair"] for r in spread] == [r["u_stair_unknown"] for r in spread], (t.scene, t.after)
        assert [r["u_stair"] for r in spread] != [r["u_stair_unmarked"] for r in spread], (t.scene, t.after)


def test_no_stored_mission_has_a_phantom_below_the_ground():
    """Every step of every stored mission fills at most 1 % of the volume below the ground (``phantom``): the scores
    read a map without the volume no ray reached."""
    import json

    steps = [(path, r["step"], r["phantom"]) for path in sorted(RESULTS_DIR.glob("*/*/*/seed*/metrics.json"))
             for r in json.loads(path.read_text())["steps"] if r.get("phantom") is not None]
    assert len(steps) > 5000  # every stored study is read
    worst = max(steps, key=lambda s: s[2])
    assert worst[2] <= 0.01, f"{worst[0]} step {worst[1]}: phantom {worst[2]:.2%}"


def test_every_stored_cross_validation_mission_replays_its_sources_views():
    """``stair_explicit`` fuses STAIR's views into the voxel map and ``ste_implicit`` trains the field on STE's: each
    stored cross-validation mission followed exactly the views of the mission of the same scene and seed it replays."""
    from stair_lite.experiments import CROSS_VALIDATION, Cell

    folder, checked = RESULTS_DIR / "comparison_lite", 0
    for replay, source in CROSS_VALIDATION.items():
        for path in sorted(folder.glob(f"*/{replay}/seed*/metrics.json")):
            cell = Cell(path.parts[-4], replay, int(path.parent.name.removeprefix("seed")))
            mine = [r["view_rad"] for r in cell.steps(folder)]
            assert mine == [r["view_rad"] for r in Cell(cell.scene, source, cell.seed).steps(folder)], cell
            checked += 1
    assert checked == 64  # 4 scenes x 2 cross-validation variants x 8 seeds


def test_each_stored_results_table_holds_every_mission_of_its_folder():
    """``report``'s results.csv beside the missions holds every stored step record with the same numbers."""
    from stair_lite.experiments import read_table

    for name in ("comparison_lite", "ablation_hidden_chair_lite"):
        rows, table = collect(RESULTS_DIR / name, log=lambda message: None), read_table(RESULTS_DIR / name / "results.csv")
        key = lambda r: (r["scene"], r["variant"], int(r["seed"]), int(r["step"]))  # noqa: E731
        assert sorted(map(key, table)) == sorted(map(key, rows)), name
        stored = {key(r): (r["psnr"], r["f1"]) for r in rows}
        assert all(abs(r["psnr"] - stored[key(r)][0]) < 1e-9 and abs(r["f1"] - stored[key(r)][1]) < 1e-9 for r in table)


def test_results_md_quotes_the_scale_verdicts():
    from stair_lite.scale_study import markdown_report as scale_report, scale_rows

    computed = scale_report(scale_rows(RESULTS_DIR, log=lambda message: None)).rstrip("\n")
    assert quoted("scale") == computed, "RESULTS.md is stale: paste the output of `python -m stair_lite scale-claims`"
