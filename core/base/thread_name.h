// NameThisThread: gives the calling thread a name that top -H, ps -L, gdb and perf show
// (/proc/self/task/TID/comm), so that a server's CPU and scheduling can be read per thread:
// which of slamd's estimator, intake, rebuild and snapshot threads, or LCM's own, took the time.
#pragma once

#include <string>

namespace slamd::core {

// Linux keeps at most 15 characters: a longer name is cut there. Failure is ignored (the name
// is a diagnostic, nothing depends on it).
void NameThisThread(const std::string& name);

// The calling thread's name ("" if it cannot be read).
std::string ThisThreadName();

}  // namespace slamd::core
