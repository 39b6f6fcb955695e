#include "urdf_trunk_mass.hpp"

#include <cctype>

#include <fmt/format.h>

#include "cpgmatch/calibration/calibrated_model.hpp"
#include "cpgmatch/errors.hpp"
#include "text_edits.hpp"

namespace cpgmatch::calibration {
namespace {

// [begin, end) of the value of attribute `name` in the tag text[tag_begin, tag_end); npos when absent.
std::pair<std::size_t, std::size_t> attribute(const std::string& text, std::size_t tag_begin, std::size_t tag_end,
                                              const std::string& name) {
  for (std::size_t at = text.find(name, tag_begin); at < tag_end; at = text.find(name, at + 1)) {
    if (!std::isspace(static_cast<unsigned char>(text[at - 1]))) continue;
    std::size_t i = at + name.size();
    while (i < tag_end && std::isspace(static_cast<unsigned char>(text[i]))) ++i;
    if (i >= tag_end || text[i] != '=') continue;
    ++i;
    while (i < tag_end && std::isspace(static_cast<unsigned char>(text[i]))) ++i;
    if (i >= tag_end || (text[i] != '"' && text[i] != '\'')) continue;
    const std::size_t close = text.find(text[i], i + 1);
    if (close < tag_end) return {i + 1, close};
  }
  return {std::string::npos, std::string::npos};
}

// The start of the first tag `<name` (followed by a space or '/', so that <inertia is not <inertial) in
// [from, to); npos when none.
std::size_t tag(const std::string& text, const std::string& name, std::size_t from, std::size_t to) {
  for (std::size_t at = text.find("<" + name, from); at < to; at = text.find("<" + name, at + 1)) {
    const char next = text[at + 1 + name.size()];
    if (std::isspace(static_cast<unsigned char>(next)) || next == '/' || next == '>') return at;
  }
  return std::string::npos;
}

}  // namespace

// The URDF with the root link's mass set to the estimate and its inertia tensor scaled by the same ratio.
// Textual: one attribute each, everything else of the file as written; the result is parsed again below.
std::string urdf_with_trunk_mass(const std::string& urdf, const RobotDescription& robot, const FittedValue& mass,
                                 const CalibrationResult& result) {
  const std::string where = fmt::format("{} link '{}'", robot.urdf_source, robot.root_link);
  std::size_t link = std::string::npos;
  for (std::size_t at = tag(urdf, "link", 0, urdf.size()); at != std::string::npos;
       at = tag(urdf, "link", at + 1, urdf.size())) {
    const auto [b, e] = attribute(urdf, at, urdf.find('>', at), "name");
    if (b != std::string::npos && urdf.compare(b, e - b, robot.root_link) == 0) {
      link = at;
      break;
    }
  }
  const std::size_t link_end = link == std::string::npos ? link : urdf.find("</link>", link);
  const std::size_t inertial = link_end == std::string::npos ? link_end : tag(urdf, "inertial", link, link_end);
  const std::size_t mass_tag = inertial == std::string::npos ? inertial : tag(urdf, "mass", inertial, link_end);
  const std::size_t inertia_tag = inertial == std::string::npos ? inertial : tag(urdf, "inertia", inertial, link_end);
  if (mass_tag == std::string::npos || inertia_tag == std::string::npos) {
    throw InputError(fmt::format("{}: no <inertial> with <mass> and <inertia> to rewrite", where));
  }
  const double old_mass = robot.link(robot.root_link).mass_kg;
  const double ratio = mass.estimate / old_mass;
  std::vector<Edit> edits;
  const auto [mb, me] = attribute(urdf, mass_tag, urdf.find('>', mass_tag), "value");
  if (mb == std::string::npos) throw InputError(fmt::format("{}: <mass> has no value attribute", where));
  edits.push_back({mb, me, exact_decimal(mass.estimate)});
  for (const char* component : {"ixx", "ixy", "ixz", "iyy", "iyz", "izz"}) {
    const auto [b, e] = attribute(urdf, inertia_tag, urdf.find('>', inertia_tag), component);
    if (b == std::string::npos) continue;  // urdfdom reads an absent component as 0, which scales to 0
    edits.push_back({b, e, exact_decimal(std::stod(urdf.substr(b, e - b)) * ratio)});
  }
  // Why the inertia is scaled: a fitted mass says the trunk weighs more (a battery, a payload), not where;
  // scaling the tensor keeps its radii of gyration, the body's shape. Placed before <inertial>, indented alike.
  const std::size_t line_start = urdf.rfind('\n', inertial) + 1;
  const std::string indent = urdf.substr(line_start, inertial - line_start);
  std::string note = fmt::format(
      "cpgmatch calibrate, the trunk's mass: {}. The inertia tensor is scaled by the same ratio {:.6g}: the fit gives "
      "the mass, not where it sits, so the trunk keeps its shape (radii of gyration).",
      calibrated_source(mass, result, ""), ratio);
  for (std::size_t d = note.find("--"); d != std::string::npos; d = note.find("--")) note.replace(d, 2, "- ");  // not in XML comments
  const std::string comment = "<!-- " + note + " -->\n" + indent;
  edits.push_back({inertial, inertial, comment});
  return apply_edits(urdf, edits);
}

}  // namespace cpgmatch::calibration
