#include "core/factors/factor_graph.h"

namespace slamd::core {

Status FactorGraph::CheckAgainst(const Values& values) const {
  for (std::size_t f = 0; f < factors_.size(); ++f) {
    const Factor& factor = *factors_[f];
    for (int i = 0; i < static_cast<int>(factor.keys().size()); ++i) {
      const Key key = factor.keys()[i];
      const int slot = values.SlotOf(key);
      if (slot < 0) {
        return NotFound("factor " + std::to_string(f) + " (" + factor.Name() +
                        ") refers to variable " + KeyToString(key) + ", which has no value");
      }
      if (values.TypeAt(slot) != factor.KeyType(i)) {
        return InvalidArgument("factor " + std::to_string(f) + " (" + factor.Name() +
                               ") expects " + KeyToString(key) + " to be a " +
                               VariableTypeName(factor.KeyType(i)) + ", but it is a " +
                               VariableTypeName(values.TypeAt(slot)));
      }
    }
  }
  return Status::Ok();
}

double FactorGraph::Chi2(const Values& values) const {
  double sum = 0.0;
  for (const FactorPtr& f : factors_) sum += f->Chi2(values);
  return sum;
}

double FactorGraph::Cost(const Values& values) const {
  double sum = 0.0;
  for (const FactorPtr& f : factors_) sum += f->Cost(values);
  return sum;
}

}  // namespace slamd::core
