// Cycle forming over unsynchronised cameras: complete cycles, dead / late / rejoining cameras.
#include <gtest/gtest.h>

#include <random>

#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/core/frame_sync.hpp"

using namespace drill_pipe_pose;

namespace {

struct Event {
  double arrival;
  std::string cam;
  int64_t stamp_ns;
};

// Frames of `cams` at 30 Hz with per-camera phase, jitter and transport delay, in arrival order.
std::vector<Event> schedule(const std::vector<std::string>& cams, double t0, double t1,
                            unsigned seed, const std::string& dead = "", double dead_from = 1e9,
                            double dead_until = 1e9) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> phase(0, 1 / 30.0), jitter(-0.001, 0.001),
      delay(0.003, 0.012);
  std::vector<Event> ev;
  for (const auto& c : cams) {
    const double ph = phase(rng);
    for (double t = t0 + ph; t < t1; t += 1 / 30.0) {
      if (c == dead && t >= dead_from && t < dead_until) continue;
      const double cap = t + jitter(rng);
      ev.push_back({cap + delay(rng), c, static_cast<int64_t>(cap * 1e9)});
    }
  }
  std::sort(ev.begin(), ev.end(),
            [](const Event& a, const Event& b) { return a.arrival < b.arrival; });
  return ev;
}

// Feeds events, polling after each and every 5 ms; returns the cycles.
std::vector<FrameSynchronizer::Cycle> run(FrameSynchronizer& sync, const std::vector<Event>& ev) {
  std::vector<FrameSynchronizer::Cycle> cycles;
  uint64_t id = 0;
  double next_tick = ev.empty() ? 0 : ev.front().arrival;
  for (const auto& e : ev) {
    while (next_tick < e.arrival) {
      for (auto& c : sync.poll(next_tick)) cycles.push_back(c);
      next_tick += 0.005;
    }
    sync.add(e.cam, e.stamp_ns, e.arrival, id++);
    for (auto& c : sync.poll(e.arrival)) cycles.push_back(c);
  }
  return cycles;
}

const std::vector<std::string> kCams = {"cam1", "cam2", "cam3", "cam4", "cam5", "cam6"};

}  // namespace

TEST(FrameSync, SixUnsynchronisedCamerasGiveOneCompleteCyclePerPeriod) {
  const unsigned seed = 5;
  FrameSynchronizer sync(kCams, FrameSyncConfig());
  const auto cycles = run(sync, schedule(kCams, 100.0, 110.0, seed));
  // ~30 cycles per second, nearly all with all six cameras.
  EXPECT_NEAR(static_cast<double>(cycles.size()), 300.0, 3.0) << "seed " << seed;
  size_t full = 0;
  for (const auto& c : cycles) full += c.frames.size() == 6;
  EXPECT_GE(full, cycles.size() - 3) << "seed " << seed;
  for (size_t i = 1; i < cycles.size(); ++i) EXPECT_GT(cycles[i].stamp_ns, cycles[i - 1].stamp_ns);
  for (const auto& [cam, st] : sync.stats()) EXPECT_GE(st.used, st.received - 3) << cam;
}

TEST(FrameSync, DeadCameraNeverStallsAndRejoins) {
  const unsigned seed = 9;
  FrameSyncConfig cfg;
  cfg.camera_timeout = 0.5;
  FrameSynchronizer sync(kCams, cfg);
  // cam3 is silent from t = 102 s to t = 105 s.
  const auto cycles = run(sync, schedule(kCams, 100.0, 108.0, seed, "cam3", 102.0, 105.0));
  EXPECT_NEAR(static_cast<double>(cycles.size()), 240.0, 4.0) << "seed " << seed;
  size_t without = 0;
  for (const auto& c : cycles) {
    const double t = c.stamp_ns * 1e-9;
    bool has3 = false;
    for (const auto& f : c.frames) has3 |= f.first == "cam3";
    if (t > 102.05 && t < 104.95) {
      EXPECT_FALSE(has3);
      EXPECT_EQ(c.frames.size(), 5u);
      ++without;
    }
    if (t > 105.2) {
      EXPECT_TRUE(has3) << "cam3 did not rejoin at t = " << t;
    }
  }
  EXPECT_GT(without, 80u);
}

TEST(FrameSync, CamerasDeadFromTheStartHoldNoCycle) {
  // cam5 and cam6 never send a frame: after the first cycle (which waits max_wait for them),
  // every cycle closes complete as soon as the four live cameras contributed, not by timeout.
  const unsigned seed = 11;
  FrameSyncConfig cfg;
  cfg.camera_timeout = 1.0;
  FrameSynchronizer sync(kCams, cfg);
  const std::vector<std::string> four(kCams.begin(), kCams.begin() + 4);
  const auto cycles = run(sync, schedule(four, 100.0, 102.0, seed));
  ASSERT_GT(cycles.size(), 50u) << "seed " << seed;
  size_t waited = 0;
  for (size_t i = 1; i < cycles.size(); ++i) waited += !cycles[i].complete;
  EXPECT_LE(waited, 1u) << "cycles closed by max_wait after the first (seed " << seed << ")";
  EXPECT_EQ(sync.liveCameras(), four) << "seed " << seed;
}

TEST(FrameSync, OneCameraWorks) {
  FrameSynchronizer sync({"cam1"}, FrameSyncConfig());
  const auto cycles = run(sync, schedule({"cam1"}, 0.0, 2.0, 1));
  EXPECT_NEAR(static_cast<double>(cycles.size()), 60.0, 1.0);
  for (const auto& c : cycles) EXPECT_TRUE(c.complete);
}

TEST(FrameSync, LateFramesAreCountedNotUsed) {
  FrameSyncConfig cfg;
  cfg.max_wait = 0.02;
  FrameSynchronizer sync({"a", "b"}, cfg);
  sync.add("a", 1000000000, 1.0, 1);
  EXPECT_TRUE(sync.poll(1.001).empty());  // waits for b
  auto cycles = sync.poll(1.03);          // max_wait passed: closes with a alone
  ASSERT_EQ(cycles.size(), 1u);
  EXPECT_EQ(cycles[0].frames.size(), 1u);
  // b, never heard, left the fusion at max_wait: the cycle holds every live camera.
  EXPECT_TRUE(cycles[0].complete);
  EXPECT_EQ(sync.liveCameras(), std::vector<std::string>{"a"});
  EXPECT_FALSE(sync.add("b", 999000000, 1.04, 2));  // older than the closed cycle
  EXPECT_EQ(sync.stats().at("b").dropped_stale, 1u);
  EXPECT_EQ(sync.takeDropped(), std::vector<uint64_t>{2});
  // After a clock jump back (looped bag), reset accepts old stamps again.
  sync.reset();
  EXPECT_TRUE(sync.add("a", 500000000, 2.5, 3));
  // ... and waits for every camera again, even b, silent for more than camera_timeout (1 s).
  EXPECT_TRUE(sync.poll(2.51).empty()) << "the first cycle after a reset must wait for b";
  EXPECT_TRUE(sync.add("b", 510000000, 2.511, 4));
  cycles = sync.poll(2.512);
  ASSERT_EQ(cycles.size(), 1u);
  EXPECT_TRUE(cycles[0].complete);
  EXPECT_EQ(cycles[0].frames.size(), 2u);
}

TEST(FrameSync, BadConfigurationIsNamed) {
  EXPECT_THROW(FrameSynchronizer({}, FrameSyncConfig()), InputError);
  EXPECT_THROW(FrameSynchronizer({"a", "a"}, FrameSyncConfig()), InputError);
  FrameSyncConfig cfg;
  cfg.window = 0;
  EXPECT_THROW(FrameSynchronizer({"a"}, cfg), InputError);
}

// The sensor nodes' rate limit: the first frame of each 1/max_rate slot of capture time, so that
// cameras with different phases (here 0 and 21 ms) and start times pick frames of the same slot.
// A node that starts mid-slot takes its first frame at once, then the first of every slot (a limit
// counted from its own last frame would stay mid-slot).
TEST(FrameSync, RateLimitOnASharedCaptureTimeGrid) {
  const double rate = 2.0;  // slots [k/2, (k+1)/2) s
  for (const int64_t phase_ns : {int64_t{0}, int64_t{21000000}}) {
    SCOPED_TRACE("phase " + std::to_string(phase_ns) + " ns");
    std::vector<int64_t> taken;
    int64_t last = 0;
    for (int k = 5; k < 66; ++k) {  // 30 Hz, starting 0.167 s into the slot [1.0, 1.5)
      const int64_t stamp = 1000000000 + k * 33333333LL + phase_ns;
      if (takeFrameAtRate(stamp, last, rate)) {
        taken.push_back(stamp);
        last = stamp;
      }
    }
    ASSERT_EQ(taken.size(), 5u);  // slots 2 (its first frame seen), 3, 4, 5, 6
    for (size_t i = 1; i < taken.size(); ++i) {
      const double t = static_cast<double>(taken[i]) * 1e-9;
      EXPECT_EQ(std::floor(t * rate), 2.0 + static_cast<double>(i)) << t;
      EXPECT_LT(t - std::floor(t * rate) / rate, 1.0 / 30.0) << "not the slot's first frame";
    }
  }
  EXPECT_TRUE(takeFrameAtRate(1000000000, 0, rate));            // first frame
  EXPECT_TRUE(takeFrameAtRate(1100000000, 1000000000, 0.0));    // no limit
  EXPECT_TRUE(takeFrameAtRate(500000000, 1000000000, rate));    // time went back (bag loop)
  EXPECT_FALSE(takeFrameAtRate(1400000000, 1000000000, rate));  // same slot
}
