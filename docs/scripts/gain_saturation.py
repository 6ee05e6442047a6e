"""Constant gain against the adaptive gain and twist saturation (docs/beyond.md section 6).

The free-flying paper cases (z-rotation pi, general motion), four schemes, exact depth, 60 Hz, 30 s,
tolerance 1e-5. python docs/scripts/gain_saturation.py prints the table (about a second of CPU).
"""
import numpy as np

import ibvs
from ibvs import sim
from ibvs.study import schemes

SETTINGS = {"gain 1": dict(gain=1.0),
            "adaptive 4 → 0.4": dict(gain=ibvs.AdaptiveGain(at_zero=4.0, at_infinity=0.4, slope_at_zero=30.0)),
            "gain 1, ≤ 0.5 m/s, ≤ 1 rad/s": dict(gain=1.0, max_linear_speed=0.5, max_angular_speed=1.0)}


def main() -> None:
    print("| case | scheme | setting | outcome | time (s) | peak ‖T‖ (m/s) | peak ‖ω‖ (rad/s) | retreat (m) "
          "| path (m) |")
    print("|---|---|---|---|---:|---:|---:|---:|---:|")
    for case in (sim.cases.z_rotation(), sim.cases.general_motion()):
        for scheme in ("cartesian", "polar", "hybrid", "stacked"):
            for label, kw in SETTINGS.items():
                servo = ibvs.Servo(schemes.make(scheme, 1.0).layout, **kw)
                r = sim.run(servo, case.camera, case.target, case.start, case.goal, duration=30.0, tolerance=1e-5)
                v = r.history.twist[np.isfinite(r.history.twist).all(1)]
                print(f"| {case.name} | {scheme} | {label} | {r.status.outcome} | {r.status.frame / 60:.1f} | "
                      f"{np.linalg.norm(v[:, :3], axis=1).max():.3g} | {np.linalg.norm(v[:, 3:], axis=1).max():.3g} | "
                      f"{r.metrics.camera_retreat:.2f} | {r.metrics.path_length:.2f} |")


if __name__ == "__main__":
    main()
