#include "report_html.hpp"

#include <openssl/evp.h>

#include <cmath>
#include <set>

#include <fmt/format.h>

#include "web_assets.hpp"

namespace cpgmatch::cli {

namespace {

using nlohmann::json;

std::string number(const json& v, const char* format = "{:.4g}") {
  return v.is_number() ? fmt::format(fmt::runtime(format), v.get<double>()) : std::string("-");
}

const json& at_or_null(const json& j, const char* key) {
  static const json null;
  return j.is_object() && j.contains(key) ? j.at(key) : null;
}

// The unit as the table prints it: a dimensionless parameter (a fraction of a cycle) says so.
std::string unit_text(const std::string& unit) { return unit.empty() || unit == "1" ? "fraction" : unit; }

// The answer of the study: the GP's recommendation beside the lowest single cost, parameter by parameter, in
// the study's search space's order and with its units; parameters the space holds fixed follow by name.
std::string gait_table(const json& report, const std::vector<ReportParameter>& space) {
  const json& rec = at_or_null(report, "recommended");
  const json& best = at_or_null(report, "best");
  if (!at_or_null(best, "rollout").is_number() || best.at("rollout").get<int>() <= 0) {
    return "<p>No rollout ran: there is no gait to recommend.</p>\n";
  }
  std::vector<std::pair<std::string, std::string>> rows;  // name, unit
  std::set<std::string> searched;
  for (const ReportParameter& p : space) {
    rows.emplace_back(p.name, fmt::format("{} ({:.4g} .. {:.4g})", unit_text(p.unit), p.low, p.high));
    searched.insert(p.name);
  }
  std::set<std::string> others;
  for (const json* p : {&at_or_null(rec, "params"), &at_or_null(best, "params")}) {
    if (p->is_object()) for (const auto& [k, v] : p->items()) if (!searched.count(k)) others.insert(k);
  }
  for (const std::string& n : others) rows.emplace_back(n, "fixed");
  std::string out = "<table class=\"gait\"><thead><tr><th>parameter</th><th>unit (searched range)</th>";
  if (rec.is_object()) out += fmt::format("<th>recommended (rollout {})</th>", number(rec.at("rollout"), "{:.0f}"));
  out += fmt::format("<th>lowest cost (rollout {})</th></tr></thead><tbody>\n", number(best.at("rollout"), "{:.0f}"));
  for (const auto& [n, unit] : rows) {
    out += fmt::format("<tr><td>{}</td><td>{}</td>", html_escape(n), html_escape(unit));
    if (rec.is_object()) out += fmt::format("<td class=\"num\">{}</td>", number(at_or_null(rec.at("params"), n.c_str())));
    out += fmt::format("<td class=\"num\">{}</td></tr>\n", number(at_or_null(best.at("params"), n.c_str())));
  }
  out += "<tr class=\"sum\"><td>cost</td><td>dimensionless</td>";
  if (rec.is_object()) {
    out += fmt::format("<td class=\"num\">{} observed, {} ± {} GP posterior</td>", number(rec.at("observed_cost")),
                       number(rec.at("predicted_cost")), number(rec.at("predicted_sd")));
  }
  out += fmt::format("<td class=\"num\">{}{}</td></tr>\n", number(best.at("cost")),
                     at_or_null(best, "fell") == true ? " (fell)" : "");
  out += fmt::format("<tr class=\"sum\"><td>speed, normalised torque</td><td>m/s, N m/(m/s)</td>{}<td class=\"num\">{} m/s, {}</td></tr>\n",
                     rec.is_object() ? "<td></td>" : "", number(at_or_null(best, "speed_mps"), "{:.3f}"),
                     number(at_or_null(best, "normalized_torque"), "{:.3f}"));
  return out + "</tbody></table>\n";
}

std::string joules(double v) { return std::isfinite(v) ? fmt::format("{:.4g}", v) : std::string("-"); }

// What each leg's motors spent in the answer's rollout, leg by leg under the robot's own names: a leg that
// works much harder than its neighbours shows here before it shows in the totals.
std::string leg_energy_table(const ReportContent& c) {
  if (c.leg_energy.empty()) return "<p>No energy per leg was measured for this study's answer.</p>\n";
  std::string out = fmt::format("<p>Energy per leg over the evaluation window of {} (J).</p>\n", html_escape(c.leg_energy_rollout)) +
                    "<table class=\"legs\"><thead><tr><th>leg</th><th>hip positive work</th><th>knee positive work</th>"
                    "<th>hip electrical</th><th>knee electrical</th></tr></thead><tbody>\n";
  for (const ReportLegEnergy& l : c.leg_energy) {
    out += fmt::format("<tr><td>{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td>"
                       "<td class=\"num\">{}</td></tr>\n",
                       html_escape(l.leg), joules(l.hip_positive_work_j), joules(l.knee_positive_work_j),
                       joules(l.hip_electrical_j), joules(l.knee_electrical_j));
  }
  return out + "</tbody></table>\n";
}

}  // namespace

// Fig. 4 draws the first leg's joints and the first two legs' feedback (services/analysis trace_plot.cpp).
std::string fig4_caption(const std::vector<std::string>& legs) {
  const std::string first = legs.empty() ? "the first leg" : legs[0];
  const std::string feedback = legs.size() >= 2 ? fmt::format("{} and {}", legs[0], legs[1]) : first;
  return fmt::format("Fig. 4: the recommended gait over the last 4 s of one rollout: the {} legs' coupled phases, {}'s "
                     "hip and knee with stance shaded, and the feedback of {}",
                     legs.size(), first, feedback);
}

std::string html_escape(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (const char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&#39;"; break;
      default: out += c;
    }
  }
  return out;
}

std::string base64(std::string_view bytes) {
  // OpenSSL's encoder (a NUL-terminated block of 4 characters per 3 bytes), not a hand-written one.
  std::string out(4 * ((bytes.size() + 2) / 3) + 1, '\0');
  const int n = EVP_EncodeBlock(reinterpret_cast<unsigned char*>(out.data()),
                                reinterpret_cast<const unsigned char*>(bytes.data()), static_cast<int>(bytes.size()));
  out.resize(static_cast<std::size_t>(n));
  return out;
}

std::string report_html(const ReportContent& c) {
  std::string html = fmt::format(
      "<!doctype html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
      "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n"
      // Nothing outside this file may load: the report must read the same offline and in ten years.
      "<meta http-equiv=\"Content-Security-Policy\" content=\"default-src 'none'; img-src data:; style-src 'unsafe-inline'\">\n"
      "<title>cpgmatch report: {0}</title>\n<style>\n{1}</style>\n</head>\n<body>\n"
      "<header><h1>cpgmatch report: {0}</h1><p class=\"generated\">{2}</p></header>\n<main>\n",
      html_escape(c.title), web::report_css(), html_escape(c.generated_by));

  html += "<section id=\"summary\"><h2>The study at a glance</h2><dl>\n";
  for (const auto& [k, v] : c.facts) html += fmt::format("<dt>{}</dt><dd>{}</dd>\n", html_escape(k), html_escape(v));
  html += "</dl></section>\n";

  html += "<section id=\"gait\"><h2>The gait it found</h2>\n"
          "<p>The recommended gait is the rollout with the lowest GP posterior mean (a single rollout's cost is noisy); "
          "the lowest single cost is beside it. Rollouts are numbered from 1, as in the paper's figures; the study's state "
          "and the dashboard give trial ids, which count from 0 (rollout N is trial N - 1). Parameters and units "
          "are the study's search space's.</p>\n" +
          gait_table(c.report, c.parameters) + "</section>\n";

  std::string legs;
  for (const std::string& leg : c.legs) legs += (legs.empty() ? "" : " ") + leg;
  html += fmt::format("<section id=\"legs\"><h2>Legs: {} ({})</h2>\n", c.legs.size(), html_escape(legs)) +
          leg_energy_table(c) + "</section>\n";

  html += "<section id=\"figures\"><h2>Figures</h2>\n";
  for (const ReportFigure& f : c.figures) {
    if (f.png.empty()) continue;
    html += fmt::format("<figure id=\"{0}\"><img alt=\"{0}: {1}\" src=\"data:image/png;base64,{2}\">"
                        "<figcaption><b>{0}</b>: {1}</figcaption></figure>\n",
                        html_escape(f.stem), html_escape(f.caption), base64(f.png));
  }
  if (!c.not_drawn.empty()) {
    html += "<p>Not drawn, because this study's data cannot give it:</p><ul class=\"not-drawn\">\n";
    for (const std::string& why : c.not_drawn) html += fmt::format("<li>{}</li>\n", html_escape(why));
    html += "</ul>\n";
  }
  html += "</section>\n";

  html += "<section id=\"science\"><h2>Beside the paper</h2>\n"
          "<p>What <code>cpgmatch analyze</code> prints: each statistic of this study beside Ruppert &amp; "
          "Badri-Sproewitz 2022's (docs/analysis.md explains each).</p>\n<pre>" +
          html_escape(c.science_table) + "</pre>\n";
  if (!c.sim2real_text.empty()) html += "<h3>Simulation and hardware</h3>\n<pre>" + html_escape(c.sim2real_text) + "</pre>\n";
  html += "</section>\n";

  html += "<section id=\"spec\"><h2>The study</h2>\n<h3>Study file, as submitted</h3>\n<pre>" +
          html_escape(c.study_yaml) + "</pre>\n";
  if (!c.spec_json.empty()) {
    html += "<details><summary>Resolved spec: model, settings, bounds and every default, as the workers ran it"
            "</summary>\n<pre>" + html_escape(c.spec_json) + "</pre></details>\n";
  }
  html += "</section>\n</main>\n</body>\n</html>\n";
  return html;
}

}  // namespace cpgmatch::cli
