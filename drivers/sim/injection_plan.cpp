#include "drivers/sim/injection_plan.hpp"

#include <cmath>
#include <cstdlib>
#include <stdexcept>

namespace clm::sim {

std::vector<PlanItem> parse_plan_items(const std::string& plan) {
  std::vector<PlanItem> items;
  std::size_t begin = 0;
  while (begin <= plan.size()) {
    const std::size_t end = std::min(plan.find(',', begin), plan.size());
    PlanItem item;
    item.text = plan.substr(begin, end - begin);
    const auto bad = [&](const std::string& why) {
      return std::invalid_argument("injection plan: step '" + item.text + "': " + why);
    };
    std::vector<std::string> fields;
    for (std::size_t at = 0;;) {
      const std::size_t colon = item.text.find(':', at);
      fields.push_back(item.text.substr(at, colon == std::string::npos ? std::string::npos : colon - at));
      if (colon == std::string::npos) break;
      at = colon + 1;
    }
    if (fields[0].empty()) throw bad("no name");
    if (fields.size() > 3) throw bad("at most name:count:value");
    item.name = fields[0];
    if (fields.size() >= 2) {
      const std::string& count = fields[1];
      char* rest = nullptr;
      const long n = count.empty() ? 0 : std::strtol(count.c_str(), &rest, 10);
      if (count.empty() || *rest != '\0' || n < 1 || n > 1000) throw bad("the count must be 1 … 1000");
      item.count = static_cast<int>(n);
    }
    if (fields.size() == 3) {
      const std::string& value = fields[2];
      char* rest = nullptr;
      const double v = value.empty() ? NAN : std::strtod(value.c_str(), &rest);
      if (value.empty() || *rest != '\0' || !std::isfinite(v)) throw bad("the value must be a finite number");
      item.value = v;
      item.has_value = true;
    }
    items.push_back(item);
    begin = end + 1;
  }
  return items;
}

}  // namespace clm::sim
