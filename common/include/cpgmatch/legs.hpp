// Leg indexing shared by the controller, the plants and the cost.
#pragma once

#include <array>
#include <string_view>

namespace cpgmatch {

inline constexpr int kNumLegs = 4;
enum Leg : int { kFrontLeft = 0, kFrontRight = 1, kHindLeft = 2, kHindRight = 3 };

inline constexpr std::array<std::string_view, kNumLegs> kLegNames{"FL", "FR", "HL", "HR"};

inline constexpr bool is_front(int leg) { return leg == kFrontLeft || leg == kFrontRight; }

// The other leg of the same girdle (shoulder or hip pair): FL <-> FR, HL <-> HR.
inline constexpr int girdle_partner(int leg) { return is_front(leg) ? 1 - leg : 5 - leg; }

template <typename T>
using PerLeg = std::array<T, kNumLegs>;

}  // namespace cpgmatch
