// The ray-against-revolved-profile primitive shared by the renderer and the estimator.
#include <gtest/gtest.h>

#include <cmath>

#include "drill_pipe_pose/core/revolved_ray.hpp"

using namespace drill_pipe_pose;

TEST(RevolvedRay, CylinderConeAndAnnulus) {
  // A cylinder r = 0.1 for z in [0, 1], hit from the side along -x.
  const RevolvedEdge cyl = RevolvedEdge::fromSegment(0.0, 0.1, 1.0, 0.1);
  EXPECT_FALSE(cyl.annulus);
  double t = 0;
  const RevolvedRay side(Eigen::Vector3d(1, 0, 0.5), Eigen::Vector3d(-1, 0, 0));
  ASSERT_TRUE(cyl.firstHit(side, 0.0, 10.0, 0.0, &t));
  EXPECT_NEAR(t, 0.9, 1e-12);
  EXPECT_FALSE(cyl.firstHit(side, 0.0, 0.5, 0.0, &t)) << "beyond t_max";
  // Outside the z range: a miss, unless eps widens it.
  const RevolvedRay above(Eigen::Vector3d(1, 0, 1.0 + 1e-4), Eigen::Vector3d(-1, 0, 0));
  EXPECT_FALSE(cyl.firstHit(above, 0.0, 10.0, 0.0, &t));
  EXPECT_TRUE(cyl.firstHit(above, 0.0, 10.0, 1e-3, &t));
  // A cone r = z (45 deg) for z in [0.1, 0.2]: a ray down the axis offset by 0.15 meets it at
  // z = 0.15; the other nappe (negative r) is never hit.
  const RevolvedEdge cone = RevolvedEdge::fromSegment(0.1, 0.1, 0.2, 0.2);
  const RevolvedRay down(Eigen::Vector3d(0.15, 0, 1), Eigen::Vector3d(0, 0, -1));
  ASSERT_TRUE(cone.firstHit(down, 0.0, 10.0, 0.0, &t));
  EXPECT_NEAR(1.0 - t, 0.15, 1e-12);
  // An annulus at z = 0 between r 0.05 and 0.1: a ray down at r = 0.07 hits, at 0.02 misses.
  const RevolvedEdge ring = RevolvedEdge::fromSegment(0.0, 0.05, 0.0, 0.1);
  EXPECT_TRUE(ring.annulus);
  EXPECT_TRUE(ring.firstHit(RevolvedRay(Eigen::Vector3d(0.07, 0, 1), Eigen::Vector3d(0, 0, -2)),
                            0.0, 10.0, 0.0, &t));
  EXPECT_NEAR(t, 0.5, 1e-12) << "d need not be unit";
  EXPECT_FALSE(ring.firstHit(RevolvedRay(Eigen::Vector3d(0.02, 0, 1), Eigen::Vector3d(0, 0, -1)),
                             0.0, 10.0, 0.0, &t));
  // Parallel to the annulus's plane: no hit.
  EXPECT_FALSE(ring.firstHit(RevolvedRay(Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(-1, 0, 0)), 0.0,
                             10.0, 0.0, &t));
}
