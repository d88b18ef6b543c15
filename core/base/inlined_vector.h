// InlinedVector<T, N>: a vector of trivially copyable T that keeps up to N entries inside the
// object and only larger sizes on the heap. For the per-factor index arrays that the solver
// reads for every factor it touches (a linearised factor's block offsets, its variable ids):
// nearly every factor has one to three keys, and a separate heap block per factor would be one
// more cache miss each time one is read.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <span>
#include <type_traits>
#include <utility>

namespace slamd::core {

template <typename T, int N>
class InlinedVector {
  static_assert(std::is_trivially_copyable_v<T>);

 public:
  InlinedVector() = default;
  explicit InlinedVector(std::size_t n) { resize(n); }  // entries unset, as resize()
  InlinedVector(const InlinedVector& other) { *this = other; }
  InlinedVector& operator=(const InlinedVector& other) {
    if (this != &other) {
      resize(other.size_);
      std::copy(other.data(), other.data() + other.size_, data());
    }
    return *this;
  }
  InlinedVector(InlinedVector&& other) noexcept { *this = std::move(other); }
  InlinedVector& operator=(InlinedVector&& other) noexcept {
    if (this != &other) {
      Free();
      if (other.capacity_ > 0) {
        heap_ = other.heap_;
      } else {
        std::copy(other.inline_, other.inline_ + other.size_, inline_);
      }
      capacity_ = std::exchange(other.capacity_, 0u);
      size_ = std::exchange(other.size_, 0u);
    }
    return *this;
  }
  ~InlinedVector() { Free(); }

  // Sets the size and leaves EVERY entry unset (unlike std::vector: callers overwrite them all).
  // Keeps the heap block when shrinking, so an object reused for a factor no larger than before
  // allocates nothing.
  void resize(std::size_t n) {
    if (n > (capacity_ > 0 ? capacity_ : static_cast<std::size_t>(N))) {
      Free();
      heap_ = new T[n];
      capacity_ = static_cast<std::uint32_t>(n);
    }
    size_ = static_cast<std::uint32_t>(n);
  }
  void assign(std::span<const T> values) {
    resize(values.size());
    std::copy(values.begin(), values.end(), data());
  }

  std::size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }
  // Bytes allocated outside the object (0 while the entries fit inline).
  std::size_t HeapBytes() const { return static_cast<std::size_t>(capacity_) * sizeof(T); }
  T* data() { return capacity_ > 0 ? heap_ : inline_; }
  const T* data() const { return capacity_ > 0 ? heap_ : inline_; }
  T& operator[](std::size_t i) { return data()[i]; }
  const T& operator[](std::size_t i) const { return data()[i]; }
  const T* begin() const { return data(); }
  const T* end() const { return data() + size_; }
  const T& back() const { return data()[size_ - 1]; }

 private:
  void Free() {
    if (capacity_ > 0) delete[] heap_;
    capacity_ = 0;
  }

  // The entries live in inline_ until a size beyond N moves them to heap_, which then stays (a
  // union: the pointer takes no room of its own beside the inline entries).
  union {
    T inline_[N] = {};
    T* heap_;
  };
  std::uint32_t capacity_ = 0;  // of heap_; 0 while the entries are inline
  std::uint32_t size_ = 0;
};

}  // namespace slamd::core
