// Morti's leg layout for tests written against it: FL FR HL HR, front and hind girdles. The product has no
// such constants (a robot's legs are data, legs.hpp); tests of Morti's own behaviour name its legs here.
#pragma once

#include <array>
#include <string_view>

#include "cpgmatch/legs.hpp"

namespace cpgmatch::test {

inline constexpr int kNumLegs = 4;  // an int: the tests loop over legs with int indices
enum Leg : int { kFrontLeft = 0, kFrontRight = 1, kHindLeft = 2, kHindRight = 3 };
inline constexpr std::array<std::string_view, kNumLegs> kLegNames{"FL", "FR", "HL", "HR"};
inline constexpr bool is_front(int leg) { return leg == kFrontLeft || leg == kFrontRight; }
inline constexpr int girdle_partner(int leg) { return is_front(leg) ? 1 - leg : 5 - leg; }
inline const LegLayout& morti_legs() {
  static const LegLayout layout = LegLayout::quadruped();
  return layout;
}

}  // namespace cpgmatch::test
