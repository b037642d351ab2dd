// CLI11 validators for the job options' text syntax (jobs/option_text.h), so that malformed
// arguments of `shrm` and `shrm-view` are usage errors (exit code 2, docs/cli.md) rejected before
// any work starts. Header-only: the command-line front ends link CLI11, the job layer does not.
#ifndef SHRM_JOBS_CLI_VALIDATORS_H_
#define SHRM_JOBS_CLI_VALIDATORS_H_

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <string>
#include <vector>

#include "jobs/option_text.h"

namespace shrm::jobs {

// A CLI11 validator from a parser: "" when `parse` accepts the text, else its message without
// the option name (CLI11 prefixes the option).
template <typename Parse>
CLI::Validator TextValidator(Parse parse, const char* syntax) {
  return CLI::Validator(
      [parse](std::string& s) -> std::string {
        auto r = parse(s, "");
        if (r.ok()) return "";
        std::string msg(r.status().message());
        return msg.size() > 1 && msg[0] == ' ' ? msg.substr(1) : msg;
      },
      syntax);
}

// "x,y,z": three finite numbers, not all zero.
inline const CLI::Validator kDirection = TextValidator(ParseDirectionText, "x,y,z");
// "F,P": two integers >= 0.
inline const CLI::Validator kOrders = TextValidator(ParseOrdersText, "F,P");
// A number in the open interval (0, 1).
inline const CLI::Validator kOpenUnitInterval = TextValidator(ParseToleranceText, "(0,1)");

// Numbers within bounds, with a message that names the bound and the value: "must be >= 0, got
// '-2'". (CLI11's NonNegativeNumber printed its upper bound, the largest double, in full: "Value
// -2 not in range 0.000000 to 17976931348623157...", 309 digits.) Text that is not a number is
// left to the option's own conversion, which names it; infinities and NaN are out of every range.
namespace internal {

inline std::string BoundText(double v) {
  char buf[64];
  if (std::abs(v) < 1e15 && v == std::floor(v)) {
    std::snprintf(buf, sizeof buf, "%.0f", v);
  } else {
    std::snprintf(buf, sizeof buf, "%g", v);
  }
  return buf;
}

// lo (open when lo_open) to hi (none when infinite).
inline CLI::Validator NumberValidator(double lo, bool lo_open, double hi, std::string syntax) {
  const std::string rule = std::isinf(hi)
                               ? std::string(lo_open ? "must be > " : "must be >= ") + BoundText(lo)
                               : "must be in [" + BoundText(lo) + ", " + BoundText(hi) + "]";
  return CLI::Validator(
      [lo, lo_open, hi, rule](std::string& s) -> std::string {
        char* end = nullptr;
        errno = 0;
        const double v = std::strtod(s.c_str(), &end);
        if (s.empty() || end != s.c_str() + s.size()) return "";  // not a number: the conversion's
        const bool above = lo_open ? v > lo : v >= lo;
        if (std::isfinite(v) && errno != ERANGE && above && v <= hi) return "";
        return rule + ", got '" + s + "'";
      },
      std::move(syntax));
}

}  // namespace internal

// A finite number >= 0.
inline const CLI::Validator kNonNegative =
    internal::NumberValidator(0, false, std::numeric_limits<double>::infinity(), "NONNEGATIVE");
// A finite number > 0.
inline const CLI::Validator kPositive =
    internal::NumberValidator(0, true, std::numeric_limits<double>::infinity(), "POSITIVE");
// A number in [lo, hi].
inline CLI::Validator InRange(double lo, double hi) {
  return internal::NumberValidator(
      lo, false, hi, "in [" + internal::BoundText(lo) + ", " + internal::BoundText(hi) + "]");
}

namespace internal {

// Levenshtein distance of two short strings (option names).
inline size_t EditDistance(const std::string& a, const std::string& b) {
  std::vector<size_t> row(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    size_t diagonal = row[0];
    row[0] = i;
    for (size_t j = 1; j <= b.size(); ++j) {
      const size_t above = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] != b[j - 1] ? 1 : 0)});
      diagonal = above;
    }
  }
  return row[b.size()];
}

}  // namespace internal

// Every option of `app` that takes values (flags aside, positionals included) refuses an empty
// one: "--report: an empty value (give one, or leave the option out)". Without it `--report
// "$UNSET"` meant no report, `-o ""` failed after the whole job, and `--env ""` said ": file not
// found". Call after the options are defined.
inline void RefuseEmptyValues(CLI::App* app) {
  static const CLI::Validator kNotEmpty(
      [](std::string& s) -> std::string {
        return s.empty() ? "an empty value (give one, or leave the option out)" : "";
      },
      "");
  for (CLI::Option* o : app->get_options()) {
    if (o->get_type_size_max() > 0) o->check(kNotEmpty);
  }
}

// What a user meant by the unknown long options among `args` (CLI11's ExtrasError says only "The
// following arguments were not expected: 45 --latitude", in reverse order): "unknown option
// --latitude (did you mean --lat?)", one per unknown option, the suggestion the option of `app`
// nearest by edit distance (at most a third of the name's letters, or the one option the name
// starts or is the start of); "" when no argument is an unknown --option (positional extras keep
// CLI11's message).
inline std::string UnknownOptionMessage(const CLI::App& app, const std::vector<std::string>& args) {
  std::vector<std::string> known;
  for (const CLI::Option* o : app.get_options()) {
    for (const std::string& n : o->get_lnames()) known.push_back(n);
  }
  std::string out;
  for (const std::string& arg : args) {
    if (arg.size() < 3 || arg.compare(0, 2, "--") != 0) continue;
    const size_t equals = arg.find('=');  // --name=value
    const std::string name = arg.substr(2, equals == std::string::npos ? equals : equals - 2);
    if (std::find(known.begin(), known.end(), name) != known.end()) continue;
    std::string best;
    size_t best_distance = std::max<size_t>(1, name.size() / 3) + 1;
    std::vector<std::string> prefixed;
    for (const std::string& k : known) {
      const size_t d = internal::EditDistance(name, k);
      if (d < best_distance) {
        best_distance = d;
        best = k;
      }
      if (name.size() >= 3 && (k.rfind(name, 0) == 0 || name.rfind(k, 0) == 0)) {
        prefixed.push_back(k);
      }
    }
    if (best.empty() && prefixed.size() == 1) best = prefixed[0];
    if (!out.empty()) out += "\n";
    out += "unknown option --" + name + (best.empty() ? "" : " (did you mean --" + best + "?)");
  }
  return out;
}

}  // namespace shrm::jobs

#endif  // SHRM_JOBS_CLI_VALIDATORS_H_
