// server/purge.h's pieces that need no daemon: the store's time stamps read back, the reasons'
// names. Purges and the retention policy through the service: service_test.cpp (ServicePurge);
// a kill -9 during purges: daemon_test.cpp.
#include "server/purge.h"

#include <gtest/gtest.h>

#include <chrono>

#include "server/log.h"

namespace fragsim::server {
namespace {

TEST(PurgeUtc, ReadsTheStoresStamps) {
  EXPECT_EQ(parse_utc("1970-01-01T00:00:00.000Z"), 0.0);
  EXPECT_EQ(parse_utc("1970-01-02T00:00:01.500Z"), 86401.5);
  // 2026-11-29T11:40:05Z: 20,786 days after the epoch, plus 11 h 40 min 5 s.
  EXPECT_EQ(parse_utc("2026-11-29T11:40:05.123Z"), 20786.0 * 86400 + 42005 + 0.123);
  EXPECT_EQ(parse_utc("2028-02-29T00:00:00.000Z"), 21243.0 * 86400);  // a leap day
}

TEST(PurgeUtc, AStampOfNowIsNow) {
  const double now =
      std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
  const auto t = parse_utc(utc_now());
  ASSERT_TRUE(t.has_value());
  EXPECT_NEAR(*t, now, 2.0);
}

TEST(PurgeUtc, AnythingElseIsNotAStamp) {
  for (const char* bad : {"", "2026-11-29", "2026-11-29T11:40:05Z", "2026-11-29T11:40:05.123",
                          "2026-11-29T11:40:05.123+01:00", "yesterday"})
    EXPECT_FALSE(parse_utc(bad).has_value()) << bad;
}

TEST(PurgeReasons, NamesAsInTheMetrics) {
  EXPECT_STREQ(purge_reason_name(PurgeReason::kRequest), "request");
  EXPECT_STREQ(purge_reason_name(PurgeReason::kAge), "age");
  EXPECT_STREQ(purge_reason_name(PurgeReason::kBytes), "bytes");
}

TEST(RetentionPolicy, ActiveOnlyWithALimit) {
  EXPECT_FALSE(RetentionPolicy{}.active());
  EXPECT_TRUE((RetentionPolicy{0.5, 0, 600}.active()));
  EXPECT_TRUE((RetentionPolicy{0.0, 1, 600}.active()));
}

}  // namespace
}  // namespace fragsim::server
