// CLI11 validators for shrm's option syntax, so that malformed arguments are usage errors
// (exit code 2, docs/cli.md) rejected before any work starts.
#ifndef SHRM_CLIENT_CLI_VALIDATORS_H_
#define SHRM_CLIENT_CLI_VALIDATORS_H_

#include <CLI/CLI.hpp>
#include <cmath>
#include <string>
#include <vector>

#include "absl/strings/numbers.h"
#include "absl/strings/str_split.h"

namespace shrm::cli {

// "x,y,z": three finite numbers, not all zero.
inline const CLI::Validator kDirection(
    [](std::string& s) -> std::string {
      std::vector<std::string> parts = absl::StrSplit(s, ',');
      double v[3];
      if (parts.size() != 3 || !absl::SimpleAtod(parts[0], &v[0]) ||
          !absl::SimpleAtod(parts[1], &v[1]) || !absl::SimpleAtod(parts[2], &v[2]))
        return "must be three numbers x,y,z, got '" + s + "'";
      const double n = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
      if (!std::isfinite(n) || n < 1e-12) return "must be a nonzero finite vector";
      return "";
    },
    "x,y,z");

// "F,P": two integers >= 0.
inline const CLI::Validator kOrders(
    [](std::string& s) -> std::string {
      std::vector<std::string> parts = absl::StrSplit(s, ',');
      int f, p;
      if (parts.size() != 2 || !absl::SimpleAtoi(parts[0], &f) || !absl::SimpleAtoi(parts[1], &p) ||
          f < 0 || p < 0)
        return "must be F,P with integers F, P >= 0, got '" + s + "'";
      return "";
    },
    "F,P");

// A number in the open interval (0, 1).
inline const CLI::Validator kOpenUnitInterval(
    [](std::string& s) -> std::string {
      double e;
      if (!absl::SimpleAtod(s, &e) || !(e > 0 && e < 1))
        return "must be in (0, 1), got '" + s + "'";
      return "";
    },
    "(0,1)");

}  // namespace shrm::cli

#endif  // SHRM_CLIENT_CLI_VALIDATORS_H_
