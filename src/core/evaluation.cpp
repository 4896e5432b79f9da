#include "drill_pipe_pose/core/evaluation.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <iterator>
#include <limits>
#include <numeric>
#include <ostream>

#include "drill_pipe_pose/core/errors.hpp"

namespace drill_pipe_pose {

void GroundTruthTrack::add(int64_t stamp_ns, const Eigen::Isometry3d& T_world_end) {
  if (!stamps_.empty() && stamp_ns < stamps_.back()) sorted_ = false;
  stamps_.push_back(stamp_ns);
  poses_.push_back(T_world_end);
}

void GroundTruthTrack::sortIfNeeded() const {
  if (sorted_) return;
  std::vector<size_t> idx(stamps_.size());
  std::iota(idx.begin(), idx.end(), 0);
  std::stable_sort(idx.begin(), idx.end(),
                   [&](size_t a, size_t b) { return stamps_[a] < stamps_[b]; });
  auto s = stamps_;
  auto p = poses_;
  for (size_t i = 0; i < idx.size(); ++i) {
    stamps_[i] = s[idx[i]];
    poses_[i] = p[idx[i]];
  }
  sorted_ = true;
}

bool GroundTruthTrack::at(int64_t t, Eigen::Isometry3d* T, int64_t max_extrapolation_ns) const {
  if (stamps_.empty()) return false;
  sortIfNeeded();
  if (t < stamps_.front() - max_extrapolation_ns || t > stamps_.back() + max_extrapolation_ns)
    return false;
  const auto it = std::lower_bound(stamps_.begin(), stamps_.end(), t);
  if (it == stamps_.begin()) {
    *T = poses_.front();
    return true;
  }
  if (it == stamps_.end()) {
    *T = poses_.back();
    return true;
  }
  const size_t j = static_cast<size_t>(it - stamps_.begin()), i = j - 1;
  const double span = static_cast<double>(stamps_[j] - stamps_[i]);
  const double s = span > 0 ? static_cast<double>(t - stamps_[i]) / span : 0.0;
  const Eigen::Quaterniond qa(poses_[i].linear()), qb(poses_[j].linear());
  T->setIdentity();
  T->linear() = qa.slerp(s, qb).toRotationMatrix();
  T->translation() = (1 - s) * poses_[i].translation() + s * poses_[j].translation();
  return true;
}

std::array<EndEvaluation, kNumEnds> evaluate(const std::array<GroundTruthTrack, kNumEnds>& truth,
                                             const std::vector<EstimateSample>& estimates,
                                             const EvaluationOptions& options) {
  std::array<EndEvaluation, kNumEnds> out;
  for (int e = 0; e < kNumEnds; ++e) {
    EndEvaluation& ev = out[e];
    ev.label = static_cast<EndLabel>(e);
    const GroundTruthTrack& gt = truth[e];
    ev.present = !gt.empty();
    if (!ev.present) continue;
    size_t expected = options.expected_cycles;
    if (expected == 0)
      expected = static_cast<size_t>(std::llround(
          options.expected_rate_hz * static_cast<double>(gt.lastStamp() - gt.firstStamp()) * 1e-9));
    std::vector<PoseError> errors;
    std::vector<Eigen::Vector3d> positions;
    size_t with_cov = 0, inside = 0, with_rot_cov = 0, axis_inside = 0;
    double lag_sum = 0, trace_sum = 0, err2_sum = 0;
    std::vector<double> fresh_errors;
    Eigen::Vector3d true_sum = Eigen::Vector3d::Zero();
    for (const auto& est : estimates) {
      if (est.label != ev.label || !est.valid) continue;
      Eigen::Isometry3d T_true;
      if (!gt.at(est.stamp_ns, &T_true)) continue;
      const PoseError err = poseError(T_true, est.T_world_end);
      errors.push_back(err);
      if (est.fresh) fresh_errors.push_back(err.position.norm());
      positions.push_back(est.T_world_end.translation());
      ev.stamps.push_back(est.stamp_ns);
      true_sum += T_true.translation();
      // Velocity of the ground truth by central difference over +-50 ms.
      Eigen::Isometry3d T_a, T_b;
      const int64_t h = 50000000;
      if (gt.at(est.stamp_ns - h, &T_a, 0) && gt.at(est.stamp_ns + h, &T_b, 0)) {
        const Eigen::Vector3d v = (T_b.translation() - T_a.translation()) / (2 * h * 1e-9);
        if (v.norm() > options.moving_speed) {
          lag_sum += err.position.dot(v.normalized());
          ++ev.moving_estimates;
        }
      }
      const Eigen::Matrix3d P = est.covariance.topLeftCorner<3, 3>();
      if (P.trace() > 0) {
        ++with_cov;
        const double d2 = err.position.dot(P.ldlt().solve(err.position));
        if (d2 <= 9.0) ++inside;
        trace_sum += P.trace();
        err2_sum += err.position.squaredNorm();
      }
      const Eigen::Matrix3d Q = est.covariance.bottomRightCorner<3, 3>();
      if (Q.trace() > 0) {
        ++with_rot_cov;
        const Eigen::Vector3d r = T_true.linear() * err.rotation_vector;
        const double d2 = r.dot(Q.ldlt().solve(r));
        if (d2 <= 9.0) ++axis_inside;
      }
    }
    ev.stats = computeStats(errors, positions, std::max(expected, errors.size()));
    ev.within_3sigma = with_cov ? static_cast<double>(inside) / with_cov : std::nan("");
    ev.axis_within_3sigma =
        with_rot_cov ? static_cast<double>(axis_inside) / with_rot_cov : std::nan("");
    ev.sigma_to_error =
        with_cov && err2_sum > 0 ? std::sqrt(trace_sum / err2_sum) : std::nan("");
    ev.fresh_median_error = fresh_errors.empty() ? std::nan("") : percentile(fresh_errors, 0.5);
    ev.fresh_p95_error = fresh_errors.empty() ? std::nan("") : percentile(fresh_errors, 0.95);
    ev.mean_lag = ev.moving_estimates ? lag_sum / static_cast<double>(ev.moving_estimates)
                                      : std::nan("");
    if (!errors.empty()) ev.true_position = true_sum / static_cast<double>(errors.size());
  }
  return out;
}

void writeErrorCsv(const std::array<EndEvaluation, kNumEnds>& evals, std::ostream& out) {
  out << "stamp_s,end,ex_m,ey_m,ez_m,error_m,along_m,across_m,axis_angle_deg,rx_deg,ry_deg\n";
  out << std::setprecision(9);
  const double deg = 180.0 / M_PI;
  for (const auto& ev : evals)
    for (size_t i = 0; i < ev.stats.errors.size(); ++i) {
      const PoseError& e = ev.stats.errors[i];
      out << ev.stamps[i] * 1e-9 << ',' << labelName(ev.label) << ',' << e.position.x() << ','
          << e.position.y() << ',' << e.position.z() << ',' << e.position_norm << ','
          << e.along_axis << ',' << e.across_axis << ',' << e.axis_angle * deg << ','
          << e.rotation_vector.x() * deg << ',' << e.rotation_vector.y() * deg << '\n';
    }
}

void printEvaluation(const std::array<EndEvaluation, kNumEnds>& evals, std::ostream& out) {
  const double deg = 180.0 / M_PI;
  out << std::fixed;
  for (const auto& ev : evals) {
    if (!ev.present) continue;
    const ErrorStats& s = ev.stats;
    out << "== " << labelName(ev.label) << ": " << s.estimates << " estimates / "
        << s.expected_cycles << " expected cycles\n";
    if (s.estimates == 0) {
      out << "   no valid estimate\n";
      continue;
    }
    out << "   axis   true [m]  mean [m]  error mean [mm]  sigma [mm]  rot mean [deg]  rot sigma "
           "[deg]\n";
    const char* axes[] = {"x", "y", "z"};
    for (int a = 0; a < 3; ++a) {
      out << "   " << axes[a] << std::setw(12) << std::setprecision(3) << ev.true_position[a]
          << std::setw(10) << s.mean_position[a] << std::setw(17) << std::setprecision(1)
          << s.mean_error[a] * 1e3 << std::setw(12) << s.std_position[a] * 1e3;
      if (a < 2)
        out << std::setw(16) << std::setprecision(2) << s.mean_rotation[a] * deg << std::setw(17)
            << s.std_rotation[a] * deg;
      out << '\n';
    }
    out << std::setprecision(1) << "   3D error [mm]: mean " << s.mean_position_error * 1e3
        << ", median " << s.p50_position_error * 1e3 << ", p95 " << s.p95_position_error * 1e3
        << ", max " << s.max_position_error * 1e3 << "; along axis " << s.mean_along * 1e3
        << ", across " << s.mean_across * 1e3 << '\n';
    out << std::setprecision(2) << "   axis angle [deg]: mean " << s.mean_axis_angle * deg
        << ", p95 " << s.p95_axis_angle * deg << ", max " << s.max_axis_angle * deg << '\n';
    out << std::setprecision(1) << "   within 1 cm/1 deg " << 100 * s.fractionWithin(0.01, 1 / deg)
        << " %, 2 cm/2 deg " << 100 * s.fractionWithin(0.02, 2 / deg) << " %, 5 cm/5 deg "
        << 100 * s.fractionWithin(0.05, 5 / deg) << " % of expected cycles\n";
    if (!std::isnan(ev.within_3sigma))
      out << "   error inside the reported 3-sigma ellipsoid: " << 100 * ev.within_3sigma
          << " % of estimates\n";
    if (!std::isnan(ev.axis_within_3sigma))
      out << "   axis error inside the reported 3-sigma (rotation covariance): "
          << 100 * ev.axis_within_3sigma << " % of estimates\n";
    if (!std::isnan(ev.sigma_to_error))
      out << std::setprecision(2) << "   reported position sigma / actual error (rms over axes): "
          << ev.sigma_to_error << '\n';
    if (!std::isnan(ev.fresh_median_error))
      out << std::setprecision(1) << "   fresh poses' error [mm]: median "
          << ev.fresh_median_error * 1e3 << ", p95 " << ev.fresh_p95_error * 1e3 << '\n';
    if (ev.moving_estimates > 0)
      out << std::setprecision(1) << "   lag (signed error along the motion) [mm]: mean "
          << ev.mean_lag * 1e3 << " over " << ev.moving_estimates
          << " estimates while moving (negative: behind)\n";
  }
  out.unsetf(std::ios::fixed);
}

void TypeTally::add(const std::string& type, const std::vector<std::string>& names,
                    const std::vector<double>& probabilities) {
  ++reports;
  ++top[type];
  for (size_t k = 0; k < names.size() && k < probabilities.size(); ++k) {
    probability[names[k]] += probabilities[k];
    if (names[k] == type && probabilities[k] > kConfidentProbability) ++confident[type];
    if (names[k] != type) {
      auto [it, fresh] = least_not_top.emplace(names[k], probabilities[k]);
      if (!fresh) it->second = std::min(it->second, probabilities[k]);
    }
  }
}

InstanceEvaluation evaluateInstances(const TrueEnds& truth, const std::vector<ReportedEnd>& reports,
                                     double match_distance, double near_distance) {
  InstanceEvaluation ev;
  // The true ends at a stamp: the latest capture at or before it, per label.
  const auto trueAt = [&](int l, int64_t stamp) -> const std::vector<Eigen::Vector3d>* {
    auto it = truth[l].upper_bound(stamp);
    if (it == truth[l].begin()) return nullptr;
    return &std::prev(it)->second;
  };
  std::map<int64_t, std::vector<const ReportedEnd*>> by_cycle;
  for (const ReportedEnd& r : reports) by_cycle[r.stamp_ns].push_back(&r);
  // Per (label, true end): the id it had in the last cycle, and that cycle's index.
  std::map<std::pair<int, size_t>, std::pair<uint32_t, size_t>> last;
  size_t cycle = 0;
  for (const auto& [stamp, reps] : by_cycle) {
    ++cycle;
    ++ev.cycles;
    size_t n_true = 0;
    for (int l = 0; l < kNumEnds; ++l) {
      const std::vector<Eigen::Vector3d>* t = trueAt(l, stamp);
      if (!t) continue;
      n_true += t->size();
      for (size_t j = 0; j < t->size(); ++j) {
        ++ev.end_cycles;
        ++ev.per_end[{l, j}].first;
        const ReportedEnd* best = nullptr;
        double best_d = match_distance;
        for (const ReportedEnd* r : reps)
          if (static_cast<int>(r->label) == l && (r->origin - (*t)[j]).norm() <= best_d)
            best_d = (r->origin - (*t)[j]).norm(), best = r;
        if (!best) continue;
        ++ev.reported;
        ++ev.per_end[{l, j}].second;
        TrueEndTypes& ty = ev.types[{l, j}];
        ty.position = (*t)[j];
        if (!best->type.empty()) ty.add(best->type, best->type_names, best->type_probabilities);
        ev.id_truth[best->id].insert({l, j});
        auto it = last.find({l, j});
        if (it != last.end() && it->second.second + 1 == cycle) {
          ++ev.id_pairs;
          if (it->second.first == best->id) ++ev.id_kept;
        }
        last[{l, j}] = {best->id, cycle};
      }
    }
    ev.true_ends = std::max(ev.true_ends, n_true);
    for (const ReportedEnd* r : reps) {
      double own = std::numeric_limits<double>::infinity();
      if (const std::vector<Eigen::Vector3d>* t = trueAt(static_cast<int>(r->label), stamp))
        for (const Eigen::Vector3d& p : *t) own = std::min(own, (r->origin - p).norm());
      constexpr size_t kExamples = 5;
      if (own > match_distance) {
        ++ev.stray;
        if (ev.stray_examples.size() < kExamples) ev.stray_examples.emplace_back(*r, own);
      }
      // Within near_distance of a true end that is not the one it stands for (its label's
      // nearest).
      for (int l = 0; l < kNumEnds; ++l) {
        const std::vector<Eigen::Vector3d>* t = trueAt(l, stamp);
        if (!t) continue;
        for (size_t j = 0; j < t->size(); ++j) {
          const double d = (r->origin - (*t)[j]).norm();
          const bool its_own = l == static_cast<int>(r->label) && d == own;
          if (!its_own && d < near_distance) {
            ++ev.near_other;
            if (ev.near_examples.size() < kExamples) ev.near_examples.push_back(*r);
            l = kNumEnds;
            break;
          }
        }
      }
    }
  }
  for (const auto& [id, ends] : ev.id_truth) ev.mixed_ids += ends.size() > 1 ? 1 : 0;
  return ev;
}

std::string trueJointsYaml(const std::vector<TrueJoint>& joints) {
  YAML::Emitter out;
  out.SetDoublePrecision(9);
  out << YAML::BeginSeq;
  for (const TrueJoint& j : joints)
    out << YAML::Flow << YAML::BeginMap << YAML::Key << "label" << YAML::Value
        << labelName(j.label) << YAML::Key << "pipe" << YAML::Value << j.pipe << YAML::Key
        << "nominal_od" << YAML::Value << j.nominal_od << YAML::Key << "rendered_od"
        << YAML::Value << j.rendered_od << YAML::EndMap;
  out << YAML::EndSeq;
  return out.c_str();
}

std::vector<TrueJoint> parseTrueJoints(const std::string& yaml) {
  const std::string where = std::string(conventions::kGroundTruthJointsTopic);
  YAML::Node root;
  try {
    root = YAML::Load(yaml);
  } catch (const YAML::Exception& e) {
    fail(where, ": not YAML: ", e.what());
  }
  if (!root.IsSequence()) fail(where, ": expected a list of joints");
  std::vector<TrueJoint> out;
  for (size_t i = 0; i < root.size(); ++i) {
    const YAML::Node& n = root[i];
    const std::string entry = where + "[" + std::to_string(i) + "]";
    auto field = [&](const char* key) {
      if (!n.IsMap() || !n[key]) fail(entry, ": no field '", key, "'");
      return n[key];
    };
    TrueJoint j;
    try {
      j.label = parseEndLabel(field("label").as<std::string>(), entry + ".label");
      j.pipe = field("pipe").as<std::string>();
      j.nominal_od = field("nominal_od").as<double>();
      j.rendered_od = field("rendered_od").as<double>();
    } catch (const YAML::Exception& e) {
      fail(entry, ": ", e.what());
    }
    if (!(j.rendered_od > 0) || !(j.nominal_od > 0)) fail(entry, ": the ODs must be positive");
    out.push_back(j);
  }
  return out;
}

}  // namespace drill_pipe_pose
