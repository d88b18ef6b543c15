#include "server/estimator/background_priority.h"

#include <sys/resource.h>
#include <unistd.h>

namespace slamd::server {

void LowerThisThreadsPriority() {
  // setpriority on a thread id changes that thread only (see setpriority(2), "BUGS").
  [[maybe_unused]] const int rc = ::setpriority(PRIO_PROCESS, static_cast<id_t>(::gettid()), 19);
}

}  // namespace slamd::server
