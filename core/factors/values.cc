#include "core/factors/values.h"

#include "core/base/storage.h"

namespace slamd::core {

Status Values::Insert(Key key, const Variable& value) {
  if (Contains(key)) return AlreadyExists("variable " + KeyToString(key) + " already exists");
  if (!AllFinite(value)) {
    return InvalidArgument("variable " + KeyToString(key) + " has a NaN or infinite entry");
  }
  slot_.Insert(key, static_cast<int>(keys_.size()));
  ReserveOneMore(&keys_);
  keys_.push_back(key);
  ReserveOneMore(&vars_);
  vars_.push_back(value);
  return Status::Ok();
}

Status Values::Update(Key key, const Variable& value) {
  const int s = SlotOf(key);
  if (s < 0) return NotFound("variable " + KeyToString(key) + " does not exist");
  if (vars_[s].index() != value.index()) {
    return InvalidArgument("variable " + KeyToString(key) + " is a " +
                           VariableTypeName(TypeAt(s)) + ", not a " +
                           VariableTypeName(TypeOf(value)));
  }
  if (!AllFinite(value)) {
    return InvalidArgument("variable " + KeyToString(key) + " has a NaN or infinite entry");
  }
  vars_[s] = value;
  return Status::Ok();
}

Status Values::Erase(Key key) {
  const int s = SlotOf(key);
  if (s < 0) return NotFound("variable " + KeyToString(key) + " does not exist");
  keys_.erase(keys_.begin() + s);
  vars_.erase(vars_.begin() + s);
  slot_.Erase(key);
  for (int i = s; i < static_cast<int>(keys_.size()); ++i) slot_.Set(keys_[i], i);
  return Status::Ok();
}

const Variable& Values::Get(Key key) const {
  const int s = SlotOf(key);
  SLAMD_CHECK(s >= 0) << "no variable named " << KeyToString(key);
  return vars_[s];
}

int Values::TotalDim() const {
  int total = 0;
  for (const Variable& v : vars_) total += TangentDim(TypeOf(v));
  return total;
}

}  // namespace slamd::core
