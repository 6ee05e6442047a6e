"""Replay a bag through a tracker and the servo, offline: ibvs.ros.replay(bag, ...), `ibvs replay BAG`.

For every image of the image topic, in order: the tracker (dots or tag) finds the points, the camera
model of the camera_info topic normalises them, a depth is given (see `depth`), and the servo computes
the twist it would have commanded. Nothing moves: the camera's motion is the one recorded.

What replay needs and where it finds it: the goal (desired pixels: `desired_pixels`, else the goal
image of /ibvs/goal/image_raw tracked as the simulator tracked it, else /ibvs/features_desired), the
dot tracker's starting pixels (`initial_pixels`, else /ibvs/config's), the servo (`scheme` and
`gain`, else /ibvs/config's servo with every option), the depth mode, the latency and the goal depths
(arguments, else /ibvs/config). A bag recorded by ibvs (sim.run(record=...)) holds all of them in
/ibvs/config, so that replaying it gives the recorded twists (tests/python/test_ros_replay.py: to
1e-9; they agree to the last bit here). A bag from a real robot needs the arguments.

Depth modes: "desired" (the constant goal depths: depth_desired), "pose" (ibvs.PlanarPose of the
tracked points; needs the target's points), "exact" (the true depths from /tf: world <- camera and
world <- target, and the target's points: a simulated bag) and "estimated" (ibvs.DepthEstimator fed
with the camera's motion between frames from /tf, as a robot's odometry would give it). The
simulator's image-boundary potential (boundary_margin > 0) is not replayed: such a bag is refused.
"""

from __future__ import annotations

import csv
from contextlib import closing
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Dict, List, Optional

import numpy as np

from .._core import DepthEstimator, PlanarPose
from . import config as cfg
from . import types as t
from .bag import BagWriter, copy, messages, topics
from .cameras import camera_model
from .images import gray8
from .joints import array_of, joint_positions
from .recorder import CAMERA, TARGET, TOPICS, WORLD
from .tf import transforms
from .twist import twist_msg

# What ibvs.ros re-exports (and documents); the other names here are its own helpers.
__all__ = ["DEPTH_MODES", "REPLAY_TWIST_TOPIC", "Replay", "replay", "recorded_twists"]

#: The depth modes replay knows (see the module docstring).
DEPTH_MODES = ("exact", "pose", "desired", "estimated")
#: The topic replay adds to the bag it writes (bag_out): what it would have commanded.
REPLAY_TWIST_TOPIC = "/ibvs/replay/cmd_twist"


@dataclass
class Replay:
    """What replay() computed: per image (K of them) its stamp (ns), the tracked pixels (K, N, 2), the
    twist (K, 6; NaN where the servo did not run) and the servo's status ("ok", "singular",
    "invalid_input", or why it did not run: "lost_feature" ends the replay, as it ends an episode);
    the desired pixels (N, 2) and the joint positions at each image (K, n) from joint_states_topic
    (None without one)."""

    stamps: np.ndarray
    pixels: np.ndarray
    twist: np.ndarray
    status: List[str]
    desired: np.ndarray
    joints: Optional[np.ndarray] = None
    config: Dict[str, Any] = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.stamps)

    def write_csv(self, path) -> None:
        """frame, stamp_ns, time_s, u0, v0, ..., Tx, Ty, Tz, wx, wy, wz, status (and q1.. with joints);
        floats written with repr (they read back exactly)."""
        n = self.pixels.shape[1]
        head = ["frame", "stamp_ns", "time_s"] + [f"{a}{i}" for i in range(n) for a in "uv"] + \
            ["Tx", "Ty", "Tz", "wx", "wy", "wz", "status"]
        if self.joints is not None:
            head += [f"q{j + 1}" for j in range(self.joints.shape[1])]
        with open(path, "w", newline="") as f:
            w = csv.writer(f)
            w.writerow(head)
            for k in range(len(self)):
                row = [k, int(self.stamps[k]), repr(int(self.stamps[k]) / t.NS)] + \
                    [repr(float(x)) for x in self.pixels[k].reshape(-1)] + \
                    [repr(float(x)) for x in self.twist[k]] + [self.status[k]]
                if self.joints is not None:
                    row += [repr(float(x)) for x in self.joints[k]]
                w.writerow(row)


def _pixels(x, n: int, name: str) -> np.ndarray:
    p = np.asarray(x, dtype=np.float64)
    if p.shape != (n, 2) or not np.isfinite(p).all():
        raise ValueError(f"{name} must be {n} finite pixels, shape ({n}, 2), got shape {p.shape}")
    return p


def _tracker(kind: str, n: int, size, vision: Optional[dict]):
    from .. import vision as v

    spec = vision if vision and vision.get("kind") == kind else {}
    if kind == "dots":
        return v.DotTracker(n, size, threshold=spec.get("threshold"), gate=spec.get("gate", 10.0),
                            min_area=spec.get("min_area", 4))
    if kind == "tag":
        ids = tuple(spec.get("ids", range(max(n // 4, 1))))
        if 4 * len(ids) != n:
            raise ValueError(f"tracker: a tag detector finds 4 corners per tag; {n} points need {n // 4} tags")
        return v.TagDetector(ids, spec.get("dictionary", "apriltag_36h11"), refine=spec.get("refine", True),
                             image_size=size, decimate=spec.get("decimate", 2))
    raise ValueError(f"tracker must be 'dots' or 'tag', got {kind!r}")


def _servo(config: dict, scheme, gain, n: int):
    if scheme is None:
        if not config.get("servo"):
            raise ValueError("scheme: the bag has no /ibvs/config servo; give a scheme (e.g. polar) and a gain")
        servo = cfg.servo_from_spec(config["servo"])
        if gain is not None:
            servo.gain = float(gain)
        return servo
    from ..study import schemes

    if isinstance(scheme, str) and scheme not in schemes.SCHEMES:
        raise ValueError(f"scheme: {scheme!r} is not one of {sorted(schemes.SCHEMES)}")
    return schemes.make(scheme, 1.0 if gain is None else float(gain), n)


def replay(bag, image_topic: str = TOPICS["image"], camera_info_topic: str = TOPICS["camera_info"],
           joint_states_topic: Optional[str] = None, tracker: Optional[str] = None, scheme=None,
           gain: Optional[float] = None, depth: Optional[str] = None, depth_desired=None, latency: Optional[int] = None,
           initial_pixels=None, desired_pixels=None, goal_image_topic: Optional[str] = None,
           target_points=None, fps: Optional[float] = None, joint_names=None) -> Replay:
    """Run a tracker and the servo over a bag's images (see the module docstring); returns a Replay.

    tracker: "dots" or "tag" (default: the recorded episode's). scheme, gain: a scheme of
    ibvs.study.schemes (default: the recorded servo). depth: one of DEPTH_MODES (default: the
    recorded one, else "desired"); depth_desired: goal depths (N,) or one for all, metres;
    latency: frames between capture and control (default: the recorded one, else 0);
    initial_pixels (N, 2): the dot tracker's start at the first image; desired_pixels (N, 2): the goal;
    target_points (N, 3): the planar target's points (depth "pose", "exact"); fps: the camera's rate
    (default the recorded one, else 60; the servo does not use it); joint_names: the joints to read
    from joint_states_topic (default: the message's)."""
    have = topics(bag)
    for name, topic in (("image_topic", image_topic), ("camera_info_topic", camera_info_topic),
                        ("joint_states_topic", joint_states_topic), ("goal_image_topic", goal_image_topic)):
        if topic is not None and topic not in have:
            raise ValueError(f"{name}: bag {str(bag)!r} has no topic {topic!r} (its topics: {', '.join(sorted(have))})")
    config: Dict[str, Any] = {}
    if TOPICS["config"] in have:
        for _, _, msg in messages(bag, [TOPICS["config"]]):
            config = cfg.loads(t.text(msg, "data", TOPICS["config"]))
    options = config.get("options") or {}
    if float(options.get("boundary_margin") or 0) > 0 and float(options.get("boundary_gain") or 0) > 0:
        raise ValueError("bag: recorded with the image-boundary potential (boundary_margin > 0), which replay does "
                         "not add to the servo's twist")
    fps = t.real(fps if fps is not None else config.get("fps", 60.0), "fps")
    vision = config.get("vision")
    kind = tracker or (vision or {}).get("kind")
    if kind is None:
        raise ValueError("tracker: give 'dots' or 'tag' (the bag has no recorded image sensor)")
    mode = depth or options.get("depth") or "desired"
    if mode not in DEPTH_MODES:
        raise ValueError(f"depth must be one of {DEPTH_MODES}, got {mode!r}")
    L = int(options.get("latency", 0) if latency is None else latency)
    if L < 0:
        raise ValueError(f"latency must be >= 0 frames, got {L}")
    scale = float(options.get("depth_scale", 1.0))

    # The camera, from the first camera_info; the images and the poses, by stamp.
    camera = None
    for _, _, msg in messages(bag, [camera_info_topic]):
        camera = camera_model(msg, fps)
        break
    if camera is None:
        raise ValueError(f"camera_info_topic: {camera_info_topic!r} has no message")
    size = (int(camera.width), int(camera.height))
    needs_tf = mode in ("exact", "estimated")
    if needs_tf and TOPICS["tf"] not in have:
        raise ValueError(f"depth: {mode} needs the camera's poses on {TOPICS['tf']}, which the bag lacks")
    goal_topic = goal_image_topic or (TOPICS["goal_image"] if TOPICS["goal_image"] in have else None)
    # The poses first (small); the images are then streamed, one in memory at a time.
    poses = {}
    if needs_tf:
        for _, ns, msg in messages(bag, [TOPICS["tf"]]):
            tf = transforms(msg)
            if (WORLD, CAMERA) in tf:
                poses[ns] = (tf[(WORLD, CAMERA)], tf.get((WORLD, TARGET)))
    count = have[image_topic][1]
    if count == 0:
        raise ValueError(f"image_topic: {image_topic!r} has no message")
    n = len(config["uv_desired"]) if config.get("uv_desired") else None
    if n is None:
        for x in (desired_pixels, initial_pixels, target_points):
            if x is not None:
                n = len(np.asarray(x))
                break
    if n is None:
        raise ValueError("desired_pixels: the bag has no /ibvs/config; give the goal's pixels (N, 2)")
    track = _tracker(kind, n, size, vision)
    resets = (vision or {}).get("resets") or []

    # The goal: given, or tracked in the goal image, or as recorded.
    if desired_pixels is not None:
        desired = _pixels(desired_pixels, n, "desired_pixels")
    elif goal_topic is not None:
        goal_msg = next(m for _, _, m in messages(bag, [goal_topic]))
        if kind == "dots":
            if not resets or resets[0] is None:
                raise ValueError("desired_pixels: the dot tracker needs a start in the goal image; give the goal's "
                                 "pixels")
            track.reset(cfg.unarray(resets[0]))
        desired = track.track(gray8(goal_msg)).pixels
        if not np.isfinite(desired).all():
            raise ValueError(f"{goal_topic}: the {kind} tracker does not find every point in the goal image")
    elif TOPICS["features_desired"] in have:
        desired = _pixels(array_of(next(m for _, _, m in messages(bag, [TOPICS["features_desired"]]))), n,
                          TOPICS["features_desired"])
    else:
        raise ValueError("desired_pixels: give the goal's pixels (the bag has no goal image nor desired features)")
    uv_desired = camera.normalize(desired)
    if depth_desired is not None:
        z_desired = np.broadcast_to(np.asarray(depth_desired, dtype=np.float64), (n,)).copy()
    elif config.get("depth_desired"):
        z_desired = cfg.unarray(config["depth_desired"])
    elif mode in ("desired", "estimated"):
        raise ValueError(f"depth_desired: depth {mode!r} needs the goal depths (the bag has no /ibvs/config)")
    else:
        z_desired = np.full(n, np.nan)
    if not (np.isfinite(z_desired).all() and (z_desired > 0).all()) and mode in ("desired", "estimated"):
        raise ValueError(f"depth_desired must be finite and > 0, got {z_desired}")
    points = None
    if target_points is not None:
        points = np.asarray(target_points, dtype=np.float64)
    elif config.get("target"):
        points = cfg.unarray(config["target"]["points"])
    if mode in ("pose", "exact") and (points is None or points.shape != (n, 3)):
        raise ValueError(f"target_points: depth {mode!r} needs the target's {n} points (N, 3)")
    planar = PlanarPose(points) if mode == "pose" else None
    estimator = None
    if mode == "estimated":
        noise = float(options.get("noise", 0.0))
        estimator = DepthEstimator(scale * z_desired, point_noise=min(noise / min(camera.px, camera.py), 10.0),
                                   min_depth=float(options.get("min_depth", 1e-3)))
    servo = _servo(config, scheme, gain, n)
    if kind == "dots":
        if initial_pixels is not None:
            start = _pixels(initial_pixels, n, "initial_pixels")
        elif len(resets) > 1 and resets[1] is not None:
            start = cfg.unarray(resets[1])
        else:
            raise ValueError("initial_pixels: the dot tracker needs the dots' pixels in the first image")
        track.reset(start)

    K = count
    pixels = np.full((K, n, 2), np.nan)
    twist = np.full((K, 6), np.nan)
    status = [""] * K
    stamps: List[int] = []
    camera_pose: list = []
    joints_at: list = []
    last_joints = None
    z = np.full(n, np.nan)
    have_pose, last_depths = False, None
    stream = messages(bag, [image_topic] + [x for x in (joint_states_topic,) if x])
    k = -1
    with closing(stream):
        for topic, _, msg in stream:
            if topic != image_topic:
                last_joints = joint_positions(msg, joint_names)
                continue
            k += 1
            stamps.append(t.stamp_ns(msg, image_topic))
            camera_pose.append(poses.get(stamps[-1]))
            joints_at.append(last_joints)
            pixels[k] = track.track(gray8(msg)).pixels
            if not np.isfinite(pixels[k]).all():
                status[k] = "lost_feature"
                break
            s = k - L if k >= L else 0
            uv = camera.normalize(pixels[s], invalid="nan")
            if not np.isfinite(uv).all():
                status[k] = "left_image"
                break
            if mode == "desired":
                z = z_desired * scale
            elif mode == "exact":
                if camera_pose[s] is None or camera_pose[s][1] is None:
                    raise ValueError(f"/tf: no world <- camera and world <- target transforms at image {s}")
                T_wc, T_wt = camera_pose[s]
                world = points @ T_wt[:3, :3].T + T_wt[:3, 3]
                z = ((world - T_wc[:3, 3]) @ T_wc[:3, :3])[:, 2] * scale
            elif mode == "pose":
                try:  # its depths are computed as the simulator's (the same C++ expression)
                    _, depths, degenerate = planar.estimate(uv)
                except ValueError:
                    degenerate = True
                if not degenerate:
                    have_pose, last_depths = True, depths
                z = last_depths * scale if have_pose else np.full(n, np.nan)
            else:
                if k == 0:
                    estimator.reset()
                    estimator.update(uv, np.eye(4))
                elif k > L:
                    a, b = camera_pose[k - L - 1], camera_pose[k - L]
                    if a is None or b is None:
                        raise ValueError(f"/tf: no world <- camera transform at images {k - L - 1} and {k - L}")
                    M = np.eye(4)
                    M[:3, :3] = a[0][:3, :3].T @ b[0][:3, :3]
                    M[:3, 3] = a[0][:3, :3].T @ (b[0][:3, 3] - a[0][:3, 3])
                    estimator.update(uv, M)
                z = estimator.depth
            r = servo.update(uv, z, uv_desired, z_desired)
            status[k] = str(r.status).split(".")[-1]
            if status[k] != "invalid_input":
                twist[k] = r.velocity
    K = k + 1
    js = None
    if joint_states_topic is not None:
        if any(j is None for j in joints_at[:K]):
            raise ValueError(f"joint_states_topic: {joint_states_topic!r} has no message before image 0")
        js = np.array(joints_at[:K])
    return Replay(np.array(stamps[:K], dtype=np.int64), pixels[:K], twist[:K], status[:K], desired, js, config)


def write_bag(replayed: Replay, bag_in, bag_out) -> Dict[str, int]:
    """A copy of bag_in with the replay's twists added on REPLAY_TWIST_TOPIC (TwistStamped, camera frame,
    stamped as their images), written atomically at bag_out (.mcap: one file)."""
    ts = t.typestore()
    twists = {int(s): tw for s, tw in zip(replayed.stamps, replayed.twist) if np.isfinite(tw).all()}
    if Path(bag_out).resolve() == Path(bag_in).resolve():
        raise ValueError("bag_out: must not be the bag replayed")
    with BagWriter(bag_out, ts) as out:
        copy(bag_in, out)
        for s, tw in sorted(twists.items()):
            out.write(REPLAY_TWIST_TOPIC, twist_msg(tw, ts, CAMERA, s), s)
        return dict(out.counts)


def recorded_twists(bag, topic: str = TOPICS["twist"]) -> Dict[int, np.ndarray]:
    """{stamp ns: (6,) twist} of a bag's TwistStamped topic (what an episode commanded)."""
    from .twist import twist_of

    return {t.stamp_ns(m, topic): twist_of(m) for _, _, m in messages(bag, [topic])}


