"""`ibvs replay BAG`: a ROS 2 bag's images through a tracker and the servo, offline (ibvs.ros.replay);
the twists it would have commanded into a CSV (--out) and, optionally, a copy of the bag with them
added (--bag-out). With the bag's own /ibvs/cmd_twist (a recorded simulation), how far they are from
the recorded ones is printed."""

from __future__ import annotations

import argparse
from pathlib import Path

from . import args as a
from .arm import numbers


def bag_path(text: str) -> Path:
    """argparse type: an existing bag, a rosbag2 directory or an .mcap file."""
    p = Path(text)
    if not p.exists():
        raise argparse.ArgumentTypeError(f"no bag {text!r}")
    if p.is_file() and p.suffix != ".mcap":
        raise argparse.ArgumentTypeError(f"{text!r}: a bag is a rosbag2 directory or an .mcap file")
    return p


def add_parser(sub) -> None:
    """The `replay` subcommand's parser."""
    from ..study.schemes import SCHEMES

    r = sub.add_parser("replay", help="run a tracker and the servo over a ROS 2 bag's images, offline",
                       description="Run a tracker (dots or tag) and the servo over a ROS 2 bag's images and write "
                                   "the twists it would have commanded. A bag recorded by ibvs (ibvs run --record) "
                                   "holds everything needed in /ibvs/config; a real robot's bag needs --tracker, "
                                   "--scheme, --desired-pixels, --depth-desired (and --initial-pixels for dots).",
                       epilog=a.exit_status("every image was replayed; the twists are written",
                                            "the features were lost on the way (the twists up to there are written)"))
    r.add_argument("bag", type=bag_path, metavar="BAG", help="a rosbag2 directory or an .mcap file")
    r.add_argument("--image-topic", default="/camera/image_raw", metavar="T", help="sensor_msgs/Image topic "
                   "(default /camera/image_raw)")
    r.add_argument("--camera-info-topic", default="/camera/camera_info", metavar="T",
                   help="sensor_msgs/CameraInfo topic (default /camera/camera_info)")
    r.add_argument("--joint-states-topic", metavar="T",
                   help="sensor_msgs/JointState topic: the joints at each image go into the CSV")
    r.add_argument("--goal-image-topic", metavar="T",
                   help="an image of the goal, whose tracked points are the desired ones (default "
                        "/ibvs/goal/image_raw when the bag has it)")
    r.add_argument("--tracker", choices=["dots", "tag"], help="default: the recorded episode's")
    r.add_argument("--scheme", choices=list(SCHEMES), help="default: the recorded servo, with every option")
    r.add_argument("--gain", type=a.number(0, 1e4, open_lo=True), help="control gain, 1/s")
    r.add_argument("--depth", choices=["exact", "pose", "desired", "estimated"],
                   help="depth given to the servo (default: the recorded one, else desired)")
    r.add_argument("--depth-desired", type=a.number(0, 1e4, open_lo=True), metavar="METRES",
                   help="the goal depth of every point (default: the recorded goal depths)")
    r.add_argument("--latency", type=a.number(0, 1000, integer=True), metavar="FRAMES",
                   help="frames between capture and control (default: the recorded one, else 0)")
    r.add_argument("--initial-pixels", type=numbers(None, "pixels U1,V1,U2,V2,...", 1e5), metavar="U1,V1,...",
                   help="the dots' pixels in the first image (dot tracker; default: the recorded start)")
    r.add_argument("--desired-pixels", type=numbers(None, "pixels U1,V1,U2,V2,...", 1e5), metavar="U1,V1,...",
                   help="the goal's pixels (default: tracked in the goal image, else /ibvs/features_desired)")
    a.add_output(r, "--out", type=a.out_file(".csv"), required=True, metavar="FILE.csv",
                   help="the twists, one row per image (frame, stamp, pixels, twist, status)")
    a.add_output(r, "--bag-out", type=a.out_file(".mcap"), metavar="FILE.mcap",
                   help="a copy of the bag with the twists added on /ibvs/replay/cmd_twist")


def _pairs(xs, name: str):
    if xs is None:
        return None
    if len(xs) % 2 or len(xs) < 6:
        a.fail("ibvs replay", f"argument {name}: expected U,V pairs for at least 3 points, got {len(xs)} numbers")
    return [xs[i:i + 2] for i in range(0, len(xs), 2)]


def command(args) -> int:
    """Run `ibvs replay`; 0 when every image was replayed, 1 when the features were lost on the way."""
    prog = "ibvs replay"
    try:
        from .. import ros

        ros.types.typestore()
        from .. import vision  # noqa: F401 - the trackers need OpenCV
    except ImportError as e:
        a.fail(prog, str(e))
    if args.bag_out is not None and args.bag_out.resolve() == args.bag.resolve():
        a.fail(prog, "argument --bag-out: must not be the bag replayed")
    try:
        rep = ros.replay(args.bag, image_topic=args.image_topic, camera_info_topic=args.camera_info_topic,
                         joint_states_topic=args.joint_states_topic, goal_image_topic=args.goal_image_topic,
                         tracker=args.tracker, scheme=args.scheme, gain=args.gain, depth=args.depth,
                         depth_desired=args.depth_desired, latency=args.latency,
                         initial_pixels=_pairs(args.initial_pixels, "--initial-pixels"),
                         desired_pixels=_pairs(args.desired_pixels, "--desired-pixels"))
    except (ValueError, TypeError, FileNotFoundError) as e:
        a.fail(prog, e)
    rep.write_csv(args.out)
    ran = sum(1 for s in rep.status if s in ("ok", "singular"))
    print(f"{args.bag}: {len(rep)} images replayed, the servo ran on {ran}; last status {rep.status[-1]}")
    print(f"  twists  {args.out}")
    have = ros.topics(args.bag)
    if ros.TOPICS["twist"] in have:
        import numpy as np

        recorded = ros.recorded_twists(args.bag)
        diffs = [np.abs(recorded[s] - tw).max() for s, tw in zip(rep.stamps, rep.twist)
                 if int(s) in recorded and np.isfinite(tw).all()]
        missing = len(recorded) - len(diffs)
        if diffs:
            print(f"  recorded {ros.TOPICS['twist']}: {len(diffs)} twists compared, largest difference "
                  f"{max(diffs):.3g}" + (f"; {missing} recorded twists not replayed" if missing else ""))
    if args.bag_out is not None:
        counts = ros.write_bag(rep, args.bag, args.bag_out)
        print(f"  bag      {args.bag_out} ({sum(counts.values())} messages)")
    return 0 if rep.status and rep.status[-1] not in ("lost_feature", "left_image") else 1
