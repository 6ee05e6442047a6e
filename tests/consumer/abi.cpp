// What a consumer does with the library's value types, built with its own flags
// (CI: AddressSanitizer + UndefinedBehaviorSanitizer against a library built
// without them): construct, copy, move, assign and destroy every type that
// owns library-allocated buffers, and run a step. Eigen allocates differently
// under ASan (no glibc-aligned malloc), so a buffer allocated by the library and
// freed by an inline destructor here would crash; the library defines those
// special members itself.
#include <ibvs/ibvs.hpp>
#include <ibvs/sim/sim.hpp>

#include <cmath>
#include <cstdio>
#include <utility>
#include <vector>

int main() {
  ibvs::Layout layout = ibvs::Layout::stacked(4);
  ibvs::Layout copy = layout;
  ibvs::Layout moved = std::move(copy);
  copy = moved;
  layout = std::move(moved);
  ibvs::Servo servo(layout, {/*gain*/ 0.5});
  ibvs::ServoInput in(layout);
  in.uv_desired << 0.1, -0.1, -0.1, 0.1, 0.1, 0.1, -0.1, -0.1;
  in.uv << 0.16, -0.05, -0.16, 0.05, 0.05, 0.16, -0.05, -0.16;
  in.depth.setConstant(0.6);
  ibvs::ServoInput in2 = in;
  in2 = in;
  ibvs::ServoInput in3 = std::move(in2);
  std::vector<ibvs::ServoOutput> outs;
  for (int k = 0; k < 4; ++k) outs.emplace_back(layout);  // reallocation moves them
  const ibvs::Status status = servo.update(in3, outs[0]);
  ibvs::ServoOutput out = outs[0];
  outs[1] = out;
  outs[2] = std::move(out);
  ibvs::Servo other = std::move(servo);
  other.update(in, outs[3]);
  // The simulator's value types too: a target, an episode and its result (history arrays).
  ibvs::sim::Target target = ibvs::sim::Target::paper();
  ibvs::sim::Target target2 = target;
  ibvs::sim::EpisodeOptions eo;
  eo.duration = 1.0;
  ibvs::sim::Episode episode(ibvs::Servo(ibvs::Layout::cartesian(4), {1.0}), ibvs::sim::Camera::normalized(0.3),
                             std::move(target2), eo);
  ibvs::Pose start = ibvs::Pose::Identity();
  start(0, 3) = 0.05;
  ibvs::sim::EpisodeResult result = episode.run(start, ibvs::Pose::Identity());
  ibvs::sim::EpisodeResult result2 = std::move(result);
  ibvs::sim::Episode episode2 = std::move(episode);
  // The joint-space mapping and secondary task (their SVD's workspace is library-allocated): copied, assigned
  // across joint counts, moved (a move copies: the source stays usable) and run on the SVD route (n = 5 < 6).
  ibvs::JointMapping mapping(5, ibvs::Pose::Identity());
  ibvs::JointMapping mapping7(7, ibvs::Pose::Identity());
  ibvs::JointMapping mapping2 = mapping7;
  mapping2 = mapping;
  ibvs::JointMapping mapping3 = std::move(mapping);
  ibvs::JointMappingInput jin(5);
  ibvs::JointMappingOutput jout(5), jout2(5);
  jin.jacobian.setIdentity();  // rows 0-4 of the identity: rank 5 = min(6, n), wz out of reach
  jin.twist << 0.1, 0.0, 0.0, 0.0, 0.0, 0.2;
  ibvs::SecondaryTask task(5);
  ibvs::SecondaryTask task2 = ibvs::SecondaryTask(7);
  task2 = task;
  ibvs::SecondaryTask task3 = std::move(task);
  bool joints_ok = mapping2.update(jin, jout) == ibvs::Status::ok && std::abs(jout.qdot(0) - 0.1) < 1e-12 &&
                   mapping.update(jin, jout2) == ibvs::Status::ok && jout2.qdot == jout.qdot &&
                   mapping3.update(jin, jout2) == ibvs::Status::ok && jout2.qdot == jout.qdot;
  ibvs::SecondaryTaskInput sin(5);
  ibvs::SecondaryTaskOutput sout(5), sout2(5);
  sin.camera_jacobian = jout.camera_jacobian;
  sin.qdot = jout.qdot;
  sin.q.setZero(5);
  sin.qdot_previous.setZero(5);
  sin.joints.setConstant(5, 0.01);
  joints_ok = joints_ok && task2.update(sin, sout) == ibvs::Status::ok && task.update(sin, sout2) == ibvs::Status::ok &&
              sout2.qdot == sout.qdot && task3.update(sin, sout2) == ibvs::Status::ok && sout2.qdot == sout.qdot;
  std::printf("status %d sigma_min %.6g condition %.6g velocity %.6g; episode: %d frames\n", static_cast<int>(status),
              outs[2].sigma_min(), outs[2].condition(), outs[3].velocity.norm(), result2.history.frames);
  const bool servo_ok = status == ibvs::Status::ok && outs[3].velocity == outs[2].velocity;
  return servo_ok && result2.history.frames > 0 && joints_ok ? 0 : 1;
}
