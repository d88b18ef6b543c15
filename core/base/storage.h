// Reusing vector storage without letting it grow without bound.
#pragma once

#include <algorithm>
#include <cstddef>
#include <memory>
#include <new>
#include <utility>
#include <vector>

namespace slamd::core {

// An allocator whose value-less construct() default-initialises: resize() of a vector of
// doubles leaves the new entries unspecified instead of zeroing them. For buffers that are
// overwritten completely after every resize (a re-eliminated clique's matrices), where the
// zeroing was a memset of every re-eliminated clique's storage on each update.
template <typename T>
struct DefaultInitAllocator : std::allocator<T> {
  template <typename U>
  struct rebind {
    using other = DefaultInitAllocator<U>;
  };
  using std::allocator<T>::allocator;
  template <typename U>
  void construct(U* p) noexcept(noexcept(::new (static_cast<void*>(p)) U)) {
    ::new (static_cast<void*>(p)) U;
  }
  template <typename U, typename... Args>
  void construct(U* p, Args&&... args) {
    std::allocator_traits<std::allocator<T>>::construct(static_cast<std::allocator<T>&>(*this), p,
                                                        std::forward<Args>(args)...);
  }
};

template <typename T>
using UninitVector = std::vector<T, DefaultInitAllocator<T>>;

namespace internal {

// Storage is given back when it is more than 1.25x (and 512 bytes) larger than needed. Objects
// recycled through free lists (Bayes tree cliques) would otherwise keep the largest size they
// ever had: after a run on a 3500-pose graph that was 100+ MB of capacity for 15 MB of live data.
// With 4x and 8 KiB, most cliques of a 2D pose graph (a cached factor of a few KiB) never gave
// any back: the tree in use held 2.4x what it needed (input_M3500 peak RSS 40.6 MB, 33.8 at 2x;
// 1.25x instead of 2x: 0.27 MB less in use at its end, the time the same: reallocating is rare
// next to the elimination's own work).
template <typename T, typename A>
bool TooLarge(const std::vector<T, A>& v, std::size_t n) {
  constexpr std::size_t kSlackBytes = 512;
  return v.capacity() > n + n / 4 && v.capacity() * sizeof(T) > kSlackBytes;
}

}  // namespace internal

// *v = n copies of `value`, reusing v's allocation unless it is too large (see above).
template <typename T, typename A>
void AssignReusingStorage(std::vector<T, A>* v, std::size_t n, const T& value) {
  if (internal::TooLarge(*v, n)) {
    std::vector<T, A>(n, value).swap(*v);
  } else {
    v->assign(n, value);
  }
}

// *v resized to n entries of unspecified value (nothing is copied or zeroed), reusing v's
// allocation unless it is too large (see above).
template <typename T>
void ResizeReusingStorage(UninitVector<T>* v, std::size_t n) {
  if (internal::TooLarge(*v, n)) {
    UninitVector<T>(n).swap(*v);
  } else {
    if (v->capacity() < n) v->clear();  // growing: the old contents need not be copied over
    v->resize(n);
  }
}

// Room for one more entry, growing by a quarter rather than doubling: for long-lived arrays that
// grow an entry at a time with the graph (a solver's per-factor and per-variable arrays), where
// doubling left up to half of the largest ones unused for as long as the solver lives. Still
// amortised O(1) per entry; each entry is moved ~4 times instead of ~1.
template <typename T, typename A>
void ReserveOneMore(std::vector<T, A>* v) {
  if (v->size() == v->capacity()) {
    v->reserve(v->capacity() + std::max<std::size_t>(v->capacity() / 4, 16));
  }
}

}  // namespace slamd::core
