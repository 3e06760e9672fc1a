"""The per-step cost of the authors' STAIR code (dmar-bonn/stair, unmodified) on this CPU, for the step ratio of
``bench_paper_cpu.py``: seconds per training iteration, per candidate in their planner's batched calls, one planning
step, and the peak memory.

Runs in an environment of its own (their code is written for Python 3.7, CUDA and ROS; on a CPU it needs only part of
it): Python 3.11 with torch==2.13.0, numpy==2.4.6, scipy==1.17.1, trimesh==5.2.0, scikit-image==0.26.0,
opencv-python-headless==4.14.0.94, kornia==0.9.0, dotmap==1.3.30, plyfile==1.1.5, matplotlib==3.11.2, imageio==2.38.2,
pillow==13.0.0, PyYAML==6.0.4, tqdm==4.70.1; their repository checked out unmodified (``--stair``). Their default
configs (configs/basic.yaml, planning/uncertainty_target.yaml, mapping/implicit.yaml's coarse stage: 128^3 dense grids,
8000-ray batches, 200 iterations per view, 200 candidates rendered at 80 x 80), built through their own argument
parser (``plan.py --config uncertainty_target implicit``).

The input is our scene's measurement (``authors_measurement.py``, run in this repository's environment, writes it). In
the order of their planning loop: their planner ingests the top view (their ``move_sensor`` without the simulator:
``record_step``, ``update_measurement``), trains ``--iterations`` (each iteration time-stamped: the median of those after
``--warmup``), plans one step (``plan_next_view``: 100 candidates on a spiral in one batched call, then 10 around each
of the best 10 in a second; s/candidate = the time of the two calls / candidates), and with ``--views 2`` ingests a
second view and trains again (from their second view on, a batch is 4000 new + 4000 replayed rays; the first view's is
4000). Checks printed: our pose against their ``view_to_pose``, their rays times our depth against our back-projected
points, their trained field's depth against the measured one. Their loop also saves the model and a mesh after every
step and waits 2 s per move: not timed here.

Modules their imports reach but the timed path never calls are stand-ins (``sys.modules``): rospy, geometry_msgs,
sensor_msgs, cv_bridge (their Gazebo link), open3d (the explicit mapper), lpips (their evaluation), torchvision (a
visualisation helper), tools.libmcubes and tools.libmise (unbuilt extensions for saving meshes); each raises if called,
except the ROS ones that stand in for the simulator at construction.

With ``--views 2`` and the full schedule the figures are stored with this machine's CPU (``--record``, default
runs/authors/step.json): ``bench_paper_cpu.py`` divides by that step on the same CPU.

Run (quiet machine): python benchmarks/authors_step.py --stair PATH --views 2 [--iterations 200 --warmup 150]"""
from __future__ import annotations

import argparse
import os
import resource
import sys
import time
import types

from authors_record import RECORD_DEFAULT, write_record

MEASUREMENT_DEFAULT = "runs/authors/measurement.npz"


def parse_args():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--iterations", type=int, default=200, help="training iterations after the top view (their "
                    "iteration_per_step is 200)")
    ap.add_argument("--warmup", type=int, default=150, help="iterations left out of the median (median over "
                    "iterations warmup+1..iterations)")
    ap.add_argument("--candidates", type=int, default=200, help="candidates of the planning step (their "
                    "num_candidates is 200); below 20 their cluster_top_k is lowered so both stages render")
    ap.add_argument("--threads", type=int, default=2, help="torch intra-op threads")
    ap.add_argument("--views", type=int, choices=(1, 2), default=1, help="2: after the planning step, add the "
                    "second measurement and time another --iterations (8000-ray batches)")
    ap.add_argument("--measurement", default=MEASUREMENT_DEFAULT)
    ap.add_argument("--stair", required=True, help="a checkout of the authors' repository (unmodified)")
    ap.add_argument("--depth-check-stride", type=int, default=4, help="pixel stride of the depth check render "
                    "(4: 100x100 rays); 0 skips it")
    ap.add_argument("--record", default=RECORD_DEFAULT, help="where the figures are stored with this machine's CPU, "
                    "for bench_paper_cpu.py's step ratio (written with --views 2 and the full schedule only)")
    ap.add_argument("--exp-path", default="runs/authors/experiment", help="their --exp_path (nothing is written "
                    "there by this harness)")
    return ap.parse_args()


ARGS = parse_args()
# threads before torch / numpy load: torch gets --threads, numpy's BLAS one (as stair_lite's cores.py)
os.environ["OMP_NUM_THREADS"] = str(ARGS.threads)
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", str(ARGS.threads))
os.environ.setdefault("MPLBACKEND", "Agg")  # their TrajectoryVisualizer makes a matplotlib figure

import numpy as np  # noqa: E402
import torch  # noqa: E402

torch.set_num_threads(ARGS.threads)
torch.set_num_interop_threads(1)

MEAS = np.load(ARGS.measurement)
H, W = MEAS["depth"].shape
FX, FY, CX, CY = (float(v) for v in MEAS["K"])


# ----------------------------------------------------------------------------------------------- stubs
def _unused(name):
    def fail(*a, **k):
        raise RuntimeError(f"stubbed {name} was called: the harness assumed it is off the timed path")
    return fail


def _module(name, **attrs):
    mod = types.ModuleType(name)
    mod.__dict__.update(attrs)
    mod.__stub__ = True
    sys.modules[name] = mod
    return mod


class _CameraInfo:  # sensor_msgs/CameraInfo: what SimulatorBridge.get_simulator_camera_info reads
    def __init__(self):
        self.K = [FX, 0.0, CX, 0.0, FY, CY, 0.0, 0.0, 1.0]
        self.height, self.width = H, W


class _Pose:  # geometry_msgs/Pose
    def __init__(self):
        self.position = types.SimpleNamespace(x=0.0, y=0.0, z=0.0)
        self.orientation = types.SimpleNamespace(x=0.0, y=0.0, z=0.0, w=1.0)


class _Publisher:
    def __init__(self, *a, **k):
        pass

    def publish(self, msg):
        pass


class _Subscriber:
    def __init__(self, *a, **k):
        pass


class _CvBridge:  # the stub simulator's "messages" are already numpy arrays
    def imgmsg_to_cv2(self, msg, encoding=None):
        return msg


def install_stubs():
    _module("rospy", Publisher=_Publisher, Subscriber=_Subscriber, init_node=lambda *a, **k: None,
            is_shutdown=lambda: False, wait_for_message=lambda topic, cls, *a, **k: _CameraInfo())
    _module("geometry_msgs")
    sys.modules["geometry_msgs"].msg = _module("geometry_msgs.msg", Pose=_Pose)
    _module("sensor_msgs")
    sys.modules["sensor_msgs"].msg = _module("sensor_msgs.msg", Image=object, CameraInfo=_CameraInfo)
    _module("cv_bridge", CvBridge=_CvBridge)
    o3d = _module("open3d")
    o3d.visualization = _module("open3d.visualization", rendering=types.SimpleNamespace())
    o3d.camera = types.SimpleNamespace()
    _module("lpips", LPIPS=_unused("lpips.LPIPS"))
    tv = _module("torchvision")
    tv.transforms = _module("torchvision.transforms", ToTensor=_unused("torchvision.transforms.ToTensor"))
    _module("tools.libmcubes", marching_cubes=_unused("mcubes.marching_cubes"),
            marching_cubes_func=_unused("mcubes.marching_cubes_func"), export_mesh=_unused("export_mesh"),
            export_obj=_unused("export_obj"), export_off=_unused("export_off"))
    _module("tools.libmise", MISE=_unused("libmise.MISE"))


# ----------------------------------------------------------------------------------------------- helpers
def peak_rss_mib():
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # Linux: KiB


def gazebo_pose(pose_cv, gazebo2opencv):
    """Their record_trajectory turns a Gazebo pose P into the OpenCV camera-to-world P @ T (planning_utils.gazebo2opencv);
    our pose is already OpenCV camera-to-world, so hand them P_cv @ inv(T)."""
    T = gazebo2opencv(np.eye(4))
    return np.asarray(pose_cv, dtype=np.float64) @ np.linalg.inv(T)


def measurement_arrays(suffix=""):
    rgb255 = MEAS["rgb" + suffix].astype(np.float64) * 255.0  # their simulator bridge: rgb8 as float 0..255
    depth = MEAS["depth" + suffix].astype(np.float64).copy()  # z-depth [m], 0 = no hit (their inf/nan -> 0)
    labels = MEAS["labels" + suffix].astype(np.uint8).copy()  # mono8 class ids 0..6 (their LABELS["shapenet"])
    return rgb255, depth, labels


def take_measurement(planner, view, pose_gz, suffix=""):
    """PlannerBase.move_sensor without the simulator: the same calls on our measurement (no publish, no sleep(2))."""
    rgb255, depth, labels = measurement_arrays(suffix)
    planner.current_view = view
    planner.current_pose = pose_gz
    planner.record_step(view, pose_gz, rgb255, depth, labels)
    planner.update_measurement()
    planner.step += 1


def timed_training(planner, n):
    """planner.update(n) as their loop calls it; returns each iteration's seconds."""
    mapper = planner.mapper
    stamps = []
    orig = mapper.update_training_setup  # called once at the end of every iteration of update_map

    def stamped():
        orig()
        stamps.append(time.perf_counter())

    mapper.update_training_setup = stamped
    try:
        t0 = time.perf_counter()
        outputs, iteration = planner.update(n)
    finally:
        del mapper.update_training_setup  # back to the class's method
    times = np.diff(np.array([t0] + stamps))
    return times, outputs, iteration


def median_after(times, warmup):
    tail = times[warmup:] if warmup < len(times) else times
    return float(np.median(tail)), len(tail)


def geometry_checks(planner, suffix, pose_gz, view, view_to_pose):
    """(a) our pose vs their view_to_pose of the same view (a roll about the optical axis would show here);
    (b) their rays (from their camera_info intrinsics and our converted pose) x our depth = our back-projected points."""
    their = view_to_pose(list(np.asarray(view, dtype=float)), planner.radius)
    d_pose = np.abs(their - pose_gz).max()
    k = planner.step - 1
    rays = planner.all_rays_record[k * planner.pixel_num:(k + 1) * planner.pixel_num].numpy().astype(np.float64)
    pix = MEAS["check_pix" + suffix]
    depth = MEAS["depth" + suffix].reshape(-1).astype(np.float64)
    pts = rays[pix, :3] + rays[pix, 3:6] * depth[pix, None]
    err = np.linalg.norm(pts - MEAS["check_xyz" + suffix], axis=1)
    print(f"[check] view{suffix or '1'}: max |our pose - their view_to_pose| = {d_pose:.2e}; their rays x our depth vs "
          f"our back-projection over {len(pix)} object pixels: max {err.max() * 1000:.3f} mm, mean {err.mean() * 1000:.3f} mm")


@torch.no_grad()
def depth_check(planner, BatchRenderer, step_index, suffix, stride):
    """Render the measured view's rays (every stride-th pixel) with their renderer and compare depth on object pixels."""
    m = planner.mapper
    n = planner.pixel_num
    idx = torch.arange(n).view(H, W)[::stride, ::stride].reshape(-1)
    rays = planner.all_rays_record[step_index * n:(step_index + 1) * n][idx]
    depth = torch.as_tensor(MEAS["depth" + suffix].reshape(-1)[idx.numpy()], dtype=torch.float32)
    obj = torch.as_tensor(MEAS["labels" + suffix].reshape(-1)[idx.numpy()] != 0)
    t0 = time.perf_counter()
    out = {}
    for mode, is_train in (("eval", False), ("train", True)):  # eval mode zeroes samples whose class is background
        rgb, sem, dep, dunc, sunc, acc, _ = BatchRenderer(rays, m.model, chunk=m.batch_size, n_samples=-1,
                                                          white_bg=m.white_bg, device=m.device, is_train=is_train)
        out[mode] = (dep, acc)
    dt = time.perf_counter() - t0
    for mode, (dep, acc) in out.items():
        mae = (dep[obj] - depth[obj]).abs().mean().item()
        print(f"[check] view{suffix or '1'} depth ({mode}-mode render, {len(idx)} rays): mean |rendered - measured| on "
              f"object pixels {mae:.4f} m (measured mean {depth[obj].mean():.3f} m; rendered mean {dep[obj].mean():.3f} m); "
              f"opacity: objects {acc[obj].mean():.3f}, background {acc[~obj].mean():.3f}")
    print(f"[check] (depth check renders took {dt:.1f} s, outside every timed region)")


def ingest_and_train(planner, suffix, gazebo2opencv, view_to_pose):
    """Ingest the measurement stored with ``suffix`` ("" the top view, "2" the second), check its geometry, train
    ``--iterations`` and print them; returns the median seconds per iteration after ``--warmup`` and how many."""
    view = np.asarray(MEAS["view" + suffix], dtype=float)
    pose = gazebo_pose(MEAS["pose" + suffix], gazebo2opencv)
    take_measurement(planner, list(view), pose, suffix=suffix)
    geometry_checks(planner, suffix, pose, view, view_to_pose)
    sampler, name = planner.mapper.training_sampler, f"view {suffix or '1'}"
    print(f"[setup] after {name}: {planner.mapper.num_rays} rays in the buffer; rays per iteration "
          f"{sampler.batch_new} new + {sampler.batch_buffer if sampler.total_buffer > 0 else 0} replayed")
    times, outputs, iteration = timed_training(planner, ARGS.iterations)
    s_iter, n_med = median_after(times, ARGS.warmup)
    print(f"[train {name}] {len(times)} iterations (to {iteration}), total {times.sum():.2f} s; first {times[0]:.3f} s; "
          f"median of the last {n_med}: {s_iter:.4f} s/iteration (min {times[-n_med:].min():.4f}, max "
          f"{times[-n_med:].max():.4f}); rgb_loss {outputs['rgb_loss']:.4f}, psnr {outputs['psnr']:.2f}")
    return s_iter, n_med


# ----------------------------------------------------------------------------------------------- main
def main():
    stair = os.path.abspath(ARGS.stair)
    sys.dont_write_bytecode = True  # leave their tree as extracted (no __pycache__)
    sys.path.insert(0, stair)
    install_stubs()
    np.random.seed(20211202)  # their --random_seed default (their code parses it but never seeds)
    torch.manual_seed(20211202)

    targets = [str(int(t)) for t in MEAS["targets"]]
    argv = sys.argv
    sys.argv = ["plan.py", "--config", "uncertainty_target", "implicit", "--exp_path", ARGS.exp_path,
                "--target_class_id", *targets]
    try:
        from tools.options import arg_parser
        args = arg_parser("planning")
    finally:
        sys.argv = argv
    from planning import get_planner
    from planning.planning_utils import gazebo2opencv, view_to_pose
    from tools.utils import BatchRenderer

    for name in ("rospy", "open3d", "lpips", "torchvision", "tools.libmcubes", "tools.libmise"):
        assert getattr(sys.modules[name], "__stub__", False), name

    device = torch.device("cpu")
    t_build = time.perf_counter()
    planner = get_planner(args, device)
    t_build = time.perf_counter() - t_build
    model = planner.mapper.model
    print(f"[setup] torch {torch.__version__}, threads {torch.get_num_threads()}, device {device}; planner "
          f"{type(planner).__name__} built in {t_build:.1f} s; camera {planner.H}x{planner.W} f={planner.focal} c={planner.c}")
    print(f"[setup] model grid {model.grid_size.tolist()} aabb {model.aabb.view(-1).tolist()}, step {model.step_size.item():.5f} m, "
          f"samples per ray {model.n_samples} (n_samples_max {model.n_samples_max}), near_far {model.near_far}, "
          f"batch_size {args.batch_size}, iteration_per_step {args.iteration_per_step}, num_candidates {args.num_candidates}, "
          f"downscale_planning {args.downscale_planning} -> candidate renders {int(planner.H * args.downscale_planning)}x"
          f"{int(planner.W * args.downscale_planning)}, targets {planner.planning_target_id}")

    # --- the top view
    s_iter, n_med = ingest_and_train(planner, "", gazebo2opencv, view_to_pose)
    rss_train = peak_rss_mib()
    print(f"[memory] peak RSS after training view 1: {rss_train:.0f} MiB")

    # --- one planning step (their plan_next_view) on the trained map
    n_cand = ARGS.candidates
    planner.num_candidates = n_cand
    if n_cand < 2:
        raise SystemExit("--candidates must be at least 2")
    coverage = int(np.floor(n_cand * planner.candidate_ratio))
    if coverage < planner.cluster_top_k:
        planner.cluster_top_k = max(1, coverage)  # short runs only: the default 200 needs no change
    calls = []
    orig_utility = planner.get_candidate_utility
    orig_render = planner.mapper.render_view

    def timed_render(pose, *a, **k):
        t0 = time.perf_counter()
        out = orig_render(pose, *a, **k)
        calls.append({"render_s": time.perf_counter() - t0, "n": int(np.shape(pose)[0]) if np.ndim(pose) == 3 else 1})
        return out

    def timed_utility(candidate_poses):
        t0 = time.perf_counter()
        out = orig_utility(candidate_poses)
        calls[-1]["utility_s"] = time.perf_counter() - t0
        return out

    planner.mapper.render_view = timed_render
    planner.get_candidate_utility = timed_utility
    t0 = time.perf_counter()
    next_views = planner.plan_next_view()
    t_plan = time.perf_counter() - t0
    del planner.mapper.render_view, planner.get_candidate_utility
    rss_plan = peak_rss_mib()
    n_scored = sum(c["n"] for c in calls)
    t_util = sum(c["utility_s"] for c in calls)
    t_render = sum(c["render_s"] for c in calls)
    s_cand = t_util / n_scored
    for i, c in enumerate(calls):
        print(f"[plan] batched call {i + 1}: {c['n']} candidates, render_view {c['render_s']:.2f} s "
              f"({c['render_s'] / c['n']:.4f} s/candidate), with cal_utility {c['utility_s']:.2f} s")
    print(f"[plan] planning step (plan_next_view) {t_plan:.2f} s; {n_scored} candidates scored in {t_util:.2f} s: "
          f"{s_cand:.4f} s/candidate ({t_render / n_scored:.4f} s/candidate in render_view alone); "
          f"cluster_top_k {planner.cluster_top_k}; next view {np.round(np.degrees(next_views[0]), 2).tolist() if next_views else None} deg; "
          f"peak RSS so far {rss_plan:.0f} MiB")

    s_iter2 = ingest_and_train(planner, "2", gazebo2opencv, view_to_pose)[0] if ARGS.views == 2 else None

    if ARGS.depth_check_stride > 0:
        depth_check(planner, BatchRenderer, 0, "", ARGS.depth_check_stride)
        if ARGS.views == 2:
            depth_check(planner, BatchRenderer, 1, "2", ARGS.depth_check_stride)

    rss = peak_rss_mib()
    print(f"[memory] peak resident memory of the process: {rss:.0f} MiB ({rss / 1024:.2f} GiB); after training "
          f"{rss_train:.0f} MiB, after planning {rss_plan:.0f} MiB")
    extra = f" s/iteration(view2, 8000 rays)={s_iter2:.4f}" if s_iter2 is not None else ""
    print(f"SUMMARY authors threads={ARGS.threads} s/iteration={s_iter:.4f} (view1, {sampler_rays(planner, 1)} rays, median "
          f"of {n_med} of {ARGS.iterations}) s/candidate={s_cand:.4f} ({n_scored} scored; plan_next_view {t_plan:.2f} s)"
          f"{extra} peak_rss={rss:.0f} MiB")
    s_step_iter = s_iter if s_iter2 is None else s_iter2
    print(f"the authors' step without evaluation: 200 x {s_step_iter:.3f} s per iteration "
          f"({'8000' if s_iter2 is not None else sampler_rays(planner, 1)} rays) + 200 x {s_cand:.3f} s per candidate = "
          f"{200 * s_step_iter + 200 * s_cand:.0f} s")
    if s_iter2 is not None and ARGS.iterations == 200 and ARGS.candidates == 200:
        write_record(ARGS.record, threads=ARGS.threads, iteration_s=round(s_iter2, 4), candidate_s=round(s_cand, 4),
                     step_s=round(200 * s_iter2 + 200 * s_cand, 1), peak_rss_mib=round(rss))
        print(f"wrote {ARGS.record}")


def sampler_rays(planner, view_count):
    return planner.args.batch_size - int(planner.args.batch_size * planner.args.buffer_sample_ratio) \
        if view_count == 1 else planner.args.batch_size


if __name__ == "__main__":
    main()
