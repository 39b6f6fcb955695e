#include "robot_overlay.hpp"

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include "cpgmatch/errors.hpp"
#include "cpgmatch/split.hpp"
#include "cpgmatch/robot_description_loader.hpp"

namespace cpgmatch::detail {
namespace {

namespace fs = std::filesystem;

// Overlays on overlays are allowed (a calibrated worn Morti); this many deep is a cycle, not a design.
constexpr int kMaxOverlayDepth = 8;

std::vector<std::string> split_path(const std::string& path) {
  const std::vector<std::string_view> steps = split_on(path, '.');
  return {steps.begin(), steps.end()};
}

// The element of a list whose `name` is `name` (legs, parallel springs), else nullopt.
std::optional<std::size_t> element_named(const YAML::Node& list, const std::string& name) {
  for (std::size_t i = 0; i < list.size(); ++i) {
    if (list[i].IsMap() && list[i]["name"] && list[i]["name"].IsScalar() && list[i]["name"].Scalar() == name) return i;
  }
  return std::nullopt;
}

// Sets `path` in `tree` (a robot.yaml) to `value`; the reason it cannot, or nullopt. Every step of the path
// must exist, except below `links`, which overrides URDF links and may be new in the overlay.
std::optional<std::string> set_value(YAML::Node tree, const std::string& path, const YAML::Node& value) {
  const std::vector<std::string> parts = split_path(path);
  for (const std::string& part : parts) {
    if (part.empty()) return fmt::format("'{}' has an empty step", path);
  }
  const bool may_be_new = parts.front() == "links";
  if (may_be_new && parts.size() != 3) return "a link's value is links.LINK.mass_kg";
  YAML::Node node = tree;
  for (std::size_t i = 0; i + 1 < parts.size(); ++i) {
    const std::string& part = parts[i];
    if (node.IsSequence()) {
      const std::optional<std::size_t> at = element_named(node, part);
      if (!at) return fmt::format("the base's '{}' has no element named '{}'", fmt::join(parts.begin(), parts.begin() + i, "."), part);
      node.reset(node[*at]);
      continue;
    }
    if (!node.IsMap()) return fmt::format("the base's '{}' is not a mapping", fmt::join(parts.begin(), parts.begin() + i, "."));
    if (!node[part]) {
      if (!may_be_new) return fmt::format("the base's robot.yaml has no '{}'", fmt::join(parts.begin(), parts.begin() + i + 1, "."));
      node[part] = YAML::Node(YAML::NodeType::Map);
    }
    YAML::Node next = node[part];
    node.reset(next);
  }
  if (!node.IsMap()) return fmt::format("the base's '{}' is not a mapping", fmt::join(parts.begin(), parts.end() - 1, "."));
  if (!node[parts.back()] && !may_be_new) return fmt::format("the base's robot.yaml has no '{}'", path);
  node[parts.back()] = YAML::Clone(value);
  return std::nullopt;
}

struct Setting {
  std::string path;
  YAML::Node value;
};

std::string merged_text(const YAML::Node& base_tree, const std::vector<Setting>& settings, std::size_t count,
                        const YamlReader& set) {
  YAML::Node tree = YAML::Clone(base_tree);
  for (std::size_t i = 0; i < count; ++i) {
    if (auto why = set_value(tree, settings[i].path, settings[i].value)) set.fail(settings[i].path, *why);
  }
  tree.remove("base");
  tree.remove("set");
  YAML::Emitter out;
  out << tree;
  return std::string(out.c_str()) + "\n";
}

}  // namespace

bool is_robot_overlay(const YamlReader& yaml) { return yaml.has("base"); }

RobotDescription load_robot_overlay(const YamlReader& overlay, const fs::path& overlay_path, int depth) {
  overlay.reject_unknown_keys({"base", "name", "summary", "set"});
  if (depth >= kMaxOverlayDepth) {
    overlay.fail("base", fmt::format("overlays nest {} deep: is there a cycle of bases?", depth));
  }
  const std::string base_name = overlay.require_string("base");
  // A plain name is a shipped robot unless such a file or folder is beside the overlay (as for load_robot).
  const fs::path beside = overlay_path.parent_path() / base_name;
  std::error_code ec;
  const std::string base_ref = (names_shipped_robot(base_name) && !fs::exists(beside, ec)) ? base_name : beside.string();
  RobotDescription base;
  try {
    base = load_robot_at_depth(base_ref, depth + 1);
  } catch (const InputError& e) {
    overlay.fail("base", e.what());
  }

  // Without `set:` the overlay is its base under another name or summary; `set` then only names the overlay.
  const YamlReader set = overlay.has("set") ? overlay.child("set") : overlay;
  std::vector<Setting> settings;
  if (overlay.has("set")) {
    set.check_keys();
    for (const auto& entry : set.node()) settings.push_back({entry.first.as<std::string>(), entry.second});
  }
  YAML::Node base_tree = YAML::Load(base.yaml_text);
  if (overlay.has("name")) base_tree["name"] = overlay.require_string("name");
  if (overlay.has("summary")) base_tree["summary"] = overlay.require_string("summary");

  const std::string source = fmt::format("{} (over {})", overlay_path.string(), base.yaml_source);
  const std::string text = fmt::format("# {}: the robot {} with the values the overlay sets\n{}", overlay_path.string(),
                                       base.yaml_source, merged_text(base_tree, settings, settings.size(), set));
  try {
    return parse_robot(text, source, base.urdf_text, base.urdf_source);
  } catch (const InputError& whole) {
    // Name the overlay's own line: the first setting after which the base no longer checks.
    for (std::size_t count = 1; count <= settings.size(); ++count) {
      try {
        (void)parse_robot(merged_text(base_tree, settings, count, set), source, base.urdf_text, base.urdf_source);
      } catch (const InputError& e) {
        set.fail(settings[count - 1].path, fmt::format("makes an invalid robot of {}: {}", base.yaml_source, e.what()));
      }
    }
    overlay.fail("", fmt::format("makes an invalid robot of {}: {}", base.yaml_source, whole.what()));
  }
}

}  // namespace cpgmatch::detail
