// Where a study is in its life: one of five states, not a string. The store keeps the names (to_string); a
// name it does not know is refused when a study is reopened.
#pragma once

#include <optional>
#include <string>

namespace cpgmatch::domain {

enum class StudyStatus { kRunning, kPaused, kDone, kFailed, kStopped };

inline const char* to_string(StudyStatus s) {
  switch (s) {
    case StudyStatus::kRunning: return "running";
    case StudyStatus::kPaused: return "paused";
    case StudyStatus::kDone: return "done";
    case StudyStatus::kFailed: return "failed";
    case StudyStatus::kStopped: return "stopped";
  }
  return "unknown";
}

inline std::optional<StudyStatus> study_status_from_string(const std::string& name) {
  for (const StudyStatus s : {StudyStatus::kRunning, StudyStatus::kPaused, StudyStatus::kDone, StudyStatus::kFailed,
                              StudyStatus::kStopped}) {
    if (name == to_string(s)) return s;
  }
  return std::nullopt;
}

// Open: it may still issue work or take reports (running or paused).
inline bool is_open(StudyStatus s) { return s == StudyStatus::kRunning || s == StudyStatus::kPaused; }

}  // namespace cpgmatch::domain
