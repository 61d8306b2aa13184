#pragma once
// Checkpoints of a run (docs/run-outputs.md, "Checkpoints and resuming"): everything a step depends
// on and the run so far, at a frame boundary, in binary (doubles bit for bit), so that a run
// continued from one gives the same bits as a run never stopped.
//
// File layout (little-endian): "WEFTCKPT", format version (u32), header length (u64) and
// header (JSON text: what the caller needs to rebuild the Simulation, such as the scene's
// path and hash and the command's options), then the body (Simulation::save, the run so
// far), then an FNV-1a hash (u64) of every byte before it.
#include <algorithm>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "weft/simulation.hpp"
#include "weft/types.hpp"

namespace weft {

constexpr std::uint32_t kCheckpointFormatVersion = 11;


/// Appends values in binary to a byte string.
class BinaryWriter {
 public:
  void u64(std::uint64_t v) { raw(&v, sizeof v); }
  void i64(std::int64_t v) { raw(&v, sizeof v); }
  void f64(double v) { raw(&v, sizeof v); }
  void text(const std::string& s) {
    u64(s.size());
    raw(s.data(), s.size());
  }
  void doubles(const double* p, size_t n) {
    u64(n);
    raw(p, n * sizeof(double));
  }
  void vec(const VecX& v) { doubles(v.data(), static_cast<size_t>(v.size())); }
  void mat(const MatX& m) {
    i64(m.rows());
    i64(m.cols());
    raw(m.data(), static_cast<size_t>(m.size()) * sizeof(double));
  }
  void raw(const void* p, size_t n) { bytes_.append(static_cast<const char*>(p), n); }
  const std::string& bytes() const { return bytes_; }

 private:
  std::string bytes_;
};

/// Reads what BinaryWriter wrote; throws InputError naming `source` when the bytes run out or
/// a size is implausible.
class BinaryReader {
 public:
  BinaryReader(const std::string& bytes, std::string source, size_t begin = 0, size_t end = std::string::npos)
      : bytes_(bytes), source_(std::move(source)), pos_(begin), end_(std::min(end, bytes.size())) {}
  std::uint64_t u64() { return value<std::uint64_t>(); }
  std::int64_t i64() { return value<std::int64_t>(); }
  double f64() { return value<double>(); }
  std::string text();
  std::vector<double> doubles();
  VecX vec();
  MatX mat();
  void raw(void* p, size_t n);
  size_t position() const { return pos_; }
  bool at_end() const { return pos_ == end_; }
  /// Throws InputError naming the source: "SOURCE: " + what.
  [[noreturn]] void fail(const std::string& what) const;

 private:
  template <class T>
  T value() {
    T v;
    raw(&v, sizeof v);
    return v;
  }
  size_t count(size_t element_size);  ///< a u64 count whose elements fit in what is left
  const std::string& bytes_;
  std::string source_;
  size_t pos_, end_;
};

}  // namespace weft
