// Rollout traces (issue 23): cut into chunks and put together again under limits, kept in the study store
// exactly, refused when they do not belong to an issued attempt, and the study spec's model written back as
// model YAML that calibration rewrites and that loads as the same model.
#include <gtest/gtest.h>

#include <sqlite3.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <random>

#include "cpgmatch/calibration/calibrated_model.hpp"
#include "cpgmatch/calibration/study_traces.hpp"
#include "cpgmatch/domain/trace_assembler.hpp"
#include "cpgmatch/study/study_spec.hpp"
#include "cpgmatch/study/study_store.hpp"
#include "cpgmatch/yaml_reader.hpp"
#include "trace_intake.hpp"
#include "../support/morti_legs.hpp"

using namespace cpgmatch::test;  // Morti's legs: FL FR HL HR

namespace cpgmatch {
namespace {

using domain::RolloutTrace;
using domain::RolloutTraceChunk;
using domain::TraceAssembler;

// A trace of `ticks` ticks at 500 Hz whose every value differs (so a tick out of place shows).
RolloutTrace make_trace(std::size_t ticks, std::uint64_t store = 7, int study = 1, int trial = 0, int attempt = 0) {
  RolloutTrace t;
  t.id = {store, study, trial, attempt};
  t.worker_id = "morti";
  t.control_rate_hz = 500.0;
  t.terrain = "flat";
  t.seed = 0xfedcba9876543210ull;  // past INT64_MAX: stored as text
  t.parameters = to_map(CpgParameters{});
  for (std::size_t i = 0; i < ticks; ++i) {
    domain::MeasuredTick k;
    k.legs = PerLeg<domain::MeasuredLeg>(4);
    k.time_s = static_cast<double>(i) / 500.0;
    k.pitch_rad = 0.001 * std::sin(0.1 * i);
    k.vx_mps = 0.3 + 1e-5 * i;
    for (int leg = 0; leg < kNumLegs; ++leg) {
      const double x = 0.01 * i + leg;
      k.legs[leg] = {std::sin(x), std::cos(x), 0.5 * std::sin(x), 0.4 * std::cos(x), (i + leg) % 3 == 0, 10.0 + x};
    }
    t.trace.ticks.push_back(k);
  }
  return t;
}

bool same_ticks(const domain::MeasuredTrace& a, const domain::MeasuredTrace& b) {
  if (a.ticks.size() != b.ticks.size()) return false;
  for (std::size_t i = 0; i < a.ticks.size(); ++i) {
    const auto &x = a.ticks[i], &y = b.ticks[i];
    if (x.time_s != y.time_s || x.pitch_rad != y.pitch_rad || x.vx_mps != y.vx_mps) return false;
    for (int leg = 0; leg < kNumLegs; ++leg) {
      const auto &p = x.legs[leg], &q = y.legs[leg];
      if (p.hip_target_rad != q.hip_target_rad || p.hip_rad != q.hip_rad || p.knee_target_rad != q.knee_target_rad ||
          p.knee_rad != q.knee_rad || p.contact != q.contact || p.foot_force_n != q.foot_force_n) {
        return false;
      }
    }
  }
  return true;
}

TEST(TraceAssembler, ChunksInAnyOrderGiveTheTraceBack) {
  const RolloutTrace trace = make_trace(1000);
  std::vector<RolloutTraceChunk> chunks = domain::split_trace(trace);
  ASSERT_EQ(chunks.size(), 4u);  // 256 + 256 + 256 + 232
  std::shuffle(chunks.begin(), chunks.end(), std::mt19937(3));
  TraceAssembler assembler;
  std::optional<RolloutTrace> got;
  for (std::size_t i = 0; i < chunks.size(); ++i) {
    TraceAssembler::Result r = assembler.add(chunks[i], 0.0);
    ASSERT_FALSE(r.rejected) << *r.rejected;
    EXPECT_EQ(r.complete.has_value(), i + 1 == chunks.size());
    if (r.complete) got = std::move(r.complete);
  }
  ASSERT_TRUE(got);
  EXPECT_TRUE(same_ticks(got->trace, trace.trace));
  EXPECT_EQ(got->seed, trace.seed);
  EXPECT_EQ(got->parameters, trace.parameters);
  EXPECT_EQ(assembler.partial_traces(), 0u);
  EXPECT_EQ(assembler.buffered_ticks(), 0u);
}

TEST(TraceAssembler, RefusesMalformedChunksAndKeepsNothingOfThem) {
  TraceAssembler assembler;
  const RolloutTraceChunk good = domain::split_trace(make_trace(10)).front();
  auto refused = [&](RolloutTraceChunk c, const std::string& why) {
    const TraceAssembler::Result r = assembler.add(std::move(c), 0.0);
    EXPECT_TRUE(r.rejected && r.rejected->find(why) != std::string::npos) << (r.rejected ? *r.rejected : "accepted");
    EXPECT_FALSE(r.complete);
  };
  RolloutTraceChunk c = good;
  c.total_ticks = 1000000000;
  refused(c, "more than a trace may hold");
  c = good;
  c.ticks[4].legs[2].knee_rad = std::nan("");
  refused(c, "not finite");
  c = good;
  c.ticks[5].time_s += 0.001;
  refused(c, "not on the 500 Hz grid");
  c = good;
  c.chunk_index = 1;
  refused(c, "chunk_index 1 of 1");
  c = good;
  c.control_rate_hz = 0.0;
  refused(c, "control_rate_hz");
  c = good;
  c.parameters["frequency"] = -1.0;
  refused(c, "parameters");
  c = good;
  c.worker_id.clear();
  refused(c, "no worker id");
  c = good;
  c.ticks.resize(257, c.ticks.back());
  refused(c, "ticks in one chunk");
  EXPECT_EQ(assembler.rejected_chunks(), 8u);
  EXPECT_EQ(assembler.partial_traces(), 0u);
  EXPECT_EQ(assembler.buffered_ticks(), 0u);
}

TEST(TraceAssembler, MemoryStaysWithinItsLimits) {
  domain::TraceAssemblerLimits limits;
  limits.max_partial_traces = 2;
  limits.max_buffered_ticks = 600;
  TraceAssembler assembler(limits);
  // Three traces begun and never finished: the third is refused, the first two hold their first chunk.
  for (int trial = 0; trial < 3; ++trial) {
    const TraceAssembler::Result r = assembler.add(domain::split_trace(make_trace(1000, 7, 1, trial)).front(), 0.0);
    EXPECT_EQ(r.rejected.has_value(), trial == 2);
  }
  EXPECT_EQ(assembler.partial_traces(), 2u);
  EXPECT_EQ(assembler.buffered_ticks(), 512u);
  // A further chunk of the first would pass 600 buffered ticks: refused.
  const TraceAssembler::Result r = assembler.add(domain::split_trace(make_trace(1000, 7, 1, 0))[1], 1.0);
  ASSERT_TRUE(r.rejected);
  EXPECT_NE(r.rejected->find("buffered"), std::string::npos);
  // A chunk contradicting its trace's header, and one received twice, are refused.
  RolloutTraceChunk other = domain::split_trace(make_trace(1000, 7, 1, 1))[0];
  EXPECT_TRUE(assembler.add(other, 1.0).rejected);  // the same chunk again
  other.chunk_index = 2;
  other.first_tick = 512;
  other.seed = 1;
  EXPECT_TRUE(assembler.add(other, 1.0).rejected);
  // Time runs out: both given up and counted; their memory is free again.
  EXPECT_TRUE(assembler.expire(100.0).empty());
  EXPECT_EQ(assembler.expire(200.0).size(), 2u);
  EXPECT_EQ(assembler.abandoned_traces(), 2u);
  EXPECT_EQ(assembler.buffered_ticks(), 0u);
}

TEST(TraceAssembler, ChunksThatDoNotTileAreDroppedWhole) {
  TraceAssembler assembler;
  std::vector<RolloutTraceChunk> chunks = domain::split_trace(make_trace(512));
  std::swap(chunks[0].first_tick, chunks[1].first_tick);  // each claims the other's place
  for (auto& c : chunks) {
    for (std::size_t i = 0; i < c.ticks.size(); ++i) c.ticks[i].time_s = (c.first_tick + i) / 500.0;
  }
  EXPECT_FALSE(assembler.add(chunks[0], 0.0).rejected);
  const TraceAssembler::Result r = assembler.add(chunks[1], 0.0);
  EXPECT_FALSE(r.complete);
  ASSERT_TRUE(r.rejected);
  EXPECT_NE(r.rejected->find("do not tile"), std::string::npos);
  EXPECT_EQ(assembler.abandoned_traces(), 1u);
}

class TraceStore : public ::testing::Test {
 protected:
  void SetUp() override {
    path_ = (std::filesystem::temp_directory_path() / ("traces-" + std::to_string(::getpid()) + ".db")).string();
    std::filesystem::remove(path_);
    store_ = std::make_unique<study::StudyStore>(path_);
    study_ = store_->create_study("t", "name: t\n", "t.yaml", 1.7e9);
    study::StoredTrial trial;
    trial.trial_id = 0;
    trial.x = Eigen::VectorXd::Zero(1);
    trial.worker_id = "morti";
    store_->add_trials(study_, {trial});
  }
  void TearDown() override {
    store_.reset();
    for (const char* suffix : {"", "-wal", "-shm"}) std::filesystem::remove(path_ + suffix);
  }
  std::string path_;
  std::unique_ptr<study::StudyStore> store_;
  int study_ = 0;
};

TEST_F(TraceStore, KeepsATraceExactlyAndOnlyForAnIssuedAttempt) {
  const RolloutTrace trace = make_trace(1234, store_->store_id(), study_);
  bool again = true;
  EXPECT_FALSE(store_->save_trace(trace, 1.7e9, &again));
  EXPECT_FALSE(again);
  EXPECT_FALSE(store_->save_trace(make_trace(10, store_->store_id(), study_), 1.7e9, &again));  // the same attempt again
  EXPECT_TRUE(again);  // kept once, the first
  EXPECT_TRUE(store_->save_trace(make_trace(10, store_->store_id(), study_, 5), 1.7e9));      // no trial 5
  EXPECT_TRUE(store_->save_trace(make_trace(10, store_->store_id(), study_, 0, 1), 1.7e9));   // never re-issued
  EXPECT_TRUE(store_->save_trace(make_trace(10, store_->store_id() + 1, study_), 1.7e9));     // another store's
  EXPECT_TRUE(store_->save_trace(make_trace(10, store_->store_id(), study_ + 1), 1.7e9));     // no such study
  const std::vector<study::StoredTrace> kept = store_->load_traces(study_);
  ASSERT_EQ(kept.size(), 1u);
  EXPECT_TRUE(same_ticks(kept[0].trace.trace, trace.trace));
  EXPECT_EQ(kept[0].trace.seed, trace.seed);
  EXPECT_EQ(kept[0].trace.parameters, trace.parameters);
  EXPECT_EQ(kept[0].trace.control_rate_hz, 500.0);
}

TEST_F(TraceStore, AnOlderStoreGetsTheTableInPlace) {
  store_.reset();
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path_.c_str(), &db), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(db, "DROP TABLE traces", nullptr, nullptr, nullptr), SQLITE_OK);  // as before issue 23
  sqlite3_close(db);
  store_ = std::make_unique<study::StudyStore>(path_);
  EXPECT_TRUE(store_->load_traces(study_).empty());
  EXPECT_FALSE(store_->save_trace(make_trace(20, store_->store_id(), study_), 1.7e9));
  EXPECT_EQ(store_->load(study_)->trials.size(), 1u);  // the study itself untouched
  EXPECT_EQ(store_->load_traces(study_).size(), 1u);
}

TEST_F(TraceStore, TheIntakeStoresWholeTracesAndCountsTheRest) {
  std::vector<std::string> warnings;
  service::TraceIntake intake(*store_, false, [](const std::string&) {},
                              [&](const std::string& m) { warnings.push_back(m); });
  for (const auto& c : domain::split_trace(make_trace(600, store_->store_id(), study_))) intake.add(c, 0.0, std::nullopt);
  for (const auto& c : domain::split_trace(make_trace(600, 99, study_))) intake.add(c, 0.0, std::nullopt);  // not ours
  EXPECT_EQ(intake.stored(), 1u);
  EXPECT_EQ(intake.rejected(), 3u);
  EXPECT_EQ(warnings.size(), 3u);
  // With DDS-Security: a sender whose certificate does not own the worker id is refused.
  service::TraceIntake secure(*store_, true, [](const std::string&) {}, [](const std::string&) {});
  secure.add(domain::split_trace(make_trace(10, store_->store_id(), study_))[0], 0.0, std::string("mallory"));
  secure.add(domain::split_trace(make_trace(10, store_->store_id(), study_))[0], 0.0, std::nullopt);
  EXPECT_EQ(secure.rejected(), 2u);
  EXPECT_EQ(store_->load_traces(study_).size(), 1u);
}

TEST(StudyModelYaml, LoadsAsTheSpecsModelAndCalibrationRewritesIt) {
  const study::StudySpec spec = study::StudySpec::resolve(
      "name: s\nmodel: {knee_spring: {stiffness_nm_per_rad: 12.5}}\n", "s.yaml", study::SpecDefaults::shipped());
  const std::string yaml = calibration::model_yaml_of(spec.tree()["model"]);
  const sim::PlanarLegModel back = sim::parse_model_file(YamlReader::from_string(yaml, "spec model"));
  EXPECT_EQ(back.knee_spring.stiffness_nm_per_rad, 12.5);
  EXPECT_EQ(back.trunk_mass_kg, spec.model().trunk_mass_kg);
  EXPECT_EQ(back.contact.friction, spec.model().contact.friction);
  calibration::CalibrationResult r;
  calibration::FittedValue v;
  v.name = "knee_spring.stiffness_nm_per_rad";
  v.estimate = 11.75;
  r.values.push_back(v);
  const std::string text = calibration::calibrated_model_text(yaml, "spec model", r, {"trace"});
  EXPECT_EQ(sim::parse_model_file(YamlReader::from_string(text, "calibrated")).knee_spring.stiffness_nm_per_rad, 11.75);
}

}  // namespace
}  // namespace cpgmatch
