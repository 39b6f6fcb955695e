#include "cpgmatch/legs.hpp"

namespace cpgmatch {

std::optional<int> LegLayout::girdle_partner(int leg) const {
  std::optional<int> partner;
  int members = 0;
  for (std::size_t other = 0; other < group_of.size(); ++other) {
    if (group_of[other] != group_of.at(leg)) continue;
    ++members;
    if (static_cast<int>(other) != leg) partner = static_cast<int>(other);
  }
  return members == 2 ? partner : std::nullopt;
}

bool LegLayout::uses_hind_duty_factor(int leg) const { return group_names.at(group_of.at(leg)) == "hind"; }

LegLayout LegLayout::quadruped() { return {{"FL", "FR", "HL", "HR"}, {0, 0, 1, 1}, {"front", "hind"}}; }

}  // namespace cpgmatch
