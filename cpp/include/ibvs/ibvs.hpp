// ibvs: real-time image-based visual servoing with Cartesian, polar and
// hybrid image Jacobians (Corke, Spindler, Chaumette, IROS 2009).
// Conventions are stated once, in ibvs/features.hpp.
#pragma once

#include "ibvs/angle_wrap.hpp"
#include "ibvs/camera_model.hpp"
#include "ibvs/depth_estimator.hpp"
#include "ibvs/feature.hpp"
#include "ibvs/features.hpp"
#include "ibvs/features/ellipse.hpp"
#include "ibvs/features/function.hpp"
#include "ibvs/features/line.hpp"
#include "ibvs/features/moments.hpp"
#include "ibvs/features/pose.hpp"
#include "ibvs/features/segment.hpp"
#include "ibvs/layout.hpp"
#include "ibvs/pinv.hpp"
#include "ibvs/planar_pose.hpp"
#include "ibvs/robot_mapping.hpp"
#include "ibvs/se3.hpp"
#include "ibvs/servo.hpp"
#include "ibvs/task.hpp"
#include "ibvs/version.hpp"
