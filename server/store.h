#pragma once
// fragsimd's persistent state in SQLite (WAL, synchronous=FULL): the site catalogue, the job queue
// and each finished job's headline figures. A job accepted with 202 is a committed row here before
// the response is sent, so no crash can lose it.
//
// One connection, serialised by a mutex: the daemon's writes are few (submissions, state changes,
// progress once a second) and each is one short transaction.
#include <sqlite3.h>

#include <cstdint>
#include <mutex>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

namespace fragsim::server {

enum class JobState { kQueued, kRunning, kDone, kFailed, kCancelled };
inline constexpr int kJobStateCount = 5;
const char* job_state_name(JobState s);
std::optional<JobState> parse_job_state(std::string_view name);
bool is_final(JobState s);

struct SiteRow {
  std::string site_id;
  std::string created_utc;
  std::string summary_json;  // SiteSummary without jobs_using
};

struct JobRow {
  std::string job_id;
  std::int64_t seq = 0;  // submission order
  std::optional<std::string> site_id;
  int priority = 0;
  JobState state = JobState::kQueued;
  std::optional<std::string> idempotency_key;
  std::string request_sha256;  // of the scenario as stored (idempotency comparison)
  std::string scenario_json;   // the request without priority and idempotency_key; empty from
                               // job() and jobs(), which serve status requests
  std::int64_t histories_total = 0;
  std::int64_t histories_done = 0;
  int attempts = 0;  // times started
  int crashes = 0;   // starts that ended with the daemon dying
  std::string created_utc;
  std::optional<std::string> started_utc;
  std::optional<std::string> finished_utc;
  std::optional<std::string> error_code;
  std::optional<std::string> error_message;
  std::optional<std::string> owner;  // who submitted it: "tok_" + 16 hex of the token's SHA-256
};

struct BuildingRow {
  std::string building_id;
  double expected_impacts = 0.0;
  double impacts_std_error = 0.0;
  double expected_penetrations = 0.0;
  double penetrations_std_error = 0.0;
};

// The store's schema version this fragsimd writes (docs/operations.md, "Upgrades"); it opens
// every earlier one, upgrading it in place, and refuses a later one.
inline constexpr int kStoreSchemaVersion = 2;

// A store of a newer schema: refused before anything is written.
class StoreVersionError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// SQLite failures (disk full, corruption): std::runtime_error naming the statement's purpose.
class Store {
 public:
  explicit Store(const std::string& path);
  ~Store();
  // The schema version the store had when opened (kStoreSchemaVersion if it was current;
  // 0: a new store).
  int upgraded_from() const { return upgraded_from_; }
  Store(const Store&) = delete;
  Store& operator=(const Store&) = delete;

  // ---- Sites ----
  void insert_site(const SiteRow& row);
  std::vector<SiteRow> sites();  // oldest first
  bool delete_site(const std::string& site_id);
  std::int64_t site_count();
  // Queued or running jobs naming the site.
  std::int64_t active_jobs_using(const std::string& site_id);

  // ---- Jobs ----
  struct Insert {
    JobRow job;            // the new row, or the existing one with the same idempotency key
    bool created = false;  // false: the key was known
  };
  // Inserts `row` (seq assigned here). With an idempotency key already in the table, nothing is
  // inserted and the existing job comes back.
  Insert insert_job(JobRow row);
  std::optional<JobRow> job(const std::string& job_id);
  // The job with its scenario_json (job() leaves it empty), for a comparison's base.
  std::optional<JobRow> job_with_scenario(const std::string& job_id);
  bool has_idempotency_key(const std::string& key);
  // Newest first, optionally one state only.
  std::vector<JobRow> jobs(std::optional<JobState> state, int limit);
  std::array<std::int64_t, kJobStateCount> job_counts();
  // The next job to run: highest priority, then oldest.
  std::optional<JobRow> next_queued();
  // queued -> running; attempts + 1. False if the job is no longer queued.
  bool mark_running(const std::string& job_id, const std::string& started_utc);
  void update_progress(const std::string& job_id, std::int64_t histories_done);
  // running -> done with the figures, in one transaction. False if the job is no longer running
  // (cancelled meanwhile): nothing is written.
  bool mark_done(const std::string& job_id, const std::string& finished_utc,
                 std::int64_t histories_done, const std::string& summary_json,
                 const std::vector<BuildingRow>& buildings);
  bool mark_failed(const std::string& job_id, const std::string& finished_utc,
                   const std::string& code, const std::string& message);
  // queued|running -> cancelled. Returns the state before (nullopt: no such job).
  std::optional<JobState> cancel(const std::string& job_id, const std::string& finished_utc);
  // running -> queued (clean shutdown: the job reruns next time; not counted as a crash).
  void requeue(const std::string& job_id);
  // failed -> queued, its error, progress and crash count cleared, unless it failed for its
  // input (invalid_input: it would fail again). Returns the job as it was (nullopt: no such job);
  // it was queued again if that row is failed with another code.
  std::optional<JobRow> retry(const std::string& job_id);
  // At start: jobs left running by a dead daemon. Each is queued again (crashes + 1), or marked
  // failed with code "crashed" once it has crashed `max_crashes` times; except those in
  // `still_running` (backend jobs the new daemon follows again), which stay running. Returns the
  // ids requeued.
  std::vector<std::string> recover_interrupted(int max_crashes, const std::string& now_utc,
                                               const std::vector<std::string>& still_running = {});
  // The running jobs, with their scenarios, oldest first.
  std::vector<JobRow> running_jobs();

  // ---- Purge (server/purge.h) ----
  struct Removal {
    enum class Outcome {
      kRemoved,  // its rows are gone
      kNoSuchJob,
      kNotFinished,     // queued or running: cancel it first
      kComparisonBase,  // a queued or running comparison pairs with it
    } outcome = Outcome::kNoSuchJob;
    JobState state = JobState::kFailed;  // the job's state when it was found
    std::int64_t comparisons = 0;        // kComparisonBase: how many
  };
  // Removes a finished (done, failed or cancelled) job's rows in one transaction.
  Removal remove_finished_job(const std::string& job_id);
  struct Finished {
    std::string job_id;
    std::string finished_utc;  // ISO 8601, so that text order is time order
    JobState state = JobState::kDone;
  };
  // Finished jobs, the earliest finished first (ties: submission order).
  std::vector<Finished> finished_jobs();
  // Job ids with a row, for the start's sweep of directories whose job was purged.
  bool has_job(const std::string& job_id);

  std::optional<std::string> summary_json(const std::string& job_id);
  std::vector<BuildingRow> buildings(const std::string& job_id);

  // "ok" when PRAGMA integrity_check finds nothing wrong.
  std::string integrity_check();

 private:
  class Statement;
  void exec(const char* sql, const char* what);
  void close() noexcept;
  int schema_version();
  void refuse_newer(const std::string& path);
  void migrate();
  // Runs `body` in one write transaction; rolled back if it throws. Defined in store.cpp.
  template <class F>
  auto transaction(F&& body);
  JobRow read_job(Statement& s);
  std::optional<JobRow> job_by_id(const std::string& job_id, const char* columns);

  std::mutex mutex_;
  sqlite3* db_ = nullptr;
  int upgraded_from_ = 0;
  std::unordered_map<std::string, sqlite3_stmt*> statements_;  // prepared, by SQL text
};

}  // namespace fragsim::server
