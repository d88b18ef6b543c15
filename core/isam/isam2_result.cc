#include "core/isam/isam2_result.h"

#include <cstdio>

namespace slamd::core {

std::string Isam2Result::Brief() const {
  char line[512];
  std::snprintf(line, sizeof(line),
                "%zu new factors, %d new variables, relinearized %d (deferred %d), re-eliminated "
                "%d variables in %d cliques, solved %d cliques, %.3f ms (relinearize %.3f, remove "
                "%.3f, order %.3f, eliminate %.3f, solve %.3f)%s%s",
                new_factor_indices.size(), new_variables, relinearized_variables,
                relinearization_deferred, reeliminated_variables, reeliminated_cliques,
                solved_cliques, seconds.total * 1e3, seconds.relinearize * 1e3,
                seconds.remove_top * 1e3, seconds.order * 1e3, seconds.eliminate * 1e3,
                seconds.solve * 1e3, batch_step ? " (batch step)" : "",
                status.ok() ? "" : (", " + status.ToString()).c_str());
  return line;
}

}  // namespace slamd::core
