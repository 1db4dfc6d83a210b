#pragma once
// Little helpers for the binary files (model, key frames): values appended to
// and read from a byte buffer in the machine's byte order, arrays prefixed by
// a uint32 element count. The reader checks every length against what is left,
// so a truncated or damaged file is a false return, never a read past the end.

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <vector>

namespace relocalizer {

class ByteWriter {
 public:
  explicit ByteWriter(std::vector<uint8_t>& out) : out_(out) {}
  void bytes(const void* data, size_t n) {
    const auto* p = static_cast<const uint8_t*>(data);
    out_.insert(out_.end(), p, p + n);
  }
  template <typename T>
  void value(const T& v) {
    bytes(&v, sizeof(T));
  }
  template <typename T>
  void array(const std::vector<T>& v) {
    value(static_cast<uint32_t>(v.size()));
    bytes(v.data(), v.size() * sizeof(T));
  }

 private:
  std::vector<uint8_t>& out_;
};

class ByteReader {
 public:
  ByteReader(const uint8_t* data, size_t size) : data_(data), size_(size) {}
  bool bytes(void* out, size_t n) {
    if (n > size_ - offset_) return false;
    if (n == 0) return true;  // `out` may be null (an empty vector's data())
    std::memcpy(out, data_ + offset_, n);
    offset_ += n;
    return true;
  }
  template <typename T>
  bool value(T& v) {
    return bytes(&v, sizeof(T));
  }
  template <typename T>
  bool array(std::vector<T>& v) {
    uint32_t n = 0;
    if (!value(n) || static_cast<size_t>(n) * sizeof(T) > size_ - offset_) return false;
    v.resize(n);
    return bytes(v.data(), n * sizeof(T));
  }
  size_t remaining() const { return size_ - offset_; }
  const uint8_t* position() const { return data_ + offset_; }
  void skip(size_t n) { offset_ += std::min(n, remaining()); }

 private:
  const uint8_t* data_;
  size_t size_;
  size_t offset_ = 0;
};

}  // namespace relocalizer
