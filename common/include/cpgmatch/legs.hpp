// Leg indexing shared by the controller, the plants and the cost.
#pragma once

#include <array>
#include <string_view>

namespace cpgmatch {

inline constexpr int kNumLegs = 4;
enum Leg : int { kFrontLeft = 0, kFrontRight = 1, kHindLeft = 2, kHindRight = 3 };

inline constexpr std::array<std::string_view, kNumLegs> kLegNames{"FL", "FR", "HL", "HR"};

inline constexpr bool is_front(int leg) { return leg == kFrontLeft || leg == kFrontRight; }

template <typename T>
using PerLeg = std::array<T, kNumLegs>;

}  // namespace cpgmatch
