#include "ops/amount.h"

#include <charconv>
#include <cmath>
#include <optional>
#include <system_error>

#include <fmt/format.h>

namespace simplexdb {

namespace {

// The number, or nullopt: from_chars reads decimal only (no hexadecimal, no
// leading space or '+'), and "inf" and "nan", which are refused after.
std::optional<double> Decimal(std::string_view text) {
  if (!text.empty() && text.front() == '+') text.remove_prefix(1);
  if (text.empty()) return std::nullopt;
  double v = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (error != std::errc() || end != text.data() + text.size() || !std::isfinite(v)) return std::nullopt;
  return v;
}

}  // namespace

Result<double> ParseDecimal(std::string_view text, std::string_view option) {
  if (const std::optional<double> v = Decimal(text)) return *v;
  return Status::InvalidArgument(fmt::format("{}: '{}' is not a decimal number", option, text));
}

Result<Amount> ParseAmount(std::string_view text, std::string_view option) {
  const bool percent = !text.empty() && text.back() == '%';
  const std::optional<double> v = Decimal(percent ? text.substr(0, text.size() - 1) : text);
  if (!v || *v < 0) {
    return Status::InvalidArgument(
        fmt::format("{}: expected a number >= 0 such as 7.3 or 1%, not '{}'", option, text));
  }
  return Amount{*v, percent};
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
