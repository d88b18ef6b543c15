// Reusing vector storage without letting it grow without bound.
#pragma once

#include <cstddef>
#include <vector>

namespace slamd::core {

// *v = n copies of `value`, reusing v's allocation unless it is more than 4x (and 8 KiB) larger
// than needed. Objects recycled through free lists (Bayes tree cliques) would otherwise keep the
// largest size they ever had: after a run on a 3500-pose graph that was 100+ MB of capacity
// for 15 MB of live data.
template <typename T>
void AssignReusingStorage(std::vector<T>* v, std::size_t n, const T& value) {
  constexpr std::size_t kSlackBytes = 8192;
  if (v->capacity() > 4 * n && v->capacity() * sizeof(T) > kSlackBytes) {
    std::vector<T>(n, value).swap(*v);
  } else {
    v->assign(n, value);
  }
}

}  // namespace slamd::core
