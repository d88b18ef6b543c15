// Background threads (the solver rebuild's helper, the snapshot writer) run at the lowest CFS
// priority, so that on a machine with few cores the estimator and intake threads and the
// robots' own processes take a core from them at once when they wake. The one lock a helper
// shares with the estimator (the rebuild log) is held only to copy a few entries; should the
// helper be preempted inside it, the estimator that waits frees a core for it.
#pragma once

namespace slamd::server {

// Lowers the calling thread's scheduling priority to nice 19 (Linux: nice is per thread). Best
// effort: a failure leaves the priority as it was.
void LowerThisThreadsPriority();

}  // namespace slamd::server
