"""Hand-eye calibration: the camera's pose on the end effector (eye-in-hand, eMc) or in the robot's base frame
(eye-to-hand, bMc) from robot poses and target poses at a set of stations, solved by OpenCV.

    result = ibvs.calibrate_hand_eye(robot_poses, target_poses, mount="eye_in_hand", method="park")
    result.eMc, result.bMo                  # end effector <- camera; base <- target (where the target lies)
    result.rms_translation, result.rms_rotation   # how well every station agrees with the estimate (m, rad)

Data, at each station i (the robot still, the target in view):
  robot_poses[i]   bMe_i, base <- end effector: the robot's forward kinematics at its joints (4x4, metres).
  target_poses[i]  cMo_i, camera <- target: the target's pose measured in the image (PlanarPose, a tag, PnP:
                   ibvs.calibration.target_poses).

Mounts and what OpenCV is given (its names: "X2Y" is the transform taking X coordinates to Y coordinates, ibvs's
Y <- X):
  eye_in_hand  the camera on the end effector, the target fixed in the cell. Unknowns eMc and bMo, with
               bMe_i eMc cMo_i = bMo at every station: the motions A = bMe_i^-1 bMe_j and B = cMo_i cMo_j^-1 satisfy
               A X = X B, X = eMc. cv2.calibrateHandEye(R_gripper2base = bMe_i, R_target2cam = cMo_i) returns
               R_cam2gripper = eMc.
  eye_to_hand  the camera fixed in the cell, the target carried by the end effector. Unknowns bMc and eMo, with
               bMe_i^-1 bMc cMo_i = eMo: the same equation with the robot poses inverted (the classic inversion),
               so cv2.calibrateHandEye(R_gripper2base = bMe_i^-1 = eMb_i, R_target2cam = cMo_i) returns
               R_cam2gripper = bMc.
The robot-world methods solve A_i X = Z B_i for both unknowns at once (cv2.calibrateRobotWorldHandEye, which
calls the fixed frame "world"): eye_in_hand R_world2cam = cMo_i, R_base2gripper = eMb_i, giving
R_base2world = oMb (so bMo) and R_gripper2cam = cMe (so eMc); eye_to_hand R_world2cam = cMo_i^-1 = oMc_i,
R_base2gripper = eMb_i, giving R_base2world = cMb (so bMc) and R_gripper2cam = oMe (so eMo).

Methods (OpenCV's implementations):
  "tsai"        Tsai & Lenz 1989, rotation then translation (IEEE Trans. Robotics and Automation 5(3))
  "park"        Park & Martin 1994, rotation on SO(3) by least squares, then translation (IEEE TRA 10(5))
  "horaud"      Horaud & Dornaika 1995, rotation as a unit quaternion, then translation (IJRR 14(3))
  "andreff"     Andreff, Horaud & Espiau 1999, rotation and translation together, linear (3DIM 1999)
  "daniilidis"  Daniilidis 1999, rotation and translation together by dual quaternions (IJRR 18(3))
  "shah"        Shah 2013, robot-world and hand-eye, Kronecker product (J. Mechanisms and Robotics 5(3))
  "li"          Li, Wang & Wu 2010, robot-world and hand-eye, dual quaternions (Int. J. Physical Sciences 5(10))
For the hand-eye methods the other unknown (bMo, or eMo) is the mean over the stations of its value through the
estimate (bMe_i eMc cMo_i, or eMb_i bMc cMo_i); the robot-world methods estimate it themselves.

Checks (finite or refused: TypeError / ValueError naming the argument):
  - each pose a finite 4x4 rigid transform (orthonormal within 1e-6, det +1, last row 0 0 0 1, translation
    within 1e6 m); the rotations are then projected onto the nearest orthonormal ones;
  - robot_poses and target_poses the same number of stations, at least 3;
  - degenerate motions are refused: pure translations (no rotation between any two stations above
    min_rotation), and rotations all about one axis (the second principal rotation of the motions below
    min_rotation: the translation along that axis cannot be found). Two motions with rotations about
    different axes are the minimum (Tsai & Lenz); more, and larger rotations, give better estimates;
  - the rotation angle of each robot motion A must equal that of the matching camera motion B (A and B are
    conjugate): a median difference above max_rotation_mismatch is refused, naming target_poses (stations
    out of order, a target that moved, a robot pose that is not the one measured). This test cannot see a
    wrong mount or an inverted pose (the angles stay equal): those show as large residuals, which are
    reported, not refused.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from itertools import combinations

import numpy as np

from .rigid import as_pose_stack, invert, mean_pose, rotation_angle

__all__ = [
    "DEFAULT_METHOD",
    "HAND_EYE_METHODS",
    "MAX_ROTATION_MISMATCH",
    "METHODS",
    "MIN_ROTATION",
    "MOUNTS",
    "ROBOT_WORLD_METHODS",
    "HandEyeResult",
    "calibrate_hand_eye",
]

#: The mounts: the camera on the end effector, or fixed in the cell watching a target on the end effector.
MOUNTS = ("eye_in_hand", "eye_to_hand")
#: Methods of cv2.calibrateHandEye: name -> the name of its constant (cv2.CALIB_HAND_EYE_<NAME>).
HAND_EYE_METHODS = {"tsai": "CALIB_HAND_EYE_TSAI", "park": "CALIB_HAND_EYE_PARK", "horaud": "CALIB_HAND_EYE_HORAUD",
                    "andreff": "CALIB_HAND_EYE_ANDREFF", "daniilidis": "CALIB_HAND_EYE_DANIILIDIS"}
#: Methods of cv2.calibrateRobotWorldHandEye (both unknowns at once): name -> its constant's name.
ROBOT_WORLD_METHODS = {"shah": "CALIB_ROBOT_WORLD_HAND_EYE_SHAH", "li": "CALIB_ROBOT_WORLD_HAND_EYE_LI"}
#: Every method's name, the hand-eye ones first.
METHODS = tuple(HAND_EYE_METHODS) + tuple(ROBOT_WORLD_METHODS)
#: The method calibrate_hand_eye uses unless told: among the most accurate at 0.3 px of noise (docs/hand-eye.md).
DEFAULT_METHOD = "park"
#: Smallest rotation (rad) the motions must have, and about a second axis (1 degree).
MIN_ROTATION = math.radians(1.0)
#: Largest median difference (rad) between the rotation angles of matching robot and camera motions (2 degrees).
MAX_ROTATION_MISMATCH = math.radians(2.0)
#: What the estimates are, per mount: (the camera's transform, the target's transform).
_NAMES = {"eye_in_hand": ("eMc", "bMo"), "eye_to_hand": ("bMc", "eMo")}


def _opencv():
    """cv2 with its hand-eye solvers, or an ImportError saying what to install."""
    try:
        import cv2
    except ImportError as e:  # pragma: no cover - the test extra installs it
        raise ImportError('ibvs.calibrate_hand_eye needs OpenCV: pip install ".[vision]" from the ibvs repository '
                          'root') from e
    if not hasattr(cv2, "calibrateHandEye"):
        raise ImportError(f"OpenCV {cv2.__version__} has no cv2.calibrateHandEye in its Python bindings (the 5.0.0 "
                          "wheels lack it and cv2.calibrateRobotWorldHandEye: opencv/opencv issue 29565): install "
                          "opencv-contrib-python-headless>=4.7,!=5.0.0.93, e.g. 4.14 (the ibvs vision extra does)")
    return cv2


@dataclass(frozen=True)
class HandEyeResult:
    """What calibrate_hand_eye estimated, and how well the stations agree with it.

    mount, method: as given. hand_eye: (4, 4) the camera's transform: eMc (end effector <- camera) for eye_in_hand,
    bMc (base <- camera) for eye_to_hand; also as result.eMc / result.bMc. target: (4, 4) the target's transform,
    bMo (base <- target) for eye_in_hand, eMo (end effector <- target) for eye_to_hand; also result.bMo /
    result.eMo; from the solver for the robot-world methods, else the mean over the stations.
    translation_residuals (m), rotation_residuals (rad): (N,) per station, how far the target's transform through
    that station's chain (bMe_i eMc cMo_i, or bMe_i^-1 bMc cMo_i) lies from `target`: the noise of the data and
    any error of the estimate; centimetres for a wrong mount or inverted poses.
    rotation_mismatch (rad): median over station pairs of |angle(A) - angle(B)|, the robot and camera motions'
    rotation angles (equal for exact data, whatever the estimate: the data's own noise).
    motion_spread (rad): the RMS rotation of the motions about their second principal axis (0 for pure
    translations or rotations about one axis; the larger, the better conditioned).
    """

    mount: str
    method: str
    hand_eye: np.ndarray
    target: np.ndarray
    translation_residuals: np.ndarray
    rotation_residuals: np.ndarray
    rotation_mismatch: float
    motion_spread: float

    def _named(self, name: str) -> np.ndarray:
        camera_name, target_name = _NAMES[self.mount]
        if name == camera_name:
            return self.hand_eye
        if name == target_name:
            return self.target
        raise AttributeError(f"{name} is not estimated for mount={self.mount!r}: it gives {camera_name} (hand_eye) "
                             f"and {target_name} (target)")

    @property
    def eMc(self) -> np.ndarray:
        """End effector <- camera (eye_in_hand only; AttributeError otherwise)."""
        return self._named("eMc")

    @property
    def bMo(self) -> np.ndarray:
        """Base <- target (eye_in_hand only)."""
        return self._named("bMo")

    @property
    def bMc(self) -> np.ndarray:
        """Base <- camera (eye_to_hand only)."""
        return self._named("bMc")

    @property
    def eMo(self) -> np.ndarray:
        """End effector <- target (eye_to_hand only)."""
        return self._named("eMo")

    @property
    def stations(self) -> int:
        """The number of stations."""
        return len(self.translation_residuals)

    @property
    def rms_translation(self) -> float:
        """RMS of translation_residuals (m)."""
        return float(np.sqrt(np.mean(self.translation_residuals ** 2)))

    @property
    def rms_rotation(self) -> float:
        """RMS of rotation_residuals (rad)."""
        return float(np.sqrt(np.mean(self.rotation_residuals ** 2)))

    def __str__(self) -> str:
        camera_name, _ = _NAMES[self.mount]
        t = 1e3 * self.hand_eye[:3, 3]
        return (f"{self.mount} ({self.method}, {self.stations} stations): {camera_name} t = ({t[0]:.2f}, {t[1]:.2f}, "
                f"{t[2]:.2f}) mm, rotation {math.degrees(rotation_angle(self.hand_eye[:3, :3])):.3f} deg; residuals "
                f"RMS {1e3 * self.rms_translation:.3f} mm, {math.degrees(self.rms_rotation):.4f} deg")


def _check_name(x, name: str, allowed) -> str:
    if not isinstance(x, str):
        raise TypeError(f"{name} must be a str, one of {', '.join(allowed)}; got {type(x).__name__}")
    if x.lower() not in allowed:
        raise ValueError(f"{name} must be one of {', '.join(allowed)}, got {x!r}")
    return x.lower()


def _check_angle(x, name: str) -> float:
    if isinstance(x, bool) or not isinstance(x, (int, float, np.integer, np.floating)):
        raise TypeError(f"{name} must be a real number (radians), got {type(x).__name__}")
    if not (0.0 <= x <= math.pi):
        raise ValueError(f"{name} must be in [0, pi] radians, got {x!r}")
    return float(x)


def _motions(P: np.ndarray, C: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rotations of the robot motions A_ij = P_i^-1 P_j and camera motions B_ij = C_i C_j^-1 over all pairs i < j
    (A X = X B)."""
    i, j = np.array(list(combinations(range(len(P)), 2))).T
    RA = np.einsum("kji,kjl->kil", P[i, :3, :3], P[j, :3, :3])
    RB = np.einsum("kij,klj->kil", C[i, :3, :3], C[j, :3, :3])
    return RA, RB


def _rotation_vectors(R: np.ndarray) -> np.ndarray:
    """Axis times angle (rad) of each rotation (K, 3, 3): (K, 3). The axis from the antisymmetric part; near a half
    turn (where that vanishes) from the largest column of R + I."""
    w = np.stack([R[:, 2, 1] - R[:, 1, 2], R[:, 0, 2] - R[:, 2, 0], R[:, 1, 0] - R[:, 0, 1]], -1)
    angle = rotation_angle(R)
    s = np.linalg.norm(w, axis=1)
    out = np.where(s[:, None] > 1e-9, w / np.maximum(s, 1e-300)[:, None], 0.0) * angle[:, None]
    for k in np.nonzero((s <= 1e-9) & (angle > 1.0))[0]:  # half turns
        B = (R[k] + np.eye(3)) / 2
        c = int(np.argmax(np.diag(B)))
        out[k] = B[:, c] / math.sqrt(max(B[c, c], 1e-300)) * angle[k]
    return out


def calibrate_hand_eye(robot_poses, target_poses, mount: str = "eye_in_hand", method: str = DEFAULT_METHOD, *,
                       min_rotation: float = MIN_ROTATION,
                       max_rotation_mismatch: float = MAX_ROTATION_MISMATCH) -> HandEyeResult:
    """Estimate the hand-eye transform from N >= 3 stations: a HandEyeResult.

    robot_poses: (N, 4, 4) bMe_i, base <- end effector, the robot's forward kinematics at station i (as measured:
        do not invert them for eye_to_hand, this function does).
    target_poses: (N, 4, 4) cMo_i, camera <- target, the target's pose in the camera at station i (PlanarPose, a
        tag: ibvs.calibration.target_poses).
    mount: "eye_in_hand" (the camera on the end effector, the target fixed: estimates eMc and bMo) or
        "eye_to_hand" (the camera fixed, the target on the end effector: estimates bMc and eMo).
    method: one of METHODS, any case: "tsai", "park", "horaud", "andreff", "daniilidis" (cv2.calibrateHandEye),
        "shah", "li" (cv2.calibrateRobotWorldHandEye).
    min_rotation (rad, default 1 deg): the motions must rotate by more than this, and by more than this about a
        second axis; else refused as degenerate. max_rotation_mismatch (rad, default 2 deg): refused when the
        median difference of rotation angle between the robot's and the camera's motions exceeds it.

    Conventions, OpenCV's arguments, the methods and every check: ibvs.calibration.hand_eye's docstring. Needs
    OpenCV (the vision extra), imported on the first call.
    """
    mount = _check_name(mount, "mount", MOUNTS)
    method = _check_name(method, "method", METHODS)
    min_rotation = _check_angle(min_rotation, "min_rotation")
    max_rotation_mismatch = _check_angle(max_rotation_mismatch, "max_rotation_mismatch")
    bMe = as_pose_stack(robot_poses, "robot_poses", min_count=3)
    cMo = as_pose_stack(target_poses, "target_poses", min_count=3)
    if len(bMe) != len(cMo):
        raise ValueError(f"robot_poses and target_poses must have one pose per station each, got {len(bMe)} and "
                         f"{len(cMo)}")
    # The robot side of A X = X B: bMe_i (eye in hand), or the classic inversion eMb_i = bMe_i^-1 (eye to hand).
    P = bMe if mount == "eye_in_hand" else invert(bMe)
    RA, RB = _motions(P, cMo)
    angles_a = rotation_angle(RA)
    if not (angles_a > min_rotation).any():  # NaN angles count as no rotation
        raise ValueError(f"robot_poses: the motions are pure translations (no two stations differ in rotation by "
                         f"more than {math.degrees(angles_a.max()):.3g} deg, min_rotation is "
                         f"{math.degrees(min_rotation):.3g} deg): the hand-eye rotation cannot be found")
    spread = float(np.linalg.svd(_rotation_vectors(RA), compute_uv=False)[1] / math.sqrt(len(RA)))
    if spread <= min_rotation:
        raise ValueError(f"robot_poses: the motions all rotate about one axis (RMS rotation about a second axis "
                         f"{math.degrees(spread):.3g} deg, min_rotation is {math.degrees(min_rotation):.3g} deg): the "
                         f"translation along that axis cannot be found; rotate about at least two axes")
    mismatch = float(np.median(np.abs(angles_a - rotation_angle(RB))))
    if mismatch > max_rotation_mismatch:
        raise ValueError(f"target_poses: the camera's motions rotate by other angles than the robot's (median "
                         f"difference {math.degrees(mismatch):.3g} deg, max_rotation_mismatch is "
                         f"{math.degrees(max_rotation_mismatch):.3g} deg): are the stations paired in order, the "
                         f"target still, robot_poses base <- end effector and target_poses camera <- target?")
    cv2 = _opencv()
    as_lists = (lambda T: ([R for R in T[:, :3, :3]], [t.reshape(3, 1) for t in T[:, :3, 3]]))
    if method in HAND_EYE_METHODS:
        R, t = cv2.calibrateHandEye(*as_lists(P), *as_lists(cMo), method=getattr(cv2, HAND_EYE_METHODS[method]))
        X = _pose(R, t, method)
        target = mean_pose(np.einsum("kij,jl,klm->kim", P, X, cMo))
    else:
        # A_i X = Z B_i with OpenCV's names: world2cam_i base2world = gripper2cam base2gripper_i.
        world2cam = cMo if mount == "eye_in_hand" else invert(cMo)
        Rw, tw, Rg, tg = cv2.calibrateRobotWorldHandEye(*as_lists(world2cam), *as_lists(invert(bMe)),
                                                        method=getattr(cv2, ROBOT_WORLD_METHODS[method]))
        base2world, gripper2cam = invert(_pose(Rw, tw, method)), invert(_pose(Rg, tg, method))
        # eye in hand: world = the target, so (eMc, bMo); eye to hand: world = the camera, "cam" = the target.
        X, target = (gripper2cam, base2world) if mount == "eye_in_hand" else (base2world, gripper2cam)
    through = np.einsum("kij,jl,klm->kim", P, X, cMo)  # the target's transform through each station's chain
    dt = np.linalg.norm(through[:, :3, 3] - target[:3, 3], axis=1)
    dr = rotation_angle(np.einsum("ji,kjl->kil", target[:3, :3], through[:, :3, :3]))
    return HandEyeResult(mount, method, X, target, dt, dr, mismatch, spread)


def _pose(R, t, method: str) -> np.ndarray:
    """OpenCV's (R, t) as a rigid 4x4 (R projected onto the nearest rotation), or a ValueError if not finite."""
    R, t = np.asarray(R, dtype=float), np.asarray(t, dtype=float).ravel()
    if R.shape != (3, 3) or t.shape != (3,) or not (np.isfinite(R).all() and np.isfinite(t).all()):
        raise ValueError(f"method: OpenCV's {method!r} solver returned no finite solution for these poses (degenerate "
                         f"motions?)")
    U, _, Vt = np.linalg.svd(R)
    T = np.eye(4)
    T[:3, :3] = U @ np.diag([1.0, 1.0, np.sign(np.linalg.det(U @ Vt))]) @ Vt
    T[:3, 3] = t
    return T
