// fragsimd's SQLite store: sites, the job queue and its state machine, crash recovery,
// persistence across reopening.
#include "server/store.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <memory>

#include "api/test_support.h"
#include "store_support.h"

namespace fragsim::server {
namespace {

namespace fs = std::filesystem;

JobRow job_row(const std::string& id, int priority = 0,
               std::optional<std::string> key = std::nullopt,
               std::optional<std::string> site = std::nullopt) {
  JobRow r;
  r.job_id = id;
  r.priority = priority;
  r.idempotency_key = std::move(key);
  r.site_id = std::move(site);
  r.request_sha256 = "sha-" + id;
  r.scenario_json = R"({"scenario": ")" + id + R"("})";
  r.histories_total = 1000;
  r.created_utc = "2026-01-01T00:00:00.000Z";
  return r;
}

BuildingRow building(const std::string& id, double impacts) {
  return {id, impacts, impacts / 10, impacts / 2, impacts / 20};
}

class StoreTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = api::testing::fresh_test_dir("fragsim_store_test_");
    open();
  }
  void TearDown() override {
    store_.reset();
    fs::remove_all(dir_);
  }
  void open() { store_ = std::make_unique<Store>((dir_ / "fragsimd.sqlite").string()); }
  void reopen() {
    store_.reset();
    open();
  }
  Store& store() { return *store_; }
  JobState state(const std::string& id) { return store_->job(id).value().state; }

  fs::path dir_;
  std::unique_ptr<Store> store_;
};

// ---- States ----

TEST(StoreStates, NamesRoundTrip) {
  for (int k = 0; k < kJobStateCount; ++k) {
    const auto s = static_cast<JobState>(k);
    EXPECT_EQ(parse_job_state(job_state_name(s)), s);
  }
  EXPECT_STREQ(job_state_name(JobState::kQueued), "queued");
  EXPECT_STREQ(job_state_name(JobState::kCancelled), "cancelled");
  EXPECT_FALSE(parse_job_state("Queued").has_value());
  EXPECT_FALSE(parse_job_state("").has_value());
  EXPECT_FALSE(is_final(JobState::kQueued));
  EXPECT_FALSE(is_final(JobState::kRunning));
  EXPECT_TRUE(is_final(JobState::kDone));
  EXPECT_TRUE(is_final(JobState::kFailed));
  EXPECT_TRUE(is_final(JobState::kCancelled));
}

// ---- Jobs ----

TEST_F(StoreTest, InsertedJobReadsBack) {
  const auto ins = store().insert_job(job_row("j_a", 5, "key-a", "s_0123456789abcdef"));
  EXPECT_TRUE(ins.created);
  EXPECT_EQ(ins.job.state, JobState::kQueued);
  EXPECT_EQ(ins.job.seq, 1);
  const auto j = store().job("j_a");
  ASSERT_TRUE(j.has_value());
  EXPECT_EQ(j->job_id, "j_a");
  EXPECT_EQ(j->seq, 1);
  EXPECT_EQ(j->site_id, "s_0123456789abcdef");
  EXPECT_EQ(j->priority, 5);
  EXPECT_EQ(j->state, JobState::kQueued);
  EXPECT_EQ(j->idempotency_key, "key-a");
  EXPECT_EQ(j->request_sha256, "sha-j_a");
  EXPECT_EQ(j->scenario_json, "") << "a status read does not carry the scenario";
  EXPECT_EQ(store().next_queued()->scenario_json, R"({"scenario": "j_a"})");
  EXPECT_EQ(j->histories_total, 1000);
  EXPECT_EQ(j->histories_done, 0);
  EXPECT_EQ(j->attempts, 0);
  EXPECT_EQ(j->crashes, 0);
  EXPECT_EQ(j->created_utc, "2026-01-01T00:00:00.000Z");
  EXPECT_FALSE(j->started_utc.has_value());
  EXPECT_FALSE(j->finished_utc.has_value());
  EXPECT_FALSE(j->error_code.has_value());
  EXPECT_FALSE(j->error_message.has_value());
  EXPECT_FALSE(store().job("j_missing").has_value());
}

TEST_F(StoreTest, NullSiteAndKeyStayNull) {
  store().insert_job(job_row("j_a"));
  const auto j = store().job("j_a");
  ASSERT_TRUE(j.has_value());
  EXPECT_FALSE(j->site_id.has_value());
  EXPECT_FALSE(j->idempotency_key.has_value());
}

TEST_F(StoreTest, SeqFollowsSubmissionOrder) {
  EXPECT_EQ(store().insert_job(job_row("j_a")).job.seq, 1);
  EXPECT_EQ(store().insert_job(job_row("j_b")).job.seq, 2);
  EXPECT_EQ(store().insert_job(job_row("j_c")).job.seq, 3);
}

TEST_F(StoreTest, IdempotencyKeyReturnsTheExistingRow) {
  const auto first = store().insert_job(job_row("j_a", 1, "retry-me"));
  ASSERT_TRUE(first.created);
  JobRow again = job_row("j_b", 9, "retry-me");
  again.request_sha256 = "other";
  const auto second = store().insert_job(again);
  EXPECT_FALSE(second.created);
  EXPECT_EQ(second.job.job_id, "j_a");
  EXPECT_EQ(second.job.priority, 1);
  EXPECT_EQ(second.job.request_sha256, "sha-j_a");
  EXPECT_FALSE(store().job("j_b").has_value());
  EXPECT_EQ(store().jobs(std::nullopt, 1000).size(), 1u);
  // Another key, or none, makes a new job.
  EXPECT_TRUE(store().insert_job(job_row("j_c", 0, "other-key")).created);
  EXPECT_TRUE(store().insert_job(job_row("j_d")).created);
  EXPECT_TRUE(store().insert_job(job_row("j_e")).created);
  EXPECT_EQ(store().jobs(std::nullopt, 1000).size(), 4u);
}

TEST_F(StoreTest, IdempotencyKeyFindsTheJobWhateverItsState) {
  store().insert_job(job_row("j_a", 0, "k"));
  ASSERT_TRUE(store().mark_running("j_a", "t1"));
  ASSERT_TRUE(store().mark_done("j_a", "t2", 1000, "{}", {}));
  const auto again = store().insert_job(job_row("j_b", 0, "k"));
  EXPECT_FALSE(again.created);
  EXPECT_EQ(again.job.job_id, "j_a");
  EXPECT_EQ(again.job.state, JobState::kDone);
}

TEST_F(StoreTest, NextQueuedIsHighestPriorityThenOldest) {
  EXPECT_FALSE(store().next_queued().has_value());
  store().insert_job(job_row("j_low", -5));
  store().insert_job(job_row("j_mid1", 0));
  store().insert_job(job_row("j_high1", 10));
  store().insert_job(job_row("j_mid2", 0));
  store().insert_job(job_row("j_high2", 10));
  std::vector<std::string> order;
  while (const auto next = store().next_queued()) {
    order.push_back(next->job_id);
    ASSERT_TRUE(store().mark_running(next->job_id, "t"));
  }
  EXPECT_EQ(order, (std::vector<std::string>{"j_high1", "j_high2", "j_mid1", "j_mid2", "j_low"}));
}

TEST_F(StoreTest, NextQueuedSkipsJobsThatAreNotQueued) {
  store().insert_job(job_row("j_a", 10));
  store().insert_job(job_row("j_b", 5));
  store().insert_job(job_row("j_c", 1));
  ASSERT_TRUE(store().cancel("j_a", "t").has_value());
  ASSERT_TRUE(store().mark_running("j_b", "t"));
  EXPECT_EQ(store().next_queued()->job_id, "j_c");
}

TEST_F(StoreTest, MarkRunningOnlyFromQueued) {
  store().insert_job(job_row("j_a"));
  EXPECT_TRUE(store().mark_running("j_a", "2026-01-01T00:00:01.000Z"));
  auto j = store().job("j_a");
  EXPECT_EQ(j->state, JobState::kRunning);
  EXPECT_EQ(j->attempts, 1);
  EXPECT_EQ(j->started_utc, "2026-01-01T00:00:01.000Z");
  EXPECT_FALSE(store().mark_running("j_a", "t2"));  // already running
  EXPECT_EQ(store().job("j_a")->attempts, 1);
  EXPECT_EQ(store().job("j_a")->started_utc, "2026-01-01T00:00:01.000Z");
  EXPECT_FALSE(store().mark_running("j_missing", "t"));

  // After a requeue it can start again: attempts counts the starts.
  store().requeue("j_a");
  EXPECT_TRUE(store().mark_running("j_a", "t3"));
  EXPECT_EQ(store().job("j_a")->attempts, 2);

  store().insert_job(job_row("j_c"));
  store().cancel("j_c", "t");
  EXPECT_FALSE(store().mark_running("j_c", "t"));
  EXPECT_EQ(state("j_c"), JobState::kCancelled);
}

TEST_F(StoreTest, ProgressOnlyWhileRunning) {
  store().insert_job(job_row("j_a"));
  store().update_progress("j_a", 10);
  EXPECT_EQ(store().job("j_a")->histories_done, 0);
  store().mark_running("j_a", "t");
  store().update_progress("j_a", 512);
  EXPECT_EQ(store().job("j_a")->histories_done, 512);
}

TEST_F(StoreTest, MarkDoneOnlyFromRunningAndWritesBuildingsInOrder) {
  store().insert_job(job_row("j_a"));
  const std::vector<BuildingRow> rows = {building("Zeta", 3.5), building("Alpha", 1.25),
                                         building("Mid", 0.0)};
  EXPECT_FALSE(store().mark_done("j_a", "t", 1000, R"({"s":1})", rows));  // still queued
  EXPECT_EQ(state("j_a"), JobState::kQueued);
  EXPECT_TRUE(store().buildings("j_a").empty());
  EXPECT_FALSE(store().summary_json("j_a").has_value());

  ASSERT_TRUE(store().mark_running("j_a", "t1"));
  store().update_progress("j_a", 100);
  EXPECT_TRUE(store().mark_done("j_a", "2026-01-01T00:01:00.000Z", 1000, R"({"s":1})", rows));
  const auto j = store().job("j_a");
  EXPECT_EQ(j->state, JobState::kDone);
  EXPECT_EQ(j->histories_done, 1000);
  EXPECT_EQ(j->finished_utc, "2026-01-01T00:01:00.000Z");
  EXPECT_FALSE(j->error_code.has_value());
  EXPECT_EQ(store().summary_json("j_a"), R"({"s":1})");

  const auto got = store().buildings("j_a");
  ASSERT_EQ(got.size(), 3u);
  for (std::size_t k = 0; k < rows.size(); ++k) {
    EXPECT_EQ(got[k].building_id, rows[k].building_id);
    EXPECT_EQ(got[k].expected_impacts, rows[k].expected_impacts);
    EXPECT_EQ(got[k].impacts_std_error, rows[k].impacts_std_error);
    EXPECT_EQ(got[k].expected_penetrations, rows[k].expected_penetrations);
    EXPECT_EQ(got[k].penetrations_std_error, rows[k].penetrations_std_error);
  }
  // Done is final: a second mark_done changes nothing.
  EXPECT_FALSE(store().mark_done("j_a", "t9", 5, "{}", {}));
  EXPECT_EQ(store().summary_json("j_a"), R"({"s":1})");
  EXPECT_EQ(store().buildings("j_a").size(), 3u);
  EXPECT_TRUE(store().buildings("j_missing").empty());
}

TEST_F(StoreTest, MarkDoneOfACancelledJobWritesNothing) {
  store().insert_job(job_row("j_a"));
  store().mark_running("j_a", "t1");
  ASSERT_EQ(store().cancel("j_a", "t2"), JobState::kRunning);
  EXPECT_FALSE(store().mark_done("j_a", "t3", 1000, "{}", {building("B1", 1)}));
  EXPECT_EQ(state("j_a"), JobState::kCancelled);
  EXPECT_TRUE(store().buildings("j_a").empty());
  EXPECT_FALSE(store().summary_json("j_a").has_value());
}

TEST_F(StoreTest, MarkFailedFromQueuedOrRunningOnly) {
  store().insert_job(job_row("j_a"));
  store().mark_running("j_a", "t");
  EXPECT_TRUE(store().mark_failed("j_a", "t2", "internal", "boom"));
  auto j = store().job("j_a");
  EXPECT_EQ(j->state, JobState::kFailed);
  EXPECT_EQ(j->error_code, "internal");
  EXPECT_EQ(j->error_message, "boom");
  EXPECT_EQ(j->finished_utc, "t2");
  EXPECT_FALSE(store().mark_failed("j_a", "t3", "other", "again"));
  EXPECT_EQ(store().job("j_a")->error_code, "internal");

  store().insert_job(job_row("j_b"));
  store().mark_running("j_b", "t");
  store().mark_done("j_b", "t", 1, "{}", {});
  EXPECT_FALSE(store().mark_failed("j_b", "t", "x", "y"));
  EXPECT_EQ(state("j_b"), JobState::kDone);
}

TEST_F(StoreTest, CancelReturnsThePreviousState) {
  store().insert_job(job_row("j_q"));
  store().insert_job(job_row("j_r"));
  store().mark_running("j_r", "t");
  EXPECT_EQ(store().cancel("j_q", "2026-01-01T00:00:05.000Z"), JobState::kQueued);
  EXPECT_EQ(state("j_q"), JobState::kCancelled);
  EXPECT_EQ(store().job("j_q")->finished_utc, "2026-01-01T00:00:05.000Z");
  EXPECT_EQ(store().cancel("j_r", "t"), JobState::kRunning);
  EXPECT_EQ(state("j_r"), JobState::kCancelled);
  EXPECT_FALSE(store().cancel("j_missing", "t").has_value());
}

TEST_F(StoreTest, CancelDoesNotChangeFinalStates) {
  store().insert_job(job_row("j_done"));
  store().mark_running("j_done", "t");
  store().mark_done("j_done", "t-done", 1000, "{}", {});
  store().insert_job(job_row("j_failed"));
  store().mark_failed("j_failed", "t-failed", "internal", "x");
  store().insert_job(job_row("j_cancelled"));
  store().cancel("j_cancelled", "t-cancelled");

  EXPECT_EQ(store().cancel("j_done", "later"), JobState::kDone);
  EXPECT_EQ(store().cancel("j_failed", "later"), JobState::kFailed);
  EXPECT_EQ(store().cancel("j_cancelled", "later"), JobState::kCancelled);
  EXPECT_EQ(state("j_done"), JobState::kDone);
  EXPECT_EQ(state("j_failed"), JobState::kFailed);
  EXPECT_EQ(state("j_cancelled"), JobState::kCancelled);
  EXPECT_EQ(store().job("j_done")->finished_utc, "t-done");
  EXPECT_EQ(store().job("j_failed")->finished_utc, "t-failed");
  EXPECT_EQ(store().job("j_cancelled")->finished_utc, "t-cancelled");
  EXPECT_EQ(store().summary_json("j_done"), "{}");
}

TEST_F(StoreTest, RequeueOnlyFromRunning) {
  store().insert_job(job_row("j_a"));
  store().mark_running("j_a", "t");
  store().update_progress("j_a", 300);
  store().requeue("j_a");
  auto j = store().job("j_a");
  EXPECT_EQ(j->state, JobState::kQueued);
  EXPECT_EQ(j->histories_done, 0);
  EXPECT_FALSE(j->started_utc.has_value());
  EXPECT_EQ(j->attempts, 1);
  EXPECT_EQ(j->crashes, 0);  // a clean shutdown is not a crash

  store().insert_job(job_row("j_b"));
  store().cancel("j_b", "t");
  store().requeue("j_b");
  EXPECT_EQ(state("j_b"), JobState::kCancelled);
}

TEST_F(StoreTest, RecoverInterruptedRequeuesThenFailsAfterMaxCrashes) {
  store().insert_job(job_row("j_run"));
  store().insert_job(job_row("j_queued"));
  store().insert_job(job_row("j_done"));
  store().mark_running("j_done", "t");
  store().mark_done("j_done", "t", 1000, "{}", {});

  // First crash: requeued, crashes 1.
  store().mark_running("j_run", "t1");
  store().update_progress("j_run", 400);
  EXPECT_EQ(store().recover_interrupted(2, "now1"), std::vector<std::string>{"j_run"});
  auto j = store().job("j_run");
  EXPECT_EQ(j->state, JobState::kQueued);
  EXPECT_EQ(j->crashes, 1);
  EXPECT_EQ(j->attempts, 1);
  EXPECT_EQ(j->histories_done, 0);
  EXPECT_FALSE(j->error_code.has_value());

  // Nothing running: nothing to do.
  EXPECT_TRUE(store().recover_interrupted(2, "now").empty());
  EXPECT_EQ(store().job("j_run")->crashes, 1);

  // Second crash: max_crashes reached -> failed "crashed".
  ASSERT_TRUE(store().mark_running("j_run", "t2"));
  EXPECT_TRUE(store().recover_interrupted(2, "now2").empty());
  j = store().job("j_run");
  EXPECT_EQ(j->state, JobState::kFailed);
  EXPECT_EQ(j->crashes, 2);
  EXPECT_EQ(j->attempts, 2);
  EXPECT_EQ(j->error_code, "crashed");
  ASSERT_TRUE(j->error_message.has_value());
  EXPECT_NE(j->error_message->find("2 times"), std::string::npos) << *j->error_message;
  EXPECT_EQ(j->finished_utc, "now2");

  // Other jobs untouched.
  EXPECT_EQ(state("j_queued"), JobState::kQueued);
  EXPECT_EQ(store().job("j_queued")->crashes, 0);
  EXPECT_EQ(state("j_done"), JobState::kDone);
  EXPECT_EQ(store().job("j_done")->crashes, 0);
}

TEST_F(StoreTest, RecoverInterruptedWithMaxCrashesOneFailsAtOnce) {
  store().insert_job(job_row("j_a"));
  store().insert_job(job_row("j_b"));
  store().mark_running("j_a", "t");
  store().mark_running("j_b", "t");
  EXPECT_TRUE(store().recover_interrupted(1, "now").empty());
  EXPECT_EQ(state("j_a"), JobState::kFailed);
  EXPECT_EQ(state("j_b"), JobState::kFailed);
  EXPECT_EQ(store().job("j_a")->error_code, "crashed");
}

TEST_F(StoreTest, RecoverInterruptedListsEveryRequeuedJobInSubmissionOrder) {
  for (const char* id : {"j_1", "j_2", "j_3"}) store().insert_job(job_row(id));
  store().mark_running("j_3", "t");
  store().mark_running("j_1", "t");
  EXPECT_EQ(store().recover_interrupted(3, "now"), (std::vector<std::string>{"j_1", "j_3"}));
  EXPECT_EQ(state("j_2"), JobState::kQueued);
  EXPECT_EQ(store().job("j_2")->crashes, 0);
}

// Backend jobs the new daemon re-attached to stay running, untouched (no crash counted).
TEST_F(StoreTest, RecoverInterruptedLeavesTheJobsStillRunningAlone) {
  for (const char* id : {"j_1", "j_2", "j_3"}) store().insert_job(job_row(id));
  for (const char* id : {"j_1", "j_2", "j_3"}) store().mark_running(id, "t");
  store().update_progress("j_2", 77);
  const auto running = store().running_jobs();
  ASSERT_EQ(running.size(), 3u);
  EXPECT_EQ(running[0].job_id, "j_1");
  EXPECT_FALSE(running[0].scenario_json.empty()) << "with the scenario";
  EXPECT_EQ(store().recover_interrupted(1, "now", {"j_2", "j_3"}),
            std::vector<std::string>{});  // j_1: failed at once (max_crashes 1)
  EXPECT_EQ(state("j_1"), JobState::kFailed);
  for (const char* id : {"j_2", "j_3"}) {
    EXPECT_EQ(state(id), JobState::kRunning) << id;
    EXPECT_EQ(store().job(id)->crashes, 0) << id;
  }
  EXPECT_EQ(store().job("j_2")->histories_done, 77);
  EXPECT_EQ(store().recover_interrupted(3, "now", {"j_3"}), std::vector<std::string>{"j_2"});
  EXPECT_EQ(state("j_2"), JobState::kQueued);
  EXPECT_EQ(state("j_3"), JobState::kRunning);
}

// docs/http-api.md, JobStatus: "started_utc is the latest start, null while queued". Both
// requeue() (clean shutdown) and recover_interrupted() (crash) clear it.
TEST_F(StoreTest, RecoverInterruptedClearsStartedUtcLikeRequeue) {
  store().insert_job(job_row("j_a"));
  store().mark_running("j_a", "t1");
  ASSERT_EQ(store().recover_interrupted(3, "now"), std::vector<std::string>{"j_a"});
  const auto j = store().job("j_a");
  EXPECT_EQ(j->state, JobState::kQueued);
  EXPECT_FALSE(j->started_utc.has_value()) << "started_utc = " << j->started_utc.value_or("");
}

TEST_F(StoreTest, JobCounts) {
  EXPECT_EQ(store().job_counts(), (std::array<std::int64_t, kJobStateCount>{0, 0, 0, 0, 0}));
  for (const char* id : {"j_1", "j_2", "j_3", "j_4", "j_5", "j_6", "j_7"})
    store().insert_job(job_row(id));
  store().mark_running("j_1", "t");
  store().mark_running("j_2", "t");
  store().mark_done("j_2", "t", 1, "{}", {});
  store().mark_failed("j_3", "t", "x", "y");
  store().cancel("j_4", "t");
  store().cancel("j_5", "t");
  // queued: 6, 7; running: 1; done: 2; failed: 3; cancelled: 4, 5
  EXPECT_EQ(store().job_counts(), (std::array<std::int64_t, kJobStateCount>{2, 1, 1, 1, 2}));
}

TEST_F(StoreTest, JobsListNewestFirstWithStateAndLimit) {
  for (const char* id : {"j_1", "j_2", "j_3", "j_4"}) store().insert_job(job_row(id));
  store().cancel("j_2", "t");
  const auto ids = [](const std::vector<JobRow>& rows) {
    std::vector<std::string> out;
    for (const auto& r : rows) out.push_back(r.job_id);
    return out;
  };
  EXPECT_EQ(ids(store().jobs(std::nullopt, 1000)),
            (std::vector<std::string>{"j_4", "j_3", "j_2", "j_1"}));
  EXPECT_EQ(ids(store().jobs(std::nullopt, 2)), (std::vector<std::string>{"j_4", "j_3"}));
  EXPECT_EQ(ids(store().jobs(JobState::kQueued, 1000)),
            (std::vector<std::string>{"j_4", "j_3", "j_1"}));
  EXPECT_EQ(ids(store().jobs(JobState::kCancelled, 1000)), std::vector<std::string>{"j_2"});
  EXPECT_TRUE(store().jobs(JobState::kDone, 1000).empty());
}

// ---- Sites ----

TEST_F(StoreTest, SitesOldestFirstAndDelete) {
  EXPECT_EQ(store().site_count(), 0);
  store().insert_site({"s_b", "t1", R"({"b":1})"});
  store().insert_site({"s_a", "t2", R"({"a":1})"});
  store().insert_site({"s_c", "t3", R"({"c":1})"});
  EXPECT_EQ(store().site_count(), 3);
  auto sites = store().sites();
  ASSERT_EQ(sites.size(), 3u);
  EXPECT_EQ(sites[0].site_id, "s_b");
  EXPECT_EQ(sites[0].created_utc, "t1");
  EXPECT_EQ(sites[0].summary_json, R"({"b":1})");
  EXPECT_EQ(sites[1].site_id, "s_a");
  EXPECT_EQ(sites[2].site_id, "s_c");

  EXPECT_TRUE(store().delete_site("s_a"));
  EXPECT_FALSE(store().delete_site("s_a"));
  EXPECT_FALSE(store().delete_site("s_missing"));
  EXPECT_EQ(store().site_count(), 2);
  sites = store().sites();
  ASSERT_EQ(sites.size(), 2u);
  EXPECT_EQ(sites[0].site_id, "s_b");
  EXPECT_EQ(sites[1].site_id, "s_c");
}

TEST_F(StoreTest, DuplicateSiteIsAnError) {
  store().insert_site({"s_a", "t1", "{}"});
  EXPECT_THROW(store().insert_site({"s_a", "t2", "{}"}), std::runtime_error);
  EXPECT_EQ(store().site_count(), 1);
}

TEST_F(StoreTest, ActiveJobsUsingCountsOnlyQueuedAndRunning) {
  const std::string site = "s_0123456789abcdef";
  EXPECT_EQ(store().active_jobs_using(site), 0);
  for (const char* id : {"j_q", "j_r", "j_d", "j_f", "j_c"})
    store().insert_job(job_row(id, 0, std::nullopt, site));
  store().insert_job(job_row("j_other", 0, std::nullopt, "s_fedcba9876543210"));
  store().insert_job(job_row("j_inline"));
  EXPECT_EQ(store().active_jobs_using(site), 5);
  store().mark_running("j_r", "t");
  store().mark_running("j_d", "t");
  store().mark_done("j_d", "t", 1, "{}", {});
  store().mark_failed("j_f", "t", "x", "y");
  store().cancel("j_c", "t");
  EXPECT_EQ(store().active_jobs_using(site), 2);  // j_q, j_r
  store().cancel("j_q", "t");
  store().cancel("j_r", "t");
  EXPECT_EQ(store().active_jobs_using(site), 0);
  EXPECT_EQ(store().active_jobs_using("s_fedcba9876543210"), 1);
}

// ---- Database ----

// ---- Purge (server/purge.h) ----

TEST_F(StoreTest, OnlyAFinishedJobIsRemovedWithItsBuildings) {
  store().insert_job(job_row("j_q"));
  store().insert_job(job_row("j_r"));
  store().insert_job(job_row("j_d"));
  ASSERT_TRUE(store().mark_running("j_r", "t"));
  ASSERT_TRUE(store().mark_running("j_d", "t"));
  ASSERT_TRUE(store().mark_done("j_d", "2026-01-01T00:01:00.000Z", 1000, "{}",
                                {building("B", 1.0), building("C", 2.0)}));
  for (const char* id : {"j_q", "j_r"}) {
    const auto r = store().remove_finished_job(id);
    EXPECT_EQ(r.outcome, Store::Removal::Outcome::kNotFinished) << id;
    EXPECT_TRUE(store().has_job(id));
  }
  EXPECT_EQ(store().remove_finished_job("j_none").outcome, Store::Removal::Outcome::kNoSuchJob);
  const auto r = store().remove_finished_job("j_d");
  EXPECT_EQ(r.outcome, Store::Removal::Outcome::kRemoved);
  EXPECT_EQ(r.state, JobState::kDone);
  EXPECT_FALSE(store().has_job("j_d"));
  EXPECT_FALSE(store().job("j_d").has_value());
  EXPECT_TRUE(store().buildings("j_d").empty());
  EXPECT_EQ(store().remove_finished_job("j_d").outcome, Store::Removal::Outcome::kNoSuchJob);
  // A cancelled or failed job goes the same way.
  store().cancel("j_q", "2026-01-01T00:02:00.000Z");
  EXPECT_EQ(store().remove_finished_job("j_q").outcome, Store::Removal::Outcome::kRemoved);
  reopen();
  EXPECT_FALSE(store().has_job("j_d"));
  EXPECT_TRUE(store().has_job("j_r"));
  EXPECT_EQ(store().integrity_check(), "ok");
}

TEST_F(StoreTest, TheBaseOfAnActiveComparisonStays) {
  store().insert_job(job_row("j_base"));
  ASSERT_TRUE(store().mark_running("j_base", "t"));
  ASSERT_TRUE(store().mark_done("j_base", "2026-01-01T00:01:00.000Z", 1000, "{}", {}));
  JobRow variant = job_row("j_variant");
  variant.scenario_json = R"({"compare_with": "j_base", "fragment_groups": []})";
  store().insert_job(variant);
  const auto r = store().remove_finished_job("j_base");
  EXPECT_EQ(r.outcome, Store::Removal::Outcome::kComparisonBase);
  EXPECT_EQ(r.comparisons, 1);
  EXPECT_TRUE(store().has_job("j_base"));
  store().cancel("j_variant", "2026-01-01T00:02:00.000Z");
  EXPECT_EQ(store().remove_finished_job("j_base").outcome, Store::Removal::Outcome::kRemoved);
}

TEST_F(StoreTest, FinishedJobsEarliestFinishedFirst) {
  for (const char* id : {"j_1", "j_2", "j_3", "j_4"}) store().insert_job(job_row(id));
  ASSERT_TRUE(store().mark_running("j_1", "t"));
  ASSERT_TRUE(store().mark_done("j_1", "2026-03-01T00:00:00.000Z", 1, "{}", {}));
  ASSERT_TRUE(store().mark_running("j_2", "t"));
  ASSERT_TRUE(store().mark_failed("j_2", "2026-01-01T00:00:00.000Z", "internal", "x"));
  store().cancel("j_3", "2026-02-01T00:00:00.000Z");
  const auto f = store().finished_jobs();  // j_4 is queued: not listed
  ASSERT_EQ(f.size(), 3u);
  EXPECT_EQ(f[0].job_id, "j_2");
  EXPECT_EQ(f[0].state, JobState::kFailed);
  EXPECT_EQ(f[1].job_id, "j_3");
  EXPECT_EQ(f[1].state, JobState::kCancelled);
  EXPECT_EQ(f[2].job_id, "j_1");
  EXPECT_EQ(f[2].finished_utc, "2026-03-01T00:00:00.000Z");
}

TEST_F(StoreTest, IntegrityCheckIsOk) {
  EXPECT_EQ(store().integrity_check(), "ok");
  store().insert_job(job_row("j_a", 0, "k"));
  store().mark_running("j_a", "t");
  store().mark_done("j_a", "t", 1, "{}", {building("B1", 1), building("B2", 2)});
  store().insert_site({"s_a", "t", "{}"});
  EXPECT_EQ(store().integrity_check(), "ok");
}

TEST_F(StoreTest, ReopeningKeepsEverything) {
  store().insert_site({"s_a", "t1", R"({"a":1})"});
  store().insert_site({"s_b", "t2", R"({"b":1})"});
  store().insert_job(job_row("j_done", 3, "key-done", "s_a"));
  store().mark_running("j_done", "started");
  store().mark_done("j_done", "finished", 1000, R"({"summary":true})",
                    {building("B1", 2.5), building("A0", 0.5)});
  store().insert_job(job_row("j_queued", -2, std::nullopt, "s_b"));
  store().insert_job(job_row("j_cancelled"));
  store().cancel("j_cancelled", "c");

  reopen();

  EXPECT_EQ(store().integrity_check(), "ok");
  EXPECT_EQ(store().site_count(), 2);
  const auto sites = store().sites();
  ASSERT_EQ(sites.size(), 2u);
  EXPECT_EQ(sites[0].site_id, "s_a");
  EXPECT_EQ(sites[0].summary_json, R"({"a":1})");
  EXPECT_EQ(sites[1].site_id, "s_b");

  const auto done = store().job("j_done");
  ASSERT_TRUE(done.has_value());
  EXPECT_EQ(done->state, JobState::kDone);
  EXPECT_EQ(done->priority, 3);
  EXPECT_EQ(done->idempotency_key, "key-done");
  EXPECT_EQ(done->site_id, "s_a");
  EXPECT_EQ(done->attempts, 1);
  EXPECT_EQ(done->started_utc, "started");
  EXPECT_EQ(done->finished_utc, "finished");
  EXPECT_EQ(done->histories_done, 1000);
  EXPECT_EQ(store().summary_json("j_done"), R"({"summary":true})");
  const auto b = store().buildings("j_done");
  ASSERT_EQ(b.size(), 2u);
  EXPECT_EQ(b[0].building_id, "B1");
  EXPECT_EQ(b[0].expected_impacts, 2.5);
  EXPECT_EQ(b[1].building_id, "A0");

  EXPECT_EQ(state("j_queued"), JobState::kQueued);
  EXPECT_EQ(state("j_cancelled"), JobState::kCancelled);
  EXPECT_EQ(store().next_queued()->job_id, "j_queued");
  EXPECT_EQ(store().job_counts(), (std::array<std::int64_t, kJobStateCount>{1, 0, 1, 0, 1}));
  EXPECT_EQ(store().active_jobs_using("s_b"), 1);

  // The idempotency key and the submission order survive too.
  const auto again = store().insert_job(job_row("j_x", 0, "key-done"));
  EXPECT_FALSE(again.created);
  EXPECT_EQ(again.job.job_id, "j_done");
  EXPECT_EQ(store().insert_job(job_row("j_new")).job.seq, 4);
}

TEST_F(StoreTest, RunningJobSurvivesReopenForRecovery) {
  // A daemon killed while a job ran: the row is still "running" when the file is reopened.
  store().insert_job(job_row("j_a"));
  store().mark_running("j_a", "t");
  reopen();
  EXPECT_EQ(state("j_a"), JobState::kRunning);
  EXPECT_EQ(store().recover_interrupted(3, "now"), std::vector<std::string>{"j_a"});
  reopen();
  EXPECT_EQ(state("j_a"), JobState::kQueued);
  EXPECT_EQ(store().job("j_a")->crashes, 1);
}

TEST_F(StoreTest, OwnerIsStoredAndReadBack) {
  JobRow r = job_row("j_mine");
  r.owner = "tok_0123456789abcdef";
  store().insert_job(r);
  store().insert_job(job_row("j_anonymous"));
  reopen();
  EXPECT_EQ(store().job("j_mine")->owner, "tok_0123456789abcdef");
  EXPECT_EQ(store().jobs(std::nullopt, 10).back().owner, "tok_0123456789abcdef");
  EXPECT_FALSE(store().job("j_anonymous")->owner.has_value());
}

TEST(StoreOpen, ADatabaseOfAnEarlierDaemonGetsTheOwnerColumnAndKeepsItsJobs) {
  // The jobs table as fragsimd created it before owners were recorded.
  const fs::path dir = api::testing::fresh_test_dir("fragsim_store_migrate_");
  const std::string path = (dir / "fragsimd.sqlite").string();
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  const char* old_schema =
      "CREATE TABLE jobs (job_id TEXT PRIMARY KEY, seq INTEGER NOT NULL UNIQUE, site_id TEXT, "
      "priority INTEGER NOT NULL, state TEXT NOT NULL, idempotency_key TEXT UNIQUE, "
      "request_sha256 TEXT NOT NULL, scenario_json TEXT NOT NULL, histories_total INTEGER NOT "
      "NULL, histories_done INTEGER NOT NULL DEFAULT 0, attempts INTEGER NOT NULL DEFAULT 0, "
      "crashes INTEGER NOT NULL DEFAULT 0, created_utc TEXT NOT NULL, started_utc TEXT, "
      "finished_utc TEXT, error_code TEXT, error_message TEXT, summary_json TEXT);"
      "INSERT INTO jobs (job_id, seq, priority, state, request_sha256, scenario_json, "
      "histories_total, created_utc) VALUES ('j_old', 1, 0, 'queued', 'x', '{}', 10, 't');";
  ASSERT_EQ(sqlite3_exec(db, old_schema, nullptr, nullptr, nullptr), SQLITE_OK);
  sqlite3_close(db);
  {
    Store s(path);
    const auto old = s.job("j_old");
    ASSERT_TRUE(old.has_value());
    EXPECT_FALSE(old->owner.has_value());
    JobRow r = job_row("j_new");
    r.owner = "tok_fedcba9876543210";
    s.insert_job(r);
    EXPECT_EQ(s.job("j_new")->owner, "tok_fedcba9876543210");
    EXPECT_EQ(s.next_queued()->job_id, "j_old");
  }
  Store again(path);  // the column is not added twice
  EXPECT_EQ(again.job("j_new")->owner, "tok_fedcba9876543210");
  EXPECT_EQ(again.upgraded_from(), kStoreSchemaVersion);
  fs::remove_all(dir);
}

TEST(StoreOpen, ANewStoreHasTheCurrentSchemaVersion) {
  const fs::path dir = api::testing::fresh_test_dir("fragsim_store_version_");
  const std::string path = (dir / "fragsimd.sqlite").string();
  {
    Store s(path);
    EXPECT_EQ(s.upgraded_from(), 0);
  }
  EXPECT_EQ(testing::meta_schema_version(path), std::to_string(kStoreSchemaVersion));
  Store again(path);
  EXPECT_EQ(again.upgraded_from(), kStoreSchemaVersion);
  fs::remove_all(dir);
}

// A store of a later schema (a newer fragsimd wrote it) is refused with a message saying so,
// and left as it was, byte for byte; so is one whose version cannot be read.
TEST(StoreOpen, ANewerStoreIsRefusedUntouched) {
  const fs::path dir = api::testing::fresh_test_dir("fragsim_store_newer_");
  const std::string path = (dir / "fragsimd.sqlite").string();
  {
    Store s(path);
    s.insert_job(job_row("j_kept"));
  }
  for (const std::string& version : {std::to_string(kStoreSchemaVersion + 1), std::string("2b")}) {
    SCOPED_TRACE(version);
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
    const std::string sql = "PRAGMA journal_mode = DELETE; UPDATE meta SET value = '" + version +
                            "' WHERE key = 'schema_version';";
    ASSERT_EQ(sqlite3_exec(db, sql.c_str(), nullptr, nullptr, nullptr), SQLITE_OK);
    sqlite3_close(db);
    const std::string before = api::testing::read_text(path);
    try {
      Store s(path);
      FAIL() << "opened a store of schema " << version;
    } catch (const StoreVersionError& e) {
      const std::string m = e.what();
      EXPECT_NE(m.find("newer fragsimd"), std::string::npos) << m;
      EXPECT_NE(m.find("reads versions 1 to " + std::to_string(kStoreSchemaVersion)),
                std::string::npos)
          << m;
      EXPECT_NE(m.find("nothing was changed"), std::string::npos) << m;
    }
    EXPECT_EQ(api::testing::read_text(path), before);
    EXPECT_EQ(testing::meta_schema_version(path), version);
  }
  fs::remove_all(dir);
}

TEST(StoreOpen, UnopenablePathThrows) {
  const fs::path dir = api::testing::fresh_test_dir("fragsim_store_open_");
  const std::string path = (dir / "no" / "such" / "dir" / "db.sqlite").string();
  EXPECT_THROW({ Store s(path); }, std::runtime_error);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace fragsim::server
