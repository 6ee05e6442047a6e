"""`ibvs run`: one simulated episode, its status and metrics printed, drawn (--plot), animated
(--animate) or closed through rendered images (--vision, --video)."""

from __future__ import annotations

import math

from . import args as a
from . import arm


#: The scheme of `ibvs run` without --scheme: IBVS-P, the paper's law, except on an arm.
DEFAULT_SCHEME = "polar"
#: On an arm the general motion's start needs the stacked hybrid: IBVS-P loses a point from the image
#: within the first second (frame 19 on the Panda, 26 on the UR5), the stacked law converges (765, 836).
DEFAULT_SCHEME_ARM = "stacked"


def add_parser(sub) -> None:
    """The `run` subcommand's parser."""
    from ..study.reproduce import CASES, DEFAULT_CASE
    from ..study.schemes import SCHEMES, TITLES

    cases = sorted({c for w in CASES.values() for c in w})
    one = sub.add_parser("run", help="simulate one episode and print its status and metrics",
                         description="Simulate one episode and print its status and metrics; draw it (--plot) or "
                                     "animate it (--animate).",
                         epilog=a.exit_status("the episode converged",
                                              "the episode ran correctly but did not converge (its outcome is printed: "
                                              "timeout, lost_feature, ...): a result, not an error"))
    one.add_argument("--world", choices=sorted(CASES), default="free",
                     help="free-flying camera, the gantry, or an arm (--robot)")
    arm.add_options(one)
    one.add_argument("--scheme", choices=list(SCHEMES), default=None,
                     help="; ".join(f"{k}: {v}" for k, v in TITLES.items() if k in SCHEMES)
                          + f" (default {DEFAULT_SCHEME}; {DEFAULT_SCHEME_ARM} for --world arm, where IBVS-P loses a "
                            "point from the image in the general motion)")
    one.add_argument("--case", choices=cases,
                     help="which start pose (default: " + ", ".join(f"{v} for {k}" for k, v in DEFAULT_CASE.items())
                          + ")")
    one.add_argument("--rotation-deg", type=a.number(-360, 360), metavar="DEG",
                     help="angle of the z-rotation case about the optical axis, in degrees (default 180)")
    a.add_output(one, "--plot", type=a.figure_file, metavar="FILE", help="save the episode's figure (PNG, PDF, SVG)")
    a.add_output(one, "--animate", type=a.animation_file, metavar="FILE",
                     help="write an animation: camera view and 3D scene (.gif, or .mp4 with imageio-ffmpeg)")
    one.add_argument("--vision", choices=["dots", "tag", "klt", "keypoints"],
                     help="close the loop through rendered images: white dots (tracked), an AprilTag 36h11 "
                          "(cv2.aruco), or a textured plate whose corners KLT or keypoints find (the schemes klt "
                          "and keypoints use these); a normalised camera becomes 640x480 with f = 800 px "
                          "(needs the vision extra)")
    a.add_output(one, "--video", type=a.out_file(".mp4", ".gif"), metavar="FILE",
                     help="with --vision: the camera frames with detected (green) and desired (red) points, "
                          ".mp4 (imageio-ffmpeg; else a GIF, with a message) or .gif")
    a.add_output(one, "--record", type=a.out_file(".mcap"), metavar="FILE.mcap",
                     help="also write the episode as a ROS 2 bag, one MCAP file (topics in docs/ros.md; needs the ros "
                          "extra)")
    a.add_output(one, "--rerun", type=a.out_file(".rrd"), metavar="FILE.rrd",
                     help="also log the episode to a Rerun recording (needs the rerun extra)")
    one.add_argument("--speed", type=a.number(0, 1000, open_lo=True), default=1.0,
                     help="animation speed: simulated seconds per second of video (default 1, real time)")
    one.add_argument("--seed", type=a.number(0, a.SEED_MAX, integer=True), default=0, help="seed of the noise")
    one.add_argument("--noise", type=a.number(0, 1e4), default=0.0, metavar="STD", help=a.NOISE_HELP)
    one.add_argument("--latency", type=a.number(0, 1000, integer=True), default=0, metavar="FRAMES",
                     help="frames between capture and control (fewer than the episode's frames)")
    one.add_argument("--gain", type=a.number(0, 1e4, open_lo=True), help="control gain, 1/s (default per world)")
    one.add_argument("--duration", type=a.number(0, 3600, open_lo=True), metavar="SECONDS",
                     help="episode length in seconds, at most 3600 (default per world)")
    one.add_argument("--depth", choices=["exact", "pose", "desired", "estimated"], help=a.DEPTH_HELP)
    one.add_argument("--goal-pose", choices=["taught", "given"], default="taught",
                     help=a.GOAL_POSE_HELP + " (default taught)")
    one.add_argument("--tolerance", type=a.number(0, 1e6), help=a.TOLERANCE_HELP)
    one.add_argument("--tolerance-px", type=a.number(0, 1e6, open_lo=True), metavar="PX", help=a.TOLERANCE_PX_HELP)
    a.add_angle_wrap(one, "consistent")


def command(args) -> int:
    """Run `ibvs run`; the exit status (0 when the episode converged, else 1)."""
    from .. import sim
    from ..study import reproduce
    from ..study import schemes as schemes_mod

    prog = "ibvs run"
    arm.check(prog, args)
    if args.scheme is None:
        args.scheme = DEFAULT_SCHEME_ARM if args.world == "arm" else DEFAULT_SCHEME
    case = args.case or reproduce.DEFAULT_CASE[args.world]
    if case not in reproduce.CASES[args.world]:
        a.fail(prog, f"argument --case: {case} is not available for --world {args.world}; "
                            f"choose from {', '.join(sorted(reproduce.CASES[args.world]))}")
    custom = None
    if args.rotation_deg is not None:
        if case != "z-rotation":
            a.fail(prog, "argument --rotation-deg: only with --case z-rotation")
        custom = sim.cases.z_rotation(math.radians(args.rotation_deg))
    if args.world == "arm":
        custom = arm.case(prog, args)
    c = custom or reproduce.make_case(args.world, case)
    duration = args.duration if args.duration is not None else reproduce.DURATION[args.world]
    frames = round(duration * c.camera.fps)
    if args.latency >= frames:
        a.fail(prog, f"argument --latency: {args.latency} frames is not shorter than the episode "
                            f"({frames} frames)")
    if (args.depth or reproduce.DEPTH[args.world]) == "pose" and not c.target.planar:
        a.fail(prog, "argument --depth: pose needs a planar target")
    for option, check in (("--record", args.record and _rosbags), ("--rerun", args.rerun and _rerun)):
        if check:
            try:
                check()
            except ImportError as e:
                a.fail(prog, f"argument {option}: {e}")
    sensor = None
    args.vision = args.vision or schemes_mod.VISION.get(args.scheme)  # klt, keypoints: their image sensor
    if args.video and not args.vision:
        a.fail(prog, "argument --video: needs --vision (dots, tag, klt, keypoints)")
    if args.vision:
        try:
            from .. import vision
        except ImportError as e:
            a.fail(prog, f"argument --vision: {e}")
        try:
            sensor = vision.ImageSensor.for_target(vision.image_camera(c.camera), c.target, args.vision,
                                                   keep_frames=bool(args.video or args.rerun))
        except ValueError as e:
            a.fail(prog, f"argument --vision: {e}")
    try:  # a scheme beyond points checks the case's target (moments: not centrally symmetric)
        schemes_mod.target_for(args.scheme, c.target)
    except ValueError as e:
        a.fail(prog, f"argument --scheme: {e}")
    case_obj, result = reproduce.run_one(args.world, case, args.scheme, duration=duration, noise=args.noise,
                                         latency=args.latency, seed=args.seed, gain=args.gain, depth=args.depth,
                                         tolerance=a.tolerance_of(args), tolerance_px=args.tolerance_px,
                                         case_object=c, angle_wrap=args.angle_wrap, vision=sensor,
                                         record=args.record, goal_pose=args.goal_pose)
    row = reproduce.summarise(args.world, case, args.scheme, result, args.angle_wrap)
    from ..study.schemes import TITLES

    wrap = "" if row.angle_wrap == "-" else f", {row.angle_wrap} wrap"
    wrap += ", goal pose given" if args.goal_pose == "given" else ""
    title = f"{case_obj.description}, {TITLES.get(args.scheme, args.scheme)}{wrap}"
    print(title)
    lines = row.report()
    width = max(len(name) for name, _ in lines)
    for name, value in lines:
        print(f"  {name:{width}s}  {value}")
    if args.plot:
        from .. import viz

        viz.episode(result, title=title).savefig(args.plot, dpi=90)
        print(f"  {'figure':{width}s}  {args.plot}")
    if args.animate:
        from .. import viz

        n = viz.animate(result, args.animate, labels=[title], speed=args.speed)
        print(f"  {'animation':{width}s}  {args.animate} ({n} frames)")
    if args.video:
        from .. import vision

        cam = sensor.renderer.camera
        pixels = result.history.measured
        desired = cam.project(result.uv_desired)
        written = vision.write_video(args.video, sensor.frames, pixels, desired, fps=cam.fps)
        print(f"  {'video':{width}s}  {written} ({len(sensor.frames)} frames)")
    if args.record:
        print(f"  {'bag':{width}s}  {args.record}")
    if args.rerun:
        from .. import viz

        viz.rerun(result, path=args.rerun, labels=[f"{args.world}_{case}_{args.scheme}"])
        print(f"  {'rerun':{width}s}  {args.rerun}")
    return 0 if result.status.outcome == "converged" else 1


def _rosbags() -> None:
    from ..ros import types

    types.typestore()


def _rerun() -> None:
    from ..viz.rerun_log import rerun_module

    rerun_module()
