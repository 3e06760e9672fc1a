"""Command line: ``python -m stair_lite <command>``; ``--help`` on each command lists its options.

  scenes   list the shipped scenes
  render   render a scene from a few views into a figure (the simulated world)
  fit      fit a map (the field, or STE's voxel map) to fixed views of a scene; report target-only PSNR and mesh F1
  run      one active reconstruction mission (planner, scene, seed) with per-step metrics
  sweep    missions over scenes x planner variants x seeds (resumable), then the results table and plots
  report   the results table, curves and summary of a sweep folder
  claims   the paper's three claims, checked against a sweep (and an ablation) folder, as Markdown
  scale-claims  the claims at lite beside the paper scale (comparison_lite, comparison_paper), as Markdown
  headroom does a utility predict what a view will teach? realised gains of spread next views, rank correlations
"""
from __future__ import annotations

import argparse
import signal
import sys
import time
from pathlib import Path

import stair_lite  # noqa: F401  (sets the offscreen platform before pyrender loads)

from .classes import CLASS_NAMES
from .config import PRESETS, SEED_LIMIT
from .experiments import WORKER_TIMEOUT_S
from .maps import IMPLICIT, MAP_KINDS
from .planners import PLANNERS, REPLAY
from .segmenter import LABEL_NOISE


def _cmd_scenes(args):
    from .scenes import build_scene, list_scenes, load_scene_spec

    for name in args.files or list_scenes():
        spec = load_scene_spec(name)
        if args.files:
            build_scene(spec)  # a file is described only if run accepts it: its objects fit the cube and do not overlap
        classes = sorted({CLASS_NAMES[o.cls] for o in spec.objects})
        print(f"{name:22s} targets: {', '.join(CLASS_NAMES[t] for t in spec.targets):16s} "
              f"{len(spec.objects)} objects ({', '.join(classes)})")


def _cmd_render(args):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from .results_folder import make_output_folder
    from .plotting import show_measurement
    from .scenes import load_scene
    from .simulator import Simulator

    out = make_output_folder(args.out)
    sim = Simulator(load_scene(args.scene))
    views = [(np.pi / 2, 0.0), (0.6, 0.5), (0.25, 2.5)]
    fig, axes = plt.subplots(len(views), 3, figsize=(11, 3.6 * len(views)))
    for row, (el, az) in zip(axes, views):
        show_measurement(sim.render_view(el, az), f"el {np.degrees(el):.0f} az {np.degrees(az):.0f}", axes=row)
    fig.tight_layout()
    image = out / f"{Path(args.scene).stem}_views.png"  # a scene file's name, not its path: the image goes into --out
    fig.savefig(image, dpi=80)
    print(f"wrote {image}")


def _cmd_fit(args):
    from dataclasses import replace

    import numpy as np

    from .config import check_device, get_preset
    from .evaluation import f1_column
    from .geometry import fibonacci_hemisphere
    from .mission import World, build_map
    from .results_folder import make_output_folder

    for name, most in (("iterations", 20000), ("rays", 65536), ("views", 500)):  # the paper: 200, 8000, 10
        value = getattr(args, name)
        if value is not None and not 1 <= value <= most:
            raise ValueError(f"--{name} must be between 1 and {most}, got {value}")
    if args.mapper != IMPLICIT and (args.iterations is not None or args.rays is not None):
        raise ValueError(f"--iterations and --rays set the field's training: the {args.mapper} map trains nothing")
    out = make_output_folder(args.out) if args.out else None  # before training: a bad folder costs nothing
    preset = get_preset(args.preset)
    if args.iterations is not None:
        preset = replace(preset, train=replace(preset.train, iterations_per_view=args.iterations))
    if args.rays is not None:
        preset = replace(preset, train=replace(preset.train, rays_new=args.rays, rays_replay=args.rays))
    if args.eval_preset is not None:
        preset = replace(preset, eval=get_preset(args.eval_preset).eval)
    world = World.build(args.scene, preset, args.seed, tuple(args.targets.split(",")) if args.targets else None,
                        args.label_noise)
    fitted = build_map(args.mapper, preset, seed=args.seed, device=check_device(args.device))
    views = fibonacci_hemisphere(args.views, azimuth_offset=0.3)
    schedule = (f", {preset.train.iterations_per_view} iterations/view, {preset.train.rays_new}+{preset.train.rays_replay} "
                "rays" if args.mapper == IMPLICIT else "")
    print(f"preset {preset.name}: {args.mapper} map, grid {preset.field.grid_resolution}^3{schedule}; scene "
          f"{world.scene.name}, targets {world.targets}, label noise {args.label_noise}")
    start = time.perf_counter()
    for i, view in enumerate(views):
        history = fitted.integrate(world.measure(view, step=i + 1))
        loss = f": loss {history[-1].total:.4f}" if history else ""
        print(f"view {i + 1:2d}/{len(views)} (el {np.degrees(view[0]):4.1f}, az {np.degrees(view[1]):5.1f}){loss}", flush=True)
    t_train = time.perf_counter() - start
    result = world.evaluator.evaluate(fitted)
    further = ", ".join(f"{f1_column(t)} {result[f1_column(t)]:.3f}" for t in preset.eval.more_f1_thresholds)
    print(f"target-only PSNR {result['psnr']:.2f} dB over {len(world.evaluator.poses)} test views | mesh precision "
          f"{result['precision']:.3f} completeness {result['completeness']:.3f} F1 {result['f1']:.3f} "
          f"(1 cm, {preset.eval.mesh_points} points), {further}, chamfer {result['chamfer'] * 100:.2f} cm | "
          f"{'training' if args.mapper == IMPLICIT else 'integration'} {t_train:.1f} s, evaluation "
          f"{result['time_total_s']:.1f} s")
    if out is not None and result["mesh"] is not None:
        result["mesh"].export(out / "target_mesh.ply")
        print(f"wrote {out / 'target_mesh.ply'}")


def _cmd_run(args):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from tqdm import tqdm

    from .mission import Mission, MissionConfig
    from .plotting import plot_camera_path, plot_mission_metrics

    config = MissionConfig(scene=args.scene, planner=args.planner, seed=args.seed, preset=args.preset,
                           targets=tuple(args.targets.split(",")) if args.targets else None,
                           budget=args.budget, epsilon=args.epsilon, mapper=args.mapper, replay=args.replay,
                           label_noise=args.label_noise)
    mission = Mission(config, out=args.out, resume=args.resume, overwrite=args.overwrite, device=args.device)
    out = Path(args.out)
    done = len(mission.records)
    print(f"mission: scene {config.scene}, targets {', '.join(CLASS_NAMES[t] for t in mission.targets)}, planner "
          f"{config.planner}, seed {config.seed}, preset {config.preset}, budget {config.budget}, label noise "
          f"{config.label_noise}"
          + (f" (resuming after step {done})" if done else ""))
    header = f"{'step':>4} {'elev':>6} {'azim':>6} {'utility':>9} {'loss':>7} {'PSNR':>6} {'clean':>6} {'prec':>5} {'compl':>5} {'F1':>5} {'F1 5cm':>6} {'chamf':>6} {'plan s':>6} {'train s':>7} {'eval s':>6}"
    bar = tqdm(total=config.budget, initial=done, desc="steps", unit="step", leave=False, disable=args.quiet)
    tqdm.write(header)

    def row(r):
        def cell(key, width, decimals):  # "-": no utility before the first plan or of this planner, no loss of STE
            return f"{r[key]:{width}.{decimals}f}" if r.get(key) is not None else f"{'-':>{width}}"
        t = r["time_s"]
        tqdm.write(f"{r['step']:4d} {r['view_deg'][0]:6.1f} {r['view_deg'][1]:6.1f} {cell('utility', 9, 1)} {cell('loss', 7, 4)} "
                   f"{cell('psnr', 6, 2)} {cell('psnr_clean', 6, 2)} {cell('precision', 5, 3)} {cell('completeness', 5, 3)} "
                   f"{cell('f1', 5, 3)} {cell('f1_5cm', 6, 3)} {cell('chamfer', 6, 3)} {t['plan']:6.2f} {t['train']:7.2f} {t['evaluate']:6.2f}")
        bar.update(1)

    for r in mission.records:
        row(r)
    bar.reset(total=config.budget)
    bar.update(done)
    start = time.perf_counter()
    try:
        records = mission.run(on_step=row)
    except KeyboardInterrupt:
        bar.close()
        print(f"\ninterrupted: {mission.saved_steps} steps are saved in {mission.metrics_path}; "
              "run again with --resume to continue", file=sys.stderr)
        return 130
    bar.close()
    axes = plot_mission_metrics(records, label=config.planner)
    axes[0].figure.suptitle(f"{config.scene}, {config.planner}, seed {config.seed}")
    axes[0].figure.tight_layout()
    axes[0].figure.savefig(out / "metrics.png", dpi=90)
    ax = plot_camera_path(mission.scene, records, title=f"{config.planner}: camera path")
    ax.figure.savefig(out / "camera_path.png", dpi=90)
    plt.close("all")
    mesh = mission.map.target_mesh(mission.targets)
    if mesh is not None:
        mesh.export(out / "target_mesh.ply")
    print(f"done in {time.perf_counter() - start:.1f} s: final PSNR {records[-1]['psnr']:.2f} dB, F1 {records[-1]['f1']:.3f}; "
          f"wrote {out}/metrics.json, metrics.png, camera_path.png" + (", target_mesh.ply" if mesh is not None else ""))
    return 0


def _cmd_sweep(args):
    from .experiments import PAPER_SCENES, SweepSpec, all_variants, base_variants, run_sweep

    scenes = PAPER_SCENES if args.scenes == "all" else tuple(args.scenes.split(","))
    variants = {"all": all_variants, "base": base_variants}.get(args.planners, lambda: tuple(args.planners.split(",")))()
    if args.seeds < 1:
        raise ValueError(f"--seeds must be at least 1, got {args.seeds}")
    if not 0 <= args.first_seed <= SEED_LIMIT - args.seeds:
        raise ValueError(f"--first-seed must be from 0 to {SEED_LIMIT} - --seeds, got {args.first_seed}")
    if args.workers < 1:
        raise ValueError(f"--workers must be at least 1, got {args.workers}")
    spec = SweepSpec(scenes, variants, tuple(range(args.first_seed, args.first_seed + args.seeds)), args.preset, args.budget,
                     args.label_noise)
    where = (f"on the Dask cluster at {args.scheduler}" if args.scheduler else
             f"on a local Dask cluster of {args.workers} workers" if args.workers > 1 else "in this process")
    print(f"sweep: {len(spec.cells())} cells ({len(scenes)} scenes x {len(variants)} variants x {args.seeds} seeds), "
          f"preset {args.preset}, label noise {args.label_noise}, {where}, results in {args.out}")
    start = time.perf_counter()
    signal.signal(signal.SIGTERM, _interrupt)  # a terminated sweep stops its workers like Ctrl-C
    try:
        outcomes = run_sweep(spec, args.out, workers=args.workers, progress=not args.quiet, device=args.device,
                             scheduler=args.scheduler, worker_timeout_s=args.worker_timeout, log=_warn)
    except KeyboardInterrupt:
        print("\ninterrupted: finished cells are kept; run the same command again to continue", file=sys.stderr)
        return 130
    before = sum(1 for _, o in outcomes if o == "finished before")
    failed = [(cell, o) for cell, o in outcomes if o.startswith(("failed", "not run"))]
    for cell, outcome in failed:
        print(f"{cell.scene}/{cell.variant}/seed{cell.seed}: {outcome}", file=sys.stderr)
    print(f"{len(outcomes) - before - len(failed)} cells run in {time.perf_counter() - start:.0f} s, {before} were "
          f"finished before" + (f", {len(failed)} failed or not run: run the same command again to redo them"
                                if failed else ""))
    args.results = args.out
    if len(failed) == len(outcomes):
        return 1
    report = _cmd_report(args)
    return 1 if failed else report


def _interrupt(signum, frame):
    raise KeyboardInterrupt


def _warn(message: str) -> None:
    print(message, file=sys.stderr)


def _cmd_report(args):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from .claims import metrics_of
    from .experiments import collect, summary, write_table
    from .metrics import METRICS
    from .plotting import plot_sweep_curves
    from .results_folder import written_whole

    root = Path(args.results)
    rows = collect(root, log=_warn)
    if not rows:
        raise ValueError(f"no finished mission results under {root}")
    metrics = metrics_of(rows)
    with written_whole(root / "results.csv") as path:  # a full disk leaves the former file, not a cut one
        write_table(rows, path)
    for metric in metrics:
        axes = plot_sweep_curves(rows, metric, ylabel=METRICS[metric].label)
        axes[0].figure.tight_layout()
        with written_whole(root / f"curves_{metric}.png") as path:
            axes[0].figure.savefig(path, dpi=90, format="png")
        plt.close("all")
    table = root / "results.csv"
    scale = {m: METRICS[m].report_scale for m in metrics}
    print("area under each curve (the mean over the steps), mean +- std over seeds"
          + "".join(f"; {m} x {s:g}" for m, s in scale.items() if s != 1))
    print(f"{'scene':10s} {'variant':16s} {'n':>2s}" + "".join(f" {m:>15s}" for m in metrics))
    for e in summary(rows, metrics):
        print(f"{e['scene']:10s} {e['variant']:16s} {e['seeds']:2d}" + "".join(
            f" {scale[m] * e[m + '_auc_mean']:7.3f} +- {scale[m] * e[m + '_auc_std']:4.2f}" for m in metrics))
    print(f"wrote {table}, " + ", ".join(str(root / f"curves_{m}.png") for m in metrics))
    return 0


def _cmd_claims(args):
    from .claims import markdown_report
    from .experiments import EPSILON_PREFIX, collect

    rows = collect(args.results, log=_warn)
    if not rows:
        raise ValueError(f"no finished mission results under {args.results}")
    ablation = collect(args.ablation, log=_warn) if args.ablation else None
    if args.ablation and not ablation:
        raise ValueError(f"no finished mission results under {args.ablation}")
    others = sorted({r["variant"] for r in ablation or [] if not r["variant"].startswith(EPSILON_PREFIX)})
    if others:
        raise ValueError(f"--ablation {args.ablation} holds the variants {others}: an epsilon ablation holds only "
                         "stair_eps<value> variants (e.g. data/results/ablation_hidden_chair_lite)")
    print(markdown_report(rows, ablation))
    return 0


def _cmd_label_noise_claims(args):
    from .noise_study import STORED_STUDY, markdown_report, study_rows

    print(markdown_report(study_rows(Path(args.results), log=_warn, study=args.study or STORED_STUDY)))
    return 0


def _cmd_scale_claims(args):
    from .scale_study import markdown_report, scale_rows

    print(markdown_report(scale_rows(Path(args.results), log=_warn)))
    return 0


def _cmd_headroom(args):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from .experiments import PAPER_SCENES
    import json

    from .headroom import Headroom, add_utilities, check_headroom_size, measure_headroom, print_headroom, ranking_planners
    from .results_folder import make_output_folder, written_whole
    from .plotting import plot_headroom

    scenes = PAPER_SCENES if args.scene == "all" else tuple(args.scene.split(","))
    afters = _whole_numbers("--after", args.after)
    for after in afters:
        check_headroom_size(after, args.candidates, args.streams)
    out = make_output_folder(args.out)
    utilities = tuple(args.utilities.split(",")) if args.utilities else None
    for scene in scenes:
        for after in afters:
            stem = out / f"{Path(scene).stem}_after{after}"
            if stem.with_suffix(".json").exists() and not args.again:
                stored = Headroom.load(stem)
                missing = [u for u in (utilities or ranking_planners()) if u not in stored.utilities]
                if not missing:
                    print(f"{stem}.json holds every utility asked for: kept (--again measures it anew)")
                    continue
                result = add_utilities(stored, tuple(missing), device=args.device,
                                       log=lambda line: None if args.quiet else print(line, flush=True))
                stem = result.save(out, json.loads(stem.with_suffix(".json").read_text()).get("command", "")
                                   + f" (then --utilities {','.join(missing)} added)")
                print_headroom(result)
                print(f"added {', '.join(missing)} to {stem}.csv, .json")
                continue
            progress = Path(f"{stem}.partial.jsonl")  # the views realised so far: a stopped run continues from them
            try:
                result = measure_headroom(scene, after, args.candidates, seed=args.seed, preset=args.preset,
                                          utilities=utilities, streams=args.streams, device=args.device,
                                          log=lambda line: None if args.quiet else print(line, flush=True),
                                          progress=progress)
            except KeyboardInterrupt:
                print(f"interrupted: the views realised so far are kept in {progress}; run the same command again to "
                      "continue", file=sys.stderr)
                return 130
            command = (f"python -m stair_lite headroom --scene {scene} --after {after} --candidates {args.candidates} "
                       f"--seed {args.seed} --preset {args.preset} --streams {args.streams} "
                       + (f"--utilities {args.utilities} " if args.utilities else "") + f"--out {args.out}")
            stem = result.save(out, command)
            axes = plot_headroom(result)
            axes[0].figure.tight_layout()
            with written_whole(stem.with_suffix(".png")) as path:
                axes[0].figure.savefig(path, dpi=90, format="png")
            plt.close("all")
            progress.unlink()
            print_headroom(Headroom.load(stem))
            print(f"wrote {stem}.csv, .json, .png")
    return 0


def _cmd_league(args):
    from .headroom import Headroom, league_markdown

    stems = sorted(p.with_suffix("") for p in Path(args.results).glob("*.json"))
    if not stems:
        raise ValueError(f"no headroom tables (*.json) in {args.results}")
    print(league_markdown([Headroom.load(s) for s in stems]))
    return 0


def _whole_numbers(option: str, text: str) -> tuple[int, ...]:
    try:
        return tuple(int(v) for v in text.split(","))
    except ValueError:
        raise ValueError(f"{option} takes whole numbers separated by commas, got {text!r}") from None


def _seed(text: str) -> int:
    """A seed option's value: a whole number from 0 to SEED_LIMIT - 1 (argparse names the option on an error)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"a seed is a whole number, got {text!r}") from None
    if not 0 <= value < SEED_LIMIT:
        raise argparse.ArgumentTypeError(f"a seed is from 0 to {SEED_LIMIT - 1}, got {value}")
    return value


def _shared_options() -> dict[str, argparse.ArgumentParser]:
    """Parent parsers of the options several commands share, each defined once."""
    compute = argparse.ArgumentParser(add_help=False)
    compute.add_argument("--device", default="cpu", help="cpu or cuda (the paper preset is meant for a GPU)")
    labels = argparse.ArgumentParser(add_help=False)
    labels.add_argument("--label-noise", default="none", choices=list(LABEL_NOISE), help="the segmenter's noise level "
                        "(segmenter.py; default: exact labels, as the paper)")
    preset = argparse.ArgumentParser(add_help=False)
    preset.add_argument("--preset", default="lite", choices=sorted(PRESETS))
    mission = argparse.ArgumentParser(add_help=False)
    mission.add_argument("--seed", type=_seed, default=0)
    mission.add_argument("--targets", default=None, help="comma-separated class names (default: the scene's)")
    return {"compute": compute, "labels": labels, "preset": preset, "mission": mission}


def main(argv=None):
    parser = argparse.ArgumentParser(prog="python -m stair_lite", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    shared = _shared_options()
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("scenes", help="list the shipped scenes, or describe scene files")
    p.add_argument("files", nargs="*", help="scene files (JSON) to describe instead")
    p.set_defaults(func=_cmd_scenes)
    p = sub.add_parser("render", help="render a scene from a few views")
    p.add_argument("--scene", default="scene1")
    p.add_argument("--out", default="runs/render")
    p.set_defaults(func=_cmd_render)
    p = sub.add_parser("fit", help="fit a map (the field, or the voxel map) to fixed spread views and evaluate it",
                       parents=[shared[k] for k in ("preset", "mission", "compute", "labels")])
    p.add_argument("--scene", default="scene1")
    p.add_argument("--views", type=int, default=10)
    p.add_argument("--mapper", default=IMPLICIT, choices=list(MAP_KINDS), help="the map fitted (default: the field)")
    p.add_argument("--iterations", type=int, default=None, help="override iterations per view")
    p.add_argument("--rays", type=int, default=None, help="override new and replay rays per iteration")
    p.add_argument("--eval-preset", default=None, choices=sorted(PRESETS), help="evaluate with another preset's protocol")
    p.add_argument("--out", default=None, help="folder for the target mesh (PLY)")
    p.set_defaults(func=_cmd_fit)
    p = sub.add_parser("run", help="run one active reconstruction mission",
                       parents=[shared[k] for k in ("preset", "mission", "compute", "labels")])
    p.add_argument("--scene", default="scene1")
    p.add_argument("--planner", default="stair", help=", ".join((*PLANNERS, REPLAY)) + ", or path/to/file.py:ClassName "
                   "(your own subclass of stair_lite.planners.Planner)")
    p.add_argument("--budget", type=int, default=None, help="number of measurements, the top view included "
                   "(default: the preset's, 10)")
    p.add_argument("--epsilon", type=float, default=None, help="exploration weight of the STAIR utility (default: the preset's, 0.2)")
    p.add_argument("--mapper", default=None, choices=list(MAP_KINDS), help="the map that is evaluated (default: the map "
                   "the planner reads, else the field)")
    p.add_argument("--replay", default=None, help="with --planner replay: a metrics.json whose views are followed")
    p.add_argument("--out", default="runs/demo")
    p.add_argument("--resume", action="store_true", help="continue a mission found in --out")
    p.add_argument("--overwrite", action="store_true", help="replace the results found in --out")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=_cmd_run)
    p = sub.add_parser("sweep", help="missions over scenes x planner variants x seeds",
                       parents=[shared[k] for k in ("preset", "compute", "labels")])
    p.add_argument("--scenes", default="all", help="'all' (scene1-4) or comma-separated scene names")
    p.add_argument("--planners", default="all", help="'all', 'base' or comma-separated variants (e.g. stair,ste,stair_eps0.5,"
                   "path/to/file.py:ClassName)")
    p.add_argument("--seeds", type=int, default=5, help="number of seeds per cell")
    p.add_argument("--first-seed", type=_seed, default=0)
    p.add_argument("--budget", type=int, default=None, help="measurements per mission (default: the preset's, 10)")
    p.add_argument("--workers", type=int, default=1, help="cells in parallel: N > 1 starts a local Dask cluster of N "
                   "single-threaded worker processes")
    p.add_argument("--scheduler", default=None, help="address of an existing Dask cluster (tcp://host:8786) to run the cells on")
    p.add_argument("--worker-timeout", type=float, default=WORKER_TIMEOUT_S, help="seconds to wait for a worker while "
                   "the cluster has none, then give up (default %(default)s)")
    p.add_argument("--out", default="runs/sweep")
    p.add_argument("--quiet", action="store_true")
    p.set_defaults(func=_cmd_sweep)
    p = sub.add_parser("report", help="results table, curves and summary of a sweep folder")
    p.add_argument("--results", default="runs/sweep")
    p.set_defaults(func=_cmd_report)
    p = sub.add_parser("headroom", help="does a utility predict what a view will teach? (realised gains of spread views)",
                       parents=[shared[k] for k in ("preset", "compute")])
    p.add_argument("--scene", default="scene1", help="a scene, comma-separated scenes, or 'all' (scene1-4)")
    p.add_argument("--after", default="3", help="views of a seeded STAIR mission before the candidate view (or a "
                   "comma-separated list)")
    p.add_argument("--candidates", type=int, default=16, help="spread candidate views (a Fibonacci set)")
    p.add_argument("--streams", type=int, default=1, help="training streams each spread view is realised with (> 1: "
                   "the noise ceiling)")
    p.add_argument("--utilities", default=None, help="comma-separated planners whose utility and pick are measured, "
                   "registered or path/to/file.py:ClassName (default: every registered planner with a utility)")
    p.add_argument("--seed", type=_seed, default=0)
    p.add_argument("--again", action="store_true", help="measure a table anew even if --out holds it (by default a "
                   "stored table is kept, and utilities it lacks are added to it)")
    p.add_argument("--out", default="runs/headroom")
    p.add_argument("--quiet", action="store_true")
    p.set_defaults(func=_cmd_headroom)
    p = sub.add_parser("league", help="the league of utilities over a folder of headroom tables (Markdown)")
    p.add_argument("--results", default="data/results/headroom_league_lite")
    p.set_defaults(func=_cmd_league)
    p = sub.add_parser("claims", help="the paper's three claims checked against stored results (Markdown)")
    p.add_argument("--results", default="data/results/comparison_lite")
    p.add_argument("--ablation", default=None, help="an epsilon-ablation sweep folder (claim iii)")
    p.set_defaults(func=_cmd_claims)
    p = sub.add_parser("label-noise-claims", help="does semantic uncertainty help under label noise? (Markdown)")
    p.add_argument("--results", default="data/results", help="the folder of label_noise_<level>_<study> and "
                   "comparison_<study>")
    p.add_argument("--study", default=None, help="the folders' suffix (default: the study RESULTS.md quotes, "
                   "noise_study.STORED_STUDY; lite: the re-run at the adopted lite)")
    p.set_defaults(func=_cmd_label_noise_claims)
    p = sub.add_parser("scale-claims", help="which claim verdicts change from lite to the paper scale (Markdown)")
    p.add_argument("--results", default="data/results", help="the folder of comparison_lite and comparison_paper")
    p.set_defaults(func=_cmd_scale_claims)
    args = parser.parse_args(argv)
    try:
        return args.func(args) or 0
    except (ValueError, OSError) as err:  # bad input, or a folder that cannot be written: one line, no traceback
        print(f"error: {err}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
