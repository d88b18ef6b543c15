#include "server/replication/message_chunks.h"

#include <algorithm>
#include <charconv>

#include "server/replication/relay_bus.h"

namespace slamd::server {
namespace {

constexpr int kMaxChunks = 4096;

// "<sender>/<number>/<index>/<count>" -> its parts; false when it is not that.
bool ParseTag(std::string_view tag, std::string* sender, std::uint64_t* number, int* index,
              int* count) {
  const std::size_t a = tag.find('/');
  if (a == 0 || a == std::string_view::npos) return false;
  *sender = std::string(tag.substr(0, a));
  const char* p = tag.data() + a + 1;
  const char* end = tag.data() + tag.size();
  auto number_at = [&](auto* out, bool last) {
    const auto r = std::from_chars(p, end, *out);
    if (r.ec != std::errc() || (last ? r.ptr != end : (r.ptr == end || *r.ptr != '/'))) {
      return false;
    }
    p = last ? r.ptr : r.ptr + 1;
    return true;
  };
  return number_at(number, false) && number_at(index, false) && number_at(count, true) &&
         *count >= 1 && *count <= kMaxChunks && *index >= 0 && *index < *count;
}

}  // namespace

std::vector<std::vector<std::uint8_t>> SplitIntoChunks(const std::string& sender,
                                                       std::uint64_t number,
                                                       std::span<const std::uint8_t> bytes,
                                                       std::size_t chunk_bytes) {
  const std::size_t count =
      std::max<std::size_t>(1, (bytes.size() + chunk_bytes - 1) / chunk_bytes);
  std::vector<std::vector<std::uint8_t>> out;
  for (std::size_t i = 0; i < count; ++i) {
    const std::size_t begin = std::min(bytes.size(), i * chunk_bytes);
    const std::size_t n = std::min(chunk_bytes, bytes.size() - begin);
    out.push_back(Frame(sender + "/" + std::to_string(number) + "/" + std::to_string(i) + "/" +
                            std::to_string(count),
                        bytes.subspan(begin, n)));
  }
  return out;
}

core::Result<std::optional<std::vector<std::uint8_t>>> ChunkAssembler::Add(
    std::span<const std::uint8_t> chunk) {
  const std::optional<Framed> framed = Unframe(chunk);
  std::string sender;
  std::uint64_t number = 0;
  int index = 0, count = 0;
  if (!framed || !ParseTag(framed->tag, &sender, &number, &index, &count)) {
    return core::InvalidArgument("not a message chunk (tag '" +
                                 std::string(framed ? framed->tag : "") +
                                 "', want sender/number/index/count)");
  }
  Partial& partial = by_sender_[sender];
  if (partial.parts.empty() || partial.number != number ||
      partial.parts.size() != static_cast<std::size_t>(count)) {
    if (!partial.parts.empty() && partial.have < static_cast<int>(partial.parts.size())) {
      ++dropped_;
    }
    partial = {.number = number,
               .parts = std::vector<std::vector<std::uint8_t>>(count),
               .got = std::vector<bool>(count, false)};
  }
  if (partial.got[index]) return std::optional<std::vector<std::uint8_t>>();  // a copy
  partial.got[index] = true;
  partial.parts[index].assign(framed->body.begin(), framed->body.end());
  if (++partial.have < count) return std::optional<std::vector<std::uint8_t>>();
  std::vector<std::uint8_t> whole;
  for (const std::vector<std::uint8_t>& p : partial.parts)
    whole.insert(whole.end(), p.begin(), p.end());
  by_sender_.erase(sender);
  return std::optional<std::vector<std::uint8_t>>(std::move(whole));
}

}  // namespace slamd::server
