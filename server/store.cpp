#include "server/store.h"

#include <array>
#include <cerrno>
#include <stdexcept>

#include "formats/output_dir.h"
#include "fragsim/version.h"

namespace fragsim::server {

namespace {

constexpr std::array<const char*, kJobStateCount> kStateNames = {"queued", "running", "done",
                                                                 "failed", "cancelled"};

constexpr const char* kSchema = R"sql(
CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS sites (
  site_id      TEXT PRIMARY KEY,
  seq          INTEGER NOT NULL,
  created_utc  TEXT NOT NULL,
  summary_json TEXT NOT NULL
);
CREATE TABLE IF NOT EXISTS jobs (
  job_id          TEXT PRIMARY KEY,
  seq             INTEGER NOT NULL UNIQUE,
  site_id         TEXT,
  priority        INTEGER NOT NULL,
  state           TEXT NOT NULL
                  CHECK (state IN ('queued', 'running', 'done', 'failed', 'cancelled')),
  idempotency_key TEXT UNIQUE,
  request_sha256  TEXT NOT NULL,
  scenario_json   TEXT NOT NULL,
  histories_total INTEGER NOT NULL,
  histories_done  INTEGER NOT NULL DEFAULT 0,
  attempts        INTEGER NOT NULL DEFAULT 0,
  crashes         INTEGER NOT NULL DEFAULT 0,
  created_utc     TEXT NOT NULL,
  started_utc     TEXT,
  finished_utc    TEXT,
  error_code      TEXT,
  error_message   TEXT,
  summary_json    TEXT,
  owner           TEXT
);
CREATE INDEX IF NOT EXISTS jobs_by_queue ON jobs (state, priority DESC, seq);
CREATE TABLE IF NOT EXISTS job_buildings (
  job_id                 TEXT NOT NULL REFERENCES jobs (job_id) ON DELETE CASCADE,
  idx                    INTEGER NOT NULL,
  building_id            TEXT NOT NULL,
  expected_impacts       REAL NOT NULL,
  impacts_std_error      REAL NOT NULL,
  expected_penetrations  REAL NOT NULL,
  penetrations_std_error REAL NOT NULL,
  PRIMARY KEY (job_id, idx)
);
INSERT OR IGNORE INTO meta (key, value) VALUES ('schema_version', '1');
)sql";

constexpr const char* kJobColumns =
    "job_id, seq, site_id, priority, state, idempotency_key, request_sha256, scenario_json, "
    "histories_total, histories_done, attempts, crashes, created_utc, started_utc, finished_utc, "
    "error_code, error_message, owner";
// The same without the scenario (an empty string in its place): a status poll must not copy a
// scenario with an inline site of megabytes (it was 11 % of the daemon's time under wrk).
constexpr const char* kJobStatusColumns =
    "job_id, seq, site_id, priority, state, idempotency_key, request_sha256, '', "
    "histories_total, histories_done, attempts, crashes, created_utc, started_utc, finished_utc, "
    "error_code, error_message, owner";

// SQLITE_FULL (the disk or a quota is full) is a StorageFullError naming the database file, as
// a full disk anywhere else; other errors name the statement.
[[noreturn]] void throw_database_error(sqlite3* db, const char* what, const std::string& message) {
  if (sqlite3_errcode(db) == SQLITE_FULL) {
    const char* file = sqlite3_db_filename(db, "main");
    throw formats::StorageFullError(file != nullptr ? file : "the database", ENOSPC, -1);
  }
  throw std::runtime_error(std::string("database error (") + what + "): " + message);
}

}  // namespace

const char* job_state_name(JobState s) {
  return kStateNames[static_cast<std::size_t>(s)];
}

std::optional<JobState> parse_job_state(std::string_view name) {
  for (std::size_t k = 0; k < kStateNames.size(); ++k)
    if (name == kStateNames[k]) return static_cast<JobState>(k);
  return std::nullopt;
}

bool is_final(JobState s) {
  return s == JobState::kDone || s == JobState::kFailed || s == JobState::kCancelled;
}

// A prepared statement; bind by position (1-based), step, read columns.
class Store::Statement {
 public:
  // Prepared once per SQL text and kept (store.statements_): preparing was a fifth of the time
  // of a status request. With the store's mutex held.
  Statement(Store& store, const std::string& sql, const char* what) : db_(store.db_), what_(what) {
    auto& cached = store.statements_[sql];
    if (!cached && sqlite3_prepare_v3(db_, sql.c_str(), -1, SQLITE_PREPARE_PERSISTENT, &cached,
                                      nullptr) != SQLITE_OK) {
      store.statements_.erase(sql);
      fail();
    }
    stmt_ = cached;
  }
  ~Statement() {
    sqlite3_reset(stmt_);
    sqlite3_clear_bindings(stmt_);
  }
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;

  Statement& bind(int i, const std::string& v) {
    check(sqlite3_bind_text(stmt_, i, v.data(), static_cast<int>(v.size()), SQLITE_TRANSIENT));
    return *this;
  }
  Statement& bind(int i, const std::optional<std::string>& v) {
    if (!v) {
      check(sqlite3_bind_null(stmt_, i));
      return *this;
    }
    return bind(i, *v);
  }
  Statement& bind(int i, std::int64_t v) {
    check(sqlite3_bind_int64(stmt_, i, v));
    return *this;
  }
  Statement& bind(int i, int v) { return bind(i, static_cast<std::int64_t>(v)); }
  Statement& bind(int i, double v) {
    check(sqlite3_bind_double(stmt_, i, v));
    return *this;
  }
  // True while there is a row.
  bool step() {
    const int rc = sqlite3_step(stmt_);
    if (rc == SQLITE_ROW) return true;
    if (rc == SQLITE_DONE) return false;
    fail();
  }
  void run() {
    while (step()) {
    }
  }
  std::string text(int col) const {
    const auto* p = reinterpret_cast<const char*>(sqlite3_column_text(stmt_, col));
    return p ? std::string(p, static_cast<std::size_t>(sqlite3_column_bytes(stmt_, col)))
             : std::string();
  }
  std::optional<std::string> optional_text(int col) const {
    if (sqlite3_column_type(stmt_, col) == SQLITE_NULL) return std::nullopt;
    return text(col);
  }
  std::int64_t integer(int col) const { return sqlite3_column_int64(stmt_, col); }
  double real(int col) const { return sqlite3_column_double(stmt_, col); }

 private:
  void check(int rc) {
    if (rc != SQLITE_OK) fail();
  }
  [[noreturn]] void fail() { throw_database_error(db_, what_, sqlite3_errmsg(db_)); }
  sqlite3* db_;
  const char* what_;
  sqlite3_stmt* stmt_ = nullptr;
};

Store::Store(const std::string& path) {
  if (sqlite3_open_v2(path.c_str(), &db_,
                      SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_FULLMUTEX,
                      nullptr) != SQLITE_OK) {
    const std::string message = db_ ? sqlite3_errmsg(db_) : "out of memory";
    sqlite3_close(db_);
    throw std::runtime_error("cannot open database " + path + ": " + message);
  }
  sqlite3_busy_timeout(db_, 10000);
  try {
    refuse_newer(path);  // before anything is written, the journal mode too
    exec("PRAGMA journal_mode = WAL", "journal mode");
    // FULL: a transaction that returned is on disk (a 202 must survive a power cut).
    exec("PRAGMA synchronous = FULL", "synchronous");
    exec("PRAGMA foreign_keys = ON", "foreign keys");
    const int before = schema_version();  // 0: a new store
    exec(kSchema, "schema");
    migrate();
    upgraded_from_ = before;
  } catch (...) {
    close();  // a refused or failed store: its cached statements too, or the close fails
    throw;
  }
}

Store::~Store() {
  close();
}

void Store::close() noexcept {
  for (auto& [sql, stmt] : statements_) sqlite3_finalize(stmt);
  statements_.clear();
  sqlite3_close(db_);
  db_ = nullptr;
}

void Store::exec(const char* sql, const char* what) {
  char* error = nullptr;
  if (sqlite3_exec(db_, sql, nullptr, nullptr, &error) != SQLITE_OK) {
    const std::string message = error ? error : sqlite3_errmsg(db_);
    sqlite3_free(error);
    throw_database_error(db_, what, message);
  }
}

template <class F>
auto Store::transaction(F&& body) {
  exec("BEGIN IMMEDIATE", "begin");
  try {
    auto result = body();  // the body's statements are finalised before the commit
    exec("COMMIT", "commit");
    return result;
  } catch (...) {
    sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
    throw;
  }
}

// The schema version in meta.schema_version (docs/operations.md, "Upgrades"); 0 when the store
// has none yet (a new file).
int Store::schema_version() {
  Statement t(*this, "SELECT 1 FROM sqlite_master WHERE type = 'table' AND name = 'meta'",
              "meta table");
  if (!t.step()) return 0;
  Statement s(*this, "SELECT value FROM meta WHERE key = 'schema_version'", "schema version");
  if (!s.step()) return 0;
  const std::string v = s.text(0);
  int n = 0;
  for (const char c : v) {
    if (c < '0' || c > '9' || n > 100000) return -1;
    n = n * 10 + (c - '0');
  }
  return v.empty() ? -1 : n;
}

// A store written by a newer fragsimd is refused untouched: its tables may mean what this one
// cannot know.
void Store::refuse_newer(const std::string& path) {
  const int v = schema_version();
  if (v >= 0 && v <= kStoreSchemaVersion) return;
  throw StoreVersionError(
      "the store " + path + " has schema version " +
      (v < 0 ? std::string("(unreadable)") : std::to_string(v)) +
      ", written by a newer fragsimd; this one (" + kVersion + ") reads versions 1 to " +
      std::to_string(kStoreSchemaVersion) +
      ": run the fragsimd that wrote it, or restore a backup made before the upgrade "
      "(docs/operations.md, \"Upgrades\"); nothing was changed");
}

// Brings an earlier store (or a new one, made at version 1 by kSchema) to this version, in one
// transaction.
//   1  the first schema (fragsimd 0.1.0 of 2026-11-23); stores written before versions were
//      kept say 1, with or without jobs.owner
//   2  jobs.owner (who submitted a job; every store fragsimd writes since this version)
void Store::migrate() {
  if (schema_version() == kStoreSchemaVersion) return;
  transaction([&] {
    bool has_owner = false;
    {
      Statement s(*this, "SELECT name FROM pragma_table_info('jobs')", "table info");
      while (s.step()) has_owner = has_owner || s.text(0) == "owner";
    }
    if (!has_owner) exec("ALTER TABLE jobs ADD COLUMN owner TEXT", "add column owner");
    Statement u(*this, "UPDATE meta SET value = ?1 WHERE key = 'schema_version'", "schema version");
    u.bind(1, std::to_string(kStoreSchemaVersion)).run();
    return 0;
  });
}

// ---- Sites ----

void Store::insert_site(const SiteRow& row) {
  const std::lock_guard<std::mutex> lock(mutex_);
  Statement s(*this,
              "INSERT INTO sites (site_id, seq, created_utc, summary_json) VALUES "
              "(?1, (SELECT COALESCE(MAX(seq), 0) + 1 FROM sites), ?2, ?3)",
              "insert site");
  s.bind(1, row.site_id).bind(2, row.created_utc).bind(3, row.summary_json).run();
}

std::vector<SiteRow> Store::sites() {
  const std::lock_guard<std::mutex> lock(mutex_);
  Statement s(*this, "SELECT site_id, created_utc, summary_json FROM sites ORDER BY seq",
              "list sites");
  std::vector<SiteRow> out;
  while (s.step()) out.push_back({s.text(0), s.text(1), s.text(2)});
  return out;
}

bool Store::delete_site(const std::string& site_id) {
  const std::lock_guard<std::mutex> lock(mutex_);
  Statement s(*this, "DELETE FROM sites WHERE site_id = ?1", "delete site");
  s.bind(1, site_id).run();
  return sqlite3_changes(db_) > 0;
}

std::int64_t Store::site_count() {
  const std::lock_guard<std::mutex> lock(mutex_);
  Statement s(*this, "SELECT COUNT(*) FROM sites", "count sites");
  s.step();
  return s.integer(0);
}

std::int64_t Store::active_jobs_using(const std::string& site_id) {
  const std::lock_guard<std::mutex> lock(mutex_);
  Statement s(*this,
              "SELECT COUNT(*) FROM jobs WHERE site_id = ?1 AND state IN ('queued', 'running')",
              "jobs using site");
  s.bind(1, site_id).step();
  return s.integer(0);
}

// ---- Jobs ----

JobRow Store::read_job(Statement& s) {
  JobRow r;
  r.job_id = s.text(0);
  r.seq = s.integer(1);
  r.site_id = s.optional_text(2);
  r.priority = static_cast<int>(s.integer(3));
  r.state = parse_job_state(s.text(4)).value_or(JobState::kFailed);
  r.idempotency_key = s.optional_text(5);
  r.request_sha256 = s.text(6);
  r.scenario_json = s.text(7);
  r.histories_total = s.integer(8);
  r.histories_done = s.integer(9);
  r.attempts = static_cast<int>(s.integer(10));
  r.crashes = static_cast<int>(s.integer(11));
  r.created_utc = s.text(12);
  r.started_utc = s.optional_text(13);
  r.finished_utc = s.optional_text(14);
  r.error_code = s.optional_text(15);
  r.error_message = s.optional_text(16);
  r.owner = s.optional_text(17);
  return r;
}

Store::Insert Store::insert_job(JobRow row) {
  const std::lock_guard<std::mutex> lock(mutex_);
  return transaction([&]() -> Insert {
    if (row.idempotency_key) {
      Statement q(*this,
                  std::string("SELECT ") + kJobColumns + " FROM jobs WHERE idempotency_key = ?1",
                  "find idempotency key");
      q.bind(1, row.idempotency_key);
      if (q.step()) return {read_job(q), false};
    }
    {
      Statement s(*this, "SELECT COALESCE(MAX(seq), 0) + 1 FROM jobs", "next seq");
      s.step();
      row.seq = s.integer(0);
    }
    Statement s(*this,
                "INSERT INTO jobs (job_id, seq, site_id, priority, state, idempotency_key, "
                "request_sha256, scenario_json, histories_total, created_utc, owner) VALUES "
                "(?1, ?2, ?3, ?4, 'queued', ?5, ?6, ?7, ?8, ?9, ?10)",
                "insert job");
    s.bind(1, row.job_id)
        .bind(2, row.seq)
        .bind(3, row.site_id)
        .bind(4, row.priority)
        .bind(5, row.idempotency_key)
        .bind(6, row.request_sha256)
        .bind(7, row.scenario_json)
        .bind(8, row.histories_total)
        .bind(9, row.created_utc)
        .bind(10, row.owner)
        .run();
    row.state = JobState::kQueued;
    return {std::move(row), true};
  });
}

std::optional<JobRow> Store::job(const std::string& job_id) {
  return job_by_id(job_id, kJobStatusColumns);
}

std::optional<JobRow> Store::job_with_scenario(const std::string& job_id) {
  return job_by_id(job_id, kJobColumns);
}

std::optional<JobRow> Store::job_by_id(const std::string& job_id, const char* columns) {
  const std::lock_guard<std::mutex> lock(mutex_);
  Statement s(*this, std::string("SELECT ") + columns + " FROM jobs WHERE job_id = ?1", "get job");
  s.bind(1, job_id);
  if (!s.step()) return std::nullopt;
  return read_job(s);
}

bool Store::has_idempotency_key(const std::string& key) {
  const std::lock_guard<std::mutex> lock(mutex_);
  Statement s(*this, "SELECT 1 FROM jobs WHERE idempotency_key = ?1", "find idempotency key");
  s.bind(1, key);
  return s.step();
}

std::vector<JobRow> Store::jobs(std::optional<JobState> state, int limit) {
  const std::lock_guard<std::mutex> lock(mutex_);
  std::string sql = std::string("SELECT ") + kJobStatusColumns + " FROM jobs";
  if (state) sql += " WHERE state = ?2";
  sql += " ORDER BY seq DESC LIMIT ?1";
  Statement s(*this, sql, "list jobs");
  s.bind(1, limit);
  if (state) s.bind(2, std::string(job_state_name(*state)));
  std::vector<JobRow> out;
  while (s.step()) out.push_back(read_job(s));
  return out;
}

std::array<std::int64_t, kJobStateCount> Store::job_counts() {
  const std::lock_guard<std::mutex> lock(mutex_);
  Statement s(*this, "SELECT state, COUNT(*) FROM jobs GROUP BY state", "count jobs");
  std::array<std::int64_t, kJobStateCount> counts{};
  while (s.step())
    if (const auto st = parse_job_state(s.text(0)))
      counts[static_cast<std::size_t>(*st)] = s.integer(1);
  return counts;
}

std::optional<JobRow> Store::next_queued() {
  const std::lock_guard<std::mutex> lock(mutex_);
  Statement s(*this,
              std::string("SELECT ") + kJobColumns +
                  " FROM jobs WHERE state = 'queued' ORDER BY priority DESC, seq LIMIT 1",
              "next job");
  if (!s.step()) return std::nullopt;
  return read_job(s);
}

bool Store::mark_running(const std::string& job_id, const std::string& started_utc) {
  const std::lock_guard<std::mutex> lock(mutex_);
  Statement s(*this,
              "UPDATE jobs SET state = 'running', attempts = attempts + 1, started_utc = ?2, "
              "histories_done = 0 WHERE job_id = ?1 AND state = 'queued'",
              "start job");
  s.bind(1, job_id).bind(2, started_utc).run();
  return sqlite3_changes(db_) > 0;
}

void Store::update_progress(const std::string& job_id, std::int64_t histories_done) {
  const std::lock_guard<std::mutex> lock(mutex_);
  Statement s(*this, "UPDATE jobs SET histories_done = ?2 WHERE job_id = ?1 AND state = 'running'",
              "job progress");
  s.bind(1, job_id).bind(2, histories_done).run();
}

bool Store::mark_done(const std::string& job_id, const std::string& finished_utc,
                      std::int64_t histories_done, const std::string& summary_json,
                      const std::vector<BuildingRow>& buildings) {
  const std::lock_guard<std::mutex> lock(mutex_);
  return transaction([&] {
    Statement s(*this,
                "UPDATE jobs SET state = 'done', finished_utc = ?2, histories_done = ?3, "
                "summary_json = ?4, error_code = NULL, error_message = NULL "
                "WHERE job_id = ?1 AND state = 'running'",
                "finish job");
    s.bind(1, job_id).bind(2, finished_utc).bind(3, histories_done).bind(4, summary_json).run();
    if (sqlite3_changes(db_) == 0) return false;  // no longer running: nothing was written
    Statement clear(*this, "DELETE FROM job_buildings WHERE job_id = ?1", "clear buildings");
    clear.bind(1, job_id).run();
    for (std::size_t k = 0; k < buildings.size(); ++k) {
      const BuildingRow& b = buildings[k];
      Statement ins(*this,
                    "INSERT INTO job_buildings (job_id, idx, building_id, expected_impacts, "
                    "impacts_std_error, expected_penetrations, penetrations_std_error) VALUES "
                    "(?1, ?2, ?3, ?4, ?5, ?6, ?7)",
                    "insert building");
      ins.bind(1, job_id)
          .bind(2, static_cast<std::int64_t>(k))
          .bind(3, b.building_id)
          .bind(4, b.expected_impacts)
          .bind(5, b.impacts_std_error)
          .bind(6, b.expected_penetrations)
          .bind(7, b.penetrations_std_error)
          .run();
    }
    return true;
  });
}

bool Store::mark_failed(const std::string& job_id, const std::string& finished_utc,
                        const std::string& code, const std::string& message) {
  const std::lock_guard<std::mutex> lock(mutex_);
  Statement s(*this,
              "UPDATE jobs SET state = 'failed', finished_utc = ?2, error_code = ?3, "
              "error_message = ?4 WHERE job_id = ?1 AND state IN ('queued', 'running')",
              "fail job");
  s.bind(1, job_id).bind(2, finished_utc).bind(3, code).bind(4, message).run();
  return sqlite3_changes(db_) > 0;
}

std::optional<JobState> Store::cancel(const std::string& job_id, const std::string& finished_utc) {
  const std::lock_guard<std::mutex> lock(mutex_);
  return transaction([&]() -> std::optional<JobState> {
    Statement q(*this, "SELECT state FROM jobs WHERE job_id = ?1", "job state");
    q.bind(1, job_id);
    if (!q.step()) return std::nullopt;
    const JobState before = parse_job_state(q.text(0)).value_or(JobState::kFailed);
    if (!is_final(before)) {
      Statement s(*this, "UPDATE jobs SET state = 'cancelled', finished_utc = ?2 WHERE job_id = ?1",
                  "cancel job");
      s.bind(1, job_id).bind(2, finished_utc).run();
    }
    return before;
  });
}

std::optional<JobRow> Store::retry(const std::string& job_id) {
  const std::lock_guard<std::mutex> lock(mutex_);
  return transaction([&]() -> std::optional<JobRow> {
    std::optional<JobRow> before;
    {
      Statement q(*this,
                  std::string("SELECT ") + kJobStatusColumns + " FROM jobs WHERE job_id = ?1",
                  "get job");
      q.bind(1, job_id);
      if (!q.step()) return std::nullopt;
      before = read_job(q);
    }
    if (before->state == JobState::kFailed && before->error_code != "invalid_input") {
      Statement s(*this,
                  "UPDATE jobs SET state = 'queued', histories_done = 0, crashes = 0, "
                  "started_utc = NULL, finished_utc = NULL, error_code = NULL, "
                  "error_message = NULL WHERE job_id = ?1",
                  "retry job");
      s.bind(1, job_id).run();
    }
    return before;
  });
}

void Store::requeue(const std::string& job_id) {
  const std::lock_guard<std::mutex> lock(mutex_);
  Statement s(*this,
              "UPDATE jobs SET state = 'queued', histories_done = 0, started_utc = NULL "
              "WHERE job_id = ?1 AND state = 'running'",
              "requeue job");
  s.bind(1, job_id).run();
}

std::vector<std::string> Store::recover_interrupted(int max_crashes, const std::string& now_utc,
                                                    const std::vector<std::string>& still_running) {
  const std::lock_guard<std::mutex> lock(mutex_);
  // The ids to leave alone, as a JSON array for json_each (SQLite's JSON functions are built in).
  std::string keep = "[";
  for (const auto& id : still_running) {
    if (keep.size() > 1) keep += ',';
    keep += '"';
    keep += id;  // job ids are j_ and hex digits: nothing to escape
    keep += '"';
  }
  keep += ']';
  return transaction([&] {
    constexpr const char* kInterrupted =
        "state = 'running' AND job_id NOT IN (SELECT value FROM json_each(?9))";
    Statement mark(*this,
                   std::string("UPDATE jobs SET crashes = crashes + 1 WHERE ") + kInterrupted,
                   "count crash");
    mark.bind(9, keep).run();
    Statement fail(*this,
                   std::string("UPDATE jobs SET state = 'failed', finished_utc = ?2, "
                               "error_code = 'crashed', error_message = 'the daemon stopped "
                               "abnormally ' || crashes || ' times while running this job' "
                               "WHERE crashes >= ?1 AND ") +
                       kInterrupted,
                   "fail crashed jobs");
    fail.bind(1, max_crashes).bind(2, now_utc).bind(9, keep).run();
    std::vector<std::string> requeued;
    Statement list(*this,
                   std::string("SELECT job_id FROM jobs WHERE ") + kInterrupted + " ORDER BY seq",
                   "interrupted jobs");
    list.bind(9, keep);
    while (list.step()) requeued.push_back(list.text(0));
    Statement back(*this,
                   std::string("UPDATE jobs SET state = 'queued', histories_done = 0, "
                               "started_utc = NULL WHERE ") +
                       kInterrupted,
                   "requeue interrupted");
    back.bind(9, keep).run();
    return requeued;
  });
}

std::vector<JobRow> Store::running_jobs() {
  const std::lock_guard<std::mutex> lock(mutex_);
  Statement s(
      *this,
      std::string("SELECT ") + kJobColumns + " FROM jobs WHERE state = 'running' ORDER BY seq",
      "running jobs");
  std::vector<JobRow> out;
  while (s.step()) out.push_back(read_job(s));
  return out;
}

// ---- Purge ----

Store::Removal Store::remove_finished_job(const std::string& job_id) {
  const std::lock_guard<std::mutex> lock(mutex_);
  return transaction([&]() -> Removal {
    Removal r;
    Statement q(*this, "SELECT state FROM jobs WHERE job_id = ?1", "job state");
    q.bind(1, job_id);
    if (!q.step()) return r;
    r.state = parse_job_state(q.text(0)).value_or(JobState::kFailed);
    if (!is_final(r.state)) {
      r.outcome = Removal::Outcome::kNotFinished;
      return r;
    }
    // compare_with is a top-level key of the stored request (api/job_request.h).
    Statement c(*this,
                "SELECT COUNT(*) FROM jobs WHERE state IN ('queued', 'running') AND "
                "json_extract(scenario_json, '$.compare_with') = ?1",
                "comparisons pairing with a job");
    c.bind(1, job_id);
    c.step();
    r.comparisons = c.integer(0);
    if (r.comparisons > 0) {
      r.outcome = Removal::Outcome::kComparisonBase;
      return r;
    }
    Statement b(*this, "DELETE FROM job_buildings WHERE job_id = ?1", "delete job buildings");
    b.bind(1, job_id).run();
    Statement d(*this, "DELETE FROM jobs WHERE job_id = ?1", "delete job");
    d.bind(1, job_id).run();
    r.outcome = Removal::Outcome::kRemoved;
    return r;
  });
}

std::vector<Store::Finished> Store::finished_jobs() {
  const std::lock_guard<std::mutex> lock(mutex_);
  Statement s(*this,
              "SELECT job_id, finished_utc, state FROM jobs WHERE state IN ('done', 'failed', "
              "'cancelled') ORDER BY finished_utc, seq",
              "finished jobs");
  std::vector<Finished> out;
  while (s.step()) {
    out.push_back({s.text(0), s.optional_text(1).value_or(""),
                   parse_job_state(s.text(2)).value_or(JobState::kFailed)});
  }
  return out;
}

bool Store::has_job(const std::string& job_id) {
  const std::lock_guard<std::mutex> lock(mutex_);
  Statement s(*this, "SELECT 1 FROM jobs WHERE job_id = ?1", "job exists");
  s.bind(1, job_id);
  return s.step();
}

std::optional<std::string> Store::summary_json(const std::string& job_id) {
  const std::lock_guard<std::mutex> lock(mutex_);
  Statement s(*this, "SELECT summary_json FROM jobs WHERE job_id = ?1 AND state = 'done'",
              "job summary");
  s.bind(1, job_id);
  if (!s.step()) return std::nullopt;
  return s.optional_text(0);
}

std::vector<BuildingRow> Store::buildings(const std::string& job_id) {
  const std::lock_guard<std::mutex> lock(mutex_);
  Statement s(*this,
              "SELECT building_id, expected_impacts, impacts_std_error, expected_penetrations, "
              "penetrations_std_error FROM job_buildings WHERE job_id = ?1 ORDER BY idx",
              "job buildings");
  s.bind(1, job_id);
  std::vector<BuildingRow> out;
  while (s.step()) out.push_back({s.text(0), s.real(1), s.real(2), s.real(3), s.real(4)});
  return out;
}

std::string Store::integrity_check() {
  const std::lock_guard<std::mutex> lock(mutex_);
  Statement s(*this, "PRAGMA integrity_check", "integrity check");
  std::string out;
  while (s.step()) {
    if (!out.empty()) out += '\n';
    out += s.text(0);
  }
  return out;
}

}  // namespace fragsim::server
