// The study store: every study, every candidate issued and every report received, in one SQLite file
// (WAL mode). The optimizer service writes here *before* it publishes a candidate or counts a report,
// so a restart on the same file resumes each unfinished study exactly where it was: observations are
// replayed into a fresh optimizer and candidates still in flight are issued again.
//
// Durability: synchronous=NORMAL by default, which survives a crash or SIGKILL of the process (the
// failure the service is built for); `Durability::kFull` also survives power loss, at an fsync per commit.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "cpgmatch/domain/rollout_report.hpp"
#include "cpgmatch/domain/rollout_trace.hpp"

struct sqlite3;

namespace cpgmatch::study {

enum class Durability { kNormal, kFull };

// The store could not record something: disk full, a read-only file or folder, an I/O error. The message
// names the store's path and the cause in plain words. The optimizer service stops on it instead of going
// on: it would otherwise acknowledge candidates and reports it could not record.
class StoreWriteError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

enum class TrialStatus { kInFlight, kDone };

inline constexpr const char* kPhaseEnqueued = "enqueued";

// What a hardware proposal of a transfer or multi_fidelity study was checked against when it was made
// (bo::HardwareProposal, issue 33's safe exploration), kept with its trial: the robot's fall probability
// there and whether it was within the study's max_fall_probability; the pessimistic cost bound (hardware
// posterior mean + safe_beta std, in cost units) and the limit it had to stay under ((1 + safe_margin)
// times the best robot cost so far; none for the first rollout, which then counts as within it); and
// where the point came from (bo::to_string(ProposalBasis): simulation_optimum, enqueued_gait, safe,
// lowest_bound, least_likely_to_fall).
struct HardwareProposalRecord {
  double fall_probability = 0.0;
  bool within_fall_limit = true;
  double cost_bound = 0.0;
  std::optional<double> cost_limit;
  bool within_cost_bound = true;
  std::string basis;
};

struct StoredTrial {
  int trial_id = 0;
  Eigen::VectorXd x;               // in the search space's units
  TrialStatus status = TrialStatus::kInFlight;
  int attempt = 0;
  std::string worker_id;           // the worker it is (or was last) assigned to
  double issued_at_s = 0.0;        // Unix time of the last issue
  double reported_at_s = 0.0;      // Unix time the report was stored
  int report_seq = 0;              // done: 1, 2, ... in the order reports were counted (0: an older store)
  bool ok = false;                 // done: the rollout ran (a fall is ok)
  double cost = 0.0;
  // done: the full report, in the store's schema of a domain::RolloutReport (domain/report_json.hpp); kept
  // as the stored tree so that readers of older stores see what was written. stored_report() types it.
  nlohmann::json report;
  // "exploration" (told to the optimizer), "validation" (a hardware set around the answer, never told) or
  // "hardware" (a hardware proposal of a transfer or multi_fidelity study, told to its hardware model).
  // Stores older than the column read as exploration, which is all they held. "enqueued" (kPhaseEnqueued):
  // a known gait queued by a user (`enqueue`), otherwise an exploration trial (told, counted in the budget).
  std::string phase = "exploration";
  int faults = 0;                  // attempts that ended in a plant fault or a divergence (not spent)
  // A hardware proposal's safety check (phase "hardware"); none for every other trial and for hardware
  // trials stored before the columns existed (they read as NULL).
  std::optional<HardwareProposalRecord> proposal;
};

// A study's resolved spec as stored (study_spec.hpp): the canonical JSON, its SHA-256, and where it came
// from ("submitted", or "migrated: ..." for a study stored before specs existed). Empty json: none yet.
struct StoredSpec {
  std::string json;
  std::string sha256;
  std::string origin;
};

// An attempt of a trial that did not measure it (refused, plant_fault, diverged): kept for the record.
struct StoredAttempt {
  int trial_id = 0;
  int attempt = 0;
  std::string worker_id;
  std::string outcome;
  nlohmann::json report;
  double reported_at_s = 0.0;
};

// A hardware rollout's trace as kept in the store's `traces` table (trace_table.cpp), with when it arrived.
struct StoredTrace {
  domain::RolloutTrace trace;
  double received_at_s = 0.0;
};

struct StoredStudy {
  int study_id = 0;
  std::string name;
  std::string config_yaml;
  std::string source_name;
  std::string state;               // running | paused | done | failed | stopped
  std::string message;
  double created_at_s = 0.0;
  std::vector<StoredTrial> trials; // by trial_id
  nlohmann::json model_state;      // the optimizer's saved state (null: none saved, e.g. an older store)
  nlohmann::json hardware_model_state;  // its bo::HardwareOptimizer's (null: none, or no hardware model)
  std::string load_error;          // non-empty: a row of this study could not be read (its trials are incomplete)
  // Every trial row of this study that could not be read, as "trial N: why" (load_error is the first).
  std::vector<std::string> unreadable_trials;
  StoredSpec spec;
};

// The store's schema version (PRAGMA user_version), set by the service when it opens or migrates a store.
// A store of a newer version is refused with both versions named: this program would misread it. 0: a store
// written before versions (read as version 1, which it is).
inline constexpr int kStoreSchemaVersion = 1;

// Opens a store for reading only (export, report, analyze, plot, calibrate, store check): SQLite's read-only
// mode, so nothing is ever created, migrated or written.
struct ReadOnly {};
inline constexpr ReadOnly kReadOnly{};

class StudyStore {
 public:
  // Opens or creates the store; throws std::runtime_error naming the path on failure, InputError for a file
  // that is not a cpgmatch store (an SQLite database with other tables, or not SQLite) or of a newer schema.
  explicit StudyStore(const std::string& path, Durability durability = Durability::kNormal);
  // Opens an existing store read-only; throws InputError naming the path when it is missing, not a regular
  // file, not a cpgmatch store (an empty file is not one) or of a newer schema, and std::runtime_error when
  // SQLite's quick_check finds it damaged.
  StudyStore(const std::string& path, ReadOnly);
  ~StudyStore();
  StudyStore(const StudyStore&) = delete;
  StudyStore& operator=(const StudyStore&) = delete;

  int create_study(const std::string& name, const std::string& config_yaml, const std::string& source_name,
                   double now_s, const StoredSpec& spec = {});
  // Gives a study its spec (a study stored before specs, migrated on first open).
  void set_spec(int study_id, const StoredSpec& spec);
  // Records an attempt that did not measure its trial (the trial stays in flight, to be issued again): the
  // report's study, trial, attempt, worker and outcome. `fault`: it counts against the trial's retry bound.
  // Returns the trial's fault count afterwards. A repeated (study, trial, attempt, worker) is recorded once.
  int record_unspent_attempt(const domain::RolloutReport& report, bool fault, double now_s);
  std::vector<StoredAttempt> unspent_attempts(int study_id) const;
  void set_state(int study_id, const std::string& state, const std::string& message);
  // Inserts new in-flight trials in one transaction.
  void add_trials(int study_id, const std::vector<StoredTrial>& trials);
  // Records a new issue of an in-flight trial (after its worker was lost or its lease ran out).
  void reissue(int study_id, int trial_id, int attempt, const std::string& worker_id, double now_s);
  // Marks an in-flight trial done with its report (the report's study and trial; ok and cost from it, cost 0
  // when it did not measure). False (and no change) when it was already done: that is how a late duplicate
  // report is never counted twice.
  bool complete_trial(const domain::RolloutReport& report, double now_s);

  // Replaces the study's saved optimizer state (see bo::ModelState): what a restart needs besides the
  // observations to resume exactly, without refitting the model once per stored result.
  void save_model_state(int study_id, const nlohmann::json& state);
  // Replaces the saved state of the study's hardware model (bo::HardwareModelState), kept beside it.
  void save_hardware_model_state(int study_id, const nlohmann::json& state);

  // A burst of writes in one transaction (the optimizer service: every report and command drained from its
  // queue at once, then the tick's writes). Commits are what a burst of reports cost on the event thread,
  // one per report before; grouping them keeps the guarantee as long as nothing is acknowledged before
  // commit() returns (the service holds its outgoing samples until then). Without commit() the batch
  // rolls back when destroyed: none of its writes happened. Batches do not nest.
  class Batch {
   public:
    explicit Batch(StudyStore& store);
    ~Batch();  // rolls back unless committed
    Batch(const Batch&) = delete;
    Batch& operator=(const Batch&) = delete;
    void commit();  // throws StoreWriteError (the batch is then rolled back)

   private:
    StudyStore& store_;
    bool open_ = true;
  };
  // True while a Batch is open on this store.
  bool in_batch() const;

  // Throws StoreWriteError unless the store can be written now (a read-only file or folder, say): the
  // optimizer checks this before it serves anything. Readers such as `cpgmatch analyze` do not need it.
  void require_writable() const;

  // Keeps a hardware rollout's trace (the `traces` table). Refused, with the reason and nothing written, when
  // its store, study or trial is not this store's or the attempt was never issued. That attempt's trace
  // kept already (sent again to a restarted optimizer) is no refusal: nothing is written and
  // `already_kept`, when given, says so. Throws StoreWriteError when it cannot be written.
  std::optional<std::string> save_trace(const domain::RolloutTrace& trace, double now_s, bool* already_kept = nullptr);
  // The study's kept traces, by trial and attempt (empty for a store older than the table). Throws
  // std::runtime_error naming the trial when a stored trace is unreadable.
  std::vector<StoredTrace> load_traces(int study_id) const;

  // `PRAGMA integrity_check`: "ok", or SQLite's list of what is damaged (pages, indexes, constraints).
  std::string integrity_check() const;

  std::vector<StoredStudy> load_all() const;
  std::optional<StoredStudy> load(int study_id) const;
  const std::string& path() const { return path_; }
  // The store's random 64-bit identity, made when the store is created (or first opened by a cpgmatch
  // that knows it) and never changed: candidates and reports carry it, so ids from different stores never
  // meet. 0 only for a read-only store that has none yet (readers do not need it).
  std::uint64_t store_id() const { return store_id_; }

 private:
  void exec(const std::string& sql) const;
  bool has_column(const std::string& table, const std::string& column) const;
  void add_column_if_missing(const std::string& table, const std::string& column, const std::string& declaration);
  std::uint64_t read_or_make_store_id();
  void create_trace_table();
  void check_schema() const;  // InputError unless a cpgmatch store this program can read
  std::string path_;
  sqlite3* db_ = nullptr;
  std::uint64_t store_id_ = 0;
};

std::string to_string(TrialStatus s);

// A stored trial's report as a domain type; nothing when the trial is not done or its report is unreadable
// (`why`, when given, says what was wrong).
std::optional<domain::RolloutReport> stored_report(const StoredTrial& trial, std::string* why = nullptr);

}  // namespace cpgmatch::study
