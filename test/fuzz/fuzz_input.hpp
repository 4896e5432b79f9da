#pragma once
// Structured fuzz input: a reader that turns arbitrary bytes into typed values (the harnesses
// build messages and tensors from it) and the matching writer (the seed generator encodes real
// frames with it, so that the seed corpus starts from inputs the code accepts).
//
// The reader never fails: past the end every read returns zeros, so every byte string is a valid
// input and a mutated seed still decodes field by field. Numbers that matter for edge cases are
// "coded": a selector byte picks one of a few special values (NaN, inf, 0, 20000 px, UINT32_MAX,
// ...) or says that the raw value follows. A mutation of one selector byte thus turns a sane
// focal length into NaN or a sane width into 20000, which raw random bytes would hardly ever do.
//
// Coding (reader and writer agree; the writer always writes "raw follows"):
//   f64 / f32: selector u8; < kSpecials: the special value, else the raw IEEE value (8 / 4 bytes)
//   dim (u32): selector u8; < kDims: a special size, else the raw little-endian u32
//   text:      selector u8; < known.size(): that known string, else length u8 + bytes
//   raw ints:  little-endian, zero-filled past the end

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

namespace drill_pipe_pose::fuzz {

/// Special doubles: every class of value the validation code must handle.
inline const std::vector<double>& specialDoubles() {
  static const std::vector<double> v = {0.0,
                                        -0.0,
                                        1.0,
                                        -1.0,
                                        std::numeric_limits<double>::quiet_NaN(),
                                        std::numeric_limits<double>::infinity(),
                                        -std::numeric_limits<double>::infinity(),
                                        std::numeric_limits<double>::min(),
                                        std::numeric_limits<double>::denorm_min(),
                                        std::numeric_limits<double>::max(),
                                        -std::numeric_limits<double>::max(),
                                        1e-9,
                                        1e9,
                                        0.5,
                                        365.4,
                                        256.0};
  return v;
}

/// Special sizes [px]: empty, 1x1, Kinect v2 SD / QHD, the 20000 px of a corrupt header, limits.
inline const std::vector<uint32_t>& specialDims() {
  static const std::vector<uint32_t> v = {0u,     1u,     2u,          3u,          16u,
                                          424u,   512u,   960u,        20000u,      65535u,
                                          65536u, 1u << 31, 0xFFFFFFFFu};
  return v;
}

/// Selector byte that means "the raw value follows" (any value >= the special table's size).
constexpr uint8_t kRawFollows = 0xFF;

class FuzzReader {
 public:
  FuzzReader(const uint8_t* data, size_t size) : data_(data), size_(size) {}

  size_t remaining() const { return pos_ < size_ ? size_ - pos_ : 0; }
  bool exhausted() const { return remaining() == 0; }

  /// Copies n bytes into out, zero-filled past the end.
  void read(void* out, size_t n) {
    const size_t k = std::min(n, remaining());
    if (k) std::memcpy(out, data_ + pos_, k);
    if (n > k) std::memset(static_cast<uint8_t*>(out) + k, 0, n - k);
    pos_ += k;
  }
  template <class T>
  T raw() {
    T v;
    read(&v, sizeof v);
    return v;
  }
  uint8_t u8() { return raw<uint8_t>(); }
  uint16_t u16() { return raw<uint16_t>(); }
  uint32_t u32() { return raw<uint32_t>(); }
  uint64_t u64() { return raw<uint64_t>(); }

  double f64() {
    const uint8_t s = u8();
    const auto& sp = specialDoubles();
    return s < sp.size() ? sp[s] : raw<double>();
  }
  float f32() {
    const uint8_t s = u8();
    const auto& sp = specialDoubles();
    return s < sp.size() ? static_cast<float>(sp[s]) : raw<float>();
  }
  uint32_t dim() {
    const uint8_t s = u8();
    const auto& sp = specialDims();
    return s < sp.size() ? sp[s] : u32();
  }
  std::string text(const std::vector<std::string>& known) {
    const uint8_t s = u8();
    if (s < known.size()) return known[s];
    std::string t(u8(), '\0');
    read(t.data(), t.size());
    return t;
  }
  /// n bytes (zero-filled past the end).
  std::vector<uint8_t> bytes(size_t n) {
    std::vector<uint8_t> b(n);
    read(b.data(), n);
    return b;
  }

 private:
  const uint8_t* data_;
  size_t size_;
  size_t pos_ = 0;
};

/// Writes what FuzzReader reads (always the "raw follows" form of coded values).
class FuzzWriter {
 public:
  void write(const void* p, size_t n) {
    const auto* b = static_cast<const uint8_t*>(p);
    out_.insert(out_.end(), b, b + n);
  }
  template <class T>
  void raw(const T& v) {
    write(&v, sizeof v);
  }
  void u8(uint8_t v) { raw(v); }
  void u16(uint16_t v) { raw(v); }
  void u32(uint32_t v) { raw(v); }
  void u64(uint64_t v) { raw(v); }
  void f64(double v) {
    u8(kRawFollows);
    raw(v);
  }
  void f32(float v) {
    u8(kRawFollows);
    raw(v);
  }
  void dim(uint32_t v) {
    u8(kRawFollows);
    u32(v);
  }
  /// A string of at most 255 bytes, written raw.
  void text(const std::string& s) {
    u8(kRawFollows);
    const size_t n = std::min<size_t>(s.size(), 255);
    u8(static_cast<uint8_t>(n));
    write(s.data(), n);
  }
  const std::vector<uint8_t>& bytes() const { return out_; }

 private:
  std::vector<uint8_t> out_;
};

}  // namespace drill_pipe_pose::fuzz
