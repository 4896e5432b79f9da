#pragma once
// Deterministic sample messages shared by the conversion tests and the transport rostest.
#include <drill_pipe_pose/LegacySensorFrame.h>
#include <drill_pipe_pose/SensorFrame.h>

#include <vector>

namespace drill_pipe_pose_test {

/// A Kinect-v2-like SensorFrame for camera `camera`: QHD colour info, SD depth info with a cropped
/// roi (depth encoding `encoding`), pseudo-random depth from `seed`, two boxes.
drill_pipe_pose::SensorFrame sampleSensorFrame(const std::string& camera, unsigned seed,
                                               const std::string& encoding = "16UC1");

/// `frame` as the definition before the amplitude field sent it (its amplitude dropped): what an
/// older bag or sensor node holds.
drill_pipe_pose::LegacySensorFrame legacyOf(const drill_pipe_pose::SensorFrame& frame);

/// Serialised bytes of a message (for exact comparison after transport).
std::vector<uint8_t> serialize(const drill_pipe_pose::SensorFrame& msg);

}  // namespace drill_pipe_pose_test
