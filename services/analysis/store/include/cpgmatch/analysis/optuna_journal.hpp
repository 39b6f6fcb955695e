// An Optuna journal (optuna.storages.JournalStorage over JournalFileStorage, Optuna 3.1 as Debian 12 ships
// it): one JSON object per line, each an operation Optuna replays: create a study (op 0), set a study's user
// attribute (op 2), create a finished trial from a template (op 4, with its state, value, parameters and
// their distributions, datetimes and user attributes). Written from the format alone (optuna/storages/
// _journal/storage.py documents it by its replay code), not from Optuna's code.
//
// Mapping: a done trial that ran is COMPLETE with its cost as the value (a fall too: it is a measured cost);
// a failed one FAIL without a value; one still in flight RUNNING. Each optimised parameter is a
// FloatDistribution over its search range (log when the space says so); everything else of the row is a
// trial user attribute (terms, feedback, torque, fell, worker, source, outcome). Studies are minimised.
#pragma once

#include <ostream>
#include <vector>

#include "cpgmatch/analysis/study_export.hpp"

namespace cpgmatch::analysis {

// Optuna study names are unique in a journal (a second study of a name is dropped on replay): a name that
// occurs more than once among `studies` gets " (study ID)" appended. Returns the names written, in order.
std::vector<std::string> write_optuna_journal(const std::vector<ExportedStudy>& studies, std::ostream& out);

}  // namespace cpgmatch::analysis
