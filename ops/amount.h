// Numbers and amounts as both front ends take them as text: a decimal
// number ("7.3", "-2", "1e-3"), and an amount in field units, "7.3"
// (absolute) or "1%" (of the field's range): `--error`, `--tolerance`.
// The one parser, so `simplexdb` and the Python package read the same text
// the same way.
//
// Thread safety: pure functions. Lifetimes: values.
// Errors: InvalidArgument naming the option as the command line spells it
// ("--error: expected a number >= 0 such as 7.3 or 1%, not 'lots'").
#pragma once

#include <string>
#include <string_view>

#include "query/criteria.h"  // Amount
#include "util/status.h"

namespace simplexdb {

// A finite decimal number: an optional sign, digits with an optional point,
// an optional exponent; nothing else around it (no space, no hexadecimal
// "0x10", no "inf" or "nan", no digit groups). InvalidArgument "<option>:
// '<text>' is not a decimal number" otherwise.
Result<double> ParseDecimal(std::string_view text, std::string_view option);

// "7.3" -> {7.3, false}; "1%" -> {1, true}. The number is ParseDecimal's,
// >= 0.
Result<Amount> ParseAmount(std::string_view text, std::string_view option);

// OK when `amount` is finite and >= 0 (an amount given as a number, not
// parsed from text); InvalidArgument naming `option` otherwise.
Status CheckAmount(const Amount& amount, std::string_view option);

// The amount in field units: a percentage of `range`, computed as value /
// 100 * range (the order the command always used: the same threshold to
// the last bit, so the same meshes).
double ResolveAmount(const Amount& amount, double range);

// How the amount reads back: "7.3" or "1%".
std::string AmountText(const Amount& amount);

}  // namespace simplexdb
