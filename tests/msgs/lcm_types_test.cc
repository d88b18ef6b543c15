// The generated LCM types: the house rules of msgs/lcm/*.lcm, encode/decode round trips, distinct
// fingerprints, the hardened decoder (hostile counts, string lengths, random corruption) and the
// encoded sizes the map publisher pages by.
#include <gtest/gtest.h>

#include <cctype>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <random>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "slamd/camera_info_t.hpp"
#include "slamd/estimate_t.hpp"
#include "slamd/frame_observations_t.hpp"
#include "slamd/key_t.hpp"
#include "slamd/landmark_observation_t.hpp"
#include "slamd/loop_closure_t.hpp"
#include "slamd/map_entry_t.hpp"
#include "slamd/map_t.hpp"
#include "slamd/odometry_t.hpp"
#include "slamd/prior_t.hpp"
#include "slamd/query_reply_t.hpp"
#include "slamd/query_t.hpp"
#include "slamd/reject_t.hpp"
#include "slamd/remove_factor_t.hpp"
#include "slamd/status_t.hpp"
#include "slamd/variable_t.hpp"

namespace {

namespace fs = std::filesystem;
const fs::path kLcmDir = fs::path(SLAMD_TEST_DATA) / ".." / ".." / "msgs" / "lcm";
// Nested building blocks, never sent alone: exempt from "utime first".
const std::set<std::string> kComponents = {"key_t", "map_entry_t", "variable_t"};

template <typename Msg>
std::vector<std::uint8_t> Encode(const Msg& m) {
  std::vector<std::uint8_t> b(m.getEncodedSize());
  EXPECT_EQ(m.encode(b.data(), 0, static_cast<int>(b.size())), static_cast<int>(b.size()));
  return b;
}

std::vector<double> Seq(int n, double start) {
  std::vector<double> v;
  for (int i = 0; i < n; ++i) v.push_back(start + 0.25 * i);
  return v;
}

slamd::map_entry_t Entry(int64_t index, int values, int covariance) {
  slamd::map_entry_t e;
  e.index = index;
  e.values = Seq(values, 1.0);
  e.num_values = values;
  e.covariance = Seq(covariance, 0.5);
  e.num_covariance = covariance;
  return e;
}

slamd::key_t Key(int64_t index) {
  slamd::key_t k;
  k.robot = "alpha";
  k.kind = slamd::key_t::KIND_POSE;
  k.index = index;
  return k;
}

// One fully populated example of each outbound/inbound type with nested arrays.
slamd::map_t Map() {
  slamd::map_t m;
  m.utime = 11;
  m.robot = "alpha";
  m.update_sequence = 7;
  m.request_id = 3;
  m.page_index = 1;
  m.page_count = 2;
  m.dimension = 3;
  m.poses = {Entry(0, 7, 36), Entry(1, 7, 0)};
  m.num_poses = 2;
  m.landmarks = {Entry(5, 3, 9)};
  m.num_landmarks = 1;
  return m;
}

slamd::query_reply_t Reply() {
  slamd::query_reply_t r;
  r.utime = 12;
  r.client = "c";
  r.request_id = -4;
  r.update_sequence = 9;
  r.status = slamd::query_reply_t::STATUS_PARTIAL;
  r.error = "marginal of alpha:x1 not ready";
  slamd::variable_t v;
  v.key = Key(1);
  v.found = true;
  v.values = Seq(3, 0.0);
  v.num_values = 3;
  v.covariance = Seq(9, 1.0);
  v.num_covariance = 9;
  r.results = {v, v};
  r.results[1].found = false;
  r.num_results = 2;
  r.joint_dimension = 2;
  r.joint_covariance = {1, 2, 3, 4};
  r.num_joint_covariance = 4;
  r.map_pages = 1;
  return r;
}

slamd::query_t Query() {
  slamd::query_t q;
  q.utime = 1;
  q.client = "slamctl";
  q.request_id = 77;
  q.keys = {Key(1), Key(2)};
  q.num_keys = 2;
  q.want_marginals = true;
  q.want_joint_marginal = false;
  q.map_robot = "*";
  return q;
}

slamd::odometry_t Odometry() {
  slamd::odometry_t o;
  o.utime = 1700000000000000;
  o.robot = "alpha";
  o.from_index = 1;
  o.to_index = 2;
  o.dimension = slamd::odometry_t::DIMENSION_2D;
  o.values = {1, 2, 3};
  o.num_values = 3;
  o.covariance = Seq(9, 1.0);
  o.num_covariance = 9;
  return o;
}

// --- House rules of the .lcm files ---

struct Field {
  std::string type, name, count;  // count: the array's size field, "" for scalars
  bool commented = false;
};

struct Parsed {
  std::string package, struct_name;
  std::vector<Field> fields;
};

Parsed Parse(const fs::path& file) {
  std::ifstream in(file);
  Parsed p;
  std::string line;
  bool previous_was_comment = false;
  const std::regex package_re(R"(^\s*package\s+(\w+)\s*;)");
  const std::regex struct_re(R"(^\s*struct\s+(\w+))");
  const std::regex field_re(R"(^\s*([\w.]+)\s+(\w+)\s*(\[(\w+)\])?\s*;\s*(//.*)?$)");
  std::smatch m;
  while (std::getline(in, line)) {
    const bool comment = std::regex_search(line, std::regex(R"(^\s*//)"));
    if (std::regex_search(line, m, package_re))
      p.package = m[1];
    else if (std::regex_search(line, m, struct_re))
      p.struct_name = m[1];
    else if (!comment && line.find("const ") == std::string::npos &&
             std::regex_match(line, m, field_re)) {
      p.fields.push_back(Field{m[1], m[2], m[4], m[5].matched || previous_was_comment});
    }
    if (!line.empty() && line.find_first_not_of(" ") != std::string::npos)
      previous_was_comment = comment;
  }
  return p;
}

TEST(LcmFiles, FollowTheHouseRules) {
  ASSERT_TRUE(fs::is_directory(kLcmDir)) << kLcmDir;
  int files = 0;
  for (const auto& entry : fs::directory_iterator(kLcmDir)) {
    if (entry.path().extension() != ".lcm") continue;
    ++files;
    const std::string type = entry.path().stem();
    SCOPED_TRACE(type);
    const Parsed p = Parse(entry.path());
    EXPECT_EQ(p.package, "slamd");
    EXPECT_EQ(p.struct_name, type) << "one type per file, named after the file";
    EXPECT_TRUE(type.size() > 2 && type.substr(type.size() - 2) == "_t");
    ASSERT_FALSE(p.fields.empty());
    if (!kComponents.count(type)) {
      EXPECT_EQ(p.fields[0].type, "int64_t");
      EXPECT_EQ(p.fields[0].name, "utime") << "int64_t utime must come first";
    }
    for (size_t i = 0; i < p.fields.size(); ++i) {
      const Field& f = p.fields[i];
      EXPECT_TRUE(f.commented) << f.name << " has no units/frame comment";
      if (!f.count.empty() && !std::isdigit(static_cast<unsigned char>(f.count[0]))) {
        ASSERT_GT(i, 0u);
        EXPECT_EQ(p.fields[i - 1].name, f.count)
            << f.name << ": its count field must come just before it";
        EXPECT_EQ(p.fields[i - 1].type, "int32_t") << f.count;
      }
    }
  }
  EXPECT_EQ(files, 17);
}

// --- Generated code ---

TEST(LcmTypes, FingerprintsAreDistinct) {
  const std::vector<int64_t> hashes = {
      slamd::odometry_t::getHash(),      slamd::landmark_observation_t::getHash(),
      slamd::loop_closure_t::getHash(),  slamd::prior_t::getHash(),
      slamd::remove_factor_t::getHash(), slamd::estimate_t::getHash(),
      slamd::map_t::getHash(),           slamd::status_t::getHash(),
      slamd::reject_t::getHash(),        slamd::query_t::getHash(),
      slamd::query_reply_t::getHash(),   slamd::key_t::getHash(),
      slamd::map_entry_t::getHash(),     slamd::variable_t::getHash(),
      slamd::camera_info_t::getHash(),   slamd::frame_observations_t::getHash()};
  EXPECT_EQ(std::set<int64_t>(hashes.begin(), hashes.end()).size(), hashes.size());
}

template <typename Msg>
void ExpectRoundTrip(const Msg& m) {
  const std::vector<std::uint8_t> bytes = Encode(m);
  Msg back;
  ASSERT_EQ(back.decode(bytes.data(), 0, static_cast<int>(bytes.size())),
            static_cast<int>(bytes.size()));
  EXPECT_EQ(Encode(back), bytes);
}

TEST(LcmTypes, RoundTrip) {
  ExpectRoundTrip(Odometry());
  ExpectRoundTrip(Map());
  ExpectRoundTrip(Reply());
  ExpectRoundTrip(Query());
  slamd::status_t s{};
  s.rejects_by_reason = {0, 1, 2};
  s.num_rejects_by_reason = 3;
  s.chi2 = 1.5;
  s.settled = true;
  ExpectRoundTrip(s);
  slamd::reject_t r{};
  r.channel = "SLAMD_ODOMETRY";
  r.detail = "odometry_t.covariance: not positive definite (smallest eigenvalue -0.2)";
  r.reason = slamd::reject_t::REASON_COVARIANCE_NOT_POSITIVE_DEFINITE;
  ExpectRoundTrip(r);
}

// Offset of odometry_t.num_values in the example's encoding: hash, utime, robot, from, to,
// dimension.
constexpr size_t kNumValuesAt = 8 + 8 + (4 + 5 + 1) + 8 + 8 + 1;

void Put32(std::vector<std::uint8_t>* b, size_t at, std::int32_t v) {
  for (int i = 0; i < 4; ++i) (*b)[at + i] = static_cast<std::uint8_t>((v >> (24 - 8 * i)) & 0xff);
}

TEST(HardenedDecode, HostileArrayCountsFailFastWithoutAllocating) {
  std::vector<std::uint8_t> bytes = Encode(Odometry());
  ASSERT_EQ(bytes[kNumValuesAt + 3], 3);
  for (std::int32_t count : {0x7fffffff, 1 << 28, -1, -0x7fffffff}) {
    Put32(&bytes, kNumValuesAt, count);
    slamd::odometry_t m;
    const auto start = std::chrono::steady_clock::now();
    EXPECT_LT(m.decode(bytes.data(), 0, static_cast<int>(bytes.size())), 0) << count;
    EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::milliseconds(50)) << count;
    EXPECT_LT(m.values.capacity(), 1000u) << count;
  }
}

TEST(HardenedDecode, HostileNestedArrayCount) {
  std::vector<std::uint8_t> bytes = Encode(Query());
  // num_keys follows hash (8), utime (8), client (4 + 7 + 1), request_id (8).
  const size_t at = 8 + 8 + 12 + 8;
  ASSERT_EQ(bytes[at + 3], 2);
  Put32(&bytes, at, 0x7fffffff);
  slamd::query_t q;
  EXPECT_LT(q.decode(bytes.data(), 0, static_cast<int>(bytes.size())), 0);
  EXPECT_LT(q.keys.capacity(), 1000u);
}

TEST(HardenedDecode, StringLengthsBelowOneAreRejectedNotThrown) {
  std::vector<std::uint8_t> bytes = Encode(Odometry());
  for (std::int32_t len : {0, -1, -100}) {
    Put32(&bytes, 16, len);  // the robot string's length (it includes the NUL, so >= 1)
    slamd::odometry_t m;
    int rc = 0;
    EXPECT_NO_THROW(rc = m.decode(bytes.data(), 0, static_cast<int>(bytes.size())));
    EXPECT_LT(rc, 0) << len;
  }
}

template <typename Msg>
void FuzzDecode(const Msg& example, std::mt19937* rng) {
  const std::vector<std::uint8_t> good = Encode(example);
  std::uniform_int_distribution<size_t> pos(
      8, good.size() - 1);  // keep the fingerprint: reach the body
  std::uniform_int_distribution<int> byte(0, 255);
  for (int trial = 0; trial < 3000; ++trial) {
    std::vector<std::uint8_t> b = good;
    const int flips = 1 + trial % 4;
    for (int f = 0; f < flips; ++f) b[pos(*rng)] = static_cast<std::uint8_t>(byte(*rng));
    const size_t length = trial % 3 == 0 ? pos(*rng) : b.size();
    Msg m;
    try {
      (void)m.decode(b.data(), 0, static_cast<int>(length));
    } catch (const std::exception& e) {
      ADD_FAILURE() << Msg::getTypeName() << " decode threw: " << e.what();
      return;
    }
  }
}

TEST(HardenedDecode, CorruptedMessagesNeverThrow) {
  std::mt19937 rng(20240607);
  FuzzDecode(Odometry(), &rng);
  FuzzDecode(Query(), &rng);
  FuzzDecode(Map(), &rng);
  FuzzDecode(Reply(), &rng);
}

TEST(EncodedSizes, WhatTheMapPublisherPagesBy) {
  // Bytes per map_entry_t: index 8, two counts 8, values and covariance 8 each.
  EXPECT_EQ(Entry(0, 3, 0)._getEncodedSizeNoHash(), 8 + 4 + 24 + 4);         // 2D pose
  EXPECT_EQ(Entry(0, 3, 9)._getEncodedSizeNoHash(), 8 + 4 + 24 + 4 + 72);    // 2D pose + covariance
  EXPECT_EQ(Entry(0, 7, 36)._getEncodedSizeNoHash(), 8 + 4 + 56 + 4 + 288);  // 3D pose + covariance
  // So a ~60 kB page holds 160 3D poses with covariance.
  slamd::map_t m = Map();
  m.poses.assign(160, Entry(0, 7, 36));
  m.num_poses = 160;
  m.landmarks.clear();
  m.num_landmarks = 0;
  EXPECT_LT(m.getEncodedSize(), 60000);
}

}  // namespace
