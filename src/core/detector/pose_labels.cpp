#include "drill_pipe_pose/core/detector/pose_labels.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <set>
#include <sstream>

namespace drill_pipe_pose {

PoseGate gatePose(const PoseSample& pose, const LabelParams& params) {
  PoseGate g;
  const Eigen::Matrix3d P = pose.covariance.topLeftCorner<3, 3>();
  const Eigen::Matrix3d R = pose.covariance.bottomRightCorner<3, 3>();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> ep(0.5 * (P + P.transpose()));
  g.position_sigma = std::sqrt(std::max(0.0, ep.eigenvalues().maxCoeff()));
  // The axis tilts by rotations perpendicular to it: project out the (unobservable) roll.
  const Eigen::Vector3d a = pose.T_world_end.linear().col(2);
  const Eigen::Matrix3d Pa = Eigen::Matrix3d::Identity() - a * a.transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> er(Pa * (0.5 * (R + R.transpose())) * Pa);
  g.axis_sigma_deg = std::sqrt(std::max(0.0, er.eigenvalues().maxCoeff())) * 180.0 / M_PI;
  if (pose.corrected) {
    g.ok = true;
    return g;
  }
  std::ostringstream why;
  if (!std::isfinite(g.position_sigma) || g.position_sigma > params.max_position_sigma)
    why << "position sigma " << g.position_sigma * 1e3 << " mm > "
        << params.max_position_sigma * 1e3 << " mm";
  else if (!std::isfinite(g.axis_sigma_deg) || g.axis_sigma_deg > params.max_axis_sigma_deg)
    why << "axis sigma " << g.axis_sigma_deg << " deg > " << params.max_axis_sigma_deg << " deg";
  else if (pose.cameras < params.min_pose_cameras)
    why << "pose from " << pose.cameras << " camera(s) < " << params.min_pose_cameras;
  g.why = why.str();
  g.ok = g.why.empty();
  return g;
}

LabelModel makeLabelModel(EndLabel label, const ToolJointDimensions& dims, double spacing) {
  LabelModel m;
  m.label = label;
  const double tong = label == EndLabel::kBoxEnd ? dims.box_tong_length : dims.pin_tong_length;
  // The detector's box region, as the simulator's true boxes cover it (docs/conventions.md).
  const double z_min = -(tong + dims.taperLength());
  const double z_max = label == EndLabel::kBoxEnd ? 0.0 : dims.pin_length;
  for (const OrientedPoint& p :
       sampleProfileSurface(toolJointProfile(label, dims), spacing, 1u, true))
    if (p.p.z() >= z_min - 1e-9 && p.p.z() <= z_max + 1e-9) m.points.push_back(p);
  m.z_min = z_min;
  m.z_max = z_max;
  return m;
}

EndInView projectEnd(const LabelModel& model, const Eigen::Isometry3d& T_world_end,
                     const LabelView& view, const LabelParams& params) {
  EndInView out;
  const Eigen::Isometry3d T_color_end = view.T_world_color.inverse() * T_world_end;
  const Eigen::Isometry3d T_depth_end = view.T_world_depth.inverse() * T_world_end;
  const bool has_depth = view.depth_image.width > 0 && view.depth_image.data;
  const int dw = has_depth ? static_cast<int>(view.depth_image.width) : 0;
  const int dh = has_depth ? static_cast<int>(view.depth_image.height) : 0;
  // Pass 1: front-facing points, their depth pixel, and the joint's own nearest depth per pixel.
  struct Pt {
    Eigen::Vector2d uv;
    double z;   ///< depth-camera z [m]
    int pixel;  ///< depth pixel index, -1: outside the depth image
  };
  std::vector<Pt> pts;
  pts.reserve(model.points.size() / 2);
  std::vector<float> zbuf(static_cast<size_t>(dw) * dh, std::numeric_limits<float>::infinity());
  const Eigen::Vector3d eye_c = Eigen::Vector3d::Zero();
  for (const OrientedPoint& op : model.points) {
    const Eigen::Vector3d pc = T_color_end * op.p.cast<double>();
    const Eigen::Vector3d nc = T_color_end.linear() * op.n.cast<double>();
    if (nc.dot(pc - eye_c) >= 0.0) continue;  // faces away from the colour camera
    Pt p;
    if (!view.color.project(pc, &p.uv) || !view.color.contains(p.uv)) continue;
    p.pixel = -1;
    p.z = 0;
    if (has_depth) {
      const Eigen::Vector3d pd = T_depth_end * op.p.cast<double>();
      Eigen::Vector2d ud;
      if (view.depth.project(pd, &ud)) {
        const int u = static_cast<int>(std::lround(ud.x())), v = static_cast<int>(std::lround(ud.y()));
        if (u >= 0 && v >= 0 && u < dw && v < dh) {
          p.pixel = v * dw + u;
          p.z = pd.z();
          zbuf[p.pixel] = std::min(zbuf[p.pixel], static_cast<float>(p.z));
        }
      }
    }
    pts.push_back(p);
  }
  // Pass 2: classify against the measured depth; box the points that are not occluded.
  double u0 = 1e18, v0 = 1e18, u1 = -1e18, v1 = -1e18;
  for (const Pt& p : pts) {
    if (p.pixel >= 0 && p.z > zbuf[p.pixel] + params.self_occlusion_tolerance) continue;
    ++out.in_image;
    if (p.pixel < 0) {
      ++out.no_depth;
    } else {
      const float m = view.depth_image.depthAt(static_cast<uint32_t>(p.pixel % dw),
                                               static_cast<uint32_t>(p.pixel / dw));
      if (!std::isfinite(m)) {
        ++out.no_depth;
      } else if (m < p.z - params.depth_tolerance) {
        ++out.occluded;
        continue;
      } else if (m > p.z + params.depth_tolerance) {
        ++out.behind;
      } else {
        ++out.agree;
      }
    }
    u0 = std::min(u0, p.uv.x());
    v0 = std::min(v0, p.uv.y());
    u1 = std::max(u1, p.uv.x());
    v1 = std::max(v1, p.uv.y());
  }
  if (u1 >= u0) {
    const double W = view.color.imageWidth(), H = view.color.imageHeight();
    out.has_box = true;
    out.box.label = model.label;
    out.box.confidence = 1.0f;
    out.box.x_min = static_cast<float>(std::clamp(u0, -0.5, W - 0.5));
    out.box.y_min = static_cast<float>(std::clamp(v0, -0.5, H - 0.5));
    out.box.x_max = static_cast<float>(std::clamp(u1, -0.5, W - 0.5));
    out.box.y_max = static_cast<float>(std::clamp(v1, -0.5, H - 0.5));
  }
  return out;
}

double poseSpreadPx(const LabelModel& model, const PoseSample& pose, const LabelView& view) {
  double spread = 0;
  const Eigen::Isometry3d T_prev = view.T_world_color.inverse() * pose.T_prev;
  const Eigen::Isometry3d T_next = view.T_world_color.inverse() * pose.T_next;
  for (const double z : {model.z_min, model.z_max}) {
    const Eigen::Vector3d p(0, 0, z);
    Eigen::Vector2d a, b;
    if (!view.color.project(T_prev * p, &a) || !view.color.project(T_next * p, &b)) continue;
    spread = std::max(spread, (a - b).norm());
  }
  return spread;
}

bool confirmsPose(const EndInView& e, const LabelParams& params) {
  return e.agree + e.behind >= params.min_agree_points &&
         e.agreeFraction() >= params.agree_fraction;
}

std::optional<PoseSample> PoseTrack::at(int64_t stamp_ns, double max_gap) const {
  if (samples_.empty()) return std::nullopt;
  const int64_t gap_ns = static_cast<int64_t>(max_gap * 1e9);
  auto hi = samples_.lower_bound(stamp_ns);
  if (hi != samples_.end() && hi->first == stamp_ns) {
    // An estimate at the stamp: its neighbours within the gap bracket it.
    PoseSample p = hi->second;
    p.T_prev = p.T_next = p.T_world_end;
    if (hi != samples_.begin() && stamp_ns - std::prev(hi)->first <= gap_ns)
      p.T_prev = std::prev(hi)->second.T_world_end;
    if (std::next(hi) != samples_.end() && std::next(hi)->first - stamp_ns <= gap_ns)
      p.T_next = std::next(hi)->second.T_world_end;
    return p;
  }
  const PoseSample* after = hi != samples_.end() ? &hi->second : nullptr;
  const PoseSample* before = hi != samples_.begin() ? &std::prev(hi)->second : nullptr;
  if (before && after && after->stamp_ns - before->stamp_ns <= gap_ns) {
    const double s = double(stamp_ns - before->stamp_ns) / double(after->stamp_ns - before->stamp_ns);
    PoseSample p = *before;
    p.stamp_ns = stamp_ns;
    const Eigen::Quaterniond qa(before->T_world_end.linear()), qb(after->T_world_end.linear());
    p.T_world_end.linear() = qa.slerp(s, qb).toRotationMatrix();
    p.T_world_end.translation() =
        (1 - s) * before->T_world_end.translation() + s * after->T_world_end.translation();
    p.covariance = before->covariance.cwiseMax(after->covariance);
    p.cameras = std::min(before->cameras, after->cameras);
    p.corrected = before->corrected && after->corrected;
    p.T_prev = before->T_world_end;
    p.T_next = after->T_world_end;
    return p;
  }
  const PoseSample* nearest = nullptr;
  if (before) nearest = before;
  if (after && (!nearest || after->stamp_ns - stamp_ns < stamp_ns - nearest->stamp_ns))
    nearest = after;
  if (nearest && std::abs(nearest->stamp_ns - stamp_ns) <= gap_ns / 2) {
    PoseSample p = *nearest;
    p.T_prev = p.T_next = p.T_world_end;  // one estimate: no spread to measure
    return p;
  }
  return std::nullopt;
}

std::string labelId(const std::string& camera, int64_t stamp_ns, EndLabel end) {
  return camera + "_" + std::to_string(stamp_ns) + "_" + labelName(end);
}

DoubtParts doubtParts(const LabelItem& item) {
  DoubtParts d;
  d.disagree = std::clamp(1.0 - item.agree_fraction, 0.0, 1.0);
  d.unconfirmed = item.measured_cameras > 0
                      ? std::clamp(1.0 - double(item.agreeing_cameras) / item.measured_cameras,
                                   0.0, 1.0)
                      : 1.0;
  const double side = std::min(item.box.x_max - item.box.x_min, item.box.y_max - item.box.y_min);
  d.spread = std::clamp(item.spread_px / std::max(1.0, side), 0.0, 1.0);
  return d;
}

double labelDoubt(const LabelItem& item, const LabelParams& /*params*/) {
  if (item.corrected) return 0.0;
  return doubtParts(item).spread;
}

namespace {

/// Per end, for every view: how many distinct cameras confirm the end's pose within the sync
/// window of the view's stamp, and how many see it (have points of it in their image).
void cameraAgreement(const LabelInputs& in, const LabelParams& params, int e,
                     std::vector<int>* agreeing, std::vector<int>* measured,
                     std::vector<int>* in_view) {
  const size_t n = in.cameras.size();
  agreeing->assign(n, 0);
  measured->assign(n, 0);
  in_view->assign(n, 0);
  const int64_t window = static_cast<int64_t>(params.sync_window * 1e9);
  std::vector<size_t> order(n);
  for (size_t i = 0; i < n; ++i) order[i] = i;
  std::sort(order.begin(), order.end(),
            [&](size_t a, size_t b) { return in.stamps_ns[a] < in.stamps_ns[b]; });
  size_t lo = 0;
  for (size_t k = 0; k < n; ++k) {
    const size_t v = order[k];
    while (in.stamps_ns[order[lo]] < in.stamps_ns[v] - window) ++lo;
    std::set<std::string> agree, measuring, seen;
    for (size_t j = lo; j < n && in.stamps_ns[order[j]] <= in.stamps_ns[v] + window; ++j) {
      const size_t w = order[j];
      if (!in.poses[w][e]) continue;
      const EndInView& p = in.projections[w][e];
      if (p.in_image > 0) seen.insert(in.cameras[w]);
      if (p.agree + p.behind >= params.min_agree_points) measuring.insert(in.cameras[w]);
      if (confirmsPose(p, params)) agree.insert(in.cameras[w]);
    }
    (*agreeing)[v] = static_cast<int>(agree.size());
    (*measured)[v] = static_cast<int>(measuring.size());
    (*in_view)[v] = static_cast<int>(seen.size());
  }
}

}  // namespace

std::vector<ImageLabels> labelImages(const LabelInputs& in, const LabelParams& params) {
  const size_t n = in.cameras.size();
  std::array<std::vector<int>, kNumEnds> agreeing, measured, in_view;
  for (int e = 0; e < kNumEnds; ++e)
    cameraAgreement(in, params, e, &agreeing[e], &measured[e], &in_view[e]);
  std::vector<ImageLabels> out(n);
  for (size_t v = 0; v < n; ++v) {
    ImageLabels& img = out[v];
    img.camera = in.cameras[v];
    img.stamp_ns = in.stamps_ns[v];
    img.poses = in.poses[v];
    img.keep = true;
    for (int e = 0; e < kNumEnds && img.keep; ++e) {
      if (!in.expected[e]) continue;
      const EndLabel label = static_cast<EndLabel>(e);
      const std::string end = labelName(label);
      const auto& pose = in.poses[v][e];
      if (!pose) {
        img.keep = false;
        img.why = end + ": no pose";
        break;
      }
      const EndInView& p = in.projections[v][e];
      const PoseGate gate = gatePose(*pose, params);
      if (!gate.ok) {
        img.keep = false;
        img.why = end + ": " + gate.why;
        break;
      }
      if (!pose->corrected && agreeing[e][v] < params.min_agreeing_cameras) {
        img.keep = false;
        img.why = end + ": confirmed by " + std::to_string(agreeing[e][v]) + " camera(s) < " +
                  std::to_string(params.min_agreeing_cameras);
        break;
      }
      if (p.in_image == 0) continue;  // not in this image
      const double vis = p.visibleFraction();
      if (vis < params.hidden_fraction) continue;  // hidden: no label
      if (vis < params.min_visible_fraction) {
        img.keep = false;
        img.why = end + ": partly hidden";
        break;
      }
      if (!pose->corrected && p.agree + p.behind >= params.min_agree_points &&
          p.agreeFraction() < params.own_agree_fraction) {
        img.keep = false;
        img.why = end + ": this camera's depth disagrees (agree " +
                  std::to_string(p.agreeFraction()) + ")";
        break;
      }
      if (!p.has_box || p.boxArea() < params.min_box_area) {
        img.keep = false;
        img.why = end + ": box too small";
        break;
      }
      LabelItem item;
      item.id = labelId(img.camera, img.stamp_ns, label);
      item.box = p.box;
      item.visible_fraction = vis;
      item.agree_fraction = p.agreeFraction();
      item.position_sigma = gate.position_sigma;
      item.axis_sigma_deg = gate.axis_sigma_deg;
      item.agreeing_cameras = agreeing[e][v];
      item.measured_cameras = measured[e][v];
      item.spread_px = p.spread_px;
      item.in_view_cameras = in_view[e][v];
      item.corrected = pose->corrected;
      item.doubt = labelDoubt(item, params);
      img.labels.push_back(item);
    }
    if (!img.keep) img.labels.clear();
  }
  return out;
}

}  // namespace drill_pipe_pose
