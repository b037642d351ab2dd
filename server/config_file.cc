#include "server/config_file.h"

#include <fstream>
#include <iterator>
#include <set>

#include "absl/status/status.h"
#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"

namespace shrm::server {
namespace {

std::string_view Trim(std::string_view s) {
  const auto space = [](char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\f'; };
  while (!s.empty() && space(s.front())) s.remove_prefix(1);
  while (!s.empty() && space(s.back())) s.remove_suffix(1);
  return s;
}

}  // namespace

absl::StatusOr<std::vector<ConfigEntry>> ParseConfigText(std::string_view text) {
  std::vector<ConfigEntry> out;
  std::set<std::string> seen;
  int line_no = 0;
  while (!text.empty()) {
    const size_t nl = text.find('\n');
    const std::string_view raw = text.substr(0, nl);
    text = nl == std::string_view::npos ? std::string_view() : text.substr(nl + 1);
    ++line_no;
    const std::string_view line = Trim(raw);
    if (line.empty() || line.front() == '#') continue;
    // Values become command-line arguments (C strings): a NUL would cut one short silently.
    if (line.find('\0') != std::string_view::npos) {
      return absl::InvalidArgumentError(
          absl::StrCat("config line ", line_no, ": contains a NUL byte (the file must be text)"));
    }
    const size_t eq = line.find('=');
    if (eq == std::string_view::npos) {
      return absl::InvalidArgumentError(
          absl::StrCat("config line ", line_no, ": expected 'key = value'"));
    }
    std::string key(Trim(line.substr(0, eq)));
    std::string value(Trim(line.substr(eq + 1)));
    if (key.empty() || key.front() == '-') {
      return absl::InvalidArgumentError(
          absl::StrCat("config line ", line_no, ": the key must be a long flag name without '--'"));
    }
    if (!value.empty() && value.front() == '"') {
      if (value.size() < 2 || value.back() != '"') {
        return absl::InvalidArgumentError(
            absl::StrCat("config line ", line_no, ": unterminated quote"));
      }
      value = value.substr(1, value.size() - 2);
    }
    if (!seen.insert(key).second) {
      return absl::InvalidArgumentError(
          absl::StrCat("config line ", line_no, ": key '", key, "' given twice"));
    }
    out.push_back({std::move(key), std::move(value), line_no});
  }
  return out;
}

absl::StatusOr<std::vector<ConfigEntry>> ReadConfigFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return absl::NotFoundError("cannot read the config file");
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  return ParseConfigText(text);
}

absl::StatusOr<std::vector<std::string>> ConfigToArgs(
    const std::vector<ConfigEntry>& entries, const std::set<std::string>& bool_flags,
    const std::function<bool(const std::string&)>& known,
    const std::function<bool(const std::string&)>& given) {
  std::vector<std::string> args;
  for (const ConfigEntry& e : entries) {
    // Actions, not settings: "--help" or "--version" from the file would make the daemon print
    // and exit at startup instead of serving, "--config" would read another file.
    if (e.key == "help" || e.key == "version" || e.key == "config") {
      return absl::InvalidArgumentError(
          absl::StrCat("config line ", e.line, ": '", e.key, "' is not a setting"));
    }
    if (!known(e.key)) {
      return absl::InvalidArgumentError(
          absl::StrCat("config line ", e.line, ": unknown key '", e.key, "'"));
    }
    if (given(e.key)) continue;
    if (bool_flags.count(e.key) > 0) {
      const std::string v = absl::AsciiStrToLower(e.value);
      if (v == "true") {
        args.push_back(absl::StrCat("--", e.key));
      } else if (v != "false") {
        return absl::InvalidArgumentError(
            absl::StrCat("config line ", e.line, ": '", e.key, "' takes true or false"));
      }
      continue;
    }
    args.push_back(absl::StrCat("--", e.key));
    args.push_back(e.value);
  }
  return args;
}

}  // namespace shrm::server
