#include "sim/checkpoint.hpp"

#include <cstring>

#include "weft/error.hpp"

namespace weft {

std::uint64_t fnv1a(const void* data, size_t size, std::uint64_t hash) {
  const auto* p = static_cast<const unsigned char*>(data);
  for (size_t i = 0; i < size; ++i) {
    hash ^= p[i];
    hash *= 0x100000001b3ull;
  }
  return hash;
}

void BinaryReader::fail(const std::string& what) const { throw InputError(source_ + ": " + what); }

void BinaryReader::raw(void* p, size_t n) {
  if (n > end_ - pos_) fail("checkpoint is truncated (needed " + std::to_string(n) + " more bytes at byte " +
                            std::to_string(pos_) + ")");
  if (n == 0) return;  // p may be an empty vector's null data(), which memcpy must not get
  std::memcpy(p, bytes_.data() + pos_, n);
  pos_ += n;
}

size_t BinaryReader::count(size_t element_size) {
  const std::uint64_t n = u64();
  if (n > (end_ - pos_) / element_size) fail("checkpoint is damaged (a count of " + std::to_string(n) + " at byte " +
                                             std::to_string(pos_ - 8) + " exceeds the file)");
  return static_cast<size_t>(n);
}

std::string BinaryReader::text() {
  std::string s(count(1), '\0');
  raw(s.data(), s.size());
  return s;
}

std::vector<double> BinaryReader::doubles() {
  std::vector<double> v(count(sizeof(double)));
  raw(v.data(), v.size() * sizeof(double));
  return v;
}

VecX BinaryReader::vec() {
  VecX v(static_cast<Eigen::Index>(count(sizeof(double))));
  raw(v.data(), static_cast<size_t>(v.size()) * sizeof(double));
  return v;
}

MatX BinaryReader::mat() {
  const std::int64_t rows = i64(), cols = i64();
  if (rows < 0 || cols < 0 || (rows > 0 && static_cast<std::uint64_t>(cols) > (end_ - pos_) / 8 / rows))
    fail("checkpoint is damaged (a " + std::to_string(rows) + " x " + std::to_string(cols) + " matrix at byte " +
         std::to_string(pos_ - 16) + " exceeds the file)");
  MatX m(rows, cols);
  raw(m.data(), static_cast<size_t>(m.size()) * sizeof(double));
  return m;
}

}  // namespace weft
