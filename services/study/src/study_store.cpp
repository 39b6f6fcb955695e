#include "cpgmatch/study/study_store.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <sqlite3.h>

#include <cmath>
#include <cstring>
#include <random>
#include <stdexcept>

#include <fmt/format.h>

#include "cpgmatch/domain/report_json.hpp"
#include "cpgmatch/errors.hpp"
#include "sqlite_statement.hpp"

namespace cpgmatch::study {

namespace {

nlohmann::json vector_json(const Eigen::VectorXd& x) {
  nlohmann::json a = nlohmann::json::array();
  for (int i = 0; i < x.size(); ++i) a.push_back(x[i]);
  return a;
}

Eigen::VectorXd json_vector(const nlohmann::json& a) {
  Eigen::VectorXd x(static_cast<int>(a.size()));
  for (std::size_t i = 0; i < a.size(); ++i) x[static_cast<int>(i)] = a[i].get<double>();
  return x;
}

}  // namespace

std::string to_string(TrialStatus s) { return s == TrialStatus::kDone ? "done" : "in_flight"; }

std::optional<domain::RolloutReport> stored_report(const StoredTrial& trial, std::string* why) {
  if (trial.status != TrialStatus::kDone || !trial.report.is_object()) {
    if (why != nullptr) *why = trial.status != TrialStatus::kDone ? "not done" : "no report stored";
    return std::nullopt;
  }
  try {
    return domain::report_from_json(trial.report);
  } catch (const std::exception& e) {
    if (why != nullptr) *why = e.what();
    return std::nullopt;
  }
}

StudyStore::StudyStore(const std::string& path, Durability durability) : path_(path) {
  // A new store is readable by its owner only (it holds every study and report); SQLite gives its -wal
  // and -shm files the same mode. An existing store keeps the mode its owner gave it.
  if (const int fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_EXCL | O_CLOEXEC, 0600); fd >= 0) ::close(fd);
  if (sqlite3_open_v2(path.c_str(), &db_, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_FULLMUTEX,
                      nullptr) != SQLITE_OK) {
    const std::string why = db_ ? sqlite3_errmsg(db_) : "out of memory";
    sqlite3_close(db_);
    db_ = nullptr;
    throw std::runtime_error(fmt::format("study store {}: cannot open: {}", path, why));
  }
  sqlite3_busy_timeout(db_, 5000);
  try {
    check_schema();  // before anything is created: never add cpgmatch's tables to someone else's database
    exec("PRAGMA journal_mode=WAL");
    exec(durability == Durability::kFull ? "PRAGMA synchronous=FULL" : "PRAGMA synchronous=NORMAL");
    exec("PRAGMA foreign_keys=ON");
    exec(R"(CREATE TABLE IF NOT EXISTS studies(
             study_id INTEGER PRIMARY KEY AUTOINCREMENT,
             name TEXT NOT NULL, config_yaml TEXT NOT NULL, source_name TEXT NOT NULL,
             state TEXT NOT NULL, message TEXT NOT NULL DEFAULT '', created_at REAL NOT NULL))");
    exec(R"(CREATE TABLE IF NOT EXISTS trials(
             study_id INTEGER NOT NULL REFERENCES studies(study_id),
             trial_id INTEGER NOT NULL,
             x_json TEXT NOT NULL,
             status TEXT NOT NULL CHECK(status IN ('in_flight', 'done')),
             attempt INTEGER NOT NULL, worker_id TEXT NOT NULL,
             issued_at REAL NOT NULL, reported_at REAL NOT NULL DEFAULT 0,
             ok INTEGER NOT NULL DEFAULT 0, cost REAL NOT NULL DEFAULT 0, report_json TEXT NOT NULL DEFAULT 'null',
             PRIMARY KEY(study_id, trial_id)))");
    add_column_if_missing("trials", "report_seq", "INTEGER NOT NULL DEFAULT 0");
    add_column_if_missing("trials", "phase", "TEXT NOT NULL DEFAULT 'exploration'");
    // A trial's attempts that did not measure it (plant faults, divergences): counted against the retry
    // bound across restarts; each attempt's report is kept in `attempts`.
    add_column_if_missing("trials", "faults", "INTEGER NOT NULL DEFAULT 0");
    // A hardware proposal's safety check (StoredTrial::proposal): NULL for every other trial and in stores
    // from before the check, which therefore read as having none.
    add_column_if_missing("trials", "proposal_fall_probability", "REAL");
    add_column_if_missing("trials", "proposal_within_fall_limit", "INTEGER");
    add_column_if_missing("trials", "proposal_cost_bound", "REAL");
    add_column_if_missing("trials", "proposal_cost_limit", "REAL");
    add_column_if_missing("trials", "proposal_within_cost_bound", "INTEGER");
    add_column_if_missing("trials", "proposal_basis", "TEXT");
    // The study's resolved spec (study_spec.hpp): what its rollouts compute, by content. Empty in stores
    // from before specs until the service migrates them (spec_origin then says so).
    add_column_if_missing("studies", "spec_json", "TEXT NOT NULL DEFAULT ''");
    add_column_if_missing("studies", "spec_sha256", "TEXT NOT NULL DEFAULT ''");
    add_column_if_missing("studies", "spec_origin", "TEXT NOT NULL DEFAULT ''");
    exec(R"(CREATE TABLE IF NOT EXISTS attempts(
             study_id INTEGER NOT NULL REFERENCES studies(study_id),
             trial_id INTEGER NOT NULL, attempt INTEGER NOT NULL, worker_id TEXT NOT NULL,
             outcome TEXT NOT NULL, report_json TEXT NOT NULL, reported_at REAL NOT NULL,
             PRIMARY KEY(study_id, trial_id, attempt, worker_id)))");
    exec(R"(CREATE TABLE IF NOT EXISTS model_states(
             study_id INTEGER PRIMARY KEY REFERENCES studies(study_id),
             state_json TEXT NOT NULL))");
    // A study with one model over simulation and hardware (`hardware: {strategy: transfer | multi_fidelity}`)
    // saves its bo::HardwareOptimizer's state beside the optimizer's; 'null' for every other study and in
    // stores written before it.
    add_column_if_missing("model_states", "hardware_state_json", "TEXT NOT NULL DEFAULT 'null'");
    create_trace_table();  // trace_table.cpp
    try {
      exec("CREATE TABLE IF NOT EXISTS meta(key TEXT PRIMARY KEY, value TEXT NOT NULL)");
      store_id_ = read_or_make_store_id();
    } catch (const StoreWriteError&) {
      store_id_ = 0;  // an older store opened read-only (analyze): readers need no id
    }
    try {
      exec(fmt::format("PRAGMA user_version = {}", kStoreSchemaVersion));
    } catch (const StoreWriteError&) {
      // a read-only file: it stays at its version, which check_schema accepted
    }
  } catch (const StoreWriteError&) {
    sqlite3_close(db_);
    db_ = nullptr;
    throw;  // names the path already
  } catch (const InputError&) {
    sqlite3_close(db_);
    db_ = nullptr;
    throw;  // names the path already
  } catch (const std::exception& e) {
    sqlite3_close(db_);
    db_ = nullptr;
    throw std::runtime_error(fmt::format("study store {}: {}", path, e.what()));
  }
}

StudyStore::StudyStore(const std::string& path, ReadOnly) : path_(path) {
  // A special file (a FIFO, /dev/zero) would hang or read without end; a missing one SQLite would create.
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) throw InputError(fmt::format("study store '{}': no such file", path));
  if (!S_ISREG(st.st_mode)) throw InputError(fmt::format("study store '{}': not a regular file", path));
  if (sqlite3_open_v2(path.c_str(), &db_, SQLITE_OPEN_READONLY | SQLITE_OPEN_FULLMUTEX, nullptr) != SQLITE_OK) {
    const std::string why = db_ ? sqlite3_errmsg(db_) : "out of memory";
    sqlite3_close(db_);
    db_ = nullptr;
    throw std::runtime_error(fmt::format("study store {}: cannot open read-only: {}", path, why));
  }
  sqlite3_busy_timeout(db_, 5000);
  try {
    check_schema();
    // Cheap next to reading every trial (one pass over the file's pages), and it tells a damaged store from
    // a damaged study: the message then blames the store.
    Statement q(db_, "PRAGMA quick_check");
    std::string problems;
    while (q.step()) {
      if (q.column_text(0) != "ok") problems += (problems.empty() ? "" : "; ") + q.column_text(0);
    }
    if (!problems.empty()) {
      throw std::runtime_error(fmt::format("damaged (SQLite quick_check: {}); `cpgmatch store check` lists what",
                                           problems.substr(0, 400)));
    }
    Statement id(db_, "SELECT value FROM meta WHERE key = 'store_id'");
    try {
      if (id.step()) store_id_ = std::stoull(id.column_text(0));
    } catch (const std::exception&) {
      store_id_ = 0;  // readers need no id
    }
  } catch (const InputError&) {
    sqlite3_close(db_);
    db_ = nullptr;
    throw;
  } catch (const std::exception& e) {
    sqlite3_close(db_);
    db_ = nullptr;
    throw std::runtime_error(fmt::format("study store {}: {}", path, e.what()));
  } catch (...) {
    sqlite3_close(db_);
    db_ = nullptr;
    throw;
  }
}

void StudyStore::check_schema() const {
  // "file is not a database" shows up on the first read: say it in the store's words.
  const int probe = sqlite3_exec(db_, "SELECT count(*) FROM sqlite_master", nullptr, nullptr, nullptr);
  if (probe == SQLITE_NOTADB) {
    throw InputError(fmt::format("'{}' is not a cpgmatch study store (not an SQLite database)", path_));
  }
  if (probe != SQLITE_OK) throw_sqlite_error(db_, probe, "reading the schema");
  int tables = 0;
  bool studies = false, trials = false;
  {
    Statement t(db_, "SELECT name FROM sqlite_master WHERE type = 'table'");
    while (t.step()) {
      ++tables;
      studies = studies || t.column_text(0) == "studies";
      trials = trials || t.column_text(0) == "trials";
    }
  }
  const bool read_only = sqlite3_db_readonly(db_, "main") == 1;
  // A writable empty database is a new store; anything else must have cpgmatch's tables.
  if (!(studies && trials) && (tables > 0 || read_only)) {
    throw InputError(fmt::format("'{}' is not a cpgmatch study store ({})", path_,
                                 tables == 0 ? "an empty database" : "an SQLite database without cpgmatch's tables"));
  }
  Statement v(db_, "PRAGMA user_version");
  const int version = v.step() ? v.column_int(0) : 0;
  if (version > kStoreSchemaVersion || version < 0) {
    throw InputError(fmt::format("study store '{}' has schema version {}; this cpgmatch reads versions up to {} "
                                 "(written by a newer cpgmatch? use that one)", path_, version, kStoreSchemaVersion));
  }
}

std::string StudyStore::integrity_check() const {
  Statement q(db_, "PRAGMA integrity_check");
  std::string out;
  while (q.step()) {
    if (!out.empty()) out += '\n';
    out += q.column_text(0);  // appended, not "\n" + text: GCC 12 warns falsely (-Wrestrict) on that
  }
  return out;
}

StudyStore::~StudyStore() { sqlite3_close(db_); }

std::uint64_t StudyStore::read_or_make_store_id() {
  {
    Statement read(db_, "SELECT value FROM meta WHERE key = 'store_id'");
    if (read.step()) return std::stoull(read.column_text(0));
  }
  // A new store (or one older than store ids). Random, not derived from the path or the time: two stores
  // made at the same moment, or a store deleted and made again at the same path, still differ.
  std::random_device entropy;
  std::uint64_t id = 0;
  while (id == 0) id = (static_cast<std::uint64_t>(entropy()) << 32) ^ entropy();
  Statement write(db_, "INSERT INTO meta(key, value) VALUES('store_id', ?)");
  write.bind(1, std::to_string(id)).run();  // read-only: StoreWriteError, see the constructor
  return id;
}

bool StudyStore::has_column(const std::string& table, const std::string& column) const {
  Statement info(db_, fmt::format("PRAGMA table_info({})", table).c_str());
  while (info.step()) {
    if (info.column_text(1) == column) return true;
  }
  return false;
}

void StudyStore::add_column_if_missing(const std::string& table, const std::string& column,
                                       const std::string& declaration) {
  // Stores written by an older cpgmatch lack newer columns; SQLite adds them in place.
  if (has_column(table, column)) return;
  exec(fmt::format("ALTER TABLE {} ADD COLUMN {} {}", table, column, declaration));
}

void StudyStore::exec(const std::string& sql) const {
  const int rc = sqlite3_exec(db_, sql.c_str(), nullptr, nullptr, nullptr);
  if (rc != SQLITE_OK) throw_sqlite_error(db_, rc, sql.substr(0, 60));
}

void StudyStore::require_writable() const {
  // BEGIN IMMEDIATE takes the write lock, which needs write access to the file (and, in WAL mode, to the
  // folder for the -wal and -shm files); rolling back writes nothing.
  exec("BEGIN IMMEDIATE");
  exec("ROLLBACK");
}

int StudyStore::create_study(const std::string& name, const std::string& config_yaml, const std::string& source_name,
                             double now_s, const StoredSpec& spec) {
  Statement s(db_, R"(INSERT INTO studies(name, config_yaml, source_name, state, created_at, spec_json, spec_sha256,
                      spec_origin) VALUES(?, ?, ?, 'running', ?, ?, ?, ?))");
  s.bind(1, name).bind(2, config_yaml).bind(3, source_name).bind(4, now_s);
  s.bind(5, spec.json).bind(6, spec.sha256).bind(7, spec.origin).run();
  return static_cast<int>(sqlite3_last_insert_rowid(db_));
}

void StudyStore::set_spec(int study_id, const StoredSpec& spec) {
  Statement s(db_, "UPDATE studies SET spec_json = ?, spec_sha256 = ?, spec_origin = ? WHERE study_id = ?");
  s.bind(1, spec.json).bind(2, spec.sha256).bind(3, spec.origin).bind(4, study_id).run();
}

int StudyStore::record_unspent_attempt(const domain::RolloutReport& report, bool fault, double now_s) {
  const int study_id = report.id.study_id, trial_id = report.id.trial_id;
  Statement a(db_, R"(INSERT OR IGNORE INTO attempts(study_id, trial_id, attempt, worker_id, outcome, report_json,
                      reported_at) VALUES(?, ?, ?, ?, ?, ?, ?))");
  a.bind(1, study_id).bind(2, trial_id).bind(3, report.id.attempt).bind(4, report.worker_id);
  a.bind(5, std::string(domain::to_string(report.outcome))).bind(6, domain::to_json(report).dump());
  a.bind(7, now_s).run();
  if (fault && sqlite3_changes(db_) == 1) {
    Statement f(db_, "UPDATE trials SET faults = faults + 1 WHERE study_id = ? AND trial_id = ?");
    f.bind(1, study_id).bind(2, trial_id).run();
  }
  Statement q(db_, "SELECT faults FROM trials WHERE study_id = ? AND trial_id = ?");
  q.bind(1, study_id).bind(2, trial_id);
  return q.step() ? q.column_int(0) : 0;
}

std::vector<StoredAttempt> StudyStore::unspent_attempts(int study_id) const {
  std::vector<StoredAttempt> out;
  Statement s(db_, R"(SELECT trial_id, attempt, worker_id, outcome, report_json, reported_at FROM attempts
                      WHERE study_id = ? ORDER BY reported_at, trial_id, attempt)");
  s.bind(1, study_id);
  while (s.step()) {
    StoredAttempt a;
    a.trial_id = s.column_int(0);
    a.attempt = s.column_int(1);
    a.worker_id = s.column_text(2);
    a.outcome = s.column_text(3);
    a.report = nlohmann::json::parse(s.column_text(4), nullptr, false);
    a.reported_at_s = s.column_double(5);
    out.push_back(std::move(a));
  }
  return out;
}

void StudyStore::set_state(int study_id, const std::string& state, const std::string& message) {
  Statement s(db_, "UPDATE studies SET state = ?, message = ? WHERE study_id = ?");
  s.bind(1, state).bind(2, message).bind(3, study_id).run();
}

bool StudyStore::in_batch() const { return sqlite3_get_autocommit(db_) == 0; }

StudyStore::Batch::Batch(StudyStore& store) : store_(store) {
  if (store_.in_batch()) throw std::logic_error("study store: batches do not nest");
  store_.exec("BEGIN IMMEDIATE");
}

StudyStore::Batch::~Batch() {
  // On a full disk SQLite may have rolled back already; ROLLBACK then fails harmlessly.
  if (open_) sqlite3_exec(store_.db_, "ROLLBACK", nullptr, nullptr, nullptr);
}

void StudyStore::Batch::commit() {
  if (!open_) return;
  store_.exec("COMMIT");  // on failure the destructor rolls back
  open_ = false;
}

void StudyStore::add_trials(int study_id, const std::vector<StoredTrial>& trials) {
  // Inside a Batch: a savepoint, so the trials are all or none within it, committed with it.
  const bool nested = in_batch();
  if (nested) {
    exec("SAVEPOINT add_trials");
  } else {
    exec("BEGIN IMMEDIATE");
  }
  try {
    Statement s(db_, R"(INSERT INTO trials(study_id, trial_id, x_json, status, attempt, worker_id, issued_at, phase,
                        proposal_fall_probability, proposal_within_fall_limit, proposal_cost_bound, proposal_cost_limit,
                        proposal_within_cost_bound, proposal_basis)
                        VALUES(?, ?, ?, 'in_flight', ?, ?, ?, ?, ?, ?, ?, ?, ?, ?))");
    for (const auto& t : trials) {
      s.bind(1, study_id).bind(2, t.trial_id).bind(3, vector_json(t.x).dump()).bind(4, t.attempt);
      s.bind(5, t.worker_id).bind(6, t.issued_at_s).bind(7, t.phase);
      if (t.proposal) {
        const HardwareProposalRecord& p = *t.proposal;
        s.bind(8, p.fall_probability).bind(9, p.within_fall_limit ? 1 : 0);
        if (std::isfinite(p.cost_bound)) {
          s.bind(10, p.cost_bound);
        } else {
          s.bind_null(10);  // SQLite has no NaN; read back as NaN
        }
        if (p.cost_limit) {
          s.bind(11, *p.cost_limit);
        } else {
          s.bind_null(11);
        }
        s.bind(12, p.within_cost_bound ? 1 : 0).bind(13, p.basis);
      }  // else: all NULL (clear_bindings after each row)
      s.run();
      s.reset();
    }
    exec(nested ? "RELEASE add_trials" : "COMMIT");
  } catch (...) {
    // On a full disk SQLite may already have rolled the transaction back itself; a second ROLLBACK then
    // fails with "no transaction is active" and would hide the real cause. Try it, keep the first error.
    if (nested) {
      sqlite3_exec(db_, "ROLLBACK TO add_trials", nullptr, nullptr, nullptr);
      sqlite3_exec(db_, "RELEASE add_trials", nullptr, nullptr, nullptr);
    } else {
      sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
    }
    throw;
  }
}

void StudyStore::reissue(int study_id, int trial_id, int attempt, const std::string& worker_id, double now_s) {
  Statement s(db_, "UPDATE trials SET attempt = ?, worker_id = ?, issued_at = ? WHERE study_id = ? AND trial_id = ? AND status = 'in_flight'");
  s.bind(1, attempt).bind(2, worker_id).bind(3, now_s).bind(4, study_id).bind(5, trial_id).run();
}

bool StudyStore::complete_trial(const domain::RolloutReport& report, double now_s) {
  const bool ok = report.ok();
  const double cost = ok ? report.summary.cost : 0.0;
  // report_seq numbers a study's reports in the order they were counted (and told to its optimizer):
  // the order a restart replays them in, whatever the wall clock did meanwhile.
  Statement s(db_, R"(UPDATE trials SET status = 'done', ok = ?, cost = ?, report_json = ?, reported_at = ?,
                      report_seq = (SELECT COALESCE(MAX(report_seq), 0) + 1 FROM trials WHERE study_id = ?5)
                      WHERE study_id = ?5 AND trial_id = ? AND status = 'in_flight')");
  s.bind(1, ok ? 1 : 0).bind(2, cost).bind(3, domain::to_json(report).dump()).bind(4, now_s);
  s.bind(5, report.id.study_id).bind(6, report.id.trial_id).run();
  return sqlite3_changes(db_) == 1;
}

void StudyStore::save_model_state(int study_id, const nlohmann::json& state) {
  // An upsert, not INSERT OR REPLACE: the row's hardware state stays as it was.
  Statement s(db_, R"(INSERT INTO model_states(study_id, state_json) VALUES(?, ?)
                      ON CONFLICT(study_id) DO UPDATE SET state_json = excluded.state_json)");
  s.bind(1, study_id).bind(2, state.dump()).run();
}

void StudyStore::save_hardware_model_state(int study_id, const nlohmann::json& state) {
  Statement s(db_, R"(INSERT INTO model_states(study_id, state_json, hardware_state_json) VALUES(?, 'null', ?)
                      ON CONFLICT(study_id) DO UPDATE SET hardware_state_json = excluded.hardware_state_json)");
  s.bind(1, study_id).bind(2, state.dump()).run();
}

std::vector<StoredStudy> StudyStore::load_all() const {
  std::vector<StoredStudy> out;
  {
    Statement s(db_, R"(SELECT study_id, name, config_yaml, source_name, state, message, created_at, spec_json,
                        spec_sha256, spec_origin FROM studies ORDER BY study_id)");
    while (s.step()) {
      StoredStudy st;
      st.study_id = s.column_int(0);
      st.name = s.column_text(1);
      st.config_yaml = s.column_text(2);
      st.source_name = s.column_text(3);
      st.state = s.column_text(4);
      st.message = s.column_text(5);
      st.created_at_s = s.column_double(6);
      st.spec = StoredSpec{s.column_text(7), s.column_text(8), s.column_text(9)};
      out.push_back(std::move(st));
    }
  }
  // A store from before the proposal columns, opened read-only (export, analyze), cannot be migrated: it
  // reads them as NULL, which is what a migrated one holds for those trials.
  const std::string proposal_columns =
      has_column("trials", "proposal_basis")
          ? "proposal_fall_probability, proposal_within_fall_limit, proposal_cost_bound, proposal_cost_limit, "
            "proposal_within_cost_bound, proposal_basis"
          : "NULL, NULL, NULL, NULL, NULL, NULL";
  const std::string select = fmt::format(
      R"(SELECT study_id, trial_id, x_json, status, attempt, worker_id, issued_at, reported_at, ok, cost,
         report_json, report_seq, phase, faults, {} FROM trials ORDER BY study_id, trial_id)",
      proposal_columns);
  Statement s(db_, select.c_str());
  std::size_t k = 0;
  while (s.step()) {
    const int study_id = s.column_int(0);
    while (k < out.size() && out[k].study_id != study_id) ++k;
    if (k == out.size()) throw std::runtime_error(fmt::format("study store {}: trial of unknown study {}", path_, study_id));
    StoredTrial t;
    t.trial_id = s.column_int(1);
    // A row that does not parse spoils its own study, not the store: the study is returned with the
    // reason, for the service to mark it failed, and every other study loads as usual. Every bad row is
    // named (unreadable_trials): readers such as export must say which trials they could not read.
    try {
      t.x = json_vector(nlohmann::json::parse(s.column_text(2)));
      t.report = nlohmann::json::parse(s.column_text(10));
      const std::string status = s.column_text(3);
      if (status != "done" && status != "in_flight") throw std::runtime_error("status '" + status + "'");
      if (status == "done" && t.report.is_object()) (void)domain::report_from_json(t.report);  // throws
    } catch (const std::exception& e) {
      const std::string why = fmt::format("trial {}: unreadable row ({})", t.trial_id, e.what());
      if (out[k].load_error.empty()) out[k].load_error = why;
      out[k].unreadable_trials.push_back(why);
      out[k].trials.clear();
      continue;
    }
    if (!out[k].load_error.empty()) continue;
    t.status = s.column_text(3) == "done" ? TrialStatus::kDone : TrialStatus::kInFlight;
    t.attempt = s.column_int(4);
    t.worker_id = s.column_text(5);
    t.issued_at_s = s.column_double(6);
    t.reported_at_s = s.column_double(7);
    t.ok = s.column_int(8) != 0;
    t.cost = s.column_double(9);
    t.report_seq = s.column_int(11);
    t.phase = s.column_text(12);
    t.faults = s.column_int(13);
    if (!s.column_is_null(14)) {
      HardwareProposalRecord p;
      p.fall_probability = s.column_double(14);
      p.within_fall_limit = s.column_int(15) != 0;
      p.cost_bound = s.column_is_null(16) ? std::nan("") : s.column_double(16);
      if (!s.column_is_null(17)) p.cost_limit = s.column_double(17);
      p.within_cost_bound = s.column_int(18) != 0;
      p.basis = s.column_text(19);
      t.proposal = std::move(p);
    }
    out[k].trials.push_back(std::move(t));
  }
  Statement m(db_, "SELECT study_id, state_json, hardware_state_json FROM model_states");
  while (m.step()) {
    for (auto& st : out) {
      if (st.study_id != m.column_int(0)) continue;
      st.model_state = nlohmann::json::parse(m.column_text(1), nullptr, false);
      st.hardware_model_state = nlohmann::json::parse(m.column_text(2), nullptr, false);
    }
  }
  return out;
}

std::optional<StoredStudy> StudyStore::load(int study_id) const {
  for (auto& s : load_all()) {
    if (s.study_id == study_id) return s;
  }
  return std::nullopt;
}

}  // namespace cpgmatch::study
