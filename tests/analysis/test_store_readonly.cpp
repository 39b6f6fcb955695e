// Issue 34: a store is read-only when read, refuses what it cannot read, and never exports a silent subset.
// Each test damages a real store (SQLite on a temporary file) and reads it the way export and report do.
#include <gtest/gtest.h>
#include <sqlite3.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <random>

#include "cpgmatch/analysis/stored_study_trials.hpp"
#include "cpgmatch/analysis/study_export.hpp"
#include "cpgmatch/errors.hpp"
#include "cpgmatch/study/study_store.hpp"

namespace cpgmatch::analysis {
namespace {

namespace fs = std::filesystem;

void sql(const std::string& path, const std::string& statement) {
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  char* error = nullptr;
  const int rc = sqlite3_exec(db, statement.c_str(), nullptr, nullptr, &error);
  EXPECT_EQ(rc, SQLITE_OK) << (error ? error : "") << " in " << statement;
  sqlite3_free(error);
  sqlite3_close(db);
}

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

std::uintmax_t size_of(const std::string& path) { return fs::file_size(path); }

class StoreReadOnly : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("store-ro-" + std::to_string(getpid()));
    fs::create_directories(dir_);
    store_ = (dir_ / "s.db").string();
    study::StudyStore store(store_);
    for (int k = 0; k < 3; ++k) {
      const int id = store.create_study("gait", "name: gait\nbudget: 6\ninitial_points: 2\n", "s.yaml", 1.7e9 + k);
      std::vector<study::StoredTrial> trials;
      for (int i = 0; i < 6; ++i) {
        study::StoredTrial t;
        t.trial_id = i;
        t.x = Eigen::VectorXd::Constant(6, 0.1);
        t.worker_id = "w";
        trials.push_back(t);
      }
      store.add_trials(id, trials);
      for (int i = 0; i < 6; ++i) {
        domain::RolloutReport r;
        r.id.study_id = id;
        r.id.trial_id = i;
        r.worker_id = "w";
        r.outcome = domain::Outcome::kCompleted;
        r.summary.cost = 1.0 + i;
        store.complete_trial(r, 1.7e9 + i);
      }
    }
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
  std::string store_;
};

TEST_F(StoreReadOnly, AnEmptyFileOrAnotherDatabaseIsRefusedAndNotWritten) {
  const std::string empty = (dir_ / "empty.db").string();
  std::ofstream(empty).close();
  EXPECT_NE(error_of([&] { study::StudyStore s(empty, study::kReadOnly); }).find("not a cpgmatch study store"),
            std::string::npos);
  EXPECT_EQ(size_of(empty), 0u);  // before: the 7 tables, 0 -> 48 KB
  const std::string other = (dir_ / "other.db").string();
  sql(other, "CREATE TABLE birds(name TEXT); INSERT INTO birds VALUES('wren')");
  const auto before = size_of(other);
  EXPECT_NE(error_of([&] { study::StudyStore s(other, study::kReadOnly); }).find("without cpgmatch's tables"),
            std::string::npos);
  EXPECT_EQ(size_of(other), before);
  // The service's read-write open refuses another database too, instead of adding its tables to it.
  EXPECT_NE(error_of([&] { study::StudyStore s(other); }).find("not a cpgmatch study store"), std::string::npos);
  EXPECT_EQ(size_of(other), before);
  const std::string text = (dir_ / "text.db").string();
  std::ofstream(text) << std::string(4096, 'x');
  EXPECT_NE(error_of([&] { study::StudyStore s(text, study::kReadOnly); }).find("not an SQLite database"),
            std::string::npos);
  EXPECT_NE(error_of([&] { study::StudyStore s((dir_ / "none.db").string(), study::kReadOnly); }).find("no such file"),
            std::string::npos);
  EXPECT_FALSE(fs::exists(dir_ / "none.db"));
}

TEST_F(StoreReadOnly, ReadingWritesNothing) {
  sql(store_, "PRAGMA wal_checkpoint(TRUNCATE)");
  const auto before = fs::last_write_time(store_);
  const auto size = size_of(store_);
  { study::StudyStore s(store_, study::kReadOnly); EXPECT_EQ(s.load_all().size(), 3u); }
  (void)load_stored_study(store_, 2);
  EXPECT_EQ(fs::last_write_time(store_), before);
  EXPECT_EQ(size_of(store_), size);
  // A store the user may not write is still readable.
  fs::permissions(store_, fs::perms::owner_read);
  EXPECT_EQ(study::StudyStore(store_, study::kReadOnly).load_all().size(), 3u);
  fs::permissions(store_, fs::perms::owner_read | fs::perms::owner_write);
}

TEST_F(StoreReadOnly, ANewerSchemaIsRefusedNamingBothVersions) {
  sql(store_, "PRAGMA user_version = 999");
  for (const auto& e : {error_of([&] { study::StudyStore s(store_, study::kReadOnly); }),
                        error_of([&] { study::StudyStore s(store_); })}) {
    EXPECT_NE(e.find("schema version 999"), std::string::npos) << e;
    EXPECT_NE(e.find("up to " + std::to_string(study::kStoreSchemaVersion)), std::string::npos) << e;
  }
}

TEST_F(StoreReadOnly, AnUnreadableTrialIsNamedNeverDropped) {
  sql(store_, "UPDATE trials SET report_json = '{not json' WHERE study_id = 3 AND trial_id = 2");
  sql(store_, "UPDATE trials SET x_json = '[0.1, 0.1' WHERE study_id = 3 AND trial_id = 4");
  study::StudyStore s(store_, study::kReadOnly);
  const auto all = s.load_all();
  ASSERT_EQ(all.size(), 3u);
  EXPECT_EQ(all[2].unreadable_trials.size(), 2u);
  // export (every study) and report (one study) refuse, naming each trial; before: 12 of 18 exported, exit 0.
  const std::string e = error_of([&] { require_every_trial_readable(all, store_); });
  EXPECT_NE(e.find("study 3 trial 2"), std::string::npos) << e;
  EXPECT_NE(e.find("study 3 trial 4"), std::string::npos) << e;
  EXPECT_NE(error_of([&] { (void)load_stored_study(store_, 3); }).find("study 3 trial 2"), std::string::npos);
  EXPECT_EQ(load_stored_study(store_, 1).trials.size(), 6u);  // an intact study still reads
}

TEST_F(StoreReadOnly, ADamagedStudyTextBlamesTheStoreNotTheStudyFile) {
  sql(store_, "UPDATE studies SET config_yaml = 'name: [gait' WHERE study_id = 2");
  const auto stored = load_stored_study(store_, 2);
  const std::string e = error_of([&] { (void)export_study(stored); });
  EXPECT_NE(e.find("the store's copy of study 2"), std::string::npos) << e;
  EXPECT_THROW((void)trials_from_stored_study(stored), std::runtime_error);
  try {
    (void)trials_from_stored_study(stored);
  } catch (const InputError&) {
    ADD_FAILURE() << "a damaged stored text must not be an input error of the study file";
  } catch (const std::exception&) {
  }
}

TEST_F(StoreReadOnly, RandomByteFlipsNeverExportASilentSubset) {
  // 40 stores, each with 30 random bytes flipped past the header: every read either returns all 18 trials
  // or throws. (What a flip inside a number does is invisible to any reader without checksums; a flip that
  // changes no row's meaning is no loss.)
  sql(store_, "PRAGMA wal_checkpoint(TRUNCATE); PRAGMA journal_mode=DELETE");
  std::mt19937 rng(34);
  int refused = 0, whole = 0;
  for (int round = 0; round < 40; ++round) {
    const std::string copy = (dir_ / ("flip-" + std::to_string(round) + ".db")).string();
    fs::copy_file(store_, copy, fs::copy_options::overwrite_existing);
    {
      std::fstream f(copy, std::ios::in | std::ios::out | std::ios::binary);
      const auto size = static_cast<long>(fs::file_size(copy));
      for (int k = 0; k < 30; ++k) {
        f.seekp(std::uniform_int_distribution<long>(100, size - 1)(rng));
        f.put(static_cast<char>(std::uniform_int_distribution<int>(0, 255)(rng)));
      }
    }
    std::size_t trials = 0;
    const std::string e = error_of([&] {
      study::StudyStore s(copy, study::kReadOnly);
      const auto all = s.load_all();
      require_every_trial_readable(all, copy);
      for (const auto& st : all) {
        const auto x = export_study(st);
        trials += x.trials.size();
      }
    });
    if (e.empty()) {
      // The rows the flips did not reach: all of them, or the whole store was refused.
      EXPECT_EQ(trials, 18u) << "round " << round;
      ++whole;
    } else {
      ++refused;
    }
  }
  RecordProperty("refused", refused);
  RecordProperty("whole", whole);
  EXPECT_GT(refused, 0);
}

}  // namespace
}  // namespace cpgmatch::analysis
