// query_client: key parsing, the query_t -> query_reply_t (+ map_t pages) round trip against a
// fake server on an InProcessBus (replies to other requests ignored, timeouts), and printing.
#include "clients/slamctl/query_client.h"

#include <gtest/gtest.h>

#include "server/messages/inbound.h"
#include "server/transport/in_process_bus.h"

namespace slamd::clients {
namespace {

TEST(QueryClientTest, ParsesKeys) {
  auto k = ParseKey("bot_1:x12", "");
  ASSERT_TRUE(k.ok());
  EXPECT_EQ(k->robot, "bot_1");
  EXPECT_EQ(k->kind, server::KeyKind::kPose);
  EXPECT_EQ(k->index, 12u);
  k = ParseKey("l3", "r");
  ASSERT_TRUE(k.ok());
  EXPECT_EQ(k->robot, "r");
  EXPECT_EQ(k->kind, server::KeyKind::kLandmark);
  EXPECT_EQ(k->index, 3u);
  EXPECT_EQ(ParseKey("a.b-c:x0", "other")->robot, "a.b-c");  // an explicit robot wins
  for (const char* bad :
       {"x12", "bot:", "bot:x", "bot:z1", "bot:x-1", "bot:x1.5", ":x1", "bot:x281474976710656"}) {
    EXPECT_FALSE(ParseKey(bad, "").ok()) << bad;
  }
  EXPECT_TRUE(ParseKey("bot:x281474976710655", "").ok());
  EXPECT_EQ(WireKeyToString("a", slamd::key_t::KIND_LANDMARK, 4), "a:l4");
  k = ParseKey("m7", "r");  // the shared map's landmark 7: no robot
  ASSERT_TRUE(k.ok()) << k.status().message();
  EXPECT_EQ(k->robot, "");
  EXPECT_EQ(k->kind, server::KeyKind::kMapLandmark);
  EXPECT_EQ(k->index, 7u);
  EXPECT_FALSE(ParseKey("m", "").ok());
  EXPECT_FALSE(ParseKey("m7x", "").ok());
  EXPECT_EQ(WireKeyToString("", slamd::key_t::KIND_MAP_LANDMARK, 7), "m7");
  EXPECT_GT(RandomRequestId(), 0);
}

// Answers every query_t: first a reply to another request (must be ignored), then the real one
// with the values x = index, a 3x3 covariance when asked, and two map pages when a map is asked.
class FakeServer {
 public:
  explicit FakeServer(server::Bus& bus) : bus_(bus) {
    sub_ = server::Subscribe<slamd::query_t>(
               bus, "SLAMD_QUERY", [this](std::string_view, const slamd::query_t& q) { Answer(q); },
               nullptr)
               .value();
  }
  bool reject = false;
  int queries = 0;

 private:
  void Answer(const slamd::query_t& q) {
    ++queries;
    slamd::query_reply_t other{};
    other.request_id = q.request_id + 1;
    other.client = q.client;
    ASSERT_TRUE(server::Publish(bus_, "SLAMD_QUERY_REPLY", other).ok());
    slamd::query_reply_t r{};
    r.client = q.client;
    r.request_id = q.request_id;
    r.update_sequence = 7;
    r.status = reject ? slamd::query_reply_t::STATUS_REJECTED : slamd::query_reply_t::STATUS_OK;
    r.error = reject ? "query_t.keys: too many" : "";
    if (!reject) {
      for (const slamd::key_t& k : q.keys) {
        slamd::variable_t v{};
        v.key = k;
        v.found = k.index < 100;
        if (v.found) {
          v.values = {static_cast<double>(k.index), 0.5, 0.25};
          if (q.want_marginals) v.covariance = {1, 0, 0, 0, 2, 0, 0, 0, 3};
        }
        v.num_values = static_cast<int32_t>(v.values.size());
        v.num_covariance = static_cast<int32_t>(v.covariance.size());
        r.results.push_back(v);
      }
      r.num_results = static_cast<int32_t>(r.results.size());
      r.map_pages = q.map_robot.empty() ? 0 : 2;
    }
    ASSERT_TRUE(server::Publish(bus_, "SLAMD_QUERY_REPLY", r).ok());
    for (int page = 0; page < r.map_pages; ++page) {
      slamd::map_t m{};
      m.robot = q.map_robot;
      m.request_id = q.request_id;
      m.page_index = page;
      m.page_count = 2;
      slamd::map_entry_t e{};
      e.index = page;
      e.values = {1.0 * page, 2.0, 0.1};
      e.num_values = 3;
      m.poses = {e};
      m.num_poses = 1;
      ASSERT_TRUE(server::Publish(bus_, "SLAMD_MAP", m).ok());
    }
  }
  server::Bus& bus_;
  server::Subscription sub_;
};

slamd::query_t Query(bool cov, const std::string& map) {
  server::QueryRequest req;
  req.client = "test";
  req.request_id = 12345;
  req.keys = {{"bot", server::KeyKind::kPose, 3}, {"bot", server::KeyKind::kLandmark, 500}};
  req.want_marginals = cov;
  req.map_robot = map;
  slamd::query_t q;
  server::ToLcm(req, &q);
  return q;
}

TEST(QueryClientTest, RoundTripWithCovariancesAndMap) {
  LcmClient client(std::make_unique<server::InProcessBus>());
  FakeServer fake(client.bus());
  auto answer = RunQuery(client, server::ChannelNames{}, Query(true, "bot"), 2.0);
  ASSERT_TRUE(answer.ok()) << answer.status().ToString();
  EXPECT_EQ(fake.queries, 1);
  EXPECT_EQ(answer->reply.request_id, 12345);
  ASSERT_EQ(answer->reply.results.size(), 2u);
  EXPECT_TRUE(answer->reply.results[0].found);
  EXPECT_FALSE(answer->reply.results[1].found);
  ASSERT_EQ(answer->map_pages.size(), 2u);

  const std::string text = FormatAnswer(*answer);
  EXPECT_NE(text.find("bot:x3  3 0.5 0.25"), std::string::npos) << text;
  EXPECT_NE(text.find("bot:l500  not found"), std::string::npos) << text;
  EXPECT_NE(text.find("    0 2 0"), std::string::npos) << text;  // covariance row 2
  EXPECT_NE(text.find("map bot page 2/2: 1 poses"), std::string::npos) << text;
  const std::string json = AnswerJson(*answer);
  EXPECT_NE(json.find("\"key\": \"bot:x3\", \"found\": true, \"values\": [3, 0.5, 0.25], "
                      "\"covariance\": [1, 0, 0, 0, 2, 0, 0, 0, 3]"),
            std::string::npos)
      << json;
  EXPECT_NE(json.find("\"status\": \"ok\""), std::string::npos) << json;
  EXPECT_NE(json.find("\"poses\": [{\"index\": 1, \"values\": [1, 2, 0.10000000000000001]"),
            std::string::npos)
      << json;
}

TEST(QueryClientTest, RejectedAndTimedOut) {
  {
    LcmClient client(std::make_unique<server::InProcessBus>());
    FakeServer fake(client.bus());
    fake.reject = true;
    auto answer = RunQuery(client, server::ChannelNames{}, Query(false, ""), 2.0);
    ASSERT_TRUE(answer.ok());
    EXPECT_EQ(answer->reply.status, slamd::query_reply_t::STATUS_REJECTED);
    EXPECT_NE(FormatAnswer(*answer).find("rejected (query_t.keys: too many)"), std::string::npos);
  }
  LcmClient lonely(std::make_unique<server::InProcessBus>());
  auto none = RunQuery(lonely, server::ChannelNames{}, Query(false, ""), 0.1);
  ASSERT_FALSE(none.ok());
  EXPECT_EQ(none.status().code(), core::StatusCode::kOutOfRange);
  EXPECT_NE(none.status().message().find("no query_reply_t for request 12345"), std::string::npos);
}

}  // namespace
}  // namespace slamd::clients
