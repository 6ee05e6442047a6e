// ibvs::sim: closed-loop simulation of the servo on a free-flying camera or
// an Afma6-like gantry with a calibrated, distorted 60 Hz camera.
#pragma once

#include "ibvs/camera_model.hpp"
#include "ibvs/sim/episode.hpp"
#include "ibvs/sim/gantry.hpp"
#include "ibvs/sim/sensor.hpp"
#include "ibvs/sim/target.hpp"
