// Writes the generated seed inputs of the fuzz harnesses into test/fuzz/corpus/ (the YAML
// harnesses' seeds are the real files of config/, linked there instead):
//  - sensor_frame/: SensorFrames as the simulator renders them for the thesis lab (cropped and
//    full depth, one to three cameras with their real transforms, 16UC1 and 32FC1), plus the
//    conversion tests' sample frame: inputs that go all the way through the estimator;
//  - estimator_yaml/all_keys.yaml: every parameter of the node's table with its default, nested
//    as in config/estimator_thesis_lab.yaml, so that mutations reach every row;
//  - yolo_decoding/: one output of each layout (grid, yolov5, yolov8, darknet) with a few
//    confident candidates, and a two-output grid model.
// Deterministic (fixed simulator seeds). Build and run from the repository root:
//   catkin_make -C .ws test_fuzz_make_seeds && .ws/devel/lib/drill_pipe_pose/test_fuzz_make_seeds

#include <cstdio>
#include <fstream>
#include <ostream>
#include <sstream>
#include <string>
#include <vector>

#include "drill_pipe_pose/core/depth_crop.hpp"
#include "drill_pipe_pose/core/estimator/estimator_params_table.hpp"
#include "drill_pipe_pose/ros/conversions.hpp"
#include "drill_pipe_pose/sim/rig_simulator.hpp"
#include "fuzz_input.hpp"
#include "sensor_frame_input.hpp"

using namespace drill_pipe_pose;

namespace {

const std::string kDir = std::string(DRILL_PIPE_POSE_SOURCE_DIR) + "/test/fuzz/corpus/";

void save(const std::string& harness, const std::string& name, const std::vector<uint8_t>& b) {
  const std::string path = kDir + harness + "/" + name;
  std::ofstream f(path, std::ios::binary);
  f.write(reinterpret_cast<const char*>(b.data()), static_cast<std::streamsize>(b.size()));
  std::printf("%s: %zu bytes\n", path.c_str(), b.size());
}

/// Cameras [first, first + n) of cycle 0 of a simulated scene that see a box, as fuzz cameras.
std::vector<fuzz::FuzzCamera> simulated(const std::string& scene, size_t n, bool crop,
                                        bool as_float) {
  sim::SimulatorOptions opt;
  opt.seed = 7;
  opt.sensor_config_dir = std::string(DRILL_PIPE_POSE_SOURCE_DIR) + "/config/sensors";
  opt.stamp_origin_ns = 1000000000;
  const std::string dir = DRILL_PIPE_POSE_SOURCE_DIR;
  auto s = sim::loadScenario(dir + "/config/rigs/thesis_lab.yaml",
                             dir + "/config/scenes/" + scene + ".yaml", opt);
  std::vector<fuzz::FuzzCamera> out;
  for (size_t i = 0; i < s->numCameras() && out.size() < n; ++i) {
    SensorFrameData f = s->render(i, s->captureTime(i, 0), 0).sensor_frame;
    if (f.boxes.empty()) continue;
    if (crop) f = cropDepthToBoxes(f, s->T_link_depth(i));
    if (as_float) {  // the same depths as 32FC1 metres
      DepthImage d = DepthImage::allocate(f.depth.width, f.depth.height, DepthEncoding::kF32Metres);
      for (uint32_t v = 0; v < d.height; ++v)
        for (uint32_t u = 0; u < d.width; ++u) d.setDepth(u, v, f.depth.depthAt(u, v));
      f.depth = d;
    }
    fuzz::FuzzCamera c;
    c.msg = toMsg(f);
    c.T_color_depth = s->T_link_depth(i);
    c.T_world_depth = s->publishedT_world_link(i) * s->T_link_depth(i);
    out.push_back(c);
  }
  return out;
}

void sensorFrameSeeds() {
  struct Seed {
    const char* name;
    const char* scene;
    size_t cameras;
    bool crop, as_float, second_cycle;
  };
  const Seed seeds[] = {
      {"sim_thesis_vertical_3cams_cropped", "thesis_vertical", 3, true, false, true},
      {"sim_thesis_angled_2cams_cropped_32fc1", "thesis_angled", 2, true, true, false},
      {"sim_cluttered_3cams_cropped", "cluttered", 3, true, false, false},
      {"sim_stabbing_1cam_full", "stabbing", 1, false, false, false},
  };
  for (const Seed& s : seeds) {
    fuzz::FuzzSensorInput in;
    in.cameras = simulated(s.scene, s.cameras, s.crop, s.as_float);
    in.second_cycle = s.second_cycle;
    save("sensor_frame", s.name, fuzz::encodeSensorInput(in));
  }
  // The conversion tests' sample frame (test/sample_messages.cpp): cropped roi, two boxes.
  fuzz::FuzzSensorInput in;
  fuzz::FuzzCamera c;
  SensorFrame& f = c.msg;
  f.header.stamp.fromNSec(1700000000123456789ull);
  f.header.frame_id = "cam1_rgb_optical_frame";
  f.camera = "cam1";
  f.color_info = fuzz::detail::presetInfo(false);
  f.color_info.header = f.header;
  f.depth_info = fuzz::detail::presetInfo(true);
  f.depth_info.roi.x_offset = 200;
  f.depth_info.roi.y_offset = 100;
  f.depth_info.roi.width = 37;
  f.depth_info.roi.height = 61;
  f.depth.header = f.depth_info.header;
  f.depth.width = 37;
  f.depth.height = 61;
  f.depth.encoding = "16UC1";
  f.depth.step = 74;
  f.depth.data.resize(74 * 61);
  for (size_t i = 0; i < f.depth.data.size() / 2; ++i) {
    const uint16_t mm = static_cast<uint16_t>(5000 + (i * 7919) % 600);
    std::memcpy(&f.depth.data[2 * i], &mm, 2);
  }
  PipeBox b;
  b.label = "box_end";
  b.confidence = 0.93f;
  b.x_min = 401.5f;
  b.y_min = 220.25f;
  b.x_max = 420.0f;
  b.y_max = 260.0f;
  f.boxes.push_back(b);
  b.label = "pin_end";
  b.confidence = 0.61f;
  b.x_min = 600.0f;
  b.y_min = 100.0f;
  b.x_max = 615.5f;
  b.y_max = 131.0f;
  f.boxes.push_back(b);
  in.cameras.push_back(c);
  save("sensor_frame", "sample_frame_cropped", fuzz::encodeSensorInput(in));
}

/// A YAML map in table order: key -> value text (a leaf) or nested map.
struct YamlTree {
  std::vector<std::pair<std::string, YamlTree>> children;
  std::string value;
  YamlTree& child(const std::string& key) {
    for (auto& c : children)
      if (c.first == key) return c.second;
    children.emplace_back(key, YamlTree());
    return children.back().second;
  }
  void write(std::ostream& out, int indent) const {
    for (const auto& [key, t] : children) {
      out << std::string(indent, ' ') << key << ":";
      if (t.children.empty()) {
        out << " " << t.value << "\n";
      } else {
        out << "\n";
        t.write(out, indent + 2);
      }
    }
  }
};

void estimatorYamlSeed() {
  EstimatorNodeConfig defaults;
  defaults.cameras = {"cam1", "cam2"};
  YamlTree root;
  for (const auto& row : estimatorNodeParamTable()) {
    // Nested maps, as the node's files are written (work_zone: {min: ...}).
    YamlTree* t = &root;
    std::string key = row.info.name;
    for (size_t p; (p = key.find('/')) != std::string::npos; key = key.substr(p + 1))
      t = &t->child(key.substr(0, p));
    t->child(key).value = formatParamValue(row.get(defaults));
  }
  std::ostringstream text;
  text << "# every parameter of the pose_estimator node with its default "
          "(test/fuzz/make_seeds.cpp)\n";
  root.write(text, 0);
  const std::string t = text.str();
  save("estimator_yaml", "all_keys.yaml", std::vector<uint8_t>(t.begin(), t.end()));
}

/// A YOLO output in the fuzz_yolo_decoding format: dims, coded floats, the decoding settings.
struct Blob {
  std::vector<int> dims;
  std::vector<float> data;
};
std::vector<uint8_t> yoloInput(int format, const std::vector<Blob>& blobs) {
  fuzz::FuzzWriter w;
  w.u8(static_cast<uint8_t>(blobs.size() - 1));
  w.u8(static_cast<uint8_t>(format));
  for (const Blob& b : blobs) {
    w.u8(static_cast<uint8_t>(b.dims.size()));
    for (int d : b.dims) w.u8(static_cast<uint8_t>(d + 2));  // small dims: d + 2 < 0xF0
    w.u8(0);  // each value coded
    for (float x : b.data) w.f32(x);
  }
  w.u8(4);  // input width: u16
  w.u16(416);
  w.u8(4);  // input height
  w.u16(416);
  w.f32(0.25f);  // score threshold
  for (int v : {0, 0, 960, 540}) {  // letterbox roi x, y, w, h
    w.u8(4);
    w.u16(static_cast<uint16_t>(v));
  }
  w.u8(1);  // allow upscale
  w.u8(4);  // max candidates
  w.u16(1000);
  w.f32(0.45f);  // nms
  w.f32(0.7f);   // cross-class nms
  w.u8(1);       // max boxes per class
  return w.bytes();
}

void yoloSeeds() {
  // grid [1, 5 + C, H, W], C = 2: one confident cell per class.
  Blob g{{1, 7, 4, 5}, std::vector<float>(7 * 20, 0.0f)};
  auto at = [&](Blob& b, int c, int y, int x) -> float& { return b.data[(c * 4 + y) * 5 + x]; };
  for (int c : {0, 1, 2, 3}) at(g, c, 1, 2) = 0.5f, at(g, c, 2, 3) = 0.4f;
  at(g, 4, 1, 2) = 0.9f;
  at(g, 5, 1, 2) = 0.95f;
  at(g, 4, 2, 3) = 0.8f;
  at(g, 6, 2, 3) = 0.9f;
  save("yolo_decoding", "grid_1x7x4x5", yoloInput(1, {g}));
  Blob g2{{1, 7, 2, 2}, std::vector<float>(7 * 4, 0.1f)};
  g2.data[4 * 4] = 0.9f;
  g2.data[5 * 4] = 0.9f;
  save("yolo_decoding", "grid_two_strides_auto", yoloInput(0, {g, g2}));
  // yolov5 [1, N, 5 + C]: cx, cy, w, h, obj, classes.
  Blob v5{{1, 3, 7}, {100, 120, 40, 60, 0.9f, 0.95f, 0.1f,  //
                      102, 118, 42, 58, 0.8f, 0.9f,  0.2f,  //
                      300, 200, 30, 30, 0.7f, 0.1f,  0.9f}};
  save("yolo_decoding", "yolov5_1x3x7", yoloInput(2, {v5}));
  // yolov8 [1, 4 + C, N]: rows cx, cy, w, h, classes.
  Blob v8{{1, 6, 3}, {100, 102, 300, 120, 118, 200, 40, 42, 30, 60, 58, 30,  //
                      0.9f, 0.8f, 0.1f, 0.1f, 0.2f, 0.9f}};
  save("yolo_decoding", "yolov8_1x6x3", yoloInput(3, {v8}));
  // darknet [N, 5 + C], normalised coordinates, class scores with objectness.
  Blob dk{{2, 7}, {0.3f, 0.4f, 0.1f, 0.2f, 0.9f, 0.85f, 0.0f,  //
                   0.6f, 0.5f, 0.1f, 0.1f, 0.8f, 0.0f, 0.7f}};
  save("yolo_decoding", "darknet_2x7", yoloInput(4, {dk}));
}

}  // namespace

int main() {
  sensorFrameSeeds();
  estimatorYamlSeed();
  yoloSeeds();
  return 0;
}
