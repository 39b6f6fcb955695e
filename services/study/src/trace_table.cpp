// The store's `traces` table: what the robot did in each hardware rollout (domain/rollout_trace.hpp), one
// row per attempt. The ticks are one BLOB of little-endian float64, kTickValues per tick in the order of
// kLayout; the header's parameters are JSON. Why a BLOB and not JSON: a 20 s rollout at 500 Hz is 10 000 ticks,
// 2.2 MB as float64 against about 6 MB as JSON text, and it is read back exactly.
#include <algorithm>
#include <bit>
#include <cstring>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "cpgmatch/study/study_store.hpp"
#include "sqlite_statement.hpp"

namespace cpgmatch::study {
namespace {

static_assert(std::endian::native == std::endian::little, "the trace BLOB is written as the host's float64");

// Per tick: time_s, pitch_rad, vx_mps, then per leg in the robot's leg order hip_target_rad, hip_rad,
// knee_target_rad, knee_rad, contact (0 or 1), foot_force_n. The leg count follows from the BLOB's size and
// the tick count (stores written before robots were data hold four legs, FL FR HL HR, the same layout).
constexpr const char* kLayout = "float64-le v1: time_s pitch_rad vx_mps [hip_target_rad hip_rad knee_target_rad "
                                "knee_rad contact foot_force_n] x legs";
constexpr std::size_t kTickValues(std::size_t legs) { return 3 + 6 * legs; }

std::vector<double> pack(const domain::MeasuredTrace& trace) {
  std::vector<double> v;
  v.reserve(trace.ticks.size() * kTickValues(trace.ticks.empty() ? 0 : trace.ticks.front().legs.size()));
  for (const auto& t : trace.ticks) {
    v.insert(v.end(), {t.time_s, t.pitch_rad, t.vx_mps});
    for (const auto& l : t.legs) {
      v.insert(v.end(), {l.hip_target_rad, l.hip_rad, l.knee_target_rad, l.knee_rad, l.contact ? 1.0 : 0.0, l.foot_force_n});
    }
  }
  return v;
}

std::vector<domain::MeasuredTick> unpack(const void* blob, std::size_t bytes, std::size_t ticks, const std::string& what) {
  const std::size_t values = ticks == 0 ? 0 : bytes / sizeof(double) / ticks;
  const std::size_t legs = values >= 3 ? (values - 3) / 6 : 0;
  if (ticks > 0 && (bytes != ticks * kTickValues(legs) * sizeof(double) || legs == 0 || legs > kMaxLegs)) {
    throw std::runtime_error(fmt::format("{}: {} bytes of ticks are not {} ticks of 3 + 6 x (1..{} legs) values", what,
                                         bytes, ticks, kMaxLegs));
  }
  std::vector<double> v(ticks * kTickValues(legs));
  if (bytes > 0) std::memcpy(v.data(), blob, bytes);
  std::vector<domain::MeasuredTick> out(ticks);
  const double* p = v.data();
  for (auto& t : out) {
    t.time_s = *p++;
    t.pitch_rad = *p++;
    t.vx_mps = *p++;
    t.legs = PerLeg<domain::MeasuredLeg>(legs);
    for (auto& l : t.legs) {
      l.hip_target_rad = *p++;
      l.hip_rad = *p++;
      l.knee_target_rad = *p++;
      l.knee_rad = *p++;
      l.contact = *p++ != 0.0;
      l.foot_force_n = *p++;
    }
  }
  return out;
}

}  // namespace

void StudyStore::create_trace_table() {
  try {
    exec(R"(CREATE TABLE IF NOT EXISTS traces(
             study_id INTEGER NOT NULL REFERENCES studies(study_id),
             trial_id INTEGER NOT NULL, attempt INTEGER NOT NULL, worker_id TEXT NOT NULL,
             control_rate_hz REAL NOT NULL, terrain TEXT NOT NULL, seed TEXT NOT NULL, params_json TEXT NOT NULL,
             tick_count INTEGER NOT NULL, ticks_dropped INTEGER NOT NULL, layout TEXT NOT NULL, ticks BLOB NOT NULL,
             received_at REAL NOT NULL,
             PRIMARY KEY(study_id, trial_id, attempt, worker_id)))");
  } catch (const StoreWriteError&) {
    // An older store opened read-only (cpgmatch analyze): it has no traces, and load_traces says none.
  }
}

std::optional<std::string> StudyStore::save_trace(const domain::RolloutTrace& t, double now_s, bool* already_kept) {
  if (already_kept != nullptr) *already_kept = false;
  if (t.id.store_id != store_id_) {
    return fmt::format("store id {:016x} is not this store's ({:016x})", t.id.store_id, store_id_);
  }
  {
    // The attempt must have been issued: a trace only joins a trial this store sent to a worker.
    Statement trial(db_, "SELECT attempt FROM trials WHERE study_id = ? AND trial_id = ?");
    trial.bind(1, t.id.study_id).bind(2, t.id.trial_id);
    if (!trial.step()) return fmt::format("study {} has no trial {}", t.id.study_id, t.id.trial_id);
    if (t.id.attempt > trial.column_int(0)) {
      return fmt::format("trial {} was issued {} times; attempt {} never was", t.id.trial_id, trial.column_int(0) + 1,
                         t.id.attempt);
    }
  }
  {
    Statement kept(db_, "SELECT 1 FROM traces WHERE study_id = ? AND trial_id = ? AND attempt = ? AND worker_id = ?");
    kept.bind(1, t.id.study_id).bind(2, t.id.trial_id).bind(3, t.id.attempt).bind(4, t.worker_id);
    if (kept.step()) {
      if (already_kept != nullptr) *already_kept = true;
      return std::nullopt;
    }
  }
  nlohmann::json params = nlohmann::json::object();
  for (const auto& [name, value] : t.parameters) params[name] = value;
  const std::vector<double> ticks = pack(t.trace);
  Statement insert(db_, R"(INSERT INTO traces(study_id, trial_id, attempt, worker_id, control_rate_hz, terrain, seed,
                           params_json, tick_count, ticks_dropped, layout, ticks, received_at)
                           VALUES(?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?))");
  // The seed as text: SQLite's integers are signed 64-bit, a seed is unsigned.
  insert.bind(1, t.id.study_id).bind(2, t.id.trial_id).bind(3, t.id.attempt).bind(4, t.worker_id);
  insert.bind(5, t.control_rate_hz).bind(6, t.terrain).bind(7, std::to_string(t.seed)).bind(8, params.dump());
  insert.bind_int64(9, static_cast<std::int64_t>(t.trace.ticks.size()));
  insert.bind_int64(10, static_cast<std::int64_t>(std::min<std::uint64_t>(t.ticks_dropped, INT64_MAX)));
  insert.bind(11, std::string(kLayout)).bind_blob(12, ticks.data(), ticks.size() * sizeof(double)).bind(13, now_s);
  insert.run();
  return std::nullopt;
}

std::vector<StoredTrace> StudyStore::load_traces(int study_id) const {
  std::vector<StoredTrace> out;
  {
    Statement table(db_, "SELECT 1 FROM sqlite_master WHERE type = 'table' AND name = 'traces'");
    if (!table.step()) return out;
  }
  Statement q(db_, R"(SELECT trial_id, attempt, worker_id, control_rate_hz, terrain, seed, params_json, tick_count,
                      ticks_dropped, layout, ticks, received_at FROM traces WHERE study_id = ?
                      ORDER BY trial_id, attempt, worker_id)");
  q.bind(1, study_id);
  while (q.step()) {
    StoredTrace s;
    domain::RolloutTrace& t = s.trace;
    t.id = {store_id_, study_id, q.column_int(0), q.column_int(1)};
    t.worker_id = q.column_text(2);
    const std::string what = fmt::format("study store {}: trace of study {} trial {} attempt {}", path_, study_id,
                                         t.id.trial_id, t.id.attempt);
    if (q.column_text(9) != kLayout) throw std::runtime_error(fmt::format("{}: unknown layout '{}'", what, q.column_text(9)));
    t.control_rate_hz = q.column_double(3);
    t.terrain = q.column_text(4);
    try {
      t.seed = std::stoull(q.column_text(5));
      const nlohmann::json params = nlohmann::json::parse(q.column_text(6));  // outlives the loop below
      for (const auto& [name, value] : params.items()) t.parameters[name] = value.get<double>();
    } catch (const std::exception& e) {
      throw std::runtime_error(fmt::format("{}: unreadable header: {}", what, e.what()));
    }
    const std::int64_t count = q.column_int64(7);
    if (count < 0) throw std::runtime_error(fmt::format("{}: negative tick count", what));
    t.ticks_dropped = static_cast<std::uint64_t>(std::max<std::int64_t>(0, q.column_int64(8)));
    t.trace.ticks = unpack(q.column_blob(10), q.column_bytes(10), static_cast<std::size_t>(count), what);
    t.trace.source = fmt::format("{} study {} trial {} attempt {} ({})", path_, study_id, t.id.trial_id, t.id.attempt, t.worker_id);
    s.received_at_s = q.column_double(11);
    out.push_back(std::move(s));
  }
  return out;
}

}  // namespace cpgmatch::study
