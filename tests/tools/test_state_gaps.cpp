// Live commissioning's drop detection: CLM_SERVO_STATE cycle counters that
// must follow one another.
#include <catch2/catch.hpp>

#include "tools/commission/live_runner.hpp"

using clm::commission::find_state_gaps;

TEST_CASE("Consecutive cycle counters have no gap", "[commission][live]") {
  const auto gaps = find_state_gaps({41, 42, 43, 44});
  CHECK(gaps.missing == 0);
  CHECK(gaps.out_of_order == 0);
  CHECK(gaps.ranges.empty());
  CHECK(find_state_gaps({}).missing == 0);
  CHECK(find_state_gaps({7}).missing == 0);
}

TEST_CASE("Every missing cycle is counted and the gaps are named", "[commission][live]") {
  const auto gaps = find_state_gaps({10, 11, 13, 14, 20, 21});
  CHECK(gaps.missing == 1 + 5);
  CHECK(gaps.out_of_order == 0);
  CHECK(gaps.ranges == "12, 15..19");
}

TEST_CASE("A repeated or earlier counter is out of order, not a gap", "[commission][live]") {
  const auto gaps = find_state_gaps({5, 6, 6, 4, 5});
  CHECK(gaps.out_of_order == 2);  // 6 after 6, 4 after 6
  CHECK(gaps.missing == 0);
}

TEST_CASE("Only the first gaps are listed, all are counted", "[commission][live]") {
  std::vector<std::int64_t> cycles;
  for (std::int64_t k = 0; k < 20; ++k) cycles.push_back(3 * k);  // two missing after each
  const auto gaps = find_state_gaps(cycles, 2);
  CHECK(gaps.missing == 2 * 19);
  CHECK(gaps.ranges == "1..2, 4..5, ... and 17 more gaps");
}
