// JSON views of the wire types: the study store keeps reports as JSON, and the CLI prints these.
#pragma once

#include <nlohmann/json.hpp>

#include "cpgmatch_msgs.h"

namespace cpgmatch::dds {

nlohmann::json to_json(const msg::RolloutReport& r);
// Throws nlohmann::json::exception when a field is missing or has the wrong type.
msg::RolloutReport report_from_json(const nlohmann::json& j);

nlohmann::json to_json(const msg::StudyState& s);
nlohmann::json to_json(const msg::WorkerAnnouncement& w);
nlohmann::json to_json(const msg::TrialRecord& t);

}  // namespace cpgmatch::dds
