// CLI11 validators for the job options' text syntax (jobs/option_text.h), so that malformed
// arguments of `shrm` and `shrm-view` are usage errors (exit code 2, docs/cli.md) rejected before
// any work starts. Header-only: the command-line front ends link CLI11, the job layer does not.
#ifndef SHRM_JOBS_CLI_VALIDATORS_H_
#define SHRM_JOBS_CLI_VALIDATORS_H_

#include <CLI/CLI.hpp>
#include <string>

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

}  // namespace shrm::jobs

#endif  // SHRM_JOBS_CLI_VALIDATORS_H_
