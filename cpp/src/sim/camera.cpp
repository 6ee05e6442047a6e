#include "ibvs/sim/camera.hpp"

#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>

namespace ibvs::sim {

Camera Camera::normalized(double bounds, double fps) {
  Camera c;
  c.u_min = c.v_min = -bounds;
  c.u_max = c.v_max = bounds;
  c.fps = fps;
  c.validate();
  return c;
}

Camera Camera::afma6() {
  Camera c;
  c.px = 1090.6;
  c.py = 1090.0;
  c.u0 = 310.1;
  c.v0 = 260.8;
  c.kud = -0.2114;
  c.kdu = 0.2217;
  c.u_min = 0.0;
  c.u_max = 640.0;
  c.v_min = 0.0;
  c.v_max = 480.0;
  c.fps = 60.0;
  return c;
}

namespace {
void require(bool ok, const char* what) {
  if (!ok) throw std::invalid_argument(std::string("ibvs: camera ") + what);
}
}  // namespace

void Camera::validate() const {
  require(std::isfinite(px) && px > 0.0, "px must be finite and > 0");
  require(std::isfinite(py) && py > 0.0, "py must be finite and > 0");
  require(std::isfinite(u0) && std::isfinite(v0), "u0, v0 must be finite");
  require(std::isfinite(kud) && std::isfinite(kdu), "kud, kdu must be finite");
  require(std::isfinite(u_min) && std::isfinite(u_max) && u_min < u_max, "bounds need u_min < u_max");
  require(std::isfinite(v_min) && std::isfinite(v_max) && v_min < v_max, "bounds need v_min < v_max");
  require(std::isfinite(fps) && fps > 0.0, "fps must be finite and > 0");
}

std::string Camera::describe() const {
  char buf[256];
  if (px == 1.0 && py == 1.0 && u0 == 0.0 && v0 == 0.0 && kud == 0.0 && kdu == 0.0)
    std::snprintf(buf, sizeof buf, "Camera(normalized, u in [%g, %g], v in [%g, %g], fps=%g)", u_min, u_max, v_min,
                  v_max, fps);
  else
    std::snprintf(buf, sizeof buf, "Camera(px=%g, py=%g, u0=%g, v0=%g, kud=%g, kdu=%g, %gx%g, fps=%g)", px, py, u0,
                  v0, kud, kdu, u_max - u_min, v_max - v_min, fps);
  return buf;
}

}  // namespace ibvs::sim
