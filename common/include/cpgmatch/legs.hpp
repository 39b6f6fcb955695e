// Legs as data: how many a robot has, their names and groups, and a container with one value per leg.
//
// Nothing here knows Morti: a robot description (robot_description.hpp) gives the layout, and
// LegLayout::quadruped() is only the default for callers that have none (Morti's FL FR HL HR, front and
// hind). The controller, the cost, energy, contact sensing and the plants work for any number of legs up
// to kMaxLegs.
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <initializer_list>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace cpgmatch {

// The most legs a robot may have: the per-leg values live in fixed arrays so that the real-time loop of the
// robot agent never allocates (8: an octopod; hexapods, quadrupeds and bipeds fit).
inline constexpr std::size_t kMaxLegs = 8;

// One value per leg, for a robot of 0..kMaxLegs legs: a fixed-capacity array with its own size. Indexing
// past size() throws std::out_of_range (a leg that does not exist is a programming error, and a silent read
// of another robot's leg would be worse).
template <typename T>
class PerLeg {
 public:
  PerLeg() = default;
  explicit PerLeg(std::size_t count, const T& value = T{}) : count_(checked(count)) {
    std::fill(items_.begin(), items_.begin() + count_, value);
  }
  PerLeg(std::initializer_list<T> values) : count_(checked(values.size())) {
    std::copy(values.begin(), values.end(), items_.begin());
  }

  std::size_t size() const { return count_; }
  bool empty() const { return count_ == 0; }
  T& operator[](std::size_t leg) { return items_[index(leg)]; }
  const T& operator[](std::size_t leg) const { return items_[index(leg)]; }
  T* begin() { return items_.data(); }
  T* end() { return items_.data() + count_; }
  const T* begin() const { return items_.data(); }
  const T* end() const { return items_.data() + count_; }
  void fill(const T& value) { std::fill(begin(), end(), value); }
  bool operator==(const PerLeg& other) const {
    return count_ == other.count_ && std::equal(begin(), end(), other.begin());
  }

 private:
  static std::size_t checked(std::size_t count) {
    if (count > kMaxLegs) throw std::out_of_range("a robot has at most 8 legs");
    return count;
  }
  std::size_t index(std::size_t leg) const {
    if (leg >= count_) throw std::out_of_range("leg " + std::to_string(leg) + " of a robot with " + std::to_string(count_) + " legs");
    return leg;
  }
  std::array<T, kMaxLegs> items_{};
  std::size_t count_ = 0;
};

// Which legs a robot has and how they are grouped. Legs of one group share the CPG's per-group parameters;
// a group of exactly two legs is a girdle (a shoulder or hip pair), which the feedback's reflex gate uses.
struct LegLayout {
  std::vector<std::string> names;        // FL, FR, HL, HR; L1, R1, ...
  std::vector<int> group_of;             // per leg: index into group_names
  std::vector<std::string> group_names;  // front, hind; front, middle, hind; all

  std::size_t size() const { return names.size(); }
  // The other leg of the leg's group, when the group is a pair (a girdle); nothing otherwise.
  std::optional<int> girdle_partner(int leg) const;
  // Whether the leg's group takes the hind legs' duty factor (a group named "hind"); every other group
  // takes the front legs' (CpgParameters has the paper's two duty factors).
  bool uses_hind_duty_factor(int leg) const;
  // Morti's: FL FR HL HR, groups front (FL, FR) and hind (HL, HR).
  static LegLayout quadruped();
};

}  // namespace cpgmatch
