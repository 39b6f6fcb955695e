#include "study_file_man_page.hpp"

#include "cpgmatch/study/study_file_keys.hpp"

namespace cpgmatch::cli {

runtime::ManPage study_file_man_page(const std::string& version) {
  using runtime::roff_escape;
  std::string text = runtime::roff_title("cpgmatch-study", 5, version);
  text += ".SH NAME\ncpgmatch\\-study \\- the study file: one optimisation study of the CPG, in YAML\n";
  text += ".SH DESCRIPTION\n.PP\n" +
          roff_escape(
              "A study file names only what differs from the release's defaults. `cpgmatch study submit --config "
              "FILE` sends it to the optimizer service, which resolves it at submit into the study's spec (the "
              "whole model, rollout settings and base parameters, with a SHA-256) and stores it; every worker runs "
              "exactly that spec. `cpgmatch study resolve --config FILE` shows what a file resolves to. A key that "
              "is not listed here is refused, naming the file and line. Units are SI: metres, seconds, radians, "
              "hertz, newton-metres.") +
          "\n";
  text += ".SH KEYS\n";
  for (const study::StudyFileKey& key : study::study_file_keys()) {
    text += ".TP\n\\fB" + roff_escape(key.key) + "\\fR: \\fI" + roff_escape(key.value) + "\\fR";
    if (*key.default_text != '\0') text += " (default: " + roff_escape(key.default_text) + ")";
    text += "\n" + roff_escape(key.description) + "\n";
  }
  text += ".SH EXAMPLE\n.nf\n" +
          roff_escape(
              "name: stiff-knee\n"
              "budget: 60\n"
              "seed: 3\n"
              "model: {knee_spring: {stiffness_nm_per_rad: 20}}\n"
              "rollout_settings: {cost: {weights: {feedback: 4}}}\n") +
          ".fi\n";
  text += ".SH SEE ALSO\n.BR cpgmatch\\-study\\-submit (1),\n.BR cpgmatch\\-study\\-resolve (1),\n"
          ".BR cpgmatch\\-study\\-run (1)\n";
  return runtime::ManPage{"cpgmatch-study.5", text};
}

}  // namespace cpgmatch::cli
