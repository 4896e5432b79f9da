#include "drill_pipe_pose/core/tool_joint.hpp"

#include <cmath>
#include <fstream>

#include "drill_pipe_pose/core/errors.hpp"

namespace drill_pipe_pose {

double ToolJointDimensions::taperLength() const {
  return (tool_joint_od - tube_od) / 2.0 / std::tan(elevator_taper_deg * M_PI / 180.0);
}

void validateDimensions(const ToolJointDimensions& d, const std::string& where) {
  auto positive = [&](double v, const char* name) {
    if (!std::isfinite(v) || !(v > 0.0))
      fail(where, ": field ", name, " = ", v, " must be finite and > 0");
  };
  positive(d.tube_od, "tube_od");
  positive(d.tube_id, "tube_id");
  positive(d.tool_joint_od, "tool_joint_od");
  positive(d.tool_joint_id, "tool_joint_id");
  positive(d.elevator_taper_deg, "elevator_taper_deg");
  positive(d.pin_tong_length, "pin_tong_length");
  positive(d.box_tong_length, "box_tong_length");
  positive(d.pin_length, "pin_length");
  positive(d.pin_large_diameter, "pin_large_diameter");
  positive(d.box_counterbore_diameter, "box_counterbore_diameter");
  positive(d.box_thread_depth, "box_thread_depth");
  positive(d.tube_length, "tube_length");
  if (d.threads) {  // only read when the thread ridges are modelled
    positive(d.threads_per_inch, "threads_per_inch");
    positive(d.thread_height, "thread_height");
  }
  if (!std::isfinite(d.pin_taper) || d.pin_taper < 0.0)
    fail(where, ": field pin_taper = ", d.pin_taper, " must be finite and >= 0");
  // At least 1 deg: a taper's length is the shoulder's height over tan(angle), so a tiny
  // positive angle (1e-320, found by the catalogue fuzzer) gave an infinite profile point.
  // API tapers are 18 deg; at 1 deg a 5" joint's taper would be 1.2 m.
  if (!(d.elevator_taper_deg >= 1.0 && d.elevator_taper_deg < 90.0))
    fail(where, ": field elevator_taper_deg = ", d.elevator_taper_deg,
         " must be >= 1 and < 90 (deg)");
  // a < b, naming both fields.
  auto less = [&](double a, const char* a_name, double b, const char* b_name) {
    if (!(a < b)) fail(where, ": field ", a_name, " = ", a, " must be < ", b_name, " = ", b);
  };
  less(d.tube_id, "tube_id", d.tube_od, "tube_od");
  less(d.tool_joint_id, "tool_joint_id", d.tool_joint_od, "tool_joint_od");
  less(d.tube_od, "tube_od", d.tool_joint_od, "tool_joint_od");
  less(d.pin_large_diameter, "pin_large_diameter", d.tool_joint_od, "tool_joint_od");
  const double pin_small = d.pin_large_diameter - d.pin_length * d.pin_taper;
  if (!(pin_small > d.tool_joint_id))
    fail(where, ": field tool_joint_id = ", d.tool_joint_id,
         " must be < the pin cone's small end (pin_large_diameter - pin_length * pin_taper = ",
         pin_small, ")");
  if (!(d.box_counterbore_diameter > d.pin_large_diameter))
    fail(where, ": field box_counterbore_diameter = ", d.box_counterbore_diameter,
         " must be > pin_large_diameter = ", d.pin_large_diameter, " (the pin enters the box)");
  less(d.box_counterbore_diameter, "box_counterbore_diameter", d.tool_joint_od, "tool_joint_od");
}

std::vector<ProfilePoint> toolJointProfile(EndLabel end, const ToolJointDimensions& d) {
  validateDimensions(d, "tool joint dimensions");
  const double R = d.tool_joint_od / 2, Rt = d.tube_od / 2, Rit = d.tube_id / 2;
  const double Rij = d.tool_joint_id / 2, Lt = d.taperLength();
  std::vector<ProfilePoint> p;
  if (end == EndLabel::kBoxEnd) {
    // End face at z = 0, body toward -z. Counter-clockwise in (z, r): end face outward, down the
    // outside, across the cut tube, up the bore, out through the threaded cone.
    const double Lb = d.box_tong_length, zb = -(Lb + Lt + d.tube_length);
    const double Rc = d.box_counterbore_diameter / 2, cb = 0.0159;  // 5/8" counterbore depth
    const double r_large = d.pin_large_diameter / 2 + 0.0005;       // thread cone at its mouth
    const double r_small = r_large - (d.box_thread_depth - cb) * d.pin_taper / 2;
    p = {{0, Rc},
         {0, R},
         {-Lb, R},
         {-Lb - Lt, Rt},
         {zb, Rt},
         {zb, Rit},
         {-Lb - Lt, Rit},
         {-Lb - Lt, Rij},
         {-d.box_thread_depth, Rij},
         {-d.box_thread_depth, r_small},
         {-cb, r_large},
         {-cb, Rc}};
    return p;
  }
  // Pin: shoulder at z = 0, pin cone toward +z (nose at z = pin_length), tong toward -z.
  const double Lp = d.pin_length, Lpt = d.pin_tong_length, zb = -(Lpt + Lt + d.tube_length);
  const double Rl = d.pin_large_diameter / 2, Rs = Rl - Lp * d.pin_taper / 2;
  p.push_back({Lp, Rij});
  p.push_back({Lp, Rs});
  if (d.threads) {
    // V threads below the cone (crests on the nominal cone), from the nose to the shoulder.
    const double half_pitch = 0.0254 / d.threads_per_inch / 2;
    bool root = true;
    for (double z = Lp - half_pitch; z > half_pitch; z -= half_pitch, root = !root)
      p.push_back({z, Rl - z * d.pin_taper / 2 - (root ? d.thread_height : 0.0)});
  }
  const std::vector<ProfilePoint> rest = {{0, Rl},  {0, R},    {-Lpt, R},        {-Lpt - Lt, Rt},
                                          {zb, Rt}, {zb, Rit}, {-Lpt - Lt, Rit}, {-Lpt - Lt, Rij}};
  p.insert(p.end(), rest.begin(), rest.end());
  return p;
}

Eigen::Vector2d profileNormal(const ProfilePoint& a, const ProfilePoint& b) {
  const Eigen::Vector2d n(b.r - a.r, -(b.z - a.z));
  return n.normalized();
}

std::vector<OrientedPoint> sampleProfileSurface(const std::vector<ProfilePoint>& profile,
                                                double spacing, uint32_t seed, bool outer_only) {
  if (!(spacing > 0.0)) fail("sampleProfileSurface: spacing = ", spacing, " must be > 0");
  std::vector<OrientedPoint> out;
  // A deterministic quasi-uniform grid: rings along each edge every `spacing`, points around each
  // ring every `spacing`, each ring rotated by a golden-ratio step (seeded) so rings don't align.
  const double golden = 0.6180339887498949;
  double phase = std::fmod(seed * golden, 1.0);
  for (size_t i = 0; i < profile.size(); ++i) {
    const ProfilePoint& a = profile[i];
    const ProfilePoint& b = profile[(i + 1) % profile.size()];
    const Eigen::Vector2d n = profileNormal(a, b);  // (nz, nr)
    if (outer_only && n.y() < -1e-9) continue;      // faces the axis: a bore
    const double len = std::hypot(b.z - a.z, b.r - a.r);
    const int rings = std::max(1, static_cast<int>(std::round(len / spacing)));
    for (int k = 0; k < rings; ++k) {
      const double s = (k + 0.5) / rings;
      const double z = a.z + s * (b.z - a.z), r = a.r + s * (b.r - a.r);
      const int around = std::max(3, static_cast<int>(std::round(2 * M_PI * r / spacing)));
      phase = std::fmod(phase + golden, 1.0);
      for (int j = 0; j < around; ++j) {
        const double phi = 2 * M_PI * (j + phase) / around;
        const double c = std::cos(phi), sn = std::sin(phi);
        out.push_back(
            {Eigen::Vector3f(r * c, r * sn, z), Eigen::Vector3f(n.y() * c, n.y() * sn, n.x())});
      }
    }
  }
  return out;
}

TriangleMesh revolveProfile(const std::vector<ProfilePoint>& profile, int segments) {
  if (segments < 3) fail("revolveProfile: segments = ", segments, " must be >= 3");
  TriangleMesh m;
  const int np = static_cast<int>(profile.size());
  for (const auto& q : profile)
    for (int j = 0; j < segments; ++j) {
      const double phi = 2 * M_PI * j / segments;
      m.vertices.emplace_back(q.r * std::cos(phi), q.r * std::sin(phi), q.z);
    }
  auto idx = [&](int i, int j) { return (i % np) * segments + (j % segments); };
  for (int i = 0; i < np; ++i) {
    const Eigen::Vector2d n = profileNormal(profile[i], profile[(i + 1) % np]);
    for (int j = 0; j < segments; ++j) {
      Eigen::Vector3i t1(idx(i, j), idx(i + 1, j), idx(i + 1, j + 1));
      Eigen::Vector3i t2(idx(i, j), idx(i + 1, j + 1), idx(i, j + 1));
      // Orient each triangle so that its normal agrees with the analytic outward normal.
      const double phi = 2 * M_PI * (j + 0.5) / segments;
      const Eigen::Vector3f expected(n.y() * std::cos(phi), n.y() * std::sin(phi), n.x());
      for (Eigen::Vector3i* t : {&t1, &t2}) {
        const Eigen::Vector3f& A = m.vertices[(*t)[0]];
        const Eigen::Vector3f& B = m.vertices[(*t)[1]];
        const Eigen::Vector3f& C = m.vertices[(*t)[2]];
        const Eigen::Vector3f tn = (B - A).cross(C - A);
        if (tn.squaredNorm() < 1e-20f) continue;  // degenerate (never for r > 0)
        if (tn.dot(expected) < 0) std::swap((*t)[1], (*t)[2]);
        m.triangles.push_back(*t);
      }
    }
  }
  return m;
}

void writeStl(const TriangleMesh& mesh, const std::string& path) {
  std::ofstream f(path, std::ios::binary);
  if (!f) fail("cannot open '", path, "' for writing");
  char header[80] = "drill_pipe_pose tool joint model [m]";
  f.write(header, 80);
  const uint32_t n = static_cast<uint32_t>(mesh.triangles.size());
  f.write(reinterpret_cast<const char*>(&n), 4);
  for (const auto& t : mesh.triangles) {
    const Eigen::Vector3f &A = mesh.vertices[t[0]], &B = mesh.vertices[t[1]],
                          &C = mesh.vertices[t[2]];
    const Eigen::Vector3f nn = (B - A).cross(C - A).normalized();
    for (const Eigen::Vector3f* v : {&nn, &A, &B, &C})
      f.write(reinterpret_cast<const char*>(v->data()), 12);
    const uint16_t attr = 0;
    f.write(reinterpret_cast<const char*>(&attr), 2);
  }
  if (!f) fail("writing '", path, "' failed");
}

}  // namespace drill_pipe_pose
