#include <ibvs/ibvs.hpp>
#include <cstdio>

int main() {
  const ibvs::Layout layout = ibvs::Layout::stacked(4);  // (u, v, r, theta) per point: 16x6
  ibvs::Servo servo(layout, {/*gain*/ 0.5, /*damping*/ 0.01});
  ibvs::ServoInput in(layout);  // sized once; update() never allocates
  ibvs::ServoOutput out(layout);
  in.uv_desired << 0.1, -0.1, -0.1, 0.1,  /* u of points 0..3 */ 0.1, 0.1, -0.1, -0.1;  // v
  in.uv << 0.16, -0.05, -0.16, 0.05,  /* u */ 0.05, 0.16, -0.05, -0.16;                  // v
  in.depth.setConstant(0.6);  // metres
  const ibvs::Status status = servo.update(in, out);
  std::printf("status %d velocity", static_cast<int>(status));
  for (double x : out.velocity) std::printf(" %.17g", x);  // Tx Ty Tz (m/s) wx wy wz (rad/s)
  std::printf("\n");
}
