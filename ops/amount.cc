#include "ops/amount.h"

#include <cmath>
#include <cstdlib>

#include <fmt/format.h>

namespace simplexdb {

Result<Amount> ParseAmount(std::string_view text, std::string_view option) {
  const bool percent = !text.empty() && text.back() == '%';
  const std::string number(percent ? text.substr(0, text.size() - 1) : text);
  char* end = nullptr;
  const double v = std::strtod(number.c_str(), &end);
  if (number.empty() || end != number.c_str() + number.size() || !std::isfinite(v) || v < 0) {
    return Status::InvalidArgument(
        fmt::format("{}: expected a number >= 0 such as 7.3 or 1%, not '{}'", option, text));
  }
  return Amount{v, percent};
}

Status CheckAmount(const Amount& amount, std::string_view option) {
  if (std::isfinite(amount.value) && amount.value >= 0) return Status::OK();
  return Status::InvalidArgument(fmt::format("{}: expected a number >= 0 such as 7.3 or 1%, not {}",
                                             option, AmountText(amount)));
}

double ResolveAmount(const Amount& amount, double range) {
  return amount.percent ? amount.value / 100 * range : amount.value;
}

std::string AmountText(const Amount& amount) {
  return fmt::format("{}{}", amount.value, amount.percent ? "%" : "");
}

}  // namespace simplexdb
