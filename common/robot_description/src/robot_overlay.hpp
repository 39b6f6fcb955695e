// A robot overlay: a robot that is another robot with a few values changed, each with the physical reason
// (configs/robots/morti/scenarios/*.yaml: Morti with worn knee springs, on a slippery belt, ...).
//
//   base: morti                       # a shipped robot's name, or a robot.yaml, its folder or another
//                                     # overlay, relative to this file's folder
//   summary: "Morti with worn knee springs"        # optional; so is `name` (default: the base's)
//   set:
//     drives.knee.stiffness_nm_per_rad: {value: 12.0, source: "REALITY GAP: 15 -> 12 N m/rad: ..."}
//     parallel_springs.biarticular.stiffness_nm_per_rad: 3.5   # a list element by its `name`
//     links.trunk.mass_kg: {value: 3.5, source: "..."}         # a URDF link's mass (robot.yaml `links:`)
//
// Each path names a value the base's robot.yaml has (`links.LINK.mass_kg` may be new: it overrides the
// URDF). The result is the base's robot.yaml with those values set, checked as any robot.yaml; its URDF is
// the base's. A name stays the base's by default: a worn Morti is still Morti, and its agent drives it.
#pragma once

#include <filesystem>

#include "cpgmatch/robot_description.hpp"
#include "cpgmatch/yaml_reader.hpp"

namespace cpgmatch::detail {

// Whether a robot.yaml text is an overlay (it has `base:`).
bool is_robot_overlay(const YamlReader& yaml);

// The robot `overlay` (read from `overlay_path`) describes. `depth` counts the overlays above this one, so
// that a cycle of overlays is an error rather than a stack overflow. Throws InputError naming the overlay's
// line: a base that does not load, a path the base lacks, a value that makes the base invalid.
RobotDescription load_robot_overlay(const YamlReader& overlay, const std::filesystem::path& overlay_path, int depth);

// load_robot for a base of an overlay, `depth` overlays deep.
RobotDescription load_robot_at_depth(const std::string& name_or_path, int depth);

}  // namespace cpgmatch::detail
