// Known gaits queued as a study's trials (`enqueue:` in a study file, `cpgmatch study enqueue`): a gait is a
// parameter file's values; as a trial it is a point of the study's search space. Only a gait the study
// could have proposed is taken: every searched parameter given and inside its bounds, every other value
// the study's own (a trial cannot run another frequency than the study fixes), every constraint met.
#pragma once

#include <Eigen/Core>

#include "cpgmatch/domain/command.hpp"
#include "cpgmatch/study/study_spec.hpp"

namespace cpgmatch::service {

// The gait as a point of the spec's search space. Throws InputError naming the gait's file and what is wrong
// (a missing or unknown parameter, a value out of bounds or not the study's, the constraint it violates).
Eigen::VectorXd point_of_gait(const study::StudySpec& spec, const domain::EnqueuedGait& gait);

// The spec of the same study with `budget` (a study extended: `cpgmatch study extend`); nothing else changes.
study::StudySpec with_budget(const study::StudySpec& spec, int budget);

}  // namespace cpgmatch::service
