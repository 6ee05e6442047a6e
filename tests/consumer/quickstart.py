import numpy as np
import ibvs

layout = ibvs.Layout.stacked(4)  # (u, v, r, theta) per point: 16x6
servo = ibvs.Servo(layout, gain=0.5, damping=0.01)
uv_desired = np.array([[0.1, 0.1], [-0.1, 0.1], [-0.1, -0.1], [0.1, -0.1]])  # (N, 2), normalised
uv = np.array([[0.16, 0.05], [-0.05, 0.16], [-0.16, -0.05], [0.05, -0.16]])  # rotated, closer
result = servo.update(uv, depth=0.6, uv_desired=uv_desired)  # depth in metres
print(f"status {int(result.status)} velocity", " ".join(f"{x:.17g}" for x in result.velocity))
