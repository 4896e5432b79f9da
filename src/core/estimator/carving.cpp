// Stage "carving": visual-hull fusion of the cut-out points.

#include <algorithm>
#include <cmath>
#include <functional>

#include "drill_pipe_pose/core/estimator/carving.hpp"

namespace drill_pipe_pose {

namespace {

/// What one camera needs to judge a point of a label: its colour and depth projections, its boxes
/// of the label and where their points lie.
struct Judge {
  Eigen::Matrix3f R;
  Eigen::Vector3f t;
  float fx, fy, cx, cy, w, h;
  std::vector<const DetectionBox*> boxes;
  // Where each box's own cut-out points lie in the world (their bounding box): the camera
  // votes against a point only within carving.box_reach of one of them.
  std::vector<Eigen::AlignedBox3f> reach;
  // The depth image, to tell whether the camera sees the point at all.
  Eigen::Matrix3f R_d;
  Eigen::Vector3f t_d;
  float dfx, dfy, dcx, dcy;  // full-sensor principal point
  int off_x, off_y;          // the delivered image's offset in the sensor (roi)
  const DepthImage* depth;
  std::array<int, 4> crop;  // depth pixels the occlusion test may read (CycleCamera::crop)
};

/// Camera `cam`'s judge of points of `label`.
Judge makeJudge(const CycleCamera& cam, EndLabel label) {
  Judge j;
  j.R = cam.T_color_world.linear().cast<float>();
  j.t = cam.T_color_world.translation().cast<float>();
  j.fx = cam.color.fx();
  j.fy = cam.color.fy();
  j.cx = cam.color.cx() - cam.color.offsetX();
  j.cy = cam.color.cy() - cam.color.offsetY();
  j.w = cam.color.imageWidth();
  j.h = cam.color.imageHeight();
  const Eigen::Isometry3d T_depth_world = cam.T_world_depth.inverse();
  j.R_d = T_depth_world.linear().cast<float>();
  j.t_d = T_depth_world.translation().cast<float>();
  j.dfx = cam.depth.fx();
  j.dfy = cam.depth.fy();
  j.dcx = cam.depth.cx();
  j.dcy = cam.depth.cy();
  j.off_x = static_cast<int>(cam.depth.offsetX());
  j.off_y = static_cast<int>(cam.depth.offsetY());
  j.depth = &cam.image;
  j.crop = cam.crop;
  for (const auto& b : cam.boxes)
    if (b.label == label) j.boxes.push_back(&b);
  j.reach.assign(j.boxes.size(), Eigen::AlignedBox3f());
  return j;
}

/// The number of ends among `boxes`: a box whose centre lies in a box already counted, or that
/// holds its centre, is the same detection twice (thesis_vertical's simulated detector repeats
/// boxes).
size_t distinctBoxes(const std::vector<const DetectionBox*>& boxes) {
  const auto holds = [](const DetectionBox& a, const DetectionBox& b) {
    const float u = 0.5f * (b.x_min + b.x_max), v = 0.5f * (b.y_min + b.y_max);
    return u >= a.x_min && u <= a.x_max && v >= a.y_min && v <= a.y_max;
  };
  std::vector<const DetectionBox*> counted;
  for (const DetectionBox* b : boxes) {
    bool repeat = false;
    for (const DetectionBox* c : counted) repeat = repeat || holds(*c, *b) || holds(*b, *c);
    if (!repeat) counted.push_back(b);
  }
  return counted.size();
}

/// The number of ends of the label that at least `need` of the cameras boxed (`distinct`: each
/// judging camera's count; others 0); 0 when fewer cameras have a box of it.
size_t endsBoxedByEnough(const std::vector<size_t>& distinct, const std::vector<bool>& can_judge,
                         size_t need) {
  std::vector<size_t> counts;
  for (size_t c = 0; c < distinct.size(); ++c)
    if (can_judge[c]) counts.push_back(distinct[c]);
  std::sort(counts.begin(), counts.end(), std::greater<size_t>());
  return counts.size() >= need && need > 0 ? counts[need - 1] : 0;
}

}  // namespace

std::vector<CloudPoint> carve(const std::vector<CloudPoint>& points, EndLabel label,
                              const std::vector<CycleCamera>& cameras,
                              const EstimatorConfig::Carving& config) {
  const int l = static_cast<int>(label);
  std::vector<Judge> judges(cameras.size());
  std::vector<bool> can_judge(cameras.size(), false);
  std::vector<size_t> distinct(cameras.size(), 0);
  for (size_t c = 0; c < cameras.size(); ++c) {
    if (!cameras[c].has_label[l]) continue;
    can_judge[c] = true;
    judges[c] = makeJudge(cameras[c], label);
    distinct[c] = distinctBoxes(judges[c].boxes);
  }
  // The number of ends of the label that at least min_cameras cameras boxed: a camera with fewer
  // may have missed an end (carving.count_boxes).
  const size_t common =
      config.count_boxes
          ? endsBoxedByEnough(distinct, can_judge, static_cast<size_t>(config.min_cameras))
          : 0;
  const float margin = config.margin_px;
  auto inBox = [margin](const DetectionBox& b, float u, float v) {
    return u >= b.x_min - margin && u <= b.x_max + margin && v >= b.y_min - margin &&
           v <= b.y_max + margin;
  };
  // Pixel of a world point in camera j's colour image; false when behind it or outside.
  auto project = [](const Judge& j, const Eigen::Vector3f& pw, float* u, float* v) {
    const Eigen::Vector3f pc = j.R * pw + j.t;
    if (!(pc.z() > 0.0f)) return false;
    *u = j.fx * pc.x() / pc.z() + j.cx;
    *v = j.fy * pc.y() / pc.z() + j.cy;
    return !(*u < -0.5f || *v < -0.5f || *u > j.w - 0.5f || *v > j.h - 0.5f);
  };
  const bool reach_on = config.box_reach > 0;
  if (reach_on)
    for (const CloudPoint& p : points) {
      if (p.camera >= cameras.size() || !can_judge[p.camera]) continue;
      Judge& j = judges[p.camera];
      float u, v;
      if (!project(j, p.p_world, &u, &v)) continue;
      for (size_t k = 0; k < j.boxes.size(); ++k)
        if (inBox(*j.boxes[k], u, v)) j.reach[k].extend(p.p_world);
    }
  const float reach2 = static_cast<float>(config.box_reach * config.box_reach);
  auto withinReach = [&](const Judge& j, const Eigen::Vector3f& pw) {
    for (const auto& r : j.reach)
      if (!r.isEmpty() && r.squaredExteriorDistance(pw) <= reach2) return true;
    return false;
  };
  // Something nearer than the point on the camera's ray (its depth pixel, where delivered, is
  // closer by more than occlusion_margin): the camera cannot see the point, and does not vote.
  auto occluded = [&](const Judge& j, const Eigen::Vector3f& pw) {
    const Eigen::Vector3f pd = j.R_d * pw + j.t_d;
    if (!(pd.z() > 0.0f)) return false;
    // Rounded in sensor pixels, then shifted: the same pixel with full and cropped depth.
    // (Checked before the conversion to int: a pixel far off the image, or NaN, is unseen.)
    const double uf = static_cast<double>(std::round(j.dfx * pd.x() / pd.z() + j.dcx)) - j.off_x,
                 vf = static_cast<double>(std::round(j.dfy * pd.y() / pd.z() + j.dcy)) - j.off_y;
    if (!(uf >= j.crop[0] && vf >= j.crop[1] && uf < j.crop[2] && vf < j.crop[3])) return false;
    const int u = static_cast<int>(uf), v = static_cast<int>(vf);
    const float z = j.depth->depthAt(static_cast<uint32_t>(u), static_cast<uint32_t>(v));
    return z > 0.0f && z < pd.z() - static_cast<float>(config.occlusion_margin);
  };
  std::vector<CloudPoint> kept;
  kept.reserve(points.size());
  // A point is kept when the cameras agree it lies in their boxes (min_cameras, vote_fraction):
  // all of them, or (count_boxes) those that boxed as many ends as the others. A camera with
  // fewer boxes may have missed the end the point is on; the point's own camera counts in both.
  const auto agree = [&](int inside, int voters) {
    return voters < config.min_cameras ||
           (inside >= config.min_cameras && inside >= config.vote_fraction * voters);
  };
  for (const CloudPoint& p : points) {
    int voters = 1, inside = 1, full_voters = 1, full_inside = 1;
    for (size_t c = 0; c < cameras.size(); ++c) {
      if (c == p.camera || !can_judge[c]) continue;
      const Judge& j = judges[c];
      float u, v;
      if (!project(j, p.p_world, &u, &v)) continue;
      if (config.occlusion_margin > 0 && occluded(j, p.p_world)) continue;
      bool in = false;
      for (const DetectionBox* b : j.boxes) in = in || inBox(*b, u, v);
      // Outside every box: a vote against only from a detection near the point.
      if (!in && reach_on && !withinReach(j, p.p_world)) continue;
      ++voters;
      if (in) ++inside;
      if (distinct[c] >= common) {
        ++full_voters;
        if (in) ++full_inside;
      }
    }
    if (agree(inside, voters) ||
        (common > 0 && full_voters >= config.min_cameras && agree(full_inside, full_voters)))
      kept.push_back(p);
  }
  return kept;
}

}  // namespace drill_pipe_pose
