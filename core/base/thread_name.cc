#include "core/base/thread_name.h"

#include <pthread.h>

namespace slamd::core {

namespace {
constexpr size_t kMaxNameLength = 15;  // TASK_COMM_LEN - 1
}  // namespace

void NameThisThread(const std::string& name) {
  pthread_setname_np(pthread_self(), name.substr(0, kMaxNameLength).c_str());
}

std::string ThisThreadName() {
  char name[kMaxNameLength + 1] = {};
  if (pthread_getname_np(pthread_self(), name, sizeof(name)) != 0) return "";
  return name;
}

}  // namespace slamd::core
